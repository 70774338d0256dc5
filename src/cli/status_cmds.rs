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
            "left ≤",
        ]
        .map(String::from)
        .to_vec(),
        rows: Vec::new(),
    };
    for (db, c) in running {
        let state = crate::sweep::engine::saved_state(db, &c.hash);
        // the wall-clock time to t_end at the case's rate so far (early stop may end it sooner)
        let left = state
            .as_ref()
            .zip(c.t_end)
            .and_then(|(s, t_end)| s.wall_left(t_end))
            .map_or_else(|| "-".to_string(), duration);
        let saved = match state {
            Some(s) => s.to_string(),
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
            left.into(),
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
            Some(s) => s.to_string(),
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

/// A duration in seconds as a person reads it: `40 s`, `25 min`, `3.2 h`.
fn duration(seconds: f64) -> String {
    match seconds {
        s if s < 90.0 => format!("{s:.0} s"),
        s if s < 5400.0 => format!("{:.0} min", s / 60.0),
        s => format!("{:.1} h", s / 3600.0),
    }
}

#[cfg(test)]
mod tests {
    use super::duration;
    use crate::sweep::engine::SavedState;

    /// The time left to t_end at the mean rate so far: a case at t = 50 of 200 after 600 s has
    /// 1800 s left; none without a clock (an older state) or before it has gone anywhere; none
    /// left past t_end.
    #[test]
    fn the_time_left_is_the_rest_at_the_rate_so_far() {
        let state = |t: f64, wall_s: Option<f64>| SavedState {
            step: 1,
            t,
            code_version: "0.1.0".into(),
            wall_s,
        };
        assert_eq!(state(50.0, Some(600.0)).wall_left(200.0), Some(1800.0));
        assert_eq!(state(50.0, None).wall_left(200.0), None);
        assert_eq!(state(0.0, Some(10.0)).wall_left(200.0), None);
        assert_eq!(state(210.0, Some(600.0)).wall_left(200.0), Some(0.0));
        assert_eq!(
            [40.0, 1800.0, 11_520.0].map(duration),
            ["40 s", "30 min", "3.2 h"]
        );
    }
}
