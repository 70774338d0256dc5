//! `xpflow sweep FILE` for a sweep file with a `[search]` section, and `xpflow query boundaries`:
//! thin handlers over `sweep::search`, with the exit codes of the sweep commands (0 ok, 1 some
//! case failed or a runtime error, 2 invalid input and nothing written).

use std::io::Write;
use std::process::ExitCode;

use anyhow::Context;

use super::query_cmds::QueryArgs;
use super::sweep_cmds::{
    invalid, list_cases, print_resolved, sweep_options, SweepArgs, EXIT_INVALID,
};
use crate::config::{ConfigError, PlannedCase, SweepSpec};
use crate::store::query::Filter;
use crate::store::Store;
use crate::sweep::engine::SweepError;
use crate::sweep::search::replay::Outcomes;
use crate::sweep::search::{
    boundaries_table, replay, run_search as search, stored_outcomes, SearchError,
};
use crate::sweep::CaseRunner;

/// Runs (or resumes) the search of `spec`, or lists its coarse round with `--dry-run`.
pub(super) fn run_search(
    args: &SweepArgs,
    spec: &SweepSpec,
    runner: &dyn CaseRunner,
    out: &mut dyn Write,
) -> anyhow::Result<ExitCode> {
    let Some(s) = &spec.search else {
        return invalid(&"the sweep has no [search] section");
    };
    // the coarse round, validated before anything is written
    let nothing_stored = &mut |_: &[&str]| Ok::<_, ConfigError>(Outcomes::new());
    let coarse = match replay(spec, args.max_cases, nothing_stored) {
        Ok(state) => state,
        Err(e) => return invalid(&e),
    };
    let lines = coarse.lines.len();
    if args.dry_run {
        list_cases(&coarse.cases, out)?;
        writeln!(
            out,
            "{} cases in sweep {} (the coarse round of its search): {lines} combination(s) of \
             the other axes × {} values of {} over [{}, {}]",
            coarse.cases.len(),
            spec.name,
            s.coarse,
            s.axis,
            s.lo,
            s.hi
        )?;
        writeln!(
            out,
            "then rounds of {} value(s) in each bracket wider than {} where the outcome \
             ({}) changes: at most {} cases in all ({} per combination); a grid of spacing {} \
             would run {}",
            s.per_bracket,
            s.tol,
            change_name(s.change),
            lines * s.budget,
            s.budget,
            s.tol,
            lines * s.grid_values()
        )?;
        if args.resolved {
            print_resolved(&coarse.cases, out)?;
        }
        return Ok(ExitCode::SUCCESS);
    }
    if args.slurm.slurm {
        return slurm_round(args, spec, runner, out);
    }
    let opts = sweep_options(args, spec);
    let mut log = |line: &str| {
        if !args.quiet {
            eprintln!("{line}");
        }
    };
    match search(spec, runner, &opts, args.max_cases, &mut log) {
        Ok(r) => {
            if !args.quiet {
                writeln!(
                    out,
                    "search {}: {} combination(s), {} round(s), {} cases ({} run now, {} failed); \
                     a grid of spacing {} would run {} ({:.0} %); results in {}; brackets: \
                     xpflow query boundaries --db {}",
                    spec.name,
                    r.lines,
                    r.rounds,
                    r.cases,
                    r.ran,
                    r.failed,
                    s.tol,
                    r.grid,
                    100.0 * r.cases as f64 / r.grid.max(1) as f64,
                    opts.db.display(),
                    opts.db.display()
                )?;
                if !r.finished {
                    writeln!(
                        out,
                        "search {}: not over: {} case(s) of round {} are being run by another \
                         process; rerun when they have finished",
                        spec.name, r.elsewhere, r.rounds
                    )?;
                }
            }
            Ok(if r.failed > 0 {
                ExitCode::FAILURE
            } else {
                ExitCode::SUCCESS
            })
        }
        Err(SearchError::Config(e)) => invalid(&e),
        Err(SearchError::Sweep(
            e @ (SweepError::Unsupported { .. } | SweepError::TooLarge { .. }),
        )) => {
            eprintln!("error: {}: {e}; nothing more was run", args.file.display());
            Ok(ExitCode::from(EXIT_INVALID))
        }
        Err(SearchError::Sweep(SweepError::Store(e)) | SearchError::Store(e))
            if e.is_bad_input() =>
        {
            invalid(&e)
        }
        Err(e) => Err(e).context(format!("search {}", spec.name)),
    }
}

/// How a change of outcome is written in messages.
fn change_name(change: crate::config::Change) -> String {
    match change {
        crate::config::Change::Kind => "kind".into(),
        crate::config::Change::StringLengthAtLeast(n) => format!("string of at least {n}"),
    }
}

/// `xpflow query boundaries --db DB [--sweep NAME]`.
pub(super) fn query_boundaries(
    args: &QueryArgs,
    filters: &[Filter],
    out: &mut dyn Write,
) -> anyhow::Result<ExitCode> {
    if !filters.is_empty() {
        return invalid(
            &"--where and --case do not apply to boundaries (a bracket needs every value of its \
              line); use --sweep",
        );
    }
    // a reader: read-only, never creates or changes the file
    let store = match Store::open_read_only(&args.db) {
        Ok(s) => s,
        Err(e) if e.is_bad_input() => return invalid(&e),
        Err(e) => return Err(e.into()),
    };
    match boundaries_table(&store, args.sweep.as_deref()) {
        Ok(t) => {
            write!(out, "{}", t.render(args.format))?;
            Ok(ExitCode::SUCCESS)
        }
        Err(SearchError::Store(e)) if e.is_bad_input() => invalid(&e),
        Err(SearchError::Config(e)) => invalid(&e),
        Err(e) => Err(e.into()),
    }
}

/// `--slurm`: submits the search's current round (its planned cases not finished in the
/// database) as a job array, their swept fields beside the manifest (the tasks cannot expand a
/// search); the sweep's cases in the database become the cases planned so far. The next round
/// is planned from the merged database by running the command again with `--resume`.
fn slurm_round(
    args: &SweepArgs,
    spec: &SweepSpec,
    runner: &dyn CaseRunner,
    out: &mut dyn Write,
) -> anyhow::Result<ExitCode> {
    let db = sweep_options(args, spec).db;
    let lookup = &mut |ids: &[&str]| stored_outcomes(&db, ids).map_err(SearchError::from);
    let state = match replay(spec, args.max_cases, lookup) {
        Ok(s) => s,
        Err(SearchError::Config(e)) => return invalid(&e),
        Err(SearchError::Store(e)) if e.is_bad_input() => return invalid(&e),
        Err(e) => return Err(e.into()),
    };
    if state.finished {
        writeln!(
            out,
            "search {}: over — {} cases in {} round(s); brackets: xpflow query boundaries --db {}",
            spec.name,
            state.cases.len(),
            state.rounds,
            db.display()
        )?;
        return Ok(ExitCode::SUCCESS);
    }
    let open: Vec<PlannedCase> = state
        .lines
        .iter()
        .flat_map(|l| &l.points)
        .filter(|p| !p.finished)
        .map(|p| state.cases[p.case].clone())
        .collect();
    let next = format!(
        "search {}: this is round {} ({} case(s) not finished in {}); the next one follows from \
         its outcomes: once its tasks are done, merge their shards and run `xpflow sweep {} \
         --slurm --resume` again",
        spec.name,
        state.rounds,
        open.len(),
        db.display(),
        args.file.display()
    );
    super::cluster::sweep_slurm_round(args, spec, &state.cases, &open, Some(&next), runner, out)
}
