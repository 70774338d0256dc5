//! Helpers shared by the integration tests.

use std::ops::Deref;
use std::path::{Path, PathBuf};

/// A scratch directory under the system's temporary directory, emptied when created and removed
/// when dropped — unless the test is failing, so that its files can be inspected.
pub struct Scratch(PathBuf);

impl Scratch {
    /// `<tmp>/xpflow-<prefix>-<name>-<pid>`, created empty.
    pub fn new(prefix: &str, name: &str) -> Scratch {
        let d = std::env::temp_dir().join(format!("xpflow-{prefix}-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        Scratch(d)
    }
}

impl Deref for Scratch {
    type Target = Path;
    fn deref(&self) -> &Path {
        &self.0
    }
}

impl AsRef<Path> for Scratch {
    fn as_ref(&self) -> &Path {
        &self.0
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        if std::thread::panicking() {
            eprintln!("scratch directory kept: {}", self.0.display());
        } else {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }
}

/// The sweep command's arguments for `file` into `db`: two jobs, quiet, no limits beyond the
/// defaults (tests change fields with struct update syntax).
#[allow(dead_code)] // not every test binary runs sweeps
pub fn sweep_args(file: &Path, db: &Path) -> xpflow::cli::sweep_cmds::SweepArgs {
    xpflow::cli::sweep_cmds::SweepArgs {
        file: file.into(),
        db: Some(db.into()),
        jobs: Some(2),
        dry_run: false,
        resolved: false,
        quiet: true,
        retry_failed: false,
        state_every: 5.0,
        max_memory: None,
        max_cases: xpflow::sweep::expand::DEFAULT_MAX_CASES,
        slurm: Default::default(),
    }
}
