//! The `[search]` section of a sweep file: one axis refined where the outcome changes instead of
//! filled on a grid (issue 24). The search itself (rounds, brackets, replay from the store) is in
//! `sweep::search`; this module only reads and validates what the file asks for.
//!
//! ```toml
//! [search]
//! axis = "fluid.wi"          # the field refined; not also in [axes] or [[zip]]
//! range = [0.0, 3.0]         # lo < hi
//! tol = 0.05                 # stop refining a bracket once it is at most this wide
//! budget = 40                # most cases per combination of the other axes, coarse round included
//! coarse = 7                 # evenly spaced start values, ends included (default 5)
//! per_bracket = 3            # values put into each open bracket per round (default 1: bisection)
//! change = "kind"            # or { string_length_at_least = 3 }
//! ```

use std::path::Path;

use serde::{Deserialize, Serialize};
use serde_json::Value;

use super::error::{read_section, section_error, ConfigError};

/// Default number of coarse values: enough to see two boundaries on most axes.
const DEFAULT_COARSE: usize = 5;
/// Default values per bracket and round: bisection, the fewest cases per boundary.
const DEFAULT_PER_BRACKET: usize = 1;
/// Most values per bracket and round: more only widens each round without narrowing it faster.
const MAX_PER_BRACKET: usize = 64;

/// What a search counts as a change of outcome between two neighbouring values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum Change {
    /// Any change of outcome kind (pass → repel → string …); `diverged` and `timeout` are kinds too.
    #[default]
    Kind,
    /// Whether the case ends in a string of at least this many particles (thesis Tables 5.2–5.4:
    /// the critical Wi of a string of N).
    StringLengthAtLeast(u32),
}

impl Change {
    /// The class an outcome falls in: neighbouring values in different classes bracket a boundary.
    /// `kind` is the stored outcome kind, `string_length` its string length (if any).
    pub fn class_of(self, kind: &str, string_length: Option<i64>) -> String {
        match self {
            Change::Kind => kind.to_string(),
            Change::StringLengthAtLeast(n) => {
                if kind == "string" && string_length.unwrap_or(0) >= i64::from(n) {
                    format!("string>={n}")
                } else {
                    format!("no string>={n}")
                }
            }
        }
    }
}

/// The `[search]` table as written.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct SearchFile {
    axis: String,
    range: [f64; 2],
    tol: f64,
    budget: usize,
    #[serde(default = "default_coarse")]
    coarse: usize,
    #[serde(default = "default_per_bracket")]
    per_bracket: usize,
    #[serde(default)]
    change: Change,
}

fn default_coarse() -> usize {
    DEFAULT_COARSE
}

fn default_per_bracket() -> usize {
    DEFAULT_PER_BRACKET
}

/// A validated `[search]` section.
#[derive(Debug, Clone, PartialEq)]
pub struct SearchSpec {
    /// Dotted field path of the refined axis, e.g. `fluid.wi`.
    pub axis: String,
    /// Lower end of the searched interval.
    pub lo: f64,
    /// Upper end (> `lo`).
    pub hi: f64,
    /// A bracket at most this wide is not refined further (> 0, < hi − lo).
    pub tol: f64,
    /// Most cases per combination of the other axes, coarse round included (≥ `coarse`).
    pub budget: usize,
    /// Evenly spaced values of the first round, both ends included (≥ 2).
    pub coarse: usize,
    /// Values put into each open bracket per round (≥ 1; 1 is bisection).
    pub per_bracket: usize,
    /// What counts as a change of outcome.
    pub change: Change,
}

impl SearchSpec {
    /// Reads and validates `value` (the `[search]` table of `file`); `swept` are the paths of the
    /// file's axes and zips, which the searched axis must not be among. Errors name the file and
    /// the field (`search.tol`, …) and say what to change.
    pub fn from_value(
        value: &Value,
        file: &Path,
        swept: &[&str],
    ) -> Result<SearchSpec, ConfigError> {
        let err = |field: &str, message: String| section_error(file, "search", field, message);
        let raw: SearchFile = read_section(value, file, "search", &[])?;
        let [lo, hi] = raw.range;
        if raw.axis.is_empty() {
            return Err(err(
                "axis",
                "name the field to refine, e.g. \"fluid.wi\"".into(),
            ));
        }
        if swept.contains(&raw.axis.as_str()) {
            return Err(err(
                "axis",
                format!(
                    "`{}` is also swept in [axes] or [[zip]]; a searched field takes its values \
                     from [search] only: remove it there",
                    raw.axis
                ),
            ));
        }
        if !(lo.is_finite() && hi.is_finite() && lo < hi) {
            return Err(err(
                "range",
                format!("[{lo}, {hi}] is not an interval [lo, hi] with lo < hi"),
            ));
        }
        if !(raw.tol.is_finite() && raw.tol > 0.0 && raw.tol < hi - lo) {
            return Err(err(
                "tol",
                format!(
                    "{} must be > 0 and smaller than the range's width {}",
                    raw.tol,
                    hi - lo
                ),
            ));
        }
        if raw.coarse < 2 {
            return Err(err(
                "coarse",
                format!(
                    "{} values cannot bracket anything; use at least 2",
                    raw.coarse
                ),
            ));
        }
        if raw.budget < raw.coarse {
            return Err(err(
                "budget",
                format!(
                    "{} cases per combination of the other axes is less than the {} coarse \
                     values; raise budget or lower coarse",
                    raw.budget, raw.coarse
                ),
            ));
        }
        if !(1..=MAX_PER_BRACKET).contains(&raw.per_bracket) {
            return Err(err(
                "per_bracket",
                format!("{} is not between 1 and {MAX_PER_BRACKET}", raw.per_bracket),
            ));
        }
        if let Change::StringLengthAtLeast(n) = raw.change {
            if n < 2 {
                return Err(err(
                    "change.string_length_at_least",
                    format!("{n}: a string has at least 2 particles"),
                ));
            }
        }
        Ok(SearchSpec {
            axis: raw.axis,
            lo,
            hi,
            tol: raw.tol,
            budget: raw.budget,
            coarse: raw.coarse,
            per_bracket: raw.per_bracket,
            change: raw.change,
        })
    }

    /// Values of a full grid with spacing at most `tol` over [lo, hi]: what a grid sweep needs to
    /// locate the same boundaries as finely.
    pub fn grid_values(&self) -> usize {
        ((self.hi - self.lo) / self.tol).ceil() as usize + 1
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<SearchSpec, ConfigError> {
        let v: Value = toml::from_str::<toml::Value>(text)
            .map(|t| serde_json::to_value(t).unwrap())
            .unwrap();
        SearchSpec::from_value(&v, Path::new("s.toml"), &["particles.layout.string.ly"])
    }

    const GOOD: &str = "axis = \"fluid.wi\"\nrange = [0.0, 3.0]\ntol = 0.05\nbudget = 40\n";

    #[test]
    fn defaults_and_change_forms() {
        let s = parse(GOOD).unwrap();
        assert_eq!((s.coarse, s.per_bracket, s.change), (5, 1, Change::Kind));
        assert_eq!(s.grid_values(), 61);
        let s = parse(&format!("{GOOD}change = {{ string_length_at_least = 3 }}")).unwrap();
        assert_eq!(s.change, Change::StringLengthAtLeast(3));
        assert_eq!(s.change.class_of("string", Some(3)), "string>=3");
        assert_eq!(s.change.class_of("string", Some(2)), "no string>=3");
        assert_eq!(s.change.class_of("pass", None), "no string>=3");
        assert_eq!(Change::Kind.class_of("repel", None), "repel");
    }

    #[test]
    fn errors_name_the_field() {
        let field = |text: &str| parse(text).unwrap_err().field().unwrap().to_string();
        assert_eq!(field(&GOOD.replace("0.05", "0")), "search.tol");
        assert_eq!(field(&GOOD.replace("0.05", "-1")), "search.tol");
        assert_eq!(field(&GOOD.replace("0.05", "5")), "search.tol");
        assert_eq!(
            field(&GOOD.replace("[0.0, 3.0]", "[3.0, 3.0]")),
            "search.range"
        );
        assert_eq!(
            field(&GOOD.replace("[0.0, 3.0]", "[3.0, 1.0]")),
            "search.range"
        );
        assert_eq!(field(&GOOD.replace("40", "4")), "search.budget");
        assert_eq!(field(&format!("{GOOD}coarse = 1")), "search.coarse");
        assert_eq!(
            field(&format!("{GOOD}per_bracket = 0")),
            "search.per_bracket"
        );
        assert_eq!(field(&GOOD.replace("0.05", "\"x\"")), "search.tol");
        assert_eq!(field(&format!("{GOOD}tolerance = 1")), "search.tolerance");
        assert_eq!(
            field(&format!("{GOOD}change = \"length\"")),
            "search.change"
        );
        assert_eq!(
            field(&format!("{GOOD}change = {{ string_length_at_least = 1 }}")),
            "search.change.string_length_at_least"
        );
        assert_eq!(
            field(&GOOD.replace("fluid.wi", "particles.layout.string.ly")),
            "search.axis"
        );
        assert_eq!(field(&GOOD.replace("budget = 40\n", "")), "search.budget");
    }
}
