//! What a Stokes solve is given: the physical and numerical parameters ([`StokesParams`]) and
//! the flow's default ghost penalty.

use super::FlowFactorization;
use crate::fem::linsolve::SolverKind;
use crate::solver::lubrication::Lubrication;
use crate::solver::multiplier::RigidCondition;
use crate::solver::rigid::WeakForm;

/// Physical and numerical parameters of a Stokes solve.
#[derive(Debug, Clone, Copy)]
pub struct StokesParams {
    /// Viscosity η of the 2η D(u) term (the solvent viscosity in viscoelastic flow).
    pub eta: f64,
    /// DEVSS-G parameter θ (the polymer viscosity in viscoelastic flow); 0 = no G unknowns.
    pub theta: f64,
    /// Linear solver.
    pub solver: SolverKind,
    /// How the rigid-body motion is imposed on the particle boundaries: the weak condition
    /// (default) or Lagrange multipliers on a ring ([`crate::solver::multiplier`]).
    pub rigid_condition: RigidCondition,
    /// Form of the weak rigid-body condition on particles.
    pub rigid_form: WeakForm,
    /// Stabilization parameter κ of the weak rigid-body condition (thesis: κ = η0).
    pub kappa: f64,
    /// With θ > 0: G as coupled unknowns (true) or supplied explicitly by the caller through
    /// [`PolymerStress`](crate::solver::polymer_terms::PolymerStress) as −θGⁿ (false; the flow matrix then has no G block).
    pub coupled_g: bool,
    /// Patch ghost penalty of velocity and pressure on the faces of cut elements
    /// ([`ghost_patch_matrices`](crate::solver::ghost::ghost_patch_matrices)): velocity
    /// γ (η + θ)/h², pressure −γ/(η + θ); 0 = none.
    pub ghost_penalty: f64,
    /// How a changed matrix is factored (LBLᵀ only; LU always factors the whole matrix).
    pub factorization: FlowFactorization,
    /// The squeeze resistance of the films the mesh does not resolve, added between the
    /// particles' rigid rows ([`crate::solver::lubrication`]); `None` = none (the default).
    pub lubrication: Option<Lubrication>,
}

impl StokesParams {
    /// Parameters with viscosity `eta`, DEVSS-G `theta`, the given solver, and the weak rigid-body
    /// condition in its symmetric form with κ = η + θ (= η0).
    pub fn new(eta: f64, theta: f64, solver: SolverKind) -> Self {
        Self {
            eta,
            theta,
            solver,
            rigid_condition: RigidCondition::Weak,
            rigid_form: WeakForm::Symmetric,
            kappa: eta + theta,
            coupled_g: true,
            ghost_penalty: FLOW_GHOST_PENALTY,
            factorization: FlowFactorization::Band,
            lubrication: None,
        }
    }
}

/// Default patch ghost-penalty coefficient of the flow ([`StokesParams::ghost_penalty`]). Chosen
/// by measurement (docs/validation.md): 0.001 removes the sliver velocities (|u| ≤ wall speed,
/// point symmetry to 1e-8) and perturbs the free Couette particle's ω by 3e-4 on 64×12; 0.01
/// perturbs it by 3e-3 and 0.1 moves the confined-cylinder drag by 5e-4 at h = 0.2R.
pub const FLOW_GHOST_PENALTY: f64 = 0.001;
