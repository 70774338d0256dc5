//! Figures end to end: builds a small results database with the fake runner (confined-shear cases ending
//! in string / repel / pass / jammed / diverged, a δ × Wi regime sweep, Couette migration cases over r0*,
//! Wi, α and ε, one case with an HDF5 snapshot file, a Couette and a shear set-up on two meshes, and one
//! particle in confined shear started at three heights on two meshes), runs
//! `plotting/make_figures.py` on it with the Python of the repository's `.venv/` (created by
//! `make figures-deps` when missing), and checks that every expected figure exists as a valid PNG and PDF
//! and every table as Markdown. A second test runs the scripts on an empty database: they must still
//! succeed, write no figure without data, and list every missing one in `index.md`.
//!
//! Needs python3 (≥ 3.11) with venv/pip and the network (PyPI) the first time; if they are missing the test
//! fails with the message of `make figures-deps`, it does not skip.

mod common;
use common::Scratch;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use xpflow::config::{CaseSpec, SweepSpec};
use xpflow::observe::OutcomeKind;
use xpflow::store::Store;
use xpflow::sweep::{expand, run_sweep, FakeBehaviour, FakeRunner, SweepOptions};

/// Figures every database with shear, regime, Couette and snapshot cases must produce (PNG + PDF each).
const EXPECTED_FIGURES: &[&str] = &[
    "migration_r_by_r0",
    "migration_r_by_wi",
    "migration_r_by_alpha",
    "migration_r_by_eps",
    "migration_vr",
    "single_particle",
    "alignment_trajectories",
    "alignment_velocities",
    "alignment_steady_omega",
    "string_gaps",
    "regime_map",
    "mesh_convergence",
    "field_snapshots",
    "film_zoom",
];
/// Markdown tables (thesis Tables 5.2–5.4 style).
const EXPECTED_TABLES: &[&str] = &["tables/string_formation.md", "tables/string_summary.md"];
/// The mesh-convergence table (thesis Table 3.1 style).
const MESH_TABLE: &str = "tables/mesh_convergence.md";
/// The one-particle table (thesis §5.5): migration per start height and mesh.
const SINGLE_TABLE: &str = "tables/single_particle.md";
/// Figures that have no data in an empty database: none is written, `index.md` lists each as missing.
const EMPTY_DB_FIGURES: &[&str] = &[
    "migration_r_by_r0",
    "migration_vr",
    "single_particle",
    "alignment_trajectories",
    "alignment_velocities",
    "alignment_steady_omega",
    "string_gaps",
    "regime_map",
    "mesh_convergence",
];
/// A rendered figure with axes, text and lines is tens of kB; an empty or truncated PNG is far smaller.
const MIN_PNG_BYTES: u64 = 10_000;
/// Figures are at least this many pixels wide and high (a 6.4 in × 150 dpi figure is ~960 px).
const MIN_PNG_PIXELS: u32 = 300;
/// A PDF page with text and vector paths is a few kB at least.
const MIN_PDF_BYTES: u64 = 2_000;

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn scratch(name: &str) -> Scratch {
    Scratch::new("figs", name)
}

fn sweep(dir: &Path, file: &str, text: &str) -> SweepSpec {
    let path = dir.join(file);
    std::fs::write(&path, text).unwrap();
    SweepSpec::from_file(&path).unwrap()
}

fn run(db: &Path, spec: &SweepSpec, runner: &FakeRunner) {
    let cases = expand(spec).unwrap();
    let mut o = SweepOptions::new(db.to_path_buf());
    o.jobs = 2;
    o.progress = xpflow::sweep::progress::ProgressMode::Quiet;
    run_sweep(spec, &cases, runner, &o).unwrap();
}

/// Shear pairs and strings: Wi 2 forms strings; Wi 1 repels for small l_y and passes for large l_y.
fn shear_behaviour(s: &CaseSpec) -> FakeBehaviour {
    let ly = s.spacing().map_or(0.0, |(_, ly)| ly);
    match (s.fluid.wi.round() as i64, ly < 0.08) {
        (2, _) => FakeBehaviour::Produce(OutcomeKind::String),
        (_, true) => FakeBehaviour::Produce(OutcomeKind::Repel),
        (_, false) => FakeBehaviour::Produce(OutcomeKind::Pass),
    }
}

/// Regime map δ × Wi: jammed at δ = 2, then pass (Wi 0.5) or string (Wi 2); Wi = 2 at δ = 10 diverges.
fn regime_behaviour(s: &CaseSpec) -> FakeBehaviour {
    let delta = s.delta().unwrap_or(0.0);
    let wi = s.fluid.wi;
    if delta < 2.5 {
        FakeBehaviour::Produce(OutcomeKind::Jammed)
    } else if wi > 1.5 && delta > 7.0 {
        FakeBehaviour::Diverge("fake: linear solve failed".into())
    } else if wi < 1.0 {
        FakeBehaviour::Produce(OutcomeKind::Pass)
    } else {
        FakeBehaviour::Produce(OutcomeKind::String)
    }
}

/// Couette: Wi 1 migrates, Wi 0.5 stays (steady).
fn couette_behaviour(s: &CaseSpec) -> FakeBehaviour {
    if s.fluid.wi > 0.75 {
        FakeBehaviour::Produce(OutcomeKind::Migrated)
    } else {
        FakeBehaviour::Produce(OutcomeKind::Steady)
    }
}

/// One particle in confined shear, by start height y0 (centre line at 0, H = 1): it stays near the bottom
/// wall (Y0/H = 0.1, `timeout`), moves to the centre line from Y0/H = 0.3 (`steady`) and to the wall from
/// Y0/H = 0.4 (`wall_contact`); not physics, but one case of each migration direction.
fn single_particle_behaviour(s: &CaseSpec) -> FakeBehaviour {
    let y0 = s.initial_positions().first().map_or(0.0, |p| p[1]);
    if y0 < -0.3 {
        FakeBehaviour::Produce(OutcomeKind::Migrated)
    } else if y0 < -0.15 {
        FakeBehaviour::Produce(OutcomeKind::Steady)
    } else {
        FakeBehaviour::Produce(OutcomeKind::WallContact)
    }
}

/// The database of the test (51 fake cases; a second or two).
fn build_database(dir: &Path) -> PathBuf {
    let db = dir.join("figs.db");
    let shear = sweep(
        dir,
        "shear.toml",
        r#"
name = "shear"
[base]
geometry.confined_shear = { h = 1.0, l = 4.0 }
fluid = { model = "giesekus", wi = 1.0, alpha = 0.01, beta = 0.1 }
particles = { radius = 0.1, layout.string = { n = 3, lx = 0.5, ly = 0.1 } }
numerics = { mesh = [40, 10], dt = 0.01, t_end = 20.0 }
output = { sample_every = 10 }
[axes]
fluid.wi = [1, 2]
particles.layout.string.n = [2, 3]
particles.layout.string.ly = [0.04, 0.06, 0.1]
"#,
    );
    run(&db, &shear, &FakeRunner::new(shear_behaviour));
    // a nested numerical setting (a mesh that follows the particles) in the set-up titles
    let follow = sweep(
        dir,
        "follow.toml",
        r#"
name = "follow"
[base]
geometry.confined_shear = { h = 1.0, l = 4.0 }
fluid = { model = "giesekus", wi = 2.0, alpha = 0.01, beta = 0.1 }
particles = { radius = 0.1, layout.string = { n = 3, lx = 0.5, ly = 0.1 } }
numerics = { mesh = [40, 10], dt = 0.01, t_end = 20.0, follow = { ratio = 2.0, ratio_y = 1.0 } }
output = { sample_every = 10 }
[axes]
numerics.follow.ratio = [1.5, 2.0]
"#,
    );
    run(&db, &follow, &FakeRunner::new(shear_behaviour));
    let regime = sweep(
        dir,
        "regime.toml",
        r#"
name = "regime"
[base]
geometry.confined_shear = { delta = 5, l = 4.0 }
fluid = { model = "giesekus", wi = 1.0, alpha = 0.01, beta = 0.1 }
particles = { radius = 0.1, layout.string = { n = 3, lx = 0.5, ly = 0.1 } }
numerics = { mesh = [40, 10], dt = 0.02, t_end = 24.0 }
output = { sample_every = 10 }
[axes]
fluid.wi = [0.5, 2]
geometry.confined_shear.delta = [2, 5, 10]
"#,
    );
    run(&db, &regime, &FakeRunner::new(regime_behaviour));
    let couette = sweep(
        dir,
        "couette.toml",
        r#"
name = "couette"
[base]
geometry.couette = { r1 = 1.0, r2 = 4.0 }
fluid = { model = "giesekus", wi = 1.0, alpha = 0.01, beta = 0.1 }
particles = { eps = 0.26666666666666666, layout.couette = { r0_star = 0.5 } }
numerics = { mesh = [20, 80], dt = 0.05, t_end = 30.0 }
output = { sample_every = 4 }
[axes]
fluid.wi = [0.5, 1]
fluid.alpha = [0.01, 0.1]
particles.eps = [0.13333333333333333, 0.26666666666666666]
particles.layout.couette.r0_star = [0.3, 0.5, 0.7]
"#,
    );
    run(&db, &couette, &FakeRunner::new(couette_behaviour));
    let snap = sweep(
        dir,
        "snap.toml",
        r#"
name = "snap"
[base]
geometry.confined_shear = { h = 1.0, l = 4.0 }
fluid = { model = "giesekus", wi = 2.0, alpha = 0.01, beta = 0.1 }
particles = { radius = 0.1, layout.string = { n = 3, lx = 0.5, ly = 0.1 } }
numerics = { mesh = [40, 10], dt = 0.01, t_end = 20.0 }
output = { sample_every = 10, snapshot_every = 300 }
"#,
    );
    run(
        &db,
        &snap,
        &FakeRunner::new(|_| FakeBehaviour::Produce(OutcomeKind::String)),
    );
    // Mesh convergence: one Couette and one shear set-up on two meshes; the coarser case of each is a
    // case of the sweeps above (same case id, run once), so each sweep adds one case.
    let couette_mesh = sweep(
        dir,
        "couette_mesh.toml",
        r#"
name = "couette_mesh"
[base]
geometry.couette = { r1 = 1.0, r2 = 4.0 }
fluid = { model = "giesekus", wi = 1.0, alpha = 0.01, beta = 0.1 }
particles = { eps = 0.26666666666666666, layout.couette = { r0_star = 0.5 } }
numerics = { mesh = [20, 80], dt = 0.05, t_end = 30.0 }
output = { sample_every = 4 }
[axes]
numerics.mesh = [[20, 80], [30, 120]]
"#,
    );
    run(&db, &couette_mesh, &FakeRunner::new(couette_behaviour));
    let shear_mesh = sweep(
        dir,
        "shear_mesh.toml",
        r#"
name = "shear_mesh"
[base]
geometry.confined_shear = { h = 1.0, l = 4.0 }
fluid = { model = "giesekus", wi = 2.0, alpha = 0.01, beta = 0.1 }
particles = { radius = 0.1, layout.string = { n = 2, lx = 0.5, ly = 0.1 } }
numerics = { mesh = [40, 10], dt = 0.01, t_end = 20.0 }
output = { sample_every = 10 }
[axes]
numerics.mesh = [[40, 10], [80, 20]]
"#,
    );
    run(&db, &shear_mesh, &FakeRunner::new(shear_behaviour));
    // One particle started at three heights, each in the frame moving with the fluid there (zipped with the
    // start, as in sweeps/single_particle_migration.toml), on two meshes.
    let single = sweep(
        dir,
        "single_particle.toml",
        r#"
name = "single_particle"
[base]
geometry.confined_shear = { h = 1.0, l = 2.0 }
fluid = { model = "giesekus", wi = 1.0, alpha = 0.2, beta = 0.09090909090909091 }
particles = { radius = 0.05, layout.explicit.positions = [[0.0, -0.4]] }
numerics = { mesh = [40, 20], dt = 0.02, t_end = 10.0 }
output = { sample_every = 5 }
[axes]
numerics.mesh = [[40, 20], [60, 30]]
[[zip]]
"particles.layout.explicit.positions" = [[[0.0, -0.4]], [[0.0, -0.2]], [[0.0, -0.1]]]
"numerics.frame_velocity" = [-0.4, -0.2, -0.1]
"#,
    );
    run(&db, &single, &FakeRunner::new(single_particle_behaviour));
    let store = Store::open(&db).unwrap();
    let count = |sql: &str| -> i64 { store.connection().query_row(sql, [], |r| r.get(0)).unwrap() };
    assert_eq!(
        count("SELECT COUNT(*) FROM cases"),
        12 + 2 + 6 + 24 + 1 + 2 + 6
    );
    assert_eq!(
        count("SELECT COUNT(*) FROM sweep_cases sc JOIN sweeps s ON s.id = sc.sweep_id WHERE s.name IN ('couette_mesh', 'shear_mesh')"),
        4,
        "the two mesh sweeps have two cases each"
    );
    for kind in [
        "string",
        "repel",
        "pass",
        "jammed",
        "diverged",
        "migrated",
        "steady",
        "wall_contact",
    ] {
        assert!(
            count(&format!(
                "SELECT COUNT(*) FROM outcomes WHERE kind = '{kind}'"
            )) > 0,
            "the fake database has no '{kind}' case"
        );
    }
    assert!(count("SELECT COUNT(*) FROM snapshots") > 0);
    db
}

/// The virtual environment's python, created with `make figures-deps` if it is missing or incomplete.
/// Serializes the venv set-up: the tests run in parallel and two `python3 -m venv` at once clash.
static VENV_LOCK: std::sync::Mutex<()> = std::sync::Mutex::new(());

fn venv_python() -> PathBuf {
    let _guard = VENV_LOCK.lock().unwrap_or_else(|e| e.into_inner());
    let python = repo().join(".venv/bin/python");
    let ready = python.exists()
        && Command::new(&python)
            .args(["-c", "import matplotlib, numpy, h5py"])
            .output()
            .is_ok_and(|o| o.status.success());
    if !ready {
        let out = Command::new("make")
            .arg("-C")
            .arg(repo())
            .arg("figures-deps")
            .output()
            .unwrap_or_else(|e| {
                panic!("could not run `make figures-deps` (is make installed?): {e}")
            });
        assert!(
            out.status.success(),
            "`make figures-deps` failed, so the figures cannot be tested (needs python3 >= 3.11 with venv and pip, and PyPI):\n{}\n{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        );
    }
    assert!(
        python.exists(),
        "{} does not exist after `make figures-deps`",
        python.display()
    );
    python
}

/// Runs the driver; returns its stdout. Panics with its output if it fails.
fn make_figures(python: &Path, db: &Path, out: &Path) -> String {
    let start = Instant::now();
    let o = Command::new(python)
        .arg(repo().join("plotting/make_figures.py"))
        .arg("--out")
        .arg(out)
        .arg(db)
        .current_dir(repo())
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&o.stdout).into_owned();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(
        o.status.success(),
        "make_figures.py failed ({}):\n{stdout}\n{stderr}",
        o.status
    );
    // reported, not asserted: a shared machine's load is not the code's (the time is measured
    // with farm-bench, docs/figures.md)
    eprintln!("make_figures.py: {:.1} s", start.elapsed().as_secs_f64());
    stdout
}

fn check_png(path: &Path) {
    let bytes =
        std::fs::read(path).unwrap_or_else(|e| panic!("missing figure {}: {e}", path.display()));
    assert_eq!(
        &bytes[..8],
        b"\x89PNG\r\n\x1a\n",
        "{} is not a PNG",
        path.display()
    );
    // The IHDR chunk follows the signature: length (4), "IHDR", width (4), height (4), big-endian.
    assert_eq!(&bytes[12..16], b"IHDR", "{} has no IHDR", path.display());
    let width = u32::from_be_bytes(bytes[16..20].try_into().unwrap());
    let height = u32::from_be_bytes(bytes[20..24].try_into().unwrap());
    assert!(
        width >= MIN_PNG_PIXELS && height >= MIN_PNG_PIXELS,
        "{} is {width} × {height} px",
        path.display()
    );
    assert!(
        bytes.len() as u64 >= MIN_PNG_BYTES,
        "{} has only {} bytes",
        path.display(),
        bytes.len()
    );
}

fn check_pdf(path: &Path) {
    let bytes =
        std::fs::read(path).unwrap_or_else(|e| panic!("missing figure {}: {e}", path.display()));
    assert!(
        bytes.starts_with(b"%PDF-"),
        "{} is not a PDF",
        path.display()
    );
    let tail = String::from_utf8_lossy(&bytes[bytes.len().saturating_sub(64)..]).into_owned();
    assert!(tail.contains("%%EOF"), "{} is truncated", path.display());
    assert!(
        bytes.len() as u64 >= MIN_PDF_BYTES,
        "{} has only {} bytes",
        path.display(),
        bytes.len()
    );
}

#[test]
fn figures_from_a_fake_sweep_database() {
    let dir = scratch("full");
    let db = build_database(&dir);
    let python = venv_python();
    let out = dir.join("figures");
    let log = make_figures(&python, &db, &out);
    // One output directory per database, named after it.
    let figs = out.join("figs");
    for name in EXPECTED_FIGURES {
        check_png(&figs.join(format!("{name}.png")));
        check_pdf(&figs.join(format!("{name}.pdf")));
    }
    for table in EXPECTED_TABLES {
        let text = std::fs::read_to_string(figs.join(table))
            .unwrap_or_else(|e| panic!("missing table {table}: {e}\n{log}"));
        assert!(text.contains("| Wi"), "{table} has no Wi table:\n{text}");
    }
    // Table 5.2 style: Wi = 2 forms strings of 2 and 3 particles in the shear sweep (H = 1).
    let table = std::fs::read_to_string(figs.join("tables/string_formation.md")).unwrap();
    assert!(
        table.contains("| Wi = 2 | + | + |"),
        "string formation table:\n{table}"
    );
    assert!(
        table.contains("| Wi = 1 | - | - |"),
        "string formation table:\n{table}"
    );
    // Mesh convergence: both set-ups compared, coarse → fine.
    let mesh = std::fs::read_to_string(figs.join(MESH_TABLE))
        .unwrap_or_else(|e| panic!("missing table {MESH_TABLE}: {e}\n{log}"));
    for row in ["| 20×80 → 30×120 | r\\* |", "| 40×10 → 80×20 | y/H |"] {
        assert!(
            mesh.contains(row),
            "mesh convergence table has no row {row}:\n{mesh}"
        );
    }
    // One particle: each start on both meshes with its migration direction; the coarser mesh compared with
    // the finer one (the fake trajectories do not depend on the mesh: no difference).
    let single = std::fs::read_to_string(figs.join(SINGLE_TABLE))
        .unwrap_or_else(|e| panic!("missing table {SINGLE_TABLE}: {e}\n{log}"));
    for (start, direction) in [
        ("0.1", "none"),
        ("0.3", "towards centre"),
        ("0.4", "towards wall"),
    ] {
        for mesh in ["40×20", "60×30"] {
            let head = format!("| {start} | {mesh} |");
            let row = single
                .lines()
                .find(|l| l.starts_with(&head))
                .unwrap_or_else(|| panic!("no row {head} in the one-particle table:\n{single}"));
            assert!(
                row.contains(&format!("| {direction} |")),
                "start {start} should move {direction}:\n{row}"
            );
            if mesh == "40×20" {
                assert!(
                    row.contains("| 60×30 |") && row.ends_with("| 0.00e+00 | 0.00e+00 |"),
                    "the coarser mesh is compared with the finer one:\n{row}"
                );
            }
        }
    }
}

#[test]
fn figures_from_an_empty_database_say_what_is_missing() {
    let dir = scratch("empty");
    let db = dir.join("empty.db");
    Store::open(&db).unwrap();
    let python = venv_python();
    let out = dir.join("figures");
    let log = make_figures(&python, &db, &out);
    let figs = out.join("empty");
    // a figure without data is not written (issue 28: 8 of the demo's 15 were empty); the index
    // says what is missing
    let index = std::fs::read_to_string(figs.join("index.md")).unwrap();
    let missing = index
        .split("## Missing or left out")
        .nth(1)
        .unwrap_or_else(|| panic!("index.md has no list of what is missing:\n{index}"));
    for name in EMPTY_DB_FIGURES {
        for ext in ["png", "pdf"] {
            let path = figs.join(format!("{name}.{ext}"));
            assert!(
                !path.exists(),
                "{} has no data but was written",
                path.display()
            );
        }
        assert!(
            missing.contains(&format!("{name} not written")),
            "index.md does not list {name} as missing:\n{index}"
        );
    }
    let mesh = std::fs::read_to_string(figs.join(MESH_TABLE))
        .unwrap_or_else(|e| panic!("missing table {MESH_TABLE}: {e}\n{log}"));
    assert!(
        mesh.contains("Nothing to compare yet"),
        "the mesh table says what is missing:\n{mesh}"
    );
    let single = std::fs::read_to_string(figs.join(SINGLE_TABLE))
        .unwrap_or_else(|e| panic!("missing table {SINGLE_TABLE}: {e}\n{log}"));
    assert!(
        single.contains("Nothing to show yet"),
        "the one-particle table says what is missing:\n{single}"
    );
    assert!(
        !figs.join("field_snapshots.png").exists(),
        "no snapshot exists, so no snapshot figure"
    );
    assert!(
        log.contains("no field snapshots"),
        "the log says why the snapshot figure is skipped:\n{log}"
    );
    assert!(
        !figs.join("film_zoom.png").exists() && log.contains("no case with field snapshots"),
        "no film to zoom on, and the log says so:\n{log}"
    );
    assert!(
        log.contains("no Couette cases"),
        "the log says what is missing:\n{log}"
    );
}

/// The extrusion figures from the shipped dataset (`data/validation/extrusion.db`, thesis §6.5):
/// trajectories, separations and velocities written, and the table's rows; the Wi = 0.5 run,
/// whose state exploded after the die exit (x ≈ 1e24 at its last step), is drawn up to its last
/// sample inside the fluid (x = 0.6982) and its final s is that sample's.
#[test]
fn extrusion_figures_from_the_shipped_dataset() {
    let dir = scratch("extrusion");
    let db = dir.join("extrusion.db");
    std::fs::copy(repo().join("data/validation/extrusion.db"), &db).unwrap();
    let python = venv_python();
    let out = dir.join("figures");
    let log = make_figures(&python, &db, &out);
    let figs = out.join("extrusion");
    for name in [
        "extrusion_trajectories",
        "extrusion_separation",
        "extrusion_velocity",
    ] {
        check_png(&figs.join(format!("{name}.png")));
        check_pdf(&figs.join(format!("{name}.pdf")));
    }
    let table = std::fs::read_to_string(figs.join("tables/extrusion.md"))
        .unwrap_or_else(|e| panic!("missing tables/extrusion.md: {e}\n{log}"));
    // the row of (Wi, a, mesh): columns Wi | α | a | X0 | mesh | …
    let row = |wi: &str, a: &str, mesh: &str| {
        table
            .lines()
            .find(|l| {
                let cells: Vec<&str> = l.split('|').map(str::trim).collect();
                cells.len() > 5 && cells[1] == wi && cells[3] == a && cells[5] == mesh
            })
            .unwrap_or_else(|| panic!("no row Wi = {wi}, a = {a}, {mesh} in:\n{table}"))
            .to_string()
    };
    let diverged = row("0.5", "0.1", "210×48");
    assert!(
        diverged.contains("| +0.0313 | 0.6982 |"),
        "the exploded run ends at its last sample in the fluid:\n{diverged}"
    );
    let converged = row("0.3", "0.1", "210×48");
    assert!(
        converged.contains("| +0.0482 |") && converged.contains("| 280×64 |"),
        "a/3 compared with a/4:\n{converged}"
    );
}
