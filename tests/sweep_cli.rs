//! The sweep/query/status handlers as functions: example sweeps validate, invalid sweep files exit with
//! code 2 naming file, case and field and write nothing, unsupported cases write nothing, queries render.

mod common;
use common::Scratch;
use std::path::Path;
use std::process::ExitCode;

use xpflow::cli::query_cmds::{run_query_to, QueryArgs, QueryWhat};
use xpflow::cli::status_cmds::{run_status_to, StatusArgs};
use xpflow::cli::sweep_cmds::{run_sweep_with, SweepArgs};
use xpflow::config::{ConfigError, SweepSpec};
use xpflow::observe::OutcomeKind;
use xpflow::store::{Format, Store};
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
    // sweeps/ and its study directories (sweeps/thesis/)
    let mut files: Vec<std::path::PathBuf> = Vec::new();
    for d in [dir.clone(), dir.join("thesis")] {
        files.extend(std::fs::read_dir(&d).unwrap().map(|e| e.unwrap().path()));
    }
    for path in files {
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
    let bad: [(&str, String, &str); 16] = [
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
            "extrapolated explicit coupling without solvent",
            GOOD.replace("beta = 0.1", "beta = 0.0").replace(
                "dt = 0.01",
                "dt = 0.01, coupling = \"explicit_extrapolated\"",
            ),
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
    assert!(before.contains("expected: no finished case"), "{before}");
    assert!(after.contains("expected:"), "{after}");
}

/// `--case`: only the selected cases run (by a prefix of the id), the sweep's others stay
/// registered and pending; an id that selects no case, or several, is refused before anything is
/// written.
#[test]
fn only_the_selected_cases_run() {
    let dir = scratch("select");
    let file = dir.join("s.toml");
    std::fs::write(&file, GOOD).unwrap();
    let db = dir.join("r.db");
    let cases = expand(&SweepSpec::from_file(&file).unwrap()).unwrap();
    let wanted = cases[1].id.clone();
    let runner = FakeRunner::new(|_| FakeBehaviour::Produce(OutcomeKind::Repel));
    for (given, why) in [("0000000000000000", "no case"), ("", "an empty id")] {
        let a = SweepArgs {
            cases: vec![given.into()],
            ..args(&file, &db)
        };
        let code = run_sweep_with(&a, &runner, &mut Vec::new()).unwrap();
        assert_eq!(code, ExitCode::from(2), "{why}");
        assert!(!db.exists(), "{why}: nothing may be written");
    }
    // a cluster submission runs whole sweeps
    let mut on_cluster = SweepArgs {
        cases: vec![wanted.clone()],
        ..args(&file, &db)
    };
    on_cluster.slurm.slurm = true;
    let code = run_sweep_with(&on_cluster, &runner, &mut Vec::new()).unwrap();
    assert_eq!(code, ExitCode::from(2));
    assert!(!db.exists());
    let a = SweepArgs {
        cases: vec![wanted[..6].to_string()],
        ..args(&file, &db)
    };
    // the listing shows the selected case alone
    let mut out = Vec::new();
    let dry = SweepArgs {
        dry_run: true,
        ..a.clone()
    };
    assert_eq!(
        run_sweep_with(&dry, &runner, &mut out).unwrap(),
        ExitCode::SUCCESS
    );
    let listing = String::from_utf8(out).unwrap();
    assert!(
        listing.contains(&wanted) && !listing.contains(&cases[0].id),
        "{listing}"
    );
    assert!(listing.contains("1 of the 2 cases"), "{listing}");
    let mut out = Vec::new();
    let quiet_summary = SweepArgs { quiet: false, ..a };
    assert_eq!(
        run_sweep_with(&quiet_summary, &runner, &mut out).unwrap(),
        ExitCode::SUCCESS
    );
    let summary = String::from_utf8(out).unwrap();
    assert!(
        summary.contains("1 run") && summary.contains("1 not selected"),
        "{summary}"
    );
    let store = Store::open_read_only(&db).unwrap();
    let status = |id: &str| -> String {
        store
            .connection()
            .query_row("SELECT status FROM cases WHERE case_hash = ?1", [id], |r| {
                r.get(0)
            })
            .unwrap()
    };
    assert_eq!(status(&wanted), "done");
    assert_eq!(status(&cases[0].id), "pending");
}

/// `--where wi=2` runs the sweep's Wi = 2 cases alone; a column that is not a parameter, a value
/// of no case, or nothing left beside `--case` is refused before anything is written.
#[test]
fn where_selects_cases_by_their_parameters() {
    let dir = scratch("where");
    let file = dir.join("s.toml");
    std::fs::write(&file, GOOD).unwrap();
    let db = dir.join("r.db");
    let cases = expand(&SweepSpec::from_file(&file).unwrap()).unwrap();
    let wi = |i: usize| cases[i].spec.fluid.wi;
    let (one, two) = if wi(0) == 2.0 { (1, 0) } else { (0, 1) };
    let runner = FakeRunner::new(|_| FakeBehaviour::Produce(OutcomeKind::Repel));
    let with = |filters: &[&str], ids: &[&str]| SweepArgs {
        filters: filters.iter().map(|f| f.to_string()).collect(),
        cases: ids.iter().map(|f| f.to_string()).collect(),
        ..args(&file, &db)
    };
    for (filters, ids) in [
        (&["status=done"][..], &[][..]),
        (&["wi=3"], &[]),
        (&["wi=two"], &[]),
        (&["wi=2"], &[cases[one].id.as_str()]),
    ] {
        let code = run_sweep_with(&with(filters, ids), &runner, &mut Vec::new()).unwrap();
        assert_eq!(
            code,
            ExitCode::from(2),
            "--where {filters:?} --case {ids:?}"
        );
        assert!(!db.exists(), "{filters:?}: nothing may be written");
    }
    // 2.0000000001 is 2 within the filter's relative 1e-9
    let code = run_sweep_with(
        &with(&["wi=2.0000000001", "n_particles=3"], &[]),
        &runner,
        &mut Vec::new(),
    );
    assert_eq!(code.unwrap(), ExitCode::SUCCESS);
    let store = Store::open_read_only(&db).unwrap();
    let status = |i: usize| -> String {
        store
            .connection()
            .query_row(
                "SELECT status FROM cases WHERE case_hash = ?1",
                [&cases[i].id],
                |r| r.get(0),
            )
            .unwrap()
    };
    assert_eq!(
        (status(two), status(one)),
        ("done".into(), "pending".into())
    );
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
            rows: None,
            cols: None,
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
        rows: None,
        cols: None,
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

/// `xpflow export`: the finished cases (done and failed) with their outcomes whole and their
/// trajectories thinned to at most `--samples` steps (first and last kept); the source is not
/// written to; an existing destination, an unknown sweep and too few samples exit 2.
#[test]
fn export_ships_the_finished_cases_thinned() {
    use xpflow::cli::export::{run_export_to, ExportArgs};
    let dir = scratch("export");
    let file = dir.join("s.toml");
    std::fs::write(
        &file,
        GOOD.replace("fluid.wi = [1, 2]", "fluid.wi = [1, 2, 3]"),
    )
    .unwrap();
    let db = dir.join("r.db");
    let runner = FakeRunner::new(|s| match s.fluid.wi {
        w if w > 2.5 => FakeBehaviour::Fail("fake".into()),
        w if w > 1.5 => FakeBehaviour::Produce(OutcomeKind::String),
        _ => FakeBehaviour::Produce(OutcomeKind::Repel),
    });
    run_sweep_with(&args(&file, &db), &runner, &mut Vec::new()).unwrap();
    let source_bytes = std::fs::read(&db).unwrap();
    let conn = |p: &Path| {
        rusqlite::Connection::open_with_flags(p, rusqlite::OpenFlags::SQLITE_OPEN_READ_ONLY)
            .unwrap()
    };
    let steps = |p: &Path| -> Vec<(String, i64, i64, i64)> {
        conn(p)
            .prepare(
                "SELECT c.case_hash, COUNT(DISTINCT s.step), MIN(s.step), MAX(s.step)
                 FROM cases c JOIN samples s ON s.case_id = c.id GROUP BY c.id ORDER BY c.case_hash",
            )
            .unwrap()
            .query_map([], |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?, r.get(3)?)))
            .unwrap()
            .map(|r| r.unwrap())
            .collect()
    };
    let export = |out: &Path, sweep: Vec<String>, thin: bool, samples: usize| {
        let a = ExportArgs {
            db: db.clone(),
            out: out.to_path_buf(),
            sweep,
            thin,
            samples,
        };
        let mut text = Vec::new();
        let code = run_export_to(&a, &mut text).unwrap();
        (code, String::from_utf8(text).unwrap())
    };
    let thin = dir.join("thin.db");
    let (code, text) = export(&thin, vec![], true, 5);
    assert_eq!(code, ExitCode::SUCCESS, "{text}");
    assert!(text.contains("exported 3 cases of 1 sweep"), "{text}");
    let (full, thinned) = (steps(&db), steps(&thin));
    assert_eq!(full.len(), thinned.len());
    for (f, t) in full.iter().zip(&thinned) {
        assert_eq!(
            (&f.0, f.2, f.3),
            (&t.0, t.2, t.3),
            "first and last step kept"
        );
        assert_eq!(t.1, f.1.min(5), "at most 5 sampled steps of {}", f.1);
    }
    assert!(
        full.iter().any(|f| f.1 > 5),
        "the fake trajectories are longer than 5"
    );
    // outcomes, statuses and tables as in the source
    let table = |p: &Path| common::query(QueryWhat::Cases, p).1;
    assert_eq!(table(&db), table(&thin));
    assert!(table(&thin).contains("failed"));
    // whole trajectories without --thin; the source untouched
    let whole = dir.join("whole.db");
    assert_eq!(
        export(&whole, vec!["cli".into()], false, 500).0,
        ExitCode::SUCCESS
    );
    assert_eq!(steps(&whole), full);
    assert_eq!(
        std::fs::read(&db).unwrap(),
        source_bytes,
        "a reader never writes"
    );
    // refusals
    assert_eq!(export(&thin, vec![], true, 5).0, ExitCode::from(2));
    assert_eq!(
        export(&dir.join("x.db"), vec!["nope".into()], true, 5).0,
        ExitCode::from(2)
    );
    assert_eq!(
        export(&dir.join("y.db"), vec![], true, 1).0,
        ExitCode::from(2)
    );
    assert!(!dir.join("x.db").exists() && !dir.join("y.db").exists());
    // a rerun of the sweep with a file that expands to other cases unlinks the finished ones;
    // the export still ships them (their results are the sweep's)
    std::fs::write(&file, GOOD.replace("fluid.wi = [1, 2]", "fluid.wi = [4]")).unwrap();
    run_sweep_with(&args(&file, &db), &runner, &mut Vec::new()).unwrap();
    let after = dir.join("after.db");
    let (code, text) = export(&after, vec![], true, 5);
    assert_eq!(code, ExitCode::SUCCESS, "{text}");
    assert!(text.contains("exported 4 cases of 1 sweep"), "{text}");
    // a case the sweep lists that has not run is listed as pending, without results
    let extra = SweepSpec::from_str(
        &GOOD.replace("fluid.wi = [1, 2]", "fluid.wi = [5]"),
        false,
        &file,
    )
    .unwrap();
    {
        let mut store = Store::open(&db).unwrap();
        let id = store.register_sweep(&extra).unwrap();
        store
            .link_cases(id, &xpflow::sweep::expand(&extra).unwrap())
            .unwrap();
    }
    let open = dir.join("open.db");
    let (code, text) = export(&open, vec![], true, 5);
    assert_eq!(code, ExitCode::SUCCESS, "{text}");
    assert!(
        text.contains("exported 4 cases")
            && text.contains("1 unfinished case(s) listed as pending"),
        "{text}"
    );
    let listed = table(&open);
    assert!(
        listed.contains("wi=5") && listed.contains("pending"),
        "{listed}"
    );
}
