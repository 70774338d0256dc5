//! Sweep, query and status subcommands: clap argument structs and handlers that wrap the library.
//!
//! Exit codes: 0 success; 1 the sweep ran but some cases failed (their snapshots or saved states
//! could not be written included), or a runtime error (the database deleted during the sweep); 2 the
//! input is invalid — the sweep file, a case the solver cannot run or that needs more memory than
//! allowed, a query, a database that is missing or not xpflow's — in which case nothing is written.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Context;

use crate::config::{PlannedCase, SweepSpec};
use crate::store::query::{Filter, QueryKind, FILTER_COLUMNS};
use crate::store::{Format, Store, Table};
use crate::sweep::engine::SweepError;
use crate::sweep::expand::expand_at_most;
use crate::sweep::progress::ProgressMode;
use crate::sweep::{default_runner, CaseRunner, SweepOptions};

/// Exit code of invalid input (sweep file, query) — nothing was written.
pub(super) const EXIT_INVALID: u8 = 2;

/// `xpflow sweep FILE`: run (or resume) a sweep.
#[derive(Debug, Clone, clap::Args)]
pub struct SweepArgs {
    /// Sweep file (TOML, or JSON with a .json extension).
    pub file: PathBuf,
    /// Results database (default: `results/<sweep name>.db`).
    #[arg(long)]
    pub db: Option<PathBuf>,
    /// Cases run at once [default: number of cores].
    #[arg(long, value_parser = at_least_one)]
    pub jobs: Option<usize>,
    /// List the expanded cases with their ids and exit.
    #[arg(long)]
    pub dry_run: bool,
    /// With --dry-run: print every case's resolved numerical settings (all defaults filled in).
    #[arg(long, requires = "dry_run")]
    pub resolved: bool,
    /// With --dry-run: the estimated core-hours of every case and of the sweep (an upper bound at
    /// the rate of the database's slowest finished case, or the benchmark's), and what is left.
    #[arg(long, requires = "dry_run")]
    pub estimate: bool,
    /// No progress output.
    #[arg(long)]
    pub quiet: bool,
    /// Rerun cases recorded as failed.
    #[arg(long)]
    pub retry_failed: bool,
    /// Run only these cases (ids, or unique prefixes of them, as `--dry-run` lists them;
    /// comma-separated or repeated): the sweep's other cases stay registered with their results
    /// and are not run. With `--dry-run`, list (and estimate) only these. Not with `--slurm` or a
    /// sweep file with a `[search]` or `[tries]` section.
    #[arg(long = "case", value_name = "ID", value_delimiter = ',')]
    pub cases: Vec<String>,
    /// Minutes between saved solver states of a running case: a killed case continues from its
    /// last one (0: after every step).
    #[arg(long, default_value_t = 5.0, value_parser = minutes)]
    pub state_every: f64,
    /// Largest estimated memory of one case, in GB: a sweep with a larger case is refused before
    /// anything runs [default: the machine's physical memory].
    #[arg(long, value_parser = gigabytes)]
    pub max_memory: Option<f64>,
    /// Most cases a sweep file may expand to.
    #[arg(long, default_value_t = crate::sweep::expand::DEFAULT_MAX_CASES, value_parser = at_least_one)]
    pub max_cases: usize,
    /// Running on a SLURM cluster instead of here.
    #[command(flatten)]
    pub slurm: super::cluster::SlurmArgs,
}

/// A count ≥ 1 (`--jobs`, `--max-cases`).
pub(super) fn at_least_one(s: &str) -> Result<usize, String> {
    match s.parse::<usize>() {
        Ok(n) if n >= 1 => Ok(n),
        Ok(_) => Err("must be at least 1".into()),
        Err(e) => Err(format!("`{s}` is not a whole number: {e}")),
    }
}

/// Minutes ≥ 0, finite (`--state-every`).
pub(super) fn minutes(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(m) if m.is_finite() && m >= 0.0 => Ok(m),
        _ => Err(format!("`{s}` is not a number of minutes ≥ 0")),
    }
}

/// Gigabytes > 0, finite (`--max-memory`).
fn gigabytes(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(g) if g.is_finite() && g > 0.0 => Ok(g),
        _ => Err(format!("`{s}` is not a number of gigabytes > 0")),
    }
}

/// What `xpflow query` tabulates.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum QueryWhat {
    /// String formation, Wi × N (thesis Table 5.2).
    Strings,
    /// Outcome kinds, δ × Wi (thesis Fig. 5.26).
    Regime,
    /// Final r* of Couette cases by a parameter (`--by`).
    FinalR,
    /// One row per case with status and outcome.
    Cases,
    /// Final state of every particle of every decided case: position, ω*, gap to the next particle
    /// along the chain (thesis 5.6.3 final positions, 5.7.2 terminal ω* and gaps); for a run that
    /// went on past its decision (no early stop) also its state at the end (`state` = `end`).
    Final,
    /// Raw samples of one case (`--case ID`).
    Trajectory,
    /// Extrusion cases (thesis §6.4–6.5): swell ratio, the particle's final separation s from the
    /// undisturbed surface and its final position.
    Extrusion,
    /// The brackets a search found: per combination of the other axes, each boundary with the
    /// values and outcomes on both sides (sweeps with a `[search]` section).
    Boundaries,
}

/// `xpflow query WHAT`: tables from a results database.
#[derive(Debug, Clone, clap::Args)]
pub struct QueryArgs {
    /// What to tabulate.
    #[arg(value_enum)]
    pub what: QueryWhat,
    /// Results database.
    #[arg(long)]
    pub db: PathBuf,
    /// Only cases of this sweep.
    #[arg(long)]
    pub sweep: Option<String>,
    /// Filter `column=value` (repeatable), e.g. `--where alpha=0.01`.
    #[arg(long = "where", value_name = "COLUMN=VALUE")]
    pub filters: Vec<String>,
    /// Case id (prefix): the case of `trajectory`; every other table only its case(s).
    #[arg(long)]
    pub case: Option<String>,
    /// Parameter column ordering `final-r` [default: r0].
    #[arg(long, default_value = "r0")]
    pub by: String,
    /// Output format.
    #[arg(long, value_enum, default_value_t = Format::Table)]
    pub format: Format,
}

/// `xpflow status`: per-sweep case counts.
#[derive(Debug, Clone, clap::Args)]
pub struct StatusArgs {
    /// Results databases [default: every results/*.db, unless --submission is given].
    #[arg(long)]
    pub db: Vec<PathBuf>,
    /// Submission directories of `xpflow sweep --slurm`: each case done / failed / running /
    /// pending / interrupted / not run, from its shards, markers and squeue.
    #[arg(long)]
    pub submission: Vec<PathBuf>,
}

/// Handler of `xpflow sweep` with the solver's runner.
pub fn run_sweep(args: &SweepArgs) -> anyhow::Result<ExitCode> {
    let runner = default_runner();
    run_sweep_with(args, runner.as_ref(), &mut std::io::stdout())
}

/// Handler of `xpflow sweep` with a given runner, writing listings to `out` (testable).
pub fn run_sweep_with(
    args: &SweepArgs,
    runner: &dyn CaseRunner,
    out: &mut dyn Write,
) -> anyhow::Result<ExitCode> {
    let spec = match SweepSpec::from_file(&args.file) {
        Ok(s) => s,
        Err(e) => return invalid(&e),
    };
    if !args.cases.is_empty() {
        let with = if spec.search.is_some() {
            Some("a sweep file with a [search] section (its cases are chosen as it runs)")
        } else if spec.tries.is_some() {
            Some("a sweep file with a [tries] section (its rounds choose the cases)")
        } else if args.slurm.slurm {
            Some("--slurm")
        } else {
            None
        };
        if let Some(with) = with {
            return invalid(&format!(
                "{}: --case cannot be used with {with}",
                args.file.display()
            ));
        }
    }
    if spec.search.is_some() {
        return super::search_cmds::run_search(args, &spec, runner, out);
    }
    let cases = match expand_at_most(&spec, args.max_cases) {
        Ok(c) => c,
        Err(e) => return invalid(&e),
    };
    if spec.tries.is_some() {
        return super::tries_cmds::run(args, &spec, &cases, runner, out);
    }
    let only = match select_cases(&cases, &args.cases) {
        Ok(only) => only,
        Err(e) => return invalid(&format!("{}: {e}", args.file.display())),
    };
    if args.dry_run {
        let listed: Vec<PlannedCase> = cases
            .iter()
            .filter(|c| only.as_ref().is_none_or(|o| o.contains(&c.id)))
            .cloned()
            .collect();
        list_cases(&listed, out)?;
        if listed.len() < cases.len() {
            writeln!(
                out,
                "{} of the {} cases in sweep {} (--case)",
                listed.len(),
                cases.len(),
                spec.name
            )?;
        } else {
            writeln!(out, "{} cases in sweep {}", cases.len(), spec.name)?;
        }
        if args.resolved {
            print_resolved(&listed, out)?;
        }
        if args.estimate {
            let db = sweep_options(args, &spec).db;
            super::estimate::print_estimate(&listed, &db, out)?;
        }
        return Ok(ExitCode::SUCCESS);
    }
    if args.slurm.slurm {
        return super::cluster::sweep_slurm(args, &spec, &cases, runner, out);
    }
    let mut opts = sweep_options(args, &spec);
    opts.only = only;
    match crate::sweep::run_sweep(&spec, &cases, runner, &opts) {
        Ok(summary) => {
            if !args.quiet {
                let elsewhere = if summary.elsewhere > 0 {
                    format!(", {} running elsewhere", summary.elsewhere)
                } else {
                    String::new()
                };
                let left_out = if summary.left_out > 0 {
                    format!(", {} not selected (--case)", summary.left_out)
                } else {
                    String::new()
                };
                writeln!(
                    out,
                    "sweep {}: {} cases, {} run, {} failed, {} skipped (done before){elsewhere}{left_out}; \
                     results in {}",
                    spec.name,
                    summary.total,
                    summary.ran,
                    summary.failed,
                    summary.skipped,
                    opts.db.display()
                )?;
            }
            Ok(if summary.failed > 0 {
                ExitCode::FAILURE
            } else {
                ExitCode::SUCCESS
            })
        }
        Err(e @ (SweepError::Unsupported { .. } | SweepError::TooLarge { .. })) => {
            eprintln!("error: {}: {e}; nothing was run", args.file.display());
            Ok(ExitCode::from(EXIT_INVALID))
        }
        Err(SweepError::Store(e)) if e.is_bad_input() => invalid(&e),
        Err(e) => Err(e).context(format!("sweep {}", spec.name)),
    }
}

/// The case ids `--case` selects (`None` when it is not given): each of `wanted` must be the id,
/// or a prefix of the id, of exactly one case.
pub(super) fn select_cases(
    cases: &[PlannedCase],
    wanted: &[String],
) -> Result<Option<std::collections::BTreeSet<String>>, String> {
    if wanted.is_empty() {
        return Ok(None);
    }
    let mut only = std::collections::BTreeSet::new();
    for w in wanted {
        let w = w.trim();
        let matching: Vec<&PlannedCase> = cases
            .iter()
            .filter(|c| !w.is_empty() && c.id.starts_with(w))
            .collect();
        match matching.as_slice() {
            [c] => {
                only.insert(c.id.clone());
            }
            [] => {
                return Err(format!(
                    "--case `{w}`: no case of the sweep has this id (`--dry-run` lists them)"
                ))
            }
            several => {
                return Err(format!(
                    "--case `{w}`: ambiguous, the id of {} cases begins so ({}): give more of it",
                    several.len(),
                    several
                        .iter()
                        .map(|c| c.id.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                ))
            }
        }
    }
    Ok(Some(only))
}

/// The `--dry-run` listing of planned cases: index, id, label.
pub(super) fn list_cases(cases: &[PlannedCase], out: &mut dyn Write) -> std::io::Result<()> {
    let mut t = Table {
        columns: vec!["index".into(), "id".into(), "label".into()],
        rows: Vec::new(),
    };
    for c in cases {
        t.rows.push(vec![
            c.index.into(),
            c.id.clone().into(),
            c.label.clone().into(),
        ]);
    }
    write!(out, "{}", t.render(Format::Table))
}

/// `--dry-run --resolved`: every case's resolved numerical settings.
pub(super) fn print_resolved(cases: &[PlannedCase], out: &mut dyn Write) -> std::io::Result<()> {
    for c in cases {
        let settings = crate::simulate::Settings::of(&c.spec).to_toml();
        writeln!(
            out,
            "\n# case {} {} ({})\n{settings}",
            c.index, c.id, c.label
        )?;
    }
    Ok(())
}

/// The engine's options from the command line (database, jobs, retries, saved states, progress,
/// memory limit).
pub(super) fn sweep_options(args: &SweepArgs, spec: &SweepSpec) -> SweepOptions {
    let db = args
        .db
        .clone()
        .unwrap_or_else(|| Path::new("results").join(format!("{}.db", spec.name)));
    let mut opts = SweepOptions::new(db);
    if let Some(j) = args.jobs {
        opts.jobs = j;
    }
    opts.retry_failed = args.retry_failed;
    opts.state_every = std::time::Duration::from_secs_f64(args.state_every * 60.0);
    opts.progress = ProgressMode::detect(args.quiet);
    if let Some(gb) = args.max_memory {
        opts.max_case_memory = gb * 1e9;
    }
    opts
}

pub(super) fn invalid(e: &dyn std::fmt::Display) -> anyhow::Result<ExitCode> {
    eprintln!("error: {e}");
    Ok(ExitCode::from(EXIT_INVALID))
}

/// Handler of `xpflow query`.
pub fn run_query(args: &QueryArgs) -> anyhow::Result<ExitCode> {
    run_query_to(args, &mut std::io::stdout())
}

/// Handler of `xpflow query` writing to `out` (testable).
pub fn run_query_to(args: &QueryArgs, out: &mut dyn Write) -> anyhow::Result<ExitCode> {
    let filters: Result<Vec<Filter>, String> = args.filters.iter().map(|f| f.parse()).collect();
    let mut filters = match filters {
        Ok(f) => f,
        Err(e) => return invalid(&e),
    };
    if let (Some(id), false) = (&args.case, args.what == QueryWhat::Trajectory) {
        // every other table restricted to the case(s) of that id prefix
        filters.push(Filter::case(id));
    }
    let kind = match args.what {
        QueryWhat::Strings => QueryKind::StringFormation,
        QueryWhat::Regime => QueryKind::Regime,
        QueryWhat::Cases => QueryKind::Cases,
        QueryWhat::Final => QueryKind::Final,
        QueryWhat::Extrusion => QueryKind::Extrusion,
        QueryWhat::FinalR => match FILTER_COLUMNS.iter().find(|c| **c == args.by) {
            Some(c) => QueryKind::FinalRStar(c),
            None => {
                return invalid(&format!(
                    "--by {}: use one of {}",
                    args.by,
                    FILTER_COLUMNS.join(", ")
                ))
            }
        },
        QueryWhat::Boundaries => return super::search_cmds::query_boundaries(args, &filters, out),
        QueryWhat::Trajectory => match &args.case {
            Some(c) => QueryKind::Trajectory(c.clone()),
            None => return invalid(&"trajectory needs --case ID (see `xpflow query cases`)"),
        },
    };
    // a reader: read-only, never creates or changes the file
    let store = match Store::open_read_only(&args.db) {
        Ok(s) => s,
        Err(e) if e.is_bad_input() => return invalid(&e),
        Err(e) => return Err(e.into()),
    };
    match store.query(&kind, args.sweep.as_deref(), &filters) {
        Ok(t) => {
            write!(out, "{}", t.render(args.format))?;
            Ok(ExitCode::SUCCESS)
        }
        Err(e) if e.is_bad_input() => invalid(&e),
        Err(e) => Err(e.into()),
    }
}

/// Handler of `xpflow status`.
pub fn run_status(args: &StatusArgs) -> anyhow::Result<ExitCode> {
    run_status_to(args, &mut std::io::stdout())
}

/// Handler of `xpflow status` writing to `out` (testable).
pub fn run_status_to(args: &StatusArgs, out: &mut dyn Write) -> anyhow::Result<ExitCode> {
    for dir in &args.submission {
        if let Err(e) = super::cluster::submission_status(dir, out) {
            return invalid(&e);
        }
    }
    if !args.submission.is_empty() && args.db.is_empty() {
        return Ok(ExitCode::SUCCESS);
    }
    let dbs: Vec<PathBuf> = if args.db.is_empty() {
        let mut v: Vec<PathBuf> = std::fs::read_dir("results")
            .map(|d| {
                d.filter_map(|e| e.ok().map(|e| e.path()))
                    .filter(|p| p.extension().is_some_and(|e| e == "db"))
                    .collect()
            })
            .unwrap_or_default();
        v.sort();
        v
    } else {
        args.db.clone()
    };
    let mut running = Vec::new();
    let mut failed = Vec::new();
    let mut t = Table {
        columns: [
            "database", "sweep", "cases", "done", "running", "failed", "pending",
        ]
        .map(String::from)
        .to_vec(),
        rows: Vec::new(),
    };
    for db in &dbs {
        // a reader: read-only, never creates or changes the file
        let store = match Store::open_read_only(db) {
            Ok(s) => s,
            Err(e) if e.is_bad_input() => return invalid(&e),
            Err(e) => return Err(e.into()),
        };
        running.extend(store.running_cases()?.into_iter().map(|c| (db, c)));
        failed.extend(store.failed_cases()?.into_iter().map(|c| (db, c)));
        for c in store.counts(None)? {
            t.rows.push(vec![
                db.display().to_string().into(),
                c.name.into(),
                c.total.into(),
                c.done.into(),
                c.running.into(),
                c.failed.into(),
                c.pending.into(),
            ]);
        }
    }
    write!(out, "{}", t.render(Format::Table))?;
    // the running (or interrupted) cases: how far they got and where a rerun continues
    let mut r = Table {
        columns: [
            "database",
            "sweep",
            "case",
            "label",
            "process",
            "t stored",
            "t_end",
            "Δt",
            "saved state",
        ]
        .map(String::from)
        .to_vec(),
        rows: Vec::new(),
    };
    for (db, c) in running {
        let saved = match crate::sweep::engine::saved_state(db, &c.hash) {
            Some((step, t, _)) => format!("step {step}, t = {t:.2}"),
            None => match crate::sweep::engine::saved_prelude(db, &c.hash) {
                Some(steps) => format!("prelude step {steps} (t = 0 follows it)"),
                None => "none (restarts at t = 0)".into(),
            },
        };
        let process = match c.alive {
            Some(true) => "running",
            Some(false) => "interrupted",
            None => "other host",
        };
        r.rows.push(vec![
            db.display().to_string().into(),
            c.sweep.into(),
            c.hash.into(),
            c.label.into(),
            process.to_string().into(),
            c.t_stored
                .map_or_else(|| "-".to_string(), |t| format!("{t:.2}"))
                .into(),
            c.t_end
                .map_or_else(|| "-".to_string(), |t| format!("{t}"))
                .into(),
            c.dt_recent
                .map_or_else(|| "-".to_string(), |dt| format!("{dt:.4}"))
                .into(),
            saved.into(),
        ]);
    }
    if !r.rows.is_empty() {
        writeln!(
            out,
            "\nrunning or interrupted cases (rerun the sweep to continue the interrupted ones):"
        )?;
        write!(out, "{}", r.render(Format::Table))?;
    }
    write_failed(&failed, out)?;
    Ok(ExitCode::SUCCESS)
}

/// The failed cases of `xpflow status`: why, how far they got, and the state each kept
/// (`sweep::engine::keep_failed_state`).
fn write_failed(
    failed: &[(&PathBuf, crate::store::FailedCase)],
    out: &mut dyn Write,
) -> anyhow::Result<()> {
    if failed.is_empty() {
        return Ok(());
    }
    let mut f = Table {
        columns: [
            "database",
            "sweep",
            "case",
            "label",
            "status",
            "t reached",
            "kept state",
            "error",
        ]
        .map(String::from)
        .to_vec(),
        rows: Vec::new(),
    };
    for (db, c) in failed {
        let kept = match crate::sweep::engine::saved_failed_state(db, &c.hash) {
            Some((step, t, _)) => format!("step {step}, t = {t:.2}"),
            None => "none (restarts at t = 0)".into(),
        };
        f.rows.push(vec![
            db.display().to_string().into(),
            c.sweep.clone().into(),
            c.hash.clone().into(),
            c.label.clone().into(),
            c.kind.clone().into(),
            c.t_reached
                .map_or_else(|| "-".to_string(), |t| format!("{t:.2}"))
                .into(),
            kept.into(),
            c.error.clone().unwrap_or_default().into(),
        ]);
    }
    writeln!(
        out,
        "\nfailed or diverged cases (`xpflow sweep FILE --retry-failed` runs the failed ones \
         again from t = 0; a kept state, <db dir>/<db stem>/<case>.failed.resume.json, \
         reproduces the trouble, or, renamed to <case>.resume.json, lets the retry continue \
         from it):"
    )?;
    write!(out, "{}", f.render(Format::Table))?;
    Ok(())
}
