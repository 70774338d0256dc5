//! Shards: the results database of the case one cluster task runs, never shared between nodes.
//!
//! A task writes its shard on local disk (`$TMPDIR`) with a rollback journal (one file, no `-wal`
//! / `-shm`: SQLite's WAL needs shared memory that a network file system does not give), and
//! publishes it into the shared shard directory: a consistent copy (`VACUUM INTO`) under a
//! temporary name, synced, then renamed over the published file, so that a reader sees the old
//! shard or the new one, never half of one. Its saved solver states are published beside it the
//! same way, after the database (a state never refers to samples the published database lacks).
//! A resubmitted task [`restore`]s both and continues the case. Each publication carries an id
//! (`meta.published`) by which `xpflow merge` ([`super::merge`]) knows what it merged.

use std::path::{Path, PathBuf};

use rusqlite::params;

use super::{hostname, Result, Store, StoreError};

/// The `meta` key of a shard's publication id.
pub const PUBLISHED_KEY: &str = "published";

fn io(path: &Path) -> impl Fn(std::io::Error) -> StoreError + '_ {
    move |source| StoreError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// `<dir>/.<name>.<pid>.tmp`: where a file is written before it is renamed to `<dir>/<name>`.
fn temporary(dir: &Path, name: &std::ffi::OsStr) -> PathBuf {
    let mut tmp = std::ffi::OsString::from(".");
    tmp.push(name);
    tmp.push(format!(".{}.tmp", std::process::id()));
    dir.join(tmp)
}

/// Copies `from` to `to` through a temporary file in `to`'s directory, synced, then renamed.
fn copy_atomically(from: &Path, to: &Path) -> Result<()> {
    let dir = to.parent().unwrap_or_else(|| Path::new("."));
    let tmp = temporary(dir, to.file_name().unwrap_or_default());
    std::fs::copy(from, &tmp).map_err(io(from))?;
    std::fs::File::open(&tmp)
        .and_then(|f| f.sync_all())
        .map_err(io(&tmp))?;
    std::fs::rename(&tmp, to).map_err(io(to))
}

/// The `*.resume.json` files of a directory (none if it does not exist).
fn state_files(dir: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .map(|d| {
            d.filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| p.to_string_lossy().ends_with(".resume.json"))
                .collect()
        })
        .unwrap_or_default();
    v.sort();
    v
}

impl Store {
    /// Opens (creating if needed) a shard database at `path`: as [`Store::open`], with a rollback
    /// journal instead of WAL.
    ///
    /// # Errors
    /// Those of [`Store::open`].
    pub fn open_shard(path: &Path) -> Result<Store> {
        Store::open_journal(path, "DELETE")
    }

    /// The publication id of this (shard) database, if it was published.
    pub fn publication(&self) -> Result<Option<String>> {
        use rusqlite::OptionalExtension;
        self.conn
            .query_row(
                "SELECT value FROM meta WHERE key = ?1",
                params![PUBLISHED_KEY],
                |r| r.get(0),
            )
            .optional()
            .map_err(self.sql_err())
    }
}

/// Publishes the shard `store` and the saved states in `states` into `dir`: the database as
/// `dir/<its file name>`, the states as `dir/<states' name>/…`; states published earlier whose
/// case has none any more (it finished) are removed. Each file appears by an atomic rename.
///
/// # Errors
/// [`StoreError::Io`] / [`StoreError::Sql`] naming the file that could not be written.
pub fn publish(store: &Store, states: &Path, dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(io(dir))?;
    let name = store.path().file_name().unwrap_or_default();
    let target = dir.join(name);
    let tmp = temporary(dir, name);
    std::fs::remove_file(&tmp).ok();
    let id = format!(
        "{}:{} {}",
        hostname(),
        std::process::id(),
        std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_nanos())
    );
    let err = store.sql_err();
    store
        .conn
        .execute(
            "INSERT OR REPLACE INTO meta (key, value) VALUES (?1, ?2)",
            params![PUBLISHED_KEY, id],
        )
        .map_err(&err)?;
    store
        .conn
        .execute("VACUUM INTO ?1", params![tmp.to_string_lossy()])
        .map_err(|source| StoreError::Sql {
            path: tmp.clone(),
            source,
        })?;
    std::fs::File::open(&tmp)
        .and_then(|f| f.sync_all())
        .map_err(io(&tmp))?;
    std::fs::rename(&tmp, &target).map_err(io(&target))?;
    // the states after the database that holds their samples
    let published = dir.join(states.file_name().unwrap_or_default());
    let local = state_files(states);
    if !local.is_empty() {
        std::fs::create_dir_all(&published).map_err(io(&published))?;
    }
    for file in &local {
        copy_atomically(file, &published.join(file.file_name().unwrap_or_default()))?;
    }
    for file in state_files(&published) {
        if !local.iter().any(|l| l.file_name() == file.file_name()) {
            std::fs::remove_file(&file).map_err(io(&file))?;
        }
    }
    Ok(())
}

/// Restores the shard published as `dir/<file name of db>` (and its states, `dir/<name of
/// states>/`) into the local `db` and `states`, and releases the claims in it: a shard has one
/// writer, the task of its case, so a case it marks running was left by an earlier task that is
/// gone (killed by a time limit, on whatever node). Returns whether there was a shard to restore.
///
/// # Errors
/// [`StoreError::Io`] when a file cannot be copied, the errors of [`Store::open_shard`].
pub fn restore(dir: &Path, db: &Path, states: &Path) -> Result<bool> {
    let published = dir.join(db.file_name().unwrap_or_default());
    if !published.is_file() {
        return Ok(false);
    }
    if let Some(parent) = db.parent() {
        std::fs::create_dir_all(parent).map_err(io(parent))?;
    }
    copy_atomically(&published, db)?;
    let published_states = dir.join(states.file_name().unwrap_or_default());
    let files = state_files(&published_states);
    if !files.is_empty() {
        std::fs::create_dir_all(states).map_err(io(states))?;
    }
    for file in files {
        copy_atomically(&file, &states.join(file.file_name().unwrap_or_default()))?;
    }
    let store = Store::open_shard(db)?;
    store
        .conn
        .execute(
            "UPDATE cases SET status = 'pending', owner = NULL, owner_pid = NULL
             WHERE status = 'running'",
            [],
        )
        .map_err(store.sql_err())?;
    Ok(true)
}

/// A case as a published shard records it.
#[derive(Debug, Clone, PartialEq)]
pub struct ShardCase {
    /// Case id.
    pub hash: String,
    /// `pending`, `running` (in progress, or its task was killed), `done` or `failed`.
    pub status: String,
    /// The error of a failed case.
    pub error: Option<String>,
}

/// The cases of the published shard `path`, read-only.
///
/// # Errors
/// Those of [`Store::open_read_only`] (a file that is not an xpflow database among them).
pub fn shard_cases(path: &Path) -> Result<Vec<ShardCase>> {
    let store = Store::open_read_only(path)?;
    let err = store.sql_err();
    let mut st = store
        .conn
        .prepare("SELECT case_hash, status, error FROM cases ORDER BY id")
        .map_err(&err)?;
    let rows = st
        .query_map([], |r| {
            Ok(ShardCase {
                hash: r.get(0)?,
                status: r.get(1)?,
                error: r.get(2)?,
            })
        })
        .map_err(&err)?;
    rows.collect::<rusqlite::Result<_>>().map_err(err)
}

/// The shard databases (`*.db`) of a directory, sorted (none if it does not exist).
pub fn shard_files(dir: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .map(|d| {
            d.filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| p.extension().is_some_and(|e| e == "db") && p.is_file())
                .collect()
        })
        .unwrap_or_default();
    v.sort();
    v
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A published shard is one rollback-journal file with a publication id; publishing again
    /// gives a new id; a restored shard has its claims released and its states back.
    #[test]
    fn publish_and_restore_round_trip() {
        let dir = std::env::temp_dir().join(format!("xpflow-shard-{}", std::process::id()));
        std::fs::remove_dir_all(&dir).ok();
        let (local, shared) = (dir.join("local"), dir.join("shared"));
        std::fs::create_dir_all(&local).unwrap();
        let db = local.join("abc.db");
        let states = local.join("abc");
        std::fs::create_dir_all(&states).unwrap();
        std::fs::write(states.join("abc.resume.json"), "{}").unwrap();
        let store = Store::open_shard(&db).unwrap();
        let mode: String = store
            .connection()
            .query_row("PRAGMA journal_mode", [], |r| r.get(0))
            .unwrap();
        assert_eq!(mode, "delete");
        publish(&store, &states, &shared).unwrap();
        let first = Store::open_read_only(&shared.join("abc.db"))
            .unwrap()
            .publication()
            .unwrap()
            .unwrap();
        assert!(shared.join("abc").join("abc.resume.json").is_file());
        assert!(!shared.join("abc.db-wal").exists());
        // the case finished: its state is gone locally, and from the published side too
        std::fs::remove_file(states.join("abc.resume.json")).unwrap();
        publish(&store, &states, &shared).unwrap();
        assert!(!shared.join("abc").join("abc.resume.json").exists());
        let second = Store::open_read_only(&shared.join("abc.db"))
            .unwrap()
            .publication()
            .unwrap()
            .unwrap();
        assert_ne!(first, second);
        let names: Vec<_> = std::fs::read_dir(&shared)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert!(
            names.iter().all(|n| !n.to_string_lossy().ends_with(".tmp")),
            "{names:?}"
        );
        drop(store);
        let again = dir.join("node2");
        assert!(restore(&shared, &again.join("abc.db"), &again.join("abc")).unwrap());
        assert!(!restore(&shared, &again.join("nope.db"), &again.join("nope")).unwrap());
        std::fs::remove_dir_all(&dir).ok();
    }
}
