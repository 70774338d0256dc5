//! The solver-backed runner end to end through the sweep engine: a tiny real Stokes sweep writes
//! samples, a decided-or-timeout outcome and HDF5 snapshots; unsupported cases are refused.

use std::path::PathBuf;

use xpflow::config::SweepSpec;
use xpflow::store::Store;
use xpflow::sweep::solver_runner::SolverRunner;
use xpflow::sweep::{expand, run_sweep, CaseRunner, SweepOptions};

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("xpflow-test-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

#[test]
fn a_real_stokes_sweep_records_samples_outcomes_and_snapshots() {
    let dir = scratch("solver-sweep");
    let file = dir.join("s.toml");
    std::fs::write(
        &file,
        r#"
name = "tiny"
[base]
geometry.confined_shear = { h = 1.0, l = 4.0 }
fluid = { model = "newtonian", wi = 0.0 }
particles = { radius = 0.1, layout.pair = { lx = 0.5, ly = 0.08 } }
numerics = { mesh = [40, 10], dt = 0.1, t_end = 0.3, quadtree_level = 3 }
output = { sample_every = 1, snapshot_every = 2 }
[axes]
particles.layout.pair.ly = [0.06, 0.08]
"#,
    )
    .unwrap();
    let spec = SweepSpec::from_file(&file).unwrap();
    let cases = expand(&spec).unwrap();
    let db = dir.join("tiny.db");
    let mut opts = SweepOptions::new(db.clone());
    opts.progress = xpflow::sweep::progress::ProgressMode::Quiet;
    let summary = run_sweep(&spec, &cases, &SolverRunner, &opts).unwrap();
    println!("{summary:?}");
    let store = Store::open(&db).unwrap();
    let c = store.connection();
    let done: i64 = c
        .query_row(
            "SELECT count(*) FROM cases WHERE status = 'done'",
            [],
            |r| r.get(0),
        )
        .unwrap();
    assert_eq!(done, 2);
    // steps 0..=3, two particles, two cases
    let samples: i64 = c
        .query_row("SELECT count(*) FROM samples", [], |r| r.get(0))
        .unwrap();
    assert_eq!(samples, 2 * 2 * 4);
    // the top-left particle moves right with the upper wall (u ≈ γ̇ y > 0) and rotates clockwise
    let (u, omega): (f64, f64) = c
        .query_row(
            "SELECT u, omega FROM samples WHERE particle = 0 AND step = 1 LIMIT 1",
            [],
            |r| Ok((r.get(0)?, r.get(1)?)),
        )
        .unwrap();
    assert!(
        u > 0.0 && omega > 0.4 && omega < 0.5,
        "u = {u}, ω = {omega}"
    );
    let kinds: i64 = c
        .query_row(
            "SELECT count(*) FROM outcomes WHERE kind = 'timeout'",
            [],
            |r| r.get(0),
        )
        .unwrap();
    assert_eq!(kinds, 2, "0.3 time units decide nothing");
    let snaps: Vec<String> = c
        .prepare("SELECT file FROM snapshots")
        .unwrap()
        .query_map([], |r| r.get(0))
        .unwrap()
        .map(|r| r.unwrap())
        .collect();
    assert!(!snaps.is_empty(), "snapshots recorded");
    for f in snaps {
        assert!(
            std::path::Path::new(&f).exists() || dir.join(&f).exists(),
            "snapshot file {f}"
        );
    }
}

#[test]
fn viscoelastic_and_couette_cases_are_refused_with_a_reason() {
    let v = serde_json::json!({
        "geometry": { "confined_shear": { "h": 1.0, "l": 4.0 } },
        "fluid": { "model": "giesekus", "wi": 1.0, "alpha": 0.01, "beta": 0.1 },
        "particles": { "radius": 0.1, "layout": { "pair": { "lx": 0.5, "ly": 0.06 } } },
        "numerics": { "mesh": [40, 10], "dt": 0.1, "t_end": 1.0 }
    });
    let spec = xpflow::config::CaseSpec::from_value(v).unwrap();
    let err = SolverRunner.supports(&spec).unwrap_err();
    assert!(err.contains("not built yet"), "{err}");
}
