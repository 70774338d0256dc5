//! Unit tests of the temporary ALE map on the annulus, and of the extension into a disc.

use super::tests::bdf_of;
use super::*;

use crate::geometry::CouetteGeometry;

#[test]
fn extension_into_a_disc_is_exact_for_linear_fields() {
    // graded in x (distance-weighted extrapolation), periodic; hole: a disc across the seam
    use crate::mesh::Axis;
    let ax = Axis::banded(-2.0, 2.0, -1.9, 0.4, 0.1, 1.2);
    let mesh = Mesh::rectangle(ax, Axis::uniform(-1.0, 1.0, 20), true);
    let (c, r, h) = ([-1.8, 0.1], 0.55, 0.1);
    let f = |p: [f64; 2]| 0.3 + 1.7 * p[0] - 0.9 * p[1];
    let period = 4.0;
    let depth = |p: [f64; 2]| {
        let dx = p[0] - c[0] - period * ((p[0] - c[0]) / period).round();
        r - dx.hypot(p[1] - c[1])
    };
    let mut known = vec![true; mesh.n_vertices()];
    let mut field = vec![0.0; mesh.n_vertices()];
    for v in 0..mesh.n_vertices() {
        let p = mesh.nodes[mesh.node_of_vertex[v]];
        known[v] = depth(p) < 0.0;
        // the exact field seen across the seam from the hole: x unwrapped next to c
        let x = c[0] + (p[0] - c[0]) - period * ((p[0] - c[0]) / period).round();
        field[v] = if known[v] { f([x, p[1]]) } else { f64::NAN };
    }
    extend_inside(&mesh, &known, &mut field);
    let mut filled = 0;
    for v in 0..mesh.n_vertices() {
        let p = mesh.nodes[mesh.node_of_vertex[v]];
        let x = c[0] + (p[0] - c[0]) - period * ((p[0] - c[0]) / period).round();
        if known[v] {
            continue;
        }
        if field[v].is_finite() {
            filled += 1;
            assert!(
                (field[v] - f([x, p[1]])).abs() < 1e-12,
                "vertex at {p:?}: {} vs {}",
                field[v],
                f([x, p[1]])
            );
        } else {
            // two layers reach at least 2h deep
            assert!(
                depth(p) > 2.0 * h,
                "vertex at {p:?} (depth {}) not filled",
                depth(p)
            );
        }
    }
    assert!(filled > 40, "{filled} vertices filled");
}

#[test]
fn pre_images_on_the_annulus() {
    let g = CouetteGeometry::new(1.0, 4.0, 1.0).unwrap();
    let mesh = g.build_mesh(64, 12);
    let mut ale = TemporaryAle::new(&mesh);
    let mut c = g.position(0.5, 0.3);
    for first in [true, false, false] {
        let step = [-0.064 * 0.3f64.sin(), 0.064 * 0.3f64.cos()];
        let moves = vec![RigidMove {
            center: c,
            radius: 0.4,
            displacement: step,
        }];
        ale.advance(&mesh, &moves, None, 0.25, bdf_of(first))
            .unwrap();
        c = [c[0] + step[0], c[1] + step[1]];
    }
}

/// A mesh that follows a particle in the Couette cell moves its θ columns: the wall nodes of
/// the new mesh lie between those of the old one, where the old discrete (piecewise
/// parabolic) boundary is O(h⁴) inside the circles. Their pre-images, and the second
/// pre-images of those in the mesh before, must still be found; on the walls (d = 0) they
/// are the nodes themselves, so the mesh velocity there vanishes but for that O(h⁴).
#[test]
fn pre_images_of_wall_nodes_on_a_moved_annulus() {
    let g = CouetteGeometry::new(1.0, 4.0, 1.0).unwrap();
    let base = g.build_mesh(64, 12);
    let two_pi = 2.0 * std::f64::consts::PI;
    let turned = |shift: f64| {
        let theta = Axis {
            vertices: (0..=64)
                .map(|i| {
                    let s = i as f64 / 64.0;
                    shift + two_pi * s + 0.05 * (two_pi * s).sin()
                })
                .collect(),
        };
        base.with_axes(theta, base.ay.clone())
    };
    let meshes = [base.clone(), turned(-0.03), turned(-0.07)];
    let mut ale = TemporaryAle::new(&base);
    ale.remap = Remap::Cubic;
    let mut c = g.position(0.5, 0.0);
    let dt = 0.25;
    for (k, pair) in meshes.windows(2).enumerate() {
        let step = [0.0, -0.03];
        let moves = vec![RigidMove {
            center: c,
            radius: 0.4,
            displacement: step,
        }];
        let m = ale
            .advance_onto(&pair[0], &pair[1], &moves, None, dt, bdf_of(k == 0))
            .expect("every pre-image found");
        let wall_speed = [Side::Bottom, Side::Top]
            .iter()
            .flat_map(|&side| pair[1].side_nodes(side))
            .map(|n| m.mesh_velocity[n][0].hypot(m.mesh_velocity[n][1]))
            .fold(0.0, f64::max);
        // the Q2 circle's distance to the circle, R Δθ⁴/520 (R = 4, Δθ up to 1.3 × 2π/64 on
        // these θ axes), over Δt; measured 2.9e-6
        let bound = 4.0 * 4.0 * (1.3 * two_pi / 64.0f64).powi(4) / 520.0 / dt;
        assert!(
            wall_speed < bound,
            "step {k}: wall mesh speed {wall_speed:e} > {bound:e}"
        );
        c = [c[0] + step[0], c[1] + step[1]];
    }
}
