//! Boundary conditions of the flow and of the stress: walls and lines of prescribed velocity, the
//! pressure pin, and the log-conformation at an inflow boundary.

use super::ViscoelasticFlow;
use crate::mesh::Side;
use crate::rheology::Sym2;

impl ViscoelasticFlow {
    /// Prescribes the velocity on a side (walls, an inflow profile), for all times.
    pub fn set_velocity(
        &mut self,
        side: Side,
        f: impl Fn([f64; 2]) -> [f64; 2] + Send + Sync + 'static,
    ) {
        self.stokes.set_velocity(side, f);
    }

    /// Prescribes velocity components at the nodes `f` chooses (`None`: free), for all times: a
    /// no-slip line inside the mesh, u_y = 0 on a symmetry line
    /// ([`Stokes::set_velocity_where`](crate::solver::flow::Stokes::set_velocity_where)).
    pub fn set_velocity_where(
        &mut self,
        f: impl Fn([f64; 2]) -> [Option<f64>; 2] + Send + Sync + 'static,
    ) {
        self.stokes.set_velocity_where(f);
    }

    /// Prescribes the log-conformation s = log c at the vertices of an inflow side where `f`
    /// gives one (the fully developed state upstream), for all times; the history starts there
    /// too.
    pub fn set_inflow_log_conformation(
        &mut self,
        side: Side,
        f: impl Fn([f64; 2]) -> Option<Sym2>,
    ) {
        let inflow: Vec<(usize, Sym2)> = self
            .mesh
            .side_nodes(side)
            .into_iter()
            .filter_map(|n| self.mesh.vertex_of_node[n].map(|v| (n, v)))
            .filter_map(|(n, v)| f(self.mesh.nodes[n]).map(|s| (v, s)))
            .collect();
        for &(v, s) in &inflow {
            self.history.current[v] = s;
        }
        self.transport.set_inflow(inflow);
    }

    /// Pins the pressure (enclosed flows).
    pub fn pin_pressure(&mut self) {
        self.stokes.pin_pressure();
    }
}
