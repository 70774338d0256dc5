//! `xpflow validate extrudate-swell`: the Newtonian extrudate swell per element size, its
//! extrapolation and the verdict against Table 6.3 (thesis §6.4).

use std::path::Path;
use std::process::ExitCode;

use super::validate::verdict;
use crate::validate::extrudate::{
    extrapolate, published_swell, swell, swell_dt, SwellMesh, SwellRun, NEWTONIAN_SWELL, SWELL_TOL,
    VISCOELASTIC_SWELL_TOL,
};

/// Runs the study at each Deborah number of `des` on the element sizes `hs` (coarse to fine,
/// each half the last for the extrapolation) with the time step `dt` (default: the study's,
/// [`swell_dt`]), prints `swell = …` per mesh and writes each profile and its history to `out`; the
/// verdict holds when every De passes.
pub(super) fn validate_extrudate_swell(
    hs: &[f64],
    des: &[f64],
    graded: bool,
    dt: Option<f64>,
    t_max: f64,
    out: &Path,
) -> anyhow::Result<ExitCode> {
    let mut pass = true;
    for &de in des {
        let dt = dt.unwrap_or_else(|| swell_dt(de));
        pass &= if de == 0.0 {
            newtonian(hs, graded, dt, t_max, out)?
        } else {
            viscoelastic(hs, graded, de, dt, t_max, out)?
        };
    }
    Ok(verdict(pass))
}

/// The table's header (die error: the conformation in the die against the fully developed one).
fn print_header() {
    println!("| h | elements | steps | steady | max ΔH last step | die error | swell | time |");
    println!("|---|---|---|---|---|---|---|---|");
}

/// Runs one mesh, prints its row and writes its profile.
fn run_mesh(grid: SwellMesh, de: f64, dt: f64, t_max: f64, out: &Path) -> anyhow::Result<SwellRun> {
    let r = swell(grid, de, dt, t_max)?;
    let h = grid.h;
    println!(
        "| {h} | {} | {} | {} | {:.1e} | {:.1e} | {:.5} | {:.1} s |",
        r.elements, r.steps, r.steady, r.last_change, r.die_error, r.swell, r.seconds
    );
    let mut csv = String::from("x,H\n");
    for (x, y) in &r.profile {
        csv += &format!("{x},{y}\n");
    }
    std::fs::create_dir_all(out)?;
    let name = if grid.graded { "graded_" } else { "" };
    std::fs::write(
        out.join(format!("extrudate_swell_de{de}_{name}h{h}.csv")),
        csv,
    )?;
    // how it got there: a surface that is not steady at t_max creeps or oscillates, and where
    let mut csv = String::from("t,swell,max_dH,dH,x_of_max_dH\n");
    for s in &r.history {
        csv += &format!(
            "{},{},{:e},{:e},{}\n",
            s.t, s.swell, s.change, s.signed_change, s.x_change
        );
    }
    std::fs::write(
        out.join(format!("extrudate_swell_de{de}_{name}h{h}_history.csv")),
        csv,
    )?;
    Ok(r)
}

/// De > 0: each mesh's swell against the thesis' M4 value (Table 6.3).
fn viscoelastic(
    hs: &[f64],
    graded: bool,
    de: f64,
    dt: f64,
    t_max: f64,
    out: &Path,
) -> anyhow::Result<bool> {
    let published = published_swell(de);
    println!(
        "Extrudate swell, UCM (thesis §6.4), De = {de}: die 2 × H0 = 1, extrudate 3, Q = 1, \
         Δt = {dt}; published (M4) {}",
        published.map_or("none".into(), |p| format!("{p}"))
    );
    print_header();
    let mut runs = Vec::new();
    for &h in hs {
        runs.push(run_mesh(SwellMesh { h, graded }, de, dt, t_max, out)?);
    }
    for r in &runs {
        println!("De = {de}, h = {}: swell = {:.5}", r.h, r.swell);
    }
    let steady = runs.iter().all(|r| r.steady);
    let Some(last) = runs.last() else {
        return Ok(false);
    };
    Ok(match published {
        Some(p) => {
            let rel = last.swell / p - 1.0;
            println!(
                "De = {de}: finest mesh {:.5} against {p}: {rel:+.2e} (tolerance \
                 {VISCOELASTIC_SWELL_TOL:.0e} up to De = 0.75){}",
                last.swell,
                if steady {
                    ""
                } else {
                    " (a run did not reach the steady test)"
                }
            );
            steady && (de > 0.75 || rel.abs() <= VISCOELASTIC_SWELL_TOL)
        }
        None => steady,
    })
}

/// De = 0: the swells extrapolated to h → 0 against the published 1.188.
fn newtonian(hs: &[f64], graded: bool, dt: f64, t_max: f64, out: &Path) -> anyhow::Result<bool> {
    println!(
        "Extrudate swell, Newtonian (thesis §6.4, De = 0): die 2 × H0 = 1, extrudate 3, Q = 1, \
         Δt = {dt}; published H_max/H0 = {NEWTONIAN_SWELL}"
    );
    print_header();
    let mut runs = Vec::new();
    for &h in hs {
        runs.push(run_mesh(SwellMesh { h, graded }, 0.0, dt, t_max, out)?);
    }
    for r in &runs {
        println!("h = {}: swell = {:.5}", r.h, r.swell);
    }
    let steady = runs.iter().all(|r| r.steady);
    let n = runs.len();
    let best = if n >= 3 {
        let (a, b, c) = (runs[n - 3].swell, runs[n - 2].swell, runs[n - 1].swell);
        let order = ((a - b) / (b - c)).log2();
        let e = extrapolate(b, c, order);
        println!("observed order {order:.2}; extrapolated swell = {e:.5}");
        e
    } else if n == 2 {
        let e = extrapolate(runs[0].swell, runs[1].swell, 1.0);
        println!("extrapolated swell (first order) = {e:.5}");
        e
    } else {
        runs.last().map_or(f64::NAN, |r| r.swell)
    };
    println!(
        "reference {NEWTONIAN_SWELL}, tolerance {SWELL_TOL}: difference {:+.1e}{}",
        best - NEWTONIAN_SWELL,
        if steady {
            ""
        } else {
            " (a run did not reach the steady test)"
        }
    );
    Ok(steady && (best - NEWTONIAN_SWELL).abs() <= SWELL_TOL)
}
