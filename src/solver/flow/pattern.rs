//! Sparsity pattern of the flow matrix, and each particle's reach: the elements coupled to its
//! rigid-body unknowns, so that the pattern and its symbolic factorization outlive small moves.

use super::dofs::{element_dofs, Layout, MAX_EL_DOFS};
use super::multipliers::{link_dofs, RingLink};
use crate::fem::sparse::{PatternBuilder, SparseMatrix};
use crate::mesh::dilate;
use crate::mesh::{bounding_box, Mesh, Shape};
use crate::solver::ghost::faces_where;
use crate::solver::rigid::{ElementCut, Particle};

/// How far beyond its boundary, in sizes of the element concerned, a particle's rigid-body
/// unknowns are coupled in the matrix pattern. A particle can move about this far before an
/// element it cuts lies outside the coupled set and the pattern and its symbolic factorization
/// must be rebuilt; the unused couplings store zeros.
const RIGID_REACH: f64 = 2.0;

/// Per particle, the elements whose velocity and pressure the pattern couples to its rigid-body
/// unknowns: bounding box within the radius plus [`RIGID_REACH`] element sizes of the centre
/// (nearest periodic image on a periodic rectangle).
fn rigid_reach(mesh: &Mesh, particles: &[Particle]) -> Vec<Vec<bool>> {
    let period = (mesh.periodic && mesh.shape == Shape::Rectangle)
        .then(|| mesh.ax.vertices[mesh.ax.len()] - mesh.ax.vertices[0]);
    particles
        .iter()
        .map(|p| {
            mesh.element_coords
                .iter()
                .map(|xe| {
                    let (lo, hi) = bounding_box(xe);
                    let size = (hi[0] - lo[0]).max(hi[1] - lo[1]);
                    let mut c = p.center;
                    if let Some(l) = period {
                        let mid = 0.5 * (lo[0] + hi[0]);
                        c[0] -= l * ((c[0] - mid) / l).round();
                    }
                    let q = [c[0].clamp(lo[0], hi[0]), c[1].clamp(lo[1], hi[1])];
                    (q[0] - c[0]).hypot(q[1] - c[1]) <= p.radius + RIGID_REACH * size
                })
                .collect()
        })
        .collect()
}

/// How far beyond the elements a free surface cuts (cut elements without particle pieces) the
/// pattern couples the ghost-penalty patches and the matrix is assembled every step, in elements:
/// the surface can move about this far before the pattern is rebuilt.
const SURFACE_REACH: usize = 2;

/// Where the flow matrix may change while a pattern lasts: each particle's reach (the elements
/// coupled to its rigid-body unknowns) and the band around a free surface. Elements outside it
/// are fluid and assembled from the cached base; the ghost-penalty patches of faces next to it
/// are in the pattern.
#[derive(Debug, Clone)]
pub(super) struct Reach {
    /// Per particle, the elements coupled to its rigid-body unknowns.
    pub particles: Vec<Vec<bool>>,
    /// The elements within [`SURFACE_REACH`] of an element cut by a free surface.
    pub surface: Vec<bool>,
}

impl Reach {
    /// Whether element `e` may be cut while the pattern lasts.
    pub fn contains(&self, e: usize) -> bool {
        self.surface[e] || self.particles.iter().any(|r| r[e])
    }

    /// Whether every cut element lies in the reach of what cuts it.
    pub fn covers(&self, cuts: &[ElementCut]) -> bool {
        cuts.iter().enumerate().all(|(e, c)| match c {
            ElementCut::Cut(c) if c.particles.is_empty() => self.surface[e],
            ElementCut::Cut(c) => c.particles.iter().all(|pc| self.particles[pc.particle][e]),
            _ => true,
        })
    }

    /// Whether the pattern couples the two elements of the face between `e` and `o` for the
    /// ghost penalty: faces next to an element in the reach (only those can be cut while the
    /// pattern lasts). The pattern and the nested-dissection ordering must agree on this.
    pub fn patched_face(&self, e: usize, o: usize) -> bool {
        self.contains(e) || self.contains(o)
    }
}

/// The [`Reach`] of the particles and surface cuts: [`rigid_reach`] of the particles, or every
/// element for every particle if that does not cover `cuts` (cuts not of these positions: a
/// caller's choice); the elements `cuts` has cut by a free surface, widened by
/// [`SURFACE_REACH`].
pub(super) fn reach_for(mesh: &Mesh, particles: &[Particle], cuts: &[ElementCut]) -> Reach {
    let surface_cut: Vec<bool> = cuts
        .iter()
        .map(|c| matches!(c, ElementCut::Cut(c) if c.particles.is_empty()))
        .collect();
    let surface = dilate(&surface_cut, mesh.dims(), mesh.periodic, SURFACE_REACH);
    let reach = Reach {
        particles: rigid_reach(mesh, particles),
        surface,
    };
    if reach.covers(cuts) {
        reach
    } else {
        Reach {
            particles: vec![vec![true; mesh.n_elements()]; particles.len()],
            ..reach
        }
    }
}

/// The sparsity pattern of the flow matrix: every element (also those inside particles, which
/// store zeros next to identity rows, so that a particle crossing the mesh does not change the
/// pattern), the rigid-body couplings of the elements in each particle's reach and the
/// multiplier couplings `links` (none with the weak rigid-body condition) and, with a lubrication
/// correction (`lubricated`), every particle's translation with every other's (the films'
/// resistances, [`crate::solver::lubrication`]: a dense 2N × 2N block, so that a film that forms
/// does not change the pattern).
pub(super) fn build_pattern(
    mesh: &Mesh,
    layout: &Layout,
    reach: &Reach,
    links: &[RingLink],
    lubricated: bool,
) -> SparseMatrix {
    let mut pb = PatternBuilder::new(layout.n_dofs());
    let mut dofs = Vec::with_capacity(MAX_EL_DOFS);
    let (mut g_ij, mut u_i) = (Vec::with_capacity(4), Vec::with_capacity(9));
    let mut group = Vec::with_capacity(25);
    for e in 0..mesh.n_elements() {
        element_dofs(mesh, layout, e, &mut dofs);
        for (i, r) in reach.particles.iter().enumerate() {
            if r[e] {
                group.clear();
                group.extend_from_slice(&dofs[..22]);
                group.extend((0..3).map(|c| layout.rigid(i, c)));
                pb.add_group(&group);
            }
        }
        // velocity and pressure couple fully; each G_ij only with itself and u_i (a third of
        // the entries a full element block would store)
        pb.add_group(&dofs[..22]);
        if layout.with_g {
            for ij in 0..4 {
                g_ij.clear();
                g_ij.extend(mesh.element_vertices[e].iter().map(|&v| layout.g(v, ij)));
                u_i.clear();
                u_i.extend(mesh.elements[e].iter().map(|&k| layout.u(k, ij / 2)));
                pb.add_group(&g_ij);
                pb.add_coupling(&g_ij, &u_i);
            }
        }
    }
    for face in faces_where(mesh, |e, o| reach.patched_face(e, o)) {
        group.clear();
        for e in [face.first, face.second] {
            element_dofs(mesh, layout, e, &mut dofs);
            group.extend_from_slice(&dofs[..22]);
        }
        group.sort_unstable();
        group.dedup();
        pb.add_group(&group);
        if layout.with_g {
            for ij in 0..4 {
                g_ij.clear();
                for e in [face.first, face.second] {
                    g_ij.extend(mesh.element_vertices[e].iter().map(|&v| layout.g(v, ij)));
                }
                g_ij.sort_unstable();
                g_ij.dedup();
                pb.add_group(&g_ij);
            }
        }
    }
    // a particle's three rigid unknowns couple with each other even outside any cut
    for i in 0..layout.n_particles {
        pb.add_group(&[layout.rigid(i, 0), layout.rigid(i, 1), layout.rigid(i, 2)]);
    }
    if lubricated && layout.n_particles > 1 {
        let translations: Vec<usize> = (0..layout.n_particles)
            .flat_map(|i| [layout.rigid(i, 0), layout.rigid(i, 1)])
            .collect();
        pb.add_group(&translations);
    }
    // a ring node's multipliers with the velocity of the elements its arcs cross, the rigid
    // unknowns and (zero) each other
    for link in links {
        let (rows, cols) = link_dofs(mesh, layout, link);
        pb.add_group(&rows);
        pb.add_coupling(&rows, &cols);
    }
    pb.build()
}
