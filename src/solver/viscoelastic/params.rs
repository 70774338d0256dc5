//! Parameters of a viscoelastic run and the errors of its time stepper.

use crate::fem::linsolve::SolveError;
use crate::fem::substructure::Factorization;
use crate::rheology::{Fluid, RheologyError};
use crate::solver::constitutive::{ConstitutiveError, SupgVelocity};
use crate::solver::constitutive_stress::Coupling;
use crate::solver::multiplier::RigidCondition;
use crate::solver::rigid::WeakForm;

/// Steady-state tolerance of thesis §2.5.1: nodal changes of u and s below 1e-6 per step.
pub const STEADY_TOL: f64 = 1e-6;

/// Parameters of a viscoelastic run (no dependency on the config module).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ViscoelasticParams {
    /// Solvent viscosity η_s (0 = UCM / Giesekus without solvent).
    pub eta_s: f64,
    /// Polymer viscosity η_p.
    pub eta_p: f64,
    /// Relaxation time λ.
    pub lambda: f64,
    /// Giesekus mobility α (0 = Oldroyd-B).
    pub alpha: f64,
    /// Time step Δt.
    pub dt: f64,
    /// End time.
    pub t_end: f64,
    /// Stress coupling in the flow solve.
    pub coupling: Coupling,
    /// DEVSS-G parameter θ (thesis: θ = η_p).
    pub theta: f64,
    /// DEVSS-G with G as flow unknowns (true) or decoupled: Gⁿ lagged in the momentum balance,
    /// G^{n+1} by a Q1 projection (false, the fast path).
    pub coupled_g: bool,
    /// Explicit coupling only: the stress of the flow solve extrapolated from the last two
    /// steps, τ(cⁿ + r(cⁿ − c^{n−1})) with r = Δtₙ/Δtₙ₋₁, instead of the lagged τ(cⁿ).
    pub extrapolate_stress: bool,
    /// Steady-state tolerance on the nodal change per step.
    pub steady_tol: f64,
    /// How the rigid-body motion is imposed: the weak condition (default) or Lagrange
    /// multipliers on a ring ([`crate::solver::multiplier`]).
    pub rigid_condition: RigidCondition,
    /// Form of the weak rigid-body condition; [`WeakForm::Thesis`] (non-symmetric, coercive for
    /// any κ however small the cut) needs an LU flow solver, chosen automatically.
    pub rigid_form: WeakForm,
    /// How the flow matrix is factored when it changed (the particles moved):
    /// [`Factorization::Band`] (default) or the whole matrix every step.
    pub factorization: Factorization,
    /// The SUPG parameter of the stress transport (default Case 1 at the step's Δt;
    /// [`SupgVelocity::LocalAt`] for variable steps).
    pub supg: SupgVelocity,
    /// Ghost-penalty factor of the stress transport on the faces of cut elements (default
    /// [`GHOST_PENALTY`](crate::solver::constitutive::GHOST_PENALTY)).
    pub stress_ghost_penalty: f64,
    /// The squeeze resistance of the films the mesh does not resolve, in the flow solve
    /// ([`crate::solver::lubrication`]); default none.
    pub lubrication: Option<crate::solver::lubrication::Lubrication>,
}

impl ViscoelasticParams {
    /// A Newtonian fluid of viscosity η (no polymer: the stress transport, its projections and
    /// the history map are skipped, and the flow solve is plain Stokes with the LBLᵀ solver;
    /// λ is a placeholder that nothing uses).
    pub fn newtonian(eta: f64, dt: f64, t_end: f64) -> Self {
        Self::new(eta, 0.0, 1.0, 0.0, dt, t_end)
    }

    /// Whether the flow solve reads the projected c^{n−1} (the semi-implicit predictor, the
    /// extrapolated explicit stress): the stepper keeps it.
    pub fn needs_previous_conformation(&self) -> bool {
        self.coupling == Coupling::SemiImplicit
            || (self.coupling == Coupling::Explicit && self.extrapolate_stress)
    }

    /// Whether the fluid has a polymer (η_p > 0); without one the stepper solves Stokes flow.
    pub fn has_polymer(&self) -> bool {
        self.eta_p > 0.0
    }

    /// Explicit coupling, decoupled DEVSS-G with θ = η_p, steady tolerance [`STEADY_TOL`].
    pub fn new(eta_s: f64, eta_p: f64, lambda: f64, alpha: f64, dt: f64, t_end: f64) -> Self {
        Self {
            eta_s,
            eta_p,
            lambda,
            alpha,
            dt,
            t_end,
            coupling: Coupling::Explicit,
            theta: eta_p,
            coupled_g: false,
            extrapolate_stress: false,
            steady_tol: STEADY_TOL,
            rigid_condition: RigidCondition::Weak,
            rigid_form: WeakForm::Symmetric,
            factorization: Factorization::Band,
            supg: SupgVelocity::Local,
            stress_ghost_penalty: crate::solver::constitutive::GHOST_PENALTY,
            lubrication: None,
        }
    }

    /// The validated fluid.
    ///
    /// # Errors
    /// As in [`super::ViscoelasticFlow::new`].
    pub fn fluid(&self) -> Result<Fluid, ViscoelasticError> {
        let fluid = Fluid::new(self.eta_s, self.eta_p, self.lambda, self.alpha)?;
        if !(self.dt > 0.0 && self.dt.is_finite() && self.t_end >= 0.0 && self.t_end.is_finite()) {
            return Err(ViscoelasticError::Time {
                dt: self.dt,
                t_end: self.t_end,
            });
        }
        if !(self.theta >= 0.0 && self.theta.is_finite()) {
            return Err(ViscoelasticError::Theta(self.theta));
        }
        if self.coupling == Coupling::Explicit && self.eta_s + self.theta == 0.0 {
            return Err(ViscoelasticError::NoViscosityInFlowMatrix);
        }
        Ok(fluid)
    }
}

/// Errors of the viscoelastic time stepper; each says what to change.
#[derive(Debug, thiserror::Error)]
pub enum ViscoelasticError {
    /// Invalid fluid parameters.
    #[error("fluid parameters: {0}")]
    Fluid(#[from] RheologyError),
    /// Bad time parameters.
    #[error("time step Δt = {dt} must be positive and the end time {t_end} non-negative (finite)")]
    Time {
        /// Δt.
        dt: f64,
        /// End time.
        t_end: f64,
    },
    /// Bad DEVSS-G parameter.
    #[error("DEVSS-G parameter θ = {0} must be non-negative and finite")]
    Theta(f64),
    /// η_s = θ = 0 with the explicit coupling: the flow matrix has no viscous part.
    #[error(
        "η_s = 0 with explicit stress coupling and θ = 0 leaves the flow matrix singular: \
         use DEVSS-G (θ = η_p) or the semi-implicit coupling"
    )]
    NoViscosityInFlowMatrix,
    /// Flow-rate control superposes a unit-force response, valid only when the flow matrix does
    /// not depend on the stress.
    #[error("flow-rate control needs the explicit stress coupling (the semi-implicit flow matrix changes every step)")]
    FlowRateNeedsExplicit,
    /// The flow solve failed.
    #[error("flow solve failed at step {step}: {source}")]
    Flow {
        /// Time step number (0 = initial solve).
        step: usize,
        /// The solver error.
        #[source]
        source: SolveError,
    },
    /// Flow-rate control with moving particles.
    #[error("flow-rate control needs fixed bodies (its unit-force response belongs to one configuration)")]
    FlowRateNeedsFixedBodies,
    /// A saved state does not fit this flow.
    #[error("saved state does not fit: {0}")]
    Restore(String),
    /// The stress solve or a projection failed.
    #[error(transparent)]
    Stress(#[from] ConstitutiveError),
}
