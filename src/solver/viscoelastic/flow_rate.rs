//! Flow-rate control of a periodic channel (a body force chosen every step so that the flux
//! through the seam is the target).

use super::{ViscoelasticError, ViscoelasticFlow};
use crate::solver::constitutive_stress::Coupling;
use crate::solver::flow::StokesSolution;

/// Flow-rate control of a periodic channel: Stokes flow is linear in the body force, and with the
/// explicit coupling the flow matrix does not depend on the stress, so the flow of each step is
/// u = u_τ + f u₁, with u₁ the response to a unit body force (computed once) and f chosen so
/// that the flux through the seam equals the target.
#[derive(Debug, Clone)]
pub(super) struct FlowRateControl {
    target: f64,
    unit_u: Vec<[f64; 2]>,
    unit_p: Vec<f64>,
    unit_flux: f64,
    unit_reaction: Vec<[f64; 3]>,
    unit_traction: Vec<[f64; 3]>,
}

impl ViscoelasticFlow {
    /// Drives a periodic channel (walls and bodies at rest, x-periodic) at flow rate `q` with a
    /// uniform body force in x adjusted every step (u = u_τ + f u₁ with a precomputed unit-force
    /// response; exact because the explicit-coupling flow matrix does not depend on τ). Call after the
    /// boundary conditions are set; the `force` passed to [`step`](Self::step) must then be zero.
    ///
    /// # Errors
    /// [`ViscoelasticError::Flow`] if the unit solve fails, [`ViscoelasticError::FlowRateNeedsExplicit`]
    /// for the semi-implicit coupling (its flow matrix changes with the stress).
    pub fn set_flow_rate(&mut self, q: f64) -> Result<(), ViscoelasticError> {
        if self.params.coupling != Coupling::Explicit {
            return Err(ViscoelasticError::FlowRateNeedsExplicit);
        }
        let unit = self
            .stokes
            .solve(&|_| [1.0, 0.0])
            .map_err(|source| ViscoelasticError::Flow { step: 0, source })?;
        let unit_flux = self.mesh.flux_through_first_column(&unit.u);
        self.flow_rate = Some(FlowRateControl {
            target: q,
            unit_u: unit.u,
            unit_p: unit.p,
            unit_flux,
            unit_reaction: unit.reaction,
            unit_traction: unit.stress_force,
        });
        Ok(())
    }

    /// Adds the flow-rate correction f·(u₁, p₁) to a solution (and to its particle reactions
    /// and traction integrals, linear in it) and returns f.
    pub(super) fn control_flow_rate(&self, sol: &mut StokesSolution) -> f64 {
        let Some(fr) = &self.flow_rate else {
            return 0.0;
        };
        let f = (fr.target - self.mesh.flux_through_first_column(&sol.u)) / fr.unit_flux;
        sol.u.iter_mut().zip(&fr.unit_u).for_each(|(a, b)| {
            a[0] += f * b[0];
            a[1] += f * b[1];
        });
        sol.p
            .iter_mut()
            .zip(&fr.unit_p)
            .for_each(|(a, b)| *a += f * b);
        for (forces, unit) in [
            (&mut sol.reaction, &fr.unit_reaction),
            (&mut sol.stress_force, &fr.unit_traction),
        ] {
            forces.iter_mut().zip(unit).for_each(|(a, b)| {
                for c in 0..3 {
                    a[c] += f * b[c];
                }
            });
        }
        f
    }
}
