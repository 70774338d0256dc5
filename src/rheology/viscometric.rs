//! Analytic viscometric functions (references for tests and validation, `validation.md` §1).
//!
//! Simple shear `u = (γ̇ y, 0)`, `Wi = λ γ̇`, `β = η_s/η0`, normal stress differences
//! `N1 = τ_xx − τ_yy`, `N2 = τ_yy − τ_zz` (`τ_zz = 0` in planar shear: `c_zz = 1` solves the zz
//! equation). Steady Giesekus (Bird, Armstrong & Hassager 1987):
//! ```text
//!   Λ² = (sqrt(1 + 16 α(1−α) Wi²) − 1) / (8 α(1−α) Wi²),     f = (1 − Λ)/(1 + (1 − 2α) Λ),
//!   τ_xy/(η0γ̇) = β + (1−β)(1−f)²/(1 + (1−2α) f),
//!   N1/(η0γ̇) = 2(1−β) f (1 − α f)/(α Wi (1 − f)),            N2/(η0γ̇) = −(1−β) f/Wi,
//! ```
//! and the conformation `c_yy = 1 − f`, `c_xy = Wi (1−f)²/(1 + (1−2α) f)`,
//! `c_xx = 1 − f + 2 f (1 − α f)/(α (1 − f))`.
//!
//! These are 0/0 at `α = 0` and lose digits to cancellation for small `α Wi²`. With
//! `x = 16 α(1−α) Wi²` and `q = sqrt(1 + x)` they are evaluated as
//! `Λ² = 2/(q + 1)`, `1 − Λ = x/((q + 1)² (1 + Λ))`, hence `f = α Wi² k` with
//! `k = 16 (1−α)/((q + 1)² (1 + Λ)(1 + (1−2α) Λ))` (`k = 1` at `α = 0`), and `f/(α Wi) = Wi k`:
//! no cancellation, continuous down to `α = 0` where `k = 1` gives Oldroyd-B
//! (`τ_xy/(η0γ̇) = 1`, `N1/(η0γ̇) = 2(1−β) Wi`, `N2 = 0`), which is also coded separately.
//!
//! Oldroyd-B start-up of simple shear from rest at `t = 0`:
//! `τ_xy(t) = η_p γ̇ (1 − e^{−t/λ})`, `N1(t) = 2 η_p λ γ̇² (1 − e^{−t/λ}(1 + t/λ))`, `τ_yy = 0`.

use super::tensor::Sym2;

/// Steady shear functions scaled by `η0 γ̇`: total shear stress (solvent + polymer) and the normal
/// stress differences.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShearFunctions {
    /// `τ_xy/(η0 γ̇)` (the dimensionless shear viscosity `η/η0`).
    pub shear_stress: f64,
    /// `N1/(η0 γ̇)`.
    pub n1: f64,
    /// `N2/(η0 γ̇)`.
    pub n2: f64,
}

/// Polymer stresses of a start-up of simple shear (dimensional).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StartupShear {
    /// Polymer shear stress `τ_p,xy`.
    pub tau_xy: f64,
    /// First normal stress difference `N1 = τ_xx − τ_yy`.
    pub n1: f64,
}

/// `f` and `k = f/(α Wi²)` of the steady Giesekus shear flow, evaluated without cancellation.
fn giesekus_f_and_k(wi: f64, alpha: f64) -> (f64, f64) {
    let x = 16.0 * alpha * (1.0 - alpha) * wi * wi;
    let q = (1.0 + x).sqrt();
    let big_lambda = (2.0 / (q + 1.0)).sqrt();
    let k = 16.0 * (1.0 - alpha)
        / ((q + 1.0) * (q + 1.0) * (1.0 + big_lambda) * (1.0 + (1.0 - 2.0 * alpha) * big_lambda));
    (alpha * wi * wi * k, k)
}

fn check_shear_arguments(wi: f64, alpha: f64, beta: f64) {
    assert!(wi.is_finite(), "Weissenberg number {wi} must be finite");
    assert!(
        (0.0..1.0).contains(&alpha),
        "Giesekus mobility α = {alpha} must lie in [0, 1)"
    );
    assert!(
        (0.0..=1.0).contains(&beta),
        "viscosity ratio β = {beta} must lie in [0, 1]"
    );
}

/// Oldroyd-B (and UCM, `β = 0`) steady simple shear: `τ_xy/(η0γ̇) = 1`, `N1/(η0γ̇) = 2(1−β) Wi`,
/// `N2 = 0`.
///
/// # Panics
/// If `wi` is not finite or `β ∉ [0, 1]`.
pub fn oldroyd_b_steady_shear(wi: f64, beta: f64) -> ShearFunctions {
    check_shear_arguments(wi, 0.0, beta);
    ShearFunctions {
        shear_stress: 1.0,
        n1: 2.0 * (1.0 - beta) * wi,
        n2: 0.0,
    }
}

/// Giesekus steady simple shear (see the module docs), accurate and continuous for all
/// `0 ≤ α < 1` (Oldroyd-B branch at `α = 0`). Valid for either sign of `Wi`.
///
/// # Panics
/// If `wi` is not finite, `α ∉ [0, 1)` or `β ∉ [0, 1]`.
pub fn giesekus_steady_shear(wi: f64, alpha: f64, beta: f64) -> ShearFunctions {
    check_shear_arguments(wi, alpha, beta);
    if alpha == 0.0 {
        return oldroyd_b_steady_shear(wi, beta);
    }
    let (f, k) = giesekus_f_and_k(wi, alpha);
    let one_m_f = 1.0 - f;
    ShearFunctions {
        shear_stress: beta + (1.0 - beta) * one_m_f * one_m_f / (1.0 + (1.0 - 2.0 * alpha) * f),
        n1: 2.0 * (1.0 - beta) * wi * k * (1.0 - alpha * f) / one_m_f,
        n2: -(1.0 - beta) * alpha * wi * k,
    }
}

/// Steady conformation tensor `c` of the Giesekus model in simple shear `u = (γ̇ y, 0)` at
/// `Wi = λγ̇` (Oldroyd-B, `α = 0`: `[[1 + 2 Wi², Wi], [Wi, 1]]`).
///
/// # Panics
/// If `wi` is not finite or `α ∉ [0, 1)`.
pub fn giesekus_steady_shear_conformation(wi: f64, alpha: f64) -> Sym2 {
    check_shear_arguments(wi, alpha, 0.0);
    let (f, k) = giesekus_f_and_k(wi, alpha);
    let one_m_f = 1.0 - f;
    Sym2::new(
        one_m_f + 2.0 * wi * wi * k * (1.0 - alpha * f) / one_m_f,
        wi * one_m_f * one_m_f / (1.0 + (1.0 - 2.0 * alpha) * f),
        one_m_f,
    )
}

/// Oldroyd-B conformation in a start-up of simple shear from rest (`c = I` at `t = 0`), at
/// `Wi = λγ̇` and `t/λ`: `c_xy = Wi (1 − e^{−t/λ})`, `c_xx = 1 + 2 Wi² (1 − e^{−t/λ}(1 + t/λ))`,
/// `c_yy = 1`.
pub fn oldroyd_b_startup_conformation(wi: f64, t_over_lambda: f64) -> Sym2 {
    let decay = (-t_over_lambda).exp();
    let approach = -(-t_over_lambda).exp_m1(); // 1 − e^{−t/λ} without cancellation
    Sym2::new(
        1.0 + 2.0 * wi * wi * (approach - t_over_lambda * decay),
        wi * approach,
        1.0,
    )
}

/// Oldroyd-B start-up of simple shear: polymer shear stress and `N1` at time `t` (`validation.md` §1).
pub fn oldroyd_b_startup_shear(eta_p: f64, lambda: f64, shear_rate: f64, t: f64) -> StartupShear {
    let c = oldroyd_b_startup_conformation(lambda * shear_rate, t / lambda);
    let g = eta_p / lambda;
    StartupShear {
        tau_xy: g * c.xy,
        n1: g * (c.xx - c.yy),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rheology::model::Giesekus;
    use crate::rheology::tensor::VelocityGradient;

    /// Printed with 7 decimals: a correct value rounds to the printed one, |error| ≤ 0.5e-7
    /// (plus a hair for the binary representation of the printed decimal).
    const SEVENTH_DIGIT: f64 = 0.5e-7 + 1e-12;
    /// The printed form loses ~eps/(α Wi²)² to the cancellations in sqrt(1+x) − 1 and 1 − Λ;
    /// for the sampled α Wi² ≥ 1e-4 that is < 1e-8 relative.
    const PRINTED_FORM_TOL: f64 = 1e-8;
    /// Against 50-digit references: a cancellation-free double evaluation is good to ~1e-15;
    /// 1e-13 relative leaves margin for the ~20 operations.
    const HIGH_PRECISION_TOL: f64 = 1e-13;
    /// Residual of the steady conformation equation: roundoff of O(|c|) terms.
    const RESIDUAL_TOL: f64 = 1e-13;
    /// Central differences of the closed-form start-up with step 1e-5: truncation ~1e-10.
    const STARTUP_FD_TOL: f64 = 1e-8;

    /// `validation.md` §1 formulas verbatim.
    fn printed_form(wi: f64, alpha: f64, beta: f64) -> ShearFunctions {
        let a = 8.0 * alpha * (1.0 - alpha) * wi * wi;
        let big_lambda = (((1.0 + 2.0 * a).sqrt() - 1.0) / a).sqrt();
        let f = (1.0 - big_lambda) / (1.0 + (1.0 - 2.0 * alpha) * big_lambda);
        ShearFunctions {
            shear_stress: beta + (1.0 - beta) * (1.0 - f).powi(2) / (1.0 + (1.0 - 2.0 * alpha) * f),
            n1: 2.0 * (1.0 - beta) * f * (1.0 - alpha * f) / (alpha * wi * (1.0 - f)),
            n2: -(1.0 - beta) * f / wi,
        }
    }

    fn rel(a: f64, b: f64) -> f64 {
        (a - b).abs() / b.abs().max(1e-300)
    }

    #[test]
    fn reproduces_validation_table_to_seven_digits() {
        let table = [
            (0.2, 1.0 / 11.0, 1.0, 0.7629883, 1.1188127, -0.1016449),
            (0.2, 1.0 / 11.0, 5.0, 0.3413337, 1.1764511, -0.0752052),
            (0.2, 0.59, 1.0, 0.8931077, 0.5045845, -0.0458418),
            (0.5, 0.0, 1.0, 0.6180340, 0.9717365, -0.2138486),
        ];
        for (alpha, beta, wi, tau, n1, n2) in table {
            let v = giesekus_steady_shear(wi, alpha, beta);
            eprintln!(
                "α {alpha} β {beta:.4} Wi {wi}: {:.9} {:.9} {:.9}",
                v.shear_stress, v.n1, v.n2
            );
            assert!((v.shear_stress - tau).abs() <= SEVENTH_DIGIT, "{v:?}");
            assert!((v.n1 - n1).abs() <= SEVENTH_DIGIT, "{v:?}");
            assert!((v.n2 - n2).abs() <= SEVENTH_DIGIT, "{v:?}");
        }
    }

    #[test]
    fn stable_form_equals_printed_form() {
        for alpha in [0.01, 0.1, 0.2, 0.5, 0.7] {
            for wi in [0.1, 0.5, 1.0, 2.0, 5.0, 10.0] {
                for beta in [0.0, 0.1, 0.59] {
                    let (a, b) = (
                        giesekus_steady_shear(wi, alpha, beta),
                        printed_form(wi, alpha, beta),
                    );
                    assert!(rel(a.shear_stress, b.shear_stress) < PRINTED_FORM_TOL);
                    assert!(rel(a.n1, b.n1) < PRINTED_FORM_TOL, "{a:?} {b:?}");
                    assert!(rel(a.n2, b.n2) < PRINTED_FORM_TOL, "{a:?} {b:?}");
                }
            }
        }
    }

    #[test]
    fn small_alpha_is_continuous_with_oldroyd_b() {
        let alpha = 1e-6;
        for wi in [0.5, 1.0, 2.0, 3.0] {
            for beta in [0.0, 0.1] {
                let ob = oldroyd_b_steady_shear(wi, beta);
                let g = giesekus_steady_shear(wi, alpha, beta);
                // Physically the values differ by O(α Wi²): to first order τ_xy/(η0γ̇) = 1 − 3(1−β)α Wi²,
                // N1/(η0γ̇) = 2(1−β) Wi (1 − 5 α Wi²), N2/(η0γ̇) = −(1−β) α Wi: below 6 α Wi² ≤ 5.4e-5.
                let bound = 6.0 * alpha * wi * wi;
                assert!(rel(g.shear_stress, ob.shear_stress) < bound, "{g:?}");
                assert!(rel(g.n1, ob.n1) < bound, "{g:?}");
                assert!(g.n2.abs() < bound, "{g:?}");
                // The general formula at α = 0 is exactly Oldroyd-B (k = 1).
                let c = giesekus_steady_shear_conformation(wi, 0.0);
                assert_eq!(c, Sym2::new(1.0 + 2.0 * wi * wi, wi, 1.0));
            }
        }
        assert_eq!(
            giesekus_steady_shear(2.0, 0.0, 0.1),
            oldroyd_b_steady_shear(2.0, 0.1)
        );
    }

    #[test]
    fn small_alpha_matches_high_precision_values() {
        // The printed form evaluated with 50-digit arithmetic (mpmath), β = 0. In double precision
        // the printed form itself loses digits to cancellation (measured: 3e-6 relative in N1 at
        // α = 1e-6, Wi = 1).
        let reference = [
            (
                1e-6,
                1.0,
                0.9999970000239997,
                1.999990000091999,
                -9.999940000579993e-07,
            ),
            (
                1e-6,
                3.0,
                0.9999730017998434,
                5.999730020626088,
                -2.999838013012766e-06,
            ),
            (
                1e-3,
                1.0,
                0.9970237568246064,
                1.9900910079584821,
                -0.0009940573598226866,
            ),
            (
                1e-3,
                3.0,
                0.974657376315496,
                5.748893239906778,
                -0.0028498953693294675,
            ),
        ];
        let mut worst: f64 = 0.0;
        for (alpha, wi, tau, n1, n2) in reference {
            let g = giesekus_steady_shear(wi, alpha, 0.0);
            worst = worst
                .max(rel(g.shear_stress, tau))
                .max(rel(g.n1, n1))
                .max(rel(g.n2, n2));
            assert!(rel(g.shear_stress, tau) < HIGH_PRECISION_TOL, "{g:?}");
            assert!(rel(g.n1, n1) < HIGH_PRECISION_TOL, "{g:?}");
            assert!(rel(g.n2, n2) < HIGH_PRECISION_TOL, "{g:?}");
            // The printed form in double precision, for the record.
            let p = printed_form(wi, alpha, 0.0);
            eprintln!(
                "α {alpha} Wi {wi}: printed form in f64 off by {:.1e} (N1)",
                rel(p.n1, n1)
            );
        }
        eprintln!("small α vs 50-digit reference: worst relative error {worst:.2e}");
    }

    #[test]
    fn steady_conformation_solves_the_conformation_equation() {
        for alpha in [0.0, 1e-6, 0.01, 0.2, 0.5, 0.7] {
            for wi in [-2.0_f64, 0.0, 0.3, 1.0, 3.0, 10.0] {
                // γ̇ = 1, λ = Wi (Wi = 0: any λ, the flow is at rest).
                let lambda = if wi == 0.0 { 1.0 } else { wi.abs() };
                let rate = if wi == 0.0 { 0.0 } else { wi.signum() };
                let model = Giesekus::new(lambda, 1.0, alpha).unwrap();
                let c = giesekus_steady_shear_conformation(wi, alpha);
                let residual = model.conformation_rate(VelocityGradient::simple_shear(rate), c);
                assert!(
                    residual.norm() < RESIDUAL_TOL * c.norm(),
                    "α {alpha} Wi {wi}: {residual:?}"
                );
                assert!(c.is_positive_definite());
                // Consistency with the shear functions (β = 0: τ/(η0γ̇) = (c − I)/Wi).
                if wi != 0.0 {
                    let v = giesekus_steady_shear(wi, alpha, 0.0);
                    assert!(rel(v.shear_stress, c.xy / wi) < RESIDUAL_TOL);
                    assert!(rel(v.n1, (c.xx - c.yy) / wi) < RESIDUAL_TOL);
                    assert!((v.n2 - (c.yy - 1.0) / wi).abs() < RESIDUAL_TOL);
                }
            }
        }
    }

    #[test]
    fn startup_closed_form_solves_the_ode_and_tends_to_steady_state() {
        let (h, wi) = (1e-5, 1.7);
        let model = Giesekus::oldroyd_b(1.0, 1.0).unwrap();
        assert_eq!(oldroyd_b_startup_conformation(wi, 0.0), Sym2::IDENTITY);
        for t in [0.1, 0.5, 1.0, 3.0] {
            let c = oldroyd_b_startup_conformation(wi, t);
            let dcdt = (1.0 / (2.0 * h))
                * (oldroyd_b_startup_conformation(wi, t + h)
                    - oldroyd_b_startup_conformation(wi, t - h));
            let rhs = model.conformation_rate(VelocityGradient::simple_shear(wi), c);
            assert!((dcdt - rhs).norm() < STARTUP_FD_TOL * c.norm(), "t = {t}");
        }
        let late = oldroyd_b_startup_shear(2.0, 0.5, 3.0, 60.0);
        let steady = oldroyd_b_steady_shear(1.5, 0.0);
        // η0 = η_p = 2, γ̇ = 3: τ_xy = 6 τ̂, N1 = 6 N̂1.
        assert!(rel(late.tau_xy, 6.0 * steady.shear_stress) < RESIDUAL_TOL);
        assert!(rel(late.n1, 6.0 * steady.n1) < RESIDUAL_TOL);
    }
}
