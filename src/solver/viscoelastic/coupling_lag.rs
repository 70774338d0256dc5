//! The explicit coupling's lag as the particles see it: the flow of a step is solved with the
//! polymer stress of cⁿ (and, with a decoupled DEVSS-G, the lagged Gⁿ); at the end of the step
//! c^{n+1} and G^{n+1} are known, and the same system (the same matrix: the geometry did not
//! change) with their stress gives the rigid velocities the step would have had without the
//! lag. Their difference is O(Δt |dτ/dt|), the error the extrapolation-based estimate of the
//! step controller does not see (docs/validation.md, "Which setting"); O(Δt² |d²τ/dt²|) with
//! the stress extrapolated from cⁿ and c^{n−1}.

use super::{ViscoelasticError, ViscoelasticFlow};
use crate::solver::constitutive_stress::Coupling;

impl ViscoelasticFlow {
    /// After a step ([`solve_stress`](Self::solve_stress)): the rigid velocities (U_x, U_y, ω)
    /// of each particle solved again with the stress at the end of the step, minus those the
    /// step used; `None` when the step has no lag (no polymer, no particles, or the
    /// semi-implicit coupling, whose stress is implicit). With the extrapolated stress the
    /// step used τ(ĉ), and the lag is O(Δt²). One more assembly and solve with the
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
        // the stress of c^{n+1} itself (not extrapolated from it and cⁿ)
        let sol = self.solve_stokes(force, self.history.steps(), false)?;
        Ok(Some(
            sol.rigid
                .iter()
                .zip(&self.rigid)
                .map(|(new, used)| [0, 1, 2].map(|c| new[c] - used[c]))
                .collect(),
        ))
    }
}
