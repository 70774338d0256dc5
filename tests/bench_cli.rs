//! `xpflow bench moving --sweep FILE --case ID [--db DB]`: a study's own case on each path,
//! continued from the state a sweep saved.

mod common;
use common::Scratch;
use std::process::{Command, Output, Stdio};

use xpflow::config::SweepSpec;
use xpflow::sweep::expand;

const EXE: &str = env!("CARGO_BIN_EXE_xpflow");

/// A two-particle shear case on a 40 × 10 mesh (the ALE map on a ring), long enough to be
/// stopped in the middle.
const SWEEP: &str = r#"
name = "bench-case"
[base]
geometry.confined_shear = { h = 1.0, l = 4.0 }
fluid = { model = "giesekus", wi = 1.0, alpha = 0.01, beta = 0.1 }
particles = { radius = 0.1, layout.pair = { lx = 0.5, ly = 0.06 } }
numerics = { mesh = [40, 10], dt = 0.01, t_end = 5.0, ale_extent = "ring" }
output = { sample_every = 1 }
"#;

fn bench(args: &[&str]) -> Output {
    Command::new(EXE)
        .args(["bench", "moving", "--repeats", "1"])
        .args(args)
        .output()
        .unwrap()
}

fn text(out: &Output) -> String {
    String::from_utf8_lossy(&out.stdout).to_string() + &String::from_utf8_lossy(&out.stderr)
}

#[test]
fn a_study_case_is_benchmarked_from_its_saved_state() {
    let dir = Scratch::new("test", "bench-case");
    let file = dir.join("s.toml");
    std::fs::write(&file, SWEEP).unwrap();
    let id = expand(&SweepSpec::from_file(&file).unwrap()).unwrap()[0]
        .id
        .clone();
    let f = file.to_str().unwrap();

    // from rest: both paths, the case's label and id in the mesh column, the band path on the
    // case's own ALE extent (the ring), the refactor path on the whole mesh
    let out = bench(&["--sweep", f, "--case", &id[..6]]);
    let log = text(&out);
    assert!(out.status.success(), "{log}");
    assert!(log.contains(&format!("({})", &id[..8])), "{log}");
    assert!(log.contains("| band, ALE ring |"), "{log}");
    assert!(log.contains("| whole (refactor) |"), "{log}");
    assert!(log.contains("step: new"), "{log}");
    assert!(!log.contains("saved state"), "{log}");

    // a database without a saved state of the case, and a case the sweep does not have
    let db = dir.join("r.db");
    let d = db.to_str().unwrap();
    let out = bench(&["--sweep", f, "--case", &id, "--db", d]);
    assert_eq!(out.status.code(), Some(2), "{}", text(&out));
    assert!(text(&out).contains("no saved state"), "{}", text(&out));
    let out = bench(&["--sweep", f, "--case", "zz"]);
    assert_eq!(out.status.code(), Some(2), "{}", text(&out));
    assert!(text(&out).contains("--case `zz`"), "{}", text(&out));

    // a sweep stopped after some saved steps: the bench continues from its state
    let state = xpflow::sweep::engine::resume_path(&db, &id);
    let mut child = Command::new(EXE)
        .args(["sweep", f, "--db", d, "--state-every", "0", "--jobs", "1"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let t0 = std::time::Instant::now();
    while xpflow::sweep::engine::saved_state(&db, &id).is_none_or(|s| s.step < 20) {
        assert!(t0.elapsed().as_secs() < 120, "no saved state appeared");
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    let step = xpflow::sweep::engine::saved_state(&db, &id).unwrap().step;
    let before = std::fs::read(&state).unwrap();
    let out = bench(&[
        "--sweep",
        f,
        "--case",
        &id,
        "--db",
        d,
        "--factorization",
        "band",
    ]);
    let log = text(&out);
    assert!(out.status.success(), "{log}");
    assert!(
        log.contains(&format!("from the saved state of case {id} at step {step}")),
        "{log}"
    );
    assert_eq!(std::fs::read(&state).unwrap(), before, "the bench wrote");
}
