//! The solver-backed runner end to end through the sweep engine: a tiny real Stokes sweep writes
//! samples, a decided-or-timeout outcome and HDF5 snapshots; viscoelastic confined-shear and
//! Couette cases run through the moving-particle step; cases with nothing to simulate are refused.

mod common;
use common::{trajectory, Scratch};
use std::path::{Path, PathBuf};

use xpflow::config::SweepSpec;
use xpflow::store::Store;
use xpflow::sweep::solver_runner::SolverRunner;
use xpflow::sweep::{expand, run_sweep, SweepOptions};

fn scratch(name: &str) -> Scratch {
    Scratch::new("test", name)
}

/// A fresh scratch directory `name` with the sweep file `s.toml`; returns (directory, file).
fn sweep_file(name: &str, toml: &str) -> (Scratch, PathBuf) {
    let dir = scratch(name);
    let file = dir.join("s.toml");
    std::fs::write(&file, toml).unwrap();
    (dir, file)
}

#[test]
fn a_real_stokes_sweep_records_samples_outcomes_and_snapshots() {
    let (dir, file) = sweep_file(
        "solver-sweep",
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
    );
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
    // every result carries the settings it ran with (the default cut rule here)
    let settings: String = c
        .query_row("SELECT settings_json FROM cases LIMIT 1", [], |r| r.get(0))
        .unwrap();
    let settings: serde_json::Value = serde_json::from_str(&settings).unwrap();
    assert_eq!(settings["cut"]["interface"], "parabolic");
    assert_eq!(settings["flow"]["stress_coupling"], "none (Stokes flow)");
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
    // the narrowest gap in elements (h = 0.1): particles of radius 0.1 at y = ±0.06 are 0.34
    // from the walls, 3.4 rows (their own gap, 0.5 along x and 0.12 across, has 3.8 layers);
    // 0.3 time units move them by far less than a row
    let gap: f64 = c
        .query_row(
            "SELECT json_extract(final_json, '$.gap_elements_min') FROM outcomes o JOIN cases c \
             ON c.id = o.case_id WHERE c.label LIKE '%0.06%'",
            [],
            |r| r.get(0),
        )
        .unwrap();
    assert!((gap - 3.4).abs() < 0.05, "{gap}");
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

/// Runs a one-case sweep file and returns (status, number of samples, last sample (x, y, u, ω)).
fn run_one(name: &str, toml: &str) -> (String, i64, [f64; 4]) {
    let (dir, file) = sweep_file(name, toml);
    let spec = SweepSpec::from_file(&file).unwrap();
    let cases = expand(&spec).unwrap();
    let db = dir.join("one.db");
    let mut opts = SweepOptions::new(db.clone());
    opts.progress = xpflow::sweep::progress::ProgressMode::Quiet;
    run_sweep(&spec, &cases, &SolverRunner, &opts).unwrap();
    let store = Store::open(&db).unwrap();
    let c = store.connection();
    let status: String = c
        .query_row("SELECT status FROM cases", [], |r| r.get(0))
        .unwrap();
    let n: i64 = c
        .query_row("SELECT count(*) FROM samples", [], |r| r.get(0))
        .unwrap();
    let last = c
        .query_row(
            "SELECT x, y, u, omega FROM samples ORDER BY step DESC LIMIT 1",
            [],
            |r| Ok([r.get(0)?, r.get(1)?, r.get(2)?, r.get(3)?]),
        )
        .unwrap();
    (status, n, last)
}

#[test]
fn a_viscoelastic_confined_shear_case_runs() {
    // thesis §5.6.3 fluid on a coarse mesh, 5 steps
    let (status, n, last) = run_one(
        "visco-shear",
        r#"
name = "visco"
[base]
geometry.confined_shear = { h = 1.0, l = 4.0 }
fluid = { model = "giesekus", wi = 1.0, alpha = 0.01, beta = 0.1 }
particles = { radius = 0.1, layout.explicit = { positions = [[0.0, 0.2]] } }
numerics = { mesh = [40, 10], dt = 0.02, t_end = 0.1 }
output = { sample_every = 1 }
"#,
    );
    assert_eq!(status, "done");
    assert_eq!(n, 6, "steps 0..=5");
    // above the centreline the particle moves with the upper wall and rotates clockwise
    // (ω* ≈ 1/2 in the store's clockwise-positive convention)
    assert!(last[2] > 0.0 && last[3] > 0.3 && last[3] < 0.6, "{last:?}");
}

#[test]
fn a_couette_case_runs_and_the_particle_orbits_counter_clockwise() {
    let (status, n, last) = run_one(
        "couette",
        r#"
name = "couette"
[base]
geometry.couette = { r1 = 1.0, r2 = 4.0, omega_inner = 1.0 }
fluid = { model = "giesekus", wi = 0.3333333333333333, alpha = 0.01, beta = 0.1 }
particles = { eps = 0.26666666666666666, layout.couette = { r0_star = 0.5 } }
numerics = { mesh = [12, 64], dt = 0.05, t_end = 0.5 }
output = { sample_every = 1 }
"#,
    );
    assert_eq!(status, "done");
    assert_eq!(n, 11, "steps 0..=10");
    // started at (2.5, 0): the flow carries it counter-clockwise (y > 0), it stays near mid-gap
    let r_star = (last[0].hypot(last[1]) - 1.0) / 3.0;
    assert!(last[1] > 0.0 && (r_star - 0.5).abs() < 0.01, "{last:?}");
}

#[test]
fn a_case_without_particles_is_refused_with_a_reason() {
    let v = serde_json::json!({
        "geometry": { "couette": { "r1": 1.0, "r2": 4.0 } },
        "fluid": { "model": "giesekus", "wi": 1.0, "alpha": 0.01, "beta": 0.1 },
        "numerics": { "mesh": [12, 64], "dt": 0.1, "t_end": 1.0 }
    });
    // refused when the case is read, before anything runs, naming the field
    let err = xpflow::config::CaseSpec::from_value(v).unwrap_err();
    assert!(format!("{err:?}").contains("particles"), "{err:?}");
}

#[test]
fn a_point_symmetric_pair_stays_symmetric() {
    // Two particles at (∓l_x, ±l_y) on a mesh symmetric about the origin: the discrete problem
    // is point symmetric, so ω₁ = ω₂ up to solver round-off. Elements cut into slivers used to
    // break this (no ghost penalty in the flow: velocities of 1e5 at sliver nodes; ω₁ − ω₂ up
    // to 1.2e-4 within these 50 steps); with the flow's ghost penalty it stays ~2e-8 (measured).
    const SYMMETRY_TOL: f64 = 1e-6;
    let (dir, file) = sweep_file(
        "symmetric-pair",
        r#"
name = "pair"
[base]
geometry.confined_shear = { h = 1.0, l = 4.0 }
fluid = { model = "giesekus", wi = 1.0, alpha = 0.01, beta = 0.1 }
particles = { radius = 0.1, layout.pair = { lx = 0.5, ly = 0.06 } }
numerics = { mesh = [100, 25], dt = 0.02, t_end = 1.0 }
output = { sample_every = 1 }
"#,
    );
    let spec = SweepSpec::from_file(&file).unwrap();
    let cases = expand(&spec).unwrap();
    let db = dir.join("pair.db");
    let mut opts = SweepOptions::new(db.clone());
    opts.progress = xpflow::sweep::progress::ProgressMode::Quiet;
    run_sweep(&spec, &cases, &SolverRunner, &opts).unwrap();
    let store = Store::open(&db).unwrap();
    let mut st = store
        .connection()
        .prepare(
            "SELECT a.x + b.x, a.y + b.y, a.omega - b.omega FROM samples a JOIN samples b
             ON a.case_id = b.case_id AND a.step = b.step AND a.particle = 0 AND b.particle = 1",
        )
        .unwrap();
    let rows: Vec<[f64; 3]> = st
        .query_map([], |r| Ok([r.get(0)?, r.get(1)?, r.get(2)?]))
        .unwrap()
        .collect::<Result<_, _>>()
        .unwrap();
    assert_eq!(rows.len(), 51, "steps 0..=50");
    let worst = rows
        .iter()
        .map(|r| r[0].abs().max(r[1].abs()).max(r[2].abs()))
        .fold(0.0, f64::max);
    println!("largest asymmetry (positions, ω): {worst:.2e}");
    assert!(worst < SYMMETRY_TOL, "asymmetry {worst:e}");
}

/// A sweep process killed in the middle of a case continues that case from its last saved
/// solver state when the sweep is run again: the samples before the state are kept, the ones
/// after it are recomputed, and the whole trajectory equals an uninterrupted run's.
#[test]
fn a_killed_case_continues_from_its_saved_state() {
    let (dir, id, reference) = killed_and_resumed("resume", "dt = 0.02");
    assert_eq!(reference.len(), 2 * 101, "steps 0..=100, two particles");
    let db = dir.join("killed.db");
    // the snapshots of both attempts make one series
    let snaps: i64 = Store::open(&db)
        .unwrap()
        .connection()
        .query_row("SELECT count(*) FROM snapshots", [], |r| r.get(0))
        .unwrap();
    assert_eq!(snaps, 11, "snapshots at steps 0, 10, …, 100");
    // snapshots go to <db dir>/<sweep name>/
    let xdmf = std::fs::read_to_string(dir.join("resume").join(format!("{id}.xdmf"))).unwrap();
    assert_eq!(xdmf.matches("<Grid Name=\"step_").count(), 11);
}

/// The same with an adaptive step (issue 27): the step controller's state is part of the saved
/// state, so the resumed run takes the steps the uninterrupted one took, and both end at t_end.
#[test]
fn a_killed_adaptive_case_continues_with_the_steps_it_would_have_taken() {
    let (dir, _, reference) = killed_and_resumed(
        "resume_adaptive",
        "dt = { initial = 0.01, min = 0.001, max = 0.2, tol = 2e-4 }",
    );
    let steps = reference.len() / 2 - 1;
    assert!(
        (30..200).contains(&steps),
        "{steps} steps: the controller should have grown the step from 0.01 (200 steps)"
    );
    let row = |db: &str, sql: &str| -> Vec<Option<f64>> {
        let store = Store::open_read_only(&dir.join(db)).unwrap();
        let mut st = store.connection().prepare(sql).unwrap();
        let n = st.column_count();
        st.query_row([], |r| (0..n).map(|i| r.get(i)).collect())
            .unwrap()
    };
    let t_last = row("whole.db", "SELECT max(t) FROM samples")[0].unwrap();
    assert!((t_last - 2.0).abs() < 1e-12, "ends at t_end, not {t_last}");
    // the steps redone are recorded with the outcome, the same for the resumed run
    let rejected = |db| {
        row(
            db,
            "SELECT json_extract(final_json, '$.rejected_steps') FROM outcomes",
        )
    };
    let whole = rejected("whole.db");
    assert!(
        whole[0].is_some(),
        "an adaptive case records its rejected steps"
    );
    assert_eq!(rejected("killed.db"), whole);
    // and what its flow solves cost (this process: the resumed run counts from its resume)
    let [solves, factorizations, placements] = row(
        "whole.db",
        "SELECT json_extract(final_json, '$.flow_solver.solves'), \
         json_extract(final_json, '$.flow_solver.factorizations'), \
         json_extract(final_json, '$.flow_solver.placements') FROM outcomes",
    )[..] else {
        panic!("three columns")
    };
    let [solves, factorizations, placements] =
        [solves, factorizations, placements].map(|v| v.unwrap() as usize);
    assert!(solves > steps, "{solves} flow solves for {steps} steps");
    // the particles move: the flow matrix is factored (by its band) every step, the far field
    // once per placement (at least the first)
    assert!(
        factorizations >= steps && placements >= 1 && placements < factorizations,
        "{factorizations} factorizations, {placements} placements for {steps} steps"
    );
    // its CPU time, the estimates' calibration: within its wall time, the attempts' sum resumed
    for db in ["whole.db", "killed.db"] {
        let cost = row(
            db,
            "SELECT json_extract(o.final_json, '$.cpu_s'), c.wall_s \
             FROM outcomes o JOIN cases c ON c.id = o.case_id",
        );
        let (cpu, wall) = (cost[0].unwrap(), cost[1].unwrap());
        assert!(
            cpu > 0.0 && cpu <= wall * 1.001,
            "{db}: {cpu} s CPU, {wall} s wall"
        );
    }
}

/// Runs the two-particle sweep of `numerics_dt` (the `dt = …` of its numerics) uninterrupted,
/// then again killed after a saved state and resumed; asserts the resumed trajectory equals the
/// uninterrupted one and returns the scratch directory, the case id and that trajectory.
fn killed_and_resumed(name: &str, numerics_dt: &str) -> (Scratch, String, Vec<[f64; 4]>) {
    // the restored flow pattern may order the factorization differently: round-off only
    const RESUME_TOL: f64 = 1e-9;
    let (dir, file) = sweep_file(
        name,
        &format!(
            r#"
name = "{name}"
[base]
geometry.confined_shear = {{ h = 1.0, l = 4.0 }}
fluid = {{ model = "giesekus", wi = 1.0, alpha = 0.01, beta = 0.1 }}
particles = {{ radius = 0.1, layout.pair = {{ lx = 0.5, ly = 0.06 }} }}
numerics = {{ mesh = [40, 10], {numerics_dt}, t_end = 2.0 }}
output = {{ sample_every = 1, snapshot_every = 10 }}
"#
        ),
    );
    let exe = env!("CARGO_BIN_EXE_xpflow");
    let sweep = |db: &PathBuf| {
        let mut c = std::process::Command::new(exe);
        c.arg("sweep")
            .arg(&file)
            .arg("--db")
            .arg(db)
            .args(["--state-every", "0", "--jobs", "1"])
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped());
        c
    };
    // uninterrupted
    let whole = dir.join("whole.db");
    let out = sweep(&whole).output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let reference = trajectory(&whole);
    // killed after some steps have been saved
    let db = dir.join("killed.db");
    let id = expand(&SweepSpec::from_file(&file).unwrap()).unwrap()[0]
        .id
        .clone();
    let state = xpflow::sweep::engine::resume_path(&db, &id);
    assert_eq!(state, dir.join("killed").join(format!("{id}.resume.json")));
    let mut child = sweep(&db).spawn().unwrap();
    let t0 = std::time::Instant::now();
    while !std::fs::metadata(&state).is_ok_and(|m| m.len() > 0) || trajectory(&db).len() < 2 * 30 {
        assert!(t0.elapsed().as_secs() < 120, "no saved state appeared");
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    let partial = trajectory(&db).len();
    // `xpflow status` tells where the rerun will continue
    let status = std::process::Command::new(exe)
        .arg("status")
        .arg("--db")
        .arg(&db)
        .output()
        .unwrap();
    let status = String::from_utf8_lossy(&status.stdout).to_string();
    assert!(
        status.contains("interrupted") && status.contains("step "),
        "{status}"
    );
    assert!(
        partial < reference.len(),
        "killed too late ({partial} rows)"
    );
    let out = sweep(&db).output().unwrap();
    let log =
        String::from_utf8_lossy(&out.stdout).to_string() + &String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{log}");
    assert!(log.contains("resume"), "the case started over:\n{log}");
    assert!(
        !state.exists(),
        "the saved state outlives the finished case"
    );
    let resumed = trajectory(&db);
    let diff = common::resumed_difference(&resumed, &reference);
    assert!(diff < RESUME_TOL, "resumed trajectory differs by {diff:e}");
    (dir, id, reference)
}

/// A case solved in a translating frame (`numerics.frame_velocity`) reports the same lab-frame
/// motion as in the fixed frame, up to the discretization error (the particle crosses the mesh in
/// one frame and sits on it in the other).
#[test]
fn a_translating_frame_reports_lab_frame_motion() {
    // Measured on this 40×20 mesh (a/h = 2) after 10 steps: x and U agree to 2e-5 and 8e-5, ω*
    // differs by 1.6e-2 (the lab-frame ω of a particle crossing a coarse mesh is noisy:
    // docs/validation.md). A sign or offset error in the conversion would show up as U_f = 0.2
    // in U or U_f t = 0.04 in x.
    const MOTION_TOL: f64 = 1e-3;
    const OMEGA_TOL: f64 = 5e-2;
    let case = |frame: &str| {
        format!(
            r#"
name = "frame"
[base]
geometry.confined_shear = {{ h = 1.0, l = 2.0 }}
fluid = {{ model = "giesekus", wi = 1.0, alpha = 0.2, beta = 0.1 }}
particles = {{ radius = 0.1, layout.explicit = {{ positions = [[0.0, 0.2]] }} }}
numerics = {{ mesh = [40, 20], dt = 0.02, t_end = 0.2{frame} }}
output = {{ sample_every = 1 }}
"#
        )
    };
    let moving = frames_agree(
        "frame",
        case,
        ", frame_velocity = 0.2",
        MOTION_TOL,
        OMEGA_TOL,
    );
    // the particle moved with the upper half of the channel in the lab frame
    assert!(moving[0] > 0.03 && moving[2] > 0.15, "{moving:?}");
}

/// A Couette case solved in a rotating frame (`numerics.frame_rotation`) reports the same lab-frame
/// motion as in the fixed frame: position, velocity and the particle's spin (ω_lab = ω + Ω).
#[test]
fn a_rotating_frame_reports_lab_frame_motion() {
    // Measured (12×64, a/h ≈ 2.5, 15 steps at Wi = 1/3): the frames agree to 8e-5 in position,
    // 1.1e-3 in velocity and 1.3e-3 in ω (the orbit carries the particle over the mesh in one
    // frame only). A missing rotation of the sample would be Ωt·r = 0.08 off, a missing Ω × x in
    // the velocity 0.26, a missing Ω in the spin 0.1.
    const MOTION_TOL: f64 = 3e-3;
    const OMEGA_TOL: f64 = 2e-2;
    let case = |frame: &str| {
        format!(
            r#"
name = "rotating"
[base]
geometry.couette = {{ r1 = 1.0, r2 = 4.0, omega_inner = 1.0 }}
fluid = {{ model = "giesekus", wi = 0.3333333333333333, alpha = 0.01, beta = 0.1 }}
particles = {{ eps = 0.26666666666666666, layout.couette = {{ r0_star = 0.5 }} }}
numerics = {{ mesh = [12, 64], dt = 0.02, t_end = 0.3{frame} }}
output = {{ sample_every = 1 }}
"#
        )
    };
    frames_agree(
        "rotating",
        case,
        ", frame_rotation = 0.104",
        MOTION_TOL,
        OMEGA_TOL,
    );
}

/// Runs a one-case sweep in the lab frame and with the `frame` fields appended to its numerics,
/// checks that the last samples agree (x, y, u within `motion_tol`, ω within `omega_tol`) and
/// returns the moving frame's (x, y, u, ω).
fn frames_agree(
    name: &str,
    case: impl Fn(&str) -> String,
    frame: &str,
    motion_tol: f64,
    omega_tol: f64,
) -> [f64; 4] {
    let (s0, n0, lab) = run_one(&format!("{name}-lab"), &case(""));
    let (s1, n1, moving) = run_one(&format!("{name}-moving"), &case(frame));
    assert_eq!((s0.as_str(), s1.as_str()), ("done", "done"));
    assert_eq!(n0, n1);
    println!("lab {lab:?}\nmoving {moving:?}");
    for k in 0..3 {
        assert!(
            (lab[k] - moving[k]).abs() < motion_tol,
            "{lab:?} vs {moving:?}"
        );
    }
    assert!(
        (lab[3] - moving[3]).abs() < omega_tol,
        "{lab:?} vs {moving:?}"
    );
    moving
}

/// A viscoelastic snapshot holds the polymer stress: tr τ, τ_xx, τ_xy, τ_yy (DESIGN's snapshot
/// fields). Far from the particle the flow is the start-up of plane Couette flow, where
/// τ_xy(t) = η_p γ̇ (1 − e^{−t/λ}) (Oldroyd-B; Giesekus α = 0.01 differs by O(α Wi²) ≈ 1e-4 at
/// t = λ/5) and tr τ = 2 η_p λ γ̇² (1 − e^{−t/λ}(1 + t/λ)) (N1 = τ_xx − τ_yy, τ_yy = O(α)).
#[test]
fn a_viscoelastic_snapshot_holds_the_polymer_stress() {
    // measured 1.9e-3 (τ_xy) and 3.8e-3 (tr τ) relative: the BDF1/BDF2 start-up at Δt = λ/50;
    // a stress without its factor η_p/λ or a wrong component would be off by O(1)
    const STARTUP_TOL: f64 = 0.02;
    let (dir, file) = sweep_file(
        "visco-snapshot",
        r#"
name = "visco_snap"
[base]
geometry.confined_shear = { h = 1.0, l = 4.0 }
fluid = { model = "giesekus", wi = 1.0, alpha = 0.01, beta = 0.1 }
particles = { radius = 0.1, layout.explicit = { positions = [[0.0, 0.0]] } }
numerics = { mesh = [40, 10], dt = 0.02, t_end = 0.2 }
output = { sample_every = 5, snapshot_every = 10 }
"#,
    );
    let spec = SweepSpec::from_file(&file).unwrap();
    let cases = expand(&spec).unwrap();
    let db = dir.join("snap.db");
    let mut opts = SweepOptions::new(db.clone());
    opts.progress = xpflow::sweep::progress::ProgressMode::Quiet;
    run_sweep(&spec, &cases, &SolverRunner, &opts).unwrap();
    let store = Store::open(&db).unwrap();
    let path: String = store
        .connection()
        .query_row(
            "SELECT file FROM snapshots ORDER BY step DESC LIMIT 1",
            [],
            |r| r.get(0),
        )
        .unwrap();
    let path = if Path::new(&path).exists() {
        PathBuf::from(path)
    } else {
        dir.join(path)
    };
    let h5 = hdf5::File::open(&path).unwrap();
    let group = h5.group("step_0000000010").unwrap();
    let read = |name: &str| group.dataset(name).unwrap().read_raw::<f64>().unwrap();
    let coords = read("coords");
    let (tr, xx, xy, yy) = (
        read("tr_tau"),
        read("tau_xx"),
        read("tau_xy"),
        read("tau_yy"),
    );
    let (eta_p, lambda, rate, t): (f64, f64, f64, f64) = (0.9, 1.0, 1.0, 0.2);
    let xy_exact = eta_p * rate * (1.0 - (-t / lambda).exp());
    let tr_exact =
        2.0 * eta_p * lambda * rate * rate * (1.0 - (-t / lambda).exp() * (1.0 + t / lambda));
    let mut far = 0;
    for k in 0..tr.len() {
        assert!((tr[k] - xx[k] - yy[k]).abs() < 1e-12, "tr τ = τ_xx + τ_yy");
        let x = coords[2 * k];
        if x.abs() > 1.5 {
            far += 1;
            assert!(
                (xy[k] - xy_exact).abs() < STARTUP_TOL * xy_exact,
                "τ_xy {} vs {xy_exact} at x = {x}",
                xy[k]
            );
            assert!(
                (tr[k] - tr_exact).abs() < STARTUP_TOL * tr_exact,
                "tr τ {} vs {tr_exact} at x = {x}",
                tr[k]
            );
        }
    }
    assert!(far > 50);
}
