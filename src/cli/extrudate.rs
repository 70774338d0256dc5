//! `xpflow validate extrudate-swell`: the Newtonian extrudate swell per element size, its
//! extrapolation and the verdict against Table 6.3 (thesis §6.4).

use std::path::Path;
use std::process::ExitCode;

use super::validate::verdict;
use crate::validate::extrudate::{
    extrapolate, newtonian_swell, NEWTONIAN_SWELL, SWELL_DT, SWELL_TOL, SWELL_T_MAX,
};

/// Runs the study on the element sizes `hs` (coarse to fine, each half the last for the
/// extrapolation), prints `swell = …` per mesh and writes each steady profile to `out`.
pub(super) fn validate_extrudate_swell(hs: &[f64], out: &Path) -> anyhow::Result<ExitCode> {
    println!(
        "Extrudate swell, Newtonian (thesis §6.4, De = 0): die 2 × H0 = 1, extrudate 3, Q = 1, \
         Δt = {SWELL_DT}; published H_max/H0 = {NEWTONIAN_SWELL}"
    );
    println!("| h | elements (fluid) | steps | steady | max ΔH last step | swell | time |");
    println!("|---|---|---|---|---|---|---|");
    std::fs::create_dir_all(out)?;
    let mut runs = Vec::new();
    for &h in hs {
        let r = newtonian_swell(h, SWELL_DT, SWELL_T_MAX)?;
        println!(
            "| {h} | {} ({}) | {} | {} | {:.1e} | {:.5} | {:.1} s |",
            r.elements.0, r.elements.1, r.steps, r.steady, r.last_change, r.swell, r.seconds
        );
        let mut csv = String::from("x,H\n");
        for (x, y) in &r.profile {
            csv += &format!("{x},{y}\n");
        }
        std::fs::write(out.join(format!("extrudate_swell_h{h}.csv")), csv)?;
        runs.push(r);
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
    Ok(verdict(
        steady && (best - NEWTONIAN_SWELL).abs() <= SWELL_TOL,
    ))
}
