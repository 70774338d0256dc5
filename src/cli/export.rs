//! `xpflow export`: a compact copy of a results database's finished cases, for shipping a study
//! as a dataset ([`crate::store::export`]).

use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

use clap::Args;

use super::sweep_cmds::invalid;
use crate::store::export::{export, ExportError, ExportOptions};

/// Sampled steps per case kept by `--thin` unless `--samples` says otherwise: a figure of a
/// trajectory is a few hundred pixels wide.
pub const DEFAULT_THIN_SAMPLES: usize = 500;

/// Arguments of `xpflow export`.
#[derive(Debug, Args)]
pub struct ExportArgs {
    /// The results database to read (opened read-only; a sweep may be running into it).
    #[arg(long)]
    pub db: PathBuf,
    /// The new database to write (refused if it exists).
    #[arg(long)]
    pub out: PathBuf,
    /// Only this sweep (repeatable; default every sweep in the database).
    #[arg(long)]
    pub sweep: Vec<String>,
    /// Thin each case's trajectory to at most `--samples` sampled steps, evenly spread in time
    /// (first and last kept); outcomes and final states stay whole.
    #[arg(long)]
    pub thin: bool,
    /// Sampled steps per case kept by `--thin`.
    #[arg(long, default_value_t = DEFAULT_THIN_SAMPLES, requires = "thin")]
    pub samples: usize,
}

/// Handler of `xpflow export`.
pub fn run_export(args: &ExportArgs) -> anyhow::Result<ExitCode> {
    run_export_to(args, &mut std::io::stdout())
}

/// Handler of `xpflow export` writing to `out` (testable). Exit 2 for an existing destination,
/// an unknown sweep, a source that is not an xpflow database or too few samples.
pub fn run_export_to(args: &ExportArgs, out: &mut dyn Write) -> anyhow::Result<ExitCode> {
    let opts = ExportOptions {
        sweeps: args.sweep.clone(),
        max_samples: args.thin.then_some(args.samples),
    };
    let e = match export(&args.db, &args.out, &opts) {
        Ok(e) => e,
        Err(ExportError::Store(s)) if !s.is_bad_input() => return Err(s.into()),
        Err(e) => return invalid(&e),
    };
    writeln!(
        out,
        "exported {} cases of {} sweep(s) from {} to {} ({:.1} MB); {} sample rows of {}{}",
        e.cases,
        e.sweeps,
        args.db.display(),
        args.out.display(),
        e.bytes as f64 / 1e6,
        e.samples_out,
        e.samples_in,
        if e.unfinished > 0 {
            format!(
                "; {} unfinished case(s) listed as pending, without results",
                e.unfinished
            )
        } else {
            String::new()
        }
    )?;
    Ok(ExitCode::SUCCESS)
}
