//! `xpflow sweep FILE` for a sweep file with a `[tries]` section: a thin handler over
//! `sweep::tries`, with the exit codes of the sweep commands (0 ok, 1 some case failed or a
//! runtime error, 2 invalid input and nothing written).

use std::io::Write;
use std::process::ExitCode;

use anyhow::Context;

use super::sweep_cmds::{
    invalid, list_cases, print_resolved, select_by_parameters, sweep_options, SweepArgs,
    EXIT_INVALID,
};
use crate::config::{PlannedCase, SweepSpec};
use crate::sweep::engine::SweepError;
use crate::sweep::search::stored_outcomes;
use crate::sweep::tries::{lines, replay, run_tries, select_lines, TryLine};
use crate::sweep::CaseRunner;

/// Runs (or resumes) the tries of `spec` over its grid `cases`, or lists the grid with
/// `--dry-run` (with `--estimate`: the bound of every case run).
pub(super) fn run(
    args: &SweepArgs,
    spec: &SweepSpec,
    cases: &[PlannedCase],
    runner: &dyn CaseRunner,
    out: &mut dyn Write,
) -> anyhow::Result<ExitCode> {
    let Some(t) = &spec.tries else {
        return invalid(&"the sweep has no [tries] section");
    };
    let mut lines = match lines(spec, cases) {
        Ok(l) => l,
        Err(e) => return invalid(&e),
    };
    if !args.filters.is_empty() {
        // `--where`: whole lines (combinations of the other axes), e.g. one Wi row of a table
        let selected = select_by_parameters(cases, &args.filters, None)
            .map(Option::unwrap_or_default)
            .and_then(|ids| select_lines(&mut lines, cases, &ids));
        if let Err(e) = selected {
            return invalid(&format!("{}: {e}", args.file.display()));
        }
    }
    let per_line = lines.iter().map(|l| l.tries.len()).max().unwrap_or(0);
    let run_lines = lines.iter().filter(|l| l.run).count();
    // the cases of the lines this invocation tries (all of the grid without `--where`)
    let listed: Vec<PlannedCase> = lines
        .iter()
        .filter(|l| l.run)
        .flat_map(|l| l.tries.iter().map(|&i| cases[i].clone()))
        .collect();
    if args.dry_run {
        list_cases(&listed, out)?;
        let selected = if run_lines < lines.len() {
            format!(" ({run_lines} of its {} selected)", lines.len())
        } else {
            String::new()
        };
        writeln!(
            out,
            "{} cases in sweep {}: {run_lines} combination(s) of the other axes{selected} × \
             {per_line} tries of {} in this order, each combination stopping at its first case \
             that ends in {}: between {run_lines} and {} cases run",
            listed.len(),
            spec.name,
            t.over,
            t.until.describe(),
            listed.len()
        )?;
        let db = sweep_options(args, spec).db;
        if db.exists() {
            // where the tries stand in the database (a reader: read only, writes nothing)
            let lookup = &mut |ids: &[&str]| stored_outcomes(&db, ids);
            match replay(spec, cases, lines.clone(), false, lookup) {
                Ok(state) => {
                    let met = state
                        .lines
                        .iter()
                        .filter(|l| l.run && l.met.is_some())
                        .count();
                    let round: Vec<String> = state
                        .round()
                        .iter()
                        .map(|&i| cases[i].index.to_string())
                        .collect();
                    writeln!(
                        out,
                        "in {}: {} case(s) tried; {met} combination(s) ended in {}, {} tried every \
                         value without it, {} still trying (next: case(s) {})",
                        db.display(),
                        state.tried().len(),
                        t.until.describe(),
                        run_lines - met - round.len(),
                        round.len(),
                        if round.is_empty() { "none".into() } else { round.join(", ") }
                    )?;
                }
                Err(e) if e.is_bad_input() => return invalid(&e),
                Err(e) => return Err(e.into()),
            }
        }
        if args.resolved {
            print_resolved(&listed, out)?;
        }
        if args.estimate {
            super::estimate::print_estimate(&listed, &db, out)?;
            writeln!(
                out,
                "(the bound runs every try; a combination stops at its first {})",
                t.until.describe()
            )?;
        }
        return Ok(ExitCode::SUCCESS);
    }
    if args.slurm.slurm {
        return slurm_round(args, spec, cases, &lines, runner, out);
    }
    let opts = sweep_options(args, spec);
    let mut log = |line: &str| {
        if !args.quiet {
            eprintln!("{line}");
        }
    };
    match run_tries(spec, cases, &lines, runner, &opts, &mut log) {
        Ok(r) => {
            if !args.quiet {
                writeln!(
                    out,
                    "tries {}: {} combination(s), {} ended in {} and {} did not; {} of the grid's \
                     {} cases tried ({} run now in {} round(s), {} failed); results in {}",
                    spec.name,
                    r.lines,
                    r.met,
                    t.until.describe(),
                    r.lines - r.met,
                    r.tried,
                    r.grid,
                    r.ran,
                    r.rounds,
                    r.failed,
                    opts.db.display()
                )?;
                if !r.finished {
                    writeln!(
                        out,
                        "tries {}: not over: {} case(s) of the current round are being run by \
                         another process; rerun when they have finished",
                        spec.name, r.elsewhere
                    )?;
                }
            }
            Ok(if r.failed > 0 {
                ExitCode::FAILURE
            } else {
                ExitCode::SUCCESS
            })
        }
        Err(e @ (SweepError::Unsupported { .. } | SweepError::TooLarge { .. })) => {
            eprintln!("error: {}: {e}; nothing more was run", args.file.display());
            Ok(ExitCode::from(EXIT_INVALID))
        }
        Err(SweepError::Store(e)) if e.is_bad_input() => invalid(&e),
        Err(e) => Err(e).context(format!("sweep {}", spec.name)),
    }
}

/// `--slurm`: submits the current round of tries (each line's first try not finished in the
/// database) as a job array; the sweep's cases in the database become its registered tries. The
/// next round is planned from the merged database by running the command again with `--resume`.
fn slurm_round(
    args: &SweepArgs,
    spec: &SweepSpec,
    cases: &[PlannedCase],
    lines: &[TryLine],
    runner: &dyn CaseRunner,
    out: &mut dyn Write,
) -> anyhow::Result<ExitCode> {
    let db = sweep_options(args, spec).db;
    let lookup = &mut |ids: &[&str]| stored_outcomes(&db, ids);
    let state = match replay(spec, cases, lines.to_vec(), args.retry_failed, lookup) {
        Ok(s) => s,
        Err(e) if e.is_bad_input() => return invalid(&e),
        Err(e) => return Err(e.into()),
    };
    if state.finished() {
        writeln!(
            out,
            "tries {}: over — no combination has a try left ({} case(s) tried; see `xpflow \
             sweep {} --dry-run`)",
            spec.name,
            state.tried().len(),
            args.file.display()
        )?;
        return Ok(ExitCode::SUCCESS);
    }
    let listed: Vec<PlannedCase> = state
        .registered()
        .iter()
        .map(|&i| cases[i].clone())
        .collect();
    let round: Vec<PlannedCase> = state.round().iter().map(|&i| cases[i].clone()).collect();
    let next = format!(
        "tries {}: this round holds each combination's first try not finished in {} ({} of {}); \
         the next one follows from its outcomes: once its tasks are done, merge their shards \
         and run `xpflow sweep {} --slurm --resume` again",
        spec.name,
        db.display(),
        round.len(),
        lines.len(),
        args.file.display()
    );
    super::cluster::sweep_slurm_round(args, spec, &listed, &round, Some(&next), runner, out)
}
