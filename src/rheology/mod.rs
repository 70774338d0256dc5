//! Constitutive layer: Giesekus / Oldroyd-B / UCM fluids in log-conformation form, on single points.
//!
//! Owns (and knows nothing about meshes):
//! - [`tensor`]: symmetric 2×2 tensors, the velocity gradient `L_ij = ∂u_i/∂x_j`, closed-form
//!   eigen-decomposition, `exp`/`log` of SPD tensors.
//! - [`model`]: [`Giesekus`] (Oldroyd-B for `α = 0`) and [`Fluid`] (adds the solvent; UCM for
//!   `η_s = 0`), validated; the conformation equation `λ c^∇ + c − I + α (c − I)² = 0` (Eqs. 2.4, 5.4,
//!   upper-convected derivative Eq. 2.5/5.5) and the polymer stress `τ = (η_p/λ)(c − I)` (Eqs. 2.6, 5.6).
//! - [`log_conformation`]: the right-hand side `g(L, s)` of the log-conformation equation
//!   `∂s/∂t + u·∇s = g(L, s)` (Eqs. 2.7, 5.7; Fattal & Kupferman 2004/2005, Hulsen, Fattal &
//!   Kupferman 2005), derivation in its docs.
//! - [`semi_implicit`]: the D'Avino–Hulsen semi-implicit stress (Eqs. 5.26–5.27) as an affine map of
//!   the velocity gradient, `τ_ij = A_ijkl L_kl + b_ij`, for the flow solve.
//! - [`homogeneous`]: the time scheme of the stress solve (Euler start, then BDF2 with the
//!   extrapolated `ŝ = 2sⁿ − sⁿ⁻¹`, Eq. 5.29) reduced to a point in a constant velocity gradient.
//! - [`viscometric`]: analytic steady simple shear of the Giesekus model and Oldroyd-B start-up of
//!   simple shear (references for tests and validation, `validation.md` §1).
//!
//! Convention: every function takes the usual velocity gradient `L` (`L_ij = ∂u_i/∂x_j`), which is
//! `(∇u)ᵀ` in the thesis' notation `(∇u)_ij = ∂u_j/∂x_i`.

pub mod homogeneous;
pub mod log_conformation;
pub mod model;
pub mod semi_implicit;
pub mod tensor;
pub mod viscometric;

#[cfg(test)]
mod test_support;

pub use homogeneous::{integrate_log_conformation, Extrapolation, HomogeneousLogConformation};
pub use log_conformation::log_conformation_rhs;
pub use model::{Fluid, Giesekus};
pub use semi_implicit::{relaxed_conformation, SemiImplicitStress};
pub use tensor::{Sym2, SymEigen, VelocityGradient};
pub use viscometric::{
    giesekus_steady_shear, giesekus_steady_shear_conformation, oldroyd_b_startup_conformation,
    oldroyd_b_startup_shear, oldroyd_b_steady_shear, ShearFunctions, StartupShear,
};

/// Invalid constitutive parameters or tensors; each message says what to change.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
pub enum RheologyError {
    /// `λ ≤ 0` or not finite.
    #[error("relaxation time λ = {0} must be positive and finite")]
    RelaxationTime(f64),
    /// A viscosity is negative or not finite.
    #[error("viscosity {name} = {value} must be non-negative and finite")]
    Viscosity {
        /// Which viscosity (`η_s`, `η_p` or `η0`).
        name: &'static str,
        /// The rejected value.
        value: f64,
    },
    /// `η0 = η_s + η_p = 0`.
    #[error(
        "zero-shear viscosity η0 = η_s + η_p is 0: give the solvent or the polymer a viscosity"
    )]
    ZeroViscosity,
    /// Giesekus mobility outside `[0, 1)`.
    #[error("Giesekus mobility α = {0} must lie in [0, 1) (0 ≤ α ≤ 0.5 is the physical range)")]
    Mobility(f64),
    /// Viscosity ratio `β = η_s/η0` outside `[0, 1]`.
    #[error("viscosity ratio β = η_s/η0 = {0} must lie in [0, 1]")]
    ViscosityRatio(f64),
    /// Time step not positive or not finite.
    #[error("time step Δt = {0} must be positive and finite")]
    TimeStep(f64),
    /// A tensor that must be symmetric positive definite (a conformation) is not.
    #[error("tensor [[{xx}, {xy}], [{xy}, {yy}]] is not positive definite: it is no conformation tensor and has no logarithm")]
    NotPositiveDefinite {
        /// Component `xx`.
        xx: f64,
        /// Component `xy`.
        xy: f64,
        /// Component `yy`.
        yy: f64,
    },
}
