//! Extrudate swell (thesis §6.4), the Newtonian limit: the free surface immersed in the fixed
//! mesh, moved by the kinematic equation, reaches the steady test and swells as published; the
//! UCM extrudate with its fully developed inflow stress; the sweep of the study is the study.

use std::path::Path;

use xpflow::config::SweepSpec;
use xpflow::sweep::expand::expand;
use xpflow::validate::extrudate::{
    extrapolate, newtonian_swell, swell, swell_dt, SwellMesh, NEWTONIAN_SWELL, PUBLISHED_SWELL,
    SWELL_DT, SWELL_TOL, SWELL_T_MAX,
};

/// The coarse mesh (h = 0.1, 750 elements, seconds): steady, pinned at the die exit, rising
/// monotonically to a swell above the published 1.188 by at most the first-order error this
/// mesh showed (measured 1.1963; h = 0.05 gives 1.1922: the error halves with h).
#[test]
fn the_coarse_extrudate_swells_and_settles() {
    // the h = 0.1 error measured (8.3e-3) with room for round-off changes, not for a new result
    const COARSE_ERROR: f64 = 1e-2;
    let r = newtonian_swell(0.1, SWELL_DT, SWELL_T_MAX).unwrap();
    assert!(r.steady, "steady test not met: {:.2e}", r.last_change);
    assert_eq!(r.profile[0], (0.0, 1.0), "H(0) = H0");
    let rise: Vec<f64> = r.profile.iter().map(|p| p.1).collect();
    let peak = rise.iter().copied().fold(f64::MIN, f64::max);
    let top = rise.iter().position(|&y| y == peak).unwrap();
    assert!(
        rise[..=top].windows(2).all(|w| w[1] >= w[0]),
        "rises to its maximum"
    );
    assert!(
        r.swell > NEWTONIAN_SWELL && r.swell < NEWTONIAN_SWELL + COARSE_ERROR,
        "swell {}",
        r.swell
    );
}

/// The validation (`xpflow validate extrudate-swell`, ≈ 10 min): h = 0.1, 0.05, 0.025 converge
/// to the published swell after extrapolation.
#[test]
#[ignore]
fn the_extrudate_swell_converges_to_the_published_ratio() {
    let s: Vec<f64> = [0.1, 0.05, 0.025]
        .iter()
        .map(|&h| newtonian_swell(h, SWELL_DT, SWELL_T_MAX).unwrap().swell)
        .collect();
    let order = ((s[0] - s[1]) / (s[1] - s[2])).log2();
    let e = extrapolate(s[1], s[2], order);
    assert!(
        (e - NEWTONIAN_SWELL).abs() <= SWELL_TOL,
        "{s:?} → {e} (order {order})"
    );
}

/// The UCM extrudate (thesis §6.4) at De = 0.25 on the coarse graded mesh (h = 0.1 at the die exit,
/// 476 elements, ≈ 10 s): the stress enters fully developed and stays so in the die, the surface
/// settles, and the swell dips below the Newtonian one on the same mesh as Table 6.3's does
/// (1.168 against 1.188: −1.68 %; measured −1.73 % with Δt = 0.04, −1.67 % with 0.05). The dip is the elastic effect the mesh
/// resolves at low De; at higher De the swell converges slowly with h (docs/validation.md).
#[test]
fn the_ucm_extrudate_dips_below_the_newtonian_swell_as_published() {
    // the published dip, and the room this mesh needs (measured 0.05 % off)
    const PUBLISHED_DIP: f64 = 1.168 / 1.188 - 1.0;
    const COARSE_DIP_TOL: f64 = 3e-3;
    // the die's conformation against the fully developed one: measured 1.6e-3 (Q1 on h = 0.1)
    const DIE_TOL: f64 = 1e-2;
    let grid = SwellMesh {
        h: 0.1,
        graded: true,
    };
    let newtonian = swell(grid, 0.0, SWELL_DT, SWELL_T_MAX).unwrap();
    let ucm = swell(grid, 0.25, swell_dt(0.25), SWELL_T_MAX).unwrap();
    assert!(ucm.steady, "steady test not met: {:.2e}", ucm.last_change);
    assert!(ucm.die_error < DIE_TOL, "die: {:.2e}", ucm.die_error);
    assert_eq!(ucm.profile[0], (0.0, 1.0), "H(0) = H0");
    let dip = ucm.swell / newtonian.swell - 1.0;
    assert!(
        (dip - PUBLISHED_DIP).abs() < COARSE_DIP_TOL,
        "dip {dip:.4} (swell {} against {})",
        ucm.swell,
        newtonian.swell
    );
}

/// One path: the cases of `sweeps/extrudate_swell.toml` are the validation study's on its
/// h = 0.025 graded mesh (`xpflow validate extrudate-swell --graded --h 0.025`), field for field,
/// and that mesh is the one refined at the die exit: 3696 elements, h at the corner (0, H0)
/// with grid lines through it, coarser away from it.
#[test]
fn the_swell_sweep_is_the_validation_study() {
    let sweep = SweepSpec::from_file(Path::new("sweeps/extrudate_swell.toml")).unwrap();
    let cases = expand(&sweep).unwrap();
    assert_eq!(cases.len(), 9);
    let grid = SwellMesh {
        h: 0.025,
        graded: true,
    };
    // (the sweep's Wi are the study's De/3 to the last bit: 0.6/3 is 0.19999999999999998)
    for (c, &(de, ..)) in cases.iter().zip(&PUBLISHED_SWELL) {
        let study = grid.case(de, swell_dt(de), SWELL_T_MAX).unwrap();
        assert_eq!(c.spec.geometry, study.geometry, "{}", c.label);
        assert_eq!(c.spec.fluid, study.fluid, "{}", c.label);
        assert_eq!(c.spec.numerics, study.numerics, "{}", c.label);
    }
    let mesh = cases[0].spec.base_mesh().unwrap();
    assert_eq!(cases[0].spec.numerics.mesh, [mesh.ax.len(), mesh.ay.len()]);
    assert_eq!(mesh.n_elements(), 3696);
    let (ax, ay) = (&mesh.ax, &mesh.ay);
    let (i, j) = (ax.locate(1e-6), ay.locate(1.0 + 1e-6));
    assert!((ax.vertices[i]).abs() < 1e-12 && (ay.vertices[j] - 1.0).abs() < 1e-12);
    assert!((ax.vertices[i + 1] - ax.vertices[i] - 0.025).abs() < 1e-12);
    assert!((ay.vertices[j + 1] - ay.vertices[j] - 0.025).abs() < 1e-12);
    assert!(
        ax.vertices[1] - ax.vertices[0] > 0.1,
        "coarse at the inflow"
    );
}
