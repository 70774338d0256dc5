//! Tests of the initial layouts' options.

use serde_json::{json, Value};

use super::*;

/// `layout.string.perturb` moves particle ⌊N/2⌋ off the point-symmetric layout and is in the
/// case id only when given; a non-finite one is refused, and one that makes particles overlap is
/// refused as any overlapping layout is.
#[test]
fn a_string_perturbation_moves_the_centre_particle_and_only_then_is_in_the_case_id() {
    let canonical = |v: Value| serde_json::to_value(CaseSpec::from_value(v).unwrap()).unwrap();
    let plain = json!({
        "geometry": {"confined_shear": {"h": 1.0, "l": 4.0}},
        "fluid": {"model": "giesekus", "wi": 2.0, "alpha": 0.01, "beta": 0.1},
        "particles": {"radius": 0.1, "layout": {"string": {"n": 3, "lx": 0.5, "ly": 0.1}}},
        "numerics": {"mesh": [440, 110], "dt": 0.01, "t_end": 100.0}
    });
    let layout = "/particles/layout/string";
    assert!(canonical(plain.clone())["particles"]["layout"]["string"]
        .get("perturb")
        .is_none());
    let mut moved = plain.clone();
    moved.pointer_mut(layout).unwrap()["perturb"] = json!([0.001, -0.002]);
    assert_ne!(canonical(moved.clone()), canonical(plain.clone()));
    let (a, b) = (
        CaseSpec::from_value(plain.clone())
            .unwrap()
            .initial_positions(),
        CaseSpec::from_value(moved).unwrap().initial_positions(),
    );
    let k = a.len() / 2;
    for (i, (p, q)) in a.iter().zip(&b).enumerate() {
        let d = if i == k { [0.001, -0.002] } else { [0.0, 0.0] };
        assert!((q[0] - p[0] - d[0]).abs() < 1e-15 && (q[1] - p[1] - d[1]).abs() < 1e-15);
    }
    let mut bad = plain.clone();
    bad.pointer_mut(layout).unwrap()["perturb"] = json!([f64::NAN, 0.0]);
    // (JSON has no NaN: serde_json writes null, refused by the parser as a wrong type)
    assert!(CaseSpec::from_value(bad).is_err());
    let mut overlap = plain;
    overlap.pointer_mut(layout).unwrap()["perturb"] = json!([0.45, 0.0]);
    let err = CaseSpec::from_value(overlap).expect_err("overlap");
    assert!(err.message.contains("overlap"), "{}", err.message);
}
