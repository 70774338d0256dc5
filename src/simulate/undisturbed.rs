//! The undisturbed steady free surface H̄(x) = H(x, t → ∞) of an extrusion case without its
//! particles (thesis Eq. 6.65), against which a particle's separation s = Y + a − H̄(X) is
//! measured: the case's mesh, fluid and time step, stepped from the flat surface until the
//! steady test of §6.4 ([`STEADY_HEIGHT_TOL`]) or [`UNDISTURBED_T_MAX`].

use crate::config::CaseSpec;
use crate::solver::free_surface::{HeightFunction, STEADY_HEIGHT_TOL};
use crate::solver::moving::{MovingError, MovingParticles};

use super::{settings, Simulation};

/// The longest time the undisturbed flow is stepped towards the steady test (the UCM swell of
/// §6.4 is steady by t ≈ 17 at De = 1.5 with Δt = 0.05: 348 steps).
pub const UNDISTURBED_T_MAX: f64 = 40.0;

/// The undisturbed steady surface of a case and how it was reached.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Undisturbed {
    /// H̄ on the surface's line mesh.
    pub surface: HeightFunction,
    /// Steps taken.
    pub steps: usize,
    /// Whether the steady test was met (otherwise the surface at [`UNDISTURBED_T_MAX`]).
    pub steady: bool,
}

impl Undisturbed {
    /// The swell ratio max H̄ / H0.
    pub fn swell(&self) -> f64 {
        self.surface.max() / self.surface.h0()
    }
}

/// The undisturbed steady surface of an extrusion `case` (`None` for other geometries).
///
/// # Errors
/// [`MovingError`] if the set-up or a step fails.
pub fn undisturbed_surface(case: &CaseSpec) -> Result<Option<Undisturbed>, MovingError> {
    let (Some(base), Some(radius)) = (case.base_mesh(), case.radius()) else {
        return Ok(None);
    };
    if case.extrusion().is_none() {
        return Ok(None);
    }
    let set_up = Simulation::set_up(case).map_err(|e| MovingError::Setup(e.to_string()))?;
    let mut flow = MovingParticles::free(
        base,
        settings::fluid_params(case),
        set_up,
        Vec::new(),
        radius,
        settings::discretization(case),
    )?;
    let mut steps = 0;
    let change = |f: &MovingParticles<_>| f.surface_change().unwrap_or(0.0);
    while change(&flow) >= STEADY_HEIGHT_TOL && flow.time() < UNDISTURBED_T_MAX {
        flow.step()?;
        steps += 1;
    }
    Ok(Some(Undisturbed {
        surface: flow.surface().expect("an extrusion has a surface").clone(),
        steps,
        steady: change(&flow) < STEADY_HEIGHT_TOL,
    }))
}
