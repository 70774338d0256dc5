//! Structured quadrilateral meshes with Q2 nodes: a rectangle (optionally periodic in x) and an
//! annulus (isoparametric Q2 elements with nodes on the exact circles, periodic in θ).
//!
//! Node grid: Q2 node `(i, j)` with `i ∈ 0..=2·nx`, `j ∈ 0..=2·ny`; vertices of the Q1 sub-grid are the
//! nodes with even `i` and `j`. On a periodic direction the last node column is identified with the
//! first (node identification, not constraints: fewer unknowns, the same result). Element `(ex, ey)`
//! has the Q2 nodes `(2ex + a, 2ey + b)`, `a, b ∈ {0, 1, 2}`, in tensor order (`a + 3b`).

use super::axis::Axis;

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
    n_node_cols: usize,
}

impl Mesh {
    /// Rectangle mesh from two axes; `periodic` identifies x = x0 with x = x1.
    pub fn rectangle(ax: Axis, ay: Axis, periodic: bool) -> Self {
        Self::build(Shape::Rectangle, ax, ay, periodic)
    }

    /// Annulus R1 ≤ r ≤ R2 with `n_theta` uniform elements around and the radial axis `ar`.
    pub fn annulus(n_theta: usize, ar: Axis) -> Self {
        let at = Axis::uniform(0.0, 2.0 * std::f64::consts::PI, n_theta);
        Self::build(Shape::Annulus, at, ar, true)
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

    /// Element containing `x` and the reference coordinates there, for rectangle meshes (x is
    /// wrapped into the period when periodic); `None` outside the mesh or for an annulus.
    pub fn locate(&self, x: [f64; 2]) -> Option<(usize, [f64; 2])> {
        if self.shape != Shape::Rectangle {
            return None;
        }
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fem::element::q2_map;
    use crate::fem::quadrature::gauss_quad;

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
}
