//! `xpflow export`: a compact copy of a results database, for shipping a study as a dataset
//! (`data/thesis/`, docs/reproduction.md).
//!
//! The copy holds the finished cases (`done` and `failed`) of the chosen sweeps — every sweep by
//! default; a sweep's cases are those its file expands to now and those it registered under an
//! earlier version of the file (a rerun with other cases unlinks them, their results stay) — with
//! their rows as they are: case parameters, settings, status and timings,
//! outcomes and final states in full, sweep membership, the sweeps and the runs that made them.
//! Trajectories are copied whole, or **thinned** to at most `max_samples` sampled steps per case,
//! evenly spread in time, the first and the last always kept (what a figure draws; the outcome
//! was decided from the full trajectory and is stored in full). Snapshot rows are left out: their
//! HDF5 files live beside the source database and are not part of a dataset. The cases a sweep
//! lists that have not finished (pending, running, interrupted) are kept as `pending` rows without
//! samples or outcomes — a dataset holds results, and says which of its sweep's cases it has not
//! got yet (a Table 5.2 cell with a position still to try reads `?`, not `-`).
//!
//! The source is opened read-only (a running sweep may go on writing to it); the copy is written
//! to a temporary file beside the destination in one transaction, compacted (`VACUUM`, rollback
//! journal: one self-contained file) and renamed into place, so a dataset is either whole or
//! absent. An existing destination is refused, not overwritten. Columns are copied by name, so a
//! source of an older schema version exports into the current one.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use rusqlite::types::Value;
use rusqlite::{params_from_iter, Connection};

use super::{Result, Store, StoreError};

/// What to export.
#[derive(Debug, Clone, Default)]
pub struct ExportOptions {
    /// Only these sweeps (by name; every sweep when empty).
    pub sweeps: Vec<String>,
    /// At most this many sampled steps per case (None: all).
    pub max_samples: Option<usize>,
}

/// What an export wrote.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Exported {
    /// Sweeps in the copy.
    pub sweeps: usize,
    /// Cases in the copy (done and failed).
    pub cases: usize,
    /// Cases of the chosen sweeps that have not finished: listed as `pending`, without results.
    pub unfinished: usize,
    /// Sample rows in the source for the exported cases.
    pub samples_in: usize,
    /// Sample rows in the copy.
    pub samples_out: usize,
    /// Size of the copy in bytes.
    pub bytes: u64,
}

/// Errors of an export that are the caller's to fix (exit 2 at the command line).
#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    /// The destination exists.
    #[error("{}: exists; export writes a new file (remove it or choose another name)", .0.display())]
    Exists(PathBuf),
    /// A requested sweep is not in the source.
    #[error("{}: no sweep named {name:?} (its sweeps: {known})", path.display())]
    NoSuchSweep {
        /// The source database.
        path: PathBuf,
        /// The name asked for.
        name: String,
        /// The sweeps it has.
        known: String,
    },
    /// `max_samples` below 2 (the first and the last sample are always kept).
    #[error("--samples {0}: keep at least 2 samples per case (the first and the last)")]
    TooFewSamples(usize),
    /// The store failed.
    #[error(transparent)]
    Store(#[from] StoreError),
}

/// Exports the finished cases of `src` into the new database `dst` (see the module).
///
/// # Errors
/// [`ExportError::Exists`], [`ExportError::NoSuchSweep`], [`ExportError::TooFewSamples`], or the
/// store's errors reading `src` or writing `dst`.
pub fn export(
    src: &Path,
    dst: &Path,
    opts: &ExportOptions,
) -> std::result::Result<Exported, ExportError> {
    if opts.max_samples.is_some_and(|n| n < 2) {
        return Err(ExportError::TooFewSamples(opts.max_samples.unwrap_or(0)));
    }
    if dst.exists() {
        return Err(ExportError::Exists(dst.to_path_buf()));
    }
    let source = Store::open_read_only(src)?;
    let sweeps = chosen_sweeps(&source, src, &opts.sweeps)?;
    let tmp = dst.with_extension("db.partial");
    let _ = std::fs::remove_file(&tmp);
    let result = write_copy(&source, &tmp, &sweeps, opts.max_samples);
    let exported = match result {
        Ok(e) => e,
        Err(e) => {
            let _ = std::fs::remove_file(&tmp);
            return Err(e.into());
        }
    };
    std::fs::rename(&tmp, dst).map_err(|source| StoreError::Io {
        path: dst.to_path_buf(),
        source,
    })?;
    let bytes = std::fs::metadata(dst).map(|m| m.len()).unwrap_or(0);
    Ok(Exported { bytes, ..exported })
}

/// The ids of the sweeps to export (all when `names` is empty).
fn chosen_sweeps(
    source: &Store,
    path: &Path,
    names: &[String],
) -> std::result::Result<Vec<i64>, ExportError> {
    let err = source.sql_err();
    let mut st = source
        .conn
        .prepare("SELECT id, name FROM sweeps ORDER BY id")
        .map_err(&err)?;
    let all: Vec<(i64, String)> = st
        .query_map([], |r| Ok((r.get(0)?, r.get(1)?)))
        .and_then(|rows| rows.collect())
        .map_err(&err)?;
    if names.is_empty() {
        return Ok(all.into_iter().map(|(id, _)| id).collect());
    }
    names
        .iter()
        .map(|n| {
            all.iter()
                .find(|(_, name)| name == n)
                .map(|(id, _)| *id)
                .ok_or_else(|| ExportError::NoSuchSweep {
                    path: path.to_path_buf(),
                    name: n.clone(),
                    known: all
                        .iter()
                        .map(|(_, s)| s.as_str())
                        .collect::<Vec<_>>()
                        .join(", "),
                })
        })
        .collect()
}

/// Writes the copy into the new file `tmp` (one transaction, then compacted).
fn write_copy(
    source: &Store,
    tmp: &Path,
    sweeps: &[i64],
    max_samples: Option<usize>,
) -> Result<Exported> {
    let src = &source.conn;
    let serr = source.sql_err();
    let mut dest = Store::open_journal(tmp, "DELETE")?;
    let derr = dest.sql_err();
    let list = |ids: &BTreeSet<i64>| ids.iter().map(i64::to_string).collect::<Vec<_>>().join(",");
    let chosen: BTreeSet<i64> = sweeps.iter().copied().collect();
    let sweep_list = list(&chosen);
    // the sweeps' cases: those their files expand to now (linked) and those they registered and
    // ran under an earlier version of the file (unlinked by a rerun, results kept)
    let linked: BTreeSet<i64> = ids(
        src,
        &format!(
            "SELECT case_id FROM sweep_cases WHERE sweep_id IN ({sweep_list})
             UNION SELECT id FROM cases WHERE sweep_id IN ({sweep_list})"
        ),
    )
    .map_err(&serr)?;
    let cases: BTreeSet<i64> = ids(
        src,
        &format!(
            "SELECT id FROM cases WHERE status IN ('done', 'failed') AND id IN ({})",
            list(&linked)
        ),
    )
    .map_err(&serr)?;
    let case_list = list(&cases);
    // the sweeps' current cases not finished: listed, without results
    let open: BTreeSet<i64> = ids(
        src,
        &format!(
            "SELECT case_id FROM sweep_cases WHERE sweep_id IN ({sweep_list})
             AND case_id NOT IN ({case_list})"
        ),
    )
    .map_err(&serr)?;
    let open_list = list(&open);
    let run_ids = ids(
        src,
        &format!(
            "SELECT DISTINCT run_id FROM cases WHERE id IN ({case_list}) AND run_id IS NOT NULL"
        ),
    )
    .map_err(&serr)?;
    // the sweeps that registered a case first, or whose run ran it, are referenced by its row
    let mut sweep_ids = chosen.clone();
    for sql in [
        format!("SELECT DISTINCT sweep_id FROM cases WHERE id IN ({case_list})"),
        format!("SELECT DISTINCT sweep_id FROM cases WHERE id IN ({open_list})"),
        format!(
            "SELECT DISTINCT sweep_id FROM runs WHERE id IN ({})",
            list(&run_ids)
        ),
    ] {
        sweep_ids.extend(ids(src, &sql).map_err(&serr)?);
    }
    let tx = dest.conn.transaction().map_err(&derr)?;
    let copy = |table: &str, filter: &str| {
        copy_rows(src, &tx, table, filter).map_err(|e| StoreError::Sql {
            path: tmp.to_path_buf(),
            source: e,
        })
    };
    copy("sweeps", &format!("id IN ({})", list(&sweep_ids)))?;
    copy("runs", &format!("id IN ({})", list(&run_ids)))?;
    copy("cases", &format!("id IN ({case_list})"))?;
    copy(
        "sweep_cases",
        &format!("sweep_id IN ({sweep_list}) AND case_id IN ({case_list})"),
    )?;
    copy("cases", &format!("id IN ({open_list})"))?;
    copy(
        "sweep_cases",
        &format!("sweep_id IN ({sweep_list}) AND case_id IN ({open_list})"),
    )?;
    tx.execute(
        &format!(
            "UPDATE cases SET status = 'pending', owner = NULL, owner_pid = NULL, run_id = NULL,
             started_at = NULL, finished_at = NULL, wall_s = NULL, steps = NULL, t_reached = NULL
             WHERE id IN ({open_list})"
        ),
        [],
    )
    .map_err(&derr)?;
    copy("outcomes", &format!("case_id IN ({case_list})"))?;
    let (mut samples_in, mut samples_out) = (0, 0);
    for &case in &cases {
        let steps = sample_steps(src, case).map_err(&serr)?;
        samples_in += src
            .query_row(
                "SELECT COUNT(*) FROM samples WHERE case_id = ?1",
                [case],
                |r| r.get::<_, i64>(0),
            )
            .map_err(&serr)? as usize;
        let filter = match max_samples {
            Some(n) if steps.len() > n => {
                let kept: BTreeSet<i64> = thin(&steps, n).into_iter().collect();
                format!("case_id = {case} AND step IN ({})", list(&kept))
            }
            _ => format!("case_id = {case}"),
        };
        samples_out += copy("samples", &filter)?;
    }
    let unfinished = open.len();
    tx.commit().map_err(&derr)?;
    dest.conn.execute_batch("VACUUM").map_err(&derr)?;
    Ok(Exported {
        sweeps: sweep_ids.len(),
        cases: cases.len(),
        unfinished,
        samples_in,
        samples_out,
        bytes: 0,
    })
}

/// The integer column of a query's rows.
fn ids(conn: &Connection, sql: &str) -> rusqlite::Result<BTreeSet<i64>> {
    let mut st = conn.prepare(sql)?;
    let rows = st.query_map([], |r| r.get(0))?;
    rows.collect()
}

/// The sampled steps of a case with their times, in order.
fn sample_steps(conn: &Connection, case: i64) -> rusqlite::Result<Vec<(i64, f64)>> {
    let mut st = conn.prepare(
        "SELECT step, MIN(t) FROM samples WHERE case_id = ?1 GROUP BY step ORDER BY step",
    )?;
    let rows = st.query_map([case], |r| Ok((r.get(0)?, r.get(1)?)))?;
    rows.collect()
}

/// At most `n` (≥ 2) of the steps, evenly spread in time: the first, the last, and between them
/// a step whenever the time has advanced by (t_last − t_first)/(n − 1) since the last one kept.
pub fn thin(steps: &[(i64, f64)], n: usize) -> Vec<i64> {
    if steps.len() <= n {
        return steps.iter().map(|s| s.0).collect();
    }
    let (first, last) = (steps[0], steps[steps.len() - 1]);
    let spacing = (last.1 - first.1) / (n - 1) as f64;
    let mut kept = vec![first.0];
    let mut next = first.1 + spacing;
    for &(step, t) in &steps[1..steps.len() - 1] {
        // room is left for the last step
        if t >= next && kept.len() < n - 1 {
            kept.push(step);
            next = t + spacing;
        }
    }
    kept.push(last.0);
    kept
}

/// Copies the rows of `table` matching `filter` from `src` into `dst`, by the columns both have.
/// Returns the number of rows copied.
fn copy_rows(
    src: &Connection,
    dst: &Connection,
    table: &str,
    filter: &str,
) -> rusqlite::Result<usize> {
    let columns = |conn: &Connection| -> rusqlite::Result<Vec<String>> {
        let mut st = conn.prepare("SELECT name FROM pragma_table_info(?1) ORDER BY cid")?;
        let rows = st.query_map([table], |r| r.get(0))?;
        rows.collect()
    };
    let theirs = columns(src)?;
    let common: Vec<String> = columns(dst)?
        .into_iter()
        .filter(|c| theirs.contains(c))
        .collect();
    let names = common.join(", ");
    let marks = vec!["?"; common.len()].join(", ");
    let mut read = src.prepare(&format!("SELECT {names} FROM {table} WHERE {filter}"))?;
    let mut write = dst.prepare(&format!("INSERT INTO {table} ({names}) VALUES ({marks})"))?;
    let mut rows = read.query([])?;
    let mut n = 0;
    while let Some(row) = rows.next()? {
        let values: Vec<Value> = (0..common.len())
            .map(|i| row.get(i))
            .collect::<rusqlite::Result<_>>()?;
        write.execute(params_from_iter(values))?;
        n += 1;
    }
    Ok(n)
}

#[cfg(test)]
mod tests {
    use super::thin;

    /// Thinning keeps the first and the last step, at most n in all, spread by time (not by
    /// step: adaptive steps sample short intervals densely).
    #[test]
    fn thinning_spreads_the_kept_steps_in_time() {
        // 1000 steps: dense (Δt 0.01) up to t = 5, then Δt 0.1 up to t = 55
        let mut steps: Vec<(i64, f64)> = (0..500).map(|i| (i, 0.01 * i as f64)).collect();
        steps.extend((0..500).map(|i| (500 + i, 5.0 + 0.1 * i as f64)));
        for n in [2, 3, 11, 100] {
            let kept = thin(&steps, n);
            assert!(
                kept.len() <= n && kept.len() >= n.min(2),
                "{n}: {}",
                kept.len()
            );
            assert_eq!((kept[0], *kept.last().unwrap()), (0, 999));
            assert!(kept.windows(2).all(|w| w[0] < w[1]));
        }
        // 11 kept over t in [0, 54.9]: spacing 5.49, so about one in the dense first 5 time units
        let kept = thin(&steps, 11);
        let early = kept.iter().filter(|&&s| s < 500).count();
        assert!(early <= 2, "{kept:?}");
        assert!(kept.len() >= 9, "{kept:?}");
        assert_eq!(
            thin(&steps[..7], 11).len(),
            7,
            "short trajectories are kept whole"
        );
    }
}
