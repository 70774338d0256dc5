//! Right-hand side `g(L, s)` of the log-conformation equation (thesis Eqs. 2.7 and 5.7),
//! ```text
//!   ∂s/∂t + u·∇s = g(L, s),      s = log c,
//! ```
//! equivalent to the Giesekus conformation equation `dc/dt = L·c + c·Lᵀ + f(c)` with
//! `f(c) = −(1/λ)[(c − I) + α (c − I)²]` (Eq. 5.4). `L_ij = ∂u_i/∂x_j` is the usual velocity
//! gradient — the thesis writes the same function as `g((∇u)ᵀ, s)` because its `(∇u)_ij = ∂u_j/∂x_i`.
//!
//! # Derivation
//! Write `c = R Λ Rᵀ`, `Λ = diag(μ1, μ2)`, `s = R diag(σ1, σ2) Rᵀ`, `μ_a = e^{σ_a}` (the
//! eigen-decomposition of `s`, see [`Sym2::eigen`]) and `m = Rᵀ L R` (the velocity gradient in the
//! eigenbasis of `c`). Rotated into the eigenbasis, `dc/dt` has components
//! ```text
//!   (Rᵀ ċ R)_aa = 2 m_aa μ_a + f(μ_a),        (Rᵀ ċ R)_12 = m_12 μ2 + m_21 μ1,
//! ```
//! since `f(c)` is a polynomial in `c` and therefore diagonal there with eigenvalues
//! `f(μ) = −(1/λ)[(μ − 1) + α (μ − 1)²]`. The derivative of the matrix logarithm at `Λ` in a direction
//! `X` is (Daleckii–Krein) `[D log(Λ) X]_ab = X_ab (ln μ_a − ln μ_b)/(μ_a − μ_b)`, with the
//! diagonal limit `X_aa/μ_a`. Hence `ds/dt = R g̃ Rᵀ` with
//! ```text
//!   g̃_aa = 2 m_aa + f(μ_a)/μ_a,
//!   g̃_12 = (m_12 μ2 + m_21 μ1) (σ1 − σ2)/(μ1 − μ2) = m_12 ψ(σ1 − σ2) + m_21 ψ(σ2 − σ1),
//!   ψ(x) = x/(eˣ − 1)   (ψ(0) = 1),
//! ```
//! and `f(μ)/μ = −(1/λ)[(1 − e^{−σ}) + α (e^σ − 2 + e^{−σ})]`. In Cartesian form this is the
//! Fattal–Kupferman `g = Ω s − s Ω + 2B + (1/λ) e^{−s}(I − e^{s} − α (e^{s} − I)²)`: their decomposition
//! `L = Ω + B + N c⁻¹` has `B = R diag(m_11, m_22) Rᵀ`, `Ω = R [[0, ω], [−ω, 0]] Rᵀ` with
//! `ω = (μ2 m_12 + μ1 m_21)/(μ2 − μ1)`, and `(Ω s − s Ω)` has eigenbasis components
//! `ω (σ2 − σ1)` off the diagonal, which is `g̃_12` above; the relaxation term commutes with `c`.
//!
//! Equal eigenvalues: the FK spin `ω` is singular as `μ1 → μ2`, but `g̃_12` is not: `ψ` is smooth,
//! `ψ(0) = 1`, and at `σ1 = σ2` the result `g = L + Lᵀ + (f(μ)/μ) I` does not depend on the
//! (arbitrary) eigenbasis. Computing `ψ` with `expm1` keeps `g` continuous and exact to roundoff
//! across the coincidence, and no `e^{σ}` of a large `σ` is formed for the rotation part.

use super::model::Giesekus;
use super::tensor::{Sym2, VelocityGradient};

/// `ψ(x) = x/(eˣ − 1)`, `ψ(0) = 1`: the divided difference `(σ1 − σ2)/(e^{σ1} − e^{σ2})` times
/// `e^{σ2}`.
#[inline]
fn psi(x: f64) -> f64 {
    if x == 0.0 {
        1.0
    } else {
        x / x.exp_m1()
    }
}

/// `g(L, s)`: the right-hand side of the log-conformation equation `Ds/Dt = g(L, s)` for the
/// Giesekus model (Oldroyd-B for `α = 0`), see the module docs for the derivation.
/// `l` is the usual velocity gradient `L_ij = ∂u_i/∂x_j` (the thesis' `(∇u)ᵀ`).
#[inline]
pub fn log_conformation_rhs(model: &Giesekus, l: VelocityGradient, s: Sym2) -> Sym2 {
    let e = s.eigen();
    let [s1, s2] = e.values;
    let m = e.to_eigenbasis(l);
    let d = s1 - s2;
    let g_eig = Sym2::new(
        2.0 * m[0][0] + model.relaxation_over_eigenvalue(s1),
        m[0][1] * psi(d) + m[1][0] * psi(-d),
        2.0 * m[1][1] + model.relaxation_over_eigenvalue(s2),
    );
    e.from_eigenbasis(g_eig)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rheology::test_support::{rel_diff, TestRng};

    /// Central difference with step `H`: truncation ~H²·|c⃛|·|log'''| ≈ 1e-10 and roundoff
    /// ~eps·|log c|/H ≈ 1e-11 for the sampled spectra (log-eigenvalues in [−2.5, 2.5]); 1e-7
    /// relative leaves margin but would catch any wrong term (those are O(1)).
    const FD_TOL: f64 = 1e-7;
    const H: f64 = 1e-5;
    /// Continuity across equal eigenvalues: a split of 1e-9 in σ changes g by O(1e-9).
    const CONTINUITY_TOL: f64 = 1e-8;
    /// Closed-form values reached through an eigen-decomposition and back: a few ulps of O(1) terms.
    const ROUNDOFF_TOL: f64 = 1e-13;

    fn finite_difference_rhs(model: &Giesekus, l: VelocityGradient, c: Sym2) -> Sym2 {
        let cdot = model.conformation_rate(l, c);
        let plus = (c + H * cdot).log().expect("SPD for small H");
        let minus = (c - H * cdot).log().expect("SPD for small H");
        (1.0 / (2.0 * H)) * (plus - minus)
    }

    fn models() -> Vec<Giesekus> {
        vec![
            Giesekus::oldroyd_b(1.0, 1.0).unwrap(),
            Giesekus::new(0.7, 2.0, 0.2).unwrap(),
            Giesekus::new(3.0, 0.5, 0.5).unwrap(),
        ]
    }

    #[test]
    fn g_is_chain_rule_of_conformation_equation() {
        let mut rng = TestRng::new(2024);
        let mut worst: f64 = 0.0;
        for model in models() {
            for _ in 0..100 {
                let c = rng.spd(2.5);
                let l = rng.gradient(2.0);
                let got = log_conformation_rhs(&model, l, c.log().unwrap());
                let want = finite_difference_rhs(&model, l, c);
                let err = rel_diff(got, want);
                worst = worst.max(err);
                assert!(
                    err < FD_TOL,
                    "c = {c:?}, L = {l:?}: g = {got:?}, FD = {want:?}"
                );
            }
        }
        eprintln!("g vs finite differences: worst relative difference {worst:.2e}");
    }

    #[test]
    fn g_at_equal_and_near_equal_eigenvalues() {
        let mut rng = TestRng::new(5);
        for model in models() {
            for mu in [1.0, 0.2, 7.0] {
                let l = rng.gradient(2.0);
                let c = Sym2::scaled_identity(mu);
                let s = c.log().unwrap();
                let got = log_conformation_rhs(&model, l, s);
                assert!(got.is_finite());
                // Exact limit: g = L + Lᵀ + (f(μ)/μ) I.
                let exact = 2.0 * l.rate_of_deformation()
                    + Sym2::scaled_identity(model.relaxation(c).xx / mu);
                assert!(rel_diff(got, exact) < ROUNDOFF_TOL, "{got:?} vs {exact:?}");
                assert!(rel_diff(got, finite_difference_rhs(&model, l, c)) < FD_TOL);
                // Split the eigenvalues by 1e-9 in a random basis: g moves by O(1e-9).
                let split = Sym2::new(0.6, 0.8, -0.2).eigen();
                let near = split.compose([mu.ln() + 1e-9, mu.ln()]);
                let g_near = log_conformation_rhs(&model, l, near);
                assert!(
                    rel_diff(g_near, got) < CONTINUITY_TOL,
                    "{g_near:?} vs {got:?}"
                );
            }
        }
    }

    #[test]
    fn stress_free_state_at_rest_is_steady_and_oldroyd_b_shear_steady_state_is_a_root() {
        let g = Giesekus::new(1.0, 1.0, 0.3).unwrap();
        assert_eq!(
            log_conformation_rhs(&g, VelocityGradient::default(), Sym2::ZERO),
            Sym2::ZERO
        );
        // Oldroyd-B, u = (γ̇ y, 0), Wi = λγ̇ = 2: c = [[1 + 2 Wi², Wi], [Wi, 1]] is steady.
        let ob = Giesekus::oldroyd_b(1.0, 1.0).unwrap();
        let c = Sym2::new(9.0, 2.0, 1.0);
        let g = log_conformation_rhs(&ob, VelocityGradient::simple_shear(2.0), c.log().unwrap());
        assert!(g.norm() < ROUNDOFF_TOL, "{g:?}");
    }
}
