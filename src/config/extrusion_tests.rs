//! Tests of an extrusion case's validation: its scales, the mesh's grid lines, where its
//! particles may start, what a free surface supports, and the mesh refined at the die exit.

use serde_json::{json, Value};

use super::tests::{field_of, set, EXACT};
use super::*;

/// The §6.5.1 extrusion as a case table.
fn extrusion() -> Value {
    json!({
        "geometry": {"extrusion": {"die_length": 3.0, "extrudate_length": 4.0}},
        "fluid": {"model": "giesekus", "wi": 0.3, "alpha": 0.1},
        "particles": {"radius": 0.1, "layout": {"explicit": {"positions": [[-2.3, 0.8]]}}},
        "numerics": {"mesh": [140, 40], "dt": 0.04, "t_end": 10.0}
    })
}

/// An extrusion: Wi = λU/H0 with U = Q/H0, the default mesh height 2 H0; refused where the mesh
/// has no grid line on the die exit or wall, the particle does not start in the die, and for
/// what the free surface does not support, each naming its field.
#[test]
fn an_extrusion_resolves_its_scales_and_refuses_what_it_cannot_run() {
    let c = CaseSpec::from_value(extrusion()).unwrap();
    assert!((c.relaxation_time() - 0.3).abs() < EXACT);
    let mut q2 = extrusion();
    q2["geometry"]["extrusion"]["flow_rate"] = json!(2.0);
    q2["numerics"]["dt"] = json!(0.02);
    assert!((CaseSpec::from_value(q2).unwrap().relaxation_time() - 0.15).abs() < EXACT);
    let e = c.extrusion().unwrap();
    assert_eq!((e.h0, e.top), (1.0, case::DEFAULT_EXTRUSION_HEIGHT));
    assert_eq!(c.base_mesh().unwrap().n_elements(), 140 * 40);
    assert_eq!(
        field_of(set(extrusion(), "/numerics/mesh", json!([141, 40]))),
        "numerics.mesh"
    );
    assert_eq!(
        field_of(set(extrusion(), "/numerics/mesh", json!([140, 41]))),
        "numerics.mesh"
    );
    for at in [
        json!([[0.5, 0.5]]),
        json!([[-2.95, 0.5]]),
        json!([[-1.0, 0.95]]),
    ] {
        let v = set(
            extrusion(),
            "/particles/layout/explicit/positions",
            at.clone(),
        );
        assert_eq!(field_of(v), "particles.layout.explicit", "{at}");
    }
    let mut low = extrusion();
    low["geometry"]["extrusion"]["height"] = json!(0.9);
    assert_eq!(field_of(low), "geometry.extrusion.height");
    for (pointer, value, field) in [
        ("/numerics/method", json!("fdm"), "numerics.method"),
        ("/numerics/frame", json!("particle"), "numerics.frame"),
        ("/numerics/grading", json!(2.0), "numerics.grading"),
    ] {
        let mut v = extrusion();
        v["numerics"][&pointer[10..]] = value;
        assert_eq!(field_of(v), field, "{pointer}");
    }
}

/// `numerics.die_exit` sets the element counts (the mesh of `validate extrudate-swell --graded`:
/// h at the die-exit corner, grid lines through it) and refuses what cannot be built, each error
/// naming its field.
#[test]
fn a_die_exit_refinement_sets_the_mesh_and_refuses_what_it_cannot_build() {
    let refined = || {
        let mut v = extrusion();
        v["numerics"] = json!({"die_exit": {"h": 0.05}, "dt": 0.04, "t_end": 10.0});
        v
    };
    let c = CaseSpec::from_value(refined()).unwrap();
    let mesh = c.base_mesh().unwrap();
    assert_eq!(c.numerics.mesh, [mesh.ax.len(), mesh.ay.len()]);
    let e = c.extrusion().unwrap();
    let (ax, ay) = e.die_exit_axes(0.05, 0.2, 1.05, f64::INFINITY);
    assert_eq!(
        (&mesh.ax.vertices, &mesh.ay.vertices),
        (&ax.vertices, &ay.vertices)
    );
    assert!(e.has_grid_lines(&ax, &ay));
    assert!((mesh.ax.min_size() - 0.05).abs() < EXACT && (mesh.ay.min_size() - 0.05).abs() < EXACT);
    assert!(
        mesh.n_elements() < 140 * 40 / 2,
        "coarser away from the exit"
    );
    // the counts it makes may be given; others are refused
    let counts = c.numerics.mesh;
    let mut given = refined();
    given["numerics"]["mesh"] = json!(counts);
    assert_eq!(CaseSpec::from_value(given).unwrap(), c);
    let mut wrong = refined();
    wrong["numerics"]["mesh"] = json!([counts[0] + 1, counts[1]]);
    assert_eq!(field_of(wrong), "numerics.mesh");
    // without it the mesh is required
    let mut none = refined();
    none["numerics"].as_object_mut().unwrap().remove("die_exit");
    assert_eq!(field_of(none), "numerics.mesh");
    for (field, value, refused) in [
        ("h", json!(0.03), "numerics.die_exit.h"),
        ("h", json!(0.0), "numerics.die_exit.h"),
        ("h", json!(1e-12), "numerics.die_exit.h"),
        ("band", json!(1.5), "numerics.die_exit.band"),
        ("growth", json!(0.9), "numerics.die_exit.growth"),
        ("growth", json!(2.0), "numerics.die_exit.growth"),
        ("coarsest", json!(0.04), "numerics.die_exit.coarsest"),
    ] {
        let mut v = refined();
        v["numerics"]["die_exit"][field] = value;
        assert_eq!(field_of(v), refused, "{field}");
    }
    // capped: the die stays at most `coarsest` (the resolution a particle needs on its way)
    let mut capped = refined();
    capped["numerics"]["die_exit"]["coarsest"] = json!(0.1);
    let capped = CaseSpec::from_value(capped).unwrap().base_mesh().unwrap();
    let largest = |v: &[f64]| v.windows(2).map(|w| w[1] - w[0]).fold(0.0, f64::max);
    assert!(largest(&capped.ax.vertices) < 0.1 * 1.05 && largest(&mesh.ax.vertices) > 0.15);
    assert!(capped.n_elements() > mesh.n_elements());
    let mut shear = json!({
        "geometry": {"confined_shear": {"h": 1.0, "l": 4.0}},
        "fluid": {"model": "newtonian", "wi": 0.0},
        "particles": {"radius": 0.1, "layout": {"string": {"n": 3, "lx": 0.5, "ly": 0.1}}},
        "numerics": {"mesh": [200, 50], "dt": 0.01, "t_end": 1.0}
    });
    shear["numerics"]["die_exit"] = json!({"h": 0.05});
    assert_eq!(field_of(shear), "numerics.die_exit");
}
