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

use crate::config::{PlannedCase, SweepSpec, PARAMETER_COLUMNS};
use crate::store::query::Filter;
use crate::store::{Format, Table};
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
    /// Run only the cases whose parameters match `COLUMN=VALUE` (repeatable, all must match):
    /// one of the database's parameter columns (wi alpha beta delta n_particles a h l lx ly r0 eps
    /// mesh dt t_end; numbers within a relative 1e-9), e.g. `--where wi=1` for one column of a
    /// study; with `--case`, the cases both select. As `--case` otherwise.
    #[arg(long = "where", value_name = "COLUMN=VALUE")]
    pub filters: Vec<String>,
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
    if !args.cases.is_empty() || !args.filters.is_empty() {
        let refused = if spec.search.is_some() {
            Some((
                "--case and --where",
                "a sweep file with a [search] section (its cases are chosen as it runs)",
            ))
        } else if spec.tries.is_some() && !args.cases.is_empty() {
            Some((
                "--case",
                "a sweep file with a [tries] section (its rounds choose the cases; --where \
                 selects whole combinations of the other axes)",
            ))
        } else if args.slurm.slurm {
            Some(("--case and --where", "--slurm"))
        } else {
            None
        };
        if let Some((what, with)) = refused {
            return invalid(&format!(
                "{}: {what} cannot be used with {with}",
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
    let only = match select_cases(&cases, &args.cases)
        .and_then(|ids| select_by_parameters(&cases, &args.filters, ids))
    {
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
                "{} of the {} cases in sweep {} (selected)",
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
                    format!(", {} not selected", summary.left_out)
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

/// The cases `--where` selects among `ids` (all cases when `None`): those whose every filter
/// matches its parameter ([`CaseSpec::parameter_columns`](crate::config::CaseSpec::parameter_columns));
/// `ids` unchanged without filters. An unknown or non-parameter column, a value of the wrong
/// type, or a selection of no case is an error.
pub(super) fn select_by_parameters(
    cases: &[PlannedCase],
    filters: &[String],
    ids: Option<std::collections::BTreeSet<String>>,
) -> Result<Option<std::collections::BTreeSet<String>>, String> {
    if filters.is_empty() {
        return Ok(ids);
    }
    let mut parsed = Vec::with_capacity(filters.len());
    for f in filters {
        let filter: Filter = f.parse().map_err(|e| format!("--where: {e}"))?;
        if !PARAMETER_COLUMNS.contains(&filter.column) {
            return Err(format!(
                "--where {f}: a sweep selects its cases by their parameters, one of {}",
                PARAMETER_COLUMNS.join(", ")
            ));
        }
        parsed.push(filter);
    }
    let only: std::collections::BTreeSet<String> = cases
        .iter()
        .filter(|c| ids.as_ref().is_none_or(|ids| ids.contains(&c.id)))
        .filter(|c| {
            let columns = c.spec.parameter_columns();
            parsed.iter().all(|f| {
                columns
                    .iter()
                    .find(|(name, _)| *name == f.column)
                    .is_some_and(|(_, v)| f.matches(v))
            })
        })
        .map(|c| c.id.clone())
        .collect();
    if only.is_empty() {
        return Err(format!(
            "--where {}: no case of the sweep{} matches (`--dry-run` lists them)",
            filters.join(" --where "),
            if ids.is_some() {
                " given by --case"
            } else {
                ""
            }
        ));
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
