//! The explicit coupling's lag as the particles see it: the flow of a step is solved with the
//! polymer stress of cⁿ (and, with a decoupled DEVSS-G, the lagged Gⁿ); at the end of the step
//! c^{n+1} and G^{n+1} are known, and the same system (the same matrix: the geometry did not
//! change) with their stress gives the rigid velocities the step would have had without the
//! lag. Their difference is O(Δt |dτ/dt|), the error the extrapolation-based estimate of the
//! step controller does not see (docs/validation.md, "Which setting").

use super::{ViscoelasticError, ViscoelasticFlow};
use crate::solver::constitutive_stress::{Coupling, CouplingStress};
use crate::solver::polymer_terms::PolymerStress;

impl ViscoelasticFlow {
    /// After a step ([`solve_stress`](Self::solve_stress)): the rigid velocities (U_x, U_y, ω)
    /// of each particle solved again with the stress at the end of the step, minus those the
    /// step used; `None` when the step has no lag (no polymer, no particles, or the
    /// semi-implicit coupling, whose stress is implicit). One more assembly and solve with the
    /// step's factorization; the flow fields of the step are left as they were.
    ///
    /// # Errors
    /// [`ViscoelasticError::Flow`] if the solve fails.
    pub fn coupling_lag(
        &mut self,
        force: &dyn Fn([f64; 2]) -> [f64; 2],
    ) -> Result<Option<Vec<[f64; 3]>>, ViscoelasticError> {
        if !self.params.has_polymer()
            || self.params.coupling != Coupling::Explicit
            || self.rigid.is_empty()
        {
            return Ok(None);
        }
        let stress = CouplingStress {
            mesh: &self.mesh,
            model: self.fluid.polymer(),
            conformation: &self.conformation,
            coupling: self.params.coupling,
            dt: self.params.dt,
            bdf: self.history.bdf2(self.params.dt),
            mesh_velocity: self.mesh_velocity.as_deref(),
            devss: (!self.params.coupled_g && self.params.theta > 0.0)
                .then_some((self.params.theta, self.gradient.as_slice())),
            previous: self.conformation_prev.as_deref(),
        };
        let step = self.history.steps();
        let sol = self
            .stokes
            .solve_with(force, Some(&stress as &dyn PolymerStress))
            .map_err(|source| ViscoelasticError::Flow { step, source })?;
        Ok(Some(
            sol.rigid
                .iter()
                .zip(&self.rigid)
                .map(|(new, used)| [0, 1, 2].map(|c| new[c] - used[c]))
                .collect(),
        ))
    }
}
