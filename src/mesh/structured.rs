//! Structured quadrilateral meshes with Q2 nodes: a rectangle (optionally periodic in x) and an
//! annulus (isoparametric Q2 elements with nodes on the exact circles, periodic in θ).
//!
//! Node grid: Q2 node `(i, j)` with `i ∈ 0..=2·nx`, `j ∈ 0..=2·ny`; vertices of the Q1 sub-grid are the
//! nodes with even `i` and `j`. On a periodic direction the last node column is identified with the
//! first (node identification, not constraints: fewer unknowns, the same result). Element `(ex, ey)`
//! has the Q2 nodes `(2ex + a, 2ey + b)`, `a, b ∈ {0, 1, 2}`, in tensor order (`a + 3b`).

use super::axis::Axis;
use crate::fem::element::q2_map;
use crate::fem::newton_inverse::{newton_inverse, Bound, Newton};

/// Which kind of domain the mesh covers.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Shape {
    /// Rectangle `[x0, x1] × [y0, y1]` from the two axes.
    Rectangle,
    /// Annulus with θ from the first axis (spanning [0, 2π], running clockwise: x = r cos θ,
    /// y = −r sin θ, so that elements are positively oriented) and r from the second.
    Annulus,
}

/// A side of the logical rectangle (for the annulus: `Bottom` = inner circle, `Top` = outer).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Side {
    /// j = 0 (y = y0, or r = R1).
    Bottom,
    /// j = 2·ny (y = y1, or r = R2).
    Top,
    /// i = 0 (x = x0); absent when periodic.
    Left,
    /// i = 2·nx (x = x1); absent when periodic.
    Right,
}

/// A structured Q2/Q1 mesh.
#[derive(Debug, Clone)]
pub struct Mesh {
    /// Geometry kind.
    pub shape: Shape,
    /// First logical axis (x, or θ).
    pub ax: Axis,
    /// Second logical axis (y, or r).
    pub ay: Axis,
    /// Whether the first direction is periodic.
    pub periodic: bool,
    /// Physical coordinates of each Q2 node (representative copy for periodic nodes).
    pub nodes: Vec<[f64; 2]>,
    /// Q2 node ids of each element, tensor order.
    pub elements: Vec<[usize; 9]>,
    /// Physical coordinates of each element's nodes, unwrapped across a periodic seam.
    pub element_coords: Vec<[[f64; 2]; 9]>,
    /// Q1 vertex id of each Q2 node, `None` for mid-side and centre nodes.
    pub vertex_of_node: Vec<Option<usize>>,
    /// Q1 vertex ids of each element, tensor order.
    pub element_vertices: Vec<[usize; 4]>,
    /// Q2 node id of each Q1 vertex.
    pub node_of_vertex: Vec<usize>,
    /// Q2 node columns (2·nx, or 2·nx + 1 on a bounded first direction).
    pub(super) n_node_cols: usize,
}

/// Bounding box (lower, upper corner) of an element's nine nodes.
pub fn bounding_box(xe: &[[f64; 2]; 9]) -> ([f64; 2], [f64; 2]) {
    let mut lo = [f64::INFINITY; 2];
    let mut hi = [f64::NEG_INFINITY; 2];
    for p in xe {
        for i in 0..2 {
            lo[i] = lo[i].min(p[i]);
            hi[i] = hi[i].max(p[i]);
        }
    }
    (lo, hi)
}

impl Mesh {
    /// Rectangle mesh from two axes; `periodic` identifies x = x0 with x = x1.
    pub fn rectangle(ax: Axis, ay: Axis, periodic: bool) -> Self {
        Self::build(Shape::Rectangle, ax, ay, periodic)
    }

    /// The periodic channel H × L (centred at the origin) with `mesh` = [along, across] elements,
    /// graded along it by `grading_x` (finest at x = 0) and across it by `grading` (finest at the
    /// centre line): the mesh of every confined-shear case, Stokes or viscoelastic.
    pub fn channel(h: f64, l: f64, mesh: [usize; 2], grading: f64, grading_x: f64) -> Self {
        Self::rectangle(
            Axis::centred(-0.5 * l, 0.5 * l, mesh[0], grading_x),
            Axis::centred(-0.5 * h, 0.5 * h, mesh[1], grading),
            true,
        )
    }

    /// Annulus R1 ≤ r ≤ R2 with `n_theta` uniform elements around and the radial axis `ar`.
    pub fn annulus(n_theta: usize, ar: Axis) -> Self {
        let at = Axis::uniform(0.0, 2.0 * std::f64::consts::PI, n_theta);
        Self::build(Shape::Annulus, at, ar, true)
    }

    /// The same mesh (shape, topology, numbering) on other axes: the vertex columns and rows
    /// moved, e.g. a grading that follows the particles.
    ///
    /// # Panics
    /// If the element counts differ, or on a periodic axis the period does (an annulus' θ axis
    /// may start anywhere: its point location wraps θ into [θ₀, θ₀ + 2π)).
    pub fn with_axes(&self, ax: Axis, ay: Axis) -> Self {
        assert_eq!(
            (ax.len(), ay.len()),
            self.dims(),
            "Mesh::with_axes: other element counts"
        );
        let span = |a: &Axis| a.vertices[a.len()] - a.vertices[0];
        assert!(
            !self.periodic || (span(&ax) - span(&self.ax)).abs() <= 1e-12 * span(&self.ax),
            "Mesh::with_axes: other period"
        );
        Self::build(self.shape, ax, ay, self.periodic)
    }

    fn build(shape: Shape, ax: Axis, ay: Axis, periodic: bool) -> Self {
        let (nx, ny) = (ax.len(), ay.len());
        let n_node_cols = if periodic { 2 * nx } else { 2 * nx + 1 };
        let n_node_rows = 2 * ny + 1;
        let n_vert_cols = if periodic { nx } else { nx + 1 };
        let coord = |i: usize, j: usize| -> [f64; 2] {
            let (s, t) = (ax.q2_coord(i), ay.q2_coord(j));
            match shape {
                Shape::Rectangle => [s, t],
                // θ runs clockwise so that the (θ, r) → (x, y) map has a positive Jacobian
                Shape::Annulus => [t * s.cos(), -t * s.sin()],
            }
        };
        let mut nodes = Vec::with_capacity(n_node_cols * n_node_rows);
        let mut vertex_of_node = Vec::with_capacity(n_node_cols * n_node_rows);
        let mut node_of_vertex = Vec::new();
        for j in 0..n_node_rows {
            for i in 0..n_node_cols {
                nodes.push(coord(i, j));
                if i.is_multiple_of(2) && j.is_multiple_of(2) {
                    vertex_of_node.push(Some(node_of_vertex.len()));
                    node_of_vertex.push(i + n_node_cols * j);
                } else {
                    vertex_of_node.push(None);
                }
            }
        }
        debug_assert_eq!(node_of_vertex.len(), n_vert_cols * (ny + 1));
        let node_id =
            |i: usize, j: usize| (if periodic { i % n_node_cols } else { i }) + n_node_cols * j;
        let mut elements = Vec::with_capacity(nx * ny);
        let mut element_coords = Vec::with_capacity(nx * ny);
        let mut element_vertices = Vec::with_capacity(nx * ny);
        for ey in 0..ny {
            for ex in 0..nx {
                let mut e = [0usize; 9];
                let mut c = [[0.0; 2]; 9];
                for b in 0..3 {
                    for a in 0..3 {
                        e[a + 3 * b] = node_id(2 * ex + a, 2 * ey + b);
                        c[a + 3 * b] = coord(2 * ex + a, 2 * ey + b);
                    }
                }
                let v = [0, 2, 6, 8].map(|k| vertex_of_node[e[k]].expect("corner is a vertex"));
                elements.push(e);
                element_coords.push(c);
                element_vertices.push(v);
            }
        }
        Self {
            shape,
            ax,
            ay,
            periodic,
            nodes,
            elements,
            element_coords,
            vertex_of_node,
            element_vertices,
            node_of_vertex,
            n_node_cols,
        }
    }

    /// Number of elements in the first / second direction.
    pub fn dims(&self) -> (usize, usize) {
        (self.ax.len(), self.ay.len())
    }

    /// Number of Q2 nodes.
    pub fn n_nodes(&self) -> usize {
        self.nodes.len()
    }

    /// Number of Q1 vertices.
    pub fn n_vertices(&self) -> usize {
        self.node_of_vertex.len()
    }

    /// Number of elements.
    pub fn n_elements(&self) -> usize {
        self.elements.len()
    }

    /// Logical grid indices `(i, j)` of a Q2 node.
    pub fn node_ij(&self, node: usize) -> (usize, usize) {
        (node % self.n_node_cols, node / self.n_node_cols)
    }

    /// Whether a node lies on the given side.
    pub fn on_side(&self, node: usize, side: Side) -> bool {
        let (i, j) = self.node_ij(node);
        match side {
            Side::Bottom => j == 0,
            Side::Top => j == 2 * self.ay.len(),
            Side::Left => !self.periodic && i == 0,
            Side::Right => !self.periodic && i == 2 * self.ax.len(),
        }
    }

    /// Q2 nodes on a side.
    pub fn side_nodes(&self, side: Side) -> Vec<usize> {
        (0..self.n_nodes())
            .filter(|&n| self.on_side(n, side))
            .collect()
    }

    /// Flux ∫ u_x dy through the node column i = 0 (x = x0; on a periodic rectangle the seam),
    /// by Simpson's rule on each element edge — exact for the Q2 interpolant on straight edges.
    /// For an incompressible periodic flow this is the flow rate.
    pub fn flux_through_first_column(&self, u: &[[f64; 2]]) -> f64 {
        let mut col: Vec<usize> = (0..self.n_nodes())
            .filter(|&k| self.node_ij(k).0 == 0)
            .collect();
        col.sort_by_key(|&k| self.node_ij(k).1);
        col.windows(3)
            .step_by(2)
            .map(|w| {
                let (y0, y2) = (self.nodes[w[0]][1], self.nodes[w[2]][1]);
                (y2 - y0) / 6.0 * (u[w[0]][0] + 4.0 * u[w[1]][0] + u[w[2]][0])
            })
            .sum()
    }

    /// Element containing `x` and the reference coordinates ξ ∈ [−1, 1]² there (X_e(ξ) = x);
    /// `None` outside the mesh. On a periodic rectangle x is wrapped into the period.
    ///
    /// On an annulus the element is picked from (θ, r) through the axes and the isoparametric map
    /// is inverted by Newton's method, moving to a neighbour while ξ leaves [−1, 1]². The discrete
    /// boundary (parabolas through nodes on the circles) differs from the exact circles by
    /// O(h⁴): a point of the exact annulus that falls just outside the discrete one is returned
    /// in the nearest boundary element with ξ clamped onto the boundary, so `X_e(ξ)` is then the
    /// nearest point of the discrete boundary, not `x`.
    pub fn locate(&self, x: [f64; 2]) -> Option<(usize, [f64; 2])> {
        match self.shape {
            Shape::Rectangle => self.locate_rectangle(x),
            Shape::Annulus => self.locate_annulus(x),
        }
    }

    /// The axes' coordinates of a physical point: (x, y) on a rectangle, (θ, r) on an annulus (θ
    /// clockwise from +x, as the mesh runs, taken in the θ axis' range).
    pub fn axis_coordinates(&self, x: [f64; 2]) -> [f64; 2] {
        match self.shape {
            Shape::Rectangle => x,
            Shape::Annulus => {
                let theta0 = self.ax.vertices[0];
                let turn = 2.0 * std::f64::consts::PI;
                let theta = theta0 + ((-x[1]).atan2(x[0]) - theta0).rem_euclid(turn);
                [theta, x[0].hypot(x[1])]
            }
        }
    }

    fn locate_rectangle(&self, x: [f64; 2]) -> Option<(usize, [f64; 2])> {
        let (x0, x1) = (self.ax.vertices[0], *self.ax.vertices.last()?);
        let (y0, y1) = (self.ay.vertices[0], *self.ay.vertices.last()?);
        let mut px = x[0];
        if self.periodic {
            px = x0 + (px - x0).rem_euclid(x1 - x0);
        }
        if !(x0..=x1).contains(&px) || !(y0..=y1).contains(&x[1]) {
            return None;
        }
        let (ex, ey) = (self.ax.locate(px), self.ay.locate(x[1]));
        let (a, b) = (self.ax.vertices[ex], self.ax.vertices[ex + 1]);
        let (c, d) = (self.ay.vertices[ey], self.ay.vertices[ey + 1]);
        let xi = [
            2.0 * (px - a) / (b - a) - 1.0,
            2.0 * (x[1] - c) / (d - c) - 1.0,
        ];
        Some((ey * self.ax.len() + ex, xi))
    }

    fn locate_annulus(&self, x: [f64; 2]) -> Option<(usize, [f64; 2])> {
        // Relative round-off allowed on |x| against the exact radii, and on ξ against ±1.
        const ROUND_OFF: f64 = 1e-12;
        // Neighbour moves before giving up: the (θ, r) guess is off by at most one element
        // (the discrete edges lie within O(h⁴) of the exact circles and rays).
        const MAX_MOVES: usize = 4;
        let (nt, nr) = self.dims();
        let (r1, r2) = (self.ay.vertices[0], self.ay.vertices[nr]);
        let r = x[0].hypot(x[1]);
        if !(r1 * (1.0 - ROUND_OFF)..=r2 * (1.0 + ROUND_OFF)).contains(&r) {
            return None;
        }
        let [theta, _] = self.axis_coordinates(x);
        let (mut et, mut er) = (self.ax.locate(theta), self.ay.locate(r));
        for _ in 0..=MAX_MOVES {
            let e = er * nt + et;
            let xi = invert_q2_map(
                &self.element_coords[e],
                x,
                self.initial_guess(et, er, theta, r),
            );
            let out = |v: f64| v.abs() > 1.0 + ROUND_OFF;
            if !out(xi[0]) && !out(xi[1]) {
                return Some((e, xi.map(|v| v.clamp(-1.0, 1.0))));
            }
            // step toward the violated side: θ wraps around, r stops at the circles
            if out(xi[0]) {
                et = if xi[0] < 0.0 {
                    (et + nt - 1) % nt
                } else {
                    (et + 1) % nt
                };
            } else if xi[1] < 0.0 && er > 0 {
                er -= 1;
            } else if xi[1] > 0.0 && er + 1 < nr {
                er += 1;
            } else {
                // outside the discrete annulus radially, inside the exact one (checked above)
                return Some((e, xi.map(|v| v.clamp(-1.0, 1.0))));
            }
        }
        None
    }

    /// ξ of (θ, r) in element (et, er) under the polar map, a guess for the Newton iteration.
    fn initial_guess(&self, et: usize, er: usize, theta: f64, r: f64) -> [f64; 2] {
        let lin = |v: &[f64], i: usize, s: f64| 2.0 * (s - v[i]) / (v[i + 1] - v[i]) - 1.0;
        // θ near 2π seen from the first element (or 0 from the last) is mapped across the seam
        let (t0, t1) = (self.ax.vertices[et], self.ax.vertices[et + 1]);
        let period = 2.0 * std::f64::consts::PI;
        let mid = 0.5 * (t0 + t1);
        let theta = theta - period * ((theta - mid) / period).round();
        [
            lin(&self.ax.vertices, et, theta).clamp(-2.0, 2.0),
            lin(&self.ay.vertices, er, r).clamp(-2.0, 2.0),
        ]
    }
    /// Smallest element edge length in physical space (by corner distances).
    pub fn min_element_size(&self) -> f64 {
        self.element_coords
            .iter()
            .map(|c| {
                let d = |p: [f64; 2], q: [f64; 2]| {
                    ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2)).sqrt()
                };
                d(c[0], c[2]).min(d(c[0], c[6]))
            })
            .fold(f64::INFINITY, f64::min)
    }
}

/// Reference coordinates ξ with X(ξ) = x for the Q2 map of the element nodes `xe`, by Newton's
/// method ([`newton_inverse`]) from `guess` (ξ may leave [−1, 1]²: the caller decides what that
/// means). Without convergence, or at a singular Jacobian, the last iterate.
pub(crate) fn invert_q2_map(xe: &[[f64; 2]; 9], x: [f64; 2], guess: [f64; 2]) -> [f64; 2] {
    // Newton converges quadratically from the polar guess; the step tolerance is round-off of ξ.
    const NEWTON: Newton = Newton {
        max_iter: 20,
        step_tol: 1e-15,
        bound: Bound::Free,
    };
    let residual = |xi| {
        let (p, j, _) = q2_map(xe, xi);
        ([x[0] - p[0], x[1] - p[1]], j)
    };
    newton_inverse(residual, guess, &NEWTON).unwrap_or_else(|failure| failure.xi())
}

/// The elements of `marked` (numbered `ey·nx + ex`, `dims` = (nx, ny)) widened by `margin`
/// elements along each index direction (a box), wrapping around a periodic first direction.
pub fn dilate(
    marked: &[bool],
    (nx, ny): (usize, usize),
    periodic: bool,
    margin: usize,
) -> Vec<bool> {
    let m = margin as isize;
    let mut wide = vec![false; nx * ny];
    for e in (0..nx * ny).filter(|&e| marked[e]) {
        let (ex, ey) = ((e % nx) as isize, e / nx);
        for d in -m..=m {
            let x = ex + d;
            let x = if periodic {
                x.rem_euclid(nx as isize)
            } else if (0..nx as isize).contains(&x) {
                x
            } else {
                continue;
            };
            wide[ey * nx + x as usize] = true;
        }
    }
    let mut out = vec![false; nx * ny];
    for e in (0..nx * ny).filter(|&e| wide[e]) {
        let (ex, ey) = (e % nx, (e / nx) as isize);
        for y in (ey - m).max(0)..=(ey + m).min(ny as isize - 1) {
            out[y as usize * nx + ex] = true;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fem::quadrature::gauss_quad;

    /// A mesh on moved axes is the mesh built there: same numbering, new coordinates; the
    /// period must stay.
    #[test]
    fn a_mesh_on_other_axes_is_the_mesh_built_there() {
        let base = Mesh::rectangle(
            Axis::uniform(-1.0, 1.0, 8),
            Axis::uniform(-0.5, 0.5, 4),
            true,
        );
        let (ax, ay) = (
            Axis::centred(-0.9, 1.1, 8, 2.0),
            Axis::centred(-0.5, 0.5, 4, 1.5),
        );
        let moved = base.with_axes(ax.clone(), ay.clone());
        let built = Mesh::rectangle(ax, ay, true);
        assert_eq!(moved.nodes, built.nodes);
        assert_eq!(moved.element_coords, built.element_coords);
        assert_eq!(moved.elements, base.elements);
        assert_eq!(moved.element_vertices, base.element_vertices);
        let annulus = Mesh::annulus(12, Axis::uniform(1.0, 2.0, 3));
        let r = Axis::centred(1.0, 2.0, 3, 2.0);
        let graded = annulus.with_axes(annulus.ax.clone(), r.clone());
        assert_eq!(graded.nodes, Mesh::annulus(12, r).nodes);
        let longer = std::panic::catch_unwind(|| {
            base.with_axes(Axis::uniform(-1.0, 1.5, 8), Axis::uniform(-0.5, 0.5, 4))
        });
        assert!(longer.is_err(), "another period");
    }

    fn area(mesh: &Mesh) -> f64 {
        let rule = gauss_quad(3);
        let mut a = 0.0;
        for c in &mesh.element_coords {
            for (p, w) in rule.points.iter().zip(&rule.weights) {
                a += w * q2_map(c, *p).2;
            }
        }
        a
    }

    #[test]
    fn periodic_rectangle_counts_and_area() {
        let m = Mesh::rectangle(
            Axis::uniform(0.0, 4.0, 8),
            Axis::graded(0.0, 1.0, 4, 0.5, 1.0),
            true,
        );
        assert_eq!(m.n_nodes(), 16 * 9);
        assert_eq!(m.n_vertices(), 8 * 5);
        assert_eq!(m.n_elements(), 32);
        // the seam element's right nodes are node column 0, but its coordinates are unwrapped
        let e = m.n_elements() / 4 - 1;
        assert_eq!(m.node_ij(m.elements[e][2]).0, 0);
        assert!((m.element_coords[e][2][0] - 4.0).abs() < 1e-14);
        assert!((area(&m) - 4.0).abs() < 1e-12);
        assert_eq!(m.side_nodes(Side::Left).len(), 0);
        assert_eq!(m.side_nodes(Side::Bottom).len(), 16);
    }

    #[test]
    fn locate_inverts_the_rectangle_map() {
        // affine elements: the inverse is exact up to round-off
        const TOL: f64 = 1e-12;
        let m = Mesh::rectangle(
            Axis::graded(-2.0, 2.0, 9, 0.3, 1.5),
            Axis::uniform(0.0, 1.0, 4),
            true,
        );
        for x in [[0.123, 0.77], [-1.99, 0.01], [5.123 - 4.0, 0.5]] {
            let (e, xi) = m.locate(x).unwrap();
            let p = q2_map(&m.element_coords[e], xi).0;
            let px = -2.0 + (x[0] + 2.0).rem_euclid(4.0);
            assert!(
                (p[0] - px).abs() < TOL && (p[1] - x[1]).abs() < TOL,
                "{x:?} -> {p:?}"
            );
        }
        assert!(m.locate([0.0, 1.5]).is_none());
    }

    #[test]
    fn annulus_area_converges_at_fourth_order() {
        // Isoparametric Q2 boundary: area error O(h^4) (nodes exactly on the circles).
        let exact = std::f64::consts::PI * (4.0 - 1.0);
        let e1 = (area(&Mesh::annulus(8, Axis::uniform(1.0, 2.0, 2))) - exact).abs();
        let e2 = (area(&Mesh::annulus(16, Axis::uniform(1.0, 2.0, 2))) - exact).abs();
        let rate = (e1 / e2).log2();
        assert!(rate > 3.8, "area rate {rate} ({e1}, {e2})");
    }

    #[test]
    fn locate_inverts_the_annulus_map_at_random_points() {
        // Newton on a smooth map from a good guess: the inverse is exact up to round-off.
        const TOL: f64 = 1e-12;
        let m = Mesh::annulus(24, Axis::graded(1.0, 4.0, 6, 1.0, 1.0));
        // deterministic pseudo-random points (LCG) spread over the exact annulus, seam included
        let mut s: u64 = 12345;
        let mut next = || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (s >> 11) as f64 / (1u64 << 53) as f64
        };
        // and with a θ axis that starts elsewhere and is not uniform (a mesh that follows a
        // particle across the seam moves vertex 0)
        let two_pi = 2.0 * std::f64::consts::PI;
        let theta = Axis {
            vertices: (0..=24)
                .map(|i| {
                    let s = i as f64 / 24.0;
                    -0.4 + two_pi * s + 0.2 * (two_pi * s).sin()
                })
                .collect(),
        };
        let moved = m.with_axes(theta, m.ay.clone());
        for mesh in [&m, &moved] {
            for _ in 0..2000 {
                let (r, th) = (1.0 + 3.0 * next(), two_pi * (next() - 0.5));
                let x = [r * th.cos(), r * th.sin()];
                let (e, xi) = mesh.locate(x).expect("a point of the annulus is located");
                let p = q2_map(&mesh.element_coords[e], xi).0;
                let err = (p[0] - x[0]).hypot(p[1] - x[1]);
                assert!(err < TOL, "{x:?} -> {p:?} in {e}: {err}");
            }
        }
        // Points on the exact circles, between nodes, may lie just outside the discrete annulus:
        // located in the boundary layer, with X_e(ξ) on the discrete boundary within its distance
        // to the circle. Q2 interpolation of a circle of radius R over Δθ: radial error
        // ≈ R Δθ⁴/520 (measured 3.62e-5 for R = 4, Δθ = 2π/24, all on the outer circle, where
        // the parabolas lie inside the circle); bound R Δθ⁴/400.
        let boundary_error = 4.0 * (2.0 * std::f64::consts::PI / 24.0).powi(4) / 400.0;
        let (mut clamped, mut worst) = (0, 0.0f64);
        for (layer, r) in [(0, 1.0), (5, 4.0)] {
            for k in 0..240 {
                let th = 2.0 * std::f64::consts::PI * (k as f64 + 0.3) / 240.0;
                let x = [r * th.cos(), r * th.sin()];
                let (e, xi) = m.locate(x).unwrap();
                assert_eq!(e / 24, layer, "radial layer at {x:?}");
                let p = q2_map(&m.element_coords[e], xi).0;
                worst = worst.max((p[0] - x[0]).hypot(p[1] - x[1]));
                clamped += usize::from(xi[1].abs() == 1.0);
            }
        }
        println!("{clamped} of 480 boundary points clamped, at most {worst:.2e} from the image");
        assert!(worst < boundary_error, "{worst:e} vs {boundary_error:e}");
        assert!(m.locate([0.999, 0.0]).is_none());
        assert!(m.locate([0.0, 4.001]).is_none());
        assert!(m.locate([0.0, 0.0]).is_none());
    }

    #[test]
    fn locate_finds_annulus_nodes_in_an_element_holding_them() {
        // nodes are exact images of ξ ∈ {−1, 0, 1}²: round-off only
        const TOL: f64 = 1e-12;
        let m = Mesh::annulus(16, Axis::uniform(1.0, 4.0, 4));
        for (e, (nodes, coords)) in m.elements.iter().zip(&m.element_coords).enumerate() {
            for (k, x) in coords.iter().enumerate() {
                let (f, xi) = m.locate(*x).unwrap();
                // the node must be node (a, b) of the located element at ξ = (a − 1, b − 1)
                let ref_xi = |a: usize| a as f64 - 1.0;
                let hit = (0..9)
                    .find(|&l| m.elements[f][l] == nodes[k])
                    .unwrap_or_else(|| {
                        panic!("node {} of element {e} located in {f} without it", nodes[k])
                    });
                assert!((xi[0] - ref_xi(hit % 3)).abs() < TOL, "{e}/{k}: {xi:?}");
                assert!((xi[1] - ref_xi(hit / 3)).abs() < TOL, "{e}/{k}: {xi:?}");
                if k == 4 {
                    assert_eq!(f, e, "an element's centre node is its own");
                }
            }
        }
    }
}
