//! `xpflow query boundaries`: per sweep with a `[search]` and per combination of its other axes,
//! each boundary as a bracket — the two neighbouring values of the searched axis and the outcomes
//! on each side — replayed from the store ([`super::replay()`]), so it is what the search knows,
//! finished or not. A combination without a change says so in one row.

use serde_json::{json, Value};

use super::replay::replay;
use super::SearchError;
use crate::config::{Change, SweepSpec};
use crate::store::{Store, StoreError, Table};

/// Columns of the table.
const COLUMNS: [&str; 11] = [
    "sweep",
    "combination",
    "axis",
    "lo",
    "hi",
    "width",
    "below",
    "above",
    "resolved",
    "cases",
    "failed",
];

/// The boundaries of every sweep of `store` that has a `[search]` section (or of the one named,
/// which must have one).
///
/// # Errors
/// A named sweep the database does not have or that is not a search ([`StoreError::BadQuery`]),
/// a stored sweep file that no longer reads, the store failing.
pub fn boundaries_table(store: &Store, sweep: Option<&str>) -> Result<Table, SearchError> {
    let files = store.sweep_files(sweep)?;
    if let Some(name) = sweep {
        if files.is_empty() {
            return Err(StoreError::BadQuery(format!(
                "no sweep `{name}` in {}",
                store.path().display()
            ))
            .into());
        }
    }
    let mut table = Table {
        columns: COLUMNS.iter().map(|c| c.to_string()).collect(),
        rows: Vec::new(),
    };
    for (name, text) in files {
        let origin = format!("{} (sweep {name} as stored)", store.path().display());
        let spec = SweepSpec::from_str(&text, true, std::path::Path::new(&origin))?;
        let Some(search) = &spec.search else {
            if sweep.is_some() {
                return Err(StoreError::BadQuery(format!(
                    "sweep `{name}` has no [search] section: its outcomes are in `query cases` \
                     and `query regime`"
                ))
                .into());
            }
            continue;
        };
        let state = replay(&spec, usize::MAX, &mut |ids: &[&str]| {
            store.outcomes_of(ids).map_err(SearchError::from)
        })?;
        for line in &state.lines {
            let points = line.sorted_points(search);
            let measured = points.iter().filter(|(_, p)| p.finished).count();
            let failed = points
                .iter()
                .filter(|(_, p)| p.finished && p.outcome.is_none())
                .count();
            let bare: Vec<_> = points.iter().map(|(p, _)| p.clone()).collect();
            let brackets = super::bracket::brackets(&bare);
            let row = |lo: Value, hi: Value, width: Value, below, above, resolved: &str| {
                vec![
                    json!(name),
                    json!(line.label),
                    json!(search.axis),
                    lo,
                    hi,
                    width,
                    below,
                    above,
                    json!(resolved),
                    json!(measured),
                    json!(failed),
                ]
            };
            if brackets.is_empty() {
                let seen: std::collections::BTreeSet<String> = points
                    .iter()
                    .filter_map(|(_, p)| p.outcome.as_ref().map(|o| describe(o, search.change)))
                    .collect();
                let all = seen.into_iter().collect::<Vec<_>>().join("/");
                let what = if state.finished { "no change" } else { "open" };
                table.rows.push(row(
                    Value::Null,
                    Value::Null,
                    Value::Null,
                    json!(all),
                    Value::Null,
                    what,
                ));
            }
            for b in brackets {
                let side = |i: usize| {
                    points[i]
                        .1
                        .outcome
                        .as_ref()
                        .map_or(Value::Null, |o| json!(describe(o, search.change)))
                };
                let resolved = if b.width() <= search.tol {
                    "yes"
                } else if state.finished {
                    "no (budget spent)"
                } else {
                    "open"
                };
                table.rows.push(row(
                    json!(b.lo),
                    json!(b.hi),
                    json!(b.width()),
                    side(b.below),
                    side(b.above),
                    resolved,
                ));
            }
        }
    }
    Ok(table)
}

/// An outcome for a person: its kind, a string with its length, and under a predicate the class.
fn describe((kind, length): &(String, Option<i64>), change: Change) -> String {
    let outcome = match (kind.as_str(), length) {
        ("string", Some(n)) => format!("string({n})"),
        _ => kind.clone(),
    };
    match change {
        Change::Kind => outcome,
        Change::StringLengthAtLeast(_) => {
            format!("{outcome} [{}]", change.class_of(kind, *length))
        }
    }
}
