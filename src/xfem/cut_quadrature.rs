//! Quadrature on the fluid part of a cut element: quadtree subdivision of the reference square
//! and interface-aligned triangles (thesis §2.3.2 "Numerical integration on a part of an
//! element", Fig. 2.8, and §5.3.2).
//!
//! The reference square is subdivided recursively. A sub-square with centre ξ_c and image radius
//! r (a bound of |x(ξ) − x(ξ_c)| over it, [`RefMap::image_radius`]) is entirely fluid when
//! φ(x(ξ_c)) ≥ r and entirely particle when φ(x(ξ_c)) ≤ −r, because φ is 1-Lipschitz: this uses
//! the exact distance to the circles, not nodal signs, so a circle that clips an edge between
//! sample points or a particle smaller than the element is still seen. Fluid sub-squares get a
//! 3×3 Gauss rule, particle ones are dropped, the others are split until the configured level;
//! there the fluid side of the interface is triangulated (module `subcell`). A sub-square that
//! may be cut and is not small against the interface's features near it (a particle radius, or
//! the gap between two particles) keeps splitting past that level, up to [`HARD_MAX_LEVEL`].
//!
//! Points are in element reference coordinates and weights in reference measure (the assembler
//! multiplies by det J(ξ)). Which triangle rule is used (Table 5.1) is decided by the caller,
//! [`CutQuadrature::classify`](super::classify), once the fluid area is known.

use super::level_set::LevelSet;
use super::ref_map::{det2, RefMap};
use super::subcell::{split_square, CurvedTri, Split};
use super::XfemError;
use crate::fem::quadrature::gauss_quad;
use crate::fem::quadrature::triangle::TriangleRule;

/// Quadtree levels used by default. The thesis used five (§5.3.2) with straight chords; with
/// parabolic chords three give the same drag K (to 7 digits) and §2.4 errors (to 4 digits) as
/// five, at the cost of straight chords at three, which are 4e-5 off in K
/// (docs/validation.md, "The cut rule").
pub const DEFAULT_LEVEL: u32 = 3;
/// Largest level a user may request (sub-squares of 2⁻¹⁶ of the element are far below any
/// resolution the flow solver can use).
pub const MAX_LEVEL: u32 = 16;
/// Absolute depth cap of the extra refinement for small particles and folded curved triangles
/// (2⁻²⁴ of the element: still 8 digits above round-off of the reference coordinates).
pub const HARD_MAX_LEVEL: u32 = 24;
/// A possibly cut sub-square keeps splitting past the configured level while the smallest
/// feature of the interface near it (a particle radius, or the gap between two particles) is
/// below this many image radii of the sub-square: small particles and narrow gaps are resolved by
/// several sub-squares across.
const SMALL_FEATURE_FACTOR: f64 = 8.0;
/// How many levels past the configured one a square with a folding curved triangle may split.
const FOLD_EXTRA_LEVELS: u32 = 3;

/// How the interface is represented inside the finest cut sub-squares.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum InterfaceApprox {
    /// Straight chords between the interface points on the sub-square edges (the thesis' choice;
    /// area error O(h_L²) with h_L the finest sub-square size).
    Linear,
    /// Parabolic chords through the interface point at the chord midpoint (6-node triangles with
    /// one curved edge; area error O(h_L³) or better).
    Quadratic,
}

/// Options of the cut-cell quadrature.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CutOptions {
    /// Quadtree levels (thesis: 5 in Ch. 5, 8 in Ch. 2).
    pub level: u32,
    /// Interface representation in the finest sub-squares.
    pub interface: InterfaceApprox,
}

impl Default for CutOptions {
    /// [`DEFAULT_LEVEL`] with parabolic chords: at the same cost as straight chords the
    /// unit-disc area of Table 2.2 comes out to ~3e-11 instead of ~3e-5 on a 120×16 channel mesh
    /// (at level 5). Use [`InterfaceApprox::Linear`] at level 5 to reproduce the thesis'
    /// integration. The cases' default (`numerics.quadtree_level`, `numerics.interface`) is
    /// this one.
    fn default() -> Self {
        Self {
            level: DEFAULT_LEVEL,
            interface: InterfaceApprox::Quadratic,
        }
    }
}

/// A sub-square of the reference square: centre and half width.
#[derive(Debug, Clone, Copy)]
struct SubSquare {
    center: [f64; 2],
    half: f64,
    level: u32,
}

/// What the quadtree found in an element.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Traversal {
    /// Some part of the element lies in a particle.
    pub particle_seen: bool,
    /// Some part of the element lies in the fluid.
    pub fluid_seen: bool,
}

/// Builds cut-cell quadrature rules, reusing its scratch memory across elements.
///
/// One instance per thread; call [`CutQuadrature::classify`](super::classify) per element.
#[derive(Debug, Clone)]
pub struct CutQuadrature {
    options: CutOptions,
    /// 3×3 Gauss rule on [-1, 1]²: `[ξ, η, w]`.
    gauss3: [[f64; 3]; 9],
    stack: Vec<SubSquare>,
    pub(crate) tris: Vec<CurvedTri>,
    pub(crate) points: Vec<[f64; 2]>,
    pub(crate) weights: Vec<f64>,
    pub(crate) particles: Vec<usize>,
    /// Number of leading entries of `points`/`weights` that come from fluid sub-squares.
    pub(crate) n_quad_points: usize,
}

impl CutQuadrature {
    /// A builder with the given options; errors for a level above [`MAX_LEVEL`].
    pub fn new(options: CutOptions) -> Result<Self, XfemError> {
        if options.level > MAX_LEVEL {
            return Err(XfemError::InvalidLevel {
                level: options.level,
                max: MAX_LEVEL,
            });
        }
        let g = gauss_quad(3);
        let mut gauss3 = [[0.0; 3]; 9];
        for (k, row) in gauss3.iter_mut().enumerate() {
            *row = [g.points[k][0], g.points[k][1], g.weights[k]];
        }
        Ok(Self {
            options,
            gauss3,
            stack: Vec::new(),
            tris: Vec::new(),
            points: Vec::new(),
            weights: Vec::new(),
            particles: Vec::new(),
            n_quad_points: 0,
        })
    }

    /// The options this builder was made with.
    pub fn options(&self) -> &CutOptions {
        &self.options
    }

    /// Runs the quadtree over the element: fills `points`/`weights` with the 3×3 Gauss rules of
    /// the fluid sub-squares, `tris` with the fluid-side triangles of the finest cut sub-squares
    /// and `particles` with the particles whose boundary crosses the element.
    pub(crate) fn traverse<M: RefMap + ?Sized, L: LevelSet + ?Sized>(
        &mut self,
        map: &M,
        ls: &L,
    ) -> Traversal {
        self.stack.clear();
        self.tris.clear();
        self.points.clear();
        self.weights.clear();
        self.particles.clear();
        let mut seen = Traversal {
            particle_seen: false,
            fluid_seen: false,
        };
        self.stack.push(SubSquare {
            center: [0.0, 0.0],
            half: 1.0,
            level: 0,
        });
        let level = self.options.level;
        let fold_cap = (level + FOLD_EXTRA_LEVELS).min(HARD_MAX_LEVEL);
        while let Some(sq) = self.stack.pop() {
            let (c, h) = (sq.center, sq.half);
            let lo = [c[0] - h, c[1] - h];
            let hi = [c[0] + h, c[1] + h];
            let xc = map.map(c);
            let phi = ls.value(xc);
            let r = map.image_radius(lo, hi);
            if phi >= r {
                self.push_square(c, h);
                seen.fluid_seen = true;
                continue;
            }
            if phi <= -r {
                seen.particle_seen = true;
                continue;
            }
            let small_feature = ls.feature_size(xc, r) < SMALL_FEATURE_FACTOR * r;
            if sq.level < level || (small_feature && sq.level < HARD_MAX_LEVEL) {
                self.push_children(sq);
                continue;
            }
            let may_refine = sq.level < fold_cap;
            match split_square(
                map,
                ls,
                self.options.interface,
                may_refine,
                lo,
                2.0 * h,
                phi,
                &mut self.tris,
                &mut self.particles,
            ) {
                Split::Fluid => {
                    self.push_square(c, h);
                    seen.fluid_seen = true;
                }
                Split::Particle => seen.particle_seen = true,
                Split::Cut => {
                    seen.particle_seen = true;
                    seen.fluid_seen = true;
                }
                Split::Refine => self.push_children(sq),
            }
        }
        self.n_quad_points = self.points.len();
        self.particles.sort_unstable();
        seen
    }

    fn push_children(&mut self, sq: SubSquare) {
        let h = 0.5 * sq.half;
        for (dx, dy) in [(-h, -h), (h, -h), (-h, h), (h, h)] {
            self.stack.push(SubSquare {
                center: [sq.center[0] + dx, sq.center[1] + dy],
                half: h,
                level: sq.level + 1,
            });
        }
    }

    /// Appends the 3×3 Gauss rule of the sub-square with centre `c` and half width `h`.
    fn push_square(&mut self, c: [f64; 2], h: f64) {
        for g in &self.gauss3 {
            self.points.push([c[0] + h * g[0], c[1] + h * g[1]]);
            self.weights.push(g[2] * h * h);
        }
    }

    /// Replaces the triangle points (everything after the fluid sub-squares' points) by `rule`
    /// on each stored triangle.
    pub(crate) fn emit_triangles(&mut self, rule: TriangleRule) {
        self.points.truncate(self.n_quad_points);
        self.weights.truncate(self.n_quad_points);
        for tri in &self.tris {
            for q in rule.table() {
                self.points.push(tri.point(q[0], q[1]));
                self.weights.push(q[2] * tri.det(q[0], q[1]));
            }
        }
    }

    /// Physical area Σ w det J(ξ) of the current points.
    pub(crate) fn physical_area<M: RefMap + ?Sized>(&self, map: &M) -> f64 {
        self.points
            .iter()
            .zip(&self.weights)
            .map(|(p, w)| w * det2(&map.jacobian(*p)))
            .sum()
    }
}
