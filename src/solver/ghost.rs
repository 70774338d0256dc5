//! Ghost-penalty stabilization of the Q1 fields on cut elements (Burman 2010; Burman & Hansbo
//! 2012): on every interior face of an element cut by a particle boundary,
//!
//! ```text
//!   j(s, d) = Σ_F γ_F ∫_F [∂_n s][∂_n d] ds
//! ```
//!
//! with [·] the jump across the face. A vertex whose support has only a sliver of fluid is then
//! tied to its neighbours by a smooth extension instead of being fixed by the sliver alone; without
//! it the log-conformation at such vertices of a moving particle's leading edge grows without
//! bound within a few steps. For Q1 the gradient jump of a smooth field is O(h), so the term is
//! weakly consistent. The face coefficient γ_F is chosen by the caller (it carries the units of
//! the equation being stabilized).

use crate::fem::element::{physical_gradients, q1, q2_map};
use crate::fem::sparse::{PatternBuilder, SparseMatrix};
use crate::mesh::Mesh;
use crate::solver::rigid::ElementCut;

/// Which face of the first element a ghost face is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FaceSide {
    /// ξ = +1 of the first element, ξ = −1 of the second.
    Right,
    /// η = +1 of the first element, η = −1 of the second.
    Top,
}

/// An interior face between two elements, at least one of them cut and neither inside a
/// particle.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct GhostFace {
    /// Element on the left / bottom.
    pub first: usize,
    /// Element on the right / top.
    pub second: usize,
    /// Orientation.
    pub side: FaceSide,
}

/// The faces that get the ghost penalty for the given cuts (periodic neighbours included).
pub fn ghost_faces(mesh: &Mesh, cuts: &[ElementCut]) -> Vec<GhostFace> {
    let (nx, ny) = mesh.dims();
    let is_cut = |e: usize| matches!(cuts[e], ElementCut::Cut(_));
    let inside = |e: usize| matches!(cuts[e], ElementCut::Inside);
    let mut faces = Vec::new();
    for ey in 0..ny {
        for ex in 0..nx {
            let e = ey * nx + ex;
            if inside(e) {
                continue;
            }
            let right = if ex + 1 < nx {
                Some(e + 1)
            } else if mesh.periodic && nx > 1 {
                Some(ey * nx)
            } else {
                None
            };
            let top = (ey + 1 < ny).then_some(e + nx);
            for (other, side) in [(right, FaceSide::Right), (top, FaceSide::Top)] {
                if let Some(o) = other {
                    if !inside(o) && (is_cut(e) || is_cut(o)) {
                        faces.push(GhostFace {
                            first: e,
                            second: o,
                            side,
                        });
                    }
                }
            }
        }
    }
    faces
}

/// Gauss–Legendre points on [−1, 1] for the face integral (exact for the quadratic integrand
/// of Q1 gradient jumps on affine elements).
const FACE_GAUSS: [(f64, f64); 2] = [
    (-0.577_350_269_189_625_8, 1.0),
    (0.577_350_269_189_625_8, 1.0),
];

/// Local matrix of `∫_F [∂_n ψ_a][∂_n ψ_b] ds` over the 8 vertex slots (first element's four,
/// then the second's; shared vertices appear twice and add up when scattered), and the face
/// length. Row-major 8×8 into `k`.
pub fn ghost_face_matrix(mesh: &Mesh, face: &GhostFace, k: &mut [f64; 64]) -> f64 {
    let (x1, x2) = (
        &mesh.element_coords[face.first],
        &mesh.element_coords[face.second],
    );
    k.fill(0.0);
    let mut length = 0.0;
    let (mut d1, mut d2) = ([[0.0; 2]; 4], [[0.0; 2]; 4]);
    for (t, w) in FACE_GAUSS {
        let (xi1, xi2) = match face.side {
            FaceSide::Right => ([1.0, t], [-1.0, t]),
            FaceSide::Top => ([t, 1.0], [t, -1.0]),
        };
        let (_, jac1, det1) = q2_map(x1, xi1);
        let (_, jac2, det2) = q2_map(x2, xi2);
        physical_gradients(&jac1, det1, &q1(xi1).1, &mut d1);
        physical_gradients(&jac2, det2, &q1(xi2).1, &mut d2);
        // tangent along the face in the first element: ∂x/∂η (Right) or ∂x/∂ξ (Top)
        let c = match face.side {
            FaceSide::Right => 1,
            FaceSide::Top => 0,
        };
        let tang = [jac1[0][c], jac1[1][c]];
        let ds = tang[0].hypot(tang[1]);
        let n = [tang[1] / ds, -tang[0] / ds];
        length += w * ds;
        let mut jump = [0.0; 8];
        for a in 0..4 {
            jump[a] = d1[a][0] * n[0] + d1[a][1] * n[1];
            jump[4 + a] = -(d2[a][0] * n[0] + d2[a][1] * n[1]);
        }
        for a in 0..8 {
            for b in 0..8 {
                k[8 * a + b] += w * ds * jump[a] * jump[b];
            }
        }
    }
    length
}

/// The Q1 pattern of the mesh's elements plus the couplings of the ghost `faces` (the vertices of
/// the two elements of a face are coupled with each other).
pub fn pattern_with_faces(mesh: &Mesh, faces: &[GhostFace]) -> SparseMatrix {
    let mut pb = PatternBuilder::new(mesh.n_vertices());
    mesh.element_vertices.iter().for_each(|g| pb.add_group(g));
    faces
        .iter()
        .for_each(|f| pb.add_group(&face_vertices(mesh, f)));
    pb.build()
}

/// The 8 vertex slots of a face (see [`ghost_face_matrix`]).
pub fn face_vertices(mesh: &Mesh, face: &GhostFace) -> [usize; 8] {
    let (a, b) = (
        mesh.element_vertices[face.first],
        mesh.element_vertices[face.second],
    );
    [a[0], a[1], a[2], a[3], b[0], b[1], b[2], b[3]]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::Axis;

    /// Sums of a few products of O(1/h) gradients: round-off.
    const ROUND_OFF: f64 = 1e-10;

    #[test]
    fn linear_fields_have_no_gradient_jump_and_kinks_do() {
        let mesh = Mesh::rectangle(Axis::uniform(0.0, 1.0, 4), Axis::uniform(0.0, 1.0, 4), true);
        let xv = |v: usize| mesh.nodes[mesh.node_of_vertex[v]];
        let mut k = [0.0; 64];
        for side in [FaceSide::Right, FaceSide::Top] {
            let face = GhostFace {
                first: 5,
                second: if side == FaceSide::Right { 6 } else { 9 },
                side,
            };
            let len = ghost_face_matrix(&mesh, &face, &mut k);
            assert!((len - 0.25).abs() < ROUND_OFF);
            let verts = face_vertices(&mesh, &face);
            let energy = |f: &dyn Fn([f64; 2]) -> f64| {
                let s: Vec<f64> = verts.iter().map(|&v| f(xv(v))).collect();
                (0..8)
                    .flat_map(|a| (0..8).map(move |b| (a, b)))
                    .map(|(a, b)| s[a] * k[8 * a + b] * s[b])
                    .sum::<f64>()
            };
            assert!(energy(&|x| 1.0 + 2.0 * x[0] - 3.0 * x[1]).abs() < ROUND_OFF);
            // |x − 1/2| (Right) or |y − 1/2| (Top) kinks on the face: jump 2, energy 4·|F|
            let kink = |x: [f64; 2]| match side {
                FaceSide::Right => (x[0] - 0.5).abs(),
                FaceSide::Top => (x[1] - 0.5).abs(),
            };
            assert!(
                (energy(&kink) - 4.0 * 0.25).abs() < ROUND_OFF,
                "{}",
                energy(&kink)
            );
        }
    }
}
