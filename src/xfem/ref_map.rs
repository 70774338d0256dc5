//! Element maps from the reference square [-1, 1]² to physical space, and their inverse.
//!
//! The XFEM geometry works element by element through [`RefMap`], so it never needs a mesh type:
//! rectangles, bilinear quadrilaterals and isoparametric Q2 elements (curved edges, e.g. the
//! annulus elements of the Couette geometry) all implement it. Nothing here assumes straight
//! edges. Corner/node ordering follows `fem::element` (tensor order: corner `a + 2b` at
//! ξ = (±1, ±1) with a, b ∈ {0, 1} for −1, +1).

use super::XfemError;
use crate::fem::element::q2_map;
use crate::fem::newton_inverse::{self as newton, Bound, Newton, NewtonFailure};
use crate::fem::quadrature::gauss_quad;

/// Lebesgue constant of tensor-product quadratic interpolation at three equispaced points per
/// direction (1.25² = 1.5625): bounds a biquadratic function on a box by its values on the 3×3
/// grid, which makes the default [`RefMap::image_radius`] rigorous for Q2 maps.
const Q2_LEBESGUE: f64 = 1.5625;

/// A smooth, positively oriented (det J > 0) map ξ ∈ [-1, 1]² → x of one element.
pub trait RefMap {
    /// The physical point x(ξ).
    fn map(&self, xi: [f64; 2]) -> [f64; 2];

    /// The Jacobian `J[i][j] = ∂x_i/∂ξ_j` at ξ.
    fn jacobian(&self, xi: [f64; 2]) -> [[f64; 2]; 2];

    /// The image of the reference centre, x(0, 0).
    fn centre(&self) -> [f64; 2] {
        self.map([0.0, 0.0])
    }

    /// An upper bound of max |x(ξ) − x(ξ_c)| over the reference box [lo, hi] with centre ξ_c
    /// (`lo[k] ≤ hi[k]`, a degenerate box is a segment). Cut detection relies on it.
    ///
    /// The default samples the 3×3 grid of the box and multiplies the largest distance by the
    /// Lebesgue constant of biquadratic interpolation, which is a true bound for maps that are
    /// biquadratic (isoparametric Q2) or simpler; override it for other maps.
    fn image_radius(&self, lo: [f64; 2], hi: [f64; 2]) -> f64 {
        sampled_image_radius(self, lo, hi)
    }
}

/// The default [`RefMap::image_radius`]: the 3×3 grid of the box sampled.
fn sampled_image_radius<M: RefMap + ?Sized>(m: &M, lo: [f64; 2], hi: [f64; 2]) -> f64 {
    let c = [0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1])];
    let xc = m.map(c);
    let mut r: f64 = 0.0;
    for eta in [lo[1], c[1], hi[1]] {
        for xi in [lo[0], c[0], hi[0]] {
            let x = m.map([xi, eta]);
            r = r.max((x[0] - xc[0]).hypot(x[1] - xc[1]));
        }
    }
    Q2_LEBESGUE * r
}

/// Determinant of a 2×2 matrix.
#[inline]
pub fn det2(j: &[[f64; 2]; 2]) -> f64 {
    j[0][0] * j[1][1] - j[0][1] * j[1][0]
}

/// Largest distance from x(centre of [lo, hi]) to the images of the four box corners: an exact
/// bound for maps that are bilinear on the box (the image lies in the corners' convex hull).
fn corner_radius<M: RefMap + ?Sized>(m: &M, lo: [f64; 2], hi: [f64; 2]) -> f64 {
    let xc = m.map([0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1])]);
    let mut r: f64 = 0.0;
    for corner in [lo, [hi[0], lo[1]], [lo[0], hi[1]], hi] {
        let x = m.map(corner);
        r = r.max((x[0] - xc[0]).hypot(x[1] - xc[1]));
    }
    r
}

/// An axis-aligned rectangle [lo, hi].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RectMap {
    lo: [f64; 2],
    hi: [f64; 2],
}

impl RectMap {
    /// The rectangle with lower-left corner `lo` and upper-right corner `hi`.
    ///
    /// # Panics
    /// Panics unless `lo[k] < hi[k]` for both k (a mesh never builds an empty element).
    pub fn new(lo: [f64; 2], hi: [f64; 2]) -> Self {
        assert!(
            lo[0] < hi[0] && lo[1] < hi[1],
            "RectMap: empty rectangle {lo:?}..{hi:?}"
        );
        Self { lo, hi }
    }
}

impl RefMap for RectMap {
    fn map(&self, xi: [f64; 2]) -> [f64; 2] {
        [
            self.lo[0] + 0.5 * (xi[0] + 1.0) * (self.hi[0] - self.lo[0]),
            self.lo[1] + 0.5 * (xi[1] + 1.0) * (self.hi[1] - self.lo[1]),
        ]
    }

    fn jacobian(&self, _xi: [f64; 2]) -> [[f64; 2]; 2] {
        [
            [0.5 * (self.hi[0] - self.lo[0]), 0.0],
            [0.0, 0.5 * (self.hi[1] - self.lo[1])],
        ]
    }

    fn image_radius(&self, lo: [f64; 2], hi: [f64; 2]) -> f64 {
        let j = self.jacobian(lo);
        0.5 * (j[0][0] * (hi[0] - lo[0])).hypot(j[1][1] * (hi[1] - lo[1]))
    }
}

/// A bilinear quadrilateral with corners in tensor order: (−1,−1), (1,−1), (−1,1), (1,1).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BilinearQuad {
    /// Physical corners in tensor order.
    pub corners: [[f64; 2]; 4],
}

impl RefMap for BilinearQuad {
    fn map(&self, xi: [f64; 2]) -> [f64; 2] {
        let n = [
            0.25 * (1.0 - xi[0]) * (1.0 - xi[1]),
            0.25 * (1.0 + xi[0]) * (1.0 - xi[1]),
            0.25 * (1.0 - xi[0]) * (1.0 + xi[1]),
            0.25 * (1.0 + xi[0]) * (1.0 + xi[1]),
        ];
        let c = &self.corners;
        [
            n[0] * c[0][0] + n[1] * c[1][0] + n[2] * c[2][0] + n[3] * c[3][0],
            n[0] * c[0][1] + n[1] * c[1][1] + n[2] * c[2][1] + n[3] * c[3][1],
        ]
    }

    fn jacobian(&self, xi: [f64; 2]) -> [[f64; 2]; 2] {
        let c = &self.corners;
        let mut j = [[0.0; 2]; 2];
        for i in 0..2 {
            j[i][0] =
                0.25 * ((1.0 - xi[1]) * (c[1][i] - c[0][i]) + (1.0 + xi[1]) * (c[3][i] - c[2][i]));
            j[i][1] =
                0.25 * ((1.0 - xi[0]) * (c[2][i] - c[0][i]) + (1.0 + xi[0]) * (c[3][i] - c[1][i]));
        }
        j
    }

    fn image_radius(&self, lo: [f64; 2], hi: [f64; 2]) -> f64 {
        corner_radius(self, lo, hi)
    }
}

/// An isoparametric Q2 element given by its nine physical nodes in the tensor order of
/// `fem::element` (curved edges allowed). Uses the default, rigorous-for-Q2 image radius.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Q2Element {
    /// Physical node coordinates, tensor order.
    pub nodes: [[f64; 2]; 9],
}

impl RefMap for Q2Element {
    fn map(&self, xi: [f64; 2]) -> [f64; 2] {
        q2_map(&self.nodes, xi).0
    }

    fn jacobian(&self, xi: [f64; 2]) -> [[f64; 2]; 2] {
        q2_map(&self.nodes, xi).1
    }

    /// The centre node (its shape function is 1 there, the others 0).
    fn centre(&self) -> [f64; 2] {
        self.nodes[4]
    }

    /// The whole element's 3×3 grid is its nodes, whose images are the node coordinates (the
    /// shape functions are exactly 0 or 1 there): read, not mapped — every element is classified
    /// by this every step, and the ten maps were most of it (the largest squared distance, one
    /// square root).
    fn image_radius(&self, lo: [f64; 2], hi: [f64; 2]) -> f64 {
        if lo != [-1.0, -1.0] || hi != [1.0, 1.0] {
            return sampled_image_radius(self, lo, hi);
        }
        let xc = self.nodes[4];
        let r2 = self.nodes.iter().fold(0.0f64, |r2, x| {
            let d = [x[0] - xc[0], x[1] - xc[1]];
            r2.max(d[0] * d[0] + d[1] * d[1])
        });
        Q2_LEBESGUE * r2.sqrt()
    }
}

/// Physical area ∫ det J dξ of an element by 3×3 Gauss (exact for bilinear and Q2 maps, whose
/// det J has degree ≤ 3 in each variable).
pub fn element_area<M: RefMap + ?Sized>(m: &M) -> f64 {
    let rule = gauss_quad(3);
    rule.points
        .iter()
        .zip(&rule.weights)
        .map(|(p, w)| w * det2(&m.jacobian(*p)))
        .sum()
}

/// Newton steps before the inverse map gives up (quadratic convergence needs < 10 from ξ = 0 on
/// reasonable elements).
const MAX_NEWTON: usize = 50;
/// A residual |x(ξ) − x| this small relative to |x| (a few ulps) is x placed to its round-off:
/// accepted when the updates, round-off over the element size, stay above
/// [`NEWTON_STEP_TOL`] (elements thinner than ≈ 1e-4 at |x| ≈ 1).
const ROUND_OFF_RESIDUAL: f64 = 8.0 * f64::EPSILON;
/// Newton stops when the reference update is below this. ξ is O(1), but its Newton updates
/// carry the round-off of x − x(ξ) divided by the element size: on a 0.05-wide element at
/// |x| ≈ 1 they stall around 1e-14 (seen on the confined-cylinder mesh), so 1e-12 — still far
/// below any quadrature need.
const NEWTON_STEP_TOL: f64 = 1e-12;
/// A reference point counts as inside the element up to this slack (round-off of Newton's ξ).
const INSIDE_TOL: f64 = 1e-10;
/// Newton iterates are kept in [-ξ_max, ξ_max]²: a point that far outside is certainly not in
/// the element, and extrapolated maps may fold beyond it.
const XI_MAX: f64 = 4.0;

/// The Newton settings of the inverse map.
const NEWTON: Newton = Newton {
    max_iter: MAX_NEWTON,
    step_tol: NEWTON_STEP_TOL,
    bound: Bound::Clamp(XI_MAX),
};

/// Newton's method for x(ξ) = x from ξ = 0 ([`fem::newton_inverse`](newton)), without checking
/// a converged ξ against the element (points on its boundary may come out a round-off outside).
/// Returns ξ and the residual |x(ξ) − x|; a non-converged iteration that ended outside the
/// element is `OutsideElement`.
pub(crate) fn newton_inverse<M: RefMap + ?Sized>(
    m: &M,
    x: [f64; 2],
) -> Result<([f64; 2], f64), XfemError> {
    let residual = |xi| {
        let p = m.map(xi);
        ([x[0] - p[0], x[1] - p[1]], m.jacobian(xi))
    };
    match newton::newton_inverse(residual, [0.0, 0.0], &NEWTON) {
        Ok(xi) => {
            let p = m.map(xi);
            Ok((xi, (p[0] - x[0]).hypot(p[1] - x[1])))
        }
        Err(NewtonFailure::Singular { xi, det }) => Err(XfemError::SingularJacobian { xi, det }),
        // x placed to its round-off: on a very thin element (a film's columns, a/256) the
        // updates stall at ε|x|/h, above the step tolerance
        Err(NewtonFailure::NotConverged { xi, residual })
            if !outside(xi)
                && residual <= ROUND_OFF_RESIDUAL * (1.0 + x[0].abs().max(x[1].abs())) =>
        {
            Ok((xi, residual))
        }
        Err(NewtonFailure::NotConverged { xi, residual }) if !outside(xi) => {
            Err(XfemError::InverseMapDiverged {
                x,
                residual,
                iterations: MAX_NEWTON,
            })
        }
        // Newton wandering outside the element means the point is not in it (the extrapolated
        // map may have no preimage at all, as for the centre of an annulus); clamped iterates
        // never escape.
        Err(failure) => Err(XfemError::OutsideElement {
            x,
            xi: failure.xi(),
        }),
    }
}

/// Whether ξ lies outside the element by more than [`INSIDE_TOL`].
fn outside(xi: [f64; 2]) -> bool {
    xi[0].abs() > 1.0 + INSIDE_TOL || xi[1].abs() > 1.0 + INSIDE_TOL
}

/// The reference coordinates ξ ∈ [-1, 1]² of the physical point `x` in the element `m`
/// (Newton's method from the element centre).
///
/// Errors: [`XfemError::OutsideElement`] when the point is not in the element (with where
/// Newton ended), [`XfemError::InverseMapDiverged`] or [`XfemError::SingularJacobian`] when the
/// map cannot be inverted there.
pub fn inverse_map<M: RefMap + ?Sized>(m: &M, x: [f64; 2]) -> Result<[f64; 2], XfemError> {
    let (xi, _) = newton_inverse(m, x)?;
    if outside(xi) {
        return Err(XfemError::OutsideElement { x, xi });
    }
    Ok(xi)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::xfem::test_support::AnnulusSector;

    /// Newton converges to round-off on O(1) coordinates.
    const ROUND_TRIP_TOL: f64 = 1e-12;

    fn check_round_trip<M: RefMap>(m: &M) {
        for &xi in &[
            [0.3, -0.7],
            [-1.0, 1.0],
            [0.99, 0.01],
            [-0.5, -0.5],
            [1.0, 1.0],
        ] {
            let x = m.map(xi);
            let back = inverse_map(m, x).expect("point of the element");
            assert!(
                (back[0] - xi[0]).abs() < ROUND_TRIP_TOL
                    && (back[1] - xi[1]).abs() < ROUND_TRIP_TOL,
                "{xi:?} -> {x:?} -> {back:?}"
            );
        }
    }

    fn skewed_quad() -> BilinearQuad {
        BilinearQuad {
            corners: [[0.0, 0.0], [2.0, 0.3], [-0.2, 1.0], [1.7, 1.6]],
        }
    }

    #[test]
    fn inverse_map_round_trips_on_rectangle_bilinear_and_curved_maps() {
        check_round_trip(&RectMap::new([1.0, -2.0], [1.25, -1.75]));
        check_round_trip(&skewed_quad());
        check_round_trip(&AnnulusSector::new([1.0, 1.5], [0.2, 0.9]));
    }

    /// A film's column at a/256 (width 4e-5 here, at x ≈ 0.5): Newton's updates stall at
    /// round-off over the width, above the step tolerance; every point is still placed (a
    /// Q2 element, as the cut cells see it).
    #[test]
    fn inverse_map_places_points_of_a_very_thin_element() {
        let (x0, w, y0, h) = (0.506_023_514_139_539_9, 4e-5, 0.0, 0.0125);
        let mut nodes = [[0.0; 2]; 9];
        for (k, node) in nodes.iter_mut().enumerate() {
            let (i, j) = (k % 3, k / 3);
            *node = [x0 + 0.5 * w * i as f64, y0 + 0.5 * h * j as f64];
        }
        let element = Q2Element { nodes };
        for k in 0..400 {
            let s = [(k % 20) as f64 / 19.0, (k / 20) as f64 / 19.0];
            let x = [x0 + s[0] * w, y0 + s[1] * h];
            let xi = inverse_map(&element, x).unwrap_or_else(|e| panic!("{x:?}: {e}"));
            assert!((xi[0] - (2.0 * s[0] - 1.0)).abs() < 1e-9, "{x:?}: {xi:?}");
        }
    }

    #[test]
    fn inverse_map_reports_points_outside() {
        let sector = AnnulusSector::new([1.0, 1.5], [0.2, 0.9]);
        let err = inverse_map(&sector, [0.0, 0.0]).expect_err("centre of the annulus");
        assert!(matches!(err, XfemError::OutsideElement { .. }), "{err}");
        let err = inverse_map(&skewed_quad(), [3.0, 0.5]).expect_err("right of the quad");
        match err {
            XfemError::OutsideElement { xi, .. } => assert!(xi[0] > 1.0),
            other => panic!("unexpected {other}"),
        }
    }

    #[test]
    fn jacobians_match_finite_differences() {
        // Central differences with step 1e-6 on O(1) maps: error ~ 1e-12 truncation + 1e-10 round-off.
        const FD_TOL: f64 = 1e-8;
        let maps: [&dyn RefMap; 3] = [
            &skewed_quad(),
            &AnnulusSector::new([1.0, 1.5], [0.2, 0.9]),
            &Q2Element {
                nodes: AnnulusSector::new([1.0, 1.5], [0.2, 0.9]).q2_nodes(),
            },
        ];
        let h = 1e-6;
        for m in maps {
            let xi = [0.3, -0.4];
            let j = m.jacobian(xi);
            for d in 0..2 {
                let mut a = xi;
                let mut b = xi;
                a[d] -= h;
                b[d] += h;
                let (pa, pb) = (m.map(a), m.map(b));
                for i in 0..2 {
                    assert!((j[i][d] - (pb[i] - pa[i]) / (2.0 * h)).abs() < FD_TOL);
                }
            }
        }
    }

    #[test]
    fn element_area_is_exact_for_bilinear_and_q2_maps() {
        // Round-off on areas of size O(1).
        const AREA_TOL: f64 = 1e-14;
        // Shoelace area of the skewed quad (corners in counter-clockwise order 0, 1, 3, 2).
        let c = skewed_quad().corners;
        let ring = [c[0], c[1], c[3], c[2]];
        let shoelace: f64 = (0..4)
            .map(|k| {
                let (p, q) = (ring[k], ring[(k + 1) % 4]);
                0.5 * (p[0] * q[1] - q[0] * p[1])
            })
            .sum();
        assert!((element_area(&skewed_quad()) - shoelace).abs() < AREA_TOL);
        // An affine Q2 element x = A ξ: area = |det A| · 4.
        let q2 = Q2Element {
            nodes: crate::fem::element::Q2_NODES.map(|p| [2.0 * p[0] + 0.5 * p[1], 0.25 * p[1]]),
        };
        assert!((element_area(&q2) - 4.0 * 0.5).abs() < AREA_TOL);
    }

    #[test]
    fn image_radius_bounds_the_sampled_image() {
        let maps: [&dyn RefMap; 3] = [
            &RectMap::new([0.0, 0.0], [2.0, 0.5]),
            &skewed_quad(),
            &Q2Element {
                nodes: AnnulusSector::new([1.0, 1.5], [0.2, 0.9]).q2_nodes(),
            },
        ];
        for m in maps {
            let (lo, hi) = ([-0.5, 0.0], [0.25, 1.0]);
            let r = m.image_radius(lo, hi);
            let c = m.map([-0.125, 0.5]);
            for i in 0..=20 {
                for j in 0..=20 {
                    let xi = [
                        lo[0] + (hi[0] - lo[0]) * i as f64 / 20.0,
                        lo[1] + (hi[1] - lo[1]) * j as f64 / 20.0,
                    ];
                    let x = m.map(xi);
                    assert!((x[0] - c[0]).hypot(x[1] - c[1]) <= r * (1.0 + 1e-14));
                }
            }
        }
    }

    /// A Q2 element's whole-box image radius, read from its nodes, is the sampled one (the
    /// shape functions are 0 or 1 at the nodes; one square root instead of nine hypots: to
    /// round-off), and its centre is its centre node.
    #[test]
    fn a_q2_element_reads_its_image_radius_from_its_nodes() {
        let curved = Q2Element {
            nodes: AnnulusSector::new([1.0, 1.5], [0.2, 0.9]).q2_nodes(),
        };
        let (lo, hi) = ([-1.0, -1.0], [1.0, 1.0]);
        let (read, sampled) = (
            curved.image_radius(lo, hi),
            sampled_image_radius(&curved, lo, hi),
        );
        assert!(
            (read - sampled).abs() <= 1e-15 * sampled,
            "{read} / {sampled}"
        );
        assert_eq!(curved.centre(), curved.map([0.0, 0.0]));
    }
}
