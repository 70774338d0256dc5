//! Reading where a sweep's cases stand (`xpflow status`, the estimate): counts, the cases
//! running and whether their processes live, the failed ones, the finished ones' timings.

use rusqlite::params;

use super::{hostname, Result, Store};

/// Per-sweep case counts for `xpflow status`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SweepCounts {
    /// Sweep name.
    pub name: String,
    /// Cases in the sweep.
    pub total: i64,
    /// Finished (any outcome, including `diverged`).
    pub done: i64,
    /// Claimed by a run that is in progress (or was killed; a rerun resets those).
    pub running: i64,
    /// Runs that could not be carried out.
    pub failed: i64,
    /// Not started.
    pub pending: i64,
}

/// A case marked running: by a live process, a killed one (a rerun continues it), or one on
/// another host.
#[derive(Debug, Clone, PartialEq)]
pub struct RunningCase {
    /// Sweep that registered the case.
    pub sweep: String,
    /// Case id.
    pub hash: String,
    /// Case label.
    pub label: String,
    /// End time of the case.
    pub t_end: Option<f64>,
    /// Time of the last stored sample.
    pub t_stored: Option<f64>,
    /// Δt per step between the last two stored samples (the step an adaptive case takes now).
    pub dt_recent: Option<f64>,
    /// Whether its process is alive (`None`: another host, cannot tell).
    pub alive: Option<bool>,
}

/// A case whose run could not be carried out (status `failed`) or ended by the solver's
/// divergence (status `done`, outcome `diverged`).
#[derive(Debug, Clone, PartialEq)]
pub struct FailedCase {
    /// `failed` or `diverged`.
    pub kind: String,
    /// Sweep that registered the case.
    pub sweep: String,
    /// Case id.
    pub hash: String,
    /// Case label.
    pub label: String,
    /// Time the run reached.
    pub t_reached: Option<f64>,
    /// Why it failed.
    pub error: Option<String>,
}

/// Δt per step between the last two stored samples of a case (`None` with fewer than two).
fn recent_dt(conn: &rusqlite::Connection, case_id: i64) -> rusqlite::Result<Option<f64>> {
    let mut st = conn.prepare_cached(
        "SELECT DISTINCT step, t FROM samples WHERE case_id = ?1 ORDER BY step DESC LIMIT 2",
    )?;
    let last: Vec<(i64, f64)> = st
        .query_map([case_id], |r| Ok((r.get(0)?, r.get(1)?)))?
        .collect::<rusqlite::Result<_>>()?;
    Ok(match last[..] {
        [(s1, t1), (s0, t0)] if s1 > s0 => Some((t1 - t0) / (s1 - s0) as f64),
        _ => None,
    })
}

/// Whether the process that claimed a case (`owner` = `host:pid`, `pid`) is alive: `None` when it
/// ran on another host (cannot tell), `Some(false)` without a pid.
pub(super) fn owner_alive(owner: Option<&str>, pid: Option<i64>, host: &str) -> Option<bool> {
    let same_host = owner.is_some_and(|o| o.rsplit_once(':').is_some_and(|(h, _)| h == host));
    match (same_host, pid) {
        (true, Some(pid)) => Some(pid_alive(pid)),
        (_, None) => Some(false),
        (false, Some(_)) => None,
    }
}

/// True if a process with this id is alive on this host (Linux `/proc`; zombies count as dead).
fn pid_alive(pid: i64) -> bool {
    if pid == i64::from(std::process::id()) {
        return true;
    }
    match std::fs::read_to_string(format!("/proc/{pid}/stat")) {
        // The state is the first field after the parenthesised command name.
        Ok(stat) => stat
            .rsplit_once(')')
            .is_some_and(|(_, rest)| !rest.trim_start().starts_with(['Z', 'X'])),
        Err(_) => false,
    }
}

impl Store {
    /// The cases marked running, with how far their stored samples go.
    pub fn running_cases(&self) -> Result<Vec<RunningCase>> {
        let err = self.sql_err();
        let host = hostname();
        let mut st = self
            .conn
            .prepare(
                "SELECT s.name, c.case_hash, c.label, c.t_end, c.owner, c.owner_pid,
                        (SELECT MAX(t) FROM samples WHERE case_id = c.id), c.id
                 FROM cases c JOIN sweeps s ON s.id = c.sweep_id
                 WHERE c.status = 'running' ORDER BY s.name, c.id",
            )
            .map_err(&err)?;
        let rows = st
            .query_map([], |r| {
                let owner: Option<String> = r.get(4)?;
                Ok(RunningCase {
                    sweep: r.get(0)?,
                    hash: r.get(1)?,
                    label: r.get(2)?,
                    t_end: r.get(3)?,
                    t_stored: r.get(6)?,
                    dt_recent: recent_dt(&self.conn, r.get(7)?)?,
                    alive: owner_alive(owner.as_deref(), r.get(5)?, &host),
                })
            })
            .map_err(&err)?;
        rows.collect::<rusqlite::Result<_>>().map_err(err)
    }

    /// The failed and the diverged cases, by sweep and registration.
    pub fn failed_cases(&self) -> Result<Vec<FailedCase>> {
        let err = self.sql_err();
        let mut st = self
            .conn
            .prepare(
                "SELECT CASE WHEN c.status = 'failed' THEN 'failed' ELSE 'diverged' END,
                        s.name, c.case_hash, c.label, c.t_reached, c.error
                 FROM cases c JOIN sweeps s ON s.id = c.sweep_id
                 LEFT JOIN outcomes o ON o.case_id = c.id
                 WHERE c.status = 'failed' OR (c.status = 'done' AND o.kind = 'diverged')
                 ORDER BY s.name, c.id",
            )
            .map_err(&err)?;
        let rows = st
            .query_map([], |r| {
                Ok(FailedCase {
                    kind: r.get(0)?,
                    sweep: r.get(1)?,
                    hash: r.get(2)?,
                    label: r.get(3)?,
                    t_reached: r.get(4)?,
                    error: r.get(5)?,
                })
            })
            .map_err(&err)?;
        rows.collect::<rusqlite::Result<_>>().map_err(err)
    }

    /// Every case's id and status.
    pub fn statuses(&self) -> Result<Vec<(String, String)>> {
        let err = self.sql_err();
        let mut st = self
            .conn
            .prepare("SELECT case_hash, status FROM cases ORDER BY id")
            .map_err(&err)?;
        let rows = st
            .query_map([], |r| Ok((r.get(0)?, r.get(1)?)))
            .map_err(&err)?;
        rows.collect::<rusqlite::Result<_>>().map_err(err)
    }

    /// The finished cases that took steps: their case JSON (`params_json`), core seconds (the
    /// CPU time the outcome records, `final_json.cpu_s`, else — for cases run before it was
    /// recorded, or where there is no thread clock — the wall-clock `wall_s`) and steps (with an
    /// extrusion's undisturbed prelude when the case stepped it itself: its time holds them),
    /// for a measured cost per step.
    pub fn finished_timings(&self) -> Result<Vec<(String, f64, u64)>> {
        let err = self.sql_err();
        let mut st = self
            .conn
            .prepare(
                "SELECT c.params_json, COALESCE(json_extract(o.final_json, '$.cpu_s'), c.wall_s),
                        c.steps + COALESCE(CASE WHEN json_extract(o.final_json,
                                                 '$.undisturbed_surface.shared') THEN 0
                                  ELSE json_extract(o.final_json, '$.undisturbed_surface.steps')
                                  END, 0)
                 FROM cases c LEFT JOIN outcomes o ON o.case_id = c.id
                 WHERE c.status = 'done' AND c.steps > 0 AND c.wall_s > 0 ORDER BY c.id",
            )
            .map_err(&err)?;
        let rows = st
            .query_map([], |r| {
                Ok((r.get(0)?, r.get(1)?, r.get::<_, i64>(2)?.max(0) as u64))
            })
            .map_err(&err)?;
        rows.collect::<rusqlite::Result<_>>().map_err(err)
    }

    /// Case counts per sweep (all sweeps, or the one named).
    pub fn counts(&self, sweep: Option<&str>) -> Result<Vec<SweepCounts>> {
        let err = self.sql_err();
        let mut st = self
            .conn
            .prepare(
                "SELECT s.name, COUNT(c.id),
                        COALESCE(SUM(c.status = 'done'), 0), COALESCE(SUM(c.status = 'running'), 0),
                        COALESCE(SUM(c.status = 'failed'), 0), COALESCE(SUM(c.status = 'pending'), 0)
                 FROM sweeps s LEFT JOIN sweep_cases sc ON sc.sweep_id = s.id LEFT JOIN cases c ON c.id = sc.case_id
                 WHERE ?1 IS NULL OR s.name = ?1
                 GROUP BY s.id ORDER BY s.name",
            )
            .map_err(&err)?;
        let rows = st
            .query_map(params![sweep], |r| {
                Ok(SweepCounts {
                    name: r.get(0)?,
                    total: r.get(1)?,
                    done: r.get(2)?,
                    running: r.get(3)?,
                    failed: r.get(4)?,
                    pending: r.get(5)?,
                })
            })
            .map_err(&err)?;
        rows.collect::<rusqlite::Result<_>>().map_err(err)
    }
}
