//! The store and the sweep under hostile use (issue 28): a database deleted while a sweep writes
//! to it, readers on foreign, non-SQLite and shared databases, snapshot and state directories that
//! cannot be written, a case run by another process, cases too large for the machine. Each test
//! failed on main before the issue's fixes. Fake runners, tiny sweeps: seconds in all.

mod common;
use common::{query, Scratch};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::Duration;

use xpflow::cli::query_cmds::QueryWhat;
use xpflow::cli::status_cmds::{run_status_to, StatusArgs};
use xpflow::cli::sweep_cmds::{run_sweep_with, SweepArgs};
use xpflow::observe::OutcomeKind;
use xpflow::store::Store;
use xpflow::sweep::{FakeBehaviour, FakeRunner};

fn scratch(name: &str) -> Scratch {
    Scratch::new("hostile-store", name)
}

/// A shear sweep named `name` over Wi (`wi`, a TOML list) with `steps` steps and `output`
/// settings.
fn sweep_file(dir: &Path, name: &str, wi: &str, steps: u32, output: &str) -> PathBuf {
    let file = dir.join(format!("{name}.toml"));
    std::fs::write(
        &file,
        format!(
            r#"
name = "{name}"
[base]
geometry.confined_shear = {{ h = 1.0, l = 4.0 }}
fluid = {{ model = "giesekus", wi = 1.0, alpha = 0.01, beta = 0.1 }}
particles = {{ radius = 0.1, layout.string = {{ n = 2, lx = 0.5, ly = 0.1 }} }}
numerics = {{ mesh = [40, 10], dt = 0.01, t_end = {t_end} }}
output = {{ sample_every = 5{output} }}
[axes]
fluid.wi = {wi}
"#,
            t_end = f64::from(steps) * 0.01
        ),
    )
    .unwrap();
    file
}

fn args(file: &Path, db: &Path) -> SweepArgs {
    SweepArgs {
        quiet: false,
        ..common::sweep_args(file, db)
    }
}

fn timeout_runner() -> FakeRunner {
    FakeRunner::new(|_| FakeBehaviour::Produce(OutcomeKind::Timeout))
}

fn status(db: &Path) -> ExitCode {
    run_status_to(
        &StatusArgs {
            db: vec![db.into()],
            submission: vec![],
        },
        &mut Vec::new(),
    )
    .unwrap()
}

fn column<T: rusqlite::types::FromSql>(db: &Path, sql: &str) -> Vec<T> {
    let store = Store::open_read_only(db).unwrap();
    let mut st = store.connection().prepare(sql).unwrap();
    st.query_map([], |r| r.get(0))
        .unwrap()
        .map(Result::unwrap)
        .collect()
}

/// Issue 28 item 1: deleting `X.db`, `-wal` and `-shm` during a 6-case sweep with 2 jobs ended
/// with exit 0, "6 cases, 2 run, 0 failed, 4 skipped" and 0 cases in any database. Now the sweep
/// fails, saying the database was deleted, and no worker recreates an empty one.
#[test]
fn a_database_deleted_during_the_sweep_is_an_error() {
    let dir = scratch("deleted");
    let file = sweep_file(&dir, "gone", "[1, 2, 3, 4, 5, 6]", 40, "");
    let db = dir.join("gone.db");
    let started = Arc::new(AtomicUsize::new(0));
    let (counter, victim) = (started.clone(), db.clone());
    let mut runner = FakeRunner::new(move |_| {
        // the third case to start deletes the database under the sweep
        if counter.fetch_add(1, Ordering::SeqCst) == 2 {
            for ext in ["", "-wal", "-shm"] {
                let mut p = victim.clone().into_os_string();
                p.push(ext);
                std::fs::remove_file(PathBuf::from(p)).ok();
            }
        }
        FakeBehaviour::Produce(OutcomeKind::Timeout)
    });
    runner.step_delay = Duration::from_millis(2);
    let result = run_sweep_with(&args(&file, &db), &runner, &mut Vec::new());
    let err = result.expect_err("a sweep whose database vanished must not succeed");
    let text = format!("{err:#}");
    assert!(text.contains("deleted or replaced"), "{text}");
    assert!(
        !db.exists(),
        "a worker recreated the deleted database: {}",
        db.display()
    );
}

/// Issue 28 item 2: `query` and `status` rewrote `meta` on every call, added the xpflow schema to a
/// foreign SQLite file (exit 0), and failed on a read-only database. Now they open read-only: the
/// file's bytes and `meta` stay, no -wal/-shm files appear, and a file that is not an xpflow
/// database is refused with exit 2 and left as it was.
#[test]
fn readers_leave_the_database_as_it_is() {
    let dir = scratch("readers");
    let file = sweep_file(&dir, "read", "[1, 2]", 20, "");
    let db = dir.join("read.db");
    let code = run_sweep_with(&args(&file, &db), &timeout_runner(), &mut Vec::new()).unwrap();
    assert_eq!(code, ExitCode::SUCCESS);
    {
        let store = Store::open(&db).unwrap();
        store
            .connection()
            .execute(
                "UPDATE meta SET value = 'sentinel' WHERE key = 'last_machine'",
                [],
            )
            .unwrap();
    }
    let before = std::fs::read(&db).unwrap();
    for what in [QueryWhat::Cases, QueryWhat::Strings, QueryWhat::Final] {
        assert_eq!(query(what, &db).0, ExitCode::SUCCESS);
    }
    assert_eq!(status(&db), ExitCode::SUCCESS);
    assert_eq!(
        std::fs::read(&db).unwrap(),
        before,
        "a reader changed the file"
    );
    for side in ["read.db-wal", "read.db-shm"] {
        assert!(!dir.join(side).exists(), "a reader created {side}");
    }
    let machine: Vec<String> = column(&db, "SELECT value FROM meta WHERE key = 'last_machine'");
    assert_eq!(machine, ["sentinel"]);

    // an SQLite database of another program: refused, untouched
    let foreign = dir.join("other.db");
    rusqlite::Connection::open(&foreign)
        .unwrap()
        .execute_batch("CREATE TABLE foo (a)")
        .unwrap();
    let before = std::fs::read(&foreign).unwrap();
    assert_eq!(query(QueryWhat::Cases, &foreign).0, ExitCode::from(2));
    assert_eq!(status(&foreign), ExitCode::from(2));
    let code = run_sweep_with(&args(&file, &foreign), &timeout_runner(), &mut Vec::new()).unwrap();
    assert_eq!(code, ExitCode::from(2), "a sweep into a foreign database");
    assert_eq!(std::fs::read(&foreign).unwrap(), before);
    let tables: Vec<String> = {
        let c = rusqlite::Connection::open(&foreign).unwrap();
        let mut st = c.prepare("SELECT name FROM sqlite_master").unwrap();
        st.query_map([], |r| r.get(0))
            .unwrap()
            .map(Result::unwrap)
            .collect()
    };
    assert_eq!(tables, ["foo"]);
}

/// Issue 28 item 9: a `--db` that is not SQLite exited 1 and said "file is not a database: file is
/// not a database: Error code 26". Now every command exits 2 with one message, and the file stays.
#[test]
fn a_file_that_is_not_sqlite_is_refused_once_with_exit_2() {
    let dir = scratch("not-sqlite");
    let file = sweep_file(&dir, "text", "[1]", 10, "");
    let db = dir.join("notes.db");
    std::fs::write(&db, "these are my notes, not a database\n".repeat(200)).unwrap();
    let before = std::fs::read(&db).unwrap();
    assert_eq!(query(QueryWhat::Cases, &db).0, ExitCode::from(2));
    assert_eq!(status(&db), ExitCode::from(2));
    let code = run_sweep_with(&args(&file, &db), &timeout_runner(), &mut Vec::new()).unwrap();
    assert_eq!(code, ExitCode::from(2));
    assert_eq!(std::fs::read(&db).unwrap(), before);
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_xpflow"))
        .args(["query", "cases", "--db"])
        .arg(&db)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(stderr.lines().count(), 1, "one message: {stderr}");
    assert!(stderr.contains("is not an SQLite database"), "{stderr}");
}

/// Issue 28 item 3: with the snapshot or the saved-state directory not writable the sweep said
/// "0 failed" and exited 0. Now such a case stops at the first write that fails, is recorded as
/// failed with the error, and the sweep exits 1.
#[test]
fn snapshot_and_state_write_failures_fail_the_case() {
    const STEPS: u32 = 40;
    let dir = scratch("unwritable");
    // snapshots go to <db dir>/<sweep name>/: a file is in the way
    let file = sweep_file(&dir, "snap", "[1, 2]", STEPS, ", snapshot_every = 2");
    std::fs::write(dir.join("snap"), "in the way").unwrap();
    let db = dir.join("r.db");
    let code = run_sweep_with(&args(&file, &db), &timeout_runner(), &mut Vec::new()).unwrap();
    assert_eq!(code, ExitCode::FAILURE);
    let rows: Vec<(String, String, i64)> = {
        let store = Store::open_read_only(&db).unwrap();
        let mut st = store
            .connection()
            .prepare("SELECT status, error, steps FROM cases")
            .unwrap();
        st.query_map([], |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?)))
            .unwrap()
            .map(Result::unwrap)
            .collect()
    };
    assert_eq!(rows.len(), 2);
    for (status, error, steps) in rows {
        assert_eq!(status, "failed");
        assert!(error.starts_with("snapshot: "), "{error}");
        assert!(
            steps < i64::from(STEPS),
            "the case went on after the failure"
        );
    }
    // saved states go to <db dir>/<db stem>/: a file is in the way
    let file = sweep_file(&dir, "state", "[1, 2]", STEPS, "");
    let db = dir.join("s.db");
    std::fs::write(dir.join("s"), "in the way").unwrap();
    let mut a = args(&file, &db);
    a.state_every = 0.0;
    let code = run_sweep_with(&a, &timeout_runner(), &mut Vec::new()).unwrap();
    assert_eq!(code, ExitCode::FAILURE);
    let errors: Vec<String> = column(&db, "SELECT error FROM cases WHERE status = 'failed'");
    assert_eq!(errors.len(), 2);
    assert!(
        errors.iter().all(|e| e.starts_with("saved state: ")),
        "{errors:?}"
    );
}

/// Issue 28 item 9: a case that another process runs was counted as "skipped". Now the summary
/// says "running elsewhere".
#[test]
fn a_case_run_by_another_process_is_running_elsewhere() {
    let dir = scratch("elsewhere");
    let file = sweep_file(&dir, "busy", "[1, 2, 3, 4]", 10, "");
    let db = dir.join("busy.db");
    run_sweep_with(&args(&file, &db), &timeout_runner(), &mut Vec::new()).unwrap();
    Store::open(&db)
        .unwrap()
        .connection()
        .execute(
            "UPDATE cases SET status = 'running', owner = 'another-host:1', owner_pid = 1
             WHERE wi = 2",
            [],
        )
        .unwrap();
    let mut out = Vec::new();
    let code = run_sweep_with(&args(&file, &db), &timeout_runner(), &mut out).unwrap();
    assert_eq!(code, ExitCode::SUCCESS);
    let text = String::from_utf8(out).unwrap();
    assert!(
        text.contains("3 skipped (done before), 1 running elsewhere"),
        "{text}"
    );
}

/// Issue 28 item 4: `mesh = [20000, 5000]` passed validation and aborted the sweep (exit 134,
/// the case left running, every rerun the same). Now it is refused before anything is written,
/// and so is a case above the memory limit (`--max-memory`).
#[test]
fn a_case_too_large_for_the_machine_is_refused_before_anything_is_written() {
    let dir = scratch("too-large");
    let file = sweep_file(&dir, "huge", "[1]", 10, "");
    let text = std::fs::read_to_string(&file).unwrap();
    let db = dir.join("huge.db");
    for (what, mesh, max_memory) in [
        ("10^8 elements", "[20000, 5000]", None),
        (
            "400×100 semi-implicit (~14 GB) over 1 GB",
            "[400, 100], coupling = \"semi_implicit\"",
            Some(1.0),
        ),
    ] {
        let big = text
            .replace("mesh = [40, 10]", &format!("mesh = {mesh}"))
            .replace("beta = 0.1", "beta = 0.0")
            .replace("dt = 0.01", "dt = 0.001");
        std::fs::write(&file, big).unwrap();
        let mut a = args(&file, &db);
        a.max_memory = max_memory;
        let code = run_sweep_with(&a, &timeout_runner(), &mut Vec::new()).unwrap();
        assert_eq!(code, ExitCode::from(2), "{what}");
        assert!(!db.exists(), "{what}: nothing may be written");
    }
    // the JSON spelling of the issue: 4·10⁹ elements along x
    let json = dir.join("huge.json");
    let v = serde_json::json!({
        "name": "huge",
        "base": {
            "geometry": {"confined_shear": {"h": 1.0, "l": 4.0}},
            "fluid": {"model": "newtonian", "wi": 0.0},
            "particles": {"radius": 0.1, "layout": {"pair": {"lx": 0.5, "ly": 0.08}}},
            "numerics": {"mesh": [4_000_000_000_u64, 10], "dt": 0.1, "t_end": 1.0}
        }
    });
    std::fs::write(&json, v.to_string()).unwrap();
    let code = run_sweep_with(&args(&json, &db), &timeout_runner(), &mut Vec::new()).unwrap();
    assert_eq!(code, ExitCode::from(2));
    assert!(!db.exists());
}
