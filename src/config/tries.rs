//! The `[tries]` section of a sweep file: the values of one axis (or the rows of one `[[zip]]`)
//! tried in order on every combination of the other axes, until a case ends in the wanted
//! outcome — the thesis' Tables 5.2–5.4 mark a cell '+' when a string forms from *some* initial
//! position, so once one has, the cell's other positions need not run. The rounds themselves
//! (planned from the store's outcomes) are in `sweep::tries`; this module only reads and
//! validates what the file asks for.
//!
//! ```toml
//! [[zip]]                                   # the initial positions, tried in this order
//! "particles.layout.string.lx" = [0.5, 0.3, 0.25]
//! "particles.layout.string.ly" = [0.1, 0.05, 0.025]
//! [tries]
//! over = "particles.layout.string.lx"       # a field of [axes] or of a [[zip]] (its whole row)
//! until = "string"                          # an outcome kind, or { string_length_at_least = 3 }
//! ```

use std::path::Path;

use serde::Deserialize;
use serde_json::Value;

use super::error::{read_section, section_error, ConfigError};

/// What ends the tries of one combination of the other axes.
#[derive(Debug, Clone, PartialEq, Eq, Deserialize)]
#[serde(untagged)]
pub enum Until {
    /// A case ends in this outcome kind (its stored name: `string`, `migrated`, …; checked
    /// against the kinds when the sweep is planned, `sweep::tries`).
    Kind(String),
    /// A case ends in a string of at least this many particles.
    StringLength {
        /// Fewest particles of the string (≥ 2).
        string_length_at_least: u32,
    },
}

impl Until {
    /// Whether a finished case with outcome `kind` (and string length `string_length`) ends the
    /// tries of its combination.
    pub fn met_by(&self, kind: &str, string_length: Option<i64>) -> bool {
        match self {
            Until::Kind(k) => k == kind,
            Until::StringLength {
                string_length_at_least: n,
            } => kind == "string" && string_length.unwrap_or(0) >= i64::from(*n),
        }
    }

    /// How it reads in messages: `string`, `a string of ≥ 3`.
    pub fn describe(&self) -> String {
        match self {
            Until::Kind(k) => k.clone(),
            Until::StringLength {
                string_length_at_least: n,
            } => format!("a string of ≥ {n}"),
        }
    }
}

/// The `[tries]` table as written.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct TriesFile {
    over: String,
    until: Until,
}

/// A validated `[tries]` section.
#[derive(Debug, Clone, PartialEq)]
pub struct TriesSpec {
    /// Dotted path of the tried field: an axis, or one field of a `[[zip]]` (then the group's
    /// rows are the tries).
    pub over: String,
    /// What ends the tries of a combination.
    pub until: Until,
}

impl TriesSpec {
    /// Reads and validates `value` (the `[tries]` table of `file`); `swept` are the paths of the
    /// file's axes and zips, among which `over` must be. Errors name the file and the field
    /// (`tries.over`, …) and say what to change.
    pub fn from_value(
        value: &Value,
        file: &Path,
        swept: &[&str],
    ) -> Result<TriesSpec, ConfigError> {
        let err = |field: &str, message: String| section_error(file, "tries", field, message);
        let expected =
            "expected an outcome kind (e.g. \"string\") or { string_length_at_least = N }";
        let raw: TriesFile = read_section(value, file, "tries", &[("until", expected)])?;
        if !swept.contains(&raw.over.as_str()) {
            return Err(err(
                "over",
                format!(
                    "`{}` is not swept: name a field of [axes] or of a [[zip]] (its values, or \
                     the zip's rows, are tried in order)",
                    raw.over
                ),
            ));
        }
        if let Until::StringLength {
            string_length_at_least: n,
        } = raw.until
        {
            if n < 2 {
                return Err(err(
                    "until.string_length_at_least",
                    format!("{n}: a string has at least 2 particles"),
                ));
            }
        }
        Ok(TriesSpec {
            over: raw.over,
            until: raw.until,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<TriesSpec, ConfigError> {
        let v: Value = toml::from_str::<toml::Value>(text)
            .map(|t| serde_json::to_value(t).unwrap())
            .unwrap();
        TriesSpec::from_value(
            &v,
            Path::new("s.toml"),
            &["fluid.wi", "particles.layout.string.lx"],
        )
    }

    const GOOD: &str = "over = \"particles.layout.string.lx\"\nuntil = \"string\"\n";

    #[test]
    fn both_forms_of_until() {
        let s = parse(GOOD).unwrap();
        assert_eq!(s.until, Until::Kind("string".into()));
        assert!(s.until.met_by("string", Some(2)));
        assert!(!s.until.met_by("repel", None));
        let s = parse(&GOOD.replace("\"string\"", "{ string_length_at_least = 3 }")).unwrap();
        assert!(s.until.met_by("string", Some(3)));
        assert!(!s.until.met_by("string", Some(2)));
        assert!(!s.until.met_by("pass", None));
        assert_eq!(s.until.describe(), "a string of ≥ 3");
    }

    #[test]
    fn errors_name_the_field() {
        let field = |text: &str| parse(text).unwrap_err().field().unwrap().to_string();
        assert_eq!(field(&GOOD.replace("string.lx", "string.ly")), "tries.over");
        assert_eq!(field(&GOOD.replace("\"string\"", "3")), "tries.until");
        assert_eq!(
            field(&GOOD.replace("\"string\"", "{ string_length_at_least = 1 }")),
            "tries.until.string_length_at_least"
        );
        assert_eq!(field(&format!("{GOOD}budget = 1")), "tries.budget");
        assert_eq!(field("until = \"string\"\n"), "tries.over");
    }
}
