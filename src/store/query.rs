//! Thesis-style tables from the database: string formation Wi × N (thesis Table 5.2), regime map δ × Wi
//! (Fig. 5.26), final r* by parameter (Couette, 3.5), case lists and raw trajectories. Filters are
//! `column=value` with the column from [`FILTER_COLUMNS`]; values are always bound as SQL parameters.

use std::collections::{BTreeMap, BTreeSet};

use rusqlite::params_from_iter;
use rusqlite::types::Value as SqlValue;
use serde_json::{json, Value};

use super::{Result, Store, StoreError, Table};

mod filter;
mod outcomes;
use filter::where_clause;
pub use filter::{Filter, FILTER_COLUMNS, PARAMETER_COLUMNS};
pub use outcomes::CaseAxis;

/// What to tabulate.
#[derive(Debug, Clone, PartialEq)]
pub enum QueryKind {
    /// '+' if a string formed from some case of the cell (e.g. one of several initial
    /// positions), '+?' if only with fewer than two elements across its narrowest gap (the
    /// outcome's warning), '?' if none did yet and a case is not decided (pending, running,
    /// failed), '−' if every case ended without one, per Wi (rows) × N (columns) — thesis
    /// Table 5.2.
    StringFormation,
    /// Outcome kinds per δ (rows) × Wi (columns) — thesis Fig. 5.26.
    Regime,
    /// Final r* of Couette cases, sorted by the given column.
    FinalRStar(&'static str),
    /// Every case's outcome (a string with its gap and film), per value of one parameter column
    /// (rows) × another (columns): e.g. β × mesh, how an outcome changes with the resolution.
    Outcomes {
        /// What the rows show.
        rows: CaseAxis,
        /// What the columns show.
        cols: CaseAxis,
    },
    /// One row per case with its status and outcome.
    Cases,
    /// One row per particle of each decided case: its final position, ω* and gap.
    Final,
    /// Samples of the case with this id (hash prefix accepted).
    Trajectory(String),
    /// One row per decided extrusion case: its swell (the undisturbed surface's for a particle
    /// case, its own steady one without particles) and the particle's final separation s and
    /// position (thesis §6.4, §6.5).
    Extrusion,
}

fn json_of(v: SqlValue) -> Value {
    match v {
        SqlValue::Null => Value::Null,
        SqlValue::Integer(i) => json!(i),
        SqlValue::Real(x) => json!(x),
        SqlValue::Text(s) => json!(s),
        SqlValue::Blob(_) => json!("<blob>"),
    }
}

impl Store {
    /// A case id prefix that names at least one case (a query restricted to none would print
    /// an empty table for a mistyped id).
    fn check_case_prefix(&self, id: &str) -> Result<()> {
        if id.is_empty() {
            return Err(StoreError::BadQuery(
                "--case needs a case id (see `xpflow query cases`)".into(),
            ));
        }
        let (cond, args) = where_clause(None, &[Filter::case(id)]);
        let n = self.rows(&format!("SELECT count(*) FROM cases c{cond}"), &args)?;
        match n.first().and_then(|r| r[0].as_i64()) {
            Some(0) => Err(StoreError::BadQuery(format!("no case with id `{id}`"))),
            _ => Ok(()),
        }
    }

    /// Runs a query over all sweeps or the named one, restricted by `filters`.
    pub fn query(
        &self,
        kind: &QueryKind,
        sweep: Option<&str>,
        filters: &[Filter],
    ) -> Result<Table> {
        if let Some(name) = sweep {
            self.check_sweep(name)?;
        }
        // a trajectory's case is a case filter like `--case` on the other tables
        let mut filters = filters.to_vec();
        if let QueryKind::Trajectory(hash) = kind {
            filters.push(Filter::case(hash));
        }
        for id in filters
            .iter()
            .filter(|f| f.prefix)
            .map(|f| f.value.as_str())
        {
            self.check_case_prefix(id.unwrap_or_default())?;
        }
        let (cond, args) = where_clause(sweep, &filters);
        match kind {
            QueryKind::StringFormation => {
                let rows = self.rows(
                    &format!(
                        "SELECT c.wi, c.n_particles, c.status, c.kind,
                                json_extract(c.final_json, '$.warning') IS NOT NULL
                         FROM case_outcomes c{cond}"
                    ),
                    &args,
                )?;
                let mut cells: BTreeMap<(Key, i64), String> = BTreeMap::new();
                for r in rows {
                    let (Some(wi), Some(n)) = (r[0].as_f64(), r[1].as_i64()) else {
                        continue;
                    };
                    let unresolved = r[4].as_i64() == Some(1);
                    let mark = match (r[2].as_str(), r[3].as_str()) {
                        (_, Some("string")) if unresolved => "+?",
                        (_, Some("string")) => "+",
                        (Some("done"), Some(_)) => "-",
                        _ => "?",
                    };
                    let e = cells.entry((Key(wi), n)).or_insert_with(|| mark.into());
                    // '+' wins over '+?' (a string on a gap of fewer than 2 elements), which
                    // wins over '?' (a case not decided: pending, running or failed), which wins
                    // over '-': a cell is '-' only when every case of it (each initial position)
                    // ended without a string.
                    let rank = |m: &str| ["-", "?", "+?", "+"].iter().position(|k| *k == m);
                    if rank(mark) > rank(e) {
                        *e = mark.into();
                    }
                }
                Ok(pivot("Wi", "N=", cells, |k| json!(k)))
            }
            QueryKind::Regime => {
                let rows = self.rows(&format!("SELECT c.delta, c.wi, c.kind FROM case_outcomes c{cond} AND c.kind IS NOT NULL"), &args)?;
                let mut kinds: BTreeMap<(Key, Key), BTreeSet<String>> = BTreeMap::new();
                for r in rows {
                    let (Some(d), Some(wi), Some(k)) =
                        (r[0].as_f64(), r[1].as_f64(), r[2].as_str())
                    else {
                        continue;
                    };
                    kinds
                        .entry((Key(d), Key(wi)))
                        .or_default()
                        .insert(k.to_string());
                }
                let cells = kinds
                    .into_iter()
                    .map(|(k, v)| (k, v.into_iter().collect::<Vec<_>>().join("/")))
                    .collect();
                Ok(pivot("delta", "Wi=", cells, |k: Key| json!(k.0)))
            }
            QueryKind::Outcomes { rows, cols } => {
                let (r, c) = (rows.sql(), cols.sql());
                let sql = format!(
                    "SELECT {r}, {c}, c.status, c.kind, c.mean_gap,
                            json_extract(c.final_json, '$.gap_elements'), c.owner, c.owner_pid
                     FROM case_outcomes c{cond} ORDER BY {r}, c.id"
                );
                let host = super::hostname();
                let mut cases = self.rows(&sql, &args)?;
                for r in &mut cases {
                    let pid = r.pop().and_then(|v| v.as_i64());
                    let owner = r.pop();
                    r[2] =
                        interrupted_or(&r[2], owner.as_ref().and_then(Value::as_str), pid, &host);
                }
                Ok(outcomes::pivot(rows.name(), cols.name(), cases))
            }
            QueryKind::FinalRStar(by) => {
                // (column, heading) of the parameters shown after the ordering one, which is
                // shown first and not again
                let params = [
                    ("r0", "r0_star"),
                    ("eps", "eps"),
                    ("wi", "wi"),
                    ("alpha", "alpha"),
                ];
                let rest: Vec<(&str, &str)> = params.into_iter().filter(|(c, _)| c != by).collect();
                let heading = params
                    .iter()
                    .find(|(c, _)| c == by)
                    .map_or(*by, |(_, h)| *h);
                let sql = format!(
                    "SELECT c.case_hash, c.label, c.{by}, {}, c.kind,
                            json_extract(c.final_json, '$.r_star[0]') FROM case_outcomes c{cond}
                     AND c.geometry = 'couette' AND c.kind IS NOT NULL ORDER BY c.{by}, c.r0, c.case_hash",
                    rest.iter()
                        .map(|(c, _)| format!("c.{c}"))
                        .collect::<Vec<_>>()
                        .join(", ")
                );
                let mut cols = vec!["case", "label", heading];
                cols.extend(rest.iter().map(|(_, h)| *h));
                cols.extend(["kind", "r_star_final"]);
                Ok(Table {
                    columns: cols.iter().map(|c| c.to_string()).collect(),
                    rows: self.rows(&sql, &args)?,
                })
            }
            QueryKind::Extrusion => {
                let sql = format!(
                    "SELECT c.case_hash, c.label, c.wi, c.alpha, c.a, c.mesh, c.dt, c.kind,
                            COALESCE(json_extract(c.final_json, '$.undisturbed_surface.swell'),
                                     json_extract(c.final_json, '$.surface.swell')),
                            json_extract(c.final_json, '$.separation[0]'),
                            json_extract(c.final_json, '$.positions[0][0]'),
                            json_extract(c.final_json, '$.positions[0][1]'), c.t_decided
                     FROM case_outcomes c{cond}
                     AND c.geometry = 'extrusion' AND c.kind IS NOT NULL
                     ORDER BY c.a IS NOT NULL, c.a, c.wi, c.mesh, c.case_hash"
                );
                let cols = [
                    "case", "label", "wi", "alpha", "a", "mesh", "dt", "kind", "swell", "s_final",
                    "x_final", "y_final", "t_final",
                ];
                Ok(Table {
                    columns: cols.iter().map(|c| c.to_string()).collect(),
                    rows: self.rows(&sql, &args)?,
                })
            }
            QueryKind::Cases => {
                let sql = format!(
                    "SELECT c.case_hash, c.label, c.status, c.kind, c.string_length, c.t_decided, c.mean_gap,
                            json_extract(c.final_json, '$.gap_elements_min'), c.wall_s,
                            json_extract(c.final_json, '$.cpu_s'), c.error, c.owner, c.owner_pid FROM case_outcomes c{cond} ORDER BY c.id"
                );
                let host = super::hostname();
                let mut rows = self.rows(&sql, &args)?;
                for r in &mut rows {
                    let pid = r.pop().and_then(|v| v.as_i64());
                    let owner = r.pop();
                    r[2] =
                        interrupted_or(&r[2], owner.as_ref().and_then(Value::as_str), pid, &host);
                    // the mean gap describes a string; for other outcomes it is the distance
                    // between particles that never chained (4960a after a jump), not a result
                    if r[3] != "string" {
                        r[6] = Value::Null;
                    }
                }
                let cols = [
                    "case",
                    "label",
                    "status",
                    "kind",
                    "string_length",
                    "t_decided",
                    "mean_gap",
                    "gap_elements",
                    "wall_s",
                    "cpu_s",
                    "error",
                ];
                Ok(Table {
                    columns: cols.iter().map(|c| c.to_string()).collect(),
                    rows,
                })
            }
            QueryKind::Final => {
                let sql = format!(
                    "SELECT c.case_hash, c.label, c.kind, c.t_decided, c.final_json
                     FROM case_outcomes c{cond} AND c.kind IS NOT NULL ORDER BY c.id"
                );
                let mut rows = Vec::new();
                for r in self.rows(&sql, &args)? {
                    let state: Value = r[4]
                        .as_str()
                        .and_then(|s| serde_json::from_str(s).ok())
                        .unwrap_or(Value::Null);
                    // the state at the decision, and the last one of a run that went on past it
                    // (no early stop: `at_end`)
                    let end = &state["at_end"];
                    for (which, s) in [("decided", &state), ("end", end)] {
                        if s.is_null() {
                            continue;
                        }
                        for particle in final_rows(s) {
                            let mut row = r[..4].to_vec();
                            row.extend([json!(which), s["t"].clone()]);
                            row.extend(particle);
                            rows.push(row);
                        }
                    }
                }
                let cols = [
                    "case",
                    "label",
                    "kind",
                    "t_decided",
                    "state",
                    "t",
                    "particle",
                    "x",
                    "y",
                    "omega_star",
                    "gap_next_over_a",
                    "r_star",
                ];
                Ok(Table {
                    columns: cols.iter().map(|c| c.to_string()).collect(),
                    rows,
                })
            }
            QueryKind::Trajectory(hash) => {
                // (the case filter above; an empty id or one of no case refused there)
                let ids = self.rows(&format!("SELECT c.id FROM cases c{cond}"), &args)?;
                let id = match ids.as_slice() {
                    [one] => one[0].clone(),
                    [] => return Err(StoreError::BadQuery(format!("no case with id `{hash}`"))),
                    _ => {
                        return Err(StoreError::BadQuery(format!(
                            "`{hash}` matches several cases; give more digits"
                        )))
                    }
                };
                // (a database older than schema 4, read without migrating, has no separation)
                let has_separation = !self
                    .rows(
                        "SELECT 1 FROM pragma_table_info('samples') WHERE name = 'separation'",
                        &[],
                    )?
                    .is_empty();
                let separation = if has_separation { "separation" } else { "NULL" };
                let sql = format!(
                    "SELECT step, t, particle, x, y, u, v, omega, theta, {separation}
                     FROM samples WHERE case_id = ?1 ORDER BY step, particle"
                );
                let cols = [
                    "step",
                    "t",
                    "particle",
                    "x",
                    "y",
                    "u",
                    "v",
                    "omega",
                    "theta",
                    "separation",
                ];
                let mut rows = self.rows(&sql, &[SqlValue::Integer(id.as_i64().unwrap_or(-1))])?;
                let mut columns: Vec<String> = cols.iter().map(|c| c.to_string()).collect();
                // the separation from a free surface: only for the cases that have one
                if rows.iter().all(|r| r.last().is_some_and(Value::is_null)) {
                    columns.pop();
                    rows.iter_mut().for_each(|r| {
                        r.pop();
                    });
                }
                Ok(Table { columns, rows })
            }
        }
    }

    /// A query for a sweep the database does not have is an error naming the ones it has.
    fn check_sweep(&self, name: &str) -> Result<()> {
        let names: Vec<String> = self
            .rows("SELECT name FROM sweeps ORDER BY name", &[])?
            .into_iter()
            .filter_map(|r| r[0].as_str().map(str::to_string))
            .collect();
        if names.iter().any(|n| n == name) {
            return Ok(());
        }
        Err(StoreError::BadQuery(format!(
            "no sweep `{name}` in {}; it has {}",
            self.path.display(),
            if names.is_empty() {
                "none".to_string()
            } else {
                names.join(", ")
            }
        )))
    }

    fn rows(&self, sql: &str, args: &[SqlValue]) -> Result<Vec<Vec<Value>>> {
        let err = self.sql_err();
        let mut st = self.conn.prepare(sql).map_err(&err)?;
        let n = st.column_count();
        let rows = st
            .query_map(params_from_iter(args.iter()), |r| {
                (0..n)
                    .map(|i| r.get::<_, SqlValue>(i).map(json_of))
                    .collect::<rusqlite::Result<Vec<_>>>()
            })
            .map_err(&err)?;
        rows.collect::<rusqlite::Result<_>>().map_err(err)
    }
}

/// A case's status as the tables show it: `interrupted` for a case `running` in the database
/// whose process (`owner`, `pid`) on this host (`host`) is gone.
fn interrupted_or(status: &Value, owner: Option<&str>, pid: Option<i64>, host: &str) -> Value {
    if status == "running" && super::status::owner_alive(owner, pid, host) == Some(false) {
        json!("interrupted")
    } else {
        status.clone()
    }
}

/// A float usable as an ordered map key.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Key(f64);
impl Eq for Key {}
impl PartialOrd for Key {
    fn partial_cmp(&self, o: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Key {
    fn cmp(&self, o: &Self) -> std::cmp::Ordering {
        self.0.total_cmp(&o.0)
    }
}
impl serde::Serialize for Key {
    fn serialize<S: serde::Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        s.serialize_f64(self.0)
    }
}

/// Pivots (row key, column key) → cell into a table with one row per row key.
fn pivot<C: Ord + Copy + std::fmt::Display>(
    row_name: &str,
    col_prefix: &str,
    cells: BTreeMap<(Key, C), String>,
    row_json: impl Fn(Key) -> Value,
) -> Table {
    let cols: BTreeSet<C> = cells.keys().map(|k| k.1).collect();
    let rows: BTreeSet<Key> = cells.keys().map(|k| k.0).collect();
    let mut columns = vec![row_name.to_string()];
    columns.extend(cols.iter().map(|c| format!("{col_prefix}{c}")));
    let rows = rows
        .into_iter()
        .map(|r| {
            let mut row = vec![row_json(r)];
            row.extend(
                cols.iter()
                    .map(|c| cells.get(&(r, *c)).map_or(Value::Null, |s| json!(s))),
            );
            row
        })
        .collect();
    Table { columns, rows }
}

impl std::fmt::Display for Key {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}", self.0)
    }
}

/// One row per particle of a final state (`final_json`, or its `at_end`): index, x, y, ω*, the
/// gap to the next particle along the chain over a, r*.
fn final_rows(state: &Value) -> Vec<Vec<Value>> {
    let at = |key: &str, i: usize| state[key].get(i).cloned().unwrap_or(Value::Null);
    let positions = state["positions"].as_array().cloned().unwrap_or_default();
    let x_of = |i: usize| positions[i].get(0).and_then(Value::as_f64);
    // gaps_over_a[k] is between the k-th and (k+1)-th particle ordered by x (as the classifier
    // orders the chain): give it to the k-th as its gap to the next
    let mut by_x: Vec<usize> = (0..positions.len()).collect();
    by_x.sort_by(|&i, &j| {
        x_of(i)
            .unwrap_or(f64::NAN)
            .total_cmp(&x_of(j).unwrap_or(f64::NAN))
    });
    let mut gap_next = vec![Value::Null; positions.len()];
    for (k, &i) in by_x.iter().enumerate() {
        gap_next[i] = at("gaps_over_a", k);
    }
    positions
        .iter()
        .enumerate()
        .map(|(i, p)| {
            vec![
                json!(i),
                p.get(0).cloned().unwrap_or(Value::Null),
                p.get(1).cloned().unwrap_or(Value::Null),
                at("omega_star", i),
                gap_next[i].clone(),
                at("r_star", i),
            ]
        })
        .collect()
}

#[cfg(test)]
mod tests;
