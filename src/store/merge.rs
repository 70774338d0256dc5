//! `xpflow merge`: folding published shards ([`super::shard`]) into a sweep's database.
//!
//! One transaction per shard: its sweep (by name), its run, its case row, samples, outcome,
//! snapshots and sweep membership, and a row in `merged_shards` with the shard's publication id.
//! A publication merged before is skipped, so merging again is a no-op. What a shard's case
//! meets in the database decides what happens:
//!
//! | database \ shard | done | failed | running |
//! |---|---|---|---|
//! | absent, pending, failed, running by a gone process | merged | merged | skipped (not finished) |
//! | done | conflict: the database's kept | ignored (the database has it done) | skipped |
//! | running by a live process or on another host | conflict | conflict | skipped |
//!
//! A shard is read through an immutable read-only attachment: merging never writes to it.

use std::path::{Path, PathBuf};

use rusqlite::{params, OptionalExtension, TransactionBehavior};

use super::open::immutable_uri;
use super::shard::shard_cases;
use super::status::owner_alive;
use super::{hostname, schema, Result, Store, StoreError};

/// The columns of `cases` copied from a shard as they are (`id`, `sweep_id` and `run_id` are
/// mapped onto the database's rows).
const CASE_COLUMNS: [&str; 29] = schema::columns(&[
    &["case_hash", "label", "geometry", "params_json"],
    &crate::config::PARAMETER_COLUMNS,
    &[
        "status",
        "owner",
        "owner_pid",
        "started_at",
        "finished_at",
        "wall_s",
        "steps",
        "t_reached",
        "error",
        "settings_json",
    ],
]);

/// What merging one shard did.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Merged {
    /// Its case was added or replaced; the status it brought (`done` or `failed`).
    Merged {
        /// Case id.
        case: String,
        /// The shard's status of the case.
        status: String,
        /// Whether the case was in the database before (pending, failed or interrupted).
        replaced: bool,
    },
    /// This publication was merged before: nothing to do.
    AlreadyMerged,
    /// The database has the case done and the shard a failed attempt: nothing to take.
    Ignored {
        /// Case id.
        case: String,
    },
    /// The shard's case has not finished (its task runs, or was killed: resubmit it).
    NotFinished {
        /// Case id.
        case: String,
    },
    /// The database holds a result or a live run of the case that the shard would overwrite;
    /// the database's is kept.
    Conflict {
        /// Case id.
        case: String,
        /// What the database has.
        reason: String,
    },
}

/// Errors that make one shard unmergeable (the others are still merged).
#[derive(Debug, thiserror::Error)]
pub enum MergeError {
    /// The shard is not a readable xpflow database of this schema, or fails its integrity check.
    #[error("shard {}: {reason}", path.display())]
    BadShard {
        /// The shard file.
        path: PathBuf,
        /// What is wrong.
        reason: String,
    },
    /// The database failed.
    #[error(transparent)]
    Store(#[from] StoreError),
}

impl Store {
    /// Merges the published shard `shard` in one transaction (see the module's table).
    ///
    /// # Errors
    /// [`MergeError::BadShard`] for a shard that is not an xpflow database of this schema, is
    /// damaged, or holds more than one sweep; [`MergeError::Store`] when the database fails.
    pub fn merge_shard(&mut self, shard: &Path) -> std::result::Result<Merged, MergeError> {
        let bad = |reason: String| MergeError::BadShard {
            path: shard.to_path_buf(),
            reason,
        };
        let (publication, cases) = {
            let s = Store::open_read_only(shard).map_err(|e| {
                bad(match e {
                    StoreError::NotDatabase { .. } => "not an SQLite database".into(),
                    StoreError::Foreign { tables, .. } => {
                        format!("an SQLite database of another program ({tables})")
                    }
                    e => e.to_string(),
                })
            })?;
            let check = s.integrity_check().map_err(|e| bad(e.to_string()))?;
            if check != "ok" {
                return Err(bad(format!("integrity check: {check}")));
            }
            let version: i64 = s
                .conn
                .query_row("SELECT MAX(version) FROM schema_version", [], |r| r.get(0))
                .map_err(|e| bad(e.to_string()))?;
            if version != schema::SCHEMA_VERSION {
                return Err(bad(format!(
                    "schema version {version}, this xpflow writes {}: merge with the xpflow \
                     that ran the shard",
                    schema::SCHEMA_VERSION
                )));
            }
            let publication = s
                .publication()
                .map_err(|e| bad(e.to_string()))?
                .ok_or_else(|| bad("never published (not a shard)".into()))?;
            let cases = shard_cases(shard).map_err(|e| bad(e.to_string()))?;
            (publication, cases)
        };
        let [case] = cases.as_slice() else {
            return Err(bad(format!("{} cases; a shard has one", cases.len())));
        };
        if case.status != "done" && case.status != "failed" {
            return Ok(Merged::NotFinished {
                case: case.hash.clone(),
            });
        }
        let err = self.sql_err();
        self.conn
            .execute("ATTACH DATABASE ?1 AS shard", params![immutable_uri(shard)])
            .map_err(|e| bad(format!("cannot attach: {e}")))?;
        let merged = self.merge_attached(shard, &publication, &case.hash, &case.status);
        self.conn
            .execute("DETACH DATABASE shard", [])
            .map_err(err)?;
        merged.map_err(MergeError::from)
    }

    /// The transaction of [`Store::merge_shard`], with the shard attached as `shard`.
    fn merge_attached(
        &mut self,
        file: &Path,
        publication: &str,
        hash: &str,
        status: &str,
    ) -> Result<Merged> {
        let err = self.sql_err();
        let host = hostname();
        let tx = self
            .conn
            .transaction_with_behavior(TransactionBehavior::Immediate)
            .map_err(&err)?;
        let seen: Option<String> = tx
            .query_row(
                "SELECT publish_id FROM merged_shards WHERE publish_id = ?1",
                params![publication],
                |r| r.get(0),
            )
            .optional()
            .map_err(&err)?;
        if seen.is_some() {
            return Ok(Merged::AlreadyMerged);
        }
        type Existing = (i64, String, Option<String>, Option<i64>);
        let existing: Option<Existing> = tx
            .query_row(
                "SELECT id, status, owner, owner_pid FROM cases WHERE case_hash = ?1",
                params![hash],
                |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?, r.get(3)?)),
            )
            .optional()
            .map_err(&err)?;
        let conflict = |reason: &str| Merged::Conflict {
            case: hash.to_string(),
            reason: reason.to_string(),
        };
        let record = |tx: &rusqlite::Transaction<'_>| {
            tx.execute(
                "INSERT INTO merged_shards (publish_id, file, case_hash, status) VALUES (?1, ?2, ?3, ?4)",
                params![publication, file.to_string_lossy(), hash, status],
            )
        };
        match &existing {
            Some((_, s, ..)) if s == "done" && status == "failed" => {
                record(&tx).map_err(&err)?;
                tx.commit().map_err(&err)?;
                return Ok(Merged::Ignored {
                    case: hash.to_string(),
                });
            }
            Some((_, s, ..)) if s == "done" => {
                return Ok(conflict(
                    "done in the database already (its result is kept)",
                ))
            }
            Some((_, s, owner, pid))
                if s == "running" && owner_alive(owner.as_deref(), *pid, &host) != Some(false) =>
            {
                return Ok(conflict(
                    "running in the database (a sweep may be running it; merge again later)",
                ))
            }
            _ => {}
        }
        // the sweep (by name) and the run of the shard
        let (shard_sweep, shard_case, shard_run): (i64, i64, Option<i64>) = tx
            .query_row(
                "SELECT sweep_id, id, run_id FROM shard.cases WHERE case_hash = ?1",
                params![hash],
                |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?)),
            )
            .map_err(&err)?;
        tx.execute(
            "INSERT INTO sweeps (name, spec_json, created_at, code_version, machine)
             SELECT name, spec_json, created_at, code_version, machine FROM shard.sweeps WHERE id = ?1
             ON CONFLICT(name) DO NOTHING",
            params![shard_sweep],
        )
        .map_err(&err)?;
        let sweep: i64 = tx
            .query_row(
                "SELECT id FROM sweeps WHERE name = (SELECT name FROM shard.sweeps WHERE id = ?1)",
                params![shard_sweep],
                |r| r.get(0),
            )
            .map_err(&err)?;
        let run: Option<i64> = match shard_run {
            Some(r) => {
                tx.execute(
                    "INSERT INTO runs (sweep_id, started_at, finished_at, code_version, machine, pid, jobs, spec_json)
                     SELECT ?1, started_at, finished_at, code_version, machine, pid, jobs, spec_json
                     FROM shard.runs WHERE id = ?2",
                    params![sweep, r],
                )
                .map_err(&err)?;
                Some(tx.last_insert_rowid())
            }
            None => None,
        };
        let columns = CASE_COLUMNS.join(", ");
        let target = match &existing {
            Some((id, ..)) => {
                for table in ["samples", "outcomes", "snapshots"] {
                    tx.execute(
                        &format!("DELETE FROM {table} WHERE case_id = ?1"),
                        params![id],
                    )
                    .map_err(&err)?;
                }
                tx.execute(
                    &format!(
                        "UPDATE cases SET ({columns}, run_id) = (SELECT {columns}, ?2
                         FROM shard.cases WHERE id = ?3) WHERE id = ?1"
                    ),
                    params![id, run, shard_case],
                )
                .map_err(&err)?;
                *id
            }
            None => {
                tx.execute(
                    &format!(
                        "INSERT INTO cases (sweep_id, run_id, {columns})
                         SELECT ?1, ?2, {columns} FROM shard.cases WHERE id = ?3"
                    ),
                    params![sweep, run, shard_case],
                )
                .map_err(&err)?;
                tx.last_insert_rowid()
            }
        };
        for sql in [
            "INSERT INTO samples (case_id, step, t, particle, x, y, u, v, omega, theta, separation)
             SELECT ?1, step, t, particle, x, y, u, v, omega, theta, separation
             FROM shard.samples WHERE case_id = ?2",
            "INSERT INTO outcomes (case_id, kind, string_length, t_decided, mean_gap, final_json)
             SELECT ?1, kind, string_length, t_decided, mean_gap, final_json FROM shard.outcomes WHERE case_id = ?2",
            "INSERT INTO snapshots (case_id, step, t, file)
             SELECT ?1, step, t, file FROM shard.snapshots WHERE case_id = ?2",
        ] {
            tx.execute(sql, params![target, shard_case]).map_err(&err)?;
        }
        tx.execute(
            "INSERT OR IGNORE INTO sweep_cases (sweep_id, case_id, case_index, label)
             SELECT ?1, ?2, case_index, label FROM shard.sweep_cases WHERE case_id = ?3",
            params![sweep, target, shard_case],
        )
        .map_err(&err)?;
        record(&tx).map_err(&err)?;
        tx.commit().map_err(&err)?;
        Ok(Merged::Merged {
            case: hash.to_string(),
            status: status.to_string(),
            replaced: existing.is_some(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every column of `cases` is copied or mapped: a column added to the schema must be added
    /// here too, or merged cases would lose it.
    #[test]
    fn the_copied_columns_are_the_table_s() {
        let store = Store {
            conn: rusqlite::Connection::open_in_memory().unwrap(),
            path: ":memory:".into(),
            identity: None,
        };
        store.conn.execute_batch(schema::CREATE).unwrap();
        let mut st = store
            .conn
            .prepare("SELECT name FROM pragma_table_info('cases') ORDER BY cid")
            .unwrap();
        let mut table: Vec<String> = st
            .query_map([], |r| r.get(0))
            .unwrap()
            .map(|r| r.unwrap())
            .collect();
        table.sort();
        let mut ours: Vec<String> = CASE_COLUMNS.iter().map(|c| c.to_string()).collect();
        ours.extend(["id", "sweep_id", "run_id"].map(String::from));
        ours.sort();
        assert_eq!(table, ours);
    }
}
