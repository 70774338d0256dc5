//! How a step and a run of moving particles end: a step's outcome (taken, or stopped by a
//! contact, which is physics), a run's end, and the errors of each phase of the step.

use crate::particles::Contact;
use crate::solver::ale::AleError;
use crate::solver::cutcells::CutError;
use crate::solver::viscoelastic::{StepReport, ViscoelasticError};

/// Why a run stopped.
#[derive(Debug, Clone, PartialEq)]
pub enum MovingEnd {
    /// End time reached.
    EndTime,
    /// The step callback asked to stop.
    Stopped,
    /// Particles touched each other or a wall.
    Contact(Contact),
}

/// Errors of a moving-particle run; the sweep engine records them as divergence.
#[derive(Debug, thiserror::Error)]
pub enum MovingError {
    /// Cut-cell geometry failed.
    #[error("step {step}: {source}")]
    Cut {
        /// Step.
        step: usize,
        /// Cause.
        source: CutError,
    },
    /// The temporary ALE map failed.
    #[error("step {step}: temporary ALE map: {source}")]
    Ale {
        /// Step.
        step: usize,
        /// Cause.
        source: AleError,
    },
    /// A flow or stress solve failed.
    #[error(transparent)]
    Flow(#[from] ViscoelasticError),
    /// A particle velocity is not finite.
    #[error("step {step}: non-finite particle velocity")]
    NonFinite {
        /// Step.
        step: usize,
    },
    /// The step's error stays far above the tolerance at the smallest Δt the adaptive step
    /// allows ([`crate::simulate::adaptive::DIVERGED_ERROR`]): the solution jumped, and a smaller
    /// step does not help.
    #[error("step {step}: the step's error is {error:.1e} times the tolerance at the minimum Δt = {dt}: the particles' motion jumped (not a too-large step)")]
    Jumped {
        /// Step.
        step: usize,
        /// The scaled error (1: the tolerance).
        error: f64,
        /// The step size, the minimum.
        dt: f64,
    },
    /// The mesh that follows the particles cannot be built around their positions.
    #[error("step {step}: mesh that follows the particles: {reason}")]
    Follow {
        /// Step.
        step: usize,
        /// Cause.
        reason: String,
    },
    /// A free surface left the mesh: it rose above the mesh top (the swell outgrew the mesh
    /// height) or fell to the symmetry line (a kinematic step that is unstable there).
    #[error("step {step}: the free surface left the mesh at x = {x:.4} (H = {height:.4}; its last kinematic step moved it by up to {moved:.2e}): {}", escape_cause(*height))]
    SurfaceEscaped {
        /// Step.
        step: usize,
        /// Where.
        x: f64,
        /// Its height there.
        height: f64,
        /// max|Hⁿ⁺¹ − Hⁿ| of the last kinematic step (infinite before the first).
        moved: f64,
    },
    /// Inconsistent set-up.
    #[error("{0}")]
    Setup(String),
}

impl MovingError {
    /// The step that failed, where the error knows it (a flow solve names its own; the set-up
    /// has none).
    pub fn step(&self) -> Option<usize> {
        match self {
            MovingError::Cut { step, .. }
            | MovingError::Ale { step, .. }
            | MovingError::NonFinite { step }
            | MovingError::Jumped { step, .. }
            | MovingError::Follow { step, .. }
            | MovingError::SurfaceEscaped { step, .. } => Some(*step),
            MovingError::Flow(_) | MovingError::Setup(_) => None,
        }
    }

    /// The phase of the time step that failed: `set-up`, `ale_map`, `classify`, `solve_flow`,
    /// `solve_stress`, `advance_surface` or `correct`.
    pub fn phase(&self) -> &'static str {
        match self {
            MovingError::Cut { .. } => "classify",
            MovingError::Ale { .. } | MovingError::Follow { .. } => "ale_map",
            MovingError::Flow(ViscoelasticError::Flow { .. }) => "solve_flow",
            MovingError::Flow(ViscoelasticError::Stress(_)) => "solve_stress",
            MovingError::NonFinite { .. } | MovingError::Jumped { .. } => "correct",
            MovingError::SurfaceEscaped { .. } => "advance_surface",
            MovingError::Flow(_) | MovingError::Setup(_) => "set-up",
        }
    }
}

/// What to do about a surface that left the mesh at `height`: above the mesh, raise it; at or
/// below the symmetry line nothing physical brings it there (the swell is positive), so the
/// kinematic step has gone unstable.
fn escape_cause(height: f64) -> &'static str {
    if height > 0.0 {
        "raise geometry.extrusion.height"
    } else {
        "it fell through the symmetry line: the kinematic step is unstable (an oscillation of H \
         from the die exit's stick-slip corner that grew; docs/validation.md, the §6.5 particle at \
         Wi = 0.5)"
    }
}

/// How a step ended: contact is an outcome of the physics, not an error.
#[derive(Debug, Clone)]
pub enum StepOutcome {
    /// The step was taken.
    Stepped(StepReport),
    /// The predicted particles would touch: the step was not taken.
    Contact(Contact),
    /// The step was taken and the corrected particles touch.
    ContactAfter(StepReport, Contact),
}

impl StepOutcome {
    /// The report of a step that ended without contact, or the contact.
    ///
    /// # Errors
    /// The contact, predicted or after the step.
    pub fn into_report(self) -> Result<StepReport, Contact> {
        match self {
            StepOutcome::Stepped(r) => Ok(r),
            StepOutcome::Contact(c) | StepOutcome::ContactAfter(_, c) => Err(c),
        }
    }
}
