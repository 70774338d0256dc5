//! The sweep engine: registers a sweep in the store, resets cases left `running` by a killed run, then
//! runs every pending case through a [`CaseRunner`] on a rayon pool. Each worker claims a case
//! (pending → running) in the database before running it, so two sweeps sharing cases never run one twice;
//! each finished case is written in one transaction (plus sample checkpoints for long cases).

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::PathBuf;
use std::sync::Mutex;
use std::time::Duration;

use rayon::prelude::*;

use super::memory;
use super::progress::{Progress, ProgressMode};
use super::recorder::{Recorder, ResumeFile};
use super::runner::{CaseRunner, RunStatus};
use super::PlannedCase;
use crate::config::SweepSpec;
use crate::observe::OutcomeKind;
use crate::store::{CaseRecord, ClaimResult, Store, StoreError};

pub use super::recorder::{
    failed_state_path, prelude_path, resume_path, saved_failed_state, saved_prelude,
    saved_runner_state, saved_state, states_dir, SavedState,
};

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
    /// Largest estimated memory of one case, in bytes ([`crate::config::CaseSpec::memory_estimate`]);
    /// a sweep with a larger case is refused before anything is written. Default: the machine's
    /// physical memory ([`memory::total`]).
    pub max_case_memory: f64,
    /// A shard (one task of a cluster job): the database is a rollback-journal file on local
    /// disk, published with its saved states into this directory after every saved state and
    /// when the sweep ends ([`crate::store::shard::publish`]).
    pub publish: Option<PathBuf>,
    /// Link the cases run to the sweep without unlinking its others (the caller registered the
    /// sweep's cases: a round of tries); by default the sweep's cases become exactly these.
    pub keep_links: bool,
    /// Run only the cases with these ids (`xpflow sweep --case`); the sweep's others are
    /// registered as always and left as they are. `None`: every case.
    pub only: Option<std::collections::BTreeSet<String>>,
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
            max_case_memory: memory::total(),
            publish: None,
            keep_links: false,
            only: None,
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
    /// Cases not run because they were done or failed already.
    pub skipped: usize,
    /// Cases not run because another process is running them.
    pub elsewhere: usize,
    /// Cases left out by [`SweepOptions::only`] (whatever their status).
    pub left_out: usize,
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
    /// A case would need more memory than allowed; nothing was written.
    #[error(
        "case {index} ({label}): field `numerics.mesh`: {mesh} elements need about {} of memory, \
         more than the limit of {} (the machine's memory, or --max-memory); use a coarser mesh, \
         or raise --max-memory if the machine has it",
        memory::gb(*need),
        memory::gb(*limit)
    )]
    TooLarge {
        /// Case index.
        index: usize,
        /// Case label.
        label: String,
        /// The mesh, `n1×n2`.
        mesh: String,
        /// Estimated bytes.
        need: f64,
        /// The limit in bytes.
        limit: f64,
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
    check_memory(cases, opts.max_case_memory)?;
    let mut store = match &opts.publish {
        Some(_) => Store::open_shard(&opts.db)?,
        None => Store::open(&opts.db)?,
    };
    let sweep_id = store.register_sweep(sweep)?;
    if opts.keep_links {
        store.link_cases(sweep_id, cases)?;
    } else {
        store.add_cases(sweep_id, cases)?;
    }
    let reset = store.reset_interrupted(sweep_id, opts.retry_failed)?;
    // each case by its status now: pending ones are run, running ones (another process; those
    // of a killed one were reset above) are left to it, the others are done
    let mut pending: Vec<&PlannedCase> = Vec::new();
    let mut running_elsewhere = Vec::new();
    {
        let err = |source| StoreError::Sql {
            path: opts.db.clone(),
            source,
        };
        let mut st = store
            .connection()
            .prepare("SELECT status FROM cases WHERE case_hash = ?1")
            .map_err(err)?;
        for c in cases {
            if opts.only.as_ref().is_some_and(|only| !only.contains(&c.id)) {
                continue;
            }
            let status: String = st.query_row([&c.id], |r| r.get(0)).map_err(err)?;
            match status.as_str() {
                "pending" => pending.push(c),
                "running" => running_elsewhere.push(c),
                _ => {}
            }
        }
    }
    let jobs = opts.jobs.max(1).min(pending.len().max(1));
    let run_id = store.begin_run(sweep_id, jobs, &sweep.raw.to_string())?;
    let snapshot_dir = opts.snapshot_dir.clone().unwrap_or_else(|| {
        opts.db
            .parent()
            .map(|d| d.join(&sweep.name))
            .unwrap_or_else(|| PathBuf::from(&sweep.name))
    });
    let progress = Progress::new(opts.progress, pending.len());
    for c in &running_elsewhere {
        progress.log(&format!(
            "running elsewhere: {} ({}) is being run by another process",
            c.label, c.id
        ));
    }
    let left_out = opts.only.as_ref().map_or(0, |only| {
        cases.iter().filter(|c| !only.contains(&c.id)).count()
    });
    let selected = if left_out > 0 {
        format!(
            " ({} selected by --case or --where)",
            cases.len() - left_out
        )
    } else {
        String::new()
    };
    progress.log(&format!(
        "sweep {}: {} cases{selected}, {} to run ({} reset after interruption), {jobs} at a time, database {}",
        sweep.name,
        cases.len(),
        pending.len(),
        reset,
        opts.db.display()
    ));
    // (index in the sweep, case, what running it gave): `cases` may be part of a sweep (a task's one)
    let results: Mutex<Vec<(usize, &PlannedCase, CaseRun)>> = Mutex::new(Vec::new());
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
                    .push((case.index, case, r)),
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
    if let Some(dir) = &opts.publish {
        crate::store::shard::publish(&store, &states_dir(&opts.db), dir)?;
    }
    let mut results = results.into_inner().unwrap_or_else(|p| p.into_inner());
    results.sort_by_key(|r| r.0);
    let mut summary = SweepSummary {
        total: cases.len(),
        reset,
        left_out,
        ..Default::default()
    };
    for (_, case, r) in results {
        match r {
            CaseRun::Finished => summary.skipped += 1,
            CaseRun::Elsewhere => summary.elsewhere += 1,
            CaseRun::Ran { kind, failed } => {
                summary.ran += 1;
                summary.failed += usize::from(failed);
                summary.outcomes.push((case.label.clone(), kind));
            }
        }
    }
    summary.elsewhere += running_elsewhere.len();
    summary.skipped += cases.len() - left_out - pending.len() - running_elsewhere.len();
    Ok(summary)
}

/// Refuses a sweep with a case whose estimated memory is above `limit` bytes.
fn check_memory(cases: &[PlannedCase], limit: f64) -> Result<(), SweepError> {
    for c in cases {
        let need = c.spec.memory_estimate();
        if need > limit {
            let [n1, n2] = c.spec.numerics.mesh;
            return Err(SweepError::TooLarge {
                index: c.index,
                label: c.label.clone(),
                mesh: format!("{n1}×{n2}"),
                need,
                limit,
            });
        }
    }
    Ok(())
}

/// What running one case gave.
enum CaseRun {
    /// Run to an outcome (kind) or failed (kind `failed`).
    Ran {
        /// Outcome kind or `failed`.
        kind: String,
        /// Whether it failed.
        failed: bool,
    },
    /// Done or failed before this process came to it.
    Finished,
    /// Another process runs it.
    Elsewhere,
}

/// What a worker needs to run a case.
pub(super) struct CaseContext<'a> {
    runner: &'a dyn CaseRunner,
    pub(super) opts: &'a SweepOptions,
    pub(super) progress: &'a Progress,
    run_id: i64,
    pub(super) snapshot_dir: &'a PathBuf,
}

/// Claims and runs one case.
///
/// # Errors
/// A store error, among them [`StoreError::Vanished`] when the database was deleted or replaced
/// during the sweep: the case's result could not be recorded.
fn run_one(case: &PlannedCase, ctx: &CaseContext<'_>) -> Result<CaseRun, StoreError> {
    // the sweep made the database: a worker never creates one (a deleted file is an error)
    let mut store = Store::open_existing(&ctx.opts.db)?;
    let resume_path = resume_path(&ctx.opts.db, &case.id);
    let saved = ResumeFile::load(&resume_path, &case.id);
    let claim = match store.claim(&case.id, saved.as_ref().map(|r| (r.step, r.rows)))? {
        ClaimResult::Claimed(c) => c,
        ClaimResult::Finished => return Ok(CaseRun::Finished),
        ClaimResult::Elsewhere => {
            ctx.progress.log(&format!(
                "running elsewhere: {} ({}) is being run by another process",
                case.label, case.id
            ));
            return Ok(CaseRun::Elsewhere);
        }
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
    if let Some(r) = saved {
        rec.resume_from(r);
    }
    // an allocation that fails aborts the process (no unwinding): a case that does not fit in
    // the memory free now fails instead of taking the sweep with it
    let result = match memory::fits(&case.spec) {
        Err(error) => Ok(crate::simulate::CaseResult::failed(error)),
        Ok(()) => catch_unwind(AssertUnwindSafe(|| ctx.runner.run(&case.spec, &mut rec))),
    };
    let (status, steps, t, rejected, flow_solver) = match result {
        Ok(r) => (r.status, r.steps, r.t, r.rejected_steps, r.flow_solver),
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
                None,
                None,
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
    let mut outcome = outcome;
    if let (Some(o), Some(n)) = (outcome.as_mut(), rejected) {
        // what an adaptive step cost beside the steps kept
        o.final_state["rejected_steps"] = serde_json::json!(n);
    }
    if let (Some(o), Some(cpu)) = (outcome.as_mut(), rec.cpu_s().filter(|&c| c > 0.0)) {
        // what the case cost in CPU time, without the waits `wall_s` holds (a loaded machine,
        // a paused sweep): the estimates' calibration (a case too short for the clock, which
        // the kernel advances at scheduling events, reads zero: left out, as unknown)
        o.final_state["cpu_s"] = serde_json::json!(cpu);
    }
    if let (Some(o), Some(stats)) = (outcome.as_mut(), flow_solver) {
        // what the flow solves cost beyond their factorizations (in this process)
        o.final_state["flow_solver"] = serde_json::json!(stats);
    }
    for (what, e) in [
        ("snapshot", rec.snapshot_error.take()),
        ("saved state", rec.state_error.take()),
    ] {
        if let Some(e) = e {
            // the run stopped at the first write that failed: it did not give what was asked
            outcome = None;
            error = Some(match error {
                Some(prev) => format!("{what}: {e}; {prev}"),
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
        (Some(o), _) => match o.final_state.get("warning").and_then(|w| w.as_str()) {
            Some(w) => format!("{} (warning: {w})", o.kind.as_str()),
            None => o.kind.as_str().to_string(),
        },
        (None, e) => format!("failed ({})", e.as_deref().unwrap_or("")),
    };
    let failed = outcome.is_none();
    // a case whose state a diagnosis wants: failed, or ended by a non-physical state
    let troubled = outcome
        .as_ref()
        .is_none_or(|o| o.kind == OutcomeKind::Diverged);
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
    let kept = if troubled {
        keep_failed_state(&ctx.opts.db, &case.id)
    } else {
        // a state kept from an earlier failure is stale once the case has run through
        std::fs::remove_file(failed_state_path(&ctx.opts.db, &case.id)).ok();
        None
    };
    let summary = match kept {
        Some(step) => format!("{summary}; its saved state of step {step} kept for a diagnosis"),
        None => summary,
    };
    // a finished case (whatever its outcome) is never resumed (a failed one's state was kept)
    std::fs::remove_file(&resume_path).ok();
    std::fs::remove_file(prelude_path(&ctx.opts.db, &case.id)).ok();
    if let Some(bar) = bar {
        ctx.progress.finish_case(bar, &summary);
    }
    Ok(CaseRun::Ran { kind, failed })
}

/// A case that failed or diverged keeps its last saved state (the step before its trouble, up to
/// `--state-every` earlier) at [`failed_state_path`], so that the failure can be reproduced from there in
/// minutes instead of from t = 0; an older kept state is replaced. The step of the kept state, if
/// the case had one.
fn keep_failed_state(db: &std::path::Path, hash: &str) -> Option<u64> {
    let step = saved_state(db, hash)?.step;
    std::fs::rename(resume_path(db, hash), failed_state_path(db, hash))
        .ok()
        .map(|()| step)
}
