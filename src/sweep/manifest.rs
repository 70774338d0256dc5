//! A manifest: the cases of one submission, one case id per line, line k (counting from 0, after
//! the `#` header) being the case of array index k; the header names the sweep file the ids come
//! from (a copy beside the manifest, so that editing the original does not change queued tasks):
//!
//! ```text
//! # xpflow manifest: line k after this header is the case of array index k
//! # sweep: sweep.toml
//! 3f2a9c0d1b4e5f60
//! …
//! ```

use std::path::{Path, PathBuf};

/// The header line naming the sweep file.
const SWEEP_PREFIX: &str = "# sweep: ";

/// A manifest's cases and its sweep file.
#[derive(Debug, Clone, PartialEq)]
pub struct Manifest {
    /// The manifest file.
    pub path: PathBuf,
    /// The sweep file (as written in the header, relative to the manifest's directory).
    pub sweep: PathBuf,
    /// Case ids, by index.
    pub cases: Vec<String>,
}

/// A manifest that cannot be read or used.
#[derive(Debug, thiserror::Error)]
#[error("manifest {}: {message}", path.display())]
pub struct ManifestError {
    /// The manifest file.
    pub path: PathBuf,
    /// What is wrong (with the line or index).
    pub message: String,
}

impl Manifest {
    /// Writes a manifest of `cases` from the sweep file `sweep` (relative to `path`'s directory).
    ///
    /// # Errors
    /// The I/O error.
    pub fn write(path: &Path, sweep: &Path, cases: &[String]) -> std::io::Result<Manifest> {
        let mut text = format!(
            "# xpflow manifest: line k after this header is the case of array index k\n\
             {SWEEP_PREFIX}{}\n",
            sweep.display()
        );
        for c in cases {
            text += c;
            text.push('\n');
        }
        std::fs::write(path, text)?;
        Ok(Manifest {
            path: path.to_path_buf(),
            sweep: sweep.to_path_buf(),
            cases: cases.to_vec(),
        })
    }

    /// Reads the manifest at `path`.
    ///
    /// # Errors
    /// [`ManifestError`] naming the file and line: unreadable, no `# sweep:` header, a line that
    /// is not a case id (16 hexadecimal digits).
    pub fn read(path: &Path) -> Result<Manifest, ManifestError> {
        let fail = |message: String| ManifestError {
            path: path.to_path_buf(),
            message,
        };
        let text = std::fs::read_to_string(path).map_err(|e| fail(e.to_string()))?;
        let mut sweep = None;
        let mut cases = Vec::new();
        for (n, line) in text.lines().enumerate() {
            let line = line.trim();
            if let Some(file) = line.strip_prefix(SWEEP_PREFIX) {
                sweep = Some(PathBuf::from(file.trim()));
            } else if line.starts_with('#') || line.is_empty() {
                continue;
            } else if line.len() == 16 && line.chars().all(|c| c.is_ascii_hexdigit()) {
                cases.push(line.to_string());
            } else {
                return Err(fail(format!(
                    "line {}: `{line}` is not a case id (16 hexadecimal digits)",
                    n + 1
                )));
            }
        }
        let sweep = sweep.ok_or_else(|| fail(format!("no `{SWEEP_PREFIX}FILE` line")))?;
        Ok(Manifest {
            path: path.to_path_buf(),
            sweep,
            cases,
        })
    }

    /// The sweep file, resolved against the manifest's directory.
    pub fn sweep_file(&self) -> PathBuf {
        self.path
            .parent()
            .unwrap_or_else(|| Path::new("."))
            .join(&self.sweep)
    }

    /// The case id of array index `index`.
    ///
    /// # Errors
    /// [`ManifestError`] when the index is beyond the manifest.
    pub fn case(&self, index: usize) -> Result<&str, ManifestError> {
        self.cases
            .get(index)
            .map(String::as_str)
            .ok_or_else(|| ManifestError {
                path: self.path.clone(),
                message: format!(
                    "index {index} is beyond its {} cases (0 to {})",
                    self.cases.len(),
                    self.cases.len().saturating_sub(1)
                ),
            })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A written manifest reads back; a bad line and an index past the end are named.
    #[test]
    fn manifests_round_trip_and_name_their_errors() {
        let dir = std::env::temp_dir().join(format!("xpflow-manifest-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("manifest.txt");
        let ids = vec!["0123456789abcdef".to_string(), "fedcba9876543210".into()];
        let written = Manifest::write(&path, Path::new("sweep.toml"), &ids).unwrap();
        let read = Manifest::read(&path).unwrap();
        assert_eq!(read, written);
        assert_eq!(read.case(1).unwrap(), "fedcba9876543210");
        assert_eq!(read.sweep_file(), dir.join("sweep.toml"));
        let e = read.case(2).unwrap_err().to_string();
        assert!(e.contains("manifest.txt") && e.contains("index 2"), "{e}");
        std::fs::write(&path, "# sweep: s.toml\n0123456789abcdef\nnot-an-id\n").unwrap();
        let e = Manifest::read(&path).unwrap_err().to_string();
        assert!(e.contains("line 3") && e.contains("not-an-id"), "{e}");
        std::fs::remove_dir_all(&dir).ok();
    }
}
