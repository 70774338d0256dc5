//! Reading back what given cases gave: their status and outcome by case id, and the sweep files
//! stored with each sweep. An adaptive search (`sweep::search`) replays its rounds from these, so
//! its state is the database's, never the memory of a process.

use std::collections::HashMap;

use rusqlite::params;

use super::{Result, Store};

/// Rows looked up per statement (SQLite binds at most 32 766 parameters).
const LOOKUP_CHUNK: usize = 500;

/// The status and outcome of one case as stored.
#[derive(Debug, Clone, PartialEq)]
pub struct StoredOutcome {
    /// `pending`, `running`, `done` or `failed`.
    pub status: String,
    /// Outcome kind of a finished case (`done`).
    pub kind: Option<String>,
    /// Its string length, for a string.
    pub string_length: Option<i64>,
}

impl Store {
    /// The stored status and outcome of each of `ids` (case hashes) that the database has.
    pub fn outcomes_of(&self, ids: &[&str]) -> Result<HashMap<String, StoredOutcome>> {
        let err = self.sql_err();
        let mut out = HashMap::with_capacity(ids.len());
        for chunk in ids.chunks(LOOKUP_CHUNK) {
            let marks = vec!["?"; chunk.len()].join(", ");
            let mut st = self
                .conn
                .prepare(&format!(
                    "SELECT c.case_hash, c.status, o.kind, o.string_length
                     FROM cases c LEFT JOIN outcomes o ON o.case_id = c.id
                     WHERE c.case_hash IN ({marks})"
                ))
                .map_err(&err)?;
            let rows = st
                .query_map(rusqlite::params_from_iter(chunk.iter()), |r| {
                    Ok((
                        r.get::<_, String>(0)?,
                        StoredOutcome {
                            status: r.get(1)?,
                            kind: r.get(2)?,
                            string_length: r.get(3)?,
                        },
                    ))
                })
                .map_err(&err)?;
            for row in rows {
                let (id, o) = row.map_err(&err)?;
                out.insert(id, o);
            }
        }
        Ok(out)
    }

    /// The names and stored sweep files (JSON) of the database's sweeps, all or the one named, by
    /// name.
    pub fn sweep_files(&self, name: Option<&str>) -> Result<Vec<(String, String)>> {
        let err = self.sql_err();
        let mut st = self
            .conn
            .prepare(
                "SELECT name, spec_json FROM sweeps WHERE ?1 IS NULL OR name = ?1 ORDER BY name",
            )
            .map_err(&err)?;
        let rows = st
            .query_map(params![name], |r| Ok((r.get(0)?, r.get(1)?)))
            .map_err(&err)?;
        rows.collect::<rusqlite::Result<_>>().map_err(err)
    }
}
