//! Constraints of the flow system: identity rows of the nodes touching no fluid, prescribed
//! particle motions, wall velocities (re-evaluated on a moved mesh) and the pressure pin.

use super::{Layout, Stokes};
use crate::mesh::{Mesh, Side};
use crate::solver::rigid::{ElementCut, Motion};

/// A wall velocity x ↦ u(x) of [`Stokes::set_velocity`], kept to re-evaluate it on a moved mesh.
pub(super) type WallVelocity = Box<dyn Fn([f64; 2]) -> [f64; 2] + Send + Sync>;

/// Velocity components prescribed at nodes chosen by position ([`Stokes::set_velocity_where`]):
/// x ↦ [u_x, u_y], `None` where a component is free.
pub(super) type NodeVelocity = Box<dyn Fn([f64; 2]) -> [Option<f64>; 2] + Send + Sync>;

/// A velocity condition as given, kept to re-evaluate it on a moved mesh.
pub(super) enum VelocityCondition {
    /// Both components on a side of the mesh.
    Side(Side, WallVelocity),
    /// Components at the nodes a function chooses (interior lines such as a die wall, one
    /// component on a symmetry line).
    Nodes(NodeVelocity),
}

/// Appends the (dof, value) pairs of a velocity condition.
pub(super) fn push_condition_values(
    mesh: &Mesh,
    layout: &Layout,
    condition: &VelocityCondition,
    out: &mut Vec<(usize, f64)>,
) {
    match condition {
        VelocityCondition::Side(side, f) => push_wall_values(mesh, layout, *side, f, out),
        VelocityCondition::Nodes(f) => {
            for (k, x) in mesh.nodes.iter().enumerate() {
                for (c, v) in f(*x).iter().enumerate() {
                    if let Some(v) = v {
                        out.push((layout.u(k, c), *v));
                    }
                }
            }
        }
    }
}

/// Appends the (dof, value) pairs of the velocity `f` at the nodes of `side`.
pub(super) fn push_wall_values(
    mesh: &Mesh,
    layout: &Layout,
    side: Side,
    f: &dyn Fn([f64; 2]) -> [f64; 2],
    out: &mut Vec<(usize, f64)>,
) {
    for k in mesh.side_nodes(side) {
        let v = f(mesh.nodes[k]);
        for (c, vc) in v.iter().enumerate() {
            out.push((layout.u(k, c), *vc));
        }
    }
}

impl Stokes {
    /// The constraints of the current cuts, particle motions, wall velocities and pressure pin.
    pub(super) fn reset_constraints(&mut self) {
        self.fixed = self.geometric_constraints();
        for &(dof, v) in &self.wall_values {
            self.fixed[dof] = Some(v);
        }
        if self.pressure_pinned {
            self.pin_pressure();
        }
    }

    /// Identity rows of the nodes touching no fluid and the prescribed particle motions.
    pub(super) fn geometric_constraints(&self) -> Vec<Option<f64>> {
        let (mesh, layout) = (&self.mesh, &self.layout);
        let mut fixed = vec![None; layout.n_dofs()];
        let mut active = vec![false; layout.n_nodes];
        for (e, cut) in self.cuts.iter().enumerate() {
            if !matches!(cut, ElementCut::Inside) {
                mesh.elements[e].iter().for_each(|&k| active[k] = true);
            }
        }
        for k in 0..layout.n_nodes {
            if !active[k] {
                fixed[layout.u(k, 0)] = Some(0.0);
                fixed[layout.u(k, 1)] = Some(0.0);
                if let Some(v) = mesh.vertex_of_node[k] {
                    fixed[layout.p(v)] = Some(0.0);
                    if layout.with_g {
                        (0..4).for_each(|ij| fixed[layout.g(v, ij)] = Some(0.0));
                    }
                }
            }
        }
        for (i, p) in self.particles.iter().enumerate() {
            if let Motion::Prescribed { u, omega } = p.motion {
                fixed[layout.rigid(i, 0)] = Some(u[0]);
                fixed[layout.rigid(i, 1)] = Some(u[1]);
                fixed[layout.rigid(i, 2)] = Some(omega);
            }
        }
        fixed
    }

    /// Prescribes the velocity `f(x)` at all nodes of the given side (a later call wins at nodes
    /// shared by two sides). `f` is kept and re-evaluated when the mesh moves
    /// ([`set_mesh`](Self::set_mesh)).
    pub fn set_velocity(
        &mut self,
        side: Side,
        f: impl Fn([f64; 2]) -> [f64; 2] + Send + Sync + 'static,
    ) {
        self.add_condition(VelocityCondition::Side(side, Box::new(f)));
    }

    /// Prescribes velocity components at the nodes `f` chooses: `f(x)` gives [u_x, u_y] with
    /// `None` for a free component (e.g. a no-slip line inside the mesh, or u_y = 0 alone on a
    /// symmetry line). Kept and re-evaluated as [`set_velocity`](Self::set_velocity) is; a later
    /// condition wins where two prescribe the same component.
    pub fn set_velocity_where(
        &mut self,
        f: impl Fn([f64; 2]) -> [Option<f64>; 2] + Send + Sync + 'static,
    ) {
        self.add_condition(VelocityCondition::Nodes(Box::new(f)));
    }

    fn add_condition(&mut self, condition: VelocityCondition) {
        let start = self.wall_values.len();
        push_condition_values(&self.mesh, &self.layout, &condition, &mut self.wall_values);
        for &(dof, v) in &self.wall_values[start..] {
            self.fixed[dof] = Some(v);
        }
        self.walls.push(condition);
    }

    /// Pins the pressure at vertex 0 (for flows with velocity prescribed on the whole boundary).
    pub fn pin_pressure(&mut self) {
        let v = (0..self.layout.n_vertices)
            .find(|&v| self.fixed[self.layout.p(v)].is_none())
            .expect("some pressure vertex touches the fluid");
        self.fixed[self.layout.p(v)] = Some(0.0);
        self.pressure_pinned = true;
    }
}
