//! `xpflow query WHAT`: thesis-style tables from a results database (a reader: read-only, never
//! creates or changes the file). Exit 2 for a query that cannot match (docs/sweeps.md).

use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

use super::sweep_cmds::invalid;
use crate::store::query::{CaseAxis, Filter, QueryKind, FILTER_COLUMNS};
use crate::store::{Format, Store};

/// What `xpflow query` tabulates.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum QueryWhat {
    /// String formation, Wi × N (thesis Table 5.2).
    Strings,
    /// Outcome kinds, δ × Wi (thesis Fig. 5.26).
    Regime,
    /// Final r* of Couette cases by a parameter (`--by`).
    FinalR,
    /// Every case's outcome per value of one parameter (`--rows`) × another (`--cols`), e.g.
    /// β × mesh: a string with its mean gap over a and the elements across its film.
    Outcomes,
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
    /// Parameter column (or dotted case setting, e.g. numerics.follow.films) of the rows of
    /// `outcomes` (e.g. beta).
    #[arg(long)]
    pub rows: Option<String>,
    /// Parameter column (or dotted case setting) of the columns of `outcomes` (e.g. mesh).
    #[arg(long)]
    pub cols: Option<String>,
    /// Output format.
    #[arg(long, value_enum, default_value_t = Format::Table)]
    pub format: Format,
}

/// What an `outcomes` axis names (`--rows`, `--cols`): a parameter column or a case setting.
fn outcome_axis(name: &Option<String>) -> Result<CaseAxis, String> {
    let name = name
        .as_deref()
        .ok_or("outcomes needs --rows COLUMN and --cols COLUMN, e.g. --rows beta --cols mesh")?;
    CaseAxis::parse(name)
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
        QueryWhat::Outcomes => match (outcome_axis(&args.rows), outcome_axis(&args.cols)) {
            (Ok(rows), Ok(cols)) => QueryKind::Outcomes { rows, cols },
            (Err(e), _) | (_, Err(e)) => return invalid(&e),
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
