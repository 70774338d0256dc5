//! The history (sⁿ, s^{n−1}, Gⁿ) carried onto a moved configuration by the temporary ALE map
//! (thesis §5.3.3, Eqs. 5.42–5.44), and the flow moved onto new particle positions or a mesh whose
//! columns and rows moved.

use super::{fluid_nodes, ViscoelasticError, ViscoelasticFlow};
use crate::mesh::Mesh;
use crate::rheology::Sym2;
use crate::solver::ale::{extend_inside, StencilWeights, STENCIL_LEN};
use crate::solver::constitutive::{inactive_vertices, LogConformationHistory};
use crate::solver::rigid::{ElementCut, Particle};

/// How the history moves onto the current configuration (temporary ALE map, thesis §5.3.3):
/// for every Q1 vertex x the interpolation at its pre-images xⁿ = Φₙ⁻¹(x) and
/// xⁿ⁻¹ = Φₙ₋₁⁻¹(xⁿ), Eqs. 5.42–5.43, and the mesh velocity of Eq. 5.44.
#[derive(Debug, Clone, Copy)]
pub struct HistoryMap<'a> {
    /// Interpolation of the fields at tⁿ (sⁿ, Gⁿ) at each vertex's pre-image.
    pub at_n: &'a [StencilWeights],
    /// Interpolation of s^{n−1}; `None` makes the coming step first order (Euler, Eq. 5.53).
    pub at_n_minus_1: Option<&'a [StencilWeights]>,
    /// Mesh velocity u_m^{n+1} at the Q2 nodes.
    pub mesh_velocity: &'a [[f64; 2]],
}

/// The four velocity-gradient components, as a vector space for interpolation.
#[derive(Debug, Clone, Copy)]
struct Grad4([f64; 4]);

impl std::ops::Add for Grad4 {
    type Output = Self;
    fn add(self, o: Self) -> Self {
        Grad4(std::array::from_fn(|i| self.0[i] + o.0[i]))
    }
}

impl std::ops::Mul<f64> for Grad4 {
    type Output = Self;
    fn mul(self, a: f64) -> Self {
        Grad4(self.0.map(|v| v * a))
    }
}

/// Moves sⁿ and s^{n−1} onto the new configuration (Eqs. 5.42–5.43). sⁿ is interpolated at
/// Φₙ⁻¹(x); s^{n−1} once at Φₙ₋₁⁻¹∘Φₙ⁻¹(x) from the copy of it as solved, which the previous
/// move left in `unmapped` (the copy in `history.previous` was already mapped by that move, and
/// the composite pre-image would carry it a step too far). Only when the last step did not move
/// (no unmapped copy of that step) is `history.previous` on the configuration of sⁿ, and then it
/// follows sⁿ's map. Leaves the unmapped sⁿ in `unmapped`.
fn carry_history(
    history: &mut LogConformationHistory,
    unmapped: &mut Option<(usize, Vec<Sym2>)>,
    map: &HistoryMap<'_>,
) {
    let steps = history.steps();
    let unmapped_nm1 = take_unmapped(unmapped, steps);
    history.previous = carry_previous(history.previous.take(), unmapped_nm1, map);
    let current = interpolate(&history.current, map.at_n);
    *unmapped = Some((steps, std::mem::replace(&mut history.current, current)));
}

/// The unmapped copy of the level before the current one, if the last move kept it one step
/// ago.
fn take_unmapped<T>(unmapped: &mut Option<(usize, Vec<T>)>, steps: usize) -> Option<Vec<T>> {
    unmapped
        .take()
        .filter(|(at, _)| at + 1 == steps)
        .map(|u| u.1)
}

/// The level n−1 on the new configuration: from its unmapped copy at the composite pre-image,
/// or, without one, the stored copy (then on the configuration of level n) at Φₙ⁻¹.
fn carry_previous<T>(
    mapped: Option<Vec<T>>,
    unmapped_nm1: Option<Vec<T>>,
    map: &HistoryMap<'_>,
) -> Option<Vec<T>>
where
    T: Copy + std::ops::Add<Output = T> + std::ops::Mul<f64, Output = T>,
{
    match (map.at_n_minus_1, unmapped_nm1, mapped) {
        (None, _, _) => None,
        (Some(at), Some(raw), _) => Some(interpolate(&raw, at)),
        (Some(_), None, Some(prev)) => Some(interpolate(&prev, map.at_n)),
        (Some(_), None, None) => None,
    }
}

fn interpolate<T>(field: &[T], at: &[StencilWeights]) -> Vec<T>
where
    T: Copy + std::ops::Add<Output = T> + std::ops::Mul<f64, Output = T>,
{
    at.iter()
        .map(|(v, w)| {
            let mut acc = field[v[0]] * w[0];
            for k in 1..STENCIL_LEN {
                if w[k] != 0.0 {
                    acc = acc + field[v[k]] * w[k];
                }
            }
            acc
        })
        .collect()
}

impl ViscoelasticFlow {
    /// Moves the particles to new positions (the predicted configuration of the coming step,
    /// with its `cuts`): the flow, transport and projection solvers take the new fluid domain,
    /// the history sⁿ, s^{n−1} and Gⁿ are carried over by the temporary ALE `map`, cⁿ is
    /// re-projected on the new fluid domain, and the coming step convects with u − u_m.
    ///
    /// # Errors
    /// [`ViscoelasticError::FlowRateNeedsFixedBodies`] with flow-rate control (its unit response
    /// belongs to one configuration), [`ViscoelasticError::Stress`] if the projection fails.
    ///
    /// # Panics
    /// Panics if the number of particles changes or the map does not cover every vertex.
    pub fn move_particles(
        &mut self,
        particles: Vec<Particle>,
        cuts: Vec<ElementCut>,
        map: HistoryMap<'_>,
    ) -> Result<(), ViscoelasticError> {
        self.move_particles_onto(None, particles, cuts, Some(map))
    }

    /// [`move_particles`](Self::move_particles) onto a computational mesh `onto` whose vertex
    /// columns and rows have moved (same topology; `None`: the mesh stays): the `map` gives the
    /// pre-images of `onto`'s vertices in the current mesh (see
    /// [`TemporaryAle::advance_onto`](crate::solver::ale::TemporaryAle::advance_onto)) and
    /// `cuts` are the particles cut into `onto`. A fluid without polymer has no history: its
    /// `map` may be `None`.
    ///
    /// # Errors
    /// As [`move_particles`](Self::move_particles).
    ///
    /// # Panics
    /// As [`move_particles`](Self::move_particles), if `onto` has another topology, and if a
    /// fluid with polymer is given no map.
    pub fn move_particles_onto(
        &mut self,
        onto: Option<Mesh>,
        particles: Vec<Particle>,
        cuts: Vec<ElementCut>,
        map: Option<HistoryMap<'_>>,
    ) -> Result<(), ViscoelasticError> {
        if self.flow_rate.is_some() {
            return Err(ViscoelasticError::FlowRateNeedsFixedBodies);
        }
        if !self.params.has_polymer() {
            // Stokes flow has no history to carry: the new geometry is all that changes
            if let Some(mesh) = onto {
                self.set_mesh(mesh);
            }
            self.fluid_node = fluid_nodes(&self.mesh, &particles, &cuts);
            self.stokes.set_particles(particles, cuts.clone());
            self.cuts = cuts;
            return Ok(());
        }
        let map = map.expect("a fluid with polymer has a history to map");
        let nv = self.mesh.n_vertices();
        assert_eq!(map.at_n.len(), nv, "one pre-image per vertex");
        // sⁿ and Gⁿ as solved on the old configuration, extended into the old particles
        let known: Vec<bool> = inactive_vertices(&self.mesh, &self.cuts)
            .iter()
            .map(Option::is_none)
            .collect();
        extend_inside(&self.mesh, &known, &mut self.history.current);
        let mut g: Vec<Grad4> = self.gradient.iter().map(|&g| Grad4(g)).collect();
        extend_inside(&self.mesh, &known, &mut g);
        carry_history(&mut self.history, &mut self.unmapped, &map);
        self.gradient = interpolate(&g, map.at_n).into_iter().map(|g| g.0).collect();
        // the carried fields are values at the new mesh's vertices from here on
        if let Some(mesh) = onto {
            self.set_mesh(mesh);
        }
        self.fluid_node = fluid_nodes(&self.mesh, &particles, &cuts);
        self.transport.set_cuts(&self.mesh, cuts.clone());
        self.projection.set_cuts(&self.mesh, cuts.clone());
        self.stokes.set_particles(particles, cuts.clone());
        self.cuts = cuts;
        self.mesh_velocity = Some(map.mesh_velocity.to_vec());
        self.projection.project_conformation(
            &self.mesh,
            &self.history.current,
            &mut self.conformation,
        )?;
        // c^{n−1} serves the semi-implicit predictor and the extrapolated explicit stress only
        let needed = self.params.needs_previous_conformation();
        self.conformation_prev = match &self.history.previous {
            Some(prev) if needed => {
                let mut c = self
                    .conformation_prev
                    .take()
                    .unwrap_or_else(|| vec![Sym2::IDENTITY; nv]);
                self.projection
                    .project_conformation(&self.mesh, prev, &mut c)?;
                Some(c)
            }
            _ => None,
        };
        Ok(())
    }

    /// Swaps in a computational mesh of the same topology whose columns or rows have moved; the
    /// nodal fields are taken as values at its nodes (the caller has mapped them). The cuts must
    /// be set next (as [`move_particles_onto`](Self::move_particles_onto) and
    /// [`restore_on`](Self::restore_on) do).
    pub(super) fn set_mesh(&mut self, mesh: Mesh) {
        // (the flow solver checks the topology)
        if (&mesh.ax, &mesh.ay) == (&self.mesh.ax, &self.mesh.ay) {
            return;
        }
        self.stokes.set_mesh(mesh.clone());
        self.projection.geometry_changed();
        self.mesh = mesh;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Pre-image of vertex i is vertex i − k (clamped at 0), weight 1: a shift by k vertices.
    fn shift(n: usize, k: usize) -> Vec<StencilWeights> {
        (0..n)
            .map(|i| {
                let mut w = ([i.saturating_sub(k); STENCIL_LEN], [0.0; STENCIL_LEN]);
                w.1[0] = 1.0;
                w
            })
            .collect()
    }

    fn field(n: usize, offset: f64) -> Vec<Sym2> {
        (0..n)
            .map(|i| Sym2::new(offset + i as f64, 0.0, 0.0))
            .collect()
    }

    #[test]
    fn previous_level_is_mapped_once_at_the_composite_pre_image() {
        let n = 8;
        let (s1, s2) = (shift(n, 1), shift(n, 2));
        let velocity = vec![[0.0; 2]; 1];
        let mut h = LogConformationHistory::from_field(field(n, 0.0));
        let mut unmapped = None;
        // first move (Euler step): s⁰ follows Φ₀⁻¹, no s^{-1}
        let first = HistoryMap {
            at_n: &s1,
            at_n_minus_1: None,
            mesh_velocity: &velocity,
        };
        carry_history(&mut h, &mut unmapped, &first);
        assert!(h.previous.is_none());
        h.push(field(n, 100.0), 0.1);
        // second move: s¹ at Φ₁⁻¹, s⁰ at Φ₀⁻¹∘Φ₁⁻¹ = a shift by 2 from s⁰ as solved
        let second = HistoryMap {
            at_n: &s1,
            at_n_minus_1: Some(&s2),
            mesh_velocity: &velocity,
        };
        carry_history(&mut h, &mut unmapped, &second);
        let prev = h.previous.as_ref().expect("BDF2 level");
        for i in 2..n {
            assert_eq!(h.current[i].xx, 100.0 + (i - 1) as f64);
            // mapping the already mapped copy would give i − 3
            assert_eq!(prev[i].xx, (i - 2) as f64, "vertex {i}");
        }
    }

    #[test]
    fn without_an_earlier_move_the_previous_level_follows_the_current_map() {
        let n = 8;
        let (s1, s2) = (shift(n, 1), shift(n, 2));
        let velocity = vec![[0.0; 2]; 1];
        let mut h = LogConformationHistory::from_field(field(n, 0.0));
        h.push(field(n, 100.0), 0.1);
        let map = HistoryMap {
            at_n: &s1,
            at_n_minus_1: Some(&s2),
            mesh_velocity: &velocity,
        };
        let mut unmapped = None;
        carry_history(&mut h, &mut unmapped, &map);
        let prev = h.previous.as_ref().expect("BDF2 level");
        for i in 1..n {
            assert_eq!(prev[i].xx, (i - 1) as f64, "vertex {i}");
        }
    }
}
