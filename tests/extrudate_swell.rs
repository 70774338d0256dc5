//! Extrudate swell (thesis §6.4), the Newtonian limit: the free surface immersed in the fixed
//! mesh, moved by the kinematic equation, reaches the steady test and swells as published.

use xpflow::validate::extrudate::{
    extrapolate, newtonian_swell, NEWTONIAN_SWELL, SWELL_DT, SWELL_TOL, SWELL_T_MAX,
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
