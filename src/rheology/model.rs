//! Constitutive models: the Giesekus polymer [`Giesekus`] (Oldroyd-B for `α = 0`) and the
//! [`Fluid`] = solvent + polymer (UCM for `η_s = 0`).
//!
//! Conformation equation (thesis Eq. 5.4, Eq. 2.4 for `α = 0`), upper-convected derivative Eq. 2.5:
//! ```text
//!   λ c^∇ + (c − I) + α (c − I)² = 0,     c^∇ = ∂c/∂t + u·∇c − L·c − c·Lᵀ,
//! ```
//! so along a particle path `dc/dt = L·c + c·Lᵀ + f(c)` with the relaxation term
//! `f(c) = −(1/λ)[(c − I) + α (c − I)²]`. Polymer stress (Eq. 5.6): `τ = G (c − I)`, `G = η_p/λ`.
//! Total extra stress (Eq. 5.3 without the pressure): `2 η_s D + τ`.

use super::tensor::{Sym2, VelocityGradient};
use super::RheologyError;

/// Giesekus polymer contribution: relaxation time `λ`, polymer viscosity `η_p`, mobility `α`.
/// `α = 0` is Oldroyd-B. Fields are private: a value exists only once validated.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Giesekus {
    lambda: f64,
    eta_p: f64,
    alpha: f64,
}

impl Giesekus {
    /// Validated Giesekus polymer.
    ///
    /// # Errors
    /// [`RheologyError::RelaxationTime`] unless `λ > 0` (finite); [`RheologyError::Viscosity`] unless
    /// `η_p ≥ 0` (finite); [`RheologyError::Mobility`] unless `0 ≤ α < 1` (0.5 < α < 1 is accepted,
    /// although outside the physical range).
    pub fn new(lambda: f64, eta_p: f64, alpha: f64) -> Result<Self, RheologyError> {
        if !(lambda > 0.0 && lambda.is_finite()) {
            return Err(RheologyError::RelaxationTime(lambda));
        }
        check_viscosity("η_p", eta_p)?;
        if !(0.0..1.0).contains(&alpha) {
            return Err(RheologyError::Mobility(alpha));
        }
        Ok(Giesekus {
            lambda,
            eta_p,
            alpha,
        })
    }

    /// Oldroyd-B polymer (`α = 0`).
    ///
    /// # Errors
    /// As [`Giesekus::new`].
    pub fn oldroyd_b(lambda: f64, eta_p: f64) -> Result<Self, RheologyError> {
        Giesekus::new(lambda, eta_p, 0.0)
    }

    /// Relaxation time `λ`.
    pub fn lambda(&self) -> f64 {
        self.lambda
    }

    /// Polymer viscosity `η_p`.
    pub fn eta_p(&self) -> f64 {
        self.eta_p
    }

    /// Mobility `α`.
    pub fn alpha(&self) -> f64 {
        self.alpha
    }

    /// Elastic modulus `G = η_p/λ`.
    pub fn modulus(&self) -> f64 {
        self.eta_p / self.lambda
    }

    /// Polymer stress `τ = G (c − I)` (Eq. 5.6).
    pub fn stress(&self, c: Sym2) -> Sym2 {
        self.modulus() * (c - Sym2::IDENTITY)
    }

    /// Relaxation term `f(c) = −(1/λ)[(c − I) + α (c − I)²]`, so that `c^∇ = f(c)` (Eq. 5.4).
    pub fn relaxation(&self, c: Sym2) -> Sym2 {
        let d = c - Sym2::IDENTITY;
        (-1.0 / self.lambda) * (d + self.alpha * d.square())
    }

    /// `dc/dt = L·c + c·Lᵀ + f(c)` of a homogeneous deformation with velocity gradient `L`.
    pub fn conformation_rate(&self, l: VelocityGradient, c: Sym2) -> Sym2 {
        l.stretch(c) + self.relaxation(c)
    }

    /// The relaxation term divided by the eigenvalue, `f(μ)/μ` with `μ = e^σ`, for an eigenvalue
    /// `σ` of `s = log c`: `−(1/λ)[(1 − e^{−σ}) + α (e^σ − 2 + e^{−σ})]`, evaluated without
    /// cancellation near `σ = 0` as `−(1/λ)[−expm1(−σ) + 4α sinh²(σ/2)]`.
    pub(crate) fn relaxation_over_eigenvalue(&self, sigma: f64) -> f64 {
        let sh = (0.5 * sigma).sinh();
        -((-(-sigma).exp_m1()) + 4.0 * self.alpha * sh * sh) / self.lambda
    }
}

/// A viscoelastic fluid: Newtonian solvent `η_s` plus a Giesekus polymer (`η_p`, `λ`, `α`).
/// Oldroyd-B for `α = 0`, UCM for `α = 0, η_s = 0`; `η_s = 0` is supported by the semi-implicit
/// stress coupling. Fields are private: a value exists only once validated.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fluid {
    eta_s: f64,
    polymer: Giesekus,
}

impl Fluid {
    /// Validated fluid.
    ///
    /// # Errors
    /// As [`Giesekus::new`]; [`RheologyError::Viscosity`] unless `η_s ≥ 0` (finite);
    /// [`RheologyError::ZeroViscosity`] if `η0 = η_s + η_p = 0`.
    pub fn new(eta_s: f64, eta_p: f64, lambda: f64, alpha: f64) -> Result<Self, RheologyError> {
        check_viscosity("η_s", eta_s)?;
        let polymer = Giesekus::new(lambda, eta_p, alpha)?;
        if eta_s + eta_p == 0.0 {
            return Err(RheologyError::ZeroViscosity);
        }
        Ok(Fluid { eta_s, polymer })
    }

    /// Fluid from the zero-shear viscosity `η0` and the viscosity ratio `β = η_s/η0`
    /// (`η_s = β η0`, `η_p = (1 − β) η0`), as the sweeps specify it.
    ///
    /// # Errors
    /// [`RheologyError::Viscosity`] unless `η0 > 0` (finite); [`RheologyError::ViscosityRatio`]
    /// unless `0 ≤ β ≤ 1`; otherwise as [`Fluid::new`].
    pub fn from_ratio(
        eta0: f64,
        beta: f64,
        lambda: f64,
        alpha: f64,
    ) -> Result<Self, RheologyError> {
        if !(eta0 > 0.0 && eta0.is_finite()) {
            return Err(RheologyError::Viscosity {
                name: "η0",
                value: eta0,
            });
        }
        if !(0.0..=1.0).contains(&beta) {
            return Err(RheologyError::ViscosityRatio(beta));
        }
        Fluid::new(beta * eta0, (1.0 - beta) * eta0, lambda, alpha)
    }

    /// Oldroyd-B fluid (`α = 0`).
    ///
    /// # Errors
    /// As [`Fluid::new`].
    pub fn oldroyd_b(eta_s: f64, eta_p: f64, lambda: f64) -> Result<Self, RheologyError> {
        Fluid::new(eta_s, eta_p, lambda, 0.0)
    }

    /// Upper-convected Maxwell fluid (`α = 0`, `η_s = 0`).
    ///
    /// # Errors
    /// As [`Fluid::new`] (in particular `η_p > 0` is needed).
    pub fn ucm(eta_p: f64, lambda: f64) -> Result<Self, RheologyError> {
        Fluid::new(0.0, eta_p, lambda, 0.0)
    }

    /// Solvent viscosity `η_s`.
    pub fn eta_s(&self) -> f64 {
        self.eta_s
    }

    /// Polymer viscosity `η_p`.
    pub fn eta_p(&self) -> f64 {
        self.polymer.eta_p()
    }

    /// Relaxation time `λ`.
    pub fn lambda(&self) -> f64 {
        self.polymer.lambda()
    }

    /// Giesekus mobility `α`.
    pub fn alpha(&self) -> f64 {
        self.polymer.alpha()
    }

    /// The polymer part.
    pub fn polymer(&self) -> Giesekus {
        self.polymer
    }

    /// Zero-shear viscosity `η0 = η_s + η_p` (> 0).
    pub fn eta0(&self) -> f64 {
        self.eta_s + self.polymer.eta_p()
    }

    /// Viscosity ratio `β = η_s/η0`.
    pub fn beta(&self) -> f64 {
        self.eta_s / self.eta0()
    }

    /// Weissenberg number `Wi = λ γ̇` for a characteristic rate `γ̇`.
    pub fn weissenberg(&self, rate: f64) -> f64 {
        self.polymer.lambda() * rate
    }

    /// `true` for UCM / Giesekus without solvent (`η_s = 0`).
    pub fn has_no_solvent(&self) -> bool {
        self.eta_s == 0.0
    }

    /// Extra stress `2 η_s D(L) + τ(c)` (Eq. 5.3 without `−p I`).
    pub fn extra_stress(&self, l: VelocityGradient, c: Sym2) -> Sym2 {
        2.0 * self.eta_s * l.rate_of_deformation() + self.polymer.stress(c)
    }
}

fn check_viscosity(name: &'static str, value: f64) -> Result<(), RheologyError> {
    if value >= 0.0 && value.is_finite() {
        Ok(())
    } else {
        Err(RheologyError::Viscosity { name, value })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Products/quotients of a few exactly representable inputs: a few ulps.
    const ARITH_TOL: f64 = 1e-15;
    /// The direct form `f(μ)/μ` loses ~1 ulp of 1 to the cancellation in `μ − 1`; absolute.
    const EIGEN_FORM_TOL: f64 = 1e-14;

    #[test]
    fn constructors_validate() {
        assert!(matches!(
            Giesekus::new(0.0, 1.0, 0.1),
            Err(RheologyError::RelaxationTime(_))
        ));
        assert!(matches!(
            Giesekus::new(f64::NAN, 1.0, 0.1),
            Err(RheologyError::RelaxationTime(_))
        ));
        assert!(matches!(
            Giesekus::new(1.0, -1.0, 0.1),
            Err(RheologyError::Viscosity { .. })
        ));
        assert!(matches!(
            Giesekus::new(1.0, 1.0, -0.1),
            Err(RheologyError::Mobility(_))
        ));
        assert!(matches!(
            Giesekus::new(1.0, 1.0, 1.0),
            Err(RheologyError::Mobility(_))
        ));
        assert!(Giesekus::new(1.0, 1.0, 0.7).is_ok());
        assert!(Giesekus::new(1.0, 0.0, 0.0).is_ok());
        assert!(matches!(
            Fluid::new(-1.0, 1.0, 1.0, 0.0),
            Err(RheologyError::Viscosity { .. })
        ));
        assert!(matches!(
            Fluid::new(0.0, 0.0, 1.0, 0.0),
            Err(RheologyError::ZeroViscosity)
        ));
        assert!(matches!(
            Fluid::from_ratio(1.0, 1.5, 1.0, 0.0),
            Err(RheologyError::ViscosityRatio(_))
        ));
        assert!(matches!(
            Fluid::from_ratio(0.0, 0.5, 1.0, 0.0),
            Err(RheologyError::Viscosity { .. })
        ));
        let msg = Fluid::new(1.0, 1.0, 1.0, 1.2).unwrap_err().to_string();
        assert!(msg.contains("[0, 1)"), "{msg}");
    }

    #[test]
    fn derived_quantities() {
        let f = Fluid::from_ratio(2.0, 0.25, 4.0, 0.1).unwrap();
        assert_eq!(f.eta_s(), 0.5);
        assert_eq!(f.eta_p(), 1.5);
        assert_eq!(f.eta0(), 2.0);
        assert_eq!(f.beta(), 0.25);
        assert_eq!(f.weissenberg(0.5), 2.0);
        assert!((f.polymer().modulus() - 0.375).abs() < ARITH_TOL);
        let ucm = Fluid::ucm(1.0, 1.0).unwrap();
        assert!(ucm.has_no_solvent() && ucm.beta() == 0.0 && ucm.alpha() == 0.0);
    }

    #[test]
    fn relaxation_matches_definition_and_eigen_form() {
        let g = Giesekus::new(2.0, 3.0, 0.3).unwrap();
        // c − I = diag(1, −0.5): f = −(1/2)[diag(1, −0.5) + 0.3 diag(1, 0.25)].
        let f = g.relaxation(Sym2::new(2.0, 0.0, 0.5));
        assert!((f.xx + 0.5 * 1.3).abs() < ARITH_TOL);
        assert!((f.yy + 0.5 * (-0.5 + 0.075)).abs() < ARITH_TOL);
        assert_eq!(f.xy, 0.0);
        for sigma in [-2.0, -1e-9, 0.0, 1e-9, 0.7, 3.0] {
            let mu: f64 = f64::exp(sigma);
            let want = g.relaxation(Sym2::scaled_identity(mu)).xx / mu;
            let got = g.relaxation_over_eigenvalue(sigma);
            assert!(
                (got - want).abs() < EIGEN_FORM_TOL * (1.0 + want.abs()),
                "σ = {sigma}"
            );
        }
        // The stress-free state does not relax.
        assert_eq!(g.relaxation(Sym2::IDENTITY), Sym2::ZERO);
        assert_eq!(g.relaxation_over_eigenvalue(0.0), 0.0);
    }

    #[test]
    fn extra_stress_is_solvent_plus_polymer() {
        let f = Fluid::new(0.5, 2.0, 4.0, 0.0).unwrap();
        let s = f.extra_stress(
            VelocityGradient::simple_shear(2.0),
            Sym2::new(3.0, 1.0, 1.0),
        );
        // 2 η_s D = [[0, 1], [1, 0]]; τ = 0.5 (c − I) = [[1, 0.5], [0.5, 0]].
        assert_eq!(s, Sym2::new(1.0, 1.5, 0.0));
    }
}
