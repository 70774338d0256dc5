//! Semi-implicit polymer stress of D'Avino & Hulsen used in the flow solve (thesis Eqs. 5.26–5.27,
//! 5.51): the polymer stress at `t^{n+1}` replaced by one explicit step of the conformation equation
//! from `cⁿ`, with the new velocity gradient `L = L^{n+1}`,
//! ```text
//!   τ(c^{n+1}) = G Δt (−(u − u_m)·∇cⁿ + L·cⁿ + cⁿ·Lᵀ) + G h(cⁿ, Δt) − G I,
//!   h(cⁿ, Δt) = cⁿ − (Δt/λ)(cⁿ − I + α (cⁿ − I)²),       G = η_p/λ.
//! ```
//! (The thesis writes `(∇u)ᵀ·cⁿ + cⁿ·∇u`; with its `(∇u)_ij = ∂u_j/∂x_i` that is `L·cⁿ + cⁿ·Lᵀ`.)
//! Without the convection term this is affine in `L`, `τ_ij = A_ijkl L_kl + b_ij` with
//! ```text
//!   A_ijkl = G Δt (δ_ik cⁿ_lj + δ_jk cⁿ_il),      b = G (h(cⁿ, Δt) − I),
//! ```
//! because `(L·c)_ij = Σ_kl δ_ik c_lj L_kl` and `(c·Lᵀ)_ij = Σ_kl δ_jk c_il L_kl`. The flow solver
//! assembles `A` as a (solvent-like, anisotropic) viscosity and `b` as a load, so `η_s = 0` works.
//! The convection term `−G Δt (u − u_m)·∇cⁿ` is linear in `u` itself: the caller, who has `∇cⁿ`,
//! assembles it with the factor [`SemiImplicitStress::g_dt`].

use super::model::Giesekus;
use super::tensor::{Sym2, VelocityGradient};

/// `h(cⁿ, Δt) = cⁿ − (Δt/λ)(cⁿ − I + α (cⁿ − I)²)` (Eq. 5.27): `cⁿ` after one explicit relaxation
/// step.
#[inline]
pub fn relaxed_conformation(model: &Giesekus, c: Sym2, dt: f64) -> Sym2 {
    c + dt * model.relaxation(c)
}

/// The affine map `L ↦ τ(c^{n+1})` of Eq. 5.26 at one point (convection term excluded, see the
/// module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SemiImplicitStress {
    /// `A[i][j][k][l]`: `τ_ij = Σ_kl A_ijkl L_kl + b_ij` with `L_kl = ∂u_k/∂x_l`.
    pub coefficients: [[[[f64; 2]; 2]; 2]; 2],
    /// `b = G (h(cⁿ, Δt) − I)`.
    pub constant: Sym2,
    /// `G Δt`: the caller adds `−G Δt (u − u_m)·∇cⁿ` to the stress.
    pub g_dt: f64,
}

impl SemiImplicitStress {
    /// The map for the (projected) conformation `cⁿ` at a point and the time step `dt`.
    /// `cⁿ` need not be positive definite (an L²-projection, Eq. 5.28, may not be).
    ///
    /// # Panics
    /// In debug builds, if `dt` is not positive and finite (a broken contract of the time stepper).
    pub fn new(model: &Giesekus, c: Sym2, dt: f64) -> Self {
        debug_assert!(
            dt > 0.0 && dt.is_finite(),
            "time step {dt} must be positive"
        );
        let g = model.modulus();
        let g_dt = g * dt;
        let c_rows = c.to_rows();
        let mut a = [[[[0.0; 2]; 2]; 2]; 2];
        for (i, ai) in a.iter_mut().enumerate() {
            for (j, aij) in ai.iter_mut().enumerate() {
                for (k, aijk) in aij.iter_mut().enumerate() {
                    for (l, aijkl) in aijk.iter_mut().enumerate() {
                        let from_lc = if i == k { c_rows[l][j] } else { 0.0 };
                        let from_clt = if j == k { c_rows[i][l] } else { 0.0 };
                        *aijkl = g_dt * (from_lc + from_clt);
                    }
                }
            }
        }
        SemiImplicitStress {
            coefficients: a,
            constant: g * (relaxed_conformation(model, c, dt) - Sym2::IDENTITY),
            g_dt,
        }
    }

    /// `τ = A : L + b` for the velocity gradient `L` (`L_kl = ∂u_k/∂x_l`).
    pub fn stress(&self, l: VelocityGradient) -> Sym2 {
        let lr = l.to_rows();
        let contract = |i: usize, j: usize| {
            let a = &self.coefficients[i][j];
            a[0][0] * lr[0][0] + a[0][1] * lr[0][1] + a[1][0] * lr[1][0] + a[1][1] * lr[1][1]
        };
        self.constant + Sym2::new(contract(0, 0), contract(0, 1), contract(1, 1))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rheology::test_support::{rel_diff, TestRng};

    /// Same arithmetic in a different order: roundoff of O(1) terms only.
    const ALGEBRAIC_TOL: f64 = 1e-13;

    #[test]
    fn equals_one_explicit_euler_step_of_the_conformation_equation() {
        let mut rng = TestRng::new(99);
        let mut worst: f64 = 0.0;
        for model in [
            Giesekus::oldroyd_b(0.8, 1.3).unwrap(),
            Giesekus::new(2.0, 0.4, 0.2).unwrap(),
            Giesekus::new(1.0, 1.0, 0.5).unwrap(),
        ] {
            for dt in [1e-3, 1e-2, 0.1] {
                for _ in 0..30 {
                    let c = rng.spd(2.0);
                    let l = rng.gradient(2.0);
                    let c_next = c + dt * model.conformation_rate(l, c);
                    let want = model.stress(c_next);
                    let got = SemiImplicitStress::new(&model, c, dt).stress(l);
                    let err = rel_diff(got, want);
                    worst = worst.max(err);
                    assert!(err < ALGEBRAIC_TOL, "{got:?} vs {want:?}");
                }
            }
        }
        eprintln!("semi-implicit stress vs explicit Euler step: worst difference {worst:.2e}");
    }

    #[test]
    fn coefficients_are_the_derivative_and_symmetric_in_ij() {
        let model = Giesekus::new(1.5, 2.0, 0.1).unwrap();
        let c = Sym2::new(3.0, -0.7, 0.5);
        let dt = 0.05;
        let map = SemiImplicitStress::new(&model, c, dt);
        assert_eq!(map.stress(VelocityGradient::default()), map.constant);
        assert!(
            rel_diff(
                map.constant,
                model.stress(relaxed_conformation(&model, c, dt))
            ) < ALGEBRAIC_TOL
        );
        for k in 0..2 {
            for l in 0..2 {
                let mut unit = [[0.0; 2]; 2];
                unit[k][l] = 1.0;
                let column = map.stress(VelocityGradient::from_rows(unit)) - map.constant;
                let want = (model.modulus() * dt) * VelocityGradient::from_rows(unit).stretch(c);
                assert!(rel_diff(column, want) < ALGEBRAIC_TOL);
                for i in 0..2 {
                    for j in 0..2 {
                        let a = map.coefficients[i][j][k][l];
                        assert_eq!(a, map.coefficients[j][i][k][l]);
                        assert!((a - column.get(i, j)).abs() < ALGEBRAIC_TOL);
                    }
                }
            }
        }
        assert_eq!(map.g_dt, model.modulus() * dt);
    }
}
