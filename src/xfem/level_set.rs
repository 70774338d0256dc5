//! Level sets of the particle boundaries: signed distances, nearest particle, interface normal.
//!
//! The fluid domain is Ω(t) = Ω_m \ ∪_i P_i(t) (thesis §5.3.2); the level set is the signed distance
//! φ(x) = min_i (|x − X_i| − a_i), positive in the fluid and negative inside a particle. With a
//! period L in x the distance is to the nearest periodic image, so a particle crossing x = ±L/2
//! cuts elements on both sides of the seam.

use super::XfemError;

/// A signed-distance level set of the interface.
///
/// Contract relied on by the quadrature: `value` is 1-Lipschitz, |φ(x) − φ(y)| ≤ |x − y| (true for
/// exact signed distances and for minima of them), so a sub-cell whose image lies within a ball
/// of radius r around x is entirely fluid when φ(x) ≥ r and entirely particle when φ(x) ≤ −r.
pub trait LevelSet {
    /// φ(x): positive in the fluid, negative inside a particle, zero on the interface.
    fn value(&self, x: [f64; 2]) -> f64;

    /// The smallest length scale of the interface within `reach` of `x`: a radius of curvature,
    /// or the width of a gap between two interface pieces. A resolution hint: the quadtree keeps
    /// refining a possibly cut sub-square that is not small against it. Infinite by default
    /// (straight interfaces).
    fn feature_size(&self, _x: [f64; 2], _reach: f64) -> f64 {
        f64::INFINITY
    }

    /// Index of the particle whose boundary is nearest to `x`, if the level set has particles.
    fn nearest_particle(&self, _x: [f64; 2]) -> Option<usize> {
        None
    }
}

/// A circular particle of radius `radius` centred at `center`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Circle {
    /// Centre X_i.
    pub center: [f64; 2],
    /// Radius a_i.
    pub radius: f64,
}

impl Circle {
    /// Signed distance |x − X| − a (positive outside the circle).
    pub fn signed_distance(&self, x: [f64; 2]) -> f64 {
        (x[0] - self.center[0]).hypot(x[1] - self.center[1]) - self.radius
    }
}

/// The nearest particle boundary to a point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Nearest {
    /// Index of the particle in the union.
    pub particle: usize,
    /// Signed distance to its boundary (positive in the fluid).
    pub distance: f64,
    /// The particle centre, or the periodic image of it, nearest to the point.
    pub center: [f64; 2],
}

/// A union of circular particles, optionally periodic in x with period `period_x`.
#[derive(Debug, Clone, PartialEq)]
pub struct CircleUnion {
    circles: Vec<Circle>,
    period_x: Option<f64>,
}

impl CircleUnion {
    /// Validates the circles (finite centres, positive finite radii) and the period (finite and
    /// larger than every diameter, so no particle overlaps its own image).
    pub fn new(circles: Vec<Circle>, period_x: Option<f64>) -> Result<Self, XfemError> {
        for (index, c) in circles.iter().enumerate() {
            if !(c.radius.is_finite() && c.radius > 0.0) {
                return Err(XfemError::InvalidRadius {
                    index,
                    radius: c.radius,
                });
            }
            if !(c.center[0].is_finite() && c.center[1].is_finite()) {
                return Err(XfemError::InvalidCenter {
                    index,
                    center: c.center,
                });
            }
        }
        if let Some(period) = period_x {
            let diameter = circles.iter().map(|c| 2.0 * c.radius).fold(0.0, f64::max);
            if !(period.is_finite() && period > diameter) {
                return Err(XfemError::InvalidPeriod { period, diameter });
            }
        }
        Ok(Self { circles, period_x })
    }

    /// The circles, indexed by particle.
    pub fn circles(&self) -> &[Circle] {
        &self.circles
    }

    /// The period in x, if any.
    pub fn period_x(&self) -> Option<f64> {
        self.period_x
    }

    /// Offset x − X reduced to the nearest periodic image (x component in [−L/2, L/2]).
    pub fn offset(&self, x: [f64; 2], center: [f64; 2]) -> [f64; 2] {
        [
            crate::periodic::fold(x[0] - center[0], self.period_x),
            x[1] - center[1],
        ]
    }

    /// The particle boundary nearest to `x` (nearest periodic image); `None` without particles.
    pub fn nearest(&self, x: [f64; 2]) -> Option<Nearest> {
        let mut best: Option<Nearest> = None;
        for (particle, c) in self.circles.iter().enumerate() {
            let d = self.offset(x, c.center);
            let distance = d[0].hypot(d[1]) - c.radius;
            if best.is_none_or(|b| distance < b.distance) {
                best = Some(Nearest {
                    particle,
                    distance,
                    center: [x[0] - d[0], x[1] - d[1]],
                });
            }
        }
        best
    }

    /// The fluid's outward unit normal on the boundary of the particle nearest to `x`: it points
    /// into the particle, n = (X_i − x)/|X_i − x| (exact on ∂P_i, radial elsewhere). `None`
    /// without particles or at a particle centre.
    pub fn outward_normal(&self, x: [f64; 2]) -> Option<[f64; 2]> {
        let near = self.nearest(x)?;
        let d = [near.center[0] - x[0], near.center[1] - x[1]];
        let len = d[0].hypot(d[1]);
        (len > 0.0).then(|| [d[0] / len, d[1] / len])
    }

    /// Centres of the images of particle `i` (the centre itself and, when periodic, its shifts
    /// by ±L) that come within `reach` of the disc boundary around `x`, i.e. whose circle can meet
    /// the ball of radius `reach` around `x`.
    pub(crate) fn images_near(
        &self,
        i: usize,
        x: [f64; 2],
        reach: f64,
    ) -> impl Iterator<Item = [f64; 2]> + '_ {
        let c = self.circles[i];
        let shifts: &[f64] = if self.period_x.is_some() {
            &[-1.0, 0.0, 1.0]
        } else {
            &[0.0]
        };
        let l = self.period_x.unwrap_or(0.0);
        // Start from the image nearest to x so that ±1 shifts cover every image within reach
        // (the period exceeds the element size in any sensible mesh).
        let base = crate::periodic::nearest_image(c.center, x[0], self.period_x)[0];
        shifts.iter().filter_map(move |k| {
            let center = [base + k * l, c.center[1]];
            let d = (x[0] - center[0]).hypot(x[1] - center[1]);
            ((d - c.radius).abs() <= reach).then_some(center)
        })
    }
}

impl LevelSet for CircleUnion {
    fn value(&self, x: [f64; 2]) -> f64 {
        let mut phi = f64::INFINITY;
        for c in &self.circles {
            let d = self.offset(x, c.center);
            phi = phi.min(d[0].hypot(d[1]) - c.radius);
        }
        phi
    }

    /// The smallest radius of the circles whose boundary comes within `reach` of `x`, and the
    /// smallest gap |X_i − X_j| − a_i − a_j between two such circles (overlapping pairs, a
    /// physics error caught elsewhere, are ignored rather than refined forever).
    fn feature_size(&self, x: [f64; 2], reach: f64) -> f64 {
        let near = |c: &Circle| {
            let d = self.offset(x, c.center);
            (d[0].hypot(d[1]) - c.radius).abs() <= reach
        };
        let mut size = f64::INFINITY;
        for (i, ci) in self.circles.iter().enumerate() {
            if !near(ci) {
                continue;
            }
            size = size.min(ci.radius);
            for cj in self.circles[i + 1..].iter().filter(|c| near(c)) {
                let d = self.offset(ci.center, cj.center);
                let gap = d[0].hypot(d[1]) - ci.radius - cj.radius;
                if gap > 0.0 {
                    size = size.min(gap);
                }
            }
        }
        size
    }

    fn nearest_particle(&self, x: [f64; 2]) -> Option<usize> {
        self.nearest(x).map(|n| n.particle)
    }
}

impl LevelSet for Circle {
    fn value(&self, x: [f64; 2]) -> f64 {
        self.signed_distance(x)
    }

    fn feature_size(&self, _x: [f64; 2], _reach: f64) -> f64 {
        self.radius
    }

    fn nearest_particle(&self, _x: [f64; 2]) -> Option<usize> {
        Some(0)
    }
}

/// The half-plane {x : n·x < c} as a "particle": φ(x) = n·x − c with unit n (fluid where φ > 0).
/// A straight interface, so cut-cell quadrature on affine elements is exact (used in tests).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HalfPlane {
    normal: [f64; 2],
    offset: f64,
}

impl HalfPlane {
    /// Fluid where `normal · x > offset`; the normal is scaled to unit length (offset with it).
    pub fn new(normal: [f64; 2], offset: f64) -> Result<Self, XfemError> {
        let len = normal[0].hypot(normal[1]);
        if !(len.is_finite() && len > 0.0 && offset.is_finite()) {
            return Err(XfemError::InvalidNormal { normal });
        }
        Ok(Self {
            normal: [normal[0] / len, normal[1] / len],
            offset: offset / len,
        })
    }
}

impl LevelSet for HalfPlane {
    fn value(&self, x: [f64; 2]) -> f64 {
        self.normal[0] * x[0] + self.normal[1] * x[1] - self.offset
    }

    fn nearest_particle(&self, _x: [f64; 2]) -> Option<usize> {
        Some(0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Round-off on distances of size O(10).
    const TOL: f64 = 1e-13;

    fn two_circles(period: Option<f64>) -> CircleUnion {
        CircleUnion::new(
            vec![
                Circle {
                    center: [14.5, 0.0],
                    radius: 1.0,
                },
                Circle {
                    center: [0.0, 1.0],
                    radius: 0.5,
                },
            ],
            period,
        )
        .expect("valid circles")
    }

    #[test]
    fn signed_distance_is_the_minimum_over_particles() {
        let u = two_circles(None);
        assert!((u.value([0.0, 0.0]) - (-0.5 + 1.0)).abs() < TOL);
        assert!((u.value([0.0, 1.2]) - (0.2 - 0.5)).abs() < TOL);
        assert!((u.value([14.5, 0.0]) + 1.0).abs() < TOL);
        let n = u.nearest([13.0, 0.0]).expect("has particles");
        assert_eq!(n.particle, 0);
        assert!((n.distance - 0.5).abs() < TOL);
    }

    #[test]
    fn periodic_image_counts_across_the_seam() {
        // Particle at x = 14.5, a = 1, period 30: its image at −15.5 reaches to x = −14.5.
        let u = two_circles(Some(30.0));
        assert!((u.value([-14.8, 0.0]) - (0.7 - 1.0)).abs() < TOL);
        let n = u.nearest([-14.8, 0.0]).expect("has particles");
        assert_eq!(n.particle, 0);
        assert!((n.center[0] + 15.5).abs() < TOL);
        // Without the period the point is far in the fluid.
        assert!(two_circles(None).value([-14.8, 0.0]) > 1.0);
    }

    #[test]
    fn outward_normal_points_into_the_particle() {
        let u = two_circles(Some(30.0));
        let n = u.outward_normal([15.5, 0.0]).expect("normal");
        assert!((n[0] + 1.0).abs() < TOL && n[1].abs() < TOL);
        let n = u.outward_normal([-14.5, 0.0]).expect("normal");
        assert!(
            (n[0] + 1.0).abs() < TOL,
            "across the seam the image is to the left"
        );
        let n = u.outward_normal([0.0, 1.5]).expect("normal");
        assert!(n[0].abs() < TOL && (n[1] + 1.0).abs() < TOL);
    }

    #[test]
    fn invalid_input_is_rejected_with_the_offending_value() {
        let bad = |r: f64, x: f64, p: Option<f64>| {
            CircleUnion::new(
                vec![Circle {
                    center: [x, 0.0],
                    radius: r,
                }],
                p,
            )
        };
        assert!(matches!(
            bad(0.0, 0.0, None),
            Err(XfemError::InvalidRadius { index: 0, .. })
        ));
        assert!(matches!(
            bad(1.0, f64::NAN, None),
            Err(XfemError::InvalidCenter { .. })
        ));
        assert!(matches!(
            bad(1.0, 0.0, Some(1.5)),
            Err(XfemError::InvalidPeriod { .. })
        ));
        assert!(HalfPlane::new([0.0, 0.0], 1.0).is_err());
    }

    #[test]
    fn feature_size_sees_radii_and_gaps_within_reach() {
        let u = CircleUnion::new(
            vec![
                Circle {
                    center: [0.0, 0.0],
                    radius: 1.0,
                },
                Circle {
                    center: [2.05, 0.0],
                    radius: 1.0,
                },
            ],
            None,
        )
        .expect("valid");
        // In the gap both boundaries are within reach: the gap 0.05 is the feature.
        assert!((u.feature_size([1.02, 0.0], 0.1) - 0.05).abs() < TOL);
        // Far from the gap only one boundary is near: its radius.
        assert_eq!(u.feature_size([-1.0, 0.0], 0.1), 1.0);
        assert_eq!(u.feature_size([0.0, 5.0], 0.1), f64::INFINITY);
    }

    #[test]
    fn images_near_finds_the_image_across_the_seam() {
        let u = two_circles(Some(30.0));
        let found: Vec<_> = u.images_near(0, [-14.75, 0.0], 0.5).collect();
        assert_eq!(found.len(), 1);
        assert!((found[0][0] + 15.5).abs() < TOL);
        assert_eq!(u.images_near(0, [0.0, 0.0], 0.5).count(), 0);
    }
}
