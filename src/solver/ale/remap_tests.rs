//! Unit tests of the history remaps of the temporary ALE map: exactness for the polynomials each
//! interpolates, the bicubic remap's order on graded axes, and the error repeated remaps
//! accumulate.

use super::tests::{channel, one_move, LOCATE_TOL};
use super::*;
use crate::mesh::Axis;
use crate::solver::bdf::Bdf2;

/// Observed order of one bicubic remap under mesh refinement: 4 asymptotically; 3.5 leaves
/// room for the pre-asymptotic range on 40 elements and is far above index-space weights' 2.
const MIN_CUBIC_ORDER: f64 = 3.5;

/// The channel graded along and across (largest element 3× / 2× the smallest).
pub(super) fn graded_channel() -> Mesh {
    Mesh::rectangle(
        Axis::centred(-1.0, 1.0, 20, 3.0),
        Axis::centred(-0.5, 0.5, 10, 2.0),
        true,
    )
}

/// The remap `remap` reproduces the field `f` (of the degree it interpolates exactly) at the
/// pre-images of one move, walls (one-sided stencils) included, on the uniform and on the
/// graded channel. Points near the periodic seam, where `f` is not periodic, are skipped.
fn assert_remap_exact(remap: Remap, f: impl Fn([f64; 2]) -> f64) {
    assert_remap_exact_on(channel(), remap, &f);
    assert_remap_exact_on(graded_channel(), remap, &f);
}

fn assert_remap_exact_on(mesh: Mesh, remap: Remap, f: &impl Fn([f64; 2]) -> f64) {
    let mut ale = TemporaryAle::new(&mesh);
    ale.remap = remap;
    let moves = one_move([0.0, 0.05], [0.013, -0.007]);
    let m = ale
        .advance(&mesh, &moves, Some(2.0), 0.1, Bdf2::EULER)
        .unwrap();
    let fv: Vec<f64> = mesh
        .node_of_vertex
        .iter()
        .map(|&k| f(mesh.nodes[k]))
        .collect();
    let mut checked = 0;
    for (v, &k) in mesh.node_of_vertex.iter().enumerate() {
        let x = mesh.nodes[k];
        if x[0].abs() > 0.7 {
            continue;
        }
        let (_, _, xn) = pre_image(&mesh, &m.displacement, x, Some(2.0), None).unwrap();
        let (vs, w) = m.at_n[v];
        let g: f64 = (0..STENCIL_LEN).map(|a| fv[vs[a]] * w[a]).sum();
        assert!(
            (g - f(xn)).abs() < LOCATE_TOL,
            "{remap:?} at {x:?}: {g} vs {}",
            f(xn)
        );
        checked += 1;
    }
    assert!(checked > 100);
}

#[test]
fn quadratic_remap_is_exact_for_biquadratic_fields() {
    assert_remap_exact(Remap::Quadratic, |p| {
        0.3 + 2.0 * p[1] - p[1] * p[1] + 0.7 * p[0] * p[0] + 0.4 * p[0] * p[1]
            - 1.3 * p[0] * p[0] * p[1] * p[1]
    });
}

/// A bicubic polynomial (degree 3 in x and in y) for the exactness tests.
pub(super) fn bicubic_field(p: [f64; 2]) -> f64 {
    let (x, y) = (p[0], p[1]);
    0.3 + 2.0 * y - y * y + 0.9 * y * y * y + 0.7 * x * x - 0.5 * x * x * x + 0.4 * x * y
        - 1.3 * x * x * y * y * y
        + 0.8 * x * x * x * y * y * y
}

#[test]
fn cubic_remap_is_exact_for_bicubic_fields() {
    assert_remap_exact(Remap::Cubic, bicubic_field);
}

/// On a graded axis the bicubic remap keeps its fourth order: one remap of sin(kx) under a
/// shift of 0.37 of a mean element, x graded 3:1, on 40 / 80 / 160 elements. (Weights in
/// index space gave 2.5e-3 / 7.9e-4 / 2.3e-4: second order.)
#[test]
fn cubic_remap_keeps_its_order_on_a_graded_axis() {
    let error = |nx: usize| -> f64 {
        let l = 2.0;
        let mesh = Mesh::rectangle(
            Axis::centred(-1.0, 1.0, nx, 3.0),
            Axis::uniform(-0.5, 0.5, 4),
            true,
        );
        let k = 2.0 * std::f64::consts::PI / l * 2.0;
        let d = vec![[0.37 * l / nx as f64, 0.0]; mesh.n_vertices()];
        let f = |x: f64| (k * x).sin();
        let fv: Vec<f64> = mesh
            .node_of_vertex
            .iter()
            .map(|&n| f(mesh.nodes[n][0]))
            .collect();
        let mut err: f64 = 0.0;
        for &n in &mesh.node_of_vertex {
            let (e, xi, xn) = pre_image(&mesh, &d, mesh.nodes[n], Some(l), None).unwrap();
            let (v, w) = stencil(&mesh, e, xi, Remap::Cubic);
            let g: f64 = (0..STENCIL_LEN).map(|a| fv[v[a]] * w[a]).sum();
            err = err.max((g - f(xn[0])).abs());
        }
        err
    };
    let e: Vec<f64> = [40, 80, 160].into_iter().map(error).collect();
    for pair in e.windows(2) {
        let order = (pair[0] / pair[1]).log2();
        assert!(order > MIN_CUBIC_ORDER, "errors {e:?}: order {order:.2}");
    }
}

/// Repeated remaps of a smooth field under a uniform shift of a fraction θ of an element
/// per step (a particle's neighbourhood crossing the fixed mesh): the error accumulates
/// per remap like a semi-Lagrangian scheme's. Bound per step and mode sin(kx):
/// Lagrange interpolation error |Π(θ + j)|/(p + 1)! · (kh)^{p+1} for the p + 1 stencil
/// points j; the cubic remap must stay within N times its bound and beat the quadratic one.
#[test]
fn repeated_remaps_accumulate_the_interpolation_error_of_their_order() {
    let (nx, l) = (40, 2.0);
    let mesh = Mesh::rectangle(
        Axis::uniform(-1.0, 1.0, nx),
        Axis::uniform(-0.5, 0.5, 4),
        true,
    );
    let h = l / nx as f64;
    let theta = 0.66;
    let d = vec![[theta * h, 0.0]; mesh.n_vertices()];
    let k = 2.0 * std::f64::consts::PI / l * 2.0;
    let exact = |x: f64, t: usize| (k * (x - t as f64 * theta * h)).sin();
    let steps = 50;
    let run = |remap: Remap| -> f64 {
        let at: Vec<StencilWeights> = mesh
            .node_of_vertex
            .iter()
            .map(|&n| {
                let (e, xi, _) = pre_image(&mesh, &d, mesh.nodes[n], Some(l), None).unwrap();
                stencil(&mesh, e, xi, remap)
            })
            .collect();
        let xs: Vec<f64> = mesh
            .node_of_vertex
            .iter()
            .map(|&n| mesh.nodes[n][0])
            .collect();
        let mut f: Vec<f64> = xs.iter().map(|&x| exact(x, 0)).collect();
        for _ in 0..steps {
            f = at
                .iter()
                .map(|(v, w)| (0..STENCIL_LEN).map(|a| f[v[a]] * w[a]).sum())
                .collect();
        }
        xs.iter()
            .zip(&f)
            .map(|(&x, g)| (g - exact(x, steps)).abs())
            .fold(0.0, f64::max)
    };
    let (quadratic, cubic) = (run(Remap::Quadratic), run(Remap::Cubic));
    // the cubic stencil holds θ between its 2nd and 3rd points: nodes at θ + 1, θ, θ − 1, θ − 2
    let node_product = |nodes: &[f64]| nodes.iter().map(|z| z.abs()).product::<f64>();
    let cubic_bound = steps as f64 * node_product(&[theta + 1.0, theta, theta - 1.0, theta - 2.0])
        / 24.0
        * (k * h).powi(4);
    assert!(
        cubic < cubic_bound,
        "cubic {cubic:.3e} above its bound {cubic_bound:.3e}"
    );
    assert!(
        cubic < quadratic / 3.0,
        "cubic {cubic:.3e} not well below quadratic {quadratic:.3e}"
    );
}
