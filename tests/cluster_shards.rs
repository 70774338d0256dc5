//! The cluster path without a scheduler: tasks (`xpflow run-case`) writing shards through the
//! sweep engine, `xpflow merge` (idempotent, conflicts kept apart, damaged shards refused),
//! `xpflow status --submission` over shards and markers, and a killed task that continues from
//! its published state when it runs again.

mod common;
use common::{trajectory, Scratch};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use xpflow::cli::cluster::{merge_to, run_case_with, MergeArgs, RunCaseArgs};
use xpflow::cli::status_cmds::{run_status_to, StatusArgs};
use xpflow::cli::sweep_cmds::run_sweep_with;
use xpflow::config::SweepSpec;
use xpflow::observe::OutcomeKind;
use xpflow::store::Store;
use xpflow::sweep::slurm::script::Resources;
use xpflow::sweep::slurm::{write_round, Submission};
use xpflow::sweep::{expand, FakeBehaviour, FakeRunner, PlannedCase};

const SWEEP: &str = r#"
name = "shards"
[base]
geometry.confined_shear = { h = 1.0, l = 4.0 }
fluid = { model = "giesekus", wi = 1.0, alpha = 0.01, beta = 0.1 }
particles = { radius = 0.1, layout.string = { n = 2, lx = 0.5, ly = 0.1 } }
numerics = { mesh = [40, 10], dt = 0.01, t_end = 0.5 }
output = { sample_every = 5 }
[axes]
fluid.wi = [1, 2, 3, 4]
"#;

/// Wi 1 repel, 2 string, 3 fails, 4 timeout.
fn runner() -> FakeRunner {
    FakeRunner::new(|s| match s.fluid.wi as i64 {
        1 => FakeBehaviour::Produce(OutcomeKind::Repel),
        2 => FakeBehaviour::Produce(OutcomeKind::String),
        3 => FakeBehaviour::Fail("solve failed at step 0".into()),
        _ => FakeBehaviour::Produce(OutcomeKind::Timeout),
    })
}

/// Every case succeeds (Wi 3 too: a resubmission after the fault was fixed).
fn fixed_runner() -> FakeRunner {
    FakeRunner::new(|_| FakeBehaviour::Produce(OutcomeKind::Timeout))
}

/// A submission of every case of `text` (one round, written as `xpflow sweep --slurm` does).
fn submission(dir: &Path, text: &str) -> (Submission, Vec<PlannedCase>, PathBuf) {
    let file = dir.join("sweep.toml");
    std::fs::write(&file, text).unwrap();
    let spec = SweepSpec::from_file(&file).unwrap();
    let cases = expand(&spec).unwrap();
    let sub = Submission::new(&dir.join("sub"));
    let refs: Vec<&PlannedCase> = cases.iter().collect();
    let res = Resources {
        time: "10".into(),
        mem: "100M".into(),
        ..Resources::default()
    };
    let round = write_round(&sub, &file, &spec.name, &refs, &res, 1001).unwrap();
    (sub, cases, round.dir.join("manifest.txt"))
}

fn task(manifest: &Path, index: usize, sub: &Submission, local: &Path) -> RunCaseArgs {
    RunCaseArgs {
        manifest: manifest.into(),
        index,
        shards: sub.shards(),
        local: Some(local.into()),
        state_every: 5.0,
        log: Some(sub.logs().join(format!("task-{index}.out"))),
        quiet: true,
    }
}

fn merge(db: &Path, shards: &Path) -> (ExitCode, String) {
    let mut out = Vec::new();
    let code = merge_to(
        &MergeArgs {
            db: db.into(),
            shards: vec![shards.into()],
        },
        &mut out,
    )
    .unwrap();
    (code, String::from_utf8(out).unwrap())
}

fn scalar(db: &Path, sql: &str) -> i64 {
    Store::open_read_only(db)
        .unwrap()
        .connection()
        .query_row(sql, [], |r| r.get(0))
        .unwrap()
}

fn status(sub: &Submission) -> String {
    let mut out = Vec::new();
    let args = StatusArgs {
        db: vec![],
        submission: vec![sub.dir.clone()],
    };
    assert_eq!(run_status_to(&args, &mut out).unwrap(), ExitCode::SUCCESS);
    String::from_utf8(out).unwrap()
}

/// Four tasks, one failing: its marker names the exit code and log; merging twice changes
/// nothing the second time; the failed case rerun after the fault is fixed replaces the failed
/// row; a damaged shard is refused while the others merge; shards of cases the database has
/// done are conflicts and leave its results as they were.
#[test]
fn merge_is_idempotent_and_keeps_conflicts_apart() {
    let dir = Scratch::new("cluster", "merge");
    let (sub, cases, manifest) = submission(&dir, SWEEP);
    let local = dir.join("tmp");
    for i in 0..cases.len() {
        let code = run_case_with(
            &task(&manifest, i, &sub, &local),
            &runner(),
            &mut Vec::new(),
        )
        .unwrap();
        let want = if i == 2 {
            ExitCode::FAILURE
        } else {
            ExitCode::SUCCESS
        };
        assert_eq!(code, want, "task {i}");
    }
    // nothing left on the local disk; one marker, for the failed case
    assert_eq!(std::fs::read_dir(&local).unwrap().count(), 0);
    let marker: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(sub.shards().join(format!("{}.failed.json", cases[2].id)))
            .unwrap(),
    )
    .unwrap();
    assert_eq!(marker["exit_code"], 1);
    assert!(marker["log"].as_str().unwrap().ends_with("task-2.out"));
    assert!(marker["error"].as_str().unwrap().contains("solve failed"));
    let s = status(&sub);
    assert!(
        s.contains("4 cases: 3 done, 1 failed, 0 running, 0 pending, 0 interrupted, 0 not run"),
        "{s}"
    );
    assert!(
        s.contains("solve failed") && s.contains("task-2.out"),
        "{s}"
    );

    let db = dir.join("merged.db");
    let (code, out) = merge(&db, &sub.shards());
    assert_eq!(code, ExitCode::SUCCESS, "{out}");
    assert!(out.contains("4 merged, 0 merged before"), "{out}");
    let rows = scalar(&db, "SELECT count(*) FROM samples");
    assert!(rows > 0);
    let (code, out) = merge(&db, &sub.shards());
    assert_eq!(code, ExitCode::SUCCESS, "{out}");
    assert!(out.contains("0 merged, 4 merged before"), "{out}");
    assert_eq!(scalar(&db, "SELECT count(*) FROM samples"), rows);
    assert_eq!(
        scalar(&db, "SELECT count(*) FROM cases WHERE status = 'failed'"),
        1
    );
    assert_eq!(scalar(&db, "SELECT count(*) FROM runs"), 4);

    // the failed case again, fixed: its shard is published anew and replaces the failed row
    let code = run_case_with(
        &task(&manifest, 2, &sub, &local),
        &fixed_runner(),
        &mut Vec::new(),
    )
    .unwrap();
    assert_eq!(code, ExitCode::SUCCESS);
    assert!(!sub
        .shards()
        .join(format!("{}.failed.json", cases[2].id))
        .exists());
    // a done case's task does nothing
    let mut out = Vec::new();
    run_case_with(&task(&manifest, 0, &sub, &local), &runner(), &mut out).unwrap();
    assert!(String::from_utf8(out).unwrap().contains("done already"));
    // a damaged shard beside them
    std::fs::write(sub.shards().join("0000000000000000.db"), "not a database").unwrap();
    let (code, out) = merge(&db, &sub.shards());
    assert_eq!(code, ExitCode::FAILURE, "{out}");
    assert!(
        out.contains("1 merged, 3 merged before") && out.contains("bad shard"),
        "{out}"
    );
    assert_eq!(
        scalar(&db, "SELECT count(*) FROM cases WHERE status = 'done'"),
        4
    );
    assert_eq!(scalar(&db, "SELECT count(*) FROM cases"), 4);
    assert_eq!(scalar(&db, "SELECT count(*) FROM sweep_cases"), 4);
    assert_eq!(
        Store::open_read_only(&db)
            .unwrap()
            .integrity_check()
            .unwrap(),
        "ok"
    );
    std::fs::remove_file(sub.shards().join("0000000000000000.db")).unwrap();

    // a database that ran the sweep itself: every done shard is a conflict, its rows stay
    let here = dir.join("here.db");
    let file = dir.join("sweep.toml");
    let args = common::sweep_args(&file, &here);
    run_sweep_with(&args, &runner(), &mut Vec::new()).unwrap();
    let before = scalar(&here, "SELECT count(*) FROM samples");
    let (code, out) = merge(&here, &sub.shards());
    assert_eq!(code, ExitCode::FAILURE, "{out}");
    assert_eq!(out.matches("conflict: ").count(), 3, "{out}");
    // the database's failed case takes the shard's result
    assert!(out.contains("1 merged"), "{out}");
    assert_eq!(
        scalar(&here, "SELECT count(*) FROM cases WHERE status = 'done'"),
        4
    );
    assert!(scalar(&here, "SELECT count(*) FROM samples") >= before);
}

/// A task killed in the middle of its case (after publishing a saved state) continues from that
/// state when it runs again — a real viscoelastic case through `xpflow run-case` — and the
/// trajectory equals an uninterrupted `xpflow sweep`'s; `xpflow status` shows it interrupted
/// in between, with the step it will continue from.
#[test]
fn a_killed_task_continues_from_its_published_state() {
    // the restored flow pattern may order the factorization differently: round-off only
    const RESUME_TOL: f64 = 1e-9;
    let dir = Scratch::new("cluster", "killed");
    let text = r#"
name = "killed"
[base]
geometry.confined_shear = { h = 1.0, l = 4.0 }
fluid = { model = "giesekus", wi = 1.0, alpha = 0.01, beta = 0.1 }
particles = { radius = 0.1, layout.pair = { lx = 0.5, ly = 0.06 } }
numerics = { mesh = [40, 10], dt = 0.02, t_end = 2.0 }
output = { sample_every = 1 }
"#;
    let (sub, cases, manifest) = submission(&dir, text);
    let id = &cases[0].id;
    let exe = env!("CARGO_BIN_EXE_xpflow");
    let whole = dir.join("whole.db");
    let out = std::process::Command::new(exe)
        .args(["sweep", "--quiet", "--jobs", "1", "--db"])
        .arg(&whole)
        .arg(dir.join("sweep.toml"))
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let reference = trajectory(&whole);
    let run_case = || {
        let mut c = std::process::Command::new(exe);
        c.args([
            "run-case",
            "--quiet",
            "--state-every",
            "0",
            "--index",
            "0",
            "--manifest",
        ])
        .arg(&manifest)
        .arg("--shards")
        .arg(sub.shards())
        .arg("--local")
        .arg(dir.join("tmp"))
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped());
        c
    };
    let shard = sub.shards().join(format!("{id}.db"));
    let state = sub.shards().join(id).join(format!("{id}.resume.json"));
    let mut child = run_case().spawn().unwrap();
    let t0 = std::time::Instant::now();
    while !state.is_file() || !shard.is_file() || trajectory(&shard).len() < 2 * 30 {
        assert!(t0.elapsed().as_secs() < 120, "no state was published");
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    let partial = trajectory(&shard).len();
    assert!(
        partial < reference.len(),
        "killed too late ({partial} rows)"
    );
    let s = status(&sub);
    assert!(
        s.contains("1 interrupted") && s.contains("saved state at step"),
        "{s}"
    );
    let out = run_case().output().unwrap();
    let log = String::from_utf8_lossy(&out.stdout).to_string();
    assert!(
        out.status.success(),
        "{log}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(log.contains("continued an earlier task's shard"), "{log}");
    assert!(
        !state.exists(),
        "the published state outlives the finished case"
    );
    let resumed = trajectory(&shard);
    let diff = common::resumed_difference(&resumed, &reference);
    assert!(diff < RESUME_TOL, "resumed trajectory differs by {diff:e}");
    let s = status(&sub);
    assert!(s.contains("1 cases: 1 done"), "{s}");
}

/// `xpflow sweep --slurm` writes a manifest of exactly the cases the database does not have done,
/// one line per array index, a script per array of at most MaxArraySize tasks whose indices are
/// offset into the manifest, and refuses a second submission into the same directory without
/// `--resume`.
#[test]
fn the_manifest_lists_what_is_not_done_and_arrays_split_at_max_array_size() {
    let dir = Scratch::new("cluster", "manifest");
    let file = dir.join("sweep.toml");
    std::fs::write(&file, SWEEP).unwrap();
    let cases = expand(&SweepSpec::from_file(&file).unwrap()).unwrap();
    let db = dir.join("r.db");
    // a local sweep did all but Wi = 3 (failed)
    run_sweep_with(&common::sweep_args(&file, &db), &runner(), &mut Vec::new()).unwrap();
    let sub = dir.join("sub");
    let mut args = common::sweep_args(&file, &db);
    args.slurm.slurm = true;
    args.slurm.submission = Some(sub.clone());
    args.slurm.max_running = Some(3);
    let mut out = Vec::new();
    assert_eq!(
        run_sweep_with(&args, &runner(), &mut out).unwrap(),
        ExitCode::SUCCESS
    );
    let out = String::from_utf8(out).unwrap();
    assert!(
        out.contains("3 done") && out.contains("round 1 submits 1"),
        "{out}"
    );
    let manifest = std::fs::read_to_string(sub.join("round-1/manifest.txt")).unwrap();
    let ids: Vec<&str> = manifest.lines().filter(|l| !l.starts_with('#')).collect();
    assert_eq!(ids, [cases[2].id.as_str()]);
    assert!(manifest.contains("# sweep: sweep.toml"));
    assert_eq!(
        std::fs::read_to_string(sub.join("round-1/sweep.toml")).unwrap(),
        SWEEP
    );
    let script = std::fs::read_to_string(sub.join("round-1/array-0.sbatch")).unwrap();
    assert!(script.contains("#SBATCH --array=0-0%3\n"), "{script}");
    // estimates: the case's memory; a time from the three finished (fake) cases
    let mb = (cases[2].spec.memory_estimate() / 1e6).ceil();
    assert!(
        script.contains(&format!("#SBATCH --mem={mb}M\n")),
        "{script}"
    );
    assert!(
        script.contains("finished case(s) in the database"),
        "{script}"
    );
    let mut again = Vec::new();
    assert_eq!(
        run_sweep_with(&args, &runner(), &mut again).unwrap(),
        ExitCode::from(2)
    );

    // four cases with MaxArraySize 3: arrays of 3 and 1, the second starting at line 3
    let other = Submission::new(&dir.join("split"));
    let refs: Vec<&PlannedCase> = cases.iter().collect();
    let res = Resources {
        time: "10".into(),
        mem: "100M".into(),
        ..Resources::default()
    };
    let round = write_round(&other, &file, "shards", &refs, &res, 3).unwrap();
    let shapes: Vec<(usize, usize)> = round
        .jobs
        .iter()
        .map(|(c, _)| (c.offset, c.count))
        .collect();
    assert_eq!(shapes, [(0, 3), (3, 1)]);
    let second = std::fs::read_to_string(round.dir.join("array-1.sbatch")).unwrap();
    assert!(second.contains("#SBATCH --array=0-0\n"), "{second}");
    assert!(
        second.contains("--index $((SLURM_ARRAY_TASK_ID + 3))"),
        "{second}"
    );
    let listed = xpflow::sweep::manifest::Manifest::read(&round.dir.join("manifest.txt")).unwrap();
    assert_eq!(listed.case(3).unwrap(), cases[3].id);
}
