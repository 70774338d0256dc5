//! Unit tests of the ring-restricted ALE map ([`AleExtent::Ring`]): the displacement is the
//! whole mesh's near the patch in kind (rigid there, harmonic, bounded) and zero beyond the ring,
//! where the nodes are their own pre-images.

use super::remap_tests::bicubic_field;
use super::tests::{bdf_of, LOCATE_TOL};
use super::*;
use crate::mesh::Axis;

/// Length (and period) of [`long_channel`].
const LENGTH: f64 = 8.0;

/// A channel long enough for the ring to end well inside it: h = 0.05 (the patch of a = 0.15
/// spans about six elements, the ring [`RING_ELEMENTS`] more on each side).
fn long_channel() -> Mesh {
    Mesh::rectangle(
        Axis::uniform(-0.5 * LENGTH, 0.5 * LENGTH, 160),
        Axis::uniform(-0.5, 0.5, 20),
        true,
    )
}

fn ring(mesh: &Mesh) -> TemporaryAle {
    let mut ale = TemporaryAle::new(mesh);
    ale.extent = AleExtent::Ring;
    ale
}

/// Solve residual 1e-10 relative on O(0.01) displacements.
const SOLVE_TOL: f64 = 1e-11;

#[test]
fn a_ring_map_is_rigid_on_the_patch_harmonic_and_zero_beyond_the_ring() {
    let mesh = long_channel();
    let (c, a, disp) = ([0.5 * LENGTH - 0.1, 0.05], 0.15, [0.012, -0.004]);
    let moves = vec![RigidMove {
        center: c,
        radius: a,
        displacement: disp,
    }];
    let d = ring(&mesh)
        .displacement(&mesh, &moves, Some(LENGTH))
        .unwrap();
    let whole = TemporaryAle::new(&mesh)
        .displacement(&mesh, &moves, Some(LENGTH))
        .unwrap();
    // the ring's outer edge: the patch's elements reach a + h√2 from the centre, the ring
    // RING_ELEMENTS elements beyond (in index space: up to √2 further in a corner)
    let h = 0.05;
    let beyond = a + h * 2f64.sqrt() * (RING_ELEMENTS as f64 + 1.0);
    let (mut on_patch, mut moved, mut still) = (0, 0, 0);
    for (v, &k) in mesh.node_of_vertex.iter().enumerate() {
        let x = mesh.nodes[k];
        // across the periodic seam
        let dx = crate::periodic::fold(x[0] - c[0], Some(LENGTH));
        let r = dx.hypot(x[1] - c[1]);
        if r < a {
            assert!((d[v][0] - disp[0]).abs() + (d[v][1] - disp[1]).abs() < SOLVE_TOL);
            on_patch += 1;
        }
        if r > beyond || x[1].abs() > 0.5 - 1e-12 {
            assert_eq!(d[v], [0.0, 0.0], "{x:?}");
        }
        // maximum principle, componentwise, and no larger than the whole mesh's
        assert!(d[v][0] > -SOLVE_TOL && d[v][0] < disp[0] + SOLVE_TOL);
        assert!(d[v][1] < SOLVE_TOL && d[v][1] > disp[1] - SOLVE_TOL);
        assert!(d[v][0] <= whole[v][0] + SOLVE_TOL, "{x:?}");
        if d[v] == [0.0, 0.0] {
            still += 1;
        } else {
            moved += 1;
        }
    }
    assert!(on_patch >= 4, "{on_patch}");
    // the whole mesh moves but for its walls; the ring a neighbourhood of the particle
    assert!(moved < still / 4, "{moved} moved, {still} still");
    assert!(whole.iter().filter(|w| **w != [0.0, 0.0]).count() > 3 * moved);
}

#[test]
fn nodes_beyond_the_ring_are_their_own_pre_images_and_the_ring_maps_exactly() {
    let mesh = long_channel();
    let mut ale = ring(&mesh);
    ale.remap = Remap::Cubic;
    let (v, dt) = ([0.3, -0.1], 0.05);
    let step = [v[0] * dt, v[1] * dt];
    let mut c = [0.0, 0.05];
    let mut last = None;
    for first in [true, false] {
        let moves = vec![RigidMove {
            center: c,
            radius: 0.15,
            displacement: step,
        }];
        let m = ale
            .advance(&mesh, &moves, Some(LENGTH), dt, bdf_of(first))
            .unwrap();
        last = Some((m, ale.last_displacement().unwrap().to_vec()));
        c = [c[0] + step[0], c[1] + step[1]];
    }
    let (m, d) = last.unwrap();
    let at_nm1 = m.at_n_minus_1.as_ref().expect("a second-order step");
    let f: Vec<f64> = mesh
        .node_of_vertex
        .iter()
        .map(|&k| bicubic_field(mesh.nodes[k]))
        .collect();
    let carried = |(vs, w): &StencilWeights| (0..STENCIL_LEN).map(|a| f[vs[a]] * w[a]).sum::<f64>();
    let mut own = 0;
    for (vtx, &k) in mesh.node_of_vertex.iter().enumerate() {
        let x = mesh.nodes[k];
        let (e, xi, xn) = pre_image(&mesh, &d, x, Some(LENGTH), None).unwrap();
        if d[vtx] == [0.0, 0.0] && xn == x {
            // no interpolation beyond the ring: the history stays as it is, the mesh still
            if at_n_minus_1_is_identity(at_nm1, vtx) {
                assert_eq!(m.at_n[vtx].1[0], 1.0);
                assert_eq!(m.mesh_velocity[k], [0.0, 0.0]);
                own += 1;
            }
        }
        // x = xⁿ + d(xⁿ) everywhere, and a bicubic field is carried to its pre-image exactly
        let dn = crate::fem::element::q1(xi).0;
        for i in 0..2 {
            let back = xn[i]
                + (0..4)
                    .map(|a| dn[a] * d[mesh.element_vertices[e][a]][i])
                    .sum::<f64>();
            assert!((back - x[i]).abs() < LOCATE_TOL, "{x:?}");
        }
        // (the field is not periodic: away from the seam)
        if x[0].abs() < 0.5 * LENGTH - 0.5 {
            let g = carried(&m.at_n[vtx]);
            assert!((g - bicubic_field(xn)).abs() < 1e-9, "{x:?}: {g}");
        }
    }
    assert!(
        own > mesh.n_vertices() / 2,
        "{own} of {}",
        mesh.n_vertices()
    );
}

fn at_n_minus_1_is_identity(at: &[StencilWeights], v: usize) -> bool {
    at[v].0[0] == v && at[v].1[0] == 1.0 && at[v].1[1..].iter().all(|&w| w == 0.0)
}

/// On the annulus (the Couette cell, periodic in θ) with the particle across the θ seam: the
/// ring wraps around the seam, the patch moves rigidly, the walls and the far side of the cell
/// stay, and every node's pre-image is found over second-order steps.
#[test]
fn a_ring_map_on_the_annulus_wraps_around_the_seam() {
    let g = crate::geometry::CouetteGeometry::new(1.0, 4.0, 1.0).unwrap();
    let mesh = g.build_mesh(64, 12);
    let mut ale = ring(&mesh);
    ale.remap = Remap::Cubic;
    let (a, dt) = (0.4, 0.25);
    let mut c = g.position(0.5, 0.06);
    let step = [0.0, -0.05];
    let mut last = None;
    for first in [true, false, false] {
        let moves = vec![RigidMove {
            center: c,
            radius: a,
            displacement: step,
        }];
        last = Some(
            ale.advance(&mesh, &moves, None, dt, bdf_of(first))
                .expect("every pre-image found"),
        );
        c = [c[0] + step[0], c[1] + step[1]];
    }
    let m = last.unwrap();
    let c_prev = [c[0] - step[0], c[1] - step[1]];
    let (mut rigid, mut still_far) = (0, 0);
    for (k, x) in mesh.nodes.iter().enumerate() {
        let u = m.mesh_velocity[k];
        let r = (x[0] - c_prev[0]).hypot(x[1] - c_prev[1]);
        if r < 0.5 * a {
            assert!((u[0] - step[0] / dt).abs() + (u[1] - step[1] / dt).abs() < 1e-9);
            rigid += 1;
        }
        // the far side of the cell (x < −1: the particle is at x ≈ 2.5, y ≈ 0)
        if x[0] < -1.0 {
            assert_eq!(u, [0.0, 0.0], "{x:?}");
            still_far += 1;
        }
        let on_wall =
            (x[0].hypot(x[1]) - 1.0).abs() < 1e-9 || (x[0].hypot(x[1]) - 4.0).abs() < 1e-9;
        if on_wall {
            assert!(u[0].abs() + u[1].abs() < 1e-12, "{x:?}: {u:?}");
        }
    }
    // the patch holds nodes on both sides of the seam (θ = 0 is the +x axis)
    let across = mesh
        .nodes
        .iter()
        .filter(|x| (x[0] - c_prev[0]).hypot(x[1] - c_prev[1]) < 0.5 * a && x[1] < 0.0);
    assert!(across.count() > 0);
    assert!(
        rigid >= 4 && still_far > 100,
        "{rigid} rigid, {still_far} still"
    );
}
