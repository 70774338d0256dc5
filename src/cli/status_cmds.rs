//! `xpflow status`: per-sweep case counts of results databases, and of cluster submissions
//! from their shards; the failed cases with why and the state each kept.

use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

use super::sweep_cmds::invalid;
use crate::store::{Format, Store, Table};

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
