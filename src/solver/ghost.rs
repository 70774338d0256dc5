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
//!
//! The flow (Q2 velocity, Q1 pressure) uses the *patch* form instead ([`ghost_patch_matrices`]),
//! which needs no higher normal derivatives of Q2: without it, velocities at nodes with a fluid
//! sliver came out as large as 1e5 (docs/validation.md).

use crate::fem::element::{physical_gradients, q1, q2_map};
use crate::fem::quadrature::QuadRule;
use crate::fem::sparse::{PatternBuilder, SparseMatrix};
use crate::mesh::{dilate, Mesh, Shape};
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

/// The faces that get the ghost penalty for the given cuts (periodic neighbours included). An
/// element integrated whole (the fictitious domain method) has no small fluid part to tie to its
/// neighbours: only XFEM's cut cells count.
pub fn ghost_faces(mesh: &Mesh, cuts: &[ElementCut]) -> Vec<GhostFace> {
    let is_cut = |e: usize| matches!(&cuts[e], ElementCut::Cut(c) if !c.whole);
    let inside = |e: usize| matches!(cuts[e], ElementCut::Inside);
    faces_where(mesh, |e, o| {
        !inside(e) && !inside(o) && (is_cut(e) || is_cut(o))
    })
}

/// The interior faces (periodic neighbours included) between elements `e`, `o` with `keep(e, o)`.
pub fn faces_where(mesh: &Mesh, keep: impl Fn(usize, usize) -> bool) -> Vec<GhostFace> {
    let (nx, ny) = mesh.dims();
    let mut faces = Vec::new();
    for ey in 0..ny {
        for ex in 0..nx {
            let e = ey * nx + ex;
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
                    if keep(e, o) {
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

/// Local matrices of the *patch* ghost penalty of the flow on a face (Preuß 2018; Burman et al.
/// 2022): with E₁u, E₂u the polynomials of the two elements extended to the whole patch
/// K₁ ∪ K₂,
///
/// ```text
///   j(u, v) = ∫_{K₁∪K₂} (E₁u − E₂u)(E₁v − E₂v) dx
/// ```
///
/// which vanishes for a field that is one polynomial across the face and ties the values at
/// nodes with a sliver of fluid to their neighbours. Q2 scalar over the 18 node slots (the first
/// element's nine, then the second's) into `k2` and Q1 over the 8 vertex slots into `k1`, both
/// row-major; returns the patch diameter (the larger element size). Extension in reference
/// coordinates: a point of one element is located in the other's (extrapolated) map. `rule`:
/// the element quadrature (3×3 Gauss integrates the Q2 products exactly on affine elements).
pub fn ghost_patch_matrices(
    mesh: &Mesh,
    face: &GhostFace,
    rule: &QuadRule,
    k2: &mut [f64; 324],
    k1: &mut [f64; 64],
) -> f64 {
    use crate::fem::element::q2;
    use crate::mesh::structured::invert_q2_map;
    let xs = [
        &mesh.element_coords[face.first],
        &mesh.element_coords[face.second],
    ];
    k2.fill(0.0);
    k1.fill(0.0);
    // reference offset of the other element's centre: (±2, 0) or (0, ±2)
    let shift = match face.side {
        FaceSide::Right => [2.0, 0.0],
        FaceSide::Top => [0.0, 2.0],
    };
    let period = (mesh.periodic && mesh.shape == Shape::Rectangle)
        .then(|| mesh.ax.vertices[mesh.ax.len()] - mesh.ax.vertices[0]);
    let mut size = 0.0_f64;
    for (own, other) in [(0usize, 1usize), (1, 0)] {
        let sign = if own == 0 { 1.0 } else { -1.0 };
        let c = xs[own];
        size = size
            .max(((c[8][0] - c[0][0]).powi(2) + (c[8][1] - c[0][1]).powi(2)).sqrt() / 2f64.sqrt());
        let centre_other = xs[other][4];
        for (xi, w) in rule.points.iter().zip(&rule.weights) {
            let (x, _, det) = q2_map(xs[own], *xi);
            // the other element may lie across the periodic seam
            let x = crate::periodic::nearest_image(x, centre_other[0], period);
            let guess = [xi[0] - sign * shift[0], xi[1] - sign * shift[1]];
            let xo = invert_q2_map(xs[other], x, guess);
            let wq = w * det;
            let (n_own, n_oth) = (q2(*xi).0, q2(xo).0);
            let (p_own, p_oth) = (q1(*xi).0, q1(xo).0);
            // slots: first element's basis with +, second's with −
            let mut j2 = [0.0; 18];
            let mut j1 = [0.0; 8];
            let (o, t) = if own == 0 { (0, 9) } else { (9, 0) };
            for a in 0..9 {
                j2[o + a] += sign * n_own[a];
                j2[t + a] -= sign * n_oth[a];
            }
            let (o, t) = if own == 0 { (0, 4) } else { (4, 0) };
            for a in 0..4 {
                j1[o + a] += sign * p_own[a];
                j1[t + a] -= sign * p_oth[a];
            }
            for a in 0..18 {
                for b in 0..18 {
                    k2[18 * a + b] += wq * j2[a] * j2[b];
                }
            }
            for a in 0..8 {
                for b in 0..8 {
                    k1[8 * a + b] += wq * j1[a] * j1[b];
                }
            }
        }
    }
    size
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

/// Rings of elements around the elements of the ghost faces in use whose faces a
/// [`FacePattern`] holds in advance: a particle moves at most half an element per step, so the
/// pattern (and the symbolic analysis of its factorization) lasts several steps. Measured
/// (`xpflow bench moving`, 200×50, three particles): with the exact faces the pattern changed in
/// half of the steps, each time a new symbolic LU of the transport (0.011–0.016 s, and a first
/// factorization 1.7× the cost of the others) and of the projections' mass matrix.
pub const FACE_PATTERN_MARGIN: usize = 2;

/// The ghost faces a Q1 pattern was built for: those in use when it was built and every interior
/// face between elements within [`FACE_PATTERN_MARGIN`] rings of them. Their couplings are in the
/// pattern whether or not the faces are in use (zeros when not).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct FacePattern {
    /// Two flags per element: its right face, its top face.
    held: Vec<bool>,
}

impl FacePattern {
    /// Whether the pattern holds every one of `faces` (never, before the first
    /// [`around`](Self::around)).
    pub fn holds(&self, faces: &[GhostFace]) -> bool {
        !self.held.is_empty() && faces.iter().all(|f| self.held[face_slot(f)])
    }

    /// The Q1 pattern with the couplings of the faces around `faces` when `faces` leave those
    /// this pattern holds (it then holds the new ones), `None` while it holds them.
    pub fn matrix_for(&mut self, mesh: &Mesh, faces: &[GhostFace]) -> Option<SparseMatrix> {
        if self.holds(faces) {
            return None;
        }
        let (pattern, around) = Self::around(mesh, faces);
        *self = pattern;
        Some(pattern_with_faces(mesh, &around))
    }

    /// The faces around `faces` (see [`FacePattern`]), and the pattern that holds them.
    pub fn around(mesh: &Mesh, faces: &[GhostFace]) -> (Self, Vec<GhostFace>) {
        let mut touched = vec![false; mesh.n_elements()];
        for f in faces {
            touched[f.first] = true;
            touched[f.second] = true;
        }
        let near = dilate(&touched, mesh.dims(), mesh.periodic, FACE_PATTERN_MARGIN);
        let all = faces_where(mesh, |e, o| near[e] && near[o]);
        let mut held = vec![false; 2 * mesh.n_elements()];
        all.iter().for_each(|f| held[face_slot(f)] = true);
        (Self { held }, all)
    }
}

/// A face's flag in [`FacePattern`]: its first element's right or top face.
fn face_slot(f: &GhostFace) -> usize {
    2 * f.first + usize::from(f.side == FaceSide::Top)
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

    #[test]
    fn patch_penalty_vanishes_on_polynomials_and_sees_kinks() {
        // 8×4 periodic mesh on [0, 2] × [0, 1] (h = 1/4): an interior face and the seam face
        let mesh = Mesh::rectangle(Axis::uniform(0.0, 2.0, 8), Axis::uniform(0.0, 1.0, 4), true);
        let (mut k2, mut k1) = ([0.0; 324], [0.0; 64]);
        let rule = crate::fem::quadrature::gauss_quad(3);
        let faces = [
            GhostFace {
                first: 9,
                second: 10,
                side: FaceSide::Right,
            },
            GhostFace {
                first: 9,
                second: 17,
                side: FaceSide::Top,
            },
            // the last element of row 1 and the first (across the seam x = 2 ≡ 0)
            GhostFace {
                first: 15,
                second: 8,
                side: FaceSide::Right,
            },
        ];
        for face in faces {
            let h = ghost_patch_matrices(&mesh, &face, &rule, &mut k2, &mut k1);
            assert!((h - 0.25).abs() < ROUND_OFF, "patch size {h}");
            // the element's own (unwrapped) node coordinates: periodic x continues across the seam
            let node_x =
                |slot: usize| mesh.element_coords[[face.first, face.second][slot / 9]][slot % 9];
            let q2_energy = |f: &dyn Fn([f64; 2]) -> f64| {
                let mut x: Vec<[f64; 2]> = (0..18).map(node_x).collect();
                if face.first == 15 {
                    // second element across the seam: shift it to continue the first
                    x[9..].iter_mut().for_each(|p| p[0] += 2.0);
                }
                let u: Vec<f64> = x.iter().map(|&p| f(p)).collect();
                (0..18)
                    .flat_map(|a| (0..18).map(move |b| (a, b)))
                    .map(|(a, b)| u[a] * k2[18 * a + b] * u[b])
                    .sum::<f64>()
            };
            let q1_energy = |f: &dyn Fn([f64; 2]) -> f64| {
                // vertex slot a of an element is its node [0, 2, 6, 8][a]
                let x: Vec<[f64; 2]> = (0..8)
                    .map(|a| node_x(9 * (a / 4) + [0, 2, 6, 8][a % 4]))
                    .map(|mut p| {
                        if face.first == 15 && p[0] < 1.0 {
                            p[0] += 2.0;
                        }
                        p
                    })
                    .collect();
                let p: Vec<f64> = x.iter().map(|&y| f(y)).collect();
                (0..8)
                    .flat_map(|a| (0..8).map(move |b| (a, b)))
                    .map(|(a, b)| p[a] * k1[8 * a + b] * p[b])
                    .sum::<f64>()
            };
            let quad = |x: [f64; 2]| {
                1.0 + x[0] - 2.0 * x[1] + x[0] * x[0] - x[0] * x[1] * x[1] + 3.0 * x[1] * x[1]
            };
            assert!(
                q2_energy(&quad).abs() < ROUND_OFF,
                "{face:?}: {}",
                q2_energy(&quad)
            );
            let bilin = |x: [f64; 2]| 2.0 - x[0] + 0.5 * x[1] + x[0] * x[1];
            assert!(
                q1_energy(&bilin).abs() < ROUND_OFF,
                "{face:?}: {}",
                q1_energy(&bilin)
            );
            // a kink on the face: |x − x_F| (Right) or |y − y_F| (Top) is seen
            let xf = match face.side {
                FaceSide::Right => mesh.element_coords[face.first][2][0],
                FaceSide::Top => mesh.element_coords[face.first][6][1],
            };
            let kink = |x: [f64; 2]| match face.side {
                FaceSide::Right => (x[0] - xf).abs(),
                FaceSide::Top => (x[1] - xf).abs(),
            };
            assert!(q2_energy(&kink) > 1e-3, "{face:?}: {}", q2_energy(&kink));
            assert!(q1_energy(&kink) > 1e-3, "{face:?}: {}", q1_energy(&kink));
        }
    }

    #[test]
    fn a_face_pattern_holds_the_faces_around_those_it_was_built_for() {
        let mesh = Mesh::rectangle(
            crate::mesh::Axis::uniform(0.0, 2.0, 20),
            crate::mesh::Axis::uniform(0.0, 1.0, 10),
            true,
        );
        let nx = 20;
        let face = |ex: usize, ey: usize, side| GhostFace {
            first: ey * nx + ex,
            second: match side {
                FaceSide::Right => ey * nx + (ex + 1) % nx,
                FaceSide::Top => (ey + 1) * nx + ex,
            },
            side,
        };
        let mut fp = FacePattern::default();
        assert!(!fp.holds(&[]), "nothing before the first pattern");
        let used = [face(5, 5, FaceSide::Right)];
        let m = fp.matrix_for(&mesh, &used).expect("a first pattern");
        assert!(fp.holds(&used));
        // faces two rings away (between elements within FACE_PATTERN_MARGIN of the used ones) are
        // held and coupled in the pattern; three rings away not
        let near = face(7, 3, FaceSide::Top);
        assert!(fp.holds(&[near]) && fp.matrix_for(&mesh, &[near]).is_none());
        let fv = face_vertices(&mesh, &near);
        let couples = |m: &SparseMatrix| {
            fv.iter()
                .all(|&i| fv.iter().all(|&j| m.column(j).0.binary_search(&i).is_ok()))
        };
        let plain = crate::fem::sparse::q1_pattern(mesh.n_vertices(), &mesh.element_vertices);
        assert!(couples(&m) && !couples(&plain));
        let far = face(9, 5, FaceSide::Right);
        assert!(!fp.holds(&[far]));
        assert!(fp.matrix_for(&mesh, &[far]).is_some() && fp.holds(&[far]));
    }
}
