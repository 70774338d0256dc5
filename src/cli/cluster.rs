//! The cluster commands: `xpflow sweep FILE --slurm` (write, and with `--submit` submit, a round
//! of job arrays), `xpflow run-case` (one array task), `xpflow merge` (fold shards into the
//! sweep's database) and `xpflow status --submission DIR`. The work is in
//! [`crate::sweep::slurm`], [`crate::sweep::task`] and [`crate::store::merge`].

use std::collections::BTreeSet;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use super::sweep_cmds::{at_least_one, invalid, minutes, SweepArgs, EXIT_INVALID};
use crate::config::{PlannedCase, SweepSpec};
use crate::store::merge::{MergeError, Merged};
use crate::store::shard::{shard_cases, shard_files};
use crate::store::{Format, Store, Table};
use crate::sweep::progress::ProgressMode;
use crate::sweep::slurm::estimate::Rate;
use crate::sweep::slurm::script::DEFAULT_MAX_ARRAY_SIZE;
use crate::sweep::slurm::status::{case_states, CaseState};
use crate::sweep::slurm::{self, scheduler, Submission};
use crate::sweep::task::{case_of, run_task, shard_path, Marker, TaskOptions, TaskOutcome};
use crate::sweep::CaseRunner;

/// The `--slurm` options of `xpflow sweep`.
#[derive(Debug, Clone, Default, clap::Args)]
pub struct SlurmArgs {
    /// Run the sweep on a SLURM cluster: write a submission directory (manifest, job array
    /// scripts, logs/, shards/) for the cases not done yet (docs/cluster.md).
    #[arg(long)]
    pub slurm: bool,
    /// Submit the arrays with sbatch and print their job ids.
    #[arg(long, requires = "slurm")]
    pub submit: bool,
    /// Continue an earlier submission: a new round with the cases not done, failed or
    /// interrupted (those queued or running are left to their tasks).
    #[arg(long, requires = "slurm")]
    pub resume: bool,
    /// Submission directory (default: `<db dir>/<db stem>.slurm`).
    #[arg(long, requires = "slurm")]
    pub submission: Option<PathBuf>,
    /// SLURM partition.
    #[arg(long, requires = "slurm")]
    pub partition: Option<String>,
    /// SLURM account.
    #[arg(long, requires = "slurm")]
    pub account: Option<String>,
    /// Time limit of each task, as SLURM reads it [default: estimated from the cases].
    #[arg(long, requires = "slurm")]
    pub time: Option<String>,
    /// Memory of each task, as SLURM reads it (e.g. 4G) [default: the largest case's estimate].
    #[arg(long, requires = "slurm")]
    pub mem: Option<String>,
    /// Most tasks running at once (`--array=…%K`).
    #[arg(long, requires = "slurm", value_parser = at_least_one)]
    pub max_running: Option<usize>,
}

/// `xpflow run-case`: one task of a submission.
#[derive(Debug, Clone, clap::Args)]
pub struct RunCaseArgs {
    /// The round's manifest.
    #[arg(long)]
    pub manifest: PathBuf,
    /// Array index (manifest line after the header).
    #[arg(long)]
    pub index: usize,
    /// Shard directory.
    #[arg(long)]
    pub shards: PathBuf,
    /// Local directory for the shard while it is written [default: $TMPDIR].
    #[arg(long)]
    pub local: Option<PathBuf>,
    /// Minutes between saved (and published) solver states.
    #[arg(long, default_value_t = 5.0, value_parser = minutes)]
    pub state_every: f64,
    /// The task's log file, named in its failure marker.
    #[arg(long)]
    pub log: Option<PathBuf>,
    /// No progress output.
    #[arg(long)]
    pub quiet: bool,
}

/// `xpflow merge DB SHARD_DIR...`.
#[derive(Debug, Clone, clap::Args)]
pub struct MergeArgs {
    /// The sweep's results database (created if missing).
    pub db: PathBuf,
    /// Shard directories (or shard files).
    #[arg(required = true)]
    pub shards: Vec<PathBuf>,
}

/// `xpflow sweep FILE --slurm`: a new round of the submission for the cases not done.
pub(super) fn sweep_slurm(
    args: &SweepArgs,
    spec: &SweepSpec,
    cases: &[PlannedCase],
    runner: &dyn CaseRunner,
    out: &mut dyn Write,
) -> anyhow::Result<ExitCode> {
    sweep_slurm_round(args, spec, cases, cases, None, runner, out)
}

/// [`sweep_slurm`] for a sweep whose rounds follow from its outcomes (`[tries]`): `cases` are
/// the sweep's cases so far (registered in the database), `candidates` those this round may
/// submit (the others are finished or not needed), and `next` says how the round after this one
/// is planned.
pub(super) fn sweep_slurm_round(
    args: &SweepArgs,
    spec: &SweepSpec,
    cases: &[PlannedCase],
    candidates: &[PlannedCase],
    next: Option<&str>,
    runner: &dyn CaseRunner,
    out: &mut dyn Write,
) -> anyhow::Result<ExitCode> {
    for c in cases {
        if let Err(reason) = runner.supports(&c.spec) {
            return invalid(&format!(
                "{}: case {} ({}): {reason}; nothing was written",
                args.file.display(),
                c.index,
                c.label
            ));
        }
    }
    let db = args
        .db
        .clone()
        .unwrap_or_else(|| Path::new("results").join(format!("{}.db", spec.name)));
    let s = &args.slurm;
    let sub = Submission::new(
        &s.submission
            .clone()
            .unwrap_or_else(|| Submission::default_dir(&db)),
    );
    let rounds = sub.rounds();
    if !s.resume && !rounds.is_empty() {
        return invalid(&format!(
            "{} holds {} round(s) of an earlier submission; `--slurm --resume` submits what is \
             not done (`xpflow status --submission {}` shows it)",
            sub.dir.display(),
            rounds.len(),
            sub.dir.display()
        ));
    }
    // the sweep's database lists every case (pending until merged) and says which are done
    let mut store = match Store::open(&db) {
        Ok(st) => st,
        Err(e) if e.is_bad_input() => return invalid(&e),
        Err(e) => return Err(e.into()),
    };
    let sweep_id = store.register_sweep(spec)?;
    store.add_cases(sweep_id, cases)?;
    let done: BTreeSet<String> = store
        .statuses()?
        .into_iter()
        .filter(|(_, st)| st == "done")
        .map(|(h, _)| h)
        .collect();
    let finished = slurm::estimate::finished_cases(&store)?;
    drop(store);
    let queue = sub.queue();
    let plan = slurm::plan(&sub, candidates, &done, queue.as_deref());
    if queue.is_none() && !rounds.is_empty() && !plan.cases.is_empty() {
        writeln!(
            out,
            "warning: squeue does not answer: tasks still queued or running cannot be told from \
             interrupted ones and are submitted again"
        )?;
    }
    if plan.cases.is_empty() {
        writeln!(
            out,
            "sweep {}: nothing to submit ({} cases: {} done, {} queued or running)",
            spec.name,
            cases.len(),
            plan.done,
            plan.active
        )?;
        if let Some(next) = next {
            writeln!(out, "{next}")?;
        }
        return Ok(ExitCode::SUCCESS);
    }
    let rate = Rate::from_finished(&finished);
    let mut res = slurm::resources(&plan.cases, &rate, s.time.as_deref(), s.mem.as_deref());
    res.partition.clone_from(&s.partition);
    res.account.clone_from(&s.account);
    res.max_running = s.max_running;
    res.state_every = Some(args.state_every);
    let max_array = scheduler::max_array_size().unwrap_or(DEFAULT_MAX_ARRAY_SIZE);
    let mut round = slurm::write_round(&sub, &spec.file, &spec.name, &plan.cases, &res, max_array)?;
    writeln!(
        out,
        "sweep {}: {} cases, {} done, {} queued or running; round {} submits {} in {} array(s) \
         (MaxArraySize {max_array}), --mem {} --time {}: {}",
        spec.name,
        cases.len(),
        plan.done,
        plan.active,
        round.number,
        plan.cases.len(),
        round.jobs.len(),
        res.mem,
        res.time,
        round.dir.display()
    )?;
    for note in &res.notes {
        writeln!(out, "  {note}")?;
    }
    if s.submit {
        let ids = slurm::submit(&mut round)?;
        writeln!(out, "submitted job array(s): {}", ids.join(" "))?;
    } else {
        for (chunk, _) in &round.jobs {
            writeln!(
                out,
                "submit with: sbatch {}{}",
                if chunk.number > 0 {
                    "--dependency=afterany:<previous job id> "
                } else {
                    ""
                },
                round.script(chunk).display()
            )?;
        }
    }
    writeln!(
        out,
        "then: xpflow status --submission {0}; xpflow merge {1} {0}/shards",
        sub.dir.display(),
        db.display()
    )?;
    if let Some(next) = next {
        writeln!(out, "{next}")?;
    }
    Ok(ExitCode::SUCCESS)
}

/// Handler of `xpflow run-case` with the solver's runner.
pub fn run_case(args: &RunCaseArgs) -> anyhow::Result<ExitCode> {
    let runner = crate::sweep::default_runner();
    run_case_with(args, runner.as_ref(), &mut std::io::stdout())
}

/// Handler of `xpflow run-case` with a given runner (testable). A task that fails leaves its
/// marker beside the shards.
pub fn run_case_with(
    args: &RunCaseArgs,
    runner: &dyn CaseRunner,
    out: &mut dyn Write,
) -> anyhow::Result<ExitCode> {
    let opts = TaskOptions {
        manifest: args.manifest.clone(),
        index: args.index,
        shards: args.shards.clone(),
        local: args.local.clone().unwrap_or_else(std::env::temp_dir),
        state_every: std::time::Duration::from_secs_f64(args.state_every * 60.0),
        progress: ProgressMode::detect(args.quiet),
    };
    let (code, error) = match run_task(&opts, runner) {
        Ok(TaskOutcome::AlreadyDone { case }) => {
            writeln!(out, "case {case}: done already (its shard is published)")?;
            return Ok(ExitCode::SUCCESS);
        }
        Ok(TaskOutcome::Ran {
            case,
            restored,
            summary,
        }) => {
            let outcome = summary.outcomes.first().map_or("-", |o| o.1.as_str());
            writeln!(
                out,
                "case {case}: {outcome}{}; shard {}",
                if restored {
                    " (continued an earlier task's shard)"
                } else {
                    ""
                },
                shard_path(&args.shards, &case).display()
            )?;
            if summary.failed == 0 {
                return Ok(ExitCode::SUCCESS);
            }
            let error = shard_cases(&shard_path(&args.shards, &case))
                .ok()
                .and_then(|c| c.into_iter().next())
                .and_then(|c| c.error)
                .unwrap_or_else(|| "the case failed".into());
            (1, error)
        }
        Err(e) => {
            eprintln!("error: {e}");
            (
                if e.is_bad_input() { EXIT_INVALID } else { 1 },
                e.to_string(),
            )
        }
    };
    let job = std::env::var("SLURM_ARRAY_JOB_ID")
        .ok()
        .zip(std::env::var("SLURM_ARRAY_TASK_ID").ok())
        .map(|(j, t)| format!("{j}_{t}"));
    let marker = Marker {
        case: case_of(&opts),
        index: args.index,
        exit_code: code,
        error,
        log: args.log.clone(),
        host: crate::store::hostname(),
        job,
    };
    match marker.write(&args.shards) {
        Ok(path) => writeln!(out, "failed: marker {}", path.display())?,
        Err(e) => eprintln!("error: cannot write the failure marker: {e}"),
    }
    Ok(ExitCode::from(code))
}

/// Handler of `xpflow merge`.
pub fn merge(args: &MergeArgs) -> anyhow::Result<ExitCode> {
    merge_to(args, &mut std::io::stdout())
}

/// Handler of `xpflow merge` writing to `out` (testable). Exit 1 when a shard is damaged or in
/// conflict with the database (the others are merged), 2 for a shard directory that is not there.
pub fn merge_to(args: &MergeArgs, out: &mut dyn Write) -> anyhow::Result<ExitCode> {
    let mut files = Vec::new();
    for d in &args.shards {
        if d.is_file() {
            files.push(d.clone());
        } else if d.is_dir() {
            files.extend(shard_files(d));
        } else {
            return invalid(&format!("shard directory {} does not exist", d.display()));
        }
    }
    let mut store = match Store::open(&args.db) {
        Ok(s) => s,
        Err(e) if e.is_bad_input() => return invalid(&e),
        Err(e) => return Err(e.into()),
    };
    let (mut merged, mut already, mut ignored, mut unfinished, mut trouble) = (0, 0, 0, 0, 0);
    for f in &files {
        match store.merge_shard(f) {
            Ok(Merged::Merged { case, status, .. }) => {
                merged += 1;
                writeln!(out, "merged {case} ({status}) from {}", f.display())?;
            }
            Ok(Merged::AlreadyMerged) => already += 1,
            Ok(Merged::Ignored { .. }) => ignored += 1,
            Ok(Merged::NotFinished { case }) => {
                unfinished += 1;
                writeln!(out, "not finished: {case} ({}): not merged", f.display())?;
            }
            Ok(Merged::Conflict { case, reason }) => {
                trouble += 1;
                writeln!(out, "conflict: {case} ({}): {reason}", f.display())?;
            }
            Err(MergeError::BadShard { path, reason }) => {
                trouble += 1;
                writeln!(out, "bad shard {}: {reason}", path.display())?;
            }
            Err(MergeError::Store(e)) => return Err(e.into()),
        }
    }
    let integrity = store.integrity_check()?;
    writeln!(
        out,
        "merge into {}: {} shards: {merged} merged, {already} merged before, {ignored} failed \
         attempts of cases done, {unfinished} not finished, {trouble} conflicts or bad shards; \
         integrity {integrity}",
        args.db.display(),
        files.len()
    )?;
    Ok(if trouble > 0 || integrity != "ok" {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    })
}

/// `xpflow status --submission DIR`: counts by state and the cases not done.
pub(super) fn submission_status(dir: &Path, out: &mut dyn Write) -> anyhow::Result<()> {
    let sub = Submission::new(dir);
    if sub.rounds().is_empty() {
        anyhow::bail!(
            "{} is not a submission directory (no round-N/manifest.txt)",
            dir.display()
        );
    }
    let queue = sub.queue();
    let states = case_states(&sub, queue.as_deref());
    let count = |name: &str| states.iter().filter(|s| s.state.name() == name).count();
    writeln!(
        out,
        "submission {}: {} cases: {} done, {} failed, {} running, {} pending, {} interrupted, {} not run{}",
        sub.dir.display(),
        states.len(),
        count("done"),
        count("failed"),
        count("running"),
        count("pending"),
        count("interrupted"),
        count("not run"),
        if queue.is_none() { " (squeue does not answer: queued and running tasks are not known)" } else { "" }
    )?;
    let mut t = Table {
        columns: ["case", "round", "index", "state", "detail"]
            .map(String::from)
            .to_vec(),
        rows: Vec::new(),
    };
    for s in states.iter().filter(|s| s.state != CaseState::Done) {
        let detail = match &s.state {
            CaseState::Failed { error, log } => match log {
                Some(l) => format!("{error} (log {l})"),
                None => error.clone(),
            },
            CaseState::Interrupted {
                saved: Some((step, t)),
            } => {
                format!("saved state at step {step}, t = {t:.3}")
            }
            CaseState::Interrupted { saved: None } => "no saved state (restarts at t = 0)".into(),
            _ => String::new(),
        };
        t.rows.push(vec![
            s.case.clone().into(),
            s.round.into(),
            s.index.into(),
            s.state.name().to_string().into(),
            detail.into(),
        ]);
    }
    if !t.rows.is_empty() {
        write!(out, "{}", t.render(Format::Table))?;
    }
    Ok(())
}
