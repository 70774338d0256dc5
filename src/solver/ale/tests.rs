//! Unit tests of the temporary ALE map: displacement, pre-images, remaps onto moved meshes,
//! mesh velocity, background displacements (the remaps' exactness and order: `remap_tests`).

use super::*;
use crate::solver::bdf::Bdf2;

/// Euler for a first step, else fixed-step BDF2.
pub(super) fn bdf_of(first: bool) -> Bdf2 {
    if first {
        Bdf2::EULER
    } else {
        Bdf2::with_ratio(1.0)
    }
}
use crate::fem::element::q1;
use crate::mesh::Axis;

use super::remap_tests::{bicubic_field, graded_channel};

/// Newton converged to 1e-13 in ξ on O(1) elements: positions to ~1e-12.
pub(super) const LOCATE_TOL: f64 = 1e-11;
/// Solve residual 1e-10 relative on O(0.01) displacements.
const SOLVE_TOL: f64 = 1e-11;

pub(super) fn channel() -> Mesh {
    Mesh::rectangle(
        Axis::uniform(-1.0, 1.0, 20),
        Axis::uniform(-0.5, 0.5, 10),
        true,
    )
}

pub(super) fn one_move(center: [f64; 2], disp: [f64; 2]) -> Vec<RigidMove> {
    vec![RigidMove {
        center,
        radius: 0.15,
        displacement: disp,
    }]
}

#[test]
fn no_motion_is_the_identity() {
    let mesh = channel();
    let mut ale = TemporaryAle::new(&mesh);
    let m = ale
        .advance(
            &mesh,
            &one_move([0.1, 0.0], [0.0, 0.0]),
            Some(2.0),
            0.1,
            Bdf2::EULER,
        )
        .unwrap();
    assert!(m
        .mesh_velocity
        .iter()
        .all(|u| u[0].abs() + u[1].abs() < LOCATE_TOL));
    let f: Vec<f64> = mesh
        .node_of_vertex
        .iter()
        .map(|&k| mesh.nodes[k][0] * 3.0 + mesh.nodes[k][1])
        .collect();
    for (v, (vs, w)) in m.at_n.iter().enumerate() {
        let g: f64 = (0..STENCIL_LEN).map(|a| f[vs[a]] * w[a]).sum();
        assert!((g - f[v]).abs() < LOCATE_TOL);
    }
}

#[test]
fn displacement_is_rigid_on_the_patch_zero_on_walls_and_bounded() {
    let mesh = channel();
    let mut ale = TemporaryAle::new(&mesh);
    // particle across the periodic seam
    let disp = [0.012, -0.004];
    let d = ale
        .displacement(&mesh, &one_move([0.97, 0.05], disp), Some(2.0))
        .unwrap();
    let mut on_patch = 0;
    for (v, &k) in mesh.node_of_vertex.iter().enumerate() {
        let x = mesh.nodes[k];
        if x[1].abs() > 0.5 - 1e-12 {
            assert_eq!(d[v], [0.0, 0.0]);
        }
        let dx = crate::periodic::fold(x[0] - 0.97, Some(2.0));
        if dx.hypot(x[1] - 0.05) < 0.15 {
            assert!((d[v][0] - disp[0]).abs() + (d[v][1] - disp[1]).abs() < SOLVE_TOL);
            on_patch += 1;
        }
        // maximum principle, componentwise
        assert!(d[v][0] > -SOLVE_TOL && d[v][0] < disp[0] + SOLVE_TOL);
        assert!(d[v][1] < SOLVE_TOL && d[v][1] > disp[1] - SOLVE_TOL);
    }
    assert!(on_patch >= 4, "{on_patch}");
}

#[test]
fn a_reused_laplace_factorization_gives_the_displacement_of_a_fresh_one() {
    // the same rigid patch (same fixed vertices) with other values, and then another patch:
    // bitwise what a map that never solved before computes
    let mesh = channel();
    let mut ale = TemporaryAle::new(&mesh);
    let moves = [
        one_move([0.5, 0.05], [0.012, -0.004]),
        one_move([0.5, 0.05], [-0.003, 0.007]),
        one_move([-0.4, -0.1], [0.01, 0.0]),
    ];
    for m in &moves {
        let reused = ale.displacement(&mesh, m, Some(2.0)).unwrap();
        let fresh = TemporaryAle::new(&mesh)
            .displacement(&mesh, m, Some(2.0))
            .unwrap();
        assert_eq!(reused, fresh);
    }
}

/// The pre-image xⁿ (in element e at ξ) moved by the displacement there: xⁿ + d(xⁿ).
fn displaced(mesh: &Mesh, d: &[[f64; 2]], e: usize, xi: [f64; 2], xn: [f64; 2]) -> [f64; 2] {
    let dn = q1(xi).0;
    std::array::from_fn(|i| {
        xn[i]
            + (0..4)
                .map(|a| dn[a] * d[mesh.element_vertices[e][a]][i])
                .sum::<f64>()
    })
}

#[test]
fn pre_images_invert_the_ale_mesh_and_bilinear_fields_map_exactly() {
    let mesh = channel();
    let mut ale = TemporaryAle::new(&mesh);
    assert_eq!(ale.remap, Remap::Bilinear);
    let moves = one_move([0.97, 0.05], [0.02, 0.01]);
    let m = ale
        .advance(&mesh, &moves, Some(2.0), 0.1, Bdf2::EULER)
        .unwrap();
    let d = &m.displacement;
    let f = |p: [f64; 2]| 0.3 + 2.0 * p[1] + 0.7 * p[1] * p[1].abs().min(0.0);
    let fv: Vec<f64> = mesh
        .node_of_vertex
        .iter()
        .map(|&k| f(mesh.nodes[k]))
        .collect();
    for (v, &k) in mesh.node_of_vertex.iter().enumerate() {
        let x = mesh.nodes[k];
        let (e, xi, xn) = pre_image(&mesh, d, x, Some(2.0), None).unwrap();
        // the search started from x's known location finds the same pre-image
        let hinted = pre_image(&mesh, d, x, Some(2.0), mesh.locate(x)).unwrap();
        assert!(
            (hinted.2[0] - xn[0]).abs() < LOCATE_TOL && (hinted.2[1] - xn[1]).abs() < LOCATE_TOL
        );
        // x = xⁿ + d(xⁿ)
        let back = displaced(&mesh, d, e, xi, xn);
        assert!((back[0] - x[0]).abs() < LOCATE_TOL, "{x:?} {xn:?}");
        assert!((back[1] - x[1]).abs() < LOCATE_TOL);
        // a field linear in y is interpolated exactly by Q1
        let (vs, w) = m.at_n[v];
        let g: f64 = (0..STENCIL_LEN).map(|a| fv[vs[a]] * w[a]).sum();
        assert!((g - f(xn)).abs() < LOCATE_TOL, "{g} {}", f(xn));
    }
}

#[test]
fn pre_images_beyond_the_neighbouring_elements_are_found() {
    // A particle of radius 3h moving 1.7 elements in one step (the first predicted step
    // moves by 2UΔt: a particle at y = −0.4 with U ≈ −0.41, Δt = 0.02, a = 5h = 0.05 moved
    // 1.65h and its pre-images were lost when only the 3×3 elements around x were searched)
    let mesh = channel();
    let h = 0.1;
    let mut ale = TemporaryAle::new(&mesh);
    let moves = vec![RigidMove {
        center: [0.3, 0.0],
        radius: 3.0 * h,
        displacement: [-1.7 * h, 0.2 * h],
    }];
    let m = ale
        .advance(&mesh, &moves, Some(2.0), 0.1, Bdf2::EULER)
        .unwrap();
    let d = &m.displacement;
    for &k in &mesh.node_of_vertex {
        let x = mesh.nodes[k];
        let (e, xi, xn) = pre_image(&mesh, d, x, Some(2.0), None).unwrap();
        let back = crate::periodic::nearest_image(displaced(&mesh, d, e, xi, xn), x[0], Some(2.0));
        assert!((back[0] - x[0]).abs() < LOCATE_TOL, "{x:?} {xn:?}");
        assert!((back[1] - x[1]).abs() < LOCATE_TOL);
    }
}

/// A computational mesh moved by exactly one element column, without particle motion: every
/// new vertex is an old vertex (the next column), so the history is relabelled exactly
/// (Kronecker weights) and the mesh velocity is zero.
#[test]
fn a_mesh_moved_by_one_column_relabels_the_history_exactly() {
    let old = channel();
    let h = old.ax.vertices[1] - old.ax.vertices[0];
    let shifted = Axis {
        vertices: old.ax.vertices.iter().map(|x| x + h).collect(),
    };
    let new = old.with_axes(shifted, old.ay.clone());
    let mut ale = TemporaryAle::new(&old);
    ale.remap = Remap::Cubic;
    let still = one_move([0.0, 0.05], [0.0, 0.0]);
    let m = ale
        .advance_onto(&old, &new, &still, Some(2.0), 0.1, Bdf2::EULER)
        .unwrap();
    let (nx, _) = old.dims();
    for (v, (vs, w)) in m.at_n.iter().enumerate() {
        let (i, j) = (v % nx, v / nx);
        let next = ((i + 1) % nx) + nx * j;
        let weight_there: f64 = (0..STENCIL_LEN)
            .filter(|&a| vs[a] == next)
            .map(|a| w[a])
            .sum();
        assert!(
            (weight_there - 1.0).abs() < 1e-12,
            "vertex {v}: {weight_there}"
        );
    }
    assert!(m.mesh_velocity.iter().flatten().all(|u| u.abs() < 1e-9));
}

/// The Laplace problem follows the mesh it is solved on: after a solve on one mesh, a solve
/// on a mesh with moved columns and rows equals that of a fresh solver built there.
#[test]
fn the_displacement_is_solved_on_the_mesh_given() {
    let (m0, m1) = (channel(), graded_channel());
    let moves = one_move([0.0, 0.05], [0.013, -0.007]);
    let mut reused = TemporaryAle::new(&m0);
    let on_m0 = reused.displacement(&m0, &moves, Some(2.0)).unwrap();
    let on_m1 = reused.displacement(&m1, &moves, Some(2.0)).unwrap();
    let fresh = TemporaryAle::new(&m1)
        .displacement(&m1, &moves, Some(2.0))
        .unwrap();
    assert_eq!(on_m1, fresh);
    assert_ne!(on_m0, on_m1, "the graded mesh has another Laplacian");
}

/// Onto a moved (graded) mesh, with a particle moving: the remap interpolates on the mesh of
/// sⁿ and reproduces a bicubic field at the pre-images of the new mesh's vertices; a second
/// step onto a third mesh locates x^{n−1} in the first mesh (the mesh of s^{n−1}) and
/// reproduces the field there too.
#[test]
fn pre_images_of_a_moved_mesh_are_interpolated_on_the_meshes_of_the_history() {
    let m0 = channel();
    let m1 = graded_channel();
    let m2 = m0.with_axes(
        Axis::centred(-1.0, 1.0, 20, 2.0),
        Axis::centred(-0.5, 0.5, 10, 1.5),
    );
    let mut ale = TemporaryAle::new(&m0);
    ale.remap = Remap::Cubic;
    let (dt, period) = (0.1, Some(2.0));
    let field = |mesh: &Mesh| -> Vec<f64> {
        mesh.node_of_vertex
            .iter()
            .map(|&k| bicubic_field(mesh.nodes[k]))
            .collect()
    };
    let check = |at: &[StencilWeights], on: &Mesh, v: usize, xp: [f64; 2]| {
        let f = field(on);
        let (vs, w) = at[v];
        let g: f64 = (0..STENCIL_LEN).map(|a| f[vs[a]] * w[a]).sum();
        assert!(
            (g - bicubic_field(xp)).abs() < LOCATE_TOL,
            "{g} vs {} at {xp:?}",
            bicubic_field(xp)
        );
    };
    // step 1: s⁰ on m0, onto m1
    let moves = one_move([0.0, 0.05], [0.013, -0.007]);
    let a = ale
        .advance_onto(&m0, &m1, &moves, period, dt, Bdf2::EULER)
        .unwrap();
    let mut checked = 0;
    for (v, &k) in m1.node_of_vertex.iter().enumerate() {
        let x = m1.nodes[k];
        if x[0].abs() > 0.7 {
            continue; // the field is not periodic
        }
        let (_, _, xn) = pre_image(&m0, &a.displacement, x, period, None).unwrap();
        check(&a.at_n, &m0, v, xn);
        checked += 1;
    }
    assert!(checked > 100);
    // step 2: s¹ on m1 (s⁰ on m0), onto m2; the particle moved on
    let moves = one_move([0.013, 0.043], [0.011, -0.006]);
    let b = ale
        .advance_onto(&m1, &m2, &moves, period, dt, Bdf2::with_ratio(1.0))
        .unwrap();
    let at_nm1 = b.at_n_minus_1.as_ref().expect("second-order step");
    for (v, &k) in m2.node_of_vertex.iter().enumerate() {
        let x = m2.nodes[k];
        if x[0].abs() > 0.7 {
            continue;
        }
        let (_, _, xn) = pre_image(&m1, &b.displacement, x, period, None).unwrap();
        check(&b.at_n, &m1, v, xn);
        // x^{n−1} from the BDF2 mesh velocity: u = (1.5 x − 2 xⁿ + 0.5 x^{n−1})/Δt
        let u = b.mesh_velocity[k];
        let xnm1 = [0, 1].map(|c| 2.0 * (u[c] * dt - 1.5 * x[c] + 2.0 * xn[c]));
        check(at_nm1, &m0, v, xnm1);
    }
}

#[test]
fn mesh_velocity_of_a_steadily_moving_particle() {
    let mesh = channel();
    let mut ale = TemporaryAle::new(&mesh);
    let (v, dt) = ([0.3, -0.1], 0.02);
    let step = [v[0] * dt, v[1] * dt];
    let mut c = [0.2, 0.0];
    let mut last = None;
    for first in [true, false, false] {
        last = Some(
            ale.advance(&mesh, &one_move(c, step), Some(2.0), dt, bdf_of(first))
                .unwrap(),
        );
        c = [c[0] + step[0], c[1] + step[1]];
    }
    let m = last.unwrap();
    assert!(m.at_n_minus_1.is_some());
    // nodes well inside the rigid patch (r < a - h) move with the particle, walls stay
    let c_prev = [c[0] - step[0], c[1] - step[1]];
    for (k, x) in mesh.nodes.iter().enumerate() {
        let r = (x[0] - c_prev[0]).hypot(x[1] - c_prev[1]);
        if r < 0.05 {
            let u = m.mesh_velocity[k];
            assert!((u[0] - v[0]).abs() + (u[1] - v[1]).abs() < 1e-9, "{u:?}");
        }
        if x[1].abs() > 0.5 - 1e-12 {
            assert!(m.mesh_velocity[k][0].abs() + m.mesh_velocity[k][1].abs() < 1e-12);
        }
    }
}

/// With a background displacement (a free surface's stretch) the rigid patch still moves by the
/// particle's displacement exactly, the walls by the background, and without particle motion the
/// map is the background itself.
#[test]
fn a_background_displacement_leaves_the_patches_rigid() {
    let mesh = Mesh::rectangle(
        Axis::uniform(-1.0, 1.0, 20),
        Axis::uniform(0.0, 1.0, 10),
        false,
    );
    // a smooth background vanishing nowhere in particular (on the walls too)
    let bg: Vec<[f64; 2]> = mesh
        .node_of_vertex
        .iter()
        .map(|&k| {
            let [x, y] = mesh.nodes[k];
            [0.0, 0.01 * y * (1.0 + x)]
        })
        .collect();
    let mut ale = TemporaryAle::new(&mesh);
    ale.background = Some(bg.clone());
    let moves = vec![RigidMove {
        center: [0.0, 0.5],
        radius: 0.15,
        displacement: [0.02, -0.01],
    }];
    let d = ale.displacement(&mesh, &moves, None).unwrap();
    let mut patch = 0;
    for (v, &k) in mesh.node_of_vertex.iter().enumerate() {
        let [x, y] = mesh.nodes[k];
        let wall = x.abs() > 1.0 - 1e-12 || !(1e-12..=1.0 - 1e-12).contains(&y);
        if wall {
            assert!(
                (d[v][0] - bg[v][0]).abs() < SOLVE_TOL && (d[v][1] - bg[v][1]).abs() < SOLVE_TOL,
                "wall vertex {v}: {:?} against {:?}",
                d[v],
                bg[v]
            );
        }
        // every vertex within the radius is on the patch
        if x.hypot(y - 0.5) < 0.15 {
            patch += 1;
            assert!(
                (d[v][0] - 0.02).abs() < SOLVE_TOL && (d[v][1] + 0.01).abs() < SOLVE_TOL,
                "patch vertex {v}: {:?}",
                d[v]
            );
        }
    }
    assert!(patch > 0);
    let still = vec![RigidMove {
        displacement: [0.0, 0.0],
        ..moves[0]
    }];
    ale.background = Some(bg.clone());
    let d = ale.displacement(&mesh, &[], None).unwrap();
    assert_eq!(d, bg, "no particles: the background");
    let d = ale.displacement(&mesh, &still, None).unwrap();
    assert!(
        d.iter().zip(&bg).any(|(a, b)| a != b),
        "a still patch holds its vertices"
    );
}

/// Vertices flagged outside the fluid (above a free surface) move by the background alone, even
/// where a particle's patch would claim them; the patch's other vertices still move rigidly.
#[test]
fn vertices_outside_the_fluid_follow_the_background_alone() {
    let mesh = Mesh::rectangle(
        Axis::uniform(-1.0, 1.0, 20),
        Axis::uniform(0.0, 1.0, 10),
        false,
    );
    let bg: Vec<[f64; 2]> = mesh
        .node_of_vertex
        .iter()
        .map(|&k| [0.0, 0.02 * mesh.nodes[k][1]])
        .collect();
    // the fluid lies below y = 0.65; the particle's patch reaches above it
    let outside: Vec<bool> = mesh
        .node_of_vertex
        .iter()
        .map(|&k| mesh.nodes[k][1] > 0.65)
        .collect();
    let mut ale = TemporaryAle::new(&mesh);
    ale.background = Some(bg.clone());
    ale.outside = Some(outside.clone());
    let moves = vec![RigidMove {
        center: [0.0, 0.55],
        radius: 0.15,
        displacement: [0.02, -0.01],
    }];
    let d = ale.displacement(&mesh, &moves, None).unwrap();
    let (mut above, mut rigid) = (0, 0);
    for (v, &k) in mesh.node_of_vertex.iter().enumerate() {
        let [x, y] = mesh.nodes[k];
        if outside[v] {
            above += usize::from(x.hypot(y - 0.55) < 0.25);
            assert!(
                (d[v][0] - bg[v][0]).abs() < SOLVE_TOL && (d[v][1] - bg[v][1]).abs() < SOLVE_TOL
            );
        } else if x.hypot(y - 0.55) < 0.15 {
            rigid += 1;
            assert!((d[v][0] - 0.02).abs() < SOLVE_TOL && (d[v][1] + 0.01).abs() < SOLVE_TOL);
        }
    }
    assert!(
        above > 0 && rigid > 0,
        "{above} outside near the particle, {rigid} rigid"
    );
}
