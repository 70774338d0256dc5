//! Helpers shared by the integration tests.

use std::ops::Deref;
use std::path::{Path, PathBuf};

/// A scratch directory under the system's temporary directory, emptied when created and removed
/// when dropped — unless the test is failing, so that its files can be inspected.
pub struct Scratch(PathBuf);

impl Scratch {
    /// `<tmp>/xpflow-<prefix>-<name>-<pid>`, created empty.
    pub fn new(prefix: &str, name: &str) -> Scratch {
        let d = std::env::temp_dir().join(format!("xpflow-{prefix}-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        Scratch(d)
    }
}

impl Deref for Scratch {
    type Target = Path;
    fn deref(&self) -> &Path {
        &self.0
    }
}

impl AsRef<Path> for Scratch {
    fn as_ref(&self) -> &Path {
        &self.0
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        if std::thread::panicking() {
            eprintln!("scratch directory kept: {}", self.0.display());
        } else {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }
}

/// The sweep command's arguments for `file` into `db`: two jobs, quiet, no limits beyond the
/// defaults (tests change fields with struct update syntax).
#[allow(dead_code)] // not every test binary runs sweeps
pub fn sweep_args(file: &Path, db: &Path) -> xpflow::cli::sweep_cmds::SweepArgs {
    xpflow::cli::sweep_cmds::SweepArgs {
        file: file.into(),
        db: Some(db.into()),
        jobs: Some(2),
        dry_run: false,
        resolved: false,
        estimate: false,
        quiet: true,
        retry_failed: false,
        cases: Vec::new(),
        filters: Vec::new(),
        state_every: 5.0,
        max_memory: None,
        max_cases: xpflow::sweep::expand::DEFAULT_MAX_CASES,
        slurm: Default::default(),
    }
}

/// Every stored sample of a database as (step, x, y, ω), ordered by step and particle (read-only).
#[allow(dead_code)]
pub fn trajectory(db: &Path) -> Vec<[f64; 4]> {
    let store = xpflow::store::Store::open_read_only(db).unwrap();
    let mut st = store
        .connection()
        .prepare("SELECT step, x, y, omega FROM samples ORDER BY step, particle")
        .unwrap();
    let rows = st
        .query_map([], |r| {
            Ok([r.get::<_, i64>(0)? as f64, r.get(1)?, r.get(2)?, r.get(3)?])
        })
        .unwrap();
    rows.map(Result::unwrap).collect()
}

/// Largest difference of x, y, ω between a resumed trajectory and the uninterrupted one, which
/// must have the same rows at the same steps.
#[allow(dead_code)]
pub fn resumed_difference(resumed: &[[f64; 4]], reference: &[[f64; 4]]) -> f64 {
    assert_eq!(resumed.len(), reference.len(), "a step missing or doubled");
    resumed
        .iter()
        .zip(reference)
        .map(|(a, b)| {
            assert_eq!(a[0], b[0], "steps out of order");
            (1..4).map(|k| (a[k] - b[k]).abs()).fold(0.0, f64::max)
        })
        .fold(0.0, f64::max)
}

/// `xpflow query WHAT --db DB --format csv` over every sweep: its exit code and output.
#[allow(dead_code)] // not every test binary queries
pub fn query(
    what: xpflow::cli::query_cmds::QueryWhat,
    db: &Path,
) -> (std::process::ExitCode, String) {
    let a = xpflow::cli::query_cmds::QueryArgs {
        what,
        db: db.into(),
        sweep: None,
        filters: vec![],
        case: None,
        by: "r0".into(),
        rows: None,
        cols: None,
        format: xpflow::store::Format::Csv,
    };
    let mut out = Vec::new();
    let code = xpflow::cli::query_cmds::run_query_to(&a, &mut out).unwrap();
    (code, String::from_utf8(out).unwrap())
}

/// The engine's options for `db`: two jobs, no progress output.
#[allow(dead_code)]
pub fn quiet_options(db: &Path) -> xpflow::sweep::SweepOptions {
    let mut o = xpflow::sweep::SweepOptions::new(db.to_path_buf());
    o.jobs = 2;
    o.progress = xpflow::sweep::progress::ProgressMode::Quiet;
    o
}

/// The rounds of the `[search]` or `[tries]` sweep `file` into `db` through the cluster path
/// without a scheduler: `xpflow sweep --slurm [--resume]` (submission directory `sub` beside
/// `db`) writes a round, every task of its manifest runs (`xpflow run-case`) and their shards are
/// merged into the database, until the command answers `over` (a line containing it), at most
/// `most` rounds. Returns the number of cases of each round.
#[allow(dead_code)]
pub fn cluster_rounds(
    file: &Path,
    db: &Path,
    runner: &xpflow::sweep::FakeRunner,
    over: &str,
    most: usize,
) -> Vec<usize> {
    use std::process::ExitCode;
    use xpflow::cli::cluster::{merge_to, run_case_with, MergeArgs, RunCaseArgs};
    let mut args = sweep_args(file, db);
    args.quiet = false;
    args.slurm.slurm = true;
    let sub_dir = db.parent().unwrap().join("sub");
    args.slurm.submission = Some(sub_dir.clone());
    let args = &mut args;
    let sub = xpflow::sweep::slurm::Submission::new(&sub_dir);
    let db = db.to_path_buf();
    let mut sizes = Vec::new();
    for round in 1..=most {
        args.slurm.resume = round > 1;
        let mut out = Vec::new();
        let code = xpflow::cli::sweep_cmds::run_sweep_with(args, runner, &mut out).unwrap();
        assert_eq!(code, ExitCode::SUCCESS);
        let out = String::from_utf8(out).unwrap();
        if out.contains(over) {
            return sizes;
        }
        assert!(out.contains("--slurm --resume"), "{out}");
        let manifest = sub.dir.join(format!("round-{round}/manifest.txt"));
        let ids = std::fs::read_to_string(&manifest).unwrap();
        let n = ids.lines().filter(|l| !l.starts_with('#')).count();
        for index in 0..n {
            let task = RunCaseArgs {
                manifest: manifest.clone(),
                index,
                shards: sub.shards(),
                local: Some(sub.dir.join("local")),
                state_every: 5.0,
                log: None,
                quiet: true,
            };
            let code = run_case_with(&task, runner, &mut Vec::new()).unwrap();
            assert_eq!(code, ExitCode::SUCCESS);
        }
        let merge = MergeArgs {
            db: db.clone(),
            shards: vec![sub.shards()],
        };
        assert_eq!(
            merge_to(&merge, &mut Vec::new()).unwrap(),
            ExitCode::SUCCESS
        );
        sizes.push(n);
    }
    panic!("not over after {most} rounds");
}
