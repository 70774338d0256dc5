//! The finest quadtree sub-squares that the interface cuts: splitting them into fluid-side
//! triangles aligned with the interface (thesis §2.3.2, Fig. 2.8).
//!
//! The corners of the sub-square are classified by the sign of φ (φ ≥ 0 counts as fluid, so an
//! interface through a corner adds no area on either side); on each edge whose end points differ
//! the interface point is found by root finding of φ(x(ξ)) along the edge. The fluid part of the
//! square is then the polygon of fluid corners and interface points (convex: the square clipped by
//! the chord(s)), fan-triangulated from the fluid corner of largest φ so every chord is the edge
//! v1–v2 of exactly one triangle. Four interface points (a saddle: two particles, or one particle
//! clipping two opposite corners) are resolved by the sign of φ at the centre: fluid centre → one
//! hexagon, particle centre → two corner triangles.
//!
//! With [`InterfaceApprox::Quadratic`] the chord of each triangle is replaced by a parabola through
//! the interface point found normal to the chord's midpoint (a 6-node triangle with one curved
//! edge). When that would fold the triangle the square asks to be split into four instead
//! ([`Split::Refine`], a few levels at most), and at the depth cap keeps the straight chord.

use super::cut_quadrature::InterfaceApprox;
use super::level_set::LevelSet;
use super::ref_map::RefMap;
use super::roots::bracketed_root;

/// Root tolerance in the edge parameter t ∈ [0, 1] (round-off).
const EDGE_ROOT_TOL: f64 = 1e-15;
/// Largest midpoint displacement of a curved chord, relative to its length (a circle resolved by
/// the finest level has a sagitta far below this).
const MAX_BULGE: f64 = 0.25;
/// A curved triangle is accepted only if det J stays above this fraction of the straight one at
/// its vertices (det J is affine in the triangle, so this bounds it everywhere).
const MIN_DET_FRACTION: f64 = 0.25;

/// A triangle in element reference coordinates whose edge v1–v2 may be curved: the edge midpoint
/// is displaced by `bulge` (a 6-node triangle with straight edges v0–v1 and v0–v2).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct CurvedTri {
    /// Vertices, counter-clockwise in the reference square.
    pub v: [[f64; 2]; 3],
    /// Displacement of the midpoint of v1–v2 from the straight chord.
    pub bulge: [f64; 2],
}

impl CurvedTri {
    /// The point at reference-triangle coordinates (s, t): v0 + s e1 + t e2 + 4 s t δ.
    #[inline]
    pub fn point(&self, s: f64, t: f64) -> [f64; 2] {
        let [a, b, c] = self.v;
        let k = 4.0 * s * t;
        [
            a[0] + s * (b[0] - a[0]) + t * (c[0] - a[0]) + k * self.bulge[0],
            a[1] + s * (b[1] - a[1]) + t * (c[1] - a[1]) + k * self.bulge[1],
        ]
    }

    /// det of the triangle map at (s, t) — affine in (s, t), positive for a valid triangle.
    #[inline]
    pub fn det(&self, s: f64, t: f64) -> f64 {
        let [a, b, c] = self.v;
        let e1 = [
            b[0] - a[0] + 4.0 * t * self.bulge[0],
            b[1] - a[1] + 4.0 * t * self.bulge[1],
        ];
        let e2 = [
            c[0] - a[0] + 4.0 * s * self.bulge[0],
            c[1] - a[1] + 4.0 * s * self.bulge[1],
        ];
        cross(e1, e2)
    }
}

#[inline]
fn cross(a: [f64; 2], b: [f64; 2]) -> f64 {
    a[0] * b[1] - a[1] * b[0]
}

#[inline]
fn lerp(a: [f64; 2], b: [f64; 2], t: f64) -> [f64; 2] {
    [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]
}

/// What a finest sub-square turned out to contain.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Split {
    /// No corner in a particle: integrate the whole square.
    Fluid,
    /// No corner in the fluid: drop the square.
    Particle,
    /// Triangles were appended.
    Cut,
    /// A curved triangle would fold: nothing was appended, split the square into four instead.
    Refine,
}

/// A vertex of the fluid polygon: a point and whether it lies on the interface.
#[derive(Debug, Clone, Copy, Default)]
struct Vertex {
    p: [f64; 2],
    on_interface: bool,
}

/// Splits the finest sub-square [lo, lo + side]² (reference coordinates) whose centre has level
/// set value `phi_center`, appending its fluid-side triangles to `tris` and the particles whose
/// boundary crosses it to `particles` (deduplicated). With `may_refine`, a curved chord that
/// would fold its triangle makes the square ask for refinement ([`Split::Refine`]) instead of
/// falling back to the straight chord.
#[allow(clippy::too_many_arguments)]
pub(crate) fn split_square<M: RefMap + ?Sized, L: LevelSet + ?Sized>(
    map: &M,
    ls: &L,
    approx: InterfaceApprox,
    may_refine: bool,
    lo: [f64; 2],
    side: f64,
    phi_center: f64,
    tris: &mut Vec<CurvedTri>,
    particles: &mut Vec<usize>,
) -> Split {
    let corners = [
        lo,
        [lo[0] + side, lo[1]],
        [lo[0] + side, lo[1] + side],
        [lo[0], lo[1] + side],
    ];
    let phi = corners.map(|c| ls.value(map.map(c)));
    let fluid = phi.map(|p| p >= 0.0);
    let n_fluid = fluid.iter().filter(|f| **f).count();
    if n_fluid == 4 {
        return Split::Fluid;
    }
    if n_fluid == 0 {
        return Split::Particle;
    }
    // Walk the boundary counter-clockwise from the corner deepest in the fluid: it becomes the fan
    // apex, so it is never a chord end (an interface through a corner makes that corner a zero-
    // length chord end) and it is as far from the chords as the square allows.
    let start = (0..4).fold(0, |best, k| if phi[k] > phi[best] { k } else { best });
    let mut poly = [Vertex::default(); 8];
    let mut n = 0;
    let mut crossings = 0;
    for step in 0..4 {
        let k = (start + step) % 4;
        let k1 = (k + 1) % 4;
        if fluid[k] {
            poly[n] = Vertex {
                p: corners[k],
                on_interface: false,
            };
            n += 1;
        }
        if fluid[k] != fluid[k1] {
            let (a, b) = (corners[k], corners[k1]);
            let f = |t: f64| ls.value(map.map(lerp(a, b, t)));
            let t = bracketed_root(f, 0.0, 1.0, phi[k], phi[k1], EDGE_ROOT_TOL);
            let p = lerp(a, b, t);
            if crossings == 0 {
                if let Some(i) = ls.nearest_particle(map.map(p)) {
                    if !particles.contains(&i) {
                        particles.push(i);
                    }
                }
            }
            crossings += 1;
            poly[n] = Vertex {
                p,
                on_interface: true,
            };
            n += 1;
        }
    }
    let first = tris.len();
    let mut folded = false;
    let mut push = |v0: [f64; 2], v1: Vertex, v2: Vertex| {
        let straight = CurvedTri {
            v: [v0, v1.p, v2.p],
            bulge: [0.0, 0.0],
        };
        // Zero-area pieces (interface through a corner) carry no weight: skip them.
        if straight.det(0.0, 0.0) <= 0.0 {
            return;
        }
        let chord = v1.on_interface && v2.on_interface;
        if chord && approx == InterfaceApprox::Quadratic {
            match curve_chord(map, ls, straight) {
                Some(curved) => tris.push(curved),
                None if may_refine => folded = true,
                None => tris.push(straight),
            }
        } else {
            tris.push(straight);
        }
    };
    if crossings == 4 && phi_center < 0.0 {
        // Saddle with a particle centre: two separate fluid corners, each cut off by its chord.
        for i in 0..n {
            if !poly[i].on_interface {
                let next = poly[(i + 1) % n];
                let prev = poly[(i + n - 1) % n];
                push(poly[i].p, next, prev);
            }
        }
    } else {
        // Convex polygon starting at a fluid corner: fan from it.
        for j in 1..n - 1 {
            push(poly[0].p, poly[j], poly[j + 1]);
        }
    }
    if folded {
        tris.truncate(first);
        return Split::Refine;
    }
    Split::Cut
}

/// Replaces the chord v1–v2 of `tri` by a parabola through the interface point on the normal to
/// the chord at its midpoint. Keeps the straight chord when the interface is not found within
/// [`MAX_BULGE`] of the chord (a resolution limit, not a fold); `None` when the curved triangle
/// would fold (det J below [`MIN_DET_FRACTION`] of the straight one at a vertex).
fn curve_chord<M: RefMap + ?Sized, L: LevelSet + ?Sized>(
    map: &M,
    ls: &L,
    tri: CurvedTri,
) -> Option<CurvedTri> {
    let [a, b, c] = tri.v;
    let m = lerp(b, c, 0.5);
    let d = [c[0] - b[0], c[1] - b[1]];
    let len = d[0].hypot(d[1]);
    // Left normal of b → c: into the (counter-clockwise) triangle, i.e. towards the fluid.
    let normal = [-d[1] / len, d[0] / len];
    let phi_m = ls.value(map.map(m));
    if phi_m == 0.0 {
        return Some(tri);
    }
    // A negative midpoint lies in the particle, so the interface is on the fluid side of it.
    let dir = if phi_m < 0.0 { 1.0 } else { -1.0 };
    let reach = MAX_BULGE * len;
    let at = |s: f64| [m[0] + dir * s * normal[0], m[1] + dir * s * normal[1]];
    let g = |s: f64| ls.value(map.map(at(s)));
    let g_reach = g(reach);
    if (g_reach > 0.0) == (phi_m > 0.0) && g_reach != 0.0 {
        return Some(tri);
    }
    let s = bracketed_root(g, 0.0, reach, phi_m, g_reach, EDGE_ROOT_TOL * len);
    let p = at(s);
    let curved = CurvedTri {
        v: tri.v,
        bulge: [p[0] - m[0], p[1] - m[1]],
    };
    let min_det = MIN_DET_FRACTION * cross([b[0] - a[0], b[1] - a[1]], [c[0] - a[0], c[1] - a[1]]);
    (curved.det(1.0, 0.0) >= min_det && curved.det(0.0, 1.0) >= min_det).then_some(curved)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::xfem::level_set::{Circle, HalfPlane};
    use crate::xfem::ref_map::RectMap;

    /// Round-off on reference areas of size O(1).
    const TOL: f64 = 1e-14;

    fn area(tris: &[CurvedTri]) -> f64 {
        // det is affine, so its mean over the triangle is its centroid value; area = det/2.
        tris.iter().map(|t| 0.5 * t.det(1.0 / 3.0, 1.0 / 3.0)).sum()
    }

    fn split(ls: &dyn LevelSet, approx: InterfaceApprox) -> (Split, Vec<CurvedTri>) {
        let map = RectMap::new([-1.0, -1.0], [1.0, 1.0]);
        let mut tris = Vec::new();
        let mut particles = Vec::new();
        let phi_c = ls.value([0.0, 0.0]);
        let s = split_square(
            &map,
            ls,
            approx,
            true,
            [-1.0, -1.0],
            2.0,
            phi_c,
            &mut tris,
            &mut particles,
        );
        (s, tris)
    }

    #[test]
    fn half_plane_through_corners_is_split_exactly() {
        // Fluid above the diagonal y = x: the interface passes through two corners.
        let hp = HalfPlane::new([-1.0, 1.0], 0.0).expect("valid");
        let (s, tris) = split(&hp, InterfaceApprox::Linear);
        assert_eq!(s, Split::Cut);
        assert!((area(&tris) - 2.0).abs() < TOL, "{}", area(&tris));
        // Fluid strictly above an edge: φ = 0 on the bottom corners counts as fluid.
        let hp = HalfPlane::new([0.0, 1.0], -1.0).expect("valid");
        assert_eq!(split(&hp, InterfaceApprox::Linear).0, Split::Fluid);
        // A line through one corner only, cutting a zero-area corner piece.
        let hp = HalfPlane::new([1.0, 1.0], 2.0).expect("valid");
        let (s, tris) = split(&hp, InterfaceApprox::Linear);
        assert_eq!(s, Split::Cut);
        assert!(tris.is_empty() && area(&tris) == 0.0);
    }

    #[test]
    fn saddle_is_resolved_by_the_centre_value() {
        // Two particles over opposite corners (−1,−1) and (1,1): fluid hexagon at the centre.
        let two = crate::xfem::level_set::CircleUnion::new(
            vec![
                Circle {
                    center: [-1.0, -1.0],
                    radius: 1.0,
                },
                Circle {
                    center: [1.0, 1.0],
                    radius: 1.0,
                },
            ],
            None,
        )
        .expect("valid");
        let (s, tris) = split(&two, InterfaceApprox::Linear);
        assert_eq!(s, Split::Cut);
        // Square minus two right triangles with legs 1: 4 − 2·(1/2) = 3.
        assert!((area(&tris) - 3.0).abs() < TOL);
        // A quarter arc is far too curved for one parabola from a corner apex: the square
        // asks to be refined rather than fold a triangle.
        let map = RectMap::new([-1.0, -1.0], [1.0, 1.0]);
        let s = split_square(
            &map,
            &two,
            InterfaceApprox::Quadratic,
            true,
            [-1.0, -1.0],
            2.0,
            two.value([0.0, 0.0]),
            &mut Vec::new(),
            &mut Vec::new(),
        );
        assert_eq!(s, Split::Refine);
        // Particles over the corners (1,−1) and (−1,1) that also cover the centre: two separate
        // fluid corners, each a right triangle with legs 0.5 (the discs have radius 1.5).
        let corners = crate::xfem::level_set::CircleUnion::new(
            vec![
                Circle {
                    center: [1.0, -1.0],
                    radius: 1.5,
                },
                Circle {
                    center: [-1.0, 1.0],
                    radius: 1.5,
                },
            ],
            None,
        )
        .expect("valid");
        let (s, tris) = split(&corners, InterfaceApprox::Linear);
        assert_eq!(s, Split::Cut);
        assert_eq!(tris.len(), 2);
        assert!((area(&tris) - 0.25).abs() < TOL, "{}", area(&tris));
    }

    #[test]
    fn quadratic_chord_is_the_parabola_through_the_arc_midpoint() {
        // A shallow arc of the circle |x − (−3,−3)| = 3.5 cuts the corner (−1,−1) off at
        // distance leg = 1 + c + √(R² − (1 + c)²) from it along both edges. The parabola through the
        // arc's ends and midpoint bounds a parabolic segment of area (2/3)·chord·sagitta beyond the
        // chord, with sagitta = R − |centre − chord midpoint| (the normal through the chord
        // midpoint passes through the centre).
        let (r, c) = (3.5, -3.0);
        let circle = Circle {
            center: [c, c],
            radius: r,
        };
        let leg = 1.0 + c + (r * r - (1.0 + c) * (1.0 + c)).sqrt();
        let chord = leg * 2f64.sqrt();
        let d_mid = ((-1.0 + 0.5 * leg) - c) * 2f64.sqrt();
        let exact = 4.0 - 0.5 * leg * leg - 2.0 / 3.0 * chord * (r - d_mid);
        let (s, tris) = split(&circle, InterfaceApprox::Quadratic);
        assert_eq!(s, Split::Cut);
        assert!(tris.iter().any(|t| t.bulge != [0.0, 0.0]));
        assert!(
            (area(&tris) - exact).abs() < TOL,
            "{} vs {exact}",
            area(&tris)
        );
        // The straight chord misses exactly the parabolic segment.
        let (_, tris) = split(&circle, InterfaceApprox::Linear);
        assert!((area(&tris) - (4.0 - 0.5 * leg * leg)).abs() < TOL);
    }
}
