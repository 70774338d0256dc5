//! Sparsity pattern of the flow matrix: every element's couplings, those of each particle's
//! [`Reach`] with its rigid-body unknowns, the ghost-penalty patches next to the reach.

use super::dofs::{element_dofs, Layout, MAX_EL_DOFS};
use super::multipliers::{link_dofs, RingLink};
use super::reach::Reach;
use crate::fem::sparse::{PatternBuilder, SparseMatrix};
use crate::mesh::Mesh;
use crate::solver::ghost::faces_where;

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
