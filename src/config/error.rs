//! Configuration errors. Every error names the file, the case (index and label) where there is one, and
//! the field path, and says what to change.

use std::path::PathBuf;

/// A problem with one field of a case, before the file and case are known.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("field `{field}`: {message}")]
pub struct SpecError {
    /// Dotted path of the offending field, e.g. `fluid.alpha`.
    pub field: String,
    /// What is wrong and what to change.
    pub message: String,
}

impl SpecError {
    /// Error for `field` with a message saying what to change.
    pub fn new(field: impl Into<String>, message: impl Into<String>) -> Self {
        SpecError {
            field: field.into(),
            message: message.into(),
        }
    }
}

/// Any error reading, parsing or validating a sweep or case file.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    /// The file could not be read.
    #[error("{}: cannot read the file: {source}", file.display())]
    Io {
        /// The file.
        file: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The file is not valid TOML/JSON.
    #[error("{}: malformed {format}: {message}", file.display())]
    Syntax {
        /// The file.
        file: PathBuf,
        /// `TOML` or `JSON`.
        format: &'static str,
        /// The parser's message (with line and column).
        message: String,
    },
    /// The sweep-level structure (name, base, axes, zip groups) is wrong.
    #[error("{}: `{field}`: {message}", file.display())]
    Sweep {
        /// The file.
        file: PathBuf,
        /// Dotted path of the offending sweep-level field.
        field: String,
        /// What is wrong and what to change.
        message: String,
    },
    /// One expanded case is invalid.
    #[error("{}: case {index} ({label}): field `{}`: {}", file.display(), error.field, error.message)]
    Case {
        /// The file.
        file: PathBuf,
        /// 0-based index of the case in the expansion order (as listed by `--dry-run`).
        index: usize,
        /// Case label (axis values), e.g. `wi=2 n=3`.
        label: String,
        /// The field-level error.
        error: SpecError,
    },
}

impl ConfigError {
    /// Dotted field path the error is about, if any.
    pub fn field(&self) -> Option<&str> {
        match self {
            ConfigError::Sweep { field, .. } => Some(field),
            ConfigError::Case { error, .. } => Some(&error.field),
            _ => None,
        }
    }
}

/// Reads a section table of a sweep file (`[search]`, `[tries]`) into `T`, with errors that name
/// the file and the field (`section.key`): a missing key by its name, a bad value by the line
/// serde reports in the pretty-printed table. `untagged` names the fields whose value is an
/// untagged enum, with the message for a value of none of its forms.
pub(crate) fn read_section<T: serde::de::DeserializeOwned>(
    value: &serde_json::Value,
    file: &std::path::Path,
    section: &str,
    untagged: &[(&str, &str)],
) -> Result<T, ConfigError> {
    let err = |field: &str, message: String| section_error(file, section, field, message);
    if !value.is_object() {
        return Err(err("", format!("invalid type: {value}, expected a table")));
    }
    // from pretty text, so that serde's line number names the field
    let pretty = serde_json::to_string_pretty(value).unwrap_or_default();
    serde_json::from_str(&pretty).map_err(|e| {
        let text = e.to_string();
        let message = text.split(" at line ").next().unwrap_or(&text).to_string();
        // a missing key has no line of its own: name it from the message
        let missing = message
            .strip_prefix("missing field `")
            .and_then(|rest| rest.split('`').next());
        let path = json_path_at_line(&pretty, e.line());
        match missing {
            Some(key) => err(key, format!("{message}; add it to [{section}]")),
            None => match untagged.iter().find(|(field, _)| path == *field) {
                Some((field, expected)) if message.contains("untagged enum") => {
                    err(field, (*expected).to_string())
                }
                _ => err(&path, message),
            },
        }
    })
}

/// The error of field `field` of section `section` of sweep file `file` (`section` alone for an
/// empty field).
pub(crate) fn section_error(
    file: &std::path::Path,
    section: &str,
    field: &str,
    message: String,
) -> ConfigError {
    ConfigError::Sweep {
        file: file.to_path_buf(),
        field: if field.is_empty() {
            section.to_string()
        } else {
            format!("{section}.{field}")
        },
        message,
    }
}

/// Maps a line of pretty-printed JSON (as written by `serde_json::to_string_pretty`, 2-space indent) to the
/// dotted path of the key on or enclosing that line. Used to name the field of a serde error, whose
/// position is a line and column only.
pub(crate) fn json_path_at_line(pretty: &str, line: usize) -> String {
    let mut stack: Vec<String> = Vec::new();
    for (i, text) in pretty.lines().enumerate() {
        let indent = text.len() - text.trim_start().len();
        let depth = indent / 2;
        let trimmed = text.trim_start();
        let key = trimmed
            .strip_prefix('"')
            .and_then(|rest| rest.find("\":").map(|end| rest[..end].to_string()));
        if i + 1 == line {
            let mut path: Vec<String> = stack
                .iter()
                .take(depth.saturating_sub(1))
                .cloned()
                .collect();
            match key {
                Some(k) => path.push(k),
                // A closing brace or an array element: the enclosing key.
                None => {
                    if let Some(k) = stack.get(depth.saturating_sub(1)) {
                        if depth >= 1 && trimmed.starts_with(['}', ']']) {
                            path = stack.iter().take(depth).cloned().collect();
                        } else {
                            path.push(k.clone());
                        }
                    }
                }
            }
            return path.join(".");
        }
        if let Some(k) = key {
            if depth >= 1 {
                stack.truncate(depth - 1);
                stack.push(k);
            }
        }
    }
    String::new()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn path_of_a_nested_key() {
        let v = serde_json::json!({"fluid": {"wi": "x", "beta": 0.1}, "numerics": {"mesh": [1, 2], "dt": 1}});
        let s = serde_json::to_string_pretty(&v).unwrap();
        let line_of = |needle: &str| s.lines().position(|l| l.contains(needle)).unwrap() + 1;
        assert_eq!(json_path_at_line(&s, line_of("\"wi\"")), "fluid.wi");
        assert_eq!(json_path_at_line(&s, line_of("\"dt\"")), "numerics.dt");
        assert_eq!(json_path_at_line(&s, line_of("2")), "numerics.mesh");
    }
}
