//! Writing sweeps, runs and cases: registration, claiming a case (pending → running), checkpoints of
//! samples, and the one transaction that records a finished case.

use rusqlite::types::Value as SqlValue;
use rusqlite::{params, OptionalExtension, TransactionBehavior};

use super::status::owner_alive;
use super::{code_version, hostname, machine, Result, Store};
use crate::config::SweepSpec;
use crate::config::{PlannedCase, PARAMETER_COLUMNS};
use crate::observe::{Outcome, Sample};

/// A case claimed by this process.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Claim {
    /// Row id of the case.
    pub id: i64,
    /// Whether it continues an interrupted attempt from its saved state (rows up to the saved
    /// step kept) rather than starting over.
    pub resumed: bool,
}

/// What [`Store::claim`] found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ClaimResult {
    /// The case was pending and is now this process's.
    Claimed(Claim),
    /// The case is done or failed already (another sweep finished it meanwhile).
    Finished,
    /// Another process is running the case.
    Elsewhere,
}

/// Everything recorded when a case ends.
#[derive(Debug, Clone)]
pub struct CaseRecord {
    /// Samples not yet written by a checkpoint.
    pub samples: Vec<Sample>,
    /// The outcome; `None` for a failed run.
    pub outcome: Option<Outcome>,
    /// Error text (failed) or divergence reason.
    pub error: Option<String>,
    /// Wall-clock seconds.
    pub wall_s: f64,
    /// Time steps taken.
    pub steps: u64,
    /// Simulated time reached.
    pub t_reached: f64,
    /// The run that produced it.
    pub run_id: i64,
    /// The resolved numerical settings it ran with (JSON), if the runner reports them.
    pub settings: Option<String>,
}

/// Sample rows of a case up to and including `step`.
fn sample_rows(conn: &rusqlite::Connection, case_id: i64, step: u64) -> rusqlite::Result<u64> {
    conn.query_row(
        "SELECT COUNT(*) FROM samples WHERE case_id = ?1 AND step <= ?2",
        params![case_id, step as i64],
        |r| r.get::<_, i64>(0),
    )
    .map(|n| n as u64)
}

/// This process' owner tag for claimed cases: `host:pid`.
fn owner() -> String {
    format!("{}:{}", hostname(), std::process::id())
}

impl Store {
    /// Records the sweep (or updates the spec of an existing sweep of that name); returns its id.
    pub fn register_sweep(&mut self, sweep: &SweepSpec) -> Result<i64> {
        let spec = sweep.raw.to_string();
        let err = self.sql_err();
        self.conn
            .execute(
                "INSERT INTO sweeps (name, spec_json, code_version, machine) VALUES (?1, ?2, ?3, ?4)
                 ON CONFLICT(name) DO UPDATE SET spec_json = excluded.spec_json",
                params![sweep.name, spec, code_version(), machine()],
            )
            .map_err(&err)?;
        self.conn
            .query_row(
                "SELECT id FROM sweeps WHERE name = ?1",
                params![sweep.name],
                |r| r.get(0),
            )
            .map_err(err)
    }

    /// Starts a run record (this invocation) of a sweep.
    pub fn begin_run(&mut self, sweep_id: i64, jobs: usize, spec_json: &str) -> Result<i64> {
        let err = self.sql_err();
        self.conn
            .execute(
                "INSERT INTO runs (sweep_id, code_version, machine, pid, jobs, spec_json) VALUES (?1, ?2, ?3, ?4, ?5, ?6)",
                params![sweep_id, code_version(), machine(), std::process::id(), jobs as i64, spec_json],
            )
            .map_err(err)?;
        Ok(self.conn.last_insert_rowid())
    }

    /// Marks a run finished.
    ///
    /// # Errors
    /// [`StoreError::Vanished`](super::StoreError::Vanished) when the database file was deleted or
    /// replaced during the run.
    pub fn finish_run(&mut self, run_id: i64) -> Result<()> {
        self.check_still_there()?;
        self.conn
            .execute(
                "UPDATE runs SET finished_at = strftime('%Y-%m-%dT%H:%M:%fZ', 'now') WHERE id = ?1",
                params![run_id],
            )
            .map_err(self.sql_err())?;
        Ok(())
    }

    /// Inserts the sweep's cases that are not in the database yet (as `pending`) and links all of them to
    /// the sweep, in one transaction. Cases linked by an earlier version of the sweep file that its
    /// current version no longer expands to are unlinked (their rows and results stay in the database;
    /// `query --sweep NAME` lists the sweep as it stands).
    pub fn add_cases(&mut self, sweep_id: i64, cases: &[PlannedCase]) -> Result<()> {
        self.insert_and_link(sweep_id, cases, true)
    }

    /// [`add_cases`](Self::add_cases) without unlinking the sweep's other cases: `cases` join
    /// those the sweep has (a round of tries runs its current cases of a sweep registered whole).
    pub fn link_cases(&mut self, sweep_id: i64, cases: &[PlannedCase]) -> Result<()> {
        self.insert_and_link(sweep_id, cases, false)
    }

    fn insert_and_link(
        &mut self,
        sweep_id: i64,
        cases: &[PlannedCase],
        replace: bool,
    ) -> Result<()> {
        let err = self.sql_err();
        let path = self.path.clone();
        let tx = self
            .conn
            .transaction_with_behavior(TransactionBehavior::Immediate)
            .map_err(&err)?;
        if replace {
            // relinked below: the links are the current expansion of the sweep file
            tx.execute(
                "DELETE FROM sweep_cases WHERE sweep_id = ?1",
                params![sweep_id],
            )
            .map_err(&err)?;
        }
        {
            let n = 5 + PARAMETER_COLUMNS.len();
            let mut insert = tx
                .prepare(&format!(
                    "INSERT OR IGNORE INTO cases (sweep_id, case_hash, label, geometry, params_json, {})
                     VALUES ({})",
                    PARAMETER_COLUMNS.join(", "),
                    (1..=n).map(|i| format!("?{i}")).collect::<Vec<_>>().join(", ")
                ))
                .map_err(&err)?;
            let mut link = tx
                .prepare(
                    "INSERT OR IGNORE INTO sweep_cases (sweep_id, case_id, case_index, label)
                     SELECT ?1, id, ?2, ?3 FROM cases WHERE case_hash = ?4",
                )
                .map_err(&err)?;
            for c in cases {
                let s = &c.spec;
                let params_json = serde_json::to_string(s).unwrap_or_default();
                let mut row = vec![
                    SqlValue::Integer(sweep_id),
                    SqlValue::Text(c.id.clone()),
                    SqlValue::Text(c.label.clone()),
                    SqlValue::Text(s.geometry.kind().into()),
                    SqlValue::Text(params_json),
                ];
                // the parameters, in the INSERT's order (PARAMETER_COLUMNS)
                row.extend(s.parameter_columns().map(|(_, v)| match v {
                    serde_json::Value::Number(n) => n.as_i64().map_or_else(
                        || SqlValue::Real(n.as_f64().unwrap_or(f64::NAN)),
                        SqlValue::Integer,
                    ),
                    serde_json::Value::String(t) => SqlValue::Text(t),
                    _ => SqlValue::Null,
                }));
                insert
                    .execute(rusqlite::params_from_iter(row))
                    .map_err(|source| super::StoreError::Sql {
                        path: path.clone(),
                        source,
                    })?;
                link.execute(params![sweep_id, c.index as i64, c.label, c.id])
                    .map_err(&err)?;
            }
        }
        tx.commit().map_err(err)
    }

    /// Resets the sweep's `running` cases whose owner process is gone (killed sweep) to `pending`, and with
    /// `retry_failed` its `failed` cases too; returns how many were reset.
    pub fn reset_interrupted(&mut self, sweep_id: i64, retry_failed: bool) -> Result<usize> {
        let err = self.sql_err();
        let host = hostname();
        let running: Vec<(i64, Option<String>, Option<i64>)> = {
            let mut st = self
                .conn
                .prepare(
                    "SELECT c.id, c.owner, c.owner_pid FROM cases c JOIN sweep_cases sc ON sc.case_id = c.id
                     WHERE sc.sweep_id = ?1 AND c.status = 'running'",
                )
                .map_err(&err)?;
            let rows = st
                .query_map(params![sweep_id], |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?)))
                .map_err(&err)?;
            rows.collect::<rusqlite::Result<_>>().map_err(&err)?
        };
        let mut reset = 0;
        for (id, owner, pid) in running {
            // another host: cannot tell; leave it (documented in docs/sweeps.md)
            if owner_alive(owner.as_deref(), pid, &host) == Some(false) {
                reset += self
                    .conn
                    .execute(
                        "UPDATE cases SET status = 'pending', owner = NULL, owner_pid = NULL
                         WHERE id = ?1 AND status = 'running' AND owner IS ?2",
                        params![id, owner],
                    )
                    .map_err(&err)?;
            }
        }
        if retry_failed {
            reset += self
                .conn
                .execute(
                    "UPDATE cases SET status = 'pending', error = NULL WHERE status = 'failed'
                     AND id IN (SELECT case_id FROM sweep_cases WHERE sweep_id = ?1)",
                    params![sweep_id],
                )
                .map_err(&err)?;
        }
        Ok(reset)
    }

    /// Claims a pending case for this process (pending → running) and clears the rows of an
    /// earlier interrupted attempt; returns the case's row id and whether it continues that
    /// attempt, or what keeps the case from being claimed (finished, or running elsewhere).
    ///
    /// `resume = Some((step, rows))` offers to continue from a saved state after `step` that was
    /// written when the case had `rows` sample rows up to `step`: if the database still has exactly
    /// those, the rows after `step` are dropped and the earlier ones kept; otherwise (a new or
    /// another database) everything is cleared and the case starts over.
    ///
    /// # Errors
    /// [`StoreError::Vanished`](super::StoreError::Vanished) when the case is not in the database
    /// at all (it was registered by this sweep: the file was deleted or replaced).
    pub fn claim(&mut self, case_hash: &str, resume: Option<(u64, u64)>) -> Result<ClaimResult> {
        self.check_still_there()?;
        let err = self.sql_err();
        let tx = self
            .conn
            .transaction_with_behavior(TransactionBehavior::Immediate)
            .map_err(&err)?;
        let row: Option<(i64, String)> = tx
            .query_row(
                "SELECT id, status FROM cases WHERE case_hash = ?1",
                params![case_hash],
                |r| Ok((r.get(0)?, r.get(1)?)),
            )
            .optional()
            .map_err(&err)?;
        let id = match row {
            Some((id, status)) if status == "pending" => id,
            Some((_, status)) => {
                tx.commit().map_err(err)?;
                return Ok(if status == "running" {
                    ClaimResult::Elsewhere
                } else {
                    ClaimResult::Finished
                });
            }
            None => {
                return Err(super::StoreError::Vanished {
                    path: self.path.clone(),
                    what: format!("case {case_hash}, registered by this sweep, is not in it"),
                })
            }
        };
        let claimed = tx
            .execute(
                "UPDATE cases SET status = 'running', owner = ?2, owner_pid = ?3, error = NULL,
                    started_at = strftime('%Y-%m-%dT%H:%M:%fZ', 'now') WHERE id = ?1 AND status = 'pending'",
                params![id, owner(), std::process::id()],
            )
            .map_err(&err)?;
        debug_assert_eq!(claimed, 1, "the row was pending inside this transaction");
        let keep = match resume {
            Some((step, rows)) => {
                // the state's own step may have been stored after it (the last sample of a run
                // that failed right after the state was saved): the rows before it must match
                let fits = sample_rows(&tx, id, step).map_err(&err)? == rows
                    || match step.checked_sub(1) {
                        Some(s) => sample_rows(&tx, id, s).map_err(&err)? == rows,
                        None => rows == 0,
                    };
                fits.then_some(step as i64)
            }
            None => None,
        };
        // keep = -1 clears everything
        let after = keep.unwrap_or(-1);
        for table in [
            "DELETE FROM samples WHERE case_id = ?1 AND step > ?2",
            "DELETE FROM snapshots WHERE case_id = ?1 AND step > ?2",
        ] {
            tx.execute(table, params![id, after]).map_err(&err)?;
        }
        tx.execute("DELETE FROM outcomes WHERE case_id = ?1", params![id])
            .map_err(&err)?;
        tx.commit().map_err(err)?;
        Ok(ClaimResult::Claimed(Claim {
            id,
            resumed: keep.is_some(),
        }))
    }

    /// Sample rows of a case up to and including `step`.
    pub fn count_samples(&self, case_id: i64, step: u64) -> Result<u64> {
        sample_rows(&self.conn, case_id, step).map_err(self.sql_err())
    }

    /// Writes samples of a running case (checkpoint), in one transaction.
    pub fn write_samples(&mut self, case_id: i64, samples: &[Sample]) -> Result<()> {
        let err = self.sql_err();
        let tx = self
            .conn
            .transaction_with_behavior(TransactionBehavior::Immediate)
            .map_err(&err)?;
        insert_samples(&tx, case_id, samples).map_err(&err)?;
        tx.commit().map_err(err)
    }

    /// Records a snapshot file of a running case.
    pub fn record_snapshot(&mut self, case_id: i64, step: u64, t: f64, file: &str) -> Result<()> {
        self.conn
            .execute(
                "INSERT OR REPLACE INTO snapshots (case_id, step, t, file) VALUES (?1, ?2, ?3, ?4)",
                params![case_id, step as i64, t, file],
            )
            .map_err(self.sql_err())?;
        Ok(())
    }

    /// Records a finished (or failed) case in one transaction: remaining samples, outcome, status.
    ///
    /// # Errors
    /// [`StoreError::Vanished`](super::StoreError::Vanished) when the database file was deleted or
    /// replaced since it was opened, or the case's row is gone: the result is not recorded, and
    /// the caller must say so.
    pub fn finish_case(&mut self, case_id: i64, rec: &CaseRecord) -> Result<()> {
        self.check_still_there()?;
        let err = self.sql_err();
        let tx = self
            .conn
            .transaction_with_behavior(TransactionBehavior::Immediate)
            .map_err(&err)?;
        insert_samples(&tx, case_id, &rec.samples).map_err(&err)?;
        let status = if let Some(o) = &rec.outcome {
            tx.execute(
                "INSERT OR REPLACE INTO outcomes (case_id, kind, string_length, t_decided, mean_gap, final_json)
                 VALUES (?1, ?2, ?3, ?4, ?5, ?6)",
                params![
                    case_id,
                    o.kind.as_str(),
                    o.string_length.map(|n| n as i64),
                    o.t_decided,
                    o.mean_gap,
                    o.final_state.to_string()
                ],
            )
            .map_err(&err)?;
            "done"
        } else {
            "failed"
        };
        let updated = tx.execute(
            "UPDATE cases SET status = ?2, finished_at = strftime('%Y-%m-%dT%H:%M:%fZ', 'now'), wall_s = ?3,
                steps = ?4, t_reached = ?5, run_id = ?6, error = ?7, owner = NULL, owner_pid = NULL,
                settings_json = ?8
             WHERE id = ?1",
            params![
                case_id,
                status,
                rec.wall_s,
                rec.steps as i64,
                rec.t_reached,
                rec.run_id,
                rec.error,
                rec.settings
            ],
        )
        .map_err(&err)?;
        if updated != 1 {
            return Err(super::StoreError::Vanished {
                path: self.path.clone(),
                what: format!("case row {case_id} is gone"),
            });
        }
        tx.commit().map_err(err)
    }
}

fn insert_samples(
    tx: &rusqlite::Transaction<'_>,
    case_id: i64,
    samples: &[Sample],
) -> rusqlite::Result<()> {
    let mut st = tx.prepare(
        "INSERT OR REPLACE INTO samples
             (case_id, step, t, particle, x, y, u, v, omega, theta, separation)
         VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11)",
    )?;
    for s in samples {
        for (k, p) in s.particles.iter().enumerate() {
            st.execute(params![
                case_id,
                s.step as i64,
                s.t,
                k as i64,
                p.x,
                p.y,
                p.u,
                p.v,
                p.omega,
                p.theta,
                p.separation
            ])?;
        }
    }
    Ok(())
}
