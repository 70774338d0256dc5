//! The flow system's part of the multiplier rigid-body condition ([`crate::solver::multiplier`]):
//! the rings of the particles, which elements each ring node couples to (the links the pattern
//! holds), the assembly of the coupling, and the force and torque the multipliers carry.

use super::dofs::Layout;
use super::Stokes;
use crate::fem::element::{q2, q2_map};
use crate::mesh::Mesh;
use crate::solver::multiplier::Ring;
use crate::solver::rigid::{jump_vectors, ElementCut, Particle};

/// Most ring nodes one boundary piece in one element touches (a particle inside a few elements
/// has all [`MIN_RING_NODES`](crate::solver::multiplier::MIN_RING_NODES) of its ring there; a
/// ring of the fluid elements' size touches two to four per element).
const MAX_PIECE_NODES: usize = 16;

/// A coupling of the pattern: ring node `node` (global) with the velocity of element `element`
/// and the rigid unknowns of particle `particle`. Sorted, no duplicates.
pub(super) type RingLink = (u32, u32, u32);

/// The rings of `particles` for the multiplier condition: ring elements of the size of the
/// elements each particle cuts (mean √area; [`Ring::for_particles`]).
pub(super) fn rings_for(mesh: &Mesh, particles: &[Particle], cuts: &[ElementCut]) -> Vec<Ring> {
    let mut sum = vec![(0.0, 0usize); particles.len()];
    for (e, cut) in cuts.iter().enumerate() {
        let ElementCut::Cut(c) = cut else { continue };
        let area = 4.0 * q2_map(&mesh.element_coords[e], [0.0, 0.0]).2;
        for pc in &c.particles {
            sum[pc.particle].0 += area.sqrt();
            sum[pc.particle].1 += 1;
        }
    }
    let radii: Vec<f64> = particles.iter().map(|p| p.radius).collect();
    let h: Vec<f64> = (sum.iter().zip(&radii))
        // a particle that cuts no element (outside the mesh) gets the minimum ring
        .map(|(&(s, n), &a)| if n > 0 { s / n as f64 } else { a })
        .collect();
    Ring::for_particles(&radii, &h)
}

/// The links of the boundary points of `cuts`: each point's two ring nodes and, so that the
/// pattern outlasts small moves and rotations of the arcs in an element, the nodes next to them.
pub(super) fn ring_links(rings: &[Ring], cuts: &[ElementCut]) -> Vec<RingLink> {
    let mut links = Vec::new();
    if rings.is_empty() {
        return links;
    }
    for (e, cut) in cuts.iter().enumerate() {
        let ElementCut::Cut(c) = cut else { continue };
        for pc in &c.particles {
            let ring = &rings[pc.particle];
            for bp in &pc.points {
                let r = [bp.x[0] - pc.center[0], bp.x[1] - pc.center[1]];
                for (k, _) in ring.basis_at(r) {
                    for node in [k, ring.neighbours(k)[0], ring.neighbours(k)[1]] {
                        links.push((e as u32, node as u32, pc.particle as u32));
                    }
                }
            }
        }
    }
    links.sort_unstable();
    links.dedup();
    links
}

/// Whether every link of `needed` is in `held` (both sorted).
pub(super) fn links_cover(held: &[RingLink], needed: &[RingLink]) -> bool {
    needed.iter().all(|l| held.binary_search(l).is_ok())
}

/// The pattern entries of one link: the ring node's two multipliers with the element's 18
/// velocity dofs and the particle's three rigid unknowns, and with each other.
pub(super) fn link_dofs(
    mesh: &Mesh,
    lay: &Layout,
    &(e, k, i): &RingLink,
) -> ([usize; 2], [usize; 21]) {
    let mut cols = [0usize; 21];
    for (a, &node) in mesh.elements[e as usize].iter().enumerate() {
        cols[2 * a] = lay.u(node, 0);
        cols[2 * a + 1] = lay.u(node, 1);
    }
    for c in 0..3 {
        cols[18 + c] = lay.rigid(i as usize, c);
    }
    let k = k as usize;
    ([lay.multiplier(k, 0), lay.multiplier(k, 1)], cols)
}

impl Stokes {
    /// Adds the multiplier coupling (v − V − χ × r, λ)_Γ and (μ, u − U − ω × r)_Γ of every
    /// boundary piece: local dofs 18 velocity, 3 rigid, then the two multipliers of each ring
    /// node the piece touches.
    pub(super) fn assemble_multipliers(&mut self) {
        let lay = self.layout;
        let mut dofs: Vec<usize> = Vec::with_capacity(21 + 2 * MAX_PIECE_NODES);
        let mut nodes: Vec<usize> = Vec::with_capacity(MAX_PIECE_NODES);
        let mut ke: Vec<f64> = Vec::new();
        let fe = [0.0; 21 + 2 * MAX_PIECE_NODES];
        for (e, cut) in self.cuts.iter().enumerate() {
            let ElementCut::Cut(c) = cut else { continue };
            for pc in &c.particles {
                let ring = &self.rings[pc.particle];
                nodes.clear();
                for bp in &pc.points {
                    let r = [bp.x[0] - pc.center[0], bp.x[1] - pc.center[1]];
                    for (k, _) in ring.basis_at(r) {
                        if !nodes.contains(&k) {
                            nodes.push(k);
                        }
                    }
                }
                assert!(
                    nodes.len() <= MAX_PIECE_NODES,
                    "element {e}: a boundary piece touches more than {MAX_PIECE_NODES} ring nodes"
                );
                let link = (e as u32, 0, pc.particle as u32);
                let (_, cols) = link_dofs(&self.mesh, &lay, &link);
                dofs.clear();
                dofs.extend_from_slice(&cols);
                for &k in &nodes {
                    dofs.extend([lay.multiplier(k, 0), lay.multiplier(k, 1)]);
                }
                let n = dofs.len();
                ke.clear();
                ke.resize(n * n, 0.0);
                for bp in &pc.points {
                    let phi = q2(bp.xi).0;
                    let r = [bp.x[0] - pc.center[0], bp.x[1] - pc.center[1]];
                    let jv = jump_vectors(&phi, r);
                    for (k, mu) in ring.basis_at(r) {
                        let slot = nodes.iter().position(|&m| m == k).expect("collected above");
                        for c in 0..2 {
                            let row = 21 + 2 * slot + c;
                            for (alpha, j) in jv.iter().enumerate() {
                                let v = bp.w * mu * j[c];
                                ke[row * n + alpha] += v;
                                ke[alpha * n + row] += v;
                            }
                        }
                    }
                }
                self.matrix
                    .scatter(&dofs, &ke, &fe[..n], &mut self.rhs, &self.unconstrained);
            }
        }
    }

    /// Force and torque on each particle from its multipliers: ∫_Γ λ ds and ∫_Γ r × λ ds on the
    /// boundary quadrature (the reaction of the rigid rows, thesis Eq. 2.57).
    pub(super) fn multiplier_forces(&self) -> Vec<[f64; 3]> {
        let lay = self.layout;
        let mut out = vec![[0.0; 3]; lay.n_particles];
        for cut in &self.cuts {
            let ElementCut::Cut(c) = cut else { continue };
            for pc in &c.particles {
                let ring = &self.rings[pc.particle];
                for bp in &pc.points {
                    let r = [bp.x[0] - pc.center[0], bp.x[1] - pc.center[1]];
                    let mut l = [0.0; 2];
                    for (k, mu) in ring.basis_at(r) {
                        l[0] += mu * self.sol[lay.multiplier(k, 0)];
                        l[1] += mu * self.sol[lay.multiplier(k, 1)];
                    }
                    let f = &mut out[pc.particle];
                    f[0] += bp.w * l[0];
                    f[1] += bp.w * l[1];
                    f[2] += bp.w * (r[0] * l[1] - r[1] * l[0]);
                }
            }
        }
        out
    }
}
