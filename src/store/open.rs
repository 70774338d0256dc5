//! Opening a results database: for the process that starts a sweep (creating it if needed and
//! bringing the schema up to date), for its workers (the file must exist and be xpflow's: a
//! database deleted while the sweep runs is an error, never a new empty file), and for readers
//! (`query`, `status`: read-only, no `meta` rewrite, nothing created). Every way refuses a file
//! that is not SQLite, or an SQLite database of another program.

use std::path::Path;

use rusqlite::{Connection, OpenFlags};

use super::{is_busy, retry_busy, schema, Result, Store, StoreError, BUSY_TIMEOUT};

/// Device and inode of a file (what tells a file from a new one at the same path).
pub(super) fn identity(path: &Path) -> Option<(u64, u64)> {
    use std::os::unix::fs::MetadataExt;
    std::fs::metadata(path).ok().map(|m| (m.dev(), m.ino()))
}

/// The path as the user can find it: absolute (relative to the working directory) when possible.
pub(super) fn full_path(path: &Path) -> std::path::PathBuf {
    std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf())
}

/// How the tables of an opened file look.
enum Kind {
    /// No tables: a new file.
    Empty,
    /// An xpflow database of this or an older schema version.
    Xpflow,
}

/// Checks that `conn` is an SQLite database that is empty or xpflow's.
fn kind(conn: &Connection, path: &Path) -> Result<Kind> {
    let tables: std::result::Result<Vec<String>, rusqlite::Error> = conn
        .prepare("SELECT name FROM sqlite_master WHERE type = 'table' ORDER BY name")
        .and_then(|mut st| {
            st.query_map([], |r| r.get(0))?
                .collect::<rusqlite::Result<Vec<String>>>()
        });
    let tables = match tables {
        Ok(t) => t,
        Err(rusqlite::Error::SqliteFailure(f, _))
            if f.code == rusqlite::ErrorCode::NotADatabase =>
        {
            return Err(StoreError::NotDatabase {
                path: path.to_path_buf(),
            })
        }
        Err(source) => {
            return Err(StoreError::Sql {
                path: path.to_path_buf(),
                source,
            })
        }
    };
    if tables.is_empty() {
        return Ok(Kind::Empty);
    }
    if !tables.iter().any(|t| t == "schema_version") {
        return Err(StoreError::Foreign {
            path: path.to_path_buf(),
            tables: format!("tables {}", tables.join(", ")),
        });
    }
    let version: Option<i64> = conn
        .query_row("SELECT MAX(version) FROM schema_version", [], |r| r.get(0))
        .map_err(|source| StoreError::Sql {
            path: path.to_path_buf(),
            source,
        })?;
    match version {
        Some(v) if v > schema::SCHEMA_VERSION => Err(StoreError::NewerSchema {
            path: path.to_path_buf(),
            found: v,
            supported: schema::SCHEMA_VERSION,
        }),
        Some(_) => Ok(Kind::Xpflow),
        // created by a process that died before its first commit: as good as new
        None => Ok(Kind::Empty),
    }
}

/// The WAL file of a database in WAL mode (exists while a connection has it open).
fn wal_path(path: &Path) -> std::path::PathBuf {
    let mut name = path.as_os_str().to_owned();
    name.push("-wal");
    name.into()
}

/// An SQLite URI opening `path` read-only and immutable (no locks, no -wal/-shm files).
pub(super) fn immutable_uri(path: &Path) -> String {
    let full = full_path(path).to_string_lossy().into_owned();
    // the characters a URI path must escape
    let escaped = full
        .replace('%', "%25")
        .replace('?', "%3f")
        .replace('#', "%23");
    format!("file:{escaped}?mode=ro&immutable=1")
}

impl Store {
    /// Opens (creating if needed) the database at `path`, switches it to WAL mode and brings the
    /// schema up to [`schema::SCHEMA_VERSION`]: for the process that starts a sweep.
    ///
    /// # Errors
    /// [`StoreError::NotDatabase`] / [`StoreError::Foreign`] for a file that is not an xpflow
    /// database, [`StoreError::Io`] (with the full path) when its directory cannot be made.
    pub fn open(path: &Path) -> Result<Store> {
        Store::open_journal(path, "WAL")
    }

    /// Opens (creating if needed) `path` as [`open`](Store::open) does, in the journal `mode`
    /// (`WAL` for a sweep's database, `DELETE` for a shard: [`Store::open_shard`]).
    pub(super) fn open_journal(path: &Path, journal: &str) -> Result<Store> {
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(|source| StoreError::Io {
                path: full_path(dir),
                source,
            })?;
        }
        let sql = |source| StoreError::Sql {
            path: path.to_path_buf(),
            source,
        };
        let conn = Connection::open(path).map_err(sql)?;
        conn.busy_timeout(BUSY_TIMEOUT).map_err(sql)?;
        retry_busy(
            |e: &StoreError| matches!(e, StoreError::Sql { source, .. } if is_busy(source)),
            || kind(&conn, path),
        )?;
        // switching a new file to WAL needs an exclusive lock and may return SQLITE_BUSY at
        // once, without the busy handler, while another process creates the same database
        let mode: String = retry_busy(is_busy, || {
            conn.query_row(&format!("PRAGMA journal_mode = {journal}"), [], |r| {
                r.get(0)
            })
        })
        .map_err(sql)?;
        debug_assert!(mode.eq_ignore_ascii_case(journal) || path.as_os_str() == ":memory:");
        let mut store = Store::configure(conn, path)?;
        let busy = |e: &StoreError| matches!(e, StoreError::Sql { source, .. } if is_busy(source));
        retry_busy(busy, || store.migrate())?;
        Ok(store)
    }

    /// Opens the existing xpflow database at `path` for writing, creating nothing: for the
    /// workers of a sweep whose first [`open`](Store::open) made the schema.
    ///
    /// # Errors
    /// [`StoreError::Vanished`] if the file is gone or no longer holds xpflow's tables (deleted
    /// or replaced during the sweep), and the errors of [`open`](Store::open).
    pub fn open_existing(path: &Path) -> Result<Store> {
        let vanished = |what: &str| StoreError::Vanished {
            path: path.to_path_buf(),
            what: what.to_string(),
        };
        if !path.exists() {
            return Err(vanished("the file is gone"));
        }
        let flags = OpenFlags::SQLITE_OPEN_READ_WRITE | OpenFlags::SQLITE_OPEN_NO_MUTEX;
        let conn = Connection::open_with_flags(path, flags).map_err(|source| {
            if path.exists() {
                StoreError::Sql {
                    path: path.to_path_buf(),
                    source,
                }
            } else {
                vanished("the file is gone")
            }
        })?;
        conn.busy_timeout(BUSY_TIMEOUT)
            .map_err(|source| StoreError::Sql {
                path: path.to_path_buf(),
                source,
            })?;
        // deleted between the check above and the reads and settings below: SQLite reports an
        // I/O error, which is the vanished file
        let gone_meanwhile = |e: StoreError| {
            if path.exists() {
                e
            } else {
                vanished("the file is gone")
            }
        };
        match kind(&conn, path).map_err(gone_meanwhile)? {
            Kind::Xpflow => Store::configure(conn, path).map_err(gone_meanwhile),
            Kind::Empty => Err(vanished("the file no longer holds xpflow's tables")),
        }
    }

    /// Opens the xpflow database at `path` read-only: for `query`, `status` and other readers,
    /// which never write (no `meta` update, no schema set-up, nothing created), so they work on a
    /// read-only file or share too.
    ///
    /// # Errors
    /// [`StoreError::Missing`] if there is no file, [`StoreError::NotDatabase`] /
    /// [`StoreError::Foreign`] if it is not an xpflow database (an empty SQLite file included),
    /// [`StoreError::NewerSchema`].
    pub fn open_read_only(path: &Path) -> Result<Store> {
        if !path.is_file() {
            return Err(StoreError::Missing {
                path: path.to_path_buf(),
            });
        }
        let sql = |source| StoreError::Sql {
            path: path.to_path_buf(),
            source,
        };
        let flags = OpenFlags::SQLITE_OPEN_READ_ONLY | OpenFlags::SQLITE_OPEN_NO_MUTEX;
        let conn = if wal_path(path).exists() {
            // a writer has the database open (or was killed): read through its WAL index
            Connection::open_with_flags(path, flags)
        } else {
            // no writer has it open: read the file as it is, so that a reader never creates the
            // -wal and -shm files (on a read-only share it could not; elsewhere they would stay,
            // owned by the reader). A sweep that starts during the read would have to checkpoint
            // into the file within the query's milliseconds to disturb it.
            Connection::open_with_flags(immutable_uri(path), flags | OpenFlags::SQLITE_OPEN_URI)
        }
        .map_err(sql)?;
        conn.busy_timeout(BUSY_TIMEOUT).map_err(sql)?;
        match kind(&conn, path)? {
            Kind::Xpflow => Ok(Store {
                conn,
                path: path.to_path_buf(),
                identity: identity(path),
            }),
            Kind::Empty => Err(StoreError::Foreign {
                path: path.to_path_buf(),
                tables: "no tables".into(),
            }),
        }
    }

    /// The connection settings of a writer.
    fn configure(conn: Connection, path: &Path) -> Result<Store> {
        let sql = |source| StoreError::Sql {
            path: path.to_path_buf(),
            source,
        };
        conn.pragma_update(None, "synchronous", "NORMAL")
            .map_err(sql)?;
        conn.pragma_update(None, "foreign_keys", "ON")
            .map_err(sql)?;
        Ok(Store {
            conn,
            path: path.to_path_buf(),
            identity: identity(path),
        })
    }

    /// Checks that the file this connection writes to is still the one at its path: a database
    /// deleted (or replaced by another file) during a sweep would otherwise take every result
    /// written since with it, silently.
    ///
    /// # Errors
    /// [`StoreError::Vanished`] saying which.
    pub fn check_still_there(&self) -> Result<()> {
        let Some(opened) = self.identity else {
            return Ok(());
        };
        let what = match identity(&self.path) {
            None => "the file is gone",
            Some(now) if now != opened => "another file is at its path now",
            Some(_) => return Ok(()),
        };
        Err(StoreError::Vanished {
            path: self.path.clone(),
            what: what.into(),
        })
    }
}
