//! Point location in the ALE mesh x_m + d_m (thesis Eq. 5.39): the element E and reference
//! point ξ with X_E(ξ) + d(E, ξ) = x, and the pre-image X_E(ξ) on the undisplaced mesh
//! (Eqs. 5.42, 5.43).

use super::AleError;
use crate::fem::element::{q1, q2_map};
use crate::fem::newton_inverse::{newton_inverse, Bound, Newton};
use crate::mesh::{bounding_box, Mesh, Shape};
use crate::periodic::nearest_image;

/// Newton tolerance of the point location, in reference coordinates. Round-off limits ξ to about
/// ε|x|/h (7e-14 for |x| = 2, h = 0.013): a tolerance of 1e-13 failed there (300×75 channel,
/// L = 4); 1e-11 still places the point to 1e-11 h.
const NEWTON_TOL: f64 = 1e-11;
/// Newton iterations before a candidate element is given up.
const NEWTON_MAX_ITER: usize = 30;
/// How far outside [−1, 1]² a converged ξ may lie and still count as inside (points on an edge
/// shared by two elements, round-off).
const INSIDE_TOL: f64 = 1e-9;
/// How far outside [−1, 1]² the nearest candidate of a point on a circle of the annulus may lie:
/// the discrete boundary (parabolas through the nodes) is up to R Δθ⁴/520 inside the circle
/// between its nodes, ≈ 6e-6 in ξ for R = 4, Δθ = 2π/64, h_r = 0.25 (a mesh that follows a
/// particle puts the new wall nodes there). Points missed in the interior are off by O(1).
const CURVED_BOUNDARY_TOL: f64 = 1e-4;

/// How far the pre-image may lie from `x`, relative to the smallest side of `x`'s element, for
/// the search to start in that element without locating x − d(x) first: the pre-image is then in
/// the element or one of its neighbours, which the search tries next.
const NEAR_SHIFT: f64 = 0.25;

/// Locates `x` in the mesh displaced by `d` and returns (element, ξ, X_E(ξ)) with the pre-image
/// X_E(ξ) as the periodic image nearest to `x`. `at` is where `x` lies in the undisplaced mesh
/// (element and ξ), if the caller knows it (a node of the mesh, a pre-image found before): it
/// spares locating `x` (a Newton iteration on a curved mesh).
pub(super) fn pre_image(
    mesh: &Mesh,
    d: &[[f64; 2]],
    x: [f64; 2],
    period: Option<f64>,
    at: Option<(usize, [f64; 2])>,
) -> Result<(usize, [f64; 2], [f64; 2]), AleError> {
    let not_found = || AleError::NotFound { x: x[0], y: x[1] };
    // pre-images of wall points may leave the domain by round-off: start from the wall
    let locate = |x: [f64; 2]| {
        mesh.locate(x).or_else(|| match mesh.shape {
            Shape::Rectangle => {
                let (y0, y1) = (mesh.ay.vertices[0], mesh.ay.vertices[mesh.ay.len()]);
                let (x0, x1) = (mesh.ax.vertices[0], mesh.ax.vertices[mesh.ax.len()]);
                let xx = if mesh.periodic {
                    x[0]
                } else {
                    x[0].clamp(x0, x1)
                };
                mesh.locate([xx, x[1].clamp(y0, y1)])
            }
            // a point of the discrete inner or outer boundary of another mesh (whose nodes on
            // the circle lie elsewhere) can be O(h⁴) outside the circles: onto the circle
            Shape::Annulus => {
                let (r1, r2) = (mesh.ay.vertices[0], mesh.ay.vertices[mesh.ay.len()]);
                let r = x[0].hypot(x[1]);
                let s = r.clamp(r1, r2) / r;
                mesh.locate([x[0] * s, x[1] * s])
            }
        })
    };
    let (e0, xi0) = match at {
        Some(at) => at,
        None => locate(x).ok_or_else(not_found)?,
    };
    // The pre-image X solves X + d(X) = x. Where d varies slowly (everywhere but across a few
    // elements next to a rigid patch) X ≈ x − d(x): search around that first, then around x.
    // A displacement of more than an element per step (a particle at speed U with UΔt > h, and
    // the first predicted step moves by 2UΔt) puts X beyond the neighbours of x's element.
    let dx = {
        let (n, _) = q1(xi0);
        let dv = mesh.element_vertices[e0].map(|v| d[v]);
        (0..4).fold([0.0; 2], |a, m| {
            [a[0] + n[m] * dv[m][0], a[1] + n[m] * dv[m][1]]
        })
    };
    let (lo, hi) = bounding_box(&mesh.element_coords[e0]);
    let near = dx[0].hypot(dx[1]) <= NEAR_SHIFT * (hi[0] - lo[0]).min(hi[1] - lo[1]);
    let guess = if near {
        None
    } else {
        locate([x[0] - dx[0], x[1] - dx[1]])
    };
    // on a graded mesh x's neighbours may be much smaller than its element (a film's columns
    // next to the taper): a shift "near" for x's element can then cross several of them, so
    // x − d(x) is searched around last
    let late = || near.then(|| locate([x[0] - dx[0], x[1] - dx[1]])).flatten();
    let (nx, ny) = mesh.dims();
    let mut best: Option<(f64, usize, [f64; 2])> = None;
    let mut tried = Vec::with_capacity(27);
    let candidates = guess
        .into_iter()
        .chain(std::iter::once((e0, xi0)))
        .chain(std::iter::once_with(late).flatten());
    for (ec, xic) in candidates {
        let (exc, eyc) = ((ec % nx) as isize, (ec / nx) as isize);
        // the centre element first (from the located ξ), then its neighbours
        for (dx, dy) in std::iter::once((0, 0)).chain(
            [-1, 0, 1]
                .into_iter()
                .flat_map(|a| [-1, 0, 1].map(move |b| (a, b)))
                .filter(|&p| p != (0, 0)),
        ) {
            let ey = eyc + dy;
            if ey < 0 || ey >= ny as isize {
                continue;
            }
            let mut ex = exc + dx;
            if mesh.periodic {
                ex = ex.rem_euclid(nx as isize);
            } else if ex < 0 || ex >= nx as isize {
                continue;
            }
            let e = ey as usize * nx + ex as usize;
            if tried.contains(&e) {
                continue;
            }
            tried.push(e);
            let xe = &mesh.element_coords[e];
            let xc = nearest_image(
                x,
                xe[4][0],
                period.filter(|_| mesh.shape == Shape::Rectangle),
            );
            let start = if (dx, dy) == (0, 0) { xic } else { [0.0, 0.0] };
            let map = ElementMap::of(mesh, xe);
            let Some(xi) = newton(&map, &mesh.element_vertices[e], d, xc, start) else {
                continue;
            };
            let out = (xi[0].abs() - 1.0).max(xi[1].abs() - 1.0);
            if out <= INSIDE_TOL {
                let p = map.at(xi).0;
                return Ok((e, clamp(xi), nearest_image(p, x[0], period)));
            }
            if best.as_ref().is_none_or(|b| out < b.0) {
                best = Some((out, e, xi));
            }
        }
    }
    // points of the exact boundary just outside the discrete (curved) one: nearest candidate
    match best {
        Some((out, e, xi)) if out < CURVED_BOUNDARY_TOL => {
            let xi = clamp(xi);
            let p = ElementMap::of(mesh, &mesh.element_coords[e]).at(xi).0;
            Ok((e, xi, nearest_image(p, x[0], period)))
        }
        _ => Err(not_found()),
    }
}

fn clamp(xi: [f64; 2]) -> [f64; 2] {
    xi.map(|v| v.clamp(-1.0, 1.0))
}

/// The geometric map X_E of an element: affine on a rectangle mesh (straight sides, the Q2
/// nodes at the midpoints: `Axis::q2_coord`), the isoparametric Q2 map otherwise (the annulus).
enum ElementMap<'a> {
    Affine { center: [f64; 2], half: [f64; 2] },
    Q2(&'a [[f64; 2]; 9]),
}

impl<'a> ElementMap<'a> {
    fn of(mesh: &Mesh, xe: &'a [[f64; 2]; 9]) -> Self {
        match mesh.shape {
            Shape::Rectangle => {
                let (lo, hi) = bounding_box(xe);
                Self::Affine {
                    center: [0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1])],
                    half: [0.5 * (hi[0] - lo[0]), 0.5 * (hi[1] - lo[1])],
                }
            }
            Shape::Annulus => Self::Q2(xe),
        }
    }

    /// X_E(ξ) and its Jacobian.
    #[inline]
    fn at(&self, xi: [f64; 2]) -> ([f64; 2], [[f64; 2]; 2]) {
        match self {
            Self::Affine { center, half } => (
                [center[0] + half[0] * xi[0], center[1] + half[1] * xi[1]],
                [[half[0], 0.0], [0.0, half[1]]],
            ),
            Self::Q2(xe) => {
                let (p, jac, _) = q2_map(xe, xi);
                (p, jac)
            }
        }
    }
}

/// Solves X_E(ξ) + Σ N_v(ξ) d_v = x for ξ by Newton ([`newton_inverse`]) from `start`; `None`
/// without convergence, at a singular Jacobian or once an iterate leaves [−10, 10]².
fn newton(
    map: &ElementMap<'_>,
    verts: &[usize; 4],
    d: &[[f64; 2]],
    x: [f64; 2],
    start: [f64; 2],
) -> Option<[f64; 2]> {
    const NEWTON: Newton = Newton {
        max_iter: NEWTON_MAX_ITER,
        step_tol: NEWTON_TOL,
        bound: Bound::Abandon(10.0),
    };
    let dv = verts.map(|v| d[v]);
    let residual = |xi| {
        let (p, mut jac) = map.at(xi);
        let (n, dn) = q1(xi);
        let mut r = [x[0] - p[0], x[1] - p[1]];
        for a in 0..4 {
            for i in 0..2 {
                r[i] -= n[a] * dv[a][i];
                for k in 0..2 {
                    jac[i][k] += dn[a][k] * dv[a][i];
                }
            }
        }
        (r, jac)
    };
    newton_inverse(residual, start, &NEWTON).ok()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::Axis;

    /// A film's thin columns next to a wide element (a graded axis: 1, 0.001 ×3, 0.997, 1): a
    /// point of the wide element near the thin ones, displaced by a uniform 0.0095 — a small
    /// shift for its element, but its pre-image lies three thin columns to the left, beyond the
    /// element's neighbours. It is found around x − d(x).
    #[test]
    fn a_pre_image_beyond_thin_neighbours_is_found() {
        let ax = Axis {
            vertices: vec![0.0, 1.0, 1.001, 1.002, 1.003, 2.0, 3.0],
        };
        let mesh = Mesh::rectangle(ax, Axis::uniform(0.0, 1.0, 2), false);
        let d = vec![[0.0095, 0.0]; mesh.n_vertices()];
        let x = [1.01, 0.3];
        let (e, _, p) = pre_image(&mesh, &d, x, None, None).expect("found");
        assert_eq!(e % 6, 1, "the pre-image's column");
        assert!(
            (p[0] - 1.0005).abs() < 1e-12 && (p[1] - 0.3).abs() < 1e-12,
            "{p:?}"
        );
    }
}
