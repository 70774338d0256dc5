//! The saved state of a flow (what a resumed run continues from) and its restore.

use super::{fluid_nodes, ViscoelasticError, ViscoelasticFlow};
use crate::mesh::Mesh;
use crate::rheology::Sym2;
use crate::solver::constitutive::LogConformationHistory;
use crate::solver::rigid::{ElementCut, Particle};

/// The time-dependent fields of a [`ViscoelasticFlow`] after a step (see
/// [`ViscoelasticFlow::state`]); serializable so that a long run can continue elsewhere.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FlowState {
    /// sⁿ and s^{n−1} with the step count.
    pub history: LogConformationHistory,
    /// sⁿ on its own configuration (moving particles).
    pub unmapped: Option<(usize, Vec<Sym2>)>,
    /// cⁿ projected on the current fluid domain.
    pub conformation: Vec<Sym2>,
    /// c^{n−1} (semi-implicit coupling).
    pub conformation_prev: Option<Vec<Sym2>>,
    /// Gⁿ.
    pub gradient: Vec<[f64; 4]>,
    /// uⁿ at the Q2 nodes.
    pub velocity: Vec<[f64; 2]>,
    /// pⁿ at the Q1 vertices.
    pub pressure: Vec<f64>,
    /// tⁿ.
    pub time: f64,
    /// Rigid-body velocities of the last flow solve.
    pub rigid: Vec<[f64; 3]>,
    /// Weak-condition reactions of the last flow solve.
    pub reaction: Vec<[f64; 3]>,
    /// Traction integrals (solvent and pressure) of the last flow solve; absent in states saved
    /// before they were kept (then zero until the next solve).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub traction: Vec<[f64; 3]>,
    /// Body force of the last flow solve.
    pub body_force: f64,
}

impl ViscoelasticFlow {
    /// Starts from the log-conformation `s0(x)` at every vertex instead of rest (call before the
    /// first step): the history and the projected conformation c⁰ = Π exp(s0).
    ///
    /// # Errors
    /// [`ViscoelasticError::Stress`] if the projection fails.
    pub fn set_initial_log_conformation(
        &mut self,
        s0: impl Fn([f64; 2]) -> Sym2,
    ) -> Result<(), ViscoelasticError> {
        let s: Vec<Sym2> = self
            .mesh
            .node_of_vertex
            .iter()
            .map(|&n| s0(self.mesh.nodes[n]))
            .collect();
        self.history = LogConformationHistory::from_field(s);
        self.projection.project_conformation(
            &self.mesh,
            &self.history.current,
            &mut self.conformation,
        )?;
        Ok(())
    }

    /// The time-dependent state after a step: what [`restore`](Self::restore) needs to continue
    /// a run from here in another process (everything else follows from the mesh, the
    /// parameters and the particle positions).
    pub fn state(&self) -> FlowState {
        FlowState {
            history: self.history.clone(),
            unmapped: self.unmapped.clone(),
            conformation: self.conformation.clone(),
            conformation_prev: self.conformation_prev.clone(),
            gradient: self.gradient.clone(),
            velocity: self.velocity.clone(),
            pressure: self.pressure.clone(),
            time: self.time,
            rigid: self.rigid.clone(),
            reaction: self.reaction.clone(),
            traction: self.traction.clone(),
            body_force: self.body_force,
        }
    }

    /// Continues from a saved [`state`](Self::state) with the particles (and their `cuts`) at
    /// the positions the state was computed at. The next step goes on exactly as the saved run
    /// would have, up to round-off (the flow pattern's reach is rebuilt around the current
    /// positions, which can reorder the factorization).
    ///
    /// # Errors
    /// [`ViscoelasticError::Restore`] if the state does not fit this mesh or particle count.
    pub fn restore(
        &mut self,
        state: FlowState,
        particles: Vec<Particle>,
        cuts: Vec<ElementCut>,
    ) -> Result<(), ViscoelasticError> {
        self.restore_on(None, state, particles, cuts)
    }

    /// [`restore`](Self::restore) a state computed on `mesh` (same topology, columns and rows
    /// possibly moved: a mesh that follows the particles; `None`: the current mesh), with `cuts`
    /// on that mesh.
    ///
    /// # Errors
    /// As [`restore`](Self::restore).
    ///
    /// # Panics
    /// If `mesh` has another topology.
    pub fn restore_on(
        &mut self,
        mesh: Option<Mesh>,
        state: FlowState,
        particles: Vec<Particle>,
        cuts: Vec<ElementCut>,
    ) -> Result<(), ViscoelasticError> {
        let (nv, nn) = (self.mesh.n_vertices(), self.mesh.n_nodes());
        let np = self.rigid.len();
        let fits = |what: &str, len: usize, want: usize| {
            if len == want {
                Ok(())
            } else {
                Err(ViscoelasticError::Restore(format!(
                    "{what} has {len} entries, this case has {want}"
                )))
            }
        };
        fits("sⁿ", state.history.current.len(), nv)?;
        if let Some(p) = &state.history.previous {
            fits("s^(n-1)", p.len(), nv)?;
        }
        if let Some((_, u)) = &state.unmapped {
            fits("unmapped sⁿ", u.len(), nv)?;
        }
        if let Some(c) = &state.conformation_prev {
            fits("c^(n-1)", c.len(), nv)?;
        }
        fits("c", state.conformation.len(), nv)?;
        fits("G", state.gradient.len(), nv)?;
        fits("p", state.pressure.len(), nv)?;
        fits("u", state.velocity.len(), nn)?;
        fits("particle velocities", state.rigid.len(), np)?;
        fits("particle reactions", state.reaction.len(), np)?;
        fits("particles", particles.len(), np)?;
        if self.flow_rate.is_some() {
            return Err(ViscoelasticError::FlowRateNeedsFixedBodies);
        }
        if let Some(mesh) = mesh {
            self.set_mesh(mesh);
        }
        self.fluid_node = fluid_nodes(&self.mesh, &particles, &cuts);
        if np > 0 {
            self.transport.set_cuts(&self.mesh, cuts.clone());
            self.projection.set_cuts(&self.mesh, cuts.clone());
            self.stokes.place_particles(particles, cuts.clone());
        }
        self.cuts = cuts;
        self.history = state.history;
        self.unmapped = state.unmapped;
        self.conformation = state.conformation;
        self.conformation_prev = state.conformation_prev;
        self.gradient = state.gradient;
        self.velocity = state.velocity;
        self.pressure = state.pressure;
        self.time = state.time;
        self.rigid = state.rigid;
        self.reaction = state.reaction;
        self.traction = if state.traction.len() == np {
            state.traction
        } else {
            vec![[0.0; 3]; np]
        };
        self.body_force = state.body_force;
        self.mesh_velocity = None;
        self.started = true;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::Axis;
    use crate::solver::viscoelastic::ViscoelasticParams;

    /// A start from a given state: the history holds it and the flow sees c⁰ = exp(s0), which
    /// the Q1 projection reproduces for a uniform state (round-off).
    #[test]
    fn an_initial_state_is_the_history_and_the_projected_conformation() {
        const ROUND_OFF: f64 = 1e-12;
        let mesh = Mesh::rectangle(
            Axis::uniform(0.0, 2.0, 4),
            Axis::uniform(0.0, 1.0, 2),
            false,
        );
        let params = ViscoelasticParams::new(0.1, 0.9, 1.0, 0.0, 0.01, 1.0);
        let mut flow = ViscoelasticFlow::new(mesh, params).unwrap();
        let s0 = crate::rheology::giesekus_steady_shear_conformation(0.7, 0.0)
            .log()
            .unwrap();
        flow.set_initial_log_conformation(|_| s0).unwrap();
        assert!(flow.history().current.iter().all(|&s| s == s0));
        assert_eq!(flow.history().steps(), 0);
        let c0 = s0.exp();
        for c in flow.conformation() {
            assert!((*c - c0).norm() < ROUND_OFF, "{c:?} vs {c0:?}");
        }
    }
}
