//! One task of a cluster job (`xpflow run-case`): the case at one index of a [`Manifest`], run
//! through the sweep engine ([`run_sweep`], the same path as `xpflow sweep`) into a shard of its
//! own, `<shards>/<case id>.db`.
//!
//! The shard is written on local disk (`$TMPDIR`, or `--local`) and published into the shard
//! directory after every saved state and at the end ([`crate::store::shard`]). A task that finds
//! its case's shard published by an earlier, killed task restores it with its saved state and
//! continues from there; one that finds it done does nothing. A task that fails leaves a marker,
//! `<shards>/<case id>.failed.json`, with its exit code, error and log file.

use std::path::{Path, PathBuf};
use std::time::Duration;

use super::engine::{states_dir, SweepError, SweepOptions, SweepSummary};
use super::expand::plan_labelled;
use super::manifest::{Manifest, ManifestError};
use super::progress::ProgressMode;
use super::slurm::{RoundCase, ROUND_CASES};
use super::{expand, run_sweep, CaseRunner};
use crate::config::{ConfigError, SweepSpec};
use crate::store::shard::{restore, shard_cases};
use crate::store::StoreError;

/// What a task is to do.
#[derive(Debug, Clone)]
pub struct TaskOptions {
    /// The manifest of the submission.
    pub manifest: PathBuf,
    /// The array index: the line of the manifest.
    pub index: usize,
    /// The shared directory of shards.
    pub shards: PathBuf,
    /// Local scratch directory under which the shard is written (default: `$TMPDIR`).
    pub local: PathBuf,
    /// Wall-clock time between saved solver states (each one published).
    pub state_every: Duration,
    /// Progress output.
    pub progress: ProgressMode,
}

/// What a task did.
#[derive(Debug, Clone, PartialEq)]
pub enum TaskOutcome {
    /// The case's shard was published done by an earlier task: nothing run.
    AlreadyDone {
        /// Case id.
        case: String,
    },
    /// The case ran (from the start or from a restored state).
    Ran {
        /// Case id.
        case: String,
        /// Whether an earlier task's shard was restored.
        restored: bool,
        /// The engine's summary.
        summary: SweepSummary,
    },
}

/// Errors of a task: bad input (the manifest, the sweep file, a case not in it) or a failure.
#[derive(Debug, thiserror::Error)]
pub enum TaskError {
    /// The manifest cannot be read, or the index is beyond it.
    #[error(transparent)]
    Manifest(#[from] ManifestError),
    /// The sweep file is invalid.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// The manifest's case is not in its sweep file (edited since the submission?).
    #[error("manifest {}: index {index}: case {case} is not in the sweep file {} (edited since it was submitted?)", manifest.display(), sweep.display())]
    NotInSweep {
        /// The manifest.
        manifest: PathBuf,
        /// The index.
        index: usize,
        /// The case id.
        case: String,
        /// The sweep file.
        sweep: PathBuf,
    },
    /// The engine failed.
    #[error(transparent)]
    Sweep(#[from] SweepError),
    /// The shard or the local directory failed.
    #[error(transparent)]
    Store(#[from] StoreError),
}

impl TaskError {
    /// Whether the error is the input's (exit code 2).
    pub fn is_bad_input(&self) -> bool {
        match self {
            TaskError::Manifest(_) | TaskError::Config(_) | TaskError::NotInSweep { .. } => true,
            TaskError::Sweep(SweepError::Unsupported { .. } | SweepError::TooLarge { .. }) => true,
            TaskError::Sweep(SweepError::Store(e)) | TaskError::Store(e) => e.is_bad_input(),
            TaskError::Sweep(SweepError::Pool { .. }) => false,
        }
    }
}

/// The shard of case `case` in `shards`.
pub fn shard_path(shards: &Path, case: &str) -> PathBuf {
    shards.join(format!("{case}.db"))
}

/// The failure marker of case `case` in `shards`.
pub fn marker_path(shards: &Path, case: &str) -> PathBuf {
    shards.join(format!("{case}.failed.json"))
}

/// What a failed task leaves beside its shard.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Marker {
    /// Case id (none when the manifest could not tell it).
    pub case: Option<String>,
    /// Array index.
    pub index: usize,
    /// The task's exit code.
    pub exit_code: u8,
    /// The error.
    pub error: String,
    /// The task's log file, if known.
    pub log: Option<PathBuf>,
    /// The host the task ran on.
    pub host: String,
    /// The SLURM array task (`<array job>_<index>`) when run under SLURM.
    pub job: Option<String>,
}

impl Marker {
    /// Writes the marker (for a case, or for index `index` when the case is unknown).
    ///
    /// # Errors
    /// The I/O error.
    pub fn write(&self, shards: &Path) -> std::io::Result<PathBuf> {
        let path = match &self.case {
            Some(c) => marker_path(shards, c),
            None => shards.join(format!("index-{}.failed.json", self.index)),
        };
        std::fs::create_dir_all(shards)?;
        let tmp = path.with_extension("json.tmp");
        std::fs::write(&tmp, serde_json::to_string_pretty(self).unwrap_or_default())?;
        std::fs::rename(&tmp, &path)?;
        Ok(path)
    }

    /// The marker of case `case`, if there is a readable one.
    pub fn read(shards: &Path, case: &str) -> Option<Marker> {
        let text = std::fs::read_to_string(marker_path(shards, case)).ok()?;
        serde_json::from_str(&text).ok()
    }
}

/// The case id the task of `opts` runs (for the marker of a failed task).
pub fn case_of(opts: &TaskOptions) -> Option<String> {
    let m = Manifest::read(&opts.manifest).ok()?;
    m.case(opts.index).ok().map(str::to_string)
}

/// Runs the task: the case at `opts.index` of the manifest, into its shard.
///
/// # Errors
/// [`TaskError`]: bad input (exit 2) or a failure of the engine or the shard.
pub fn run_task(opts: &TaskOptions, runner: &dyn CaseRunner) -> Result<TaskOutcome, TaskError> {
    let manifest = Manifest::read(&opts.manifest)?;
    let id = manifest.case(opts.index)?.to_string();
    let sweep_file = manifest.sweep_file();
    let spec = SweepSpec::from_file(&sweep_file)?;
    let not_in_sweep = || TaskError::NotInSweep {
        manifest: opts.manifest.clone(),
        index: opts.index,
        case: id.clone(),
        sweep: sweep_file.clone(),
    };
    let case = if spec.search.is_some() {
        // a search's cases are planned from its results: the round lists their swept fields
        let path = opts
            .manifest
            .parent()
            .unwrap_or_else(|| Path::new("."))
            .join(ROUND_CASES);
        let listed: Vec<RoundCase> = std::fs::read_to_string(&path)
            .ok()
            .and_then(|t| serde_json::from_str(&t).ok())
            .ok_or_else(not_in_sweep)?;
        let c = listed
            .into_iter()
            .find(|c| c.id == id)
            .ok_or_else(not_in_sweep)?;
        // planned again from the sweep file: another id if its base was edited since
        Some(plan_labelled(&spec, c.index, c.label, c.params)?).filter(|c| c.id == id)
    } else {
        expand(&spec)?.into_iter().find(|c| c.id == id)
    }
    .ok_or_else(not_in_sweep)?;
    let published = shard_path(&opts.shards, &id);
    if published.is_file() && shard_cases(&published)?.iter().any(|c| c.status == "done") {
        std::fs::remove_file(marker_path(&opts.shards, &id)).ok();
        return Ok(TaskOutcome::AlreadyDone { case: id });
    }
    let local = opts
        .local
        .join(format!("xpflow-task-{id}-{}", std::process::id()));
    let db = local.join(format!("{id}.db"));
    let outcome = (|| {
        let restored = restore(&opts.shards, &db, &states_dir(&db))?;
        let mut sweep_opts = SweepOptions::new(db.clone());
        sweep_opts.jobs = 1;
        // a task runs only a case that is not done: a failed one is run again
        sweep_opts.retry_failed = true;
        sweep_opts.state_every = opts.state_every;
        sweep_opts.progress = opts.progress;
        sweep_opts.snapshot_dir = Some(
            std::path::absolute(&opts.shards)
                .unwrap_or_else(|_| opts.shards.clone())
                .join(&spec.name),
        );
        sweep_opts.publish = Some(opts.shards.clone());
        let summary = run_sweep(&spec, std::slice::from_ref(&case), runner, &sweep_opts)?;
        Ok(TaskOutcome::Ran {
            case: id.clone(),
            restored,
            summary,
        })
    })();
    std::fs::remove_dir_all(&local).ok();
    if matches!(&outcome, Ok(TaskOutcome::Ran { summary, .. }) if summary.failed == 0) {
        std::fs::remove_file(marker_path(&opts.shards, &id)).ok();
    }
    outcome
}
