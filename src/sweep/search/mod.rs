//! Adaptive sweeps (issue 24): find where the outcome changes along one axis instead of filling
//! a grid. A sweep file's `[search]` section ([`crate::config::SearchSpec`]) names the axis, its
//! interval, the tolerance, the budget and what counts as a change; for each combination of the
//! other axes ("line") the search runs the coarse values, then rounds of values inside every
//! bracket wider than the tolerance ([`bracket`]), until none is or the budget is spent.
//!
//! One path: every round is an ordinary [`run_sweep`] of the cases planned so far (the same ids,
//! store, runner, claims and resume as a grid sweep; the finished ones are skipped). The search
//! keeps no state of its own: [`replay()`] rebuilds it from the outcomes in the store, so a killed
//! search continues with the round it was in. [`boundaries`] tabulates the brackets found.

pub mod boundaries;
pub mod bracket;
pub mod replay;

use std::collections::HashMap;
use std::path::Path;

use super::engine::{run_sweep, SweepError, SweepOptions};
use super::runner::CaseRunner;
use crate::config::{ConfigError, SweepSpec};
use crate::store::{Store, StoreError, StoredOutcome};

pub use boundaries::boundaries_table;
pub use replay::{replay, SearchState};

/// Errors of a search.
#[derive(Debug, thiserror::Error)]
pub enum SearchError {
    /// A planned case is invalid (a value of the searched axis the case rules refuse).
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// A round could not run.
    #[error(transparent)]
    Sweep(#[from] SweepError),
    /// The store could not be read.
    #[error(transparent)]
    Store(#[from] StoreError),
}

/// What a search invocation did.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SearchSummary {
    /// Lines searched (combinations of the other axes).
    pub lines: usize,
    /// Rounds planned so far (all of them when the search is over).
    pub rounds: usize,
    /// Cases the search has planned (run now or before).
    pub cases: usize,
    /// Cases a full grid of spacing `tol` over the lines would take.
    pub grid: usize,
    /// Cases run by this invocation.
    pub ran: usize,
    /// Of those, the ones that failed.
    pub failed: usize,
    /// Whether the search is over (no open round and nothing left to try).
    pub finished: bool,
    /// Cases of the current round another process is running (the search stopped to wait).
    pub elsewhere: usize,
}

/// Stored outcomes of `ids` in the database at `db` (none when it does not exist yet), read
/// without writing: a search or tries sweep plans its rounds from it, and so do the readers
/// (`--dry-run`) and the cluster path's submissions.
pub fn stored_outcomes(
    db: &Path,
    ids: &[&str],
) -> Result<HashMap<String, StoredOutcome>, StoreError> {
    if !db.exists() {
        return Ok(HashMap::new());
    }
    Store::open_read_only(db)?.outcomes_of(ids)
}

/// Runs (or resumes) the search of `sweep` round by round until it is over; `log` gets one line
/// per round. `max_cases` bounds lines × budget.
///
/// # Errors
/// An invalid case, a round that cannot run (the runner refuses a case, one needs too much
/// memory, the store fails).
pub fn run_search(
    sweep: &SweepSpec,
    runner: &dyn CaseRunner,
    opts: &SweepOptions,
    max_cases: usize,
    log: &mut dyn FnMut(&str),
) -> Result<SearchSummary, SearchError> {
    let mut summary = SearchSummary::default();
    let state = loop {
        let state: SearchState = replay(sweep, max_cases, &mut |ids: &[&str]| {
            stored_outcomes(&opts.db, ids).map_err(SearchError::from)
        })?;
        if state.finished {
            break state;
        }
        log(&format!(
            "search {}: round {}, {} of {} cases planned still to run",
            sweep.name,
            state.rounds,
            state.open_cases(),
            state.cases.len()
        ));
        let s = run_sweep(sweep, &state.cases, runner, opts)?;
        summary.ran += s.ran;
        summary.failed += s.failed;
        if s.ran == 0 {
            // nothing could run: the round's open cases are another process's
            summary.elsewhere = s.elsewhere;
            break state;
        }
    };
    let spec = sweep.search.as_ref().map_or(0, |s| s.grid_values());
    summary.lines = state.lines.len();
    summary.rounds = state.rounds;
    summary.cases = state.cases.len();
    summary.grid = state.lines.len() * spec;
    summary.finished = state.finished;
    Ok(summary)
}
