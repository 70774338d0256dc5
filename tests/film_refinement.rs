//! The film refinement of a following mesh (`numerics.follow.films`, issue 25) through the one
//! simulation path: a case's mesh gives the gap between near particles the elements asked for,
//! keeps them as the particles move, and leaves the mesh alone where no film is thin.

use serde_json::{json, Value};
use xpflow::config::CaseSpec;
use xpflow::simulate::Simulation;

/// Table 5.2's set-up (a = 0.1, Wi = 2, 200×62 graded: a/8 at the centre) with two particles
/// side by side `gap` apart and the film refinement `films`.
fn pair(gap: f64, films: Option<f64>) -> Value {
    let mut follow = json!({ "ratio": 1.0 });
    if let Some(e) = films {
        follow["films"] = json!(e);
    }
    json!({
        "geometry": { "confined_shear": { "h": 1.0, "l": 4.0 } },
        "fluid": { "model": "giesekus", "wi": 2.0, "alpha": 0.01, "beta": 0.1 },
        "particles": { "radius": 0.1, "layout": { "string": { "n": 2, "lx": 0.2 + gap, "ly": 0.0 } } },
        "numerics": { "mesh": [200, 62], "grading": 2.0, "grading_x": 3.0, "dt": 0.02,
                      "t_end": 0.06, "follow": follow }
    })
}

/// Elements of `mesh`'s columns between x0 and x1.
fn columns_between(mesh: &xpflow::mesh::Mesh, x0: f64, x1: f64) -> f64 {
    mesh.ax.index_coordinate(x1) - mesh.ax.index_coordinate(x0)
}

/// A film of 0.05a (0.4 elements of the fixed mesh) gets E columns across for E = 2 and 4; no
/// rows move (the film is along x), and a film of 0.6a (4.8 elements) leaves the mesh as it is.
#[test]
fn a_case_gives_a_thin_film_the_elements_asked_for() {
    let gap = 0.005;
    for e in [2.0, 4.0] {
        let case = CaseSpec::from_value(pair(gap, Some(e))).unwrap();
        let follow = case.following_mesh().expect("a following mesh");
        let mesh = follow.mesh_at(&case.initial_positions()).unwrap();
        let across = columns_between(&mesh, -gap / 2.0, gap / 2.0);
        assert!((across - e).abs() < 1e-9, "E = {e}: {across}");
        assert_eq!(mesh.ay, follow.base.ay);
        let fixed = columns_between(&follow.base, -gap / 2.0, gap / 2.0);
        assert!(fixed < 0.5, "{fixed}");
    }
    let case = CaseSpec::from_value(pair(0.06, Some(4.0))).unwrap();
    let follow = case.following_mesh().unwrap();
    let mesh = follow.mesh_at(&case.initial_positions()).unwrap();
    assert_eq!(mesh.ax, follow.base.ax);
}

/// Three steps of the pair: the mesh moves with the film, which keeps its four elements (the
/// sample's narrowest gap in elements), where the fixed mesh holds 0.4.
#[test]
fn the_film_keeps_its_elements_as_the_particles_move() {
    let gap = 0.005;
    for (films, lo, hi) in [(Some(4.0), 3.5, 4.5), (None, 0.3, 0.5)] {
        let mut sim = Simulation::new(&CaseSpec::from_value(pair(gap, films)).unwrap()).unwrap();
        for _ in 0..3 {
            sim.step().unwrap().into_report().unwrap();
        }
        let s = sim.sample();
        let elements = s.gap_elements.expect("two particles");
        assert!(
            elements > lo && elements < hi,
            "films {films:?}: {elements} elements"
        );
    }
}

/// The refinement is refused off the channel and below one element, naming the field.
#[test]
fn films_are_refused_where_they_do_not_apply() {
    let mut low = pair(0.01, Some(0.5));
    let e = CaseSpec::from_value(low.clone()).expect_err("below one element");
    assert_eq!(e.field, "numerics.follow.films");
    low["numerics"]["follow"]["films"] = json!(1.0);
    assert!(CaseSpec::from_value(low).is_ok());
    let couette = json!({
        "geometry": {"couette": {"r1": 1.0, "r2": 4.0}},
        "fluid": {"model": "giesekus", "wi": 1.0, "alpha": 0.1, "beta": 0.1},
        "particles": {"eps": 0.2, "layout": {"couette": {"r0_star": 0.5}}},
        "numerics": {"mesh": [40, 160], "dt": 0.01, "t_end": 10.0,
                     "follow": { "ratio": 1.0, "films": 4.0 }}
    });
    let e = CaseSpec::from_value(couette).expect_err("not a channel");
    assert_eq!(e.field, "numerics.follow.films", "{}", e.message);
}
