//! `xpflow sweep FILE --dry-run --estimate`: what a sweep will cost before it runs — per case its
//! elements, steps and step cost and the core-hours they take at a measured rate, the total, and
//! what is left of it when the sweep's database already has finished cases.
//!
//! Beside the bound, an expectation (`core-h ~`) from the database's finished cases
//! ([`Expectation`]): their core seconds in all (CPU time where a case recorded it, else wall
//! time) over the work of their step bounds; for a case
//! without early stop, its steps at its largest Δt at their cost per step taken.
//!
//! The rate is the one the cluster path asks SLURM for ([`Rate`]): the slowest finished case of
//! the sweep's database (seconds per element and step, every rejected step and resumption
//! included) when there is one, else the benchmark of docs/performance.md. The steps are an upper
//! bound: a fixed step's t_end/Δt and an adaptive step's t_end over its *initial* Δt, with no early
//! stop (an adaptive case took 3.9–4.2× fewer steps on the reference set, docs/validation.md),
//! and for an extrusion its undisturbed prelude to t = 40, counted for the first case of each
//! undisturbed flow only (the others take it: `simulate::undisturbed::prelude_key`).

use std::collections::BTreeMap;
use std::io::Write;
use std::path::Path;

use crate::config::{CaseSpec, PlannedCase};
use crate::simulate::undisturbed::{prelude_key, UNDISTURBED_T_MAX};
use crate::store::{Format, Store, Table};
use crate::sweep::slurm::estimate::{
    finished_cases, prelude_steps, steps_seconds, Expectation, Rate,
};

/// What the database already knows: each case's status and the finished cases' timings.
struct Known {
    status: BTreeMap<String, String>,
    finished: Vec<(CaseSpec, f64, u64)>,
}

/// Reads statuses and timings from `db` if it exists (read-only: a reader never writes).
fn known(db: &Path) -> anyhow::Result<Known> {
    let mut k = Known {
        status: BTreeMap::new(),
        finished: Vec::new(),
    };
    if !db.exists() {
        return Ok(k);
    }
    let store = Store::open_read_only(db)?;
    k.status = store.statuses()?.into_iter().collect();
    k.finished = finished_cases(&store)?;
    Ok(k)
}

/// Prints the estimate of `cases` (the sweep's database `db`, which may not exist yet).
///
/// # Errors
/// A database that exists but cannot be read, or a failed write to `out`.
pub(super) fn print_estimate(
    cases: &[PlannedCase],
    db: &Path,
    out: &mut dyn Write,
) -> anyhow::Result<()> {
    let known = known(db)?;
    let rate = Rate::from_finished(&known.finished);
    let expect = Expectation::from_finished(&known.finished);
    let mut t = Table {
        columns: [
            "index",
            "id",
            "label",
            "elements",
            "steps ≤",
            "step cost",
            "core-h ≤",
            "core-h ~",
            "status",
        ]
        .map(String::from)
        .to_vec(),
        rows: Vec::new(),
    };
    let (mut total, mut left) = (0.0, 0.0);
    let (mut expected, mut expected_left) = (0.0, 0.0);
    // an extrusion's undisturbed prelude is stepped once per undisturbed flow (the others take it)
    let mut preludes = std::collections::BTreeSet::new();
    for c in cases {
        let prelude = match c.spec.extrusion() {
            Some(_) if preludes.insert(prelude_key(&c.spec)) => prelude_steps(&c.spec),
            _ => 0.0,
        };
        let steps = c.spec.steps() + prelude;
        let hours = steps_seconds(&c.spec, steps, &rate) / 3600.0;
        let status = known
            .status
            .get(&c.id)
            .cloned()
            .unwrap_or_else(|| "not run".into());
        let likely = expect.map(|e| e.seconds_of(&c.spec, steps) / 3600.0);
        total += hours;
        expected += likely.unwrap_or(0.0);
        if status != "done" {
            left += hours;
            expected_left += likely.unwrap_or(0.0);
        }
        t.rows.push(vec![
            c.index.into(),
            c.id.clone().into(),
            c.label.clone().into(),
            (c.spec.mesh_elements() as i64).into(),
            (steps as i64).into(),
            c.spec.step_cost().into(),
            format!("{hours:.2}").into(),
            likely.map_or("–".into(), |h| format!("{h:.2}")).into(),
            status.into(),
        ]);
    }
    write!(out, "{}", t.render(Format::Table))?;
    writeln!(out, "rate: {}", rate.source())?;
    writeln!(
        out,
        "estimate: at most {total:.1} core-hours for {} cases, {left:.1} of them not done yet \
         (steps without early stop, adaptive steps at their initial Δt; an extrusion's \
         undisturbed prelude to t = {UNDISTURBED_T_MAX} once per undisturbed flow)",
        cases.len()
    )?;
    match expect {
        Some(e) => writeln!(
            out,
            "expected: about {expected:.1} core-hours, {expected_left:.1} of them not done yet \
             ({})",
            e.source()
        )?,
        None => writeln!(
            out,
            "expected: no finished case in the database to take the expectation from"
        )?,
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sweep::slurm::estimate::BENCHMARK_SECONDS_PER_ELEMENT_STEP;

    fn planned(index: usize, mesh: [usize; 2], dt: serde_json::Value) -> PlannedCase {
        planned_case(
            index,
            serde_json::json!({
                "geometry": {"confined_shear": {"h": 1.0, "l": 4.0}},
                "fluid": {"model": "giesekus", "wi": 1.0, "alpha": 0.01, "beta": 0.1},
                "particles": {"radius": 0.1, "layout": {"string": {"n": 2, "lx": 0.5, "ly": 0.1}}},
                "numerics": {"mesh": mesh, "dt": dt, "t_end": 20.0}
            }),
        )
    }

    fn planned_case(index: usize, case: serde_json::Value) -> PlannedCase {
        let spec = CaseSpec::from_value(case).unwrap();
        PlannedCase {
            index,
            id: format!("case{index}"),
            label: format!("c{index}"),
            spec,
            params: Vec::new(),
        }
    }

    /// Without a database: the benchmark rate, steps × elements (an adaptive case at its initial
    /// Δt), summed; nothing is created where the database would be.
    #[test]
    fn the_estimate_sums_steps_times_elements_at_the_benchmark_rate() {
        let cases = [
            planned(0, [200, 50], serde_json::json!(0.02)),
            planned(
                1,
                [100, 25],
                serde_json::json!({"initial": 0.04, "min": 0.004, "max": 0.08, "tol": 1e-3}),
            ),
        ];
        let db = std::env::temp_dir().join(format!("xpflow-estimate-{}.db", std::process::id()));
        let mut out = Vec::new();
        print_estimate(&cases, &db, &mut out).unwrap();
        let text = String::from_utf8(out).unwrap();
        let expect = (1000.0 * 1e4 + 500.0 * 2500.0) * BENCHMARK_SECONDS_PER_ELEMENT_STEP / 3600.0;
        assert!(
            text.contains(&format!(
                "at most {expect:.1} core-hours for 2 cases, {expect:.1}"
            )),
            "{text}"
        );
        assert!(text.contains("not run"), "{text}");
        assert!(text.contains("expected: no finished case"), "{text}");
        assert!(!db.exists(), "an estimate never creates the database");
    }

    /// An extrusion case counts its undisturbed prelude (to t = 40 at its Δt) once per
    /// undisturbed flow: a second case differing only in its particle adds its own steps, a case
    /// that skips the prelude none.
    #[test]
    fn an_extrusion_counts_its_prelude_once_per_undisturbed_flow() {
        let extrusion = |index: usize, radius: f64, undisturbed: bool| {
            planned_case(
                index,
                serde_json::json!({
                    "geometry": {"extrusion": {"die_length": 3.0, "extrudate_length": 4.0}},
                    "fluid": {"model": "giesekus", "wi": 0.3, "alpha": 0.1},
                    "particles": {"radius": radius, "layout": {"explicit": {"positions": [[-2.3, 0.8]]}}},
                    "numerics": {"mesh": [70, 20], "dt": 0.05, "t_end": 5.0},
                    "output": {"undisturbed_surface": undisturbed}
                }),
            )
        };
        let cases = [
            extrusion(0, 0.1, true),
            extrusion(1, 0.15, true),
            extrusion(2, 0.1, false),
        ];
        let db = std::env::temp_dir().join(format!("xpflow-estimate-x-{}.db", std::process::id()));
        let mut out = Vec::new();
        print_estimate(&cases, &db, &mut out).unwrap();
        let text = String::from_utf8(out).unwrap();
        // 100 steps to t_end each, and 800 prelude steps (t = 40 at Δt 0.05) once
        let elements = 70.0 * 20.0 * cases[0].spec.step_cost();
        let expect = (3.0 * 100.0 + 800.0) * elements * BENCHMARK_SECONDS_PER_ELEMENT_STEP / 3600.0;
        assert!(
            text.contains(&format!("at most {expect:.1} core-hours for 3 cases")),
            "{text}"
        );
        let steps: Vec<&str> = text
            .lines()
            .filter(|l| {
                l.split_whitespace()
                    .nth(1)
                    .is_some_and(|id| id.starts_with("case"))
            })
            .map(|l| l.split_whitespace().nth(4).unwrap_or(""))
            .collect();
        assert_eq!(steps, ["900", "100", "100"], "{text}");
    }
}
