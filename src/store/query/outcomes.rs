//! `xpflow query outcomes --rows COLUMN --cols COLUMN`: the outcome of every case pivoted on two
//! parameter columns or case-file settings ([`CaseAxis`]) — e.g. β × mesh, the convergence of
//! outcomes with the resolution (issue 25), Wi × α of a study, or β × `numerics.follow.films`. A cell lists its cases' outcomes (a string with its mean gap and the
//! elements across its film, for the film is what a mesh may not resolve), or their status while
//! they are not decided.

use std::cmp::Ordering;
use std::collections::BTreeMap;

use serde_json::{json, Value};

use super::Table;

/// What a pivot axis shows of each case: a parameter column (`beta`, `mesh`, …) or a setting of
/// its case file by its dotted path (`numerics.follow.films`, read from the stored case; a case
/// without it has no value there).
#[derive(Debug, Clone, PartialEq)]
pub enum CaseAxis {
    /// A parameter column of `cases`.
    Column(&'static str),
    /// A dotted path into the case (lower-case letters, digits and `_` between the dots).
    Setting(String),
}

impl CaseAxis {
    /// The axis `name` names: a parameter column, else a dotted path of a setting.
    ///
    /// # Errors
    /// A message naming the columns when `name` is neither.
    pub fn parse(name: &str) -> Result<CaseAxis, String> {
        if let Some(c) = super::PARAMETER_COLUMNS.iter().find(|c| **c == name) {
            return Ok(CaseAxis::Column(c));
        }
        let segment = |s: &str| {
            !s.is_empty()
                && s.bytes()
                    .all(|b| b.is_ascii_lowercase() || b.is_ascii_digit() || b == b'_')
        };
        if name.contains('.') && name.split('.').all(segment) {
            return Ok(CaseAxis::Setting(name.to_string()));
        }
        Err(format!(
            "`{name}` is neither a parameter column ({}) nor a dotted setting of the case file \
             (e.g. numerics.follow.films)",
            super::PARAMETER_COLUMNS.join(", ")
        ))
    }

    /// Its heading.
    pub fn name(&self) -> &str {
        match self {
            CaseAxis::Column(c) => c,
            CaseAxis::Setting(p) => p,
        }
    }

    /// Its SQL expression on `case_outcomes c` (a setting's path holds only the characters
    /// [`parse`](Self::parse) allows, so it may be written into the statement).
    pub(super) fn sql(&self) -> String {
        match self {
            CaseAxis::Column(c) => format!("c.{c}"),
            CaseAxis::Setting(p) => format!("json_extract(c.params_json, '$.{p}')"),
        }
    }
}

/// One value of a pivot axis: a number (Wi, β, …) or a text (the mesh, `200x62`), ordered
/// naturally — numbers by value, texts by the numbers in them (so `400x100` follows `300x78`),
/// a case without a value (`–`) last.
#[derive(Debug, Clone, PartialEq)]
pub(super) enum AxisValue {
    Number(f64),
    Text(String),
    Missing,
}

impl AxisValue {
    pub(super) fn of(v: &Value) -> AxisValue {
        match v {
            Value::Number(n) => n.as_f64().map_or(AxisValue::Missing, AxisValue::Number),
            Value::String(s) => AxisValue::Text(s.clone()),
            _ => AxisValue::Missing,
        }
    }

    /// The numbers in a text, in order (`200x62` → 200, 62).
    fn numbers(s: &str) -> Vec<f64> {
        s.split(|c: char| !(c.is_ascii_digit() || c == '.'))
            .filter_map(|t| t.parse().ok())
            .collect()
    }

    fn json(&self) -> Value {
        match self {
            AxisValue::Number(x) => json!(x),
            AxisValue::Text(s) => json!(s),
            AxisValue::Missing => json!("–"),
        }
    }
}

impl std::fmt::Display for AxisValue {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            AxisValue::Number(x) => write!(f, "{x}"),
            AxisValue::Text(s) => write!(f, "{s}"),
            AxisValue::Missing => write!(f, "–"),
        }
    }
}

impl Eq for AxisValue {}

impl PartialOrd for AxisValue {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}

impl Ord for AxisValue {
    fn cmp(&self, o: &Self) -> Ordering {
        use AxisValue::*;
        let rank = |v: &AxisValue| match v {
            Number(_) => 0,
            Text(_) => 1,
            Missing => 2,
        };
        match (self, o) {
            (Number(a), Number(b)) => a.total_cmp(b),
            (Text(a), Text(b)) => {
                let (na, nb) = (Self::numbers(a), Self::numbers(b));
                na.iter()
                    .zip(&nb)
                    .map(|(x, y)| x.total_cmp(y))
                    .find(|c| c.is_ne())
                    .unwrap_or_else(|| na.len().cmp(&nb.len()))
                    .then_with(|| a.cmp(b))
            }
            _ => rank(self).cmp(&rank(o)),
        }
    }
}

/// The text of one case in a cell: its outcome kind, a string's mean gap over a and the elements
/// across its film at the decision (`string 0.067a 0.54el`), or its status while it has no
/// outcome (`pending`, `running`, `failed`).
pub(super) fn case_text(status: &Value, kind: &Value, mean_gap: &Value, film: &Value) -> String {
    match kind.as_str() {
        Some("string") => {
            let mut s = String::from("string");
            if let Some(g) = mean_gap.as_f64() {
                s += &format!(" {g:.3}a");
            }
            if let Some(e) = film.as_f64() {
                s += &format!(" {e:.2}el");
            }
            s
        }
        Some(k) => k.to_string(),
        None => status.as_str().unwrap_or("?").to_string(),
    }
}

/// Pivots rows of (row value, column value, status, kind, mean gap, film in elements) — one per
/// case, in the order the cases should be listed within a cell — into a table of `rows`
/// (first column) × `cols` (`COLUMN=value` headings); cases sharing a cell are joined by `; `.
pub(super) fn pivot(rows_name: &str, cols_name: &str, cases: Vec<Vec<Value>>) -> Table {
    let mut cells: BTreeMap<(AxisValue, AxisValue), Vec<String>> = BTreeMap::new();
    for r in &cases {
        let key = (AxisValue::of(&r[0]), AxisValue::of(&r[1]));
        cells
            .entry(key)
            .or_default()
            .push(case_text(&r[2], &r[3], &r[4], &r[5]));
    }
    let mut row_keys: Vec<&AxisValue> = cells.keys().map(|k| &k.0).collect();
    row_keys.dedup();
    let mut col_keys: Vec<&AxisValue> = cells.keys().map(|k| &k.1).collect();
    col_keys.sort();
    col_keys.dedup();
    let mut columns = vec![rows_name.to_string()];
    columns.extend(col_keys.iter().map(|c| format!("{cols_name}={c}")));
    let rows = row_keys
        .iter()
        .map(|r| {
            let mut row = vec![r.json()];
            row.extend(col_keys.iter().map(|c| {
                cells
                    .get(&((*r).clone(), (*c).clone()))
                    .map_or(Value::Null, |v| json!(v.join("; ")))
            }));
            row
        })
        .collect();
    Table { columns, rows }
}
