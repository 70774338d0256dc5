//! Quadrature on the particle boundaries ∂P_i inside an element, along the exact circle arcs.
//!
//! The boundary integrals (·,·)_{∂P_i} of thesis Eqs. (5.17), (5.20) and (5.24) — weak no-slip,
//! force- and torque-free conditions — are taken over ∂P_i ∩ element. The arcs are the parts of
//! each circle (and of its periodic images) between its crossings with the element boundary; the
//! crossings are found on the element's edge curves x(ξ(t)) by root finding of |x − X| − a, with
//! a bound on the edge's deviation from its chords so that a circle clipping an edge between
//! samples is not missed, and whether an arc lies in the element is decided by the inverse map of
//! its midpoint. Neighbouring elements share edge curves and so crossing points, hence the arcs
//! of all elements partition each circle and their lengths sum to 2πa up to round-off. Each arc is
//! split into pieces of at most `max_arc_angle` and integrated by Gauss–Legendre in the angle.
//!
//! Exception: where a circle is tangent to an element edge the crossing is a double root, located
//! only to √ε; neighbours may then disagree about an arc of length ~1e-8 a (measured 1.2e-7 for a
//! unit circle tangent to grid lines at four element corners), against ~1e-15 in general position.

use super::level_set::CircleUnion;
use super::ref_map::{newton_inverse, RefMap};
use super::roots::bracketed_root;
use super::XfemError;
use crate::fem::quadrature::gauss_legendre_1d;
use std::f64::consts::PI;

/// Default Gauss points per arc piece.
pub const DEFAULT_POINTS_PER_ARC: usize = 4;
/// Default longest arc piece: π/8, so that 4 Gauss points integrate the trigonometric content of
/// Q2 fields on an arc to ~1e-10 relative even for a particle inside one element.
pub const DEFAULT_MAX_ARC_ANGLE: f64 = PI / 8.0;
/// Root tolerance in the edge parameter t ∈ [0, 1] (round-off).
const EDGE_ROOT_TOL: f64 = 1e-15;
/// Depth at which a segment with a sign change of |x − X| − a is considered to hold one root
/// (1/16 of the edge; an element edge is not curved enough to meet a circle twice within it).
const MIN_ROOT_DEPTH: u32 = 4;
/// Depth at which the search for a double (near-tangent) crossing gives up: the missed arc is
/// then shorter than about 2⁻⁴⁰ of the edge length.
const MAX_EDGE_DEPTH: u32 = 40;
/// Safety factor on the midpoint deviation of an edge piece from its chord (1 would be exact for
/// quadratic and circular edges; the margin covers other smooth edges).
const CHORD_DEVIATION_SAFETY: f64 = 1.5;
/// Crossing angles closer than this (radians) are one crossing: arcs shorter than 1e-7 a only
/// arise from round-off near tangencies.
const ANGLE_MERGE: f64 = 1e-7;

/// Where a circle without crossings is tested for lying inside the element: four points a
/// quarter turn apart (at least three of them are off any one point where the circle touches
/// the element from outside).
const WHOLE_CIRCLE_PROBES: [f64; 4] = [0.0, 1.0, 2.0, 3.0];

/// Options of the interface quadrature.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InterfaceOptions {
    /// Gauss–Legendre points per arc piece (1..=5).
    pub points_per_arc: usize,
    /// Longest arc piece in radians; longer arcs are split evenly.
    pub max_arc_angle: f64,
}

impl Default for InterfaceOptions {
    fn default() -> Self {
        Self {
            points_per_arc: DEFAULT_POINTS_PER_ARC,
            max_arc_angle: DEFAULT_MAX_ARC_ANGLE,
        }
    }
}

/// One quadrature point on a particle boundary inside an element.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InterfacePoint {
    /// Physical point on ∂P_i.
    pub x: [f64; 2],
    /// Its reference coordinates in the element.
    pub xi: [f64; 2],
    /// Arc-length weight (physical).
    pub weight: f64,
    /// Outward unit normal of the fluid, pointing into the particle.
    pub normal: [f64; 2],
    /// Particle index.
    pub particle: usize,
    /// x − X_i with X_i the centre (image) of the particle: the lever arm of the torque.
    pub arm: [f64; 2],
}

/// Builds interface quadrature rules, reusing its scratch memory across elements.
#[derive(Debug, Clone)]
pub struct InterfaceQuadrature {
    options: InterfaceOptions,
    gauss: (Vec<f64>, Vec<f64>),
    angles: Vec<f64>,
    stack: Vec<Segment>,
}

/// A piece [t0, t1] of an element edge: its end points' images and values of |x − X| − a.
#[derive(Debug, Clone, Copy)]
struct Segment {
    t: [f64; 2],
    x: [[f64; 2]; 2],
    g: [f64; 2],
    depth: u32,
}

/// Whether an edge piece whose ends lie on the same side of the circle certainly does not meet
/// it. The curve stays within `dev` of its chord, with `dev` the midpoint's distance from the
/// chord midpoint times [`CHORD_DEVIATION_SAFETY`] (exact for quadratic and circular edges); the
/// chord misses the circle when its distance to the centre exceeds the radius (ends outside) or
/// when both ends are inside (the disc is convex).
fn no_root(seg: &Segment, xm: [f64; 2], center: [f64; 2], radius: f64) -> bool {
    let [p, q] = seg.x;
    let dev =
        CHORD_DEVIATION_SAFETY * (xm[0] - 0.5 * (p[0] + q[0])).hypot(xm[1] - 0.5 * (p[1] + q[1]));
    if seg.g[0] > 0.0 && seg.g[1] > 0.0 {
        let d = [q[0] - p[0], q[1] - p[1]];
        let len2 = d[0] * d[0] + d[1] * d[1];
        let s = if len2 > 0.0 {
            (((center[0] - p[0]) * d[0] + (center[1] - p[1]) * d[1]) / len2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let near = [p[0] + s * d[0], p[1] + s * d[1]];
        (near[0] - center[0]).hypot(near[1] - center[1]) - radius > dev
    } else if seg.g[0] < 0.0 && seg.g[1] < 0.0 {
        -seg.g[0].max(seg.g[1]) > dev
    } else {
        false
    }
}

impl InterfaceQuadrature {
    /// A builder; errors for points per arc outside 1..=5 or an angle outside (0, 2π].
    pub fn new(options: InterfaceOptions) -> Result<Self, XfemError> {
        if !(1..=5).contains(&options.points_per_arc) {
            return Err(XfemError::InvalidArcPoints {
                points: options.points_per_arc,
            });
        }
        if !(options.max_arc_angle > 0.0 && options.max_arc_angle <= 2.0 * PI) {
            return Err(XfemError::InvalidArcAngle {
                angle: options.max_arc_angle,
            });
        }
        Ok(Self {
            options,
            gauss: gauss_legendre_1d(options.points_per_arc),
            angles: Vec::new(),
            stack: Vec::new(),
        })
    }

    /// Appends to `out` the quadrature points of every particle boundary inside the element.
    ///
    /// Errors only when the inverse map fails at an arc point, which means a broken element map.
    pub fn points_into<M: RefMap + ?Sized>(
        &mut self,
        map: &M,
        particles: &CircleUnion,
        out: &mut Vec<InterfacePoint>,
    ) -> Result<(), XfemError> {
        let xc = map.centre();
        let reach = map.image_radius([-1.0, -1.0], [1.0, 1.0]);
        for (i, circle) in particles.circles().iter().enumerate() {
            for center in particles.images_near(i, xc, reach) {
                self.arcs_of_circle(map, i, center, circle.radius, out)?;
            }
        }
        Ok(())
    }

    /// Arcs of the circle (`center`, `radius`) inside the element, as quadrature points.
    fn arcs_of_circle<M: RefMap + ?Sized>(
        &mut self,
        map: &M,
        particle: usize,
        center: [f64; 2],
        radius: f64,
        out: &mut Vec<InterfacePoint>,
    ) -> Result<(), XfemError> {
        self.angles.clear();
        let g = |x: [f64; 2]| (x[0] - center[0]).hypot(x[1] - center[1]) - radius;
        // The boundary counter-clockwise: each edge from one corner to the next.
        let corners = [[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]];
        for k in 0..4 {
            let (a, b) = (corners[k], corners[(k + 1) % 4]);
            let at = |t: f64| [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])];
            let (ea, eb) = (map.map(a), map.map(b));
            let ga = g(ea);
            if ga == 0.0 {
                self.push_angle(ea, center);
            }
            self.stack.clear();
            self.stack.push(Segment {
                t: [0.0, 1.0],
                x: [ea, eb],
                g: [ga, g(eb)],
                depth: 0,
            });
            while let Some(seg) = self.stack.pop() {
                let [g0, g1] = seg.g;
                let sign_change = (g0 < 0.0 && g1 > 0.0) || (g0 > 0.0 && g1 < 0.0);
                if sign_change && seg.depth >= MIN_ROOT_DEPTH {
                    let [t0, t1] = seg.t;
                    let t = bracketed_root(|t| g(map.map(at(t))), t0, t1, g0, g1, EDGE_ROOT_TOL);
                    self.push_angle(map.map(at(t)), center);
                    continue;
                }
                let tm = 0.5 * (seg.t[0] + seg.t[1]);
                let xm = map.map(at(tm));
                let gm = g(xm);
                if !sign_change
                    && (seg.depth >= MAX_EDGE_DEPTH || no_root(&seg, xm, center, radius))
                {
                    continue;
                }
                if gm == 0.0 {
                    self.push_angle(xm, center);
                }
                self.stack.push(Segment {
                    t: [seg.t[0], tm],
                    x: [seg.x[0], xm],
                    g: [g0, gm],
                    depth: seg.depth + 1,
                });
                self.stack.push(Segment {
                    t: [tm, seg.t[1]],
                    x: [xm, seg.x[1]],
                    g: [gm, g1],
                    depth: seg.depth + 1,
                });
            }
        }
        let point = |theta: f64| {
            [
                center[0] + radius * theta.cos(),
                center[1] + radius * theta.sin(),
            ]
        };
        if self.angles.is_empty() {
            // No crossing: the whole circle is inside the element or entirely outside it (or
            // touches it from outside within round-off, at one point: a single test point could
            // be that point, as when two particles near contact are tangent to one vertex line).
            if WHOLE_CIRCLE_PROBES
                .iter()
                .all(|&k| inside(map, point(k * 0.5 * PI + 0.3)))
            {
                self.emit_arc(map, particle, center, radius, 0.0, 2.0 * PI, out)?;
            }
            return Ok(());
        }
        self.angles.sort_by(f64::total_cmp);
        // Near a tangency the edge function |x − X| − a stays within round-off of zero over a
        // stretch of edge and the bracketing finds many spurious crossings there (seen: 10⁵
        // angles within ±1.5e-8 rad, i.e. 4·10⁵ quadrature points in one element). Merge
        // clusters; each arc between the remaining angles is still kept or dropped by its
        // midpoint, so parity does not matter.
        self.angles.dedup_by(|b, a| (*b - *a).abs() < ANGLE_MERGE);
        let n = self.angles.len();
        for j in 0..n {
            let t0 = self.angles[j];
            let t1 = if j + 1 < n {
                self.angles[j + 1]
            } else {
                self.angles[0] + 2.0 * PI
            };
            if t1 > t0 && inside(map, point(0.5 * (t0 + t1))) {
                self.emit_arc(map, particle, center, radius, t0, t1, out)?;
            }
        }
        Ok(())
    }

    fn push_angle(&mut self, x: [f64; 2], center: [f64; 2]) {
        self.angles.push((x[1] - center[1]).atan2(x[0] - center[0]));
    }

    /// Gauss points on the arc θ ∈ [t0, t1], split into pieces of at most `max_arc_angle`.
    #[allow(clippy::too_many_arguments)]
    fn emit_arc<M: RefMap + ?Sized>(
        &self,
        map: &M,
        particle: usize,
        center: [f64; 2],
        radius: f64,
        t0: f64,
        t1: f64,
        out: &mut Vec<InterfacePoint>,
    ) -> Result<(), XfemError> {
        let pieces = ((t1 - t0) / self.options.max_arc_angle).ceil().max(1.0) as usize;
        let dt = (t1 - t0) / pieces as f64;
        let (gx, gw) = &self.gauss;
        for piece in 0..pieces {
            let mid = t0 + (piece as f64 + 0.5) * dt;
            for (s, w) in gx.iter().zip(gw) {
                let theta = mid + 0.5 * dt * s;
                let arm = [radius * theta.cos(), radius * theta.sin()];
                let x = [center[0] + arm[0], center[1] + arm[1]];
                let (xi, _) = newton_inverse(map, x)?;
                out.push(InterfacePoint {
                    x,
                    xi,
                    weight: 0.5 * dt * w * radius,
                    normal: [-arm[0] / radius, -arm[1] / radius],
                    particle,
                    arm,
                });
            }
        }
        Ok(())
    }
}

/// Whether the physical point lies in the element (inverse map inside [-1, 1]²; a failed
/// inverse map means far outside).
fn inside<M: RefMap + ?Sized>(map: &M, x: [f64; 2]) -> bool {
    super::ref_map::inverse_map(map, x).is_ok()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::xfem::level_set::Circle;
    use crate::xfem::ref_map::RectMap;

    /// Arc lengths are sums of exact angle differences: round-off only.
    const TOL: f64 = 1e-14;

    fn points(center: [f64; 2], radius: f64) -> Vec<InterfacePoint> {
        let union = CircleUnion::new(vec![Circle { center, radius }], None).expect("valid");
        let mut iq = InterfaceQuadrature::new(InterfaceOptions::default()).expect("valid");
        let mut out = Vec::new();
        let m = RectMap::new([0.0, 0.0], [1.0, 1.0]);
        iq.points_into(&m, &union, &mut out)
            .expect("rectangle inverts");
        for p in &out {
            let x = m.map(p.xi);
            assert!((x[0] - p.x[0]).abs() < TOL && (x[1] - p.x[1]).abs() < TOL);
            // The fluid's outward normal points into the particle: opposite to the lever arm.
            let dot = p.normal[0] * p.arm[0] + p.normal[1] * p.arm[1];
            assert!((dot + radius).abs() < TOL && p.particle == 0);
        }
        out
    }

    fn length(pts: &[InterfacePoint]) -> f64 {
        pts.iter().map(|p| p.weight).sum()
    }

    #[test]
    fn circle_inside_one_element_is_integrated_whole() {
        let pts = points([0.37, 0.61], 0.1);
        assert!((length(&pts) - 2.0 * PI * 0.1).abs() < TOL);
        // 2π split into pieces of at most π/8, 4 Gauss points each.
        assert_eq!(pts.len(), 16 * DEFAULT_POINTS_PER_ARC);
    }

    #[test]
    fn clipped_arc_between_nodes_has_its_exact_length() {
        // Radius 1 dipping 0.01 into the element: arc of angle 2 acos(0.99).
        let pts = points([0.3, -0.99], 1.0);
        assert!((length(&pts) - 2.0 * 0.99f64.acos()).abs() < TOL);
        // Tangent from outside between finest sample points: nothing (or a round-off sliver of
        // the order of the square root of the rounding error).
        let pts = points([0.3, -0.7], 0.7);
        assert!(length(&pts) < 1e-7, "{}", length(&pts));
    }

    #[test]
    fn circle_touching_a_corner_from_outside_gives_nothing() {
        // Seen with two cylinders 0.1a apart on h = 0.1a: each touches a vertex line at the
        // corner of the element between them, a round-off outside it; the whole circle used to
        // be emitted because its test point was the touching point.
        let pts = points([-1.0 - 1e-15, 0.0], 1.0);
        assert!(length(&pts) < 1e-7, "{}", length(&pts));
        let pts = points([2.0 + 1e-15, 1.0], 1.0);
        assert!(length(&pts) < 1e-7, "{}", length(&pts));
    }

    #[test]
    fn tangent_circle_gives_few_points_not_a_cloud() {
        // Circle of radius 1 centred at x = 0.0123 touches the edge x = 1.0123 of the element
        // [1.0123, 1.2123] × [−0.0952, 0.0952] (the confined-cylinder mesh where this was
        // seen): round-off made 10⁵ spurious crossings before the angle merge.
        let x0 = 0.0123;
        let u = CircleUnion::new(
            vec![Circle {
                center: [x0, 0.0],
                radius: 1.0,
            }],
            Some(30.0),
        )
        .unwrap();
        let mut iq = InterfaceQuadrature::new(InterfaceOptions::default()).unwrap();
        for (lo, hi) in [
            ([x0 + 1.0, -0.0952], [x0 + 1.2, 0.0952]),
            ([x0 + 0.8, -0.0952], [x0 + 1.0, 0.0952]),
        ] {
            let mut pts = Vec::new();
            iq.points_into(&RectMap::new(lo, hi), &u, &mut pts).unwrap();
            // a full cut element carries ≤ 16 arc pieces × 4 points; the tangent one ~nothing
            assert!(pts.len() <= 64, "{} points", pts.len());
        }
    }

    #[test]
    fn invalid_options_are_rejected() {
        let bad = |points_per_arc, max_arc_angle| {
            InterfaceQuadrature::new(InterfaceOptions {
                points_per_arc,
                max_arc_angle,
            })
        };
        assert!(matches!(
            bad(0, 0.1),
            Err(XfemError::InvalidArcPoints { points: 0 })
        ));
        assert!(matches!(
            bad(6, 0.1),
            Err(XfemError::InvalidArcPoints { .. })
        ));
        assert!(matches!(
            bad(4, 0.0),
            Err(XfemError::InvalidArcAngle { .. })
        ));
        assert!(matches!(
            bad(4, f64::NAN),
            Err(XfemError::InvalidArcAngle { .. })
        ));
    }
}
