//! `column=value` filters of the case tables: which columns a filter may name, how a value
//! matches (numbers within a relative [`FILTER_REL_TOL`], text exactly or as a case id's prefix),
//! in SQL for the queries ([`where_clause`]) and on a planned case's parameters for `xpflow sweep
//! --where` ([`Filter::matches`]).

use rusqlite::types::Value as SqlValue;
use serde_json::Value;

pub use crate::config::PARAMETER_COLUMNS;

/// Columns of `cases`/`outcomes` a filter may name (identifiers cannot be bound, so they are
/// whitelisted): the case's parameters, then its state and outcome.
pub const FILTER_COLUMNS: [&str; 22] = crate::store::schema::columns(&[
    &PARAMETER_COLUMNS,
    &[
        "status",
        "kind",
        "geometry",
        "label",
        "case_hash",
        "string_length",
        "error",
    ],
]);

/// Columns of [`FILTER_COLUMNS`] that hold text; the others are numbers, and a filter on them needs one.
const TEXT_COLUMNS: [&str; 7] = [
    "mesh",
    "status",
    "kind",
    "geometry",
    "label",
    "case_hash",
    "error",
];

/// Values of the `status` column (`interrupted` is how `query cases` shows a running case whose
/// process is gone; the database has it as `running`).
const STATUSES: [&str; 4] = ["pending", "running", "done", "failed"];

/// Outcome kinds (the `kind` column).
const KINDS: [&str; 11] = [
    "string",
    "repel",
    "pass",
    "jammed",
    "wall_contact",
    "surface_contact",
    "exited",
    "migrated",
    "steady",
    "diverged",
    "timeout",
];

/// Relative tolerance when a numeric filter matches a stored value, so `wi=0.3` finds 0.30000000000000004.
const FILTER_REL_TOL: f64 = 1e-9;

/// One `column=value` condition.
#[derive(Debug, Clone, PartialEq)]
pub struct Filter {
    /// Whitelisted column.
    pub column: &'static str,
    /// Value: numbers match within a relative 1e-9, text exactly (or as a prefix).
    pub value: Value,
    /// A text value matches the stored values it begins (a case id's prefix).
    pub prefix: bool,
}

impl Filter {
    /// Whether the column's value `value` (`null` where the column has none) passes: the rule
    /// of `where_clause`'s SQL, for values outside the database (a planned case's parameters).
    pub fn matches(&self, value: &Value) -> bool {
        match (self.value.as_f64(), value) {
            (Some(x), Value::Number(v)) => v
                .as_f64()
                .is_some_and(|v| (v - x).abs() <= FILTER_REL_TOL * x.abs().max(1.0)),
            (Some(_), _) => false,
            (None, Value::String(v)) => {
                let want = self.value.as_str().unwrap_or_default();
                if self.prefix {
                    v.starts_with(want)
                } else {
                    v == want
                }
            }
            (None, _) => false,
        }
    }

    /// The cases whose id begins with `id` (`xpflow query --case ID`).
    pub fn case(id: &str) -> Filter {
        Filter {
            column: "case_hash",
            value: Value::from(id),
            prefix: true,
        }
    }
}

impl std::str::FromStr for Filter {
    type Err = String;

    /// Parses `column=value`.
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        let (col, val) = s
            .split_once('=')
            .ok_or_else(|| format!("filter `{s}` is not column=value"))?;
        let column = FILTER_COLUMNS
            .iter()
            .find(|c| **c == col.trim())
            .ok_or_else(|| {
                format!(
                    "unknown filter column `{col}`; use one of {}",
                    FILTER_COLUMNS.join(", ")
                )
            })?;
        let val = val.trim();
        let value = if TEXT_COLUMNS.contains(column) {
            let known: &[&str] = match *column {
                "status" => &STATUSES,
                "kind" => &KINDS,
                _ => &[],
            };
            if !known.is_empty() && !known.contains(&val) {
                return Err(format!(
                    "filter `{s}`: {column} is one of {}",
                    known.join(", ")
                ));
            }
            Value::from(val)
        } else {
            match val.parse::<f64>() {
                Ok(x) if x.is_finite() => Value::from(x),
                _ => {
                    return Err(format!(
                        "filter `{s}`: {column} is a number, `{val}` is not one"
                    ))
                }
            }
        };
        Ok(Filter {
            column,
            value,
            prefix: false,
        })
    }
}

/// The SQL condition (` WHERE …` on `cases c`) and its bound values: the cases of sweep
/// `sweep` that pass every filter.
pub(super) fn where_clause(sweep: Option<&str>, filters: &[Filter]) -> (String, Vec<SqlValue>) {
    let mut sql = String::from(" WHERE 1 = 1");
    let mut args: Vec<SqlValue> = Vec::new();
    if let Some(name) = sweep {
        args.push(SqlValue::Text(name.into()));
        sql += &format!(
            " AND c.id IN (SELECT sc.case_id FROM sweep_cases sc JOIN sweeps s ON s.id = sc.sweep_id WHERE s.name = ?{})",
            args.len()
        );
    }
    for f in filters {
        match f.value.as_f64() {
            Some(x) => {
                args.push(SqlValue::Real(x));
                let i = args.len();
                sql += &format!(
                    " AND abs(c.{} - ?{i}) <= {FILTER_REL_TOL:e} * max(1.0, abs(?{i}))",
                    f.column
                );
            }
            None => {
                args.push(SqlValue::Text(f.value.as_str().unwrap_or_default().into()));
                let (c, i) = (f.column, args.len());
                sql += &if f.prefix {
                    format!(" AND substr(c.{c}, 1, length(?{i})) = ?{i}")
                } else {
                    format!(" AND c.{c} = ?{i}")
                };
            }
        }
    }
    (sql, args)
}
