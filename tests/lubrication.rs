//! The lubrication correction on free particles (issue 25, `solver::lubrication`): two
//! force- and torque-free cylinders pushed together by a planar straining flow approach at the
//! speed a film-resolving mesh gives, on a mesh whose film is a tenth of an element — the mesh
//! alone lets them approach more than twice as fast — and a resolved film is left alone.

use xpflow::fem::linsolve::SolverKind;
use xpflow::mesh::resolution::narrowest_gap;
use xpflow::mesh::{Axis, Mesh, Side};
use xpflow::solver::cutcells::compute_cuts;
use xpflow::solver::flow::{Stokes, StokesParams};
use xpflow::solver::lubrication::{Lubrication, RESOLVED_ELEMENTS};
use xpflow::solver::rigid::{Motion, Particle};
use xpflow::xfem::CutOptions;

/// Radius, gap and half-width of the box.
const A: f64 = 1.0;
const GAP: f64 = 0.02;
const BOX: f64 = 6.0;
/// Growth of the elements away from the refined bands.
const GROWTH: f64 = 1.12;

/// Agreement asked of the corrected approach speed on the coarse mesh with the film-resolving
/// mesh's: the correction's fit scatter (≈ 10 % in the film force, `solver::lubrication`) and the
/// coarse mesh's far field (h = 0.2a on the cylinders) that drives the approach.
const APPROACH_TOL: f64 = 0.15;

/// Relative round-off of two direct solves of the same system in different orderings.
const ROUND_OFF: f64 = 1e-9;

/// The mesh alone must be this far off for the test to show anything: at a tenth of an element
/// the film carries ≈ 40 % of its force (docs/validation.md), so the approach is ≈ 2.3× too fast.
const UNCORRECTED_MIN_ERROR: f64 = 0.5;

/// The approach speed W = U_x(left) − U_x(right) of the two free cylinders at (∓(a + g/2), 0) in
/// the straining flow u = (−x, y) imposed on the box's sides, on axes `ax`, `ay`.
fn approach_speed(ax: Axis, ay: Axis, lubrication: Option<Lubrication>) -> f64 {
    let mesh = Mesh::rectangle(ax, ay, false);
    let c = A + GAP / 2.0;
    let free = |center| Particle {
        center,
        radius: A,
        motion: Motion::Free,
    };
    let particles = vec![free([-c, 0.0]), free([c, 0.0])];
    let cuts = compute_cuts(&mesh, &particles, None, CutOptions::default()).expect("cuts");
    let film = narrowest_gap(&mesh, &[particles[0].center, particles[1].center], A);
    let unresolved = film.expect("two particles").elements < RESOLVED_ELEMENTS;
    let mut params = StokesParams::new(1.0, 0.0, SolverKind::Lblt);
    params.lubrication = lubrication;
    let mut st = Stokes::with_particles(mesh, params, particles, cuts);
    for side in [Side::Bottom, Side::Top, Side::Left, Side::Right] {
        st.set_velocity(side, |x| [-x[0], x[1]]);
    }
    st.pin_pressure();
    let sol = st.solve(&|_| [0.0, 0.0]).expect("solves");
    // the solve counts as corrected exactly when its film is under one element across
    assert_eq!(
        st.stats.lubricated_solves,
        usize::from(lubrication.is_some() && unresolved)
    );
    sol.rigid[0][0] - sol.rigid[1][0]
}

/// h = 0.2a over both cylinders: the film is a tenth of an element.
fn coarse() -> (Axis, Axis) {
    (
        Axis::banded(-BOX, BOX, -2.6, 2.6, 0.2, GROWTH),
        Axis::banded(-BOX, BOX, -1.4, 1.4, 0.2, GROWTH),
    )
}

#[test]
fn the_corrected_approach_on_a_coarse_mesh_is_the_resolved_one() {
    let lub = Some(Lubrication {
        viscosity: 1.0,
        walls: false,
    });
    // h = 0.02a = g around the film in both directions (one element across), growing outside
    let fine = || {
        (
            Axis::banded(-BOX, BOX, -0.11, 0.11, 0.02, GROWTH),
            Axis::banded(-BOX, BOX, -0.3, 0.3, 0.02, GROWTH),
        )
    };
    let (ax, ay) = fine();
    let resolved = approach_speed(ax, ay, None);
    let (ax, ay) = fine();
    let resolved_lub = approach_speed(ax, ay, lub);
    assert!(
        resolved > 0.0,
        "the strain pushes the cylinders together: W = {resolved}"
    );
    // one element across: no film to correct, the same solution (to the round-off of the
    // pattern's extra block between the particles)
    assert!(
        (resolved_lub - resolved).abs() < ROUND_OFF * resolved,
        "{resolved_lub} against {resolved}"
    );
    let (ax, ay) = coarse();
    let raw = approach_speed(ax, ay, None);
    let (ax, ay) = coarse();
    let corrected = approach_speed(ax, ay, lub);
    let (e_raw, e_corr) = (raw / resolved - 1.0, corrected / resolved - 1.0);
    eprintln!("W: resolved {resolved:.5e}, coarse {raw:.5e} ({e_raw:+.3}), corrected {corrected:.5e} ({e_corr:+.3})");
    assert!(e_raw > UNCORRECTED_MIN_ERROR, "the mesh alone: {e_raw:+.3}");
    assert!(e_corr.abs() < APPROACH_TOL, "corrected: {e_corr:+.3}");
}
