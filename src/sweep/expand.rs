//! Expansion of a sweep file into cases, and case ids: FNV-1a 64 of the canonical JSON of the validated
//! case spec (keys sorted, defaults filled in, shorthands resolved), so the id is stable across runs,
//! machines and the way the case was written.

use std::collections::HashMap;

use serde_json::Value;

use crate::config::{CaseSpec, ConfigError, PlannedCase, SpecError, SweepSpec};

/// FNV-1a 64-bit hash of `bytes`.
pub fn fnv1a64(bytes: &[u8]) -> u64 {
    const OFFSET: u64 = 0xcbf2_9ce4_8422_2325;
    const PRIME: u64 = 0x0000_0100_0000_01b3;
    bytes
        .iter()
        .fold(OFFSET, |h, b| (h ^ u64::from(*b)).wrapping_mul(PRIME))
}

/// JSON text with object keys sorted at every level (independent of serde_json's map ordering).
pub fn canonical_json(v: &Value) -> String {
    match v {
        Value::Object(m) => {
            let mut keys: Vec<&String> = m.keys().collect();
            keys.sort();
            let body: Vec<String> = keys
                .iter()
                .map(|k| format!("{}:{}", Value::String((*k).clone()), canonical_json(&m[*k])))
                .collect();
            format!("{{{}}}", body.join(","))
        }
        Value::Array(a) => format!(
            "[{}]",
            a.iter().map(canonical_json).collect::<Vec<_>>().join(",")
        ),
        other => other.to_string(),
    }
}

/// The stable id of a case: FNV-1a 64 of its canonical JSON, as 16 hex digits.
///
/// A Newtonian case has no history to carry: its id leaves out `numerics.remap`, so that a
/// change of the remap default does not rerun Stokes cases.
pub fn case_id(spec: &CaseSpec) -> String {
    // Serializing plain data with string keys cannot fail.
    let mut value = serde_json::to_value(spec).unwrap_or(Value::Null);
    if spec.relaxation_time() == 0.0 {
        if let Some(numerics) = value.get_mut("numerics").and_then(Value::as_object_mut) {
            numerics.remove("remap");
        }
    }
    format!("{:016x}", fnv1a64(canonical_json(&value).as_bytes()))
}

/// Most cases a sweep may expand to unless told otherwise (`xpflow sweep --max-cases`): far more
/// than a study runs, few enough that expanding and registering them takes seconds.
pub const DEFAULT_MAX_CASES: usize = 100_000;

/// Expands a sweep into validated cases (at most [`DEFAULT_MAX_CASES`]); see [`expand_at_most`].
pub fn expand(sweep: &SweepSpec) -> Result<Vec<PlannedCase>, ConfigError> {
    expand_at_most(sweep, DEFAULT_MAX_CASES)
}

/// Expands a sweep into validated cases: the crossed axes (first varies slowest) times each zip group.
/// Errors name the file, the case index and label, and the field; identical cases are an error, and so is
/// a sweep of more than `max_cases` cases (counted before anything is expanded). Time and memory are
/// linear in the number of cases. A sweep with a `[search]` section is refused: its cases are
/// planned round by round (`sweep::search`).
pub fn expand_at_most(
    sweep: &SweepSpec,
    max_cases: usize,
) -> Result<Vec<PlannedCase>, ConfigError> {
    if sweep.search.is_some() {
        return Err(ConfigError::Sweep {
            file: sweep.file.clone(),
            field: "search".into(),
            message: "a search's cases are planned round by round from its results \
                      (sweep::search::replay), not expanded at once"
                .into(),
        });
    }
    let combinations = combinations(sweep, max_cases, 1)?;
    let labels = Labels::new(&swept_axes(sweep));
    let mut cases: Vec<PlannedCase> = Vec::with_capacity(combinations.len());
    let mut seen: HashMap<String, usize> = HashMap::with_capacity(combinations.len());
    for (index, params) in combinations.into_iter().enumerate() {
        let case = plan_case(sweep, &labels, index, params)?;
        if let Some(&twin) = seen.get(&case.id) {
            let twin = &cases[twin];
            let first_path = sweep.axes.iter().chain(sweep.zips.iter().flatten()).next();
            return Err(ConfigError::Case {
                file: sweep.file.clone(),
                index,
                label: case.label.clone(),
                error: SpecError::new(
                    first_path.map_or("", |a| a.path.as_str()),
                    format!(
                        "identical to case {} ({}); remove the duplicate axis value",
                        twin.index, twin.label
                    ),
                ),
            });
        }
        seen.insert(case.id.clone(), index);
        cases.push(case);
    }
    Ok(cases)
}

/// The axes and zipped axes of a sweep, in expansion order.
pub(crate) fn swept_axes(sweep: &SweepSpec) -> Vec<&crate::config::Axis> {
    sweep
        .axes
        .iter()
        .chain(sweep.zips.iter().flatten())
        .collect()
}

/// Every combination of the sweep's axes (first varies slowest) times each zip group, as the
/// assignments (path, value) of each. Refused when `per` cases for each would be more than
/// `max_cases` (counted before anything is expanded).
pub(crate) fn combinations(
    sweep: &SweepSpec,
    max_cases: usize,
    per: usize,
) -> Result<Vec<Vec<(String, Value)>>, ConfigError> {
    // Each dimension is a list of assignments; a plain axis is a zip group of one.
    let mut dims: Vec<Vec<Vec<(String, Value)>>> = Vec::new();
    for axis in &sweep.axes {
        dims.push(
            axis.values
                .iter()
                .map(|v| vec![(axis.path.clone(), v.clone())])
                .collect(),
        );
    }
    for group in &sweep.zips {
        let len = group.first().map_or(0, |a| a.values.len());
        dims.push(
            (0..len)
                .map(|i| {
                    group
                        .iter()
                        .map(|a| (a.path.clone(), a.values[i].clone()))
                        .collect()
                })
                .collect(),
        );
    }
    let count = dims.iter().fold(1.0_f64, |n, d| n * d.len() as f64);
    if count * per as f64 > max_cases as f64 {
        let sizes: Vec<String> = dims.iter().map(|d| d.len().to_string()).collect();
        let each = if per > 1 {
            format!(" combinations, each searched with up to {per} cases (search.budget)")
        } else {
            " cases".into()
        };
        return Err(ConfigError::Sweep {
            file: sweep.file.clone(),
            field: "axes".into(),
            message: format!(
                "the axes expand to {count:.0}{each} ({}), more than the limit of {max_cases} \
                 cases; split the sweep into several files, or raise the limit with --max-cases",
                sizes.join(" × ")
            ),
        });
    }
    let total = count as usize;
    let mut out = Vec::with_capacity(total);
    // odometer over the dimensions, the last varying fastest
    let mut at = vec![0_usize; dims.len()];
    for _ in 0..total {
        out.push(
            dims.iter()
                .zip(&at)
                .flat_map(|(d, &k)| d[k].iter().cloned())
                .collect(),
        );
        for k in (0..dims.len()).rev() {
            at[k] += 1;
            if at[k] < dims[k].len() {
                break;
            }
            at[k] = 0;
        }
    }
    Ok(out)
}

/// The validated case `index` of a sweep with the swept fields set to `params`; the error names
/// the file, the case (index, label) and the field.
pub(crate) fn plan_case(
    sweep: &SweepSpec,
    labels: &Labels,
    index: usize,
    params: Vec<(String, Value)>,
) -> Result<PlannedCase, ConfigError> {
    let label = labels.of(&params);
    plan_labelled(sweep, index, label, params)
}

/// [`plan_case`] with its label given: a case planned elsewhere (a search's round, written
/// beside a cluster round's manifest) planned again from its swept fields.
pub(crate) fn plan_labelled(
    sweep: &SweepSpec,
    index: usize,
    label: String,
    params: Vec<(String, Value)>,
) -> Result<PlannedCase, ConfigError> {
    let case_err = |error: SpecError| ConfigError::Case {
        file: sweep.file.clone(),
        index,
        label: label.clone(),
        error,
    };
    let mut value = sweep.base.clone();
    for (path, v) in &params {
        set_path(&mut value, path, v.clone()).map_err(case_err)?;
    }
    let spec = CaseSpec::from_value(value).map_err(case_err)?;
    let id = case_id(&spec);
    Ok(PlannedCase {
        index,
        label,
        id,
        spec,
        params,
    })
}

/// Significant digits a label gives a float at least: 4 (0.1667 for 1/6), more only where the
/// values of an axis need them to be told apart.
const LABEL_MIN_DIGITS: usize = 4;
/// Digits that tell any two different f64 apart.
const LABEL_MAX_DIGITS: usize = 17;

/// How the case labels name each swept field and write its values: `name=value`, the name the
/// last segment of the path (the full path where two axes share it), floats in the shortest form
/// with at least [`LABEL_MIN_DIGITS`] significant digits that tells the axis' values apart.
pub(crate) struct Labels {
    /// Per path: (name in the label, significant digits of its floats).
    fields: HashMap<String, (String, usize)>,
}

impl Labels {
    pub(crate) fn new(axes: &[&crate::config::Axis]) -> Labels {
        let short = |p: &str| p.rsplit('.').next().unwrap_or(p).to_string();
        let fields = axes
            .iter()
            .map(|a| {
                let s = short(&a.path);
                let ambiguous = axes.iter().filter(|b| short(&b.path) == s).count() > 1;
                let name = if ambiguous { a.path.clone() } else { s };
                (a.path.clone(), (name, digits_to_tell_apart(&a.values)))
            })
            .collect();
        Labels { fields }
    }

    pub(crate) fn of(&self, params: &[(String, Value)]) -> String {
        if params.is_empty() {
            return "base".into();
        }
        params
            .iter()
            .map(|(path, v)| {
                let (name, digits) = self
                    .fields
                    .get(path)
                    .map_or((path.as_str(), LABEL_MAX_DIGITS), |(n, d)| (n.as_str(), *d));
                format!("{name}={}", label_value(v, digits))
            })
            .collect::<Vec<_>>()
            .join(" ")
    }
}

/// A value in a label: strings bare, floats with at most `digits` significant digits.
fn label_value(v: &Value, digits: usize) -> String {
    match v {
        Value::String(s) => s.clone(),
        Value::Number(n) if n.is_f64() => n.as_f64().map_or_else(
            || n.to_string(),
            |x| crate::store::table::round_sig(x, digits),
        ),
        Value::Array(items) => format!(
            "[{}]",
            items
                .iter()
                .map(|x| label_value(x, digits))
                .collect::<Vec<_>>()
                .join(",")
        ),
        // a table (e.g. an adaptive step { initial, min, max, tol }): its fields, compactly
        Value::Object(fields) => format!(
            "{{{}}}",
            fields
                .iter()
                .map(|(k, x)| format!("{k}={}", label_value(x, digits)))
                .collect::<Vec<_>>()
                .join(",")
        ),
        other => other.to_string(),
    }
}

/// The fewest significant digits (at least [`LABEL_MIN_DIGITS`]) at which the different values
/// of an axis are written differently.
fn digits_to_tell_apart(values: &[Value]) -> usize {
    let distinct: std::collections::HashSet<String> = values
        .iter()
        .map(|v| label_value(v, LABEL_MAX_DIGITS))
        .collect();
    (LABEL_MIN_DIGITS..LABEL_MAX_DIGITS)
        .find(|&d| {
            let written: std::collections::HashSet<String> =
                values.iter().map(|v| label_value(v, d)).collect();
            written.len() == distinct.len()
        })
        .unwrap_or(LABEL_MAX_DIGITS)
}

/// Sets `value` at a dotted path, creating tables on the way.
fn set_path(root: &mut Value, path: &str, value: Value) -> Result<(), SpecError> {
    let mut node = root;
    let parts: Vec<&str> = path.split('.').collect();
    for (i, part) in parts.iter().enumerate() {
        let Value::Object(map) = node else {
            return Err(SpecError::new(
                parts[..i].join("."),
                format!("is not a table, so `{path}` cannot be set; check the axis path"),
            ));
        };
        if i + 1 == parts.len() {
            map.insert((*part).to_string(), value);
            return Ok(());
        }
        node = map
            .entry((*part).to_string())
            .or_insert_with(|| Value::Object(Default::default()));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use super::*;

    const SWEEP: &str = r#"
        name = "t"
        [base]
        fluid = { model = "giesekus", alpha = 0.01, beta = 0.1, wi = 1.0 }
        geometry.confined_shear = { h = 1.0, l = 4.0 }
        particles = { radius = 0.1, layout.string = { n = 2, lx = 0.5, ly = 0.1 } }
        numerics = { mesh = [40, 10], dt = 0.01, t_end = 1.0 }
        [axes]
        fluid.wi = [1, 2, 3]
        particles.layout.string.n = { start = 2, stop = 3, step = 1 }
        [[zip]]
        "numerics.dt" = [0.01, 0.02]
        "numerics.t_end" = [1.0, 2.0]
    "#;

    fn parse(text: &str) -> SweepSpec {
        SweepSpec::from_str(text, false, Path::new("t.toml")).unwrap()
    }

    #[test]
    fn crossed_and_zipped_axes() {
        let cases = expand(&parse(SWEEP)).unwrap();
        assert_eq!(cases.len(), 3 * 2 * 2);
        assert_eq!(cases[0].label, "wi=1 n=2 dt=0.01 t_end=1");
        assert_eq!(cases[11].label, "wi=3 n=3 dt=0.02 t_end=2");
        assert_eq!(cases[11].spec.n_particles(), 3);
        assert_eq!(cases[11].spec.numerics.dt.initial(), 0.02);
    }

    #[test]
    fn ids_are_stable_and_independent_of_spelling() {
        let a = expand(&parse(SWEEP)).unwrap();
        // The same sweep written with reordered keys, a default spelled out, and integers as floats.
        let b = parse(&SWEEP.replace(
            "particles = {",
            "output = { sample_every = 10 }\nparticles = {",
        ));
        let b = expand(&b).unwrap();
        for (x, y) in a.iter().zip(&b) {
            assert_eq!(x.id, y.id);
            assert_eq!(x.id.len(), 16);
        }
        // Changing any parameter changes the id.
        let c = expand(&parse(&SWEEP.replace("ly = 0.1", "ly = 0.11"))).unwrap();
        assert_ne!(a[0].id, c[0].id);
        // Numerical choices with a default: the default spelled out keeps the id, another choice
        // is another case. The remap is always serialized (its default changed: cases that named
        // their remap kept their ids), the coupling only when not `auto`.
        let with = |field: &str| {
            let text = SWEEP.replace("dt = 0.01", &format!("{field}, dt = 0.01"));
            assert_ne!(text, SWEEP, "the sweep has a numerics table with dt = 0.01");
            expand(&parse(&text)).unwrap()
        };
        assert_eq!(with("remap = \"bicubic\"")[0].id, a[0].id);
        assert_ne!(with("remap = \"biquadratic\"")[0].id, a[0].id);
        assert_ne!(with("remap = \"bilinear\"")[0].id, a[0].id);
        // ... but a Newtonian case has no history: the remap is not part of its id
        let newtonian = |remap: &str| {
            let text = SWEEP
                .replace(
                    "{ model = \"giesekus\", alpha = 0.01, beta = 0.1, wi = 1.0 }",
                    "{ model = \"newtonian\", wi = 0.0 }",
                )
                .replace("fluid.wi = [1, 2, 3]", "particles.radius = [0.1]")
                .replace("dt = 0.01", &format!("{remap}dt = 0.01"));
            expand(&parse(&text)).unwrap()[0].id.clone()
        };
        assert_eq!(newtonian(""), newtonian("remap = \"bilinear\", "));
        assert_eq!(newtonian(""), newtonian("remap = \"biquadratic\", "));
        assert_eq!(with("coupling = \"auto\"")[0].id, a[0].id);
        assert_ne!(with("coupling = \"semi_implicit\"")[0].id, a[0].id);
        // Pinned value: the hash of the canonical JSON must never change between versions, or resume breaks.
        assert_eq!(format!("{:016x}", fnv1a64(b"a")), "af63dc4c8601ec8c");
    }

    #[test]
    fn a_bad_axis_value_names_file_case_and_field() {
        let bad = parse(&SWEEP.replace("fluid.wi = [1, 2, 3]", "fluid.wi = [1, -2, 3]"));
        match expand(&bad).unwrap_err() {
            ConfigError::Case {
                index,
                label,
                error,
                file,
            } => {
                assert_eq!(index, 4);
                assert!(label.starts_with("wi=-2"), "{label}");
                assert_eq!(error.field, "fluid.wi");
                assert_eq!(file, Path::new("t.toml"));
            }
            e => panic!("wrong error {e}"),
        }
        let bad = parse(&SWEEP.replace("fluid.wi = [1, 2, 3]", "fluid.wi.x = [1]"));
        assert_eq!(expand(&bad).unwrap_err().field(), Some("fluid.wi"));
        let dup = parse(&SWEEP.replace("fluid.wi = [1, 2, 3]", "fluid.wi = [1, 1.0]"));
        assert!(matches!(
            expand(&dup).unwrap_err(),
            ConfigError::Case { index: 4, .. }
        ));
    }
}
