//! Sweep engine end to end with fake runners: outcomes and divergence, resume after `kill -9`, two sweeps
//! writing one database at once.

mod common;
use common::Scratch;
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use xpflow::cli::status_cmds::{run_status_to, StatusArgs};
use xpflow::config::{CaseSpec, SweepSpec};
use xpflow::observe::OutcomeKind;
use xpflow::store::query::{CaseAxis, QueryKind};
use xpflow::store::{Format, Store};
use xpflow::sweep::engine::{failed_state_path, resume_path};
use xpflow::sweep::{case_id, expand, run_sweep, FakeBehaviour, FakeRunner, SweepOptions};

/// Environment variable that turns the ignored `kill_child` test into the child of the kill test.
const CHILD_ENV: &str = "XPFLOW_KILL_CHILD";
/// Fake step delay in the killed child: 40 steps × 10 ms ≈ 0.4 s per case.
const CHILD_STEP_DELAY: Duration = Duration::from_millis(10);
/// How long the kill test waits for the child to finish some cases before giving up.
const CHILD_DEADLINE: Duration = Duration::from_secs(60);

fn scratch(name: &str) -> Scratch {
    Scratch::new("test", name)
}

/// A shear sweep over Wi × N with t_end = steps·dt.
fn sweep_text(name: &str, wi: &str, n: &str, steps: u32) -> String {
    format!(
        r#"
name = "{name}"
[base]
geometry.confined_shear = {{ h = 1.0, l = 4.0 }}
fluid = {{ model = "giesekus", wi = 1.0, alpha = 0.01, beta = 0.1 }}
particles = {{ radius = 0.1, layout.string = {{ n = 2, lx = 0.5, ly = 0.1 }} }}
numerics = {{ mesh = [40, 10], dt = 0.01, t_end = {t_end} }}
output = {{ sample_every = 5, snapshot_every = 0 }}
[axes]
fluid.wi = {wi}
particles.layout.string.n = {n}
"#,
        t_end = f64::from(steps) * 0.01
    )
}

fn parse(text: &str, dir: &Path) -> SweepSpec {
    let file = dir.join("sweep.toml");
    std::fs::write(&file, text).unwrap();
    SweepSpec::from_file(&file).unwrap()
}

/// Behaviour by Wi: 1 repel, 2 string, 3 reported divergence, 4 panic (a failure, not physics),
/// 5 NaN states, other timeout.
fn by_wi(spec: &CaseSpec) -> FakeBehaviour {
    match spec.fluid.wi as i64 {
        1 => FakeBehaviour::Produce(OutcomeKind::Repel),
        2 => FakeBehaviour::Produce(OutcomeKind::String),
        3 => FakeBehaviour::Diverge("step 5: log-conformation not finite at vertex 12".into()),
        4 => FakeBehaviour::Panic,
        5 => FakeBehaviour::Produce(OutcomeKind::Diverged),
        _ => FakeBehaviour::Produce(OutcomeKind::Timeout),
    }
}

fn opts(db: &Path, jobs: usize) -> SweepOptions {
    let mut o = SweepOptions::new(db.to_path_buf());
    o.jobs = jobs;
    o.progress = xpflow::sweep::progress::ProgressMode::Quiet;
    o
}

fn scalar<T: rusqlite::types::FromSql>(store: &Store, sql: &str) -> T {
    store.connection().query_row(sql, [], |r| r.get(0)).unwrap()
}

#[test]
fn outcomes_divergence_and_rerun() {
    let dir = scratch("outcomes");
    let sweep = parse(
        &sweep_text("outcomes", "[1, 2, 3, 4, 5]", "[2, 3]", 3000),
        &dir,
    );
    let cases = expand(&sweep).unwrap();
    let db = dir.join("r.db");
    let s = run_sweep(&sweep, &cases, &FakeRunner::new(by_wi), &opts(&db, 2)).unwrap();
    assert_eq!((s.total, s.ran, s.failed), (10, 10, 2));
    let store = Store::open(&db).unwrap();
    let kind_of = |wi: f64, n: i64| -> (String, Option<String>) {
        store
            .connection()
            .query_row(
                "SELECT o.kind, c.error FROM cases c JOIN outcomes o ON o.case_id = c.id WHERE c.wi = ?1 AND c.n_particles = ?2",
                rusqlite::params![wi, n],
                |r| Ok((r.get(0)?, r.get(1)?)),
            )
            .unwrap()
    };
    for n in [2, 3] {
        assert_eq!(kind_of(1.0, n).0, "repel");
        assert_eq!(kind_of(2.0, n).0, "string");
        let (k, e) = kind_of(3.0, n);
        assert_eq!(k, "diverged");
        assert!(e.unwrap().contains("log-conformation not finite"));
        // a panic is a failure of the code: status failed, no outcome, the message kept
        let (status, e): (String, String) = store
            .connection()
            .query_row(
                "SELECT status, error FROM cases WHERE wi = 4.0 AND n_particles = ?1",
                [n],
                |r| Ok((r.get(0)?, r.get(1)?)),
            )
            .unwrap();
        assert_eq!(status, "failed");
        assert!(e.contains("panicked at step"), "{e}");
        let (k, e) = kind_of(5.0, n);
        assert_eq!(k, "diverged");
        assert!(e.unwrap().contains("non-finite"));
    }
    // Strings stop early (t ≈ 10 of 30) and their samples are stored every 5 steps plus the last one.
    let t: f64 = scalar(&store, "SELECT MAX(t_reached) FROM cases WHERE wi = 2");
    assert!(t < 20.0, "early stop: t = {t}");
    let steps: i64 = scalar(
        &store,
        "SELECT MIN(step) FROM samples JOIN cases c ON c.id = case_id WHERE c.wi = 2",
    );
    assert_eq!(steps, 5);
    // A diverged case keeps its last state before the failure (step 4), not a multiple of 5.
    let last: i64 = scalar(
        &store,
        "SELECT MAX(step) FROM samples JOIN cases c ON c.id = case_id WHERE c.wi = 3",
    );
    assert_eq!(last, 4);
    // Table 5.2-style query.
    let table = store
        .query(&QueryKind::StringFormation, Some("outcomes"), &[])
        .unwrap();
    let csv = table.render(Format::Csv);
    assert!(csv.starts_with("Wi,N=2,N=3\n1.0,-,-\n2.0,+,+\n"), "{csv}");
    // the outcomes pivoted on a case-file setting read from the stored case: N by its path
    let by_setting = QueryKind::Outcomes {
        rows: CaseAxis::parse("wi").unwrap(),
        cols: CaseAxis::parse("particles.layout.string.n").unwrap(),
    };
    let csv = store
        .query(&by_setting, Some("outcomes"), &[])
        .unwrap()
        .render(Format::Csv);
    let head = "wi,particles.layout.string.n=2,particles.layout.string.n=3\n";
    assert!(csv.starts_with(head), "{csv}");
    assert!(csv.contains("\n2.0,string "), "{csv}");
    assert!(CaseAxis::parse("particles.Layout").is_err() && CaseAxis::parse("x").is_err());
    // a string that formed on a gap of fewer than two elements is marked '+?' (the fake runner
    // has no mesh: the warning is written as the classifier would)
    store
        .connection()
        .execute(
            "UPDATE outcomes SET final_json = json_set(final_json, '$.warning', 'the narrowest gap \
             had 0.90 elements across it') WHERE case_id IN (SELECT id FROM cases WHERE wi = 2 \
             AND n_particles = 2)",
            [],
        )
        .unwrap();
    let table = store
        .query(&QueryKind::StringFormation, Some("outcomes"), &[])
        .unwrap();
    let csv = table.render(Format::Csv);
    assert!(csv.starts_with("Wi,N=2,N=3\n1.0,-,-\n2.0,+?,+\n"), "{csv}");
    // a cell of several cases (initial positions) is '-' only when all of them ended without a
    // string: the failed Wi = 4 case moved into the cell of a repelling one makes it undecided
    let move_failed = |wi: f64| {
        store
            .connection()
            .execute(
                "UPDATE cases SET wi = ?1 WHERE status = 'failed' AND n_particles = 2",
                [wi],
            )
            .unwrap()
    };
    assert_eq!(move_failed(1.0), 1);
    let csv = store
        .query(&QueryKind::StringFormation, Some("outcomes"), &[])
        .unwrap()
        .render(Format::Csv);
    assert!(csv.starts_with("Wi,N=2,N=3\n1.0,?,-\n2.0,+?,+\n"), "{csv}");
    assert_eq!(move_failed(4.0), 1);
    let filtered = store
        .query(&QueryKind::Cases, None, &["wi=2".parse().unwrap()])
        .unwrap();
    assert_eq!(filtered.rows.len(), 2);
    // Rerun: nothing to do.
    let again = run_sweep(&sweep, &cases, &FakeRunner::new(by_wi), &opts(&db, 2)).unwrap();
    assert_eq!((again.ran, again.skipped), (0, 10));
    // the two failed (panicked) cases have no outcome
    let n: i64 = scalar(&store, "SELECT COUNT(*) FROM outcomes");
    assert_eq!(n, 8);
    assert_eq!(store.integrity_check().unwrap(), "ok");
}

#[test]
fn an_edited_sweep_lists_its_current_cases_and_keeps_the_old_results() {
    let dir = scratch("edited");
    let db = dir.join("r.db");
    let run = |wi: &str| {
        let sweep = parse(&sweep_text("edited", wi, "[2]", 300), &dir);
        let cases = expand(&sweep).unwrap();
        run_sweep(&sweep, &cases, &FakeRunner::new(by_wi), &opts(&db, 1)).unwrap()
    };
    assert_eq!(run("[1, 2]").ran, 2);
    // the file now sweeps Wi = 2 and 6: Wi = 2 is done already, Wi = 1 is no longer part of it
    let s = run("[2, 6]");
    assert_eq!((s.ran, s.skipped), (1, 1));
    let store = Store::open(&db).unwrap();
    let listed = store.query(&QueryKind::Cases, Some("edited"), &[]).unwrap();
    let labels: BTreeSet<String> = listed
        .rows
        .iter()
        .map(|r| r[1].as_str().unwrap().to_string())
        .collect();
    assert_eq!(
        labels,
        BTreeSet::from(["wi=2 n=2".into(), "wi=6 n=2".into()])
    );
    let all = store.query(&QueryKind::Cases, None, &[]).unwrap();
    assert_eq!(all.rows.len(), 3, "the Wi = 1 results stay in the database");
}

/// Child half of the kill test: runs a slow sweep until killed. Does nothing unless started by the parent.
#[test]
#[ignore = "child process of kill_minus_9_then_resume"]
fn kill_child() {
    let Ok(dir) = std::env::var(CHILD_ENV) else {
        return;
    };
    let dir = PathBuf::from(dir);
    let sweep = SweepSpec::from_file(&dir.join("sweep.toml")).unwrap();
    let cases = expand(&sweep).unwrap();
    let mut runner = FakeRunner::new(|_| FakeBehaviour::Produce(OutcomeKind::Timeout));
    runner.step_delay = CHILD_STEP_DELAY;
    run_sweep(&sweep, &cases, &runner, &opts(&dir.join("r.db"), 2)).unwrap();
}

#[test]
fn kill_minus_9_then_resume() {
    let dir = scratch("kill");
    let sweep = parse(&sweep_text("kill", "[1, 2, 3, 4]", "[2, 3, 4]", 40), &dir);
    let cases = expand(&sweep).unwrap();
    let db = dir.join("r.db");
    let mut child = std::process::Command::new(std::env::current_exe().unwrap())
        .args([
            "--exact",
            "kill_child",
            "--ignored",
            "--nocapture",
            "--test-threads",
            "1",
        ])
        .env(CHILD_ENV, &*dir)
        .stdout(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let start = Instant::now();
    loop {
        std::thread::sleep(Duration::from_millis(50));
        let done: i64 = Store::open(&db)
            .ok()
            .and_then(|s| {
                s.connection()
                    .query_row(
                        "SELECT COUNT(*) FROM cases WHERE status = 'done'",
                        [],
                        |r| r.get(0),
                    )
                    .ok()
            })
            .unwrap_or(0);
        if done >= 3 {
            break;
        }
        assert!(start.elapsed() < CHILD_DEADLINE, "child made no progress");
        assert!(
            child.try_wait().unwrap().is_none(),
            "child exited before it was killed"
        );
    }
    child.kill().unwrap(); // SIGKILL
    child.wait().unwrap();

    let store = Store::open(&db).unwrap();
    assert_eq!(store.integrity_check().unwrap(), "ok");
    let hashes = |status: &str| -> BTreeSet<String> {
        let mut st = store
            .connection()
            .prepare("SELECT case_hash FROM cases WHERE status = ?1")
            .unwrap();
        st.query_map([status], |r| r.get(0))
            .unwrap()
            .map(Result::unwrap)
            .collect()
    };
    let done_before = hashes("done");
    let running_before = hashes("running");
    assert!(
        done_before.len() >= 3 && done_before.len() < cases.len(),
        "{}",
        done_before.len()
    );
    // `query cases` tells the killed sweep's in-flight cases from running ones
    let listed = store.query(&QueryKind::Cases, None, &[]).unwrap();
    let interrupted: BTreeSet<String> = listed
        .rows
        .iter()
        .filter(|r| r[2] == "interrupted")
        .map(|r| r[0].as_str().unwrap().to_string())
        .collect();
    assert_eq!(interrupted, running_before);
    assert!(listed.rows.iter().all(|r| r[2] != "running"));
    let finished_at_before: Vec<String> = {
        let mut st = store
            .connection()
            .prepare("SELECT finished_at FROM cases WHERE status = 'done' ORDER BY case_hash")
            .unwrap();
        st.query_map([], |r| r.get(0))
            .unwrap()
            .map(Result::unwrap)
            .collect()
    };

    // Resume in-process, recording which cases the runner is asked to run.
    let ran: std::sync::Arc<Mutex<Vec<String>>> = Default::default();
    let log = ran.clone();
    let runner = FakeRunner::new(move |spec| {
        log.lock().unwrap().push(case_id(spec));
        FakeBehaviour::Produce(OutcomeKind::Timeout)
    });
    let s = run_sweep(&sweep, &cases, &runner, &opts(&db, 2)).unwrap();
    assert_eq!(s.reset, running_before.len(), "in-flight cases are reset");
    let ran: BTreeSet<String> = ran.lock().unwrap().iter().cloned().collect();
    let all: BTreeSet<String> = cases.iter().map(|c| c.id.clone()).collect();
    assert_eq!(
        ran,
        &all - &done_before,
        "exactly the unfinished cases are run"
    );
    assert!(running_before.is_subset(&ran));
    assert_eq!(store.integrity_check().unwrap(), "ok");
    let rows: i64 = scalar(&store, "SELECT COUNT(*) FROM cases");
    let outcomes: i64 = scalar(&store, "SELECT COUNT(*) FROM outcomes");
    let distinct: i64 = scalar(&store, "SELECT COUNT(DISTINCT case_id) FROM outcomes");
    assert_eq!(
        (rows, outcomes, distinct),
        (12, 12, 12),
        "every case exactly once"
    );
    let finished_at_after: Vec<String> = {
        let mut st = store
            .connection()
            .prepare("SELECT finished_at FROM cases WHERE case_hash = ?1")
            .unwrap();
        done_before
            .iter()
            .map(|h| st.query_row([h], |r| r.get(0)).unwrap())
            .collect()
    };
    assert_eq!(
        finished_at_before, finished_at_after,
        "finished cases are untouched"
    );
    // Every case has its 8 samples (steps 5..40) per particle, no leftovers from the killed attempt.
    let bad: i64 = scalar(
        &store,
        "SELECT COUNT(*) FROM (SELECT c.id FROM cases c LEFT JOIN samples s ON s.case_id = c.id
         GROUP BY c.id HAVING COUNT(s.step) != 8 * c.n_particles)",
    );
    assert_eq!(bad, 0);
}

#[test]
fn two_sweeps_write_one_database_at_once() {
    let dir = scratch("concurrent");
    let a = parse(&sweep_text("a", "[1, 2, 6]", "[2, 3]", 200), &dir);
    // Sweep b shares the cases with wi = 6 with sweep a; they must be run once.
    let b = parse(&sweep_text("b", "[6, 7, 8]", "[2, 3]", 200), &dir);
    let db = dir.join("shared.db");
    let (ca, cb) = (expand(&a).unwrap(), expand(&b).unwrap());
    let runner = FakeRunner::new(by_wi);
    let (sa, sb) = std::thread::scope(|s| {
        let ha = s.spawn(|| run_sweep(&a, &ca, &runner, &opts(&db, 2)).unwrap());
        let hb = s.spawn(|| run_sweep(&b, &cb, &runner, &opts(&db, 2)).unwrap());
        (ha.join().unwrap(), hb.join().unwrap())
    });
    assert_eq!(sa.ran + sb.ran, 10, "12 case slots, 2 shared");
    let store = Store::open(&db).unwrap();
    assert_eq!(store.integrity_check().unwrap(), "ok");
    let counts = store.counts(None).unwrap();
    assert_eq!(counts.len(), 2);
    for c in counts {
        assert_eq!(
            (c.total, c.done, c.running, c.pending, c.failed),
            (6, 6, 0, 0, 0),
            "{}",
            c.name
        );
    }
    let outcomes: i64 = scalar(&store, "SELECT COUNT(*) FROM outcomes");
    assert_eq!(outcomes, 10);
}

/// A case that fails (a panic) or diverges keeps its last saved state for a diagnosis, as
/// `<hash>.failed.resume.json`; renamed back to `<hash>.resume.json`, `--retry-failed` continues
/// the failed case from it; a case that runs through keeps none.
#[test]
fn a_failed_case_keeps_its_last_saved_state() {
    let dir = scratch("kept_state");
    let sweep = parse(&sweep_text("kept_state", "[3, 4, 6]", "[2]", 30), &dir);
    let cases = expand(&sweep).unwrap();
    let db = dir.join("r.db");
    let mut o = opts(&db, 1);
    o.state_every = Duration::ZERO;
    let s = run_sweep(&sweep, &cases, &FakeRunner::new(by_wi), &o).unwrap();
    assert_eq!((s.ran, s.failed), (3, 1));
    let id_of = |wi: f64| {
        cases
            .iter()
            .find(|c| c.spec.fluid.wi == wi)
            .unwrap()
            .id
            .clone()
    };
    let (diverged, panicked, ran_through) = (id_of(3.0), id_of(4.0), id_of(6.0));
    for id in [&diverged, &panicked] {
        let kept = failed_state_path(&db, id);
        let text = std::fs::read_to_string(&kept)
            .unwrap_or_else(|e| panic!("no kept state {}: {e}", kept.display()));
        // the fake runner's trouble comes at step 5: the last state saved is step 4's
        assert!(
            text.contains("\"step\":4"),
            "{}",
            &text[..text.len().min(200)]
        );
        assert!(!resume_path(&db, id).exists());
    }
    assert!(!failed_state_path(&db, &ran_through).exists());
    assert!(!resume_path(&db, &ran_through).exists());
    // `xpflow status` names them with the kept state
    let mut listing = Vec::new();
    let status_args = StatusArgs {
        db: vec![db.clone()],
        submission: vec![],
    };
    run_status_to(&status_args, &mut listing).unwrap();
    let listing = String::from_utf8(listing).unwrap();
    let failed_part = listing
        .split("failed or diverged cases")
        .nth(1)
        .unwrap_or_else(|| panic!("no failed cases listed:\n{listing}"));
    for id in [&diverged, &panicked] {
        let row = failed_part
            .lines()
            .find(|l| l.contains(id.as_str()))
            .unwrap_or_else(|| panic!("{id} not listed:\n{listing}"));
        assert!(row.contains("step 4, t = "), "{row}");
    }
    assert!(!failed_part.contains(ran_through.as_str()), "{listing}");
    // after a fix, the failed case continues from its kept state
    std::fs::rename(
        failed_state_path(&db, &panicked),
        resume_path(&db, &panicked),
    )
    .unwrap();
    o.retry_failed = true;
    let fixed = FakeRunner::new(|_| FakeBehaviour::Produce(OutcomeKind::Timeout));
    let again = run_sweep(&sweep, &cases, &fixed, &o).unwrap();
    assert_eq!((again.ran, again.failed), (1, 0));
    let store = Store::open(&db).unwrap();
    let first: i64 = scalar(
        &store,
        "SELECT MIN(step) FROM samples JOIN cases c ON c.id = case_id WHERE c.wi = 4",
    );
    let status: String = scalar(&store, "SELECT status FROM cases WHERE wi = 4");
    assert_eq!((first, status.as_str()), (4, "done"), "resumed at step 5");
    assert!(!failed_state_path(&db, &panicked).exists());
}
