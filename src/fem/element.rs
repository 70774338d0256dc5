//! Reference elements on the square [-1, 1]²: bilinear Q1 (4 nodes) and biquadratic Q2 (9 nodes).
//!
//! Local node numbering is tensor-product: node `a + n·b` sits at the `a`-th 1D node in ξ and the
//! `b`-th in η, with 1D nodes ordered −1, (0,) +1. So Q1 corners are 0:(−1,−1), 1:(1,−1),
//! 2:(−1,1), 3:(1,1), and the Q2 corners are nodes 0, 2, 6, 8 with the centre node 4.

use crate::mesh::{Axis, Mesh};

/// 1D linear Lagrange basis on [-1, 1] at nodes −1, 1: values and derivatives.
#[inline]
fn lagrange1(x: f64) -> ([f64; 2], [f64; 2]) {
    ([0.5 * (1.0 - x), 0.5 * (1.0 + x)], [-0.5, 0.5])
}

/// 1D quadratic Lagrange basis on [-1, 1] at nodes −1, 0, 1: values and derivatives.
#[inline]
fn lagrange2(x: f64) -> ([f64; 3], [f64; 3]) {
    (
        [0.5 * x * (x - 1.0), 1.0 - x * x, 0.5 * x * (x + 1.0)],
        [x - 0.5, -2.0 * x, x + 0.5],
    )
}

/// Q1 shape function values and reference gradients at `xi`.
#[inline]
pub fn q1(xi: [f64; 2]) -> ([f64; 4], [[f64; 2]; 4]) {
    let (lx, dx) = lagrange1(xi[0]);
    let (ly, dy) = lagrange1(xi[1]);
    let mut n = [0.0; 4];
    let mut g = [[0.0; 2]; 4];
    for b in 0..2 {
        for a in 0..2 {
            n[a + 2 * b] = lx[a] * ly[b];
            g[a + 2 * b] = [dx[a] * ly[b], lx[a] * dy[b]];
        }
    }
    (n, g)
}

/// Q2 shape function values and reference gradients at `xi`.
#[inline]
pub fn q2(xi: [f64; 2]) -> ([f64; 9], [[f64; 2]; 9]) {
    let (lx, dx) = lagrange2(xi[0]);
    let (ly, dy) = lagrange2(xi[1]);
    let mut n = [0.0; 9];
    let mut g = [[0.0; 2]; 9];
    for b in 0..3 {
        for a in 0..3 {
            n[a + 3 * b] = lx[a] * ly[b];
            g[a + 3 * b] = [dx[a] * ly[b], lx[a] * dy[b]];
        }
    }
    (n, g)
}

/// Reference coordinates of the Q2 nodes (tensor ordering).
pub const Q2_NODES: [[f64; 2]; 9] = [
    [-1.0, -1.0],
    [0.0, -1.0],
    [1.0, -1.0],
    [-1.0, 0.0],
    [0.0, 0.0],
    [1.0, 0.0],
    [-1.0, 1.0],
    [0.0, 1.0],
    [1.0, 1.0],
];

/// Local Q2 node index of each Q1 corner (Q1 tensor ordering).
pub const Q1_IN_Q2: [usize; 4] = [0, 2, 6, 8];

/// Isoparametric map of a Q2 element with physical node coordinates `x`:
/// the physical point, the Jacobian `J[i][j] = ∂x_i/∂ξ_j` and its determinant at `xi`.
#[inline]
pub fn q2_map(x: &[[f64; 2]; 9], xi: [f64; 2]) -> ([f64; 2], [[f64; 2]; 2], f64) {
    let (n, g) = q2(xi);
    let mut p = [0.0; 2];
    let mut j = [[0.0; 2]; 2];
    for k in 0..9 {
        for i in 0..2 {
            p[i] += n[k] * x[k][i];
            for d in 0..2 {
                j[i][d] += g[k][d] * x[k][i];
            }
        }
    }
    let det = j[0][0] * j[1][1] - j[0][1] * j[1][0];
    (p, j, det)
}

/// Maps reference gradients to physical gradients: `∇N = J^{-T} ∇_ξ N`.
#[inline]
pub fn physical_gradients<const N: usize>(
    jac: &[[f64; 2]; 2],
    det: f64,
    dref: &[[f64; 2]; N],
    out: &mut [[f64; 2]; N],
) {
    // J^{-1} = adj(J)/det; ∇N_i = Σ_d (J^{-1})_{d i} ∂N/∂ξ_d
    let inv = [
        [jac[1][1] / det, -jac[0][1] / det],
        [-jac[1][0] / det, jac[0][0] / det],
    ];
    for k in 0..N {
        let (a, b) = (dref[k][0], dref[k][1]);
        out[k] = [inv[0][0] * a + inv[1][0] * b, inv[0][1] * a + inv[1][1] * b];
    }
}

/// What [`q2_map`] returns at a point: the physical point, J and det J.
pub type MapAt = ([f64; 2], [[f64; 2]; 2], f64);

/// Points of the element rule the solvers integrate uncut elements with (3×3 Gauss).
pub const RULE_POINTS: usize = 9;

/// [`q2_map`] of every element of a mesh at the points of the element rule, tabulated once per
/// mesh geometry: the assemblies of uncut elements read it instead of evaluating the map at
/// every point and step (the same numbers, bitwise).
#[derive(Debug, Clone, Default)]
pub struct RuleMaps {
    /// The mesh axes the table belongs to.
    axes: Option<(Axis, Axis)>,
    maps: Vec<[MapAt; RULE_POINTS]>,
}

impl RuleMaps {
    /// The maps of `mesh`'s elements at `points` (the element rule's).
    ///
    /// # Panics
    /// If there are not [`RULE_POINTS`] points.
    pub fn of(mesh: &Mesh, points: &[[f64; 2]]) -> Self {
        assert_eq!(points.len(), RULE_POINTS, "the 3×3 Gauss rule");
        Self {
            axes: Some((mesh.ax.clone(), mesh.ay.clone())),
            maps: mesh
                .element_coords
                .iter()
                .map(|xe| std::array::from_fn(|q| q2_map(xe, points[q])))
                .collect(),
        }
    }

    /// Whether the table was made for a mesh with `mesh`'s axes (the structured meshes'
    /// coordinates follow from them).
    pub fn fits(&self, mesh: &Mesh) -> bool {
        self.axes
            .as_ref()
            .is_some_and(|(ax, ay)| (ax, ay) == (&mesh.ax, &mesh.ay))
    }

    /// Element `e`'s maps at the rule's points.
    pub fn at(&self, e: usize) -> &[MapAt; RULE_POINTS] {
        &self.maps[e]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Lagrange property and partition of unity hold to round-off.
    const TOL: f64 = 1e-14;

    #[test]
    fn q2_lagrange_property_and_partition_of_unity() {
        for (i, xi) in Q2_NODES.iter().enumerate() {
            let (n, g) = q2(*xi);
            for (k, nk) in n.iter().enumerate() {
                let expect = if k == i { 1.0 } else { 0.0 };
                assert!((nk - expect).abs() < TOL);
            }
            let gs: [f64; 2] = g.iter().fold([0.0, 0.0], |s, d| [s[0] + d[0], s[1] + d[1]]);
            assert!(gs[0].abs() < TOL && gs[1].abs() < TOL);
        }
    }

    #[test]
    fn q1_lagrange_property() {
        for (i, &node) in Q1_IN_Q2.iter().enumerate() {
            let (n, _) = q1(Q2_NODES[node]);
            for (k, nk) in n.iter().enumerate() {
                assert!((nk - if k == i { 1.0 } else { 0.0 }).abs() < TOL);
            }
        }
    }

    #[test]
    fn gradients_match_finite_differences() {
        // central differences with h = 1e-6 on quadratics: truncation error 0, round-off ~1e-10
        const FD_TOL: f64 = 1e-8;
        let h = 1e-6;
        for xi in [[0.3, -0.7], [-0.91, 0.2], [0.0, 0.55]] {
            let (_, g2) = q2(xi);
            let (_, g1) = q1(xi);
            for d in 0..2 {
                let mut p = xi;
                let mut m = xi;
                p[d] += h;
                m[d] -= h;
                let (np, nm) = (q2(p).0, q2(m).0);
                for k in 0..9 {
                    assert!(((np[k] - nm[k]) / (2.0 * h) - g2[k][d]).abs() < FD_TOL);
                }
                let (np, nm) = (q1(p).0, q1(m).0);
                for k in 0..4 {
                    assert!(((np[k] - nm[k]) / (2.0 * h) - g1[k][d]).abs() < FD_TOL);
                }
            }
        }
    }

    #[test]
    fn isoparametric_map_reproduces_affine_geometry_and_gradients() {
        // element [1,3]×[2,2.5]: J = diag(1, 0.25)
        let mut x = [[0.0; 2]; 9];
        for (k, xi) in Q2_NODES.iter().enumerate() {
            x[k] = [2.0 + xi[0], 2.25 + 0.25 * xi[1]];
        }
        let (p, j, det) = q2_map(&x, [0.5, -0.5]);
        assert!((p[0] - 2.5).abs() < TOL && (p[1] - 2.125).abs() < TOL);
        assert!((det - 0.25).abs() < TOL && (j[0][0] - 1.0).abs() < TOL);
        // physical gradient of f = Σ N_k f(x_k) with f = 3x − 2y is (3, −2)
        let (_, g) = q2([0.1, 0.7]);
        let mut pg = [[0.0; 2]; 9];
        physical_gradients(&j, det, &g, &mut pg);
        let mut grad = [0.0; 2];
        for k in 0..9 {
            let f = 3.0 * x[k][0] - 2.0 * x[k][1];
            grad[0] += f * pg[k][0];
            grad[1] += f * pg[k][1];
        }
        assert!((grad[0] - 3.0).abs() < 1e-12 && (grad[1] + 2.0).abs() < 1e-12);
    }
}
