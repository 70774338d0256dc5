//! Expansion of a sweep file into cases, and case ids: FNV-1a 64 of the canonical JSON of the validated
//! case spec (keys sorted, defaults filled in, shorthands resolved), so the id is stable across runs,
//! machines and the way the case was written.

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

/// Expands a sweep into validated cases: the crossed axes (first varies slowest) times each zip group.
/// Errors name the file, the case index and label, and the field; identical cases are an error.
pub fn expand(sweep: &SweepSpec) -> Result<Vec<PlannedCase>, ConfigError> {
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
    let paths: Vec<&str> = sweep
        .axes
        .iter()
        .chain(sweep.zips.iter().flatten())
        .map(|a| a.path.as_str())
        .collect();
    let mut combos: Vec<Vec<(String, Value)>> = vec![Vec::new()];
    for dim in &dims {
        combos = combos
            .iter()
            .flat_map(|c| {
                dim.iter()
                    .map(move |assign| c.iter().cloned().chain(assign.iter().cloned()).collect())
            })
            .collect();
    }
    let mut cases: Vec<PlannedCase> = Vec::with_capacity(combos.len());
    for (index, params) in combos.into_iter().enumerate() {
        let label = label_of(&params, &paths);
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
        if let Some(twin) = cases.iter().find(|c| c.id == id) {
            return Err(case_err(SpecError::new(
                paths.first().copied().unwrap_or(""),
                format!(
                    "identical to case {} ({}); remove the duplicate axis value",
                    twin.index, twin.label
                ),
            )));
        }
        cases.push(PlannedCase {
            index,
            label,
            id,
            spec,
            params,
        });
    }
    Ok(cases)
}

fn label_of(params: &[(String, Value)], paths: &[&str]) -> String {
    if params.is_empty() {
        return "base".into();
    }
    let short = |p: &str| p.rsplit('.').next().unwrap_or(p).to_string();
    params
        .iter()
        .map(|(path, v)| {
            let s = short(path);
            let ambiguous = paths.iter().filter(|q| short(q) == s).count() > 1;
            let name = if ambiguous { path.clone() } else { s };
            let value = match v {
                Value::String(s) => s.clone(),
                other => other.to_string(),
            };
            format!("{name}={value}")
        })
        .collect::<Vec<_>>()
        .join(" ")
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
        assert_eq!(cases[0].label, "wi=1 n=2 dt=0.01 t_end=1.0");
        assert_eq!(cases[11].label, "wi=3 n=3 dt=0.02 t_end=2.0");
        assert_eq!(cases[11].spec.n_particles(), 3);
        assert_eq!(cases[11].spec.numerics.dt, 0.02);
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
