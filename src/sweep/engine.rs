//! The sweep engine: registers a sweep in the store, resets cases left `running` by a killed run, then
//! runs every pending case through a [`CaseRunner`] on a rayon pool. Each worker claims a case
//! (pending → running) in the database before running it, so two sweeps sharing cases never run one twice;
//! each finished case is written in one transaction (plus sample checkpoints for long cases).

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::PathBuf;
use std::sync::Mutex;
use std::time::{Duration, Instant};

use rayon::prelude::*;

use super::progress::{CaseProgress, Progress, ProgressMode};
use super::runner::{CaseRunner, RunStatus};
use super::PlannedCase;
use crate::config::{CaseSpec, SweepSpec};
use crate::observe::{CaseObserver, Classifier, Control, FieldSnapshot, OutcomeKind, Sample};
use crate::store::snapshot::SnapshotWriter;
use crate::store::{CaseRecord, Store, StoreError};

/// Sample rows buffered before a checkpoint writes them, bounding memory of long cases.
const CHECKPOINT_ROWS: usize = 50_000;

/// Options of one sweep invocation.
#[derive(Debug, Clone)]
pub struct SweepOptions {
    /// Database file.
    pub db: PathBuf,
    /// Cases run at once (each on one thread).
    pub jobs: usize,
    /// Rerun cases recorded as `failed`.
    pub retry_failed: bool,
    /// Progress display.
    pub progress: ProgressMode,
    /// Wall-clock seconds between sample checkpoints of a running case.
    pub checkpoint_every: Duration,
    /// Wall-clock seconds between saved solver states of a running case (zero: every step); a
    /// killed case continues from its last one.
    pub state_every: Duration,
    /// Directory of HDF5 snapshots (default `<db dir>/<sweep name>/`).
    pub snapshot_dir: Option<PathBuf>,
}

impl SweepOptions {
    /// Defaults: jobs = cores, plain log, sample checkpoints every minute, solver states every
    /// five minutes.
    pub fn new(db: PathBuf) -> SweepOptions {
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
        SweepOptions {
            db,
            jobs: cores,
            retry_failed: false,
            progress: ProgressMode::Plain,
            checkpoint_every: Duration::from_secs(60),
            state_every: Duration::from_secs(300),
            snapshot_dir: None,
        }
    }
}

/// What a sweep invocation did.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SweepSummary {
    /// Cases in the sweep.
    pub total: usize,
    /// Cases run to an outcome by this invocation.
    pub ran: usize,
    /// Cases this invocation ran that failed.
    pub failed: usize,
    /// Cases not run (already done or failed, or being run by another process).
    pub skipped: usize,
    /// Interrupted cases reset to pending before running.
    pub reset: usize,
    /// Outcome kinds of the cases run, in case order.
    pub outcomes: Vec<(String, String)>,
}

/// Errors of the sweep engine.
#[derive(Debug, thiserror::Error)]
pub enum SweepError {
    /// The runner cannot simulate a case; nothing was written.
    #[error("case {index} ({label}): {reason}")]
    Unsupported {
        /// Case index.
        index: usize,
        /// Case label.
        label: String,
        /// The runner's reason.
        reason: String,
    },
    /// The store failed.
    #[error(transparent)]
    Store(#[from] StoreError),
    /// The thread pool could not be built.
    #[error("cannot start {jobs} worker threads: {message}")]
    Pool {
        /// Requested jobs.
        jobs: usize,
        /// The error.
        message: String,
    },
}

/// Runs (or resumes) `sweep` with its expanded `cases`.
pub fn run_sweep(
    sweep: &SweepSpec,
    cases: &[PlannedCase],
    runner: &dyn CaseRunner,
    opts: &SweepOptions,
) -> Result<SweepSummary, SweepError> {
    for c in cases {
        runner
            .supports(&c.spec)
            .map_err(|reason| SweepError::Unsupported {
                index: c.index,
                label: c.label.clone(),
                reason,
            })?;
    }
    let mut store = Store::open(&opts.db)?;
    let sweep_id = store.register_sweep(sweep)?;
    store.add_cases(sweep_id, cases)?;
    let reset = store.reset_interrupted(sweep_id, opts.retry_failed)?;
    let pending: Vec<&PlannedCase> = {
        let conn = store.connection();
        let mut st = conn
            .prepare("SELECT status FROM cases WHERE case_hash = ?1")
            .map_err(|source| StoreError::Sql {
                path: opts.db.clone(),
                source,
            })?;
        cases
            .iter()
            .filter(|c| {
                st.query_row([&c.id], |r| r.get::<_, String>(0))
                    .is_ok_and(|s| s == "pending")
            })
            .collect()
    };
    let jobs = opts.jobs.max(1).min(pending.len().max(1));
    let run_id = store.begin_run(sweep_id, jobs, &sweep.raw.to_string())?;
    let snapshot_dir = opts.snapshot_dir.clone().unwrap_or_else(|| {
        opts.db
            .parent()
            .map(|d| d.join(&sweep.name))
            .unwrap_or_else(|| PathBuf::from(&sweep.name))
    });
    let progress = Progress::new(opts.progress, pending.len());
    progress.log(&format!(
        "sweep {}: {} cases, {} to run ({} reset after interruption), {jobs} at a time, database {}",
        sweep.name,
        cases.len(),
        pending.len(),
        reset,
        opts.db.display()
    ));
    let results: Mutex<Vec<(usize, CaseRun)>> = Mutex::new(Vec::new());
    let errors: Mutex<Vec<StoreError>> = Mutex::new(Vec::new());
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(jobs)
        .build()
        .map_err(|e| SweepError::Pool {
            jobs,
            message: e.to_string(),
        })?;
    pool.install(|| {
        pending.par_iter().with_max_len(1).for_each(|case| {
            let ctx = CaseContext {
                runner,
                opts,
                progress: &progress,
                run_id,
                snapshot_dir: &snapshot_dir,
            };
            match run_one(case, &ctx) {
                Ok(r) => results
                    .lock()
                    .unwrap_or_else(|p| p.into_inner())
                    .push((case.index, r)),
                Err(e) => errors.lock().unwrap_or_else(|p| p.into_inner()).push(e),
            }
        })
    });
    progress.finish();
    if let Some(e) = errors
        .into_inner()
        .unwrap_or_else(|p| p.into_inner())
        .into_iter()
        .next()
    {
        return Err(e.into());
    }
    store.finish_run(run_id)?;
    let mut results = results.into_inner().unwrap_or_else(|p| p.into_inner());
    results.sort_by_key(|r| r.0);
    let mut summary = SweepSummary {
        total: cases.len(),
        reset,
        ..Default::default()
    };
    for (index, r) in results {
        match r {
            None => summary.skipped += 1,
            Some((kind, failed)) => {
                summary.ran += 1;
                summary.failed += usize::from(failed);
                summary.outcomes.push((cases[index].label.clone(), kind));
            }
        }
    }
    summary.skipped += cases.len() - pending.len();
    Ok(summary)
}

/// What running one case gave: `None` if another process had claimed it, else (outcome kind or
/// `failed`, whether it failed).
type CaseRun = Option<(String, bool)>;

struct CaseContext<'a> {
    runner: &'a dyn CaseRunner,
    opts: &'a SweepOptions,
    progress: &'a Progress,
    run_id: i64,
    snapshot_dir: &'a PathBuf,
}

/// Claims and runs one case; `None` if another process had it. Returns (outcome or "failed", failed?).
fn run_one(
    case: &PlannedCase,
    ctx: &CaseContext<'_>,
) -> Result<Option<(String, bool)>, StoreError> {
    let mut store = Store::open(&ctx.opts.db)?;
    let resume_path = resume_path(&ctx.opts.db, &case.id);
    let saved = ResumeFile::load(&resume_path, &case.id);
    let Some(claim) = store.claim(&case.id, saved.as_ref().map(|r| (r.step, r.rows)))? else {
        return Ok(None);
    };
    let case_id = claim.id;
    let saved = saved.filter(|_| claim.resumed);
    if let Some(r) = &saved {
        ctx.progress.log(&format!(
            "resume {} ({}) from step {} (t = {}), saved by {}",
            case.label, case.id, r.step, r.t, r.code_version
        ));
    }
    let bar = ctx
        .progress
        .start_case(&case.label, &case.id, case.spec.numerics.t_end);
    let mut rec = Recorder::new(&mut store, case_id, &case.spec, &case.id, ctx, bar);
    rec.resume_path = resume_path.clone();
    if let Some(r) = saved {
        rec.resume_from(r);
    }
    let result = catch_unwind(AssertUnwindSafe(|| ctx.runner.run(&case.spec, &mut rec)));
    let (status, steps, t) = match result {
        Ok(r) => (r.status, r.steps, r.t),
        Err(payload) => {
            let msg = payload
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| payload.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_else(|| "unknown panic".into());
            let t = rec.last.as_ref().map_or(0.0, |s| s.t);
            let steps = rec.last.as_ref().map_or(0, |s| s.step);
            // a panic is a broken contract of the code, not physics: the case failed
            (
                RunStatus::Failed {
                    error: format!("panicked at step {steps}: {msg}"),
                },
                steps,
                t,
            )
        }
    };
    let (outcome, mut error) = match status {
        RunStatus::Finished => {
            let o = rec.classifier.clone().finish();
            let reason = o
                .final_state
                .get("reason")
                .and_then(|r| r.as_str())
                .map(str::to_string);
            (Some(o), reason)
        }
        RunStatus::Diverged { reason } => (Some(rec.classifier.diverged(t, &reason)), Some(reason)),
        RunStatus::Failed { error } => (None, Some(error)),
    };
    for (what, e) in [
        ("snapshot", rec.snapshot_error.take()),
        ("saved state", rec.state_error.take()),
    ] {
        if let Some(e) = e {
            error = Some(match error {
                Some(prev) => format!("{prev}; {what}: {e}"),
                None => format!("{what}: {e}"),
            });
        }
    }
    let mut samples = std::mem::take(&mut rec.buffer);
    if let Some(last) = rec.last.take() {
        if rec.stored_step != Some(last.step) && samples.last().map(|s| s.step) != Some(last.step) {
            samples.push(last);
        }
    }
    let bar = rec.bar.take();
    let wall_s = rec.wall_s();
    drop(rec);
    let summary = match (&outcome, &error) {
        (Some(o), Some(e)) if o.kind == OutcomeKind::Diverged => format!("diverged ({e})"),
        (Some(o), _) => o.kind.as_str().to_string(),
        (None, e) => format!("failed ({})", e.as_deref().unwrap_or("")),
    };
    let failed = outcome.is_none();
    let kind = outcome
        .as_ref()
        .map_or("failed", |o| o.kind.as_str())
        .to_string();
    let record = CaseRecord {
        samples,
        outcome,
        error,
        wall_s,
        steps,
        t_reached: t,
        run_id: ctx.run_id,
        settings: ctx.runner.settings(&case.spec).map(|v| v.to_string()),
    };
    store.finish_case(case_id, &record)?;
    // a finished case (whatever its outcome) is never resumed
    std::fs::remove_file(&resume_path).ok();
    if let Some(bar) = bar {
        ctx.progress.finish_case(bar, &summary);
    }
    Ok(Some((kind, failed)))
}

/// The observer the engine gives a runner: classifies every step, keeps every k-th sample, checkpoints,
/// writes snapshots and drives the case's progress bar.
struct Recorder<'a> {
    store: &'a mut Store,
    case_id: i64,
    hash: &'a str,
    spec: &'a CaseSpec,
    classifier: Classifier,
    buffer: Vec<Sample>,
    last: Option<Sample>,
    stored_step: Option<u64>,
    last_flush: Instant,
    checkpoint_every: Duration,
    snapshot_dir: &'a PathBuf,
    snapshots: Option<SnapshotWriter>,
    snapshot_error: Option<String>,
    bar: Option<CaseProgress>,
    /// Where the solver state goes ([`resume_path`]).
    resume_path: PathBuf,
    state_every: Duration,
    last_state: Instant,
    state_error: Option<String>,
    /// The state a resumed case continues from, until the runner takes it.
    resume_state: Option<String>,
    /// The step a resumed case continues after (its snapshots up to there are kept).
    resumed_at: Option<u64>,
    /// Wall-clock seconds spent on the case by earlier, interrupted attempts.
    wall_before: f64,
    started: Instant,
}

impl<'a> Recorder<'a> {
    fn new(
        store: &'a mut Store,
        case_id: i64,
        spec: &'a CaseSpec,
        hash: &'a str,
        ctx: &CaseContext<'a>,
        bar: CaseProgress,
    ) -> Self {
        Recorder {
            store,
            case_id,
            hash,
            spec,
            classifier: Classifier::new(spec),
            buffer: Vec::new(),
            last: None,
            stored_step: None,
            last_flush: Instant::now(),
            checkpoint_every: ctx.opts.checkpoint_every,
            snapshot_dir: ctx.snapshot_dir,
            snapshots: None,
            snapshot_error: None,
            bar: Some(bar),
            resume_path: PathBuf::new(),
            state_every: ctx.opts.state_every,
            last_state: Instant::now(),
            state_error: None,
            resume_state: None,
            resumed_at: None,
            wall_before: 0.0,
            started: Instant::now(),
        }
    }

    /// Wall-clock seconds spent on the case so far, over all attempts.
    fn wall_s(&self) -> f64 {
        self.wall_before + self.started.elapsed().as_secs_f64()
    }

    /// Continues an interrupted attempt: the classifier, the last sample and the solver state as
    /// they were saved.
    fn resume_from(&mut self, r: ResumeFile) {
        self.classifier = r.classifier;
        self.stored_step = r.stored_step;
        self.last = Some(r.last);
        self.wall_before = r.wall_s;
        self.resumed_at = Some(r.step);
        self.resume_state = Some(r.solver.get().to_string());
    }

    /// Writes the resume file for `step` (samples flushed first, so that the database holds every
    /// sample up to `step` whenever the file says so).
    fn write_state(&mut self, step: u64, state: &str) -> Result<(), String> {
        let Some(last) = self.last.clone().filter(|s| s.step == step) else {
            return Err(format!("step {step} was not reported before its state"));
        };
        self.flush();
        if !self.buffer.is_empty() {
            return Err("samples could not be written".into());
        }
        let rows = self
            .store
            .count_samples(self.case_id, step)
            .map_err(|e| e.to_string())?;
        let file = ResumeFile {
            format: RESUME_FORMAT,
            case_hash: self.hash.to_string(),
            code_version: crate::store::code_version(),
            step,
            t: last.t,
            rows,
            stored_step: self.stored_step,
            last,
            classifier: self.classifier.clone(),
            wall_s: self.wall_s(),
            solver: serde_json::value::RawValue::from_string(state.to_string())
                .map_err(|e| format!("solver state is not JSON: {e}"))?,
        };
        let json = serde_json::to_string(&file).map_err(|e| e.to_string())?;
        let io = |e: std::io::Error| format!("{}: {e}", self.resume_path.display());
        if let Some(dir) = self.resume_path.parent() {
            std::fs::create_dir_all(dir).map_err(io)?;
        }
        // write-then-rename: a kill leaves the previous state or this one, never half of one
        let tmp = self.resume_path.with_extension("json.tmp");
        std::fs::write(&tmp, json).map_err(io)?;
        std::fs::rename(&tmp, &self.resume_path).map_err(io)
    }

    fn flush(&mut self) {
        if self.buffer.is_empty() {
            return;
        }
        // A failed checkpoint is not fatal: the samples stay buffered for the final transaction.
        if self.store.write_samples(self.case_id, &self.buffer).is_ok() {
            self.stored_step = self.buffer.last().map(|s| s.step);
            self.buffer.clear();
        }
        self.last_flush = Instant::now();
    }
}

impl CaseObserver for Recorder<'_> {
    fn on_step(&mut self, sample: &Sample) -> Control {
        self.classifier.push(sample);
        if sample.step.is_multiple_of(self.spec.output.sample_every) {
            self.buffer.push(sample.clone());
        }
        self.last = Some(sample.clone());
        if let Some(bar) = &mut self.bar {
            bar.update(sample.t, sample.step);
        }
        let rows = self.buffer.len() * sample.particles.len().max(1);
        if rows >= CHECKPOINT_ROWS || self.last_flush.elapsed() >= self.checkpoint_every {
            self.flush();
        }
        match self.classifier.decided() {
            Some(o) if o.kind == OutcomeKind::Diverged || self.spec.stop.early_stop => {
                Control::Stop
            }
            _ => Control::Continue,
        }
    }

    fn snapshot_due(&self, step: u64) -> bool {
        let every = self.spec.output.snapshot_every;
        every > 0 && step.is_multiple_of(every)
    }

    fn on_snapshot(&mut self, snapshot: &FieldSnapshot) {
        if self.snapshots.is_none() && self.snapshot_error.is_none() {
            let opened = match self.resumed_at {
                Some(step) => SnapshotWriter::reopen(self.snapshot_dir, self.hash, step),
                None => SnapshotWriter::create(self.snapshot_dir, self.hash),
            };
            match opened {
                Ok(w) => self.snapshots = Some(w),
                Err(e) => self.snapshot_error = Some(e.to_string()),
            }
        }
        let Some(w) = &mut self.snapshots else { return };
        let file = w.h5_path().display().to_string();
        let written = w.write(snapshot).and_then(|_| {
            self.store
                .record_snapshot(self.case_id, snapshot.step, snapshot.t, &file)
        });
        if let Err(e) = written {
            self.snapshot_error.get_or_insert(e.to_string());
        }
    }

    fn checkpoint(&mut self) {
        self.flush();
    }

    fn state_due(&self, _step: u64) -> bool {
        self.last_state.elapsed() >= self.state_every
    }

    fn save_state(&mut self, step: u64, state: &str) {
        if let Err(e) = self.write_state(step, state) {
            self.state_error.get_or_insert(e);
        }
        self.last_state = Instant::now();
    }

    fn resume_state(&mut self) -> Option<String> {
        self.resume_state.take()
    }
}

/// Where the saved state of case `hash` of database `db` lives: `<db dir>/<db stem>/<hash>.resume.json`
/// (beside the snapshots when the sweep is named like its database, the default), whichever sweep
/// invocation runs the case.
pub fn resume_path(db: &std::path::Path, hash: &str) -> PathBuf {
    let stem = db
        .file_stem()
        .map_or_else(|| "results".into(), |s| s.to_string_lossy().into_owned());
    db.parent()
        .unwrap_or_else(|| std::path::Path::new("."))
        .join(stem)
        .join(format!("{hash}.resume.json"))
}

/// The step, time and writing build of the saved state of a case, if it has a readable one.
pub fn saved_state(db: &std::path::Path, hash: &str) -> Option<(u64, f64, String)> {
    #[derive(serde::Deserialize)]
    struct Header {
        format: u32,
        code_version: String,
        step: u64,
        t: f64,
    }
    let text = std::fs::read_to_string(resume_path(db, hash)).ok()?;
    serde_json::from_str::<Header>(&text)
        .ok()
        .filter(|h| h.format == RESUME_FORMAT)
        .map(|h| (h.step, h.t, h.code_version))
}

/// Layout version of the resume file.
const RESUME_FORMAT: u32 = 1;

/// A running case's saved state: what the observer had seen (classifier, last sample, how many
/// sample rows the database held) and the runner's own state, after one step.
#[derive(serde::Serialize, serde::Deserialize)]
struct ResumeFile {
    format: u32,
    case_hash: String,
    /// The build that wrote it (a resumed case may finish with another; the log says so).
    code_version: String,
    step: u64,
    t: f64,
    /// Sample rows of the case with step ≤ `step` when it was written.
    rows: u64,
    stored_step: Option<u64>,
    last: Sample,
    classifier: Classifier,
    wall_s: f64,
    solver: Box<serde_json::value::RawValue>,
}

impl ResumeFile {
    /// The saved state of case `hash`, if there is a readable one of this layout.
    fn load(path: &std::path::Path, hash: &str) -> Option<ResumeFile> {
        let text = std::fs::read_to_string(path).ok()?;
        serde_json::from_str::<ResumeFile>(&text)
            .ok()
            .filter(|r| r.format == RESUME_FORMAT && r.case_hash == hash)
    }
}
