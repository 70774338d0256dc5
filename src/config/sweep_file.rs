//! Sweep files (TOML, or JSON by extension): a name, a base case table and axes by dotted field path.
//!
//! ```toml
//! name = "table5_2"
//! [base]            # a full case table (see CaseSpec)
//! ...
//! [axes]            # crossed with each other; a list or a range { start, stop, step | num }
//! fluid.wi = [1, 2, 3]
//! particles.layout.string.n = { start = 2, stop = 6, step = 1 }
//! [[zip]]           # lists of equal length varied together; each group is crossed with the axes
//! "geometry.confined_shear.h" = [0.5, 1.0]
//! "numerics.mesh" = [[220, 28], [440, 55]]
//! [search]          # optional: refine one more axis where the outcome changes (`search`)
//! axis = "fluid.wi"
//! range = [0.0, 3.0]
//! tol = 0.05
//! budget = 40
//! [tries]           # optional, instead of [search]: try one axis' values in order per
//! over = "particles.layout.string.lx"   # combination of the others, until an outcome (`tries`)
//! until = "string"
//! ```
//! Expansion into cases is in `sweep::expand`; a search's rounds in `sweep::search`; the rounds of
//! tries in `sweep::tries`.

use std::path::{Path, PathBuf};

use serde_json::{Map, Value};

use super::case::CaseSpec;
use super::error::ConfigError;
use super::search::SearchSpec;
use super::tries::TriesSpec;

/// Keys allowed at the top level of a sweep file.
const TOP_LEVEL_KEYS: [&str; 7] = [
    "name",
    "description",
    "base",
    "axes",
    "zip",
    "search",
    "tries",
];

/// Upper bound on values produced by one range, so that a mistyped step cannot exhaust memory.
const MAX_RANGE_VALUES: usize = 100_000;

/// Relative slack when deciding whether a range's stop value is reached by `start + k·step`, so that
/// `{ start = 0, stop = 0.3, step = 0.1 }` includes 0.3 despite binary rounding.
const RANGE_STOP_SLACK: f64 = 1e-9;

/// A parsed sweep file; its cases are produced by `sweep::expand`.
#[derive(Debug, Clone)]
pub struct SweepSpec {
    /// The file it was read from (for messages).
    pub file: PathBuf,
    /// Sweep name: letters, digits, `_`, `-`, `.`; names the default database `results/<name>.db`.
    pub name: String,
    /// Free text.
    pub description: String,
    /// The base case table, before axis values are set.
    pub base: Value,
    /// Axes crossed with each other (first varies slowest).
    pub axes: Vec<Axis>,
    /// Zip groups: axes of equal length varied together, each group crossed with the other axes.
    pub zips: Vec<Vec<Axis>>,
    /// The `[search]` section: one more axis refined where the outcome changes, for each
    /// combination of the axes and zips.
    pub search: Option<SearchSpec>,
    /// The `[tries]` section: one axis (or zip) tried in order on each combination of the others
    /// until a case ends in the wanted outcome.
    pub tries: Option<TriesSpec>,
    /// The whole file as JSON, recorded in the store.
    pub raw: Value,
}

/// One swept field and its values.
#[derive(Debug, Clone, PartialEq)]
pub struct Axis {
    /// Dotted field path into the case table, e.g. `fluid.wi`.
    pub path: String,
    /// The values, in order.
    pub values: Vec<Value>,
}

impl SweepSpec {
    /// Reads and parses a sweep file (`.json` as JSON, anything else as TOML).
    pub fn from_file(path: &Path) -> Result<SweepSpec, ConfigError> {
        let text = std::fs::read_to_string(path).map_err(|source| ConfigError::Io {
            file: path.to_path_buf(),
            source,
        })?;
        let is_json = path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("json"));
        Self::from_str(&text, is_json, path)
    }

    /// Parses sweep text; `file` is used in messages only.
    pub fn from_str(text: &str, is_json: bool, file: &Path) -> Result<SweepSpec, ConfigError> {
        let raw = super::text::parse(text, is_json, file)?;
        Self::from_value(raw, file)
    }

    fn from_value(raw: Value, file: &Path) -> Result<SweepSpec, ConfigError> {
        let err = |field: &str, message: String| ConfigError::Sweep {
            file: file.to_path_buf(),
            field: field.to_string(),
            message,
        };
        let Some(top) = raw.as_object() else {
            return Err(err(
                "",
                "a sweep file is a table with name, base and axes".into(),
            ));
        };
        if let Some(k) = top.keys().find(|k| !TOP_LEVEL_KEYS.contains(&k.as_str())) {
            return Err(err(
                k,
                format!("unknown key; expected one of {}", TOP_LEVEL_KEYS.join(", ")),
            ));
        }
        let name = match top.get("name") {
            Some(Value::String(s)) if is_valid_name(s) => s.clone(),
            Some(Value::String(s)) => {
                return Err(err(
                    "name",
                    format!(
                        "`{s}` may only use letters, digits, `_`, `-` and `.`, start with a \
                         letter, digit or `_`, and have at most {MAX_NAME_CHARS} characters \
                         (it names files: results/<name>.db, results/<name>/)"
                    ),
                ));
            }
            Some(v) => return Err(err("name", format!("invalid type: {v}, expected a string"))),
            None => {
                return Err(err(
                    "name",
                    "missing; add name = \"...\" (it names the database)".into(),
                ))
            }
        };
        let description = match top.get("description") {
            None => String::new(),
            Some(Value::String(s)) => s.clone(),
            Some(v) => {
                return Err(err(
                    "description",
                    format!("invalid type: {v}, expected a string"),
                ))
            }
        };
        let base = match top.get("base") {
            Some(v @ Value::Object(_)) => v.clone(),
            Some(v) => return Err(err("base", format!("invalid type: {v}, expected a table"))),
            None => {
                return Err(err(
                    "base",
                    "missing; add a [base] table with the case parameters".into(),
                ))
            }
        };
        let mut axes = Vec::new();
        match top.get("axes") {
            None => {}
            Some(Value::Object(m)) => {
                flatten_axes(m, "", &mut axes).map_err(|(f, m)| err(&format!("axes.{f}"), m))?
            }
            Some(v) => return Err(err("axes", format!("invalid type: {v}, expected a table"))),
        }
        let mut zips = Vec::new();
        match top.get("zip") {
            None => {}
            Some(Value::Array(groups)) => {
                for (g, group) in groups.iter().enumerate() {
                    let Value::Object(m) = group else {
                        return Err(err(
                            &format!("zip[{g}]"),
                            "each zip group is a table of lists".into(),
                        ));
                    };
                    let mut axes = Vec::new();
                    flatten_axes(m, "", &mut axes)
                        .map_err(|(f, m)| err(&format!("zip[{g}].{f}"), m))?;
                    if let Some(first) = axes.first() {
                        if let Some(bad) =
                            axes.iter().find(|a| a.values.len() != first.values.len())
                        {
                            return Err(err(
                                &format!("zip[{g}].{}", bad.path),
                                format!(
                                    "zipped lists must have equal length: {} has {}, {} has {}",
                                    first.path,
                                    first.values.len(),
                                    bad.path,
                                    bad.values.len()
                                ),
                            ));
                        }
                    }
                    zips.push(axes);
                }
            }
            Some(v) => {
                return Err(err(
                    "zip",
                    format!("invalid type: {v}, expected [[zip]] tables"),
                ))
            }
        }
        let all: Vec<&Axis> = axes.iter().chain(zips.iter().flatten()).collect();
        for (i, a) in all.iter().enumerate() {
            if all[..i].iter().any(|b| b.path == a.path) {
                return Err(err(
                    &a.path,
                    "this field is swept twice; keep one axis per field".into(),
                ));
            }
        }
        let search = match top.get("search") {
            None => None,
            Some(v) => {
                let swept: Vec<&str> = all.iter().map(|a| a.path.as_str()).collect();
                Some(SearchSpec::from_value(v, file, &swept)?)
            }
        };
        let tries =
            match top.get("tries") {
                None => None,
                Some(_) if search.is_some() => return Err(err(
                    "tries",
                    "a sweep has [search] or [tries], not both (each plans its own rounds from \
                     the outcomes): split it into two files"
                        .into(),
                )),
                Some(v) => {
                    let swept: Vec<&str> = all.iter().map(|a| a.path.as_str()).collect();
                    Some(TriesSpec::from_value(v, file, &swept)?)
                }
            };
        Ok(SweepSpec {
            file: file.to_path_buf(),
            name,
            description,
            base,
            axes,
            zips,
            search,
            tries,
            raw,
        })
    }
}

/// Longest sweep name (it is a file name, with `.db` appended).
const MAX_NAME_CHARS: usize = 100;

/// A name that is one safe path component: letters, digits, `_`, `-`, `.`, not starting with `.`
/// or `-` (so never `.`, `..`, a hidden file or an option).
fn is_valid_name(s: &str) -> bool {
    s.len() <= MAX_NAME_CHARS
        && s.starts_with(|c: char| c.is_ascii_alphanumeric() || c == '_')
        && s.chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.'))
}

/// Collects axes from a (possibly nested) table: arrays and range tables are leaves.
fn flatten_axes(
    m: &Map<String, Value>,
    prefix: &str,
    out: &mut Vec<Axis>,
) -> Result<(), (String, String)> {
    for (k, v) in m {
        let path = if prefix.is_empty() {
            k.clone()
        } else {
            format!("{prefix}.{k}")
        };
        match v {
            Value::Array(values) => {
                if values.is_empty() {
                    return Err((path, "an axis needs at least one value".into()));
                }
                out.push(Axis { path, values: values.clone() });
            }
            Value::Object(inner) if is_range(inner) => {
                let values = expand_range(inner).map_err(|m| (path.clone(), m))?;
                out.push(Axis { path, values });
            }
            Value::Object(inner) => flatten_axes(inner, &path, out)?,
            other => {
                return Err((
                    path,
                    format!("{other} is not a list or a range {{ start, stop, step | num }}; a fixed value belongs in [base]"),
                ))
            }
        }
    }
    Ok(())
}

fn is_range(m: &Map<String, Value>) -> bool {
    m.contains_key("start")
        && m.keys()
            .all(|k| matches!(k.as_str(), "start" | "stop" | "step" | "num"))
}

/// Values of `{ start, stop, step }` (stop inclusive; integers stay integers) or `{ start, stop, num }`.
fn expand_range(m: &Map<String, Value>) -> Result<Vec<Value>, String> {
    let get = |k: &str| -> Result<Option<f64>, String> {
        match m.get(k) {
            None => Ok(None),
            Some(v) => v
                .as_f64()
                .map(Some)
                .ok_or_else(|| format!("range `{k}` must be a number, got {v}")),
        }
    };
    let start = get("start")?.ok_or("range needs start")?;
    let stop = get("stop")?.ok_or("range needs stop")?;
    let all_int = ["start", "stop", "step"]
        .iter()
        .all(|k| m.get(*k).is_none_or(Value::is_i64));
    match (get("step")?, m.get("num")) {
        (Some(step), None) => {
            if !(step != 0.0 && (stop - start) * step >= 0.0 && step.is_finite()) {
                return Err(format!("step {step} does not lead from {start} to {stop}"));
            }
            let count = ((stop - start) / step + RANGE_STOP_SLACK).floor() as usize + 1;
            if count > MAX_RANGE_VALUES {
                return Err(format!(
                    "range gives {count} values, more than {MAX_RANGE_VALUES}"
                ));
            }
            Ok((0..count)
                .map(|k| {
                    let x = start + k as f64 * step;
                    if all_int {
                        Value::from(x.round() as i64)
                    } else {
                        Value::from(x)
                    }
                })
                .collect())
        }
        (None, Some(num)) => {
            let num = num
                .as_u64()
                .filter(|&n| n >= 1)
                .ok_or("range `num` must be an integer ≥ 1")? as usize;
            if num > MAX_RANGE_VALUES {
                return Err(format!("num = {num} is more than {MAX_RANGE_VALUES}"));
            }
            Ok((0..num)
                .map(|k| {
                    let x = if num == 1 {
                        start
                    } else {
                        start + (stop - start) * k as f64 / (num - 1) as f64
                    };
                    Value::from(x)
                })
                .collect())
        }
        _ => Err("a range needs exactly one of step or num".into()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<SweepSpec, ConfigError> {
        SweepSpec::from_str(text, false, Path::new("t.toml"))
    }

    #[test]
    fn nested_and_quoted_axis_paths_and_ranges() {
        let s = parse(
            r#"
            name = "x"
            [base]
            [axes]
            fluid.wi = [1, 2]
            "numerics.dt" = { start = 0.01, stop = 0.03, step = 0.01 }
            particles.layout.string.n = { start = 2, stop = 6, step = 2 }
            fluid.beta = { start = 0.0, stop = 0.9, num = 4 }
            "#,
        )
        .unwrap();
        let get = |p: &str| s.axes.iter().find(|a| a.path == p).unwrap().values.clone();
        assert_eq!(get("fluid.wi"), vec![Value::from(1), Value::from(2)]);
        assert_eq!(
            get("numerics.dt").len(),
            3,
            "stop is inclusive despite rounding"
        );
        assert_eq!(
            get("particles.layout.string.n"),
            vec![Value::from(2), Value::from(4), Value::from(6)]
        );
        assert_eq!(get("fluid.beta").len(), 4);
    }

    #[test]
    fn sweep_level_errors_name_the_field() {
        let e = parse("name = \"x\"\nbase = {}\nextra = 1").unwrap_err();
        assert_eq!(e.field(), Some("extra"));
        let e = parse("name = \"x\"\n[base]\n[axes]\nfluid.wi = 3").unwrap_err();
        assert_eq!(e.field(), Some("axes.fluid.wi"));
        let e = parse("name = \"x\"\n[base]\n[[zip]]\na = [1, 2]\nb = [1]").unwrap_err();
        assert_eq!(e.field(), Some("zip[0].b"));
        let e = parse("name = \"a b\"\n[base]").unwrap_err();
        assert_eq!(e.field(), Some("name"));
        // a name is one safe path component (issue 28: ".." wrote outside results/)
        for bad in ["..", ".", ".hidden", "-x", ""] {
            let e = parse(&format!("name = \"{bad}\"\n[base]")).unwrap_err();
            assert_eq!(e.field(), Some("name"), "{bad}: {e}");
        }
        assert!(parse("name = \"a.b-c_1\"\n[base]").is_ok());
        let e = parse("name = \"x\"\n[base]\n[axes]\nw = { start = 0, stop = 1, step = -1 }")
            .unwrap_err();
        assert_eq!(e.field(), Some("axes.w"));
        assert!(matches!(
            parse("name = = 1").unwrap_err(),
            ConfigError::Syntax { .. }
        ));
    }
}

/// One case of a sweep, ready to run.
#[derive(Debug, Clone)]
pub struct PlannedCase {
    /// 0-based position in the expansion order.
    pub index: usize,
    /// Axis values, e.g. `wi=2 n=3` (last path segment, or the full path where that is ambiguous).
    pub label: String,
    /// Stable case id: 16 hex digits.
    pub id: String,
    /// The validated case.
    pub spec: CaseSpec,
    /// The swept fields and their values for this case.
    pub params: Vec<(String, Value)>,
}
