//! Numbering of the flow unknowns ([`Layout`]: velocity, pressure, G, the particles' rigid
//! velocities, the multipliers of their rings), the local dof list of an element, and the node blocks and nested-dissection
//! order handed to the LBLᵀ factorization.

use super::Stokes;
use crate::fem::linsolve::DofBlocks;
use crate::mesh::Mesh;

/// Numbering of the unknowns: velocity (2 per Q2 node), pressure (1 per Q1 vertex), then G
/// (4 per Q1 vertex, components G_xx, G_xy, G_yx, G_yy) when θ > 0.
#[derive(Debug, Clone, Copy)]
pub struct Layout {
    /// Number of Q2 nodes.
    pub n_nodes: usize,
    /// Number of Q1 vertices.
    pub n_vertices: usize,
    /// Whether G unknowns exist.
    pub with_g: bool,
    /// Number of particles (3 rigid unknowns each: U_x, U_y, ω).
    pub n_particles: usize,
    /// Number of multiplier ring nodes of all particles (2 unknowns each: λ_x, λ_y; 0 with the
    /// weak rigid-body condition, [`crate::solver::multiplier`]).
    pub n_ring_nodes: usize,
}

impl Layout {
    /// Velocity component `c` at node `k`.
    #[inline]
    pub fn u(&self, k: usize, c: usize) -> usize {
        2 * k + c
    }
    /// Pressure at vertex `v`.
    #[inline]
    pub fn p(&self, v: usize) -> usize {
        2 * self.n_nodes + v
    }
    /// G component `ij = 2i + j` at vertex `v`.
    #[inline]
    pub fn g(&self, v: usize, ij: usize) -> usize {
        2 * self.n_nodes + self.n_vertices + 4 * v + ij
    }
    /// Rigid unknown `c` (0: U_x, 1: U_y, 2: ω) of particle `i`.
    #[inline]
    pub fn rigid(&self, i: usize, c: usize) -> usize {
        self.n_field_dofs() + 3 * i + c
    }
    /// Multiplier component `c` at (global) ring node `k`.
    #[inline]
    pub fn multiplier(&self, k: usize, c: usize) -> usize {
        self.n_field_dofs() + 3 * self.n_particles + 2 * k + c
    }
    /// Number of field unknowns (velocity, pressure, G).
    pub fn n_field_dofs(&self) -> usize {
        2 * self.n_nodes + self.n_vertices + if self.with_g { 4 * self.n_vertices } else { 0 }
    }
    /// Total number of unknowns.
    pub fn n_dofs(&self) -> usize {
        self.n_field_dofs() + 3 * self.n_particles + 2 * self.n_ring_nodes
    }
}

/// Maximum dofs of one element: 18 velocity + 4 pressure + 16 G + 3 rigid for up to 4 particle pieces.
pub(super) const MAX_EL_DOFS: usize = 50;

/// Local dof list of element `e`: 18 velocity, 4 pressure, then 16 G (if present).
pub(super) fn element_dofs(mesh: &Mesh, lay: &Layout, e: usize, dofs: &mut Vec<usize>) {
    dofs.clear();
    for &k in &mesh.elements[e] {
        dofs.push(lay.u(k, 0));
        dofs.push(lay.u(k, 1));
    }
    for &v in &mesh.element_vertices[e] {
        dofs.push(lay.p(v));
    }
    if lay.with_g {
        for &v in &mesh.element_vertices[e] {
            for ij in 0..4 {
                dofs.push(lay.g(v, ij));
            }
        }
    }
}

/// Largest lattice region (in Q2 nodes) the nested-dissection ordering keeps in natural order.
const ND_LEAF: usize = 4;

impl Stokes {
    /// Node blocks for the LBLᵀ ordering: each Q2 node's velocity, then (at vertices) its G, then
    /// its pressure last.
    pub(super) fn dof_blocks(&self) -> DofBlocks {
        let lay = self.layout;
        let n = lay.n_dofs();
        // geometric nested dissection of the structured mesh: 17 % (200×50) and 27 % (440×110)
        // less flow factorization time than AMD on the node-block graph
        // (its separators must also cut the pattern's ghost-penalty patches)
        let mut order: Vec<u32> = self
            .mesh
            .nested_dissection(ND_LEAF, &|e, o| self.reach.patched_face(e, o))
            .into_iter()
            .map(|k| k as u32)
            .collect();
        order.extend((0..lay.n_particles).map(|i| (lay.n_nodes + i) as u32));
        let mut blocks = DofBlocks {
            block: vec![0; n],
            class: vec![0; n],
            order: Some(order),
        };
        for k in 0..lay.n_nodes {
            for c in 0..2 {
                blocks.block[lay.u(k, c)] = k as u32;
            }
        }
        for v in 0..lay.n_vertices {
            let k = self.mesh.node_of_vertex[v] as u32;
            blocks.block[lay.p(v)] = k;
            blocks.class[lay.p(v)] = 2;
            if lay.with_g {
                for ij in 0..4 {
                    blocks.block[lay.g(v, ij)] = k;
                    blocks.class[lay.g(v, ij)] = 1;
                }
            }
        }
        // a particle's block holds its rigid unknowns and the multipliers of its ring, the
        // multipliers first: both have zero diagonals (the LBLᵀ pivots inside supernodes only),
        // and each is nonsingular once what it constrains is eliminated — the velocity (ordered
        // before every particle block) for the multipliers, the multipliers for the rigid
        // unknowns
        for i in 0..lay.n_particles {
            for c in 0..3 {
                blocks.block[lay.rigid(i, c)] = (lay.n_nodes + i) as u32;
                blocks.class[lay.rigid(i, c)] = 1;
            }
        }
        for (i, ring) in self.rings.iter().enumerate() {
            for k in ring.first..ring.first + ring.nodes {
                for c in 0..2 {
                    blocks.block[lay.multiplier(k, c)] = (lay.n_nodes + i) as u32;
                }
            }
        }
        blocks
    }
}
