//! Fast Stokes checks (coarse meshes); the full studies run with `make validate`.

use xpflow::fem::linsolve::SolverKind;
use xpflow::validate::stokes::{circular_couette, plane_couette_max_error, stokes_mms, Domain};

/// Plane Couette is in the Q2 space: nodal errors at round-off of a well-conditioned solve.
const ROUND_OFF: f64 = 1e-11;

#[test]
fn plane_couette_is_reproduced_to_round_off() {
    for with_g in [false, true] {
        let err = plane_couette_max_error(with_g).unwrap();
        assert!(err < ROUND_OFF, "with_g={with_g}: {err:e}");
    }
}

#[test]
fn stokes_mms_rates_channel_and_annulus() {
    for domain in [Domain::Channel, Domain::Annulus] {
        for with_g in [false, true] {
            let study = stokes_mms(domain, with_g, 4, SolverKind::Lblt).unwrap();
            println!("{}", study.to_markdown());
            assert!(study.passed(), "{}", study.to_markdown());
        }
    }
}

#[test]
fn lu_and_lblt_agree_on_stokes() {
    let a = stokes_mms(Domain::Channel, true, 2, SolverKind::Lblt).unwrap();
    let b = stokes_mms(Domain::Channel, true, 2, SolverKind::Lu).unwrap();
    for (ra, rb) in a.rows.iter().zip(&b.rows) {
        for (ea, eb) in ra.errors.iter().zip(&rb.errors) {
            // both solve the same system to ~1e-12 relative; errors agree to many digits
            assert!((ea - eb).abs() <= 1e-8 * ea.abs(), "{ea} vs {eb}");
        }
    }
}

#[test]
fn circular_couette_converges() {
    let study = circular_couette(4).unwrap();
    println!("{}", study.to_markdown());
    assert!(study.passed(), "{}", study.to_markdown());
}

#[test]
fn an_unchanged_matrix_reuses_its_factorization() {
    use xpflow::mesh::{Axis, Mesh, Side};
    use xpflow::solver::flow::{Stokes, StokesParams};
    let mesh = Mesh::rectangle(Axis::uniform(0.0, 2.0, 8), Axis::uniform(0.0, 1.0, 4), true);
    let mut st = Stokes::new(mesh, StokesParams::new(1.0, 0.0, SolverKind::Lblt));
    st.set_velocity(Side::Bottom, |_| [0.0, 0.0]);
    st.set_velocity(Side::Top, |_| [1.0, 0.0]);
    st.pin_pressure();
    let a = st.solve(&|x| [x[1], 0.0]).unwrap();
    // same matrix, another load: no new factorization, and the solution follows the load
    let b = st.solve(&|x| [2.0 * x[1], 0.0]).unwrap();
    assert_eq!(st.refactorizations, 1);
    assert!(a
        .u
        .iter()
        .zip(&b.u)
        .any(|(p, q)| (p[0] - q[0]).abs() > 1e-3));
    // a changed viscosity changes the matrix: refactorized
    st.params.eta = 2.0;
    st.solve(&|x| [x[1], 0.0]).unwrap();
    assert_eq!(st.refactorizations, 2);
}
