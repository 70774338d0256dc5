//! The sweep/query/status handlers as functions: example sweeps validate, invalid sweep files exit with
//! code 2 naming file, case and field and write nothing, unsupported cases write nothing, queries render.

mod common;
use common::Scratch;
use std::path::Path;
use std::process::ExitCode;

use xpflow::cli::sweep_cmds::{
    run_query_to, run_status_to, run_sweep_with, QueryArgs, QueryWhat, StatusArgs, SweepArgs,
};
use xpflow::config::{ConfigError, SweepSpec};
use xpflow::observe::OutcomeKind;
use xpflow::store::Format;
use xpflow::sweep::solver_runner::SolverRunner;
use xpflow::sweep::{expand, FakeBehaviour, FakeRunner};

fn scratch(name: &str) -> Scratch {
    Scratch::new("cli", name)
}

fn args(file: &Path, db: &Path) -> SweepArgs {
    common::sweep_args(file, db)
}

const GOOD: &str = r#"
name = "cli"
[base]
geometry.confined_shear = { h = 1.0, l = 4.0 }
fluid = { model = "giesekus", wi = 1.0, alpha = 0.01, beta = 0.1 }
particles = { radius = 0.1, layout.string = { n = 3, lx = 0.5, ly = 0.1 } }
numerics = { mesh = [40, 10], dt = 0.01, t_end = 30.0 }
[axes]
fluid.wi = [1, 2]
"#;

#[test]
fn example_sweeps_pass_dry_run() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("sweeps");
    let mut n = 0;
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "toml") {
            let mut out = Vec::new();
            let mut a = args(&path, Path::new("/nonexistent/never.db"));
            a.dry_run = true;
            let code = run_sweep_with(&a, &SolverRunner, &mut out).unwrap();
            assert_eq!(code, ExitCode::SUCCESS, "{}", path.display());
            let text = String::from_utf8(out).unwrap();
            assert!(text.contains(" cases in sweep "), "{text}");
            n += 1;
        }
    }
    assert!(
        n >= 4,
        "expected the thesis sweeps and demo.toml, found {n}"
    );
}

#[test]
fn invalid_sweeps_exit_2_and_write_nothing() {
    let dir = scratch("invalid");
    let bad: [(&str, String, &str); 15] = [
        (
            "malformed",
            GOOD.replace("name = \"cli\"", "name = = 1"),
            "",
        ),
        (
            "unknown key",
            GOOD.replace("beta = 0.1", "beta = 0.1, betta = 1"),
            "fluid.betta",
        ),
        (
            "wrong type",
            GOOD.replace("t_end = 30.0", "t_end = \"long\""),
            "numerics.t_end",
        ),
        (
            "a >= H/2",
            GOOD.replace("radius = 0.1", "radius = 0.5"),
            "particles.radius",
        ),
        (
            "overlap",
            GOOD.replace("lx = 0.5", "lx = 0.15"),
            "particles.layout.string",
        ),
        (
            "wall",
            GOOD.replace("ly = 0.1", "ly = 0.45"),
            "particles.layout.string",
        ),
        (
            "Wi < 0",
            GOOD.replace("fluid.wi = [1, 2]", "fluid.wi = [1, -2]"),
            "fluid.wi",
        ),
        (
            "alpha",
            GOOD.replace("alpha = 0.01", "alpha = 1.0"),
            "fluid.alpha",
        ),
        (
            "beta",
            GOOD.replace("beta = 0.1", "beta = 1.0"),
            "fluid.beta",
        ),
        ("dt", GOOD.replace("dt = 0.01", "dt = 0.0"), "numerics.dt"),
        (
            "N = 0",
            GOOD.replace("n = 3", "n = 0"),
            "particles.layout.string.n",
        ),
        (
            "axis path",
            GOOD.replace("fluid.wi = [1, 2]", "fluid.wii = [1, 2]"),
            "fluid.wii",
        ),
        (
            "explicit coupling without solvent",
            GOOD.replace("beta = 0.1", "beta = 0.0")
                .replace("dt = 0.01", "dt = 0.01, coupling = \"explicit\""),
            "numerics.coupling",
        ),
        (
            "rotating channel",
            GOOD.replace("dt = 0.01", "dt = 0.01, frame_rotation = 0.1"),
            "numerics.frame_rotation",
        ),
        (
            "unknown coupling",
            GOOD.replace("dt = 0.01", "dt = 0.01, coupling = \"implicit\""),
            "numerics.coupling",
        ),
    ];
    for (what, text, field) in bad {
        let file = dir.join("bad.toml");
        std::fs::write(&file, &text).unwrap();
        let db = dir.join("never.db");
        let _ = std::fs::remove_file(&db);
        let code = run_sweep_with(
            &args(&file, &db),
            &FakeRunner::new(|_| FakeBehaviour::Fail("x".into())),
            &mut Vec::new(),
        )
        .unwrap();
        assert_eq!(code, ExitCode::from(2), "{what}");
        assert!(!db.exists(), "{what}: nothing may be written");
        // The message names the file, the case and the field.
        let err = SweepSpec::from_file(&file)
            .and_then(|s| expand(&s).map(|_| ()))
            .unwrap_err();
        let msg = err.to_string();
        assert!(msg.contains("bad.toml"), "{what}: {msg}");
        if !field.is_empty() {
            assert_eq!(err.field(), Some(field), "{what}: {msg}");
            assert!(msg.contains(field), "{what}: {msg}");
            if let ConfigError::Case { .. } = err {
                assert!(msg.contains("case "), "{what}: {msg}");
            }
        }
    }
}

#[test]
fn unsupported_cases_exit_2_and_write_nothing() {
    let dir = scratch("unsupported");
    let file = dir.join("s.toml");
    std::fs::write(&file, GOOD).unwrap();
    let db = dir.join("r.db");
    let mut refusing = FakeRunner::new(|_| FakeBehaviour::Produce(OutcomeKind::Timeout));
    refusing.refuse = Box::new(|_| true);
    let code = run_sweep_with(&args(&file, &db), &refusing, &mut Vec::new()).unwrap();
    assert_eq!(code, ExitCode::from(2));
    assert!(!db.exists());
}

/// `--dry-run --estimate`: before the sweep every case is "not run" and nothing is created;
/// after it the database's cases are done and nothing is left (the database is only read).
#[test]
fn the_estimate_reads_what_the_database_has_done() {
    let dir = scratch("estimate");
    let file = dir.join("s.toml");
    std::fs::write(&file, GOOD).unwrap();
    let db = dir.join("r.db");
    let estimate = || {
        let mut a = args(&file, &db);
        a.dry_run = true;
        a.estimate = true;
        let mut out = Vec::new();
        let runner = FakeRunner::new(|_| FakeBehaviour::Produce(OutcomeKind::Repel));
        assert_eq!(
            run_sweep_with(&a, &runner, &mut out).unwrap(),
            ExitCode::SUCCESS
        );
        String::from_utf8(out).unwrap()
    };
    let before = estimate();
    assert_eq!(before.matches("not run").count(), 2, "{before}");
    assert!(before.contains("for 2 cases"), "{before}");
    assert!(!db.exists(), "an estimate creates no database");
    let runner = FakeRunner::new(|_| FakeBehaviour::Produce(OutcomeKind::Repel));
    run_sweep_with(&args(&file, &db), &runner, &mut Vec::new()).unwrap();
    let after = estimate();
    let done = after
        .lines()
        .filter(|l| l.trim_end().ends_with(" done"))
        .count();
    assert_eq!(done, 2, "{after}");
    assert!(after.contains(", 0.0 of them not done yet"), "{after}");
}

#[test]
fn sweep_then_query_and_status() {
    let dir = scratch("query");
    let file = dir.join("s.toml");
    std::fs::write(&file, GOOD).unwrap();
    let db = dir.join("r.db");
    let runner = FakeRunner::new(|s| {
        FakeBehaviour::Produce(if s.fluid.wi > 1.5 {
            OutcomeKind::String
        } else {
            OutcomeKind::Repel
        })
    });
    assert_eq!(
        run_sweep_with(&args(&file, &db), &runner, &mut Vec::new()).unwrap(),
        ExitCode::SUCCESS
    );

    let q = |what, filters: Vec<&str>, format| {
        let a = QueryArgs {
            what,
            db: db.clone(),
            sweep: Some("cli".into()),
            filters: filters.into_iter().map(String::from).collect(),
            case: None,
            by: "r0".into(),
            format,
        };
        let mut out = Vec::new();
        let code = run_query_to(&a, &mut out).unwrap();
        (code, String::from_utf8(out).unwrap())
    };
    let (code, json) = q(QueryWhat::Strings, vec![], Format::Json);
    assert_eq!(code, ExitCode::SUCCESS);
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    assert_eq!(
        v,
        serde_json::json!([{"Wi": 1.0, "N=3": "-"}, {"Wi": 2.0, "N=3": "+"}])
    );
    // Final states: one row per particle of each decided case, a gap to the next particle for
    // all but the last along the chain.
    let (code, json) = q(QueryWhat::Final, vec![], Format::Json);
    assert_eq!(code, ExitCode::SUCCESS);
    let rows: Vec<serde_json::Value> = serde_json::from_str(&json).unwrap();
    assert_eq!(rows.len(), 6, "{json}");
    for case in rows.chunks(3) {
        let idx: Vec<_> = case.iter().map(|r| r["particle"].as_i64()).collect();
        assert_eq!(idx, [Some(0), Some(1), Some(2)], "{json}");
        assert!(case
            .iter()
            .all(|r| r["x"].is_number() && r["omega_star"].is_number()));
        let gaps = case
            .iter()
            .filter(|r| r["gap_next_over_a"].is_number())
            .count();
        assert_eq!(gaps, 2, "{json}");
    }
    // A filter value that looks like SQL is just a value.
    let (code, csv) = q(QueryWhat::Cases, vec!["label=x' OR '1'='1"], Format::Csv);
    assert_eq!(code, ExitCode::SUCCESS);
    assert_eq!(csv.lines().count(), 1, "header only: {csv}");
    let (code, _) = q(QueryWhat::Cases, vec!["nonsense=1"], Format::Csv);
    assert_eq!(code, ExitCode::from(2));
    let (_, cases) = q(QueryWhat::Cases, vec!["wi=2"], Format::Csv);
    let id = cases
        .lines()
        .nth(1)
        .unwrap()
        .split(',')
        .next()
        .unwrap()
        .to_string();
    let a = QueryArgs {
        what: QueryWhat::Trajectory,
        db: db.clone(),
        sweep: None,
        filters: vec![],
        case: Some(id[..8].into()),
        by: "r0".into(),
        format: Format::Csv,
    };
    let mut out = Vec::new();
    run_query_to(&a, &mut out).unwrap();
    let traj = String::from_utf8(out).unwrap();
    assert!(
        traj.starts_with("step,t,particle,x,y,u,v,omega,theta\n10,"),
        "{}",
        &traj[..80.min(traj.len())]
    );

    let mut out = Vec::new();
    run_status_to(
        &StatusArgs {
            db: vec![db.clone()],
            submission: vec![],
        },
        &mut out,
    )
    .unwrap();
    let status = String::from_utf8(out).unwrap();
    let row = status.lines().nth(1).unwrap();
    let cells: Vec<&str> = row.split_whitespace().collect();
    assert_eq!(&cells[1..], ["cli", "2", "2", "0", "0", "0"], "{status}");
}
