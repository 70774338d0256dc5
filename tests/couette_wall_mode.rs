//! The explicit coupling's wall mode in the circular Couette cell (issue 26, docs/validation.md
//! "The explicit coupling's wall mode"), without a particle: `validate::couette_wall_mode` at
//! Wi = 1 on the family's 45×240 mesh (also `xpflow validate couette-wall-mode`).

use xpflow::validate::couette_wall_mode::{
    wall_mode_study, WallModeRun, FIT_FROM, MESH, STUDY_DT, STUDY_WI, T_END,
};

/// The explicit coupling at Δt = 0.08 grows the seeded m = 9 wall mode; at Δt = 0.02, or with the
/// semi-implicit stress at 0.08, it decays.
#[test]
#[ignore = "21 min on the shared two-core machine: cargo test --release --test couette_wall_mode -- --ignored --nocapture"]
fn the_explicit_coupling_grows_the_wall_mode_at_a_large_step() {
    let (runs, passed) = wall_mode_study(STUDY_WI, STUDY_DT, MESH, &mut |coupling, dt, t, a| {
        println!("{coupling:?} dt={dt}: t={t:.2} |c9|={a:.3e}");
    })
    .unwrap();
    let rates: Vec<f64> = runs.iter().map(WallModeRun::growth_rate).collect();
    println!("growth of |c9| per t* over t* {FIT_FROM}..{T_END}: {rates:?}");
    assert!(
        passed,
        "explicit dt 0.08, explicit dt 0.02, semi-implicit dt 0.08: {rates:?}"
    );
}
