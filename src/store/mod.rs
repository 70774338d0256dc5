//! Results store: SQLite tables and HDF5 field snapshots.
//!
//! One SQLite file per results set, in WAL mode with a busy timeout so that several sweeps (processes or
//! threads, each with its own connection) can write to it at once. Schema in [`schema`]; writes in
//! [`cases`]; the thesis-style tables in [`query`]; HDF5 snapshots with an XDMF sidecar in [`snapshot`].
//! On a cluster each task writes a [`shard`] of its own (rollback journal, local disk, published by
//! an atomic rename), and [`merge`] folds the shards into the sweep's database.
//! All SQL uses bound parameters. Write transactions are `BEGIN IMMEDIATE`, so a writer waits for the lock
//! up front instead of failing to upgrade a read lock.

pub mod cases;
pub mod export;
pub mod merge;
mod open;
mod outcomes;
pub mod query;
pub mod schema;
pub mod shard;
pub mod snapshot;
pub mod status;
pub mod table;

use std::path::{Path, PathBuf};
use std::time::Duration;

use rusqlite::{params, Connection, OptionalExtension, TransactionBehavior};

pub use cases::{CaseRecord, Claim, ClaimResult};
pub use outcomes::StoredOutcome;
pub use status::{FailedCase, RunningCase, SweepCounts};
pub use table::{Format, Table};

/// How long a connection waits for another writer before giving up: a finished case's transaction takes
/// milliseconds, so a minute means something is wrong.
const BUSY_TIMEOUT: Duration = Duration::from_secs(60);

/// Store errors.
#[derive(Debug, thiserror::Error)]
pub enum StoreError {
    /// SQLite failed.
    #[error("database {}: {source}", path.display())]
    Sql {
        /// Database file.
        path: PathBuf,
        /// The SQLite error.
        source: rusqlite::Error,
    },
    /// The database was written by a newer xpflow.
    #[error("database {} has schema version {found}, newer than this xpflow's {supported}; use a newer xpflow", path.display())]
    NewerSchema {
        /// Database file.
        path: PathBuf,
        /// Version in the file.
        found: i64,
        /// Version this code writes.
        supported: i64,
    },
    /// File-system error (database directory, snapshot files).
    #[error("{}: {source}", path.display())]
    Io {
        /// The path.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// HDF5 failed.
    #[error("HDF5 file {}: {message}", path.display())]
    Hdf5 {
        /// The file.
        path: PathBuf,
        /// The library's message.
        message: String,
    },
    /// A query asked for something that does not exist (unknown column, unknown sweep, ...).
    #[error("{0}")]
    BadQuery(String),
    /// The database file does not exist (readers never create one).
    #[error("database {} does not exist", path.display())]
    Missing {
        /// The path given.
        path: PathBuf,
    },
    /// The file is not an SQLite database.
    #[error("{} is not an SQLite database (not an xpflow results database); give another --db", path.display())]
    NotDatabase {
        /// The file.
        path: PathBuf,
    },
    /// An SQLite database without xpflow's tables.
    #[error("{} is an SQLite database but not an xpflow results database (it has {tables} and no \
             schema_version table); give another --db", path.display())]
    Foreign {
        /// The file.
        path: PathBuf,
        /// The tables it has, comma-separated.
        tables: String,
    },
    /// The database was deleted or replaced while a sweep wrote to it: what it was writing is lost.
    #[error("database {} was deleted or replaced while the sweep ran ({what}); results written \
             since are lost: rerun the sweep", path.display())]
    Vanished {
        /// The database file.
        path: PathBuf,
        /// What was found.
        what: String,
    },
}

impl StoreError {
    /// Whether the error is the user's input (a database that is missing, not xpflow's or newer,
    /// a bad query) rather than a failure at run time: the CLI exits with code 2 for these.
    pub fn is_bad_input(&self) -> bool {
        matches!(
            self,
            StoreError::BadQuery(_)
                | StoreError::Missing { .. }
                | StoreError::NotDatabase { .. }
                | StoreError::Foreign { .. }
                | StoreError::NewerSchema { .. }
        )
    }
}

/// Result alias for the store.
pub type Result<T> = std::result::Result<T, StoreError>;

/// Code version recorded with results: the crate version plus `XPFLOW_GIT_DESCRIBE` if set at build time.
pub fn code_version() -> String {
    match option_env!("XPFLOW_GIT_DESCRIBE") {
        Some(git) => format!("{} ({git})", env!("CARGO_PKG_VERSION")),
        None => env!("CARGO_PKG_VERSION").to_string(),
    }
}

/// Host name, as used for case ownership.
pub fn hostname() -> String {
    std::fs::read_to_string("/proc/sys/kernel/hostname")
        .or_else(|_| std::fs::read_to_string("/etc/hostname"))
        .map(|s| s.trim().to_string())
        .unwrap_or_else(|_| "unknown-host".into())
}

/// Machine description recorded with results: host, OS, architecture, available cores.
pub fn machine() -> String {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    format!(
        "{} {}-{} {} cores",
        hostname(),
        std::env::consts::OS,
        std::env::consts::ARCH,
        cores
    )
}

/// Whether an SQLite error is SQLITE_BUSY.
fn is_busy(e: &rusqlite::Error) -> bool {
    matches!(e, rusqlite::Error::SqliteFailure(f, _) if f.code == rusqlite::ErrorCode::DatabaseBusy)
}

/// Retries `f` while its error is SQLITE_BUSY (`busy` tells), for up to [`BUSY_TIMEOUT`]: for
/// the statements SQLite answers with BUSY without waiting (the journal-mode switch and the
/// schema set-up of a database that another connection is creating at the same moment).
fn retry_busy<T, E>(
    busy: impl Fn(&E) -> bool,
    mut f: impl FnMut() -> std::result::Result<T, E>,
) -> std::result::Result<T, E> {
    let deadline = std::time::Instant::now() + BUSY_TIMEOUT;
    loop {
        match f() {
            Err(e) if busy(&e) && std::time::Instant::now() < deadline => {
                std::thread::sleep(Duration::from_millis(10))
            }
            r => return r,
        }
    }
}

/// A connection to a results database. Not shared between threads: open one per thread.
///
/// Three ways to open one ([`open`](Store::open) for the process that starts a sweep,
/// [`open_existing`](Store::open_existing) for its workers, [`open_read_only`](Store::open_read_only)
/// for readers); all refuse a file that is not SQLite or an SQLite database of another program.
pub struct Store {
    conn: Connection,
    path: PathBuf,
    /// Device and inode of the file when it was opened: a file deleted or replaced since is
    /// noticed before a result is committed to it ([`Store::check_still_there`]).
    identity: Option<(u64, u64)>,
}

impl Store {
    /// The database file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The raw connection, for ad-hoc reads (tests, tools).
    pub fn connection(&self) -> &Connection {
        &self.conn
    }

    /// Wraps an SQLite error with this database's path (owns a copy of the path, so it can be held
    /// across mutable uses of the connection).
    /// An error of a file deleted or replaced under the connection (SQLite reports a disk I/O
    /// error when its file is gone mid-write) is [`StoreError::Vanished`].
    pub(crate) fn sql_err(&self) -> impl Fn(rusqlite::Error) -> StoreError {
        let (path, opened) = (self.path.clone(), self.identity);
        move |source| {
            let gone = opened.and_then(|opened| match open::identity(&path) {
                None => Some("the file is gone"),
                Some(now) if now != opened => Some("another file is at its path now"),
                Some(_) => None,
            });
            match gone {
                Some(what) => StoreError::Vanished {
                    path: path.clone(),
                    what: format!("{what}; SQLite: {source}"),
                },
                None => StoreError::Sql {
                    path: path.clone(),
                    source,
                },
            }
        }
    }

    fn migrate(&mut self) -> Result<()> {
        let path = self.path.clone();
        let sql = |source| StoreError::Sql {
            path: path.clone(),
            source,
        };
        let tx = self
            .conn
            .transaction_with_behavior(TransactionBehavior::Immediate)
            .map_err(sql)?;
        tx.execute_batch(schema::CREATE).map_err(sql)?;
        let found: Option<i64> = tx
            .query_row("SELECT MAX(version) FROM schema_version", [], |r| r.get(0))
            .optional()
            .map_err(sql)?
            .flatten();
        match found {
            None => {
                tx.execute(
                    "INSERT INTO schema_version (version) VALUES (?1)",
                    params![schema::SCHEMA_VERSION],
                )
                .map_err(sql)?;
            }
            Some(v) if v > schema::SCHEMA_VERSION => {
                return Err(StoreError::NewerSchema {
                    path,
                    found: v,
                    supported: schema::SCHEMA_VERSION,
                });
            }
            Some(v) => {
                for (i, m) in schema::MIGRATIONS.iter().enumerate().skip((v - 1) as usize) {
                    tx.execute_batch(m).map_err(sql)?;
                    tx.execute(
                        "UPDATE schema_version SET version = ?1",
                        params![i as i64 + 2],
                    )
                    .map_err(sql)?;
                }
            }
        }
        for (k, v) in [("code_version", code_version()), ("machine", machine())] {
            tx.execute(
                "INSERT OR IGNORE INTO meta (key, value) VALUES (?1, ?2)",
                params![format!("created_{k}"), v],
            )
            .map_err(sql)?;
            tx.execute(
                "INSERT OR REPLACE INTO meta (key, value) VALUES (?1, ?2)",
                params![format!("last_{k}"), v],
            )
            .map_err(sql)?;
        }
        tx.commit().map_err(sql)
    }

    /// `PRAGMA integrity_check` result (`"ok"` when healthy).
    pub fn integrity_check(&self) -> Result<String> {
        self.conn
            .query_row("PRAGMA integrity_check", [], |r| r.get(0))
            .map_err(self.sql_err())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A version-1 database (no `cases.settings_json`, no `samples.separation`, the outcome kinds
    /// before extrusion) is migrated on open: the columns are there, an extrusion's outcome kind
    /// is admitted, the views read the new outcomes table, and the version is the current one.
    #[test]
    fn a_version_1_database_gains_the_settings_column() {
        let dir = std::env::temp_dir().join(format!("xpflow-migrate-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("v1.db");
        std::fs::remove_file(&path).ok();
        {
            let conn = Connection::open(&path).unwrap();
            let v1 = schema::CREATE
                .replace(",\n    settings_json TEXT", "")
                .replace(" separation REAL,", "")
                .replace(
                    "'wall_contact',\n                                        'surface_contact', 'exited', 'migrated', 'steady',",
                    "'wall_contact', 'migrated', 'steady',",
                );
            assert!(
                !v1.contains("settings_json")
                    && !v1.contains("separation")
                    && !v1.contains("exited"),
                "the v1 schema lacks the columns and kinds"
            );
            conn.execute_batch(&v1).unwrap();
            conn.execute("INSERT INTO schema_version (version) VALUES (1)", [])
                .unwrap();
        }
        let store = Store::open(&path).unwrap();
        let version: i64 = store
            .connection()
            .query_row("SELECT MAX(version) FROM schema_version", [], |r| r.get(0))
            .unwrap();
        assert_eq!(version, schema::SCHEMA_VERSION);
        let has_column: i64 = store
            .connection()
            .query_row(
                "SELECT COUNT(*) FROM pragma_table_info('cases') WHERE name = 'settings_json'",
                [],
                |r| r.get(0),
            )
            .unwrap();
        assert_eq!(has_column, 1);
        let conn = store.connection();
        let separation: i64 = conn
            .query_row(
                "SELECT COUNT(*) FROM pragma_table_info('samples') WHERE name = 'separation'",
                [],
                |r| r.get(0),
            )
            .unwrap();
        assert_eq!(separation, 1);
        conn.execute_batch(
            "INSERT INTO sweeps (name, spec_json, code_version, machine) VALUES ('s', '{}', 'v', 'm');
             INSERT INTO cases (sweep_id, case_hash, label, geometry, params_json)
                 VALUES (1, 'h', 'l', 'extrusion', '{}');
             INSERT INTO outcomes (case_id, kind, final_json) VALUES (1, 'exited', '{}');",
        )
        .unwrap();
        let kind: String = conn
            .query_row("SELECT kind FROM case_outcomes", [], |r| r.get(0))
            .unwrap();
        assert_eq!(kind, "exited");
        std::fs::remove_dir_all(&dir).ok();
    }
}
