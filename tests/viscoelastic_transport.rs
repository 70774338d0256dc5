//! SUPG/BDF2 log-conformation transport alone (λ → ∞, G = 0): a smooth profile sheared by the
//! prescribed periodic velocity u = (1 + y/2, 0), convergence in h (Δt ∝ h) and in Δt. The full
//! studies (finer meshes, longer times) are `#[ignore]`d.

use xpflow::validate::viscoelastic::{transport_dt_study, transport_study};

/// Stored reference of the finest fast level (8·2³ = 64², Δt = h/2, t = 0.5), measured at commit
/// time; a change beyond 1 % means the scheme changed (STYLE §8).
const REF_ERROR_64: f64 = 4.290170e-3;
/// Relative tolerance against the stored reference values.
const REF_TOL: f64 = 0.01;

#[test]
fn transport_converges_at_second_order_in_h_with_dt_proportional_to_h() {
    let study = transport_study(8, 4, 0.5, 0.5).unwrap();
    println!("{}", study.to_markdown());
    assert!(study.passed(), "{}", study.to_markdown());
    let last = study.rows.last().unwrap().errors[0];
    println!("finest error {last:.6e}");
    assert!(
        (last - REF_ERROR_64).abs() < REF_TOL * REF_ERROR_64,
        "{last:e}"
    );
}

#[test]
fn transport_converges_at_second_order_in_dt() {
    let study = transport_dt_study(16, 0.025, 4).unwrap();
    println!("{}", study.to_markdown());
    assert!(study.passed(), "{}", study.to_markdown());
}

#[test]
#[ignore = "full study: 16² … 128², t = 1 (about 20 s)"]
fn transport_full_h_study() {
    let study = transport_study(16, 4, 0.5, 1.0).unwrap();
    println!("{}", study.to_markdown());
    assert!(study.passed(), "{}", study.to_markdown());
}

#[test]
#[ignore = "full study: 64² mesh (about 10 s)"]
fn transport_full_dt_study() {
    let study = transport_dt_study(64, 0.025, 4).unwrap();
    println!("{}", study.to_markdown());
    assert!(study.passed(), "{}", study.to_markdown());
}
