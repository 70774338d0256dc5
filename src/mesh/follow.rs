//! A mesh axis refined around moving particles: the column (or row) coordinates of a tensor-product
//! mesh that follows the particles, same element count and numbering as the base axis
//! (docs/moving-mesh-plan.md, "a moving tensor-product grading").
//!
//! # Method: equidistribution of a Lipschitz size function
//! Let `s(x)` be the base axis' continuous element index (piecewise linear through the base
//! vertices, `ds = dx / h(x)`, `h` the base element size) and `g(x) = 1/ρ(x)` the new element size
//! relative to the base one. Each centre `c` has a *core* `|x − c| ≤ core` and a *zone*
//! `|x − c| < reach`; the zones are merged into connected components `[z₀, z₁]` (clipped to the
//! ends of a bounded axis, wrapped on a periodic one). On a component
//!
//! ```text
//! g(x) = min( 1/ratio + σ·d(x),  1 + σ·D(x),  coarsest )
//! d(x) = max(0, min_c |x − c| − core)     distance to the nearest core
//! D(x) = reach − min_c |x − c|            depth inside the deepest zone (0 on the zone's edge)
//! ```
//!
//! and `g = 1` outside every zone. So `g = 1/ratio` exactly in the cores, rises with slope σ away
//! from them, and falls back with slope σ to exactly 1 at the component's ends: `g` is continuous
//! (C⁰, piecewise linear in x) and σ-Lipschitz. Element sizes then grow geometrically away from
//! a core, and neighbouring elements differ by a factor ≤ exp(σh) (h the base size there; times
//! the base's own neighbour ratio on a graded base). σ is fixed by conserving the component's
//! element count, `∫_{z₀}^{z₁} dx / (h g) = s(z₁) − s(z₀)`: the refinement of the cores is paid
//! for by coarsening in the tapers, never by the cores. For a given σ, `g` is the largest
//! σ-Lipschitz size with these core and edge values, so the σ that balances the count is the
//! smallest possible: the smoothest grading that conserves the count (up to the `coarsest` cap,
//! which flattens the peak and raises σ).
//!
//! The new vertex `i` of a component is where the cumulative count `s(z₀) + ∫_{z₀}^{x} dx/(h g)`
//! equals `i`. `g` is linear and `h` constant between breakpoints, so the integral (`ln`) and its
//! inverse (`exp`) are in closed form; σ is found by bisection to round-off, and the count is then
//! rescaled by 1 ± 1e-15 so that it is conserved exactly. Vertices outside every zone are copied
//! from the base axis, bit for bit (the flow solver caches their element matrices).
//!
//! # Merging zones: continuity
//! Two neighbouring centres of a component (sorted) are *linked* with a weight rising smoothly
//! from 0, when their zones just touch, to 1, when they overlap by `reach − core` (centres
//! `reach + core` apart). If every link of a component has weight 1, it has one σ as above. If not,
//! it is cut at the midpoints of the partially linked pairs; each cell gets its own σ, and the
//! count carried across a cut (beyond the base's) is the weight times that of the one-σ solution.
//! So zones that just touch balance separately, as separate components do, and fully linked ones
//! are the one-σ solution: the vertices move Lipschitz-continuously with the centres through
//! merges and splits, also between a cluster (large σ) and a lone particle (small σ). While a link
//! is partial, g may jump at its cut (measured: neighbour ratios 1.25 there against 1.15 apart and
//! 1.20 joined). Moving a centre by δ moves the vertices by up to ≈ (coarsest g − 1)·δ (a
//! translation moves them by (1 − g)·δ: the coarse taper moves backwards), 1.6–2.7δ for ratio 2.
//!
//! # Parameters
//! For particles of radius `a`: `core ≈ 1.5a`, `ratio = 2`, `reach = 6–8a` (the count balance
//! needs `ratio·core < reach` at least, and smoothness much more). An isolated particle on a
//! uniform base ([`Follow::isolated`], independent of h; q = exp(σh) for h = a/5, `COARSEST` = 4):
//!
//! ```text
//! ratio  reach   σ·a    coarsest  q        ratio  reach   σ·a    coarsest  q
//! 1.5    5a      0.62   1.92      1.13     2      8a      0.46   2.26      1.10
//! 1.5    6a      0.40   1.74      1.08     2      10a     0.30   2.03      1.06
//! 2      5a      1.63   3.60      1.38     3      8a      1.18   4 (cap)   1.27
//! 2      6a      0.92   2.83      1.20     3      10a     0.65   3.41      1.14
//! ```
//!
//! (ratio 3 has no room below reach 5.5a and is steep at 6a: q = 3.2.) Clusters need more: a
//! refined region of length ℓ (the union of the cores) needs (ratio − 1)·ℓ/h extra elements from
//! its two tapers. For three particles 2.5a apart (ℓ = 8a), ratio 1.5 works from reach 6a
//! (q = 1.26), ratio 2 needs reach ≥ 8a (q = 1.52; 10a: 1.17, 12a: 1.10), ratio 3 about 15a
//! (q = 1.23). Between walls the component is often the whole channel (reach > H/2): the cores of
//! all particles must fit with the rest at most `COARSEST` times coarser.

use super::{Axis, Mesh, Shape};

/// A computational mesh that follows the particles (a tensor-product variant of thesis
/// §3.3.4): the vertex columns and rows of `base` near each particle are moved every step so
/// that the elements around it are refined (see [`follow_axis`]); topology, numbering and every
/// vertex away from the particles stay as in `base`. On an annulus the columns are the θ axis
/// (`x`, lengths in radians) and the rows the radial one (`y`).
#[derive(Debug, Clone)]
pub struct FollowingMesh {
    /// The mesh the refinement is applied to.
    pub base: Mesh,
    /// Refinement of the columns (along the flow: x or θ).
    pub x: Follow,
    /// Refinement of the rows (across the flow: y or r).
    pub y: Follow,
}

impl FollowingMesh {
    /// The mesh refined around particles at `centres` (a periodic axis wraps with the base's
    /// period).
    ///
    /// # Errors
    /// The reason, naming the direction, when an axis has no room for the refinement.
    pub fn mesh_at(&self, centres: &[[f64; 2]]) -> Result<Mesh, String> {
        let base = &self.base;
        let period = base
            .periodic
            .then(|| base.ax.vertices[base.ax.len()] - base.ax.vertices[0]);
        // the axes' coordinates of the centres: (x, y), or (θ, r) on an annulus (θ clockwise
        // from +x, as the mesh runs)
        let (cx, cy): (Vec<f64>, Vec<f64>) = match base.shape {
            Shape::Rectangle => centres.iter().map(|c| (c[0], c[1])).unzip(),
            Shape::Annulus => centres
                .iter()
                .map(|c| ((-c[1]).atan2(c[0]), c[0].hypot(c[1])))
                .unzip(),
        };
        let ax = follow_axis(&base.ax, &cx, &self.x, period)
            .map_err(|e| format!("along the flow: {e}"))?;
        let ay = follow_axis(&base.ay, &cy, &self.y, None)
            .map_err(|e| format!("across the flow: {e}"))?;
        Ok(base.with_axes(ax, ay))
    }
}

/// Largest element size allowed in a zone by [`follow_axis`], relative to the base size: the
/// minimum density is 1/4. (The smoothest grading of the typical parameters stays below it, see
/// the module documentation; [`follow_axis_zones`] takes another cap.)
pub const COARSEST: f64 = 4.0;

/// How an axis is refined around the particles (lengths in the axis' physical units).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Follow {
    /// Core refinement: element size in a core = base size / ratio (ratio ≥ 1; 1 = no change).
    pub ratio: f64,
    /// Half-width of the refined core around each centre (≥ 0, e.g. 1.5 particle radii).
    pub core: f64,
    /// Half-width of the zone around each centre beyond which no vertex moves (> core).
    pub reach: f64,
}

impl Follow {
    /// Element size in a core at `x` (inside the base axis): the base size there / ratio. (The
    /// smallest element of a refined axis is [`Axis::min_size`].)
    pub fn core_size(&self, base: &Axis, x: f64) -> f64 {
        let e = base.locate(x);
        (base.vertices[e + 1] - base.vertices[e]) / self.ratio
    }

    /// The zone of one particle on a uniform base far from walls and other particles (it does
    /// not depend on the base size): its slope σ (neighbouring elements differ by ≤ exp(σh)) and
    /// coarsest element, with elements up to `coarsest` times the base size allowed
    /// ([`COARSEST`] in [`follow_axis`]). For choosing `reach`.
    ///
    /// # Errors
    /// As [`follow_axis`]: a bad spec or no room.
    pub fn isolated(&self, coarsest: f64) -> Result<Zone, FollowError> {
        self.validate(coarsest)?;
        let verts = [-self.reach, self.reach];
        let comp = Component {
            lo: -self.reach,
            hi: self.reach,
            centres: vec![0.0],
        };
        Ok(solve(&verts, &comp, self, coarsest)?.zone)
    }

    fn validate(&self, coarsest: f64) -> Result<(), FollowError> {
        let bad = |what: &str| Err(FollowError::Spec(format!("{what} ({self:?})")));
        if !(self.ratio.is_finite() && self.ratio >= 1.0) {
            return bad("ratio must be finite and ≥ 1");
        }
        if !(self.core.is_finite() && self.core >= 0.0) {
            return bad("core must be finite and ≥ 0");
        }
        if !(self.reach.is_finite() && self.reach > self.core) {
            return bad("reach must be finite and > core");
        }
        if coarsest.is_nan() || coarsest < 1.0 {
            return Err(FollowError::Spec(format!(
                "the coarsest element size must be ≥ 1 base size (got {coarsest})"
            )));
        }
        Ok(())
    }
}

/// A connected component of the union of zones, as refined.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Zone {
    /// Left end (on a periodic axis unwrapped: it may lie beyond the axis' right end).
    pub lo: f64,
    /// Right end.
    pub hi: f64,
    /// Number of centres whose zones make it up.
    pub centres: usize,
    /// σ: slope of the relative element size per unit length; neighbouring elements differ in
    /// size by a factor ≤ exp(σh) (h the base element size there). The largest over the cells
    /// of a component cut at partial links.
    pub slope: f64,
    /// Largest relative element size g in it (coarsest element / base element).
    pub coarsest: f64,
}

/// A refined axis and its zones.
#[derive(Debug, Clone, PartialEq)]
pub struct Followed {
    /// The refined axis.
    pub axis: Axis,
    /// The components of the union of zones, left to right.
    pub zones: Vec<Zone>,
}

/// Why an axis could not be refined.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FollowError {
    /// Bad parameters.
    #[error("follow: {0}")]
    Spec(String),
    /// A centre is not finite.
    #[error("follow: centre {index} is {value}")]
    Centre {
        /// Index in the centres given.
        index: usize,
        /// Its value.
        value: f64,
    },
    /// The period given is not the base axis' span.
    #[error("follow: period {period} is not the base axis' span {span}")]
    Period {
        /// Period given.
        period: f64,
        /// `vertices[n] − vertices[0]`.
        span: f64,
    },
    /// On a periodic axis the zones leave no point fixed.
    #[error(
        "follow: the zones (reach {reach}) of {centres} centres cover the whole periodic axis \
         (period {period}): reduce reach"
    )]
    Covered {
        /// Zone half-width.
        reach: f64,
        /// Number of centres.
        centres: usize,
        /// Period.
        period: f64,
    },
    /// A component cannot conserve its element count with elements no coarser than allowed.
    #[error(
        "follow: no room in the zone [{lo}, {hi}] of {centres} centre(s): it holds {elements:.4} \
         base elements, but the cores need {core_elements:.4} at ratio {ratio} and the rest \
         {rest_elements:.4} even at {coarsest} times the base size (lower ratio or core, widen \
         reach or allow coarser elements)"
    )]
    NoRoom {
        /// Left end of the component.
        lo: f64,
        /// Right end.
        hi: f64,
        /// Number of centres in it.
        centres: usize,
        /// Base elements in it, s(hi) − s(lo).
        elements: f64,
        /// Elements the cores take at the core ratio.
        core_elements: f64,
        /// Elements the rest takes at the coarsest size allowed.
        rest_elements: f64,
        /// Core ratio.
        ratio: f64,
        /// Coarsest relative size allowed.
        coarsest: f64,
    },
    /// Round-off broke the ordering of the vertices (not expected).
    #[error("follow: vertices {index} and {} not increasing ({left} ≥ {right})", index + 1)]
    NotIncreasing {
        /// First vertex of the pair.
        index: usize,
        /// Its coordinate.
        left: f64,
        /// The next one's.
        right: f64,
    },
}

/// The axis `base` refined around `centres` by `spec`; `period = Some(L)` for a periodic axis
/// (L = the base's span; zones wrap and vertex 0 may move, the span stays L), `None` for a
/// bounded one (ends fixed, zones clipped at them). See the module documentation.
///
/// # Errors
/// [`FollowError`]: bad spec, centre or period, zones covering a periodic axis, no room.
pub fn follow_axis(
    base: &Axis,
    centres: &[f64],
    spec: &Follow,
    period: Option<f64>,
) -> Result<Axis, FollowError> {
    Ok(follow_axis_zones(base, centres, spec, period, COARSEST)?.axis)
}

/// [`follow_axis`] with elements up to `coarsest` (≥ 1, may be infinite) times the base size
/// allowed in the zones instead of [`COARSEST`], and the zones (their slopes and coarsest
/// elements) for diagnostics.
///
/// # Errors
/// As [`follow_axis`].
pub fn follow_axis_zones(
    base: &Axis,
    centres: &[f64],
    spec: &Follow,
    period: Option<f64>,
    coarsest: f64,
) -> Result<Followed, FollowError> {
    spec.validate(coarsest)?;
    if let Some((index, &value)) = centres.iter().enumerate().find(|(_, c)| !c.is_finite()) {
        return Err(FollowError::Centre { index, value });
    }
    let n = base.len();
    let v = &base.vertices;
    let span = v[n] - v[0];
    if let Some(period) = period {
        let same = (period - span).abs() <= 1e-12 * span;
        if !same {
            return Err(FollowError::Period { period, span });
        }
    }
    let unchanged = || Followed {
        axis: base.clone(),
        zones: Vec::new(),
    };
    if centres.is_empty() || spec.ratio == 1.0 {
        return Ok(unchanged());
    }
    let mut out = v.clone();
    let mut zones = Vec::new();
    match period {
        None => {
            for comp in components(centres, spec.reach, v[0], v[n]) {
                let sol = solve(v, &comp, spec, coarsest)?;
                for (k, x) in sol.vertices {
                    out[k] = x;
                }
                zones.push(sol.zone);
            }
        }
        Some(_) => {
            let wrap = |c: f64, from: f64| {
                let w = from + (c - from).rem_euclid(span);
                if w >= from + span {
                    from
                } else {
                    w
                }
            };
            let covered = || FollowError::Covered {
                reach: spec.reach,
                centres: centres.len(),
                period: span,
            };
            if 2.0 * spec.reach >= span {
                return Err(covered());
            }
            // A point no zone covers (open zones): v₀ itself, or the right end of the component
            // covering it. The window [xr, xr + L] then holds every zone whole.
            let images: Vec<f64> = centres
                .iter()
                .flat_map(|&c| {
                    let w = wrap(c, v[0]);
                    [w - span, w, w + span]
                })
                .collect();
            let line = components(&images, spec.reach, f64::NEG_INFINITY, f64::INFINITY);
            let xr = match line.iter().find(|c| c.lo < v[0] && v[0] < c.hi) {
                None => v[0],
                Some(c) if c.hi - c.lo >= span => return Err(covered()),
                Some(c) => c.hi,
            };
            // base vertices over two periods: index k ≥ n is vertex k − n shifted by L
            let ext: Vec<f64> = v
                .iter()
                .copied()
                .chain(v[1..].iter().map(|x| x + span))
                .collect();
            let inside: Vec<f64> = centres.iter().map(|&c| wrap(c, xr)).collect();
            for comp in components(&inside, spec.reach, xr, xr + span) {
                let sol = solve(&ext, &comp, spec, coarsest)?;
                for (k, x) in sol.vertices {
                    if k < n {
                        out[k] = x;
                    } else {
                        out[k - n] = x - span;
                    }
                }
                zones.push(sol.zone);
            }
            if out[0] != v[0] {
                (out[0], out[n]) = exact_span(out[0], span);
            }
        }
    }
    if let Some(i) = (0..n).find(|&i| out[i] >= out[i + 1]) {
        return Err(FollowError::NotIncreasing {
            index: i,
            left: out[i],
            right: out[i + 1],
        });
    }
    Ok(Followed {
        axis: Axis { vertices: out },
        zones,
    })
}

/// (x₀, x₀ + L), x₀ nudged by a few ulps if needed so that (x₀ + L) − x₀ == L in floating point.
fn exact_span(x0: f64, span: f64) -> (f64, f64) {
    let (mut up, mut down) = (x0, x0);
    let mut candidates = vec![x0];
    for _ in 0..8 {
        up = up.next_up();
        down = down.next_down();
        candidates.extend([up, down]);
    }
    candidates
        .into_iter()
        .map(|x| (x, x + span))
        .find(|&(x, end)| end - x == span)
        .unwrap_or((x0, x0 + span))
}

/// A connected component of the union of zones with the centres making it up (sorted).
#[derive(Debug, Clone)]
struct Component {
    lo: f64,
    hi: f64,
    centres: Vec<f64>,
}

/// Components of the union of the open zones (c − reach, c + reach), clipped to [a, b]; zones
/// that only touch stay apart.
fn components(centres: &[f64], reach: f64, a: f64, b: f64) -> Vec<Component> {
    let mut zones: Vec<(f64, f64, f64)> = centres
        .iter()
        .map(|&c| (c, (c - reach).max(a), (c + reach).min(b)))
        .filter(|z| z.2 > z.1)
        .collect();
    zones.sort_by(|p, q| p.1.total_cmp(&q.1).then(p.0.total_cmp(&q.0)));
    let mut out: Vec<Component> = Vec::new();
    for (c, lo, hi) in zones {
        match out.last_mut() {
            Some(last) if lo < last.hi => {
                last.hi = last.hi.max(hi);
                last.centres.push(c);
            }
            _ => out.push(Component {
                lo,
                hi,
                centres: vec![c],
            }),
        }
    }
    for comp in &mut out {
        comp.centres.sort_by(f64::total_cmp);
    }
    out
}

/// New positions (index into the vertex list, coordinate) of the vertices strictly inside a
/// component, and its zone.
struct Solution {
    vertices: Vec<(usize, f64)>,
    zone: Zone,
}

/// The σ-independent part of g on an interval of a component: breakpoints (where d, D or h may
/// bend or jump), d and D there, the base size on each interval between them.
struct Profile {
    xs: Vec<f64>,
    d: Vec<f64>,
    depth: Vec<f64>,
    h: Vec<f64>,
}

/// A piece on which h is constant and g linear (g0 at x0, g1 at x1).
#[derive(Debug, Clone, Copy)]
struct Piece {
    x0: f64,
    x1: f64,
    g0: f64,
    g1: f64,
    h: f64,
}

impl Piece {
    /// ∫ dx / (h g) over the piece.
    fn count(&self) -> f64 {
        (self.x1 - self.x0) / (self.h * self.g0) * ln1p_over((self.g1 - self.g0) / self.g0)
    }

    /// The x at which the count from x0 reaches `c` ∈ [0, count()].
    fn invert(&self, c: f64) -> f64 {
        let dx = self.x1 - self.x0;
        let u = c * self.h * self.g0 / dx; // fraction of the piece if g were constant
        let w = (self.g1 - self.g0) / self.g0;
        (self.x0 + dx * u * expm1_over(w * u)).clamp(self.x0, self.x1)
    }
}

/// ln(1 + w) / w, 1 at w = 0.
fn ln1p_over(w: f64) -> f64 {
    if w == 0.0 {
        1.0
    } else {
        w.ln_1p() / w
    }
}

/// (eᶻ − 1) / z, 1 at z = 0.
fn expm1_over(z: f64) -> f64 {
    if z == 0.0 {
        1.0
    } else {
        z.exp_m1() / z
    }
}

/// Base index of x: (element k, fraction in it), with verts[k] ≤ x ≤ verts[k + 1].
fn base_index(verts: &[f64], x: f64) -> (usize, f64) {
    let k = verts
        .partition_point(|&v| v <= x)
        .saturating_sub(1)
        .min(verts.len() - 2);
    (k, (x - verts[k]) / (verts[k + 1] - verts[k]))
}

/// The profile of the interval [lo, hi] of a component with the given centres.
fn profile(verts: &[f64], lo: f64, hi: f64, cs: &[f64], spec: &Follow) -> Profile {
    let mut xs = vec![lo, hi];
    xs.extend(verts.iter().copied().filter(|&x| lo < x && x < hi));
    for &c in cs {
        xs.extend([c - spec.core, c, c + spec.core]);
    }
    xs.extend(cs.windows(2).map(|w| 0.5 * (w[0] + w[1])));
    xs.retain(|&x| lo <= x && x <= hi);
    xs.sort_by(f64::total_cmp);
    xs.dedup();
    let near = |x: f64| {
        cs.iter()
            .map(|c| (x - c).abs())
            .fold(f64::INFINITY, f64::min)
    };
    let d = xs.iter().map(|&x| (near(x) - spec.core).max(0.0)).collect();
    let depth = xs
        .iter()
        .map(|&x| (spec.reach - near(x)).max(0.0))
        .collect();
    let h = xs
        .windows(2)
        .map(|w| {
            let (k, _) = base_index(verts, 0.5 * (w[0] + w[1]));
            verts[k + 1] - verts[k]
        })
        .collect();
    Profile { xs, d, depth, h }
}

/// The pieces of g for slope σ.
fn pieces(p: &Profile, sigma: f64, ratio: f64, cap: f64) -> Vec<Piece> {
    let fine = 1.0 / ratio;
    let mut out = Vec::with_capacity(2 * p.xs.len());
    for k in 0..p.h.len() {
        let (xa, xb) = (p.xs[k], p.xs[k + 1]);
        let (da, db) = (p.d[k], p.d[k + 1]);
        let (ea, eb) = (p.depth[k], p.depth[k + 1]);
        // the three candidates, linear in t ∈ [0, 1]
        let at = |t: f64| -> f64 {
            let (d, e) = if t == 1.0 {
                (db, eb)
            } else {
                (da + t * (db - da), ea + t * (eb - ea))
            };
            (fine + sigma * d).min(1.0 + sigma * e).min(cap)
        };
        let f = |t: f64| -> [f64; 3] {
            let (d, e) = (da + t * (db - da), ea + t * (eb - ea));
            [fine + sigma * d, 1.0 + sigma * e, cap]
        };
        let (f0, f1) = (f(0.0), f(1.0));
        let mut ts = vec![0.0, 1.0];
        for (i, j) in [(0, 1), (0, 2), (1, 2)] {
            let (a, b) = (f0[i] - f0[j], f1[i] - f1[j]);
            if a.is_finite() && b.is_finite() && a * b < 0.0 {
                ts.push(a / (a - b));
            }
        }
        ts.sort_by(f64::total_cmp);
        ts.dedup();
        let x_at = |t: f64| if t == 1.0 { xb } else { xa + t * (xb - xa) };
        for w in ts.windows(2) {
            let (x0, x1) = (x_at(w[0]), x_at(w[1]));
            if x1 > x0 {
                out.push(Piece {
                    x0,
                    x1,
                    g0: at(w[0]),
                    g1: at(w[1]),
                    h: p.h[k],
                });
            }
        }
    }
    out
}

/// How strongly two neighbouring centres `spacing` apart share one slope: 0 while their zones
/// just touch, rising smoothly (C¹) to 1 when the zones overlap by reach − core.
fn link_weight(spacing: f64, spec: &Follow) -> f64 {
    let t = ((2.0 * spec.reach - spacing) / (spec.reach - spec.core)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// Elements the interval of a profile takes as σ → ∞: (in the cores at the core ratio, in the
/// rest at the cap).
fn limits(prof: &Profile, spec: &Follow, cap: f64) -> (f64, f64) {
    let (mut core, mut rest) = (0.0, 0.0);
    for k in 0..prof.h.len() {
        let n = (prof.xs[k + 1] - prof.xs[k]) / prof.h[k];
        if prof.d[k] + prof.d[k + 1] <= 1e-12 * spec.reach {
            core += spec.ratio * n;
        } else {
            rest += n / cap;
        }
    }
    (core, rest)
}

/// The σ at which the interval of `prof` holds `target` elements (bisection from `guess`), or
/// None if no σ ≥ 0 does.
fn slope_for(prof: &Profile, target: f64, guess: f64, ratio: f64, cap: f64) -> Option<f64> {
    let excess = |sigma: f64| -> f64 {
        pieces(prof, sigma, ratio, cap)
            .iter()
            .map(Piece::count)
            .sum::<f64>()
            - target
    };
    // the count falls as σ grows: bracket the root, then halve
    let (mut lo, mut hi);
    if excess(guess) > 0.0 {
        (lo, hi) = (guess, 2.0 * guess);
        let mut n = 0;
        while excess(hi) > 0.0 {
            (lo, hi) = (hi, 2.0 * hi);
            n += 1;
            if n > 200 {
                return None;
            }
        }
    } else {
        (lo, hi) = (0.5 * guess, guess);
        let mut n = 0;
        while excess(lo) <= 0.0 {
            (lo, hi) = (0.5 * lo, lo);
            n += 1;
            if n > 60 {
                if excess(0.0) <= 0.0 {
                    return None;
                }
                lo = 0.0;
                break;
            }
        }
    }
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if mid <= lo || mid >= hi {
            break;
        }
        if excess(mid) > 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Some(0.5 * (lo + hi))
}

/// Refines one component. One σ for the whole component (the "joint" solution) when all its
/// neighbouring centres are fully linked ([`link_weight`] 1). Otherwise the component is cut at
/// the midpoints of the partially linked pairs, each cell gets its own σ, and the count carried
/// across a cut is the weight times the joint solution's: cells of zones that just touch balance
/// on their own (as separate components do), fully linked ones are the joint solution, and the
/// vertices move continuously in between.
fn solve(
    verts: &[f64],
    comp: &Component,
    spec: &Follow,
    cap: f64,
) -> Result<Solution, FollowError> {
    let (lo, hi, cs) = (comp.lo, comp.hi, &comp.centres[..]);
    let sb = |x: f64| base_index(verts, x);
    let (klo, flo) = sb(lo);
    let (khi, _) = sb(hi);
    // base elements between x and y (x ≤ y), from the element indices to keep round-off small
    let between = |x: f64, y: f64| {
        let ((kx, fx), (ky, fy)) = (sb(x), sb(y));
        (ky - kx) as f64 + fy - fx
    };
    let elements = between(lo, hi);
    let no_room = |prof: &Profile, lo: f64, hi: f64, elements: f64| {
        let (core_elements, rest_elements) = limits(prof, spec, cap);
        FollowError::NoRoom {
            lo,
            hi,
            centres: cs.len(),
            elements,
            core_elements,
            rest_elements,
            ratio: spec.ratio,
            coarsest: cap,
        }
    };
    let whole = profile(verts, lo, hi, cs, spec);
    let (core, rest) = limits(&whole, spec, cap);
    if core + rest >= elements * (1.0 - 1e-9) {
        return Err(no_room(&whole, lo, hi, elements));
    }
    // At σ₀ the size is ≤ 1 everywhere (d ≤ reach − core in a zone): too many elements.
    let sigma0 = (1.0 - 1.0 / spec.ratio) / (spec.reach - spec.core);
    let joint = slope_for(&whole, elements, sigma0, spec.ratio, cap)
        .ok_or_else(|| no_room(&whole, lo, hi, elements))?;
    let count = |prof: &Profile, sigma: f64| -> f64 {
        pieces(prof, sigma, spec.ratio, cap)
            .iter()
            .map(Piece::count)
            .sum()
    };
    let joint_scale = elements / count(&whole, joint);
    // cuts (x, count carried across it beyond the base's) at the partially linked pairs
    let mut cuts = vec![(lo, 0.0)];
    for w in cs.windows(2) {
        let (m, weight) = (0.5 * (w[0] + w[1]), link_weight(w[1] - w[0], spec));
        if weight < 1.0 && lo < m && m < hi {
            let left = profile(verts, lo, m, cs, spec);
            let carried = count(&left, joint) * joint_scale - between(lo, m);
            cuts.push((m, weight * carried));
        }
    }
    cuts.push((hi, 0.0));
    // the cells' pieces, each cell's count scaled to its target exactly
    let cells = if cuts.len() == 2 {
        vec![(whole, elements, joint)]
    } else {
        let mut cells = Vec::with_capacity(cuts.len() - 1);
        for c in cuts.windows(2) {
            let ((a, ta), (b, tb)) = (c[0], c[1]);
            let prof = profile(verts, a, b, cs, spec);
            let target = between(a, b) + tb - ta;
            let sigma = slope_for(&prof, target, joint, spec.ratio, cap)
                .ok_or_else(|| no_room(&prof, a, b, target))?;
            cells.push((prof, target, sigma));
        }
        cells
    };
    let (mut ps, mut counts, mut slope) = (Vec::new(), Vec::new(), 0.0_f64);
    for (prof, target, sigma) in cells {
        let cell = pieces(&prof, sigma, spec.ratio, cap);
        let n: Vec<f64> = cell.iter().map(Piece::count).collect();
        let scale = target / n.iter().sum::<f64>();
        counts.extend(n.iter().map(|c| c * scale));
        ps.extend(cell);
        slope = slope.max(sigma);
    }
    let mut vertices = Vec::new();
    let (mut j, mut before) = (0, 0.0);
    for k in klo + 1..=khi {
        if !(lo < verts[k] && verts[k] < hi) {
            continue;
        }
        let target = (k - klo) as f64 - flo;
        while j + 1 < ps.len() && before + counts[j] < target {
            before += counts[j];
            j += 1;
        }
        // the count of a piece in its own scale
        let own = ps[j].count();
        let c = ((target - before) * own / counts[j]).clamp(0.0, own);
        vertices.push((k, ps[j].invert(c)));
    }
    let largest = ps.iter().map(|p| p.g0.max(p.g1)).fold(0.0, f64::max);
    Ok(Solution {
        vertices,
        zone: Zone {
            lo,
            hi,
            centres: cs.len(),
            slope,
            coarsest: largest,
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sizes(ax: &Axis) -> Vec<f64> {
        ax.vertices.windows(2).map(|w| w[1] - w[0]).collect()
    }

    /// max over neighbouring elements of the larger / smaller size
    fn neighbour_ratio(ax: &Axis, periodic: bool) -> f64 {
        let h = sizes(ax);
        let mut q = h
            .windows(2)
            .map(|w| (w[1] / w[0]).max(w[0] / w[1]))
            .fold(1.0, f64::max);
        if periodic {
            let (a, b) = (h[0], h[h.len() - 1]);
            q = q.max((a / b).max(b / a));
        }
        q
    }

    /// The channel's x-axis: L = 4, 200 elements; particles of radius 0.1 with core 0.15 and
    /// reach 0.6 (1.5a and 6a).
    const L: f64 = 4.0;

    /// Largest distance between the vertices of two axes of one element count.
    fn max_shift(a: &Axis, b: &Axis) -> f64 {
        a.vertices
            .iter()
            .zip(&b.vertices)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f64::max)
    }

    fn channel() -> Axis {
        Axis::uniform(-0.5 * L, 0.5 * L, 200)
    }

    fn spec(ratio: f64) -> Follow {
        Follow {
            ratio,
            core: 0.15,
            reach: 0.6,
        }
    }

    /// The string of three particles of radius 0.1, 0.25 apart: their cores make one refined
    /// region 0.8 long, which needs a wider reach (15a).
    const STRING: [f64; 3] = [0.3, 0.55, 0.8];

    fn wide(ratio: f64) -> Follow {
        Follow {
            reach: 1.5,
            ..spec(ratio)
        }
    }

    /// Distance of x to c modulo the period (or plain).
    fn dist(x: f64, c: f64, period: Option<f64>) -> f64 {
        match period {
            Some(p) => {
                let d = (x - c).rem_euclid(p);
                d.min(p - d)
            }
            None => (x - c).abs(),
        }
    }

    /// Continuous base index of x (bounded: x in the axis).
    fn index(base: &Axis, x: f64) -> f64 {
        let (k, f) = base_index(&base.vertices, x);
        k as f64 + f
    }

    /// Checks properties 2–3 (copy outside zones, count, order, ends / span) and returns the
    /// axis and zones.
    fn checked(
        base: &Axis,
        centres: &[f64],
        spec: &Follow,
        period: Option<f64>,
    ) -> (Axis, Vec<Zone>) {
        let f = follow_axis_zones(base, centres, spec, period, COARSEST).unwrap();
        let (v, w) = (&base.vertices, &f.axis.vertices);
        let n = base.len();
        assert_eq!(w.len(), v.len());
        assert!(w.windows(2).all(|p| p[1] > p[0]), "strictly increasing");
        match period {
            None => assert!(w[0] == v[0] && w[n] == v[n], "ends fixed"),
            Some(p) => assert_eq!(w[n] - w[0], p, "span exactly L"),
        }
        let mut moved = 0;
        for i in 0..=n {
            let outside = centres.iter().all(|&c| dist(v[i], c, period) >= spec.reach);
            if outside {
                assert_eq!(
                    w[i].to_bits(),
                    v[i].to_bits(),
                    "vertex {i} outside the zones"
                );
            } else if w[i] != v[i] {
                moved += 1;
            }
        }
        assert!(moved > 0, "something moved");
        (f.axis, f.zones)
    }

    #[test]
    fn no_centres_or_ratio_one_give_the_base_bitwise() {
        let graded = Axis::centred(-2.0, 2.0, 120, 2.0);
        for (base, period) in [(channel(), Some(L)), (graded, None)] {
            for (centres, ratio) in [(vec![], 2.0), (vec![0.3, -1.9], 1.0)] {
                let ax = follow_axis(&base, &centres, &spec(ratio), period).unwrap();
                assert_eq!(ax, base);
            }
        }
        // a bounded axis: zones beyond the ends are ignored
        let ax = follow_axis(&channel(), &[2.7, -3.0], &spec(2.0), None).unwrap();
        assert_eq!(ax, channel());
    }

    #[test]
    fn vertices_outside_the_zones_are_copied_and_the_count_ends_and_span_kept() {
        type Case = (&'static [f64], Option<f64>, fn(f64) -> Follow);
        let cases: [Case; 6] = [
            (&STRING, Some(L), wide),
            (&[-1.9, 0.3, 1.2], Some(L), spec), // the first zone wraps past −L/2
            (&[1.95, -0.5], Some(L), spec),
            (&[-1.8, 0.0, 1.9], None, spec), // zones clipped at the ends
            (&[-1.7, 1.8], Some(L), wide),   // zones wrapping both ways
            (&[1.0, -1.9], None, wide),      // a core cut by the end
        ];
        for (centres, period, spec) in cases {
            for ratio in [1.5, 2.0] {
                for base in [channel(), Axis::centred(-2.0, 2.0, 200, 2.0)] {
                    checked(&base, centres, &spec(ratio), period);
                }
            }
        }
        checked(&channel(), &STRING, &wide(3.0), Some(L));
        checked(&channel(), &[1.9], &spec(3.0), Some(L));
        // a centre counted twice (particles side by side) changes nothing
        assert_eq!(
            follow_axis(&channel(), &[0.3, -1.0, 0.3], &spec(2.0), Some(L)),
            follow_axis(&channel(), &[-1.0, 0.3], &spec(2.0), Some(L))
        );
        // the wrapped zone moves vertex 0, and the span stays exactly L
        let ax = follow_axis(&channel(), &[-1.9], &spec(2.0), Some(L)).unwrap();
        assert!(ax.vertices[0] != -2.0 && ax.vertices[200] - ax.vertices[0] == L);
        // the y-axis between walls (H = 20a) with a particle near the wall
        let y = Axis::centred(-1.0, 1.0, 100, 1.5);
        checked(&y, &[0.92, -0.1], &spec(2.0), None);
    }

    #[test]
    fn a_centre_shifted_by_the_period_gives_the_same_axis() {
        for centres in [[-1.9, 0.3], [1.7, -0.2], [0.0, 1.99]] {
            let a = follow_axis(&channel(), &centres, &spec(2.0), Some(L)).unwrap();
            for shift in [L, -L, 2.0 * L] {
                let moved = [centres[0] + shift, centres[1]];
                let b = follow_axis(&channel(), &moved, &spec(2.0), Some(L)).unwrap();
                let worst = max_shift(&a, &b);
                assert!(worst < 1e-13, "{centres:?} shifted by {shift}: {worst:e}");
            }
        }
    }

    /// Properties 4: the core elements, the coarsest element, neighbouring elements.
    #[test]
    fn cores_are_refined_by_the_ratio_and_the_tapers_are_smooth() {
        let graded = Axis::centred(-2.0, 2.0, 200, 1.5);
        let base_q = neighbour_ratio(&graded, true);
        let lone = vec![0.3];
        let seam = vec![-1.95, 1.95]; // 0.1 apart across the seam
        let pair = vec![-1.95, 1.0]; // zones apart
        let string = STRING.to_vec();
        let cases = [
            (2.0, 0.6, &lone),
            (2.0, 0.6, &seam),
            (2.0, 0.6, &pair),
            (2.0, 0.5, &lone),
            (2.0, 0.5, &seam),
            (3.0, 0.6, &lone),
            (3.0, 0.9, &lone),
            (3.0, 0.9, &seam),
            (2.0, 1.2, &string),
            (3.0, 1.5, &string),
        ];
        for (ratio, reach, centres) in cases {
            let spec = Follow {
                ratio,
                core: 0.15,
                reach,
            };
            let iso = spec.isolated(COARSEST).unwrap();
            for base in [channel(), graded.clone()] {
                let (ax, zones) = checked(&base, centres, &spec, Some(L));
                let v = &ax.vertices;
                let in_core = |x: f64| centres.iter().any(|&c| dist(x, c, Some(L)) <= spec.core);
                let (mut core_err, mut coarsest) = (0.0_f64, 0.0_f64);
                for i in 0..200 {
                    if v[i] < -2.0 || v[i + 1] > 2.0 {
                        continue; // across the seam: not an element of the base's index range
                    }
                    // the element in the base index measure: 1/ratio in the cores
                    let count = index(&base, v[i + 1]) - index(&base, v[i]);
                    if in_core(v[i]) && in_core(v[i + 1]) {
                        core_err = core_err.max((count * ratio - 1.0).abs());
                    }
                    coarsest = coarsest.max(count);
                }
                let q = neighbour_ratio(&ax, true);
                let slope = zones.iter().map(|z| z.slope).fold(0.0, f64::max);
                let largest = zones.iter().map(|z| z.coarsest).fold(0.0, f64::max);
                let h = sizes(&base).into_iter().fold(0.0, f64::max);
                let bound = (slope * h).exp() * neighbour_ratio(&base, true);
                eprintln!(
                    "ratio {ratio} reach {reach} centres {centres:?} graded {}: core error \
                     {core_err:.1e}, coarsest {coarsest:.3} (zones {largest:.3}, isolated {:.3}), \
                     neighbours {q:.3} (exp(σh) {bound:.3}, isolated {:.3})",
                    base != channel(),
                    iso.coarsest,
                    (iso.slope * 0.02).exp() * if base == channel() { 1.0 } else { base_q }
                );
                assert!(core_err < 1e-9, "core elements");
                assert!(coarsest <= largest * (1.0 + 1e-9) && largest <= COARSEST);
                assert!(q <= bound * 1.01, "neighbour ratio {q} > {bound}");
            }
        }
    }

    #[test]
    fn vertices_move_continuously_with_the_centres() {
        let delta = 1e-6;
        let cases: [(&[f64], Option<f64>, Follow); 8] = [
            (&[0.3], Some(L), spec(2.0)),
            (&[0.3], Some(L), spec(3.0)),
            (&STRING, Some(L), wide(2.0)),
            (&STRING, Some(L), wide(3.0)),
            (&[-1.97, 1.0], Some(L), spec(2.0)),
            (&[0.42, -0.1], None, spec(2.0)),
            (&[0.3, 1.0], Some(L), spec(2.0)), // zones overlapping a little
            (&[1.0, -1.9], None, wide(2.0)),
        ];
        let mut worst: f64 = 0.0;
        for (centres, period, spec) in cases {
            {
                let a = follow_axis(&channel(), centres, &spec, period).unwrap();
                for k in 0..centres.len() {
                    for sign in [1.0, -1.0] {
                        let mut moved = centres.to_vec();
                        moved[k] += sign * delta;
                        let b = follow_axis(&channel(), &moved, &spec, period).unwrap();
                        let d = max_shift(&a, &b);
                        worst = worst.max(d / delta);
                    }
                }
            }
        }
        eprintln!("continuity: max vertex displacement / centre displacement {worst:.3}");
        // a translation of everything by δ moves the vertices by δ(1 − g): up to δ(coarsest − 1)
        assert!(worst < 1.5 * COARSEST, "{worst}");
        // two lone particles whose zones start to overlap (same σ): no jump
        let jump = |a: &Axis, b: &Axis| {
            a.vertices
                .iter()
                .zip(&b.vertices)
                .map(|(x, y)| (x - y).abs())
                .fold(0.0, f64::max)
        };
        let at = |centres: &[f64]| follow_axis(&channel(), centres, &spec(2.0), None).unwrap();
        let d = jump(&at(&[-0.6, 0.6 + delta]), &at(&[-0.6, 0.6 - delta]));
        eprintln!(
            "lone zones merging: displacement / centre displacement {:.3}",
            d / (2.0 * delta)
        );
        assert!(d < 3.0 * 2.0 * delta);
        // a pair meeting a lone particle (different σ: without the links, 19 elements at once)
        let d = jump(
            &at(&[-0.8, -0.5, 0.7 + delta]),
            &at(&[-0.8, -0.5, 0.7 - delta]),
        );
        eprintln!(
            "pair meeting a lone zone: displacement / centre displacement {:.3}",
            d / (2.0 * delta)
        );
        assert!(d < 3.0 * 2.0 * delta);
    }

    /// A lone particle approaching a pair (their σ differ): through the merge of the zones and
    /// the rise of the link, the vertices move Lipschitz-continuously.
    #[test]
    fn zones_merge_continuously() {
        let step = 2e-4;
        let spec = Follow {
            reach: 0.9,
            ..spec(2.0)
        };
        let at = |x: f64| follow_axis_zones(&channel(), &[-1.0, -0.7, x], &spec, Some(L), COARSEST);
        let mut last = at(1.15).unwrap().axis;
        let (mut lipschitz, mut q, mut x) = (0.0_f64, 0.0_f64, 1.15);
        while x > 0.2 {
            x -= step;
            let now = at(x).unwrap().axis;
            let d = max_shift(&now, &last);
            lipschitz = lipschitz.max(d / step);
            q = q.max(neighbour_ratio(&now, true));
            last = now;
        }
        let separate = neighbour_ratio(&at(1.15).unwrap().axis, true);
        let joint = neighbour_ratio(&at(0.2).unwrap().axis, true);
        eprintln!(
            "lone approaching a pair: max vertex speed / particle speed {lipschitz:.3}, \
             neighbour ratio ≤ {q:.3} (apart {separate:.3}, joined {joint:.3})"
        );
        assert!(lipschitz < 1.5 * COARSEST);
        assert!(q < 1.3);
    }

    #[test]
    fn no_room_and_bad_input_are_errors() {
        // the cores alone need 5·0.3 = 1.5 > 1.2 of the zone
        let err = follow_axis(&channel(), &[0.3], &spec(5.0), Some(L)).unwrap_err();
        let FollowError::NoRoom {
            centres,
            elements,
            core_elements,
            ..
        } = &err
        else {
            panic!("{err}");
        };
        assert_eq!(*centres, 1);
        assert!((elements - 60.0).abs() < 1e-9 && (core_elements - 75.0).abs() < 1e-9);
        assert!(
            err.to_string().contains("no room in the zone [-0.3"),
            "{err}"
        );
        // possible, but only with elements coarser than allowed
        assert!(matches!(
            follow_axis_zones(&channel(), &[0.3], &spec(3.0), Some(L), 2.0),
            Err(FollowError::NoRoom { .. })
        ));
        assert!(follow_axis_zones(&channel(), &[0.3], &spec(3.0), Some(L), 4.0).is_ok());
        let bad = |f: Follow| follow_axis(&channel(), &[0.3], &f, None);
        for f in [
            Follow {
                ratio: 0.5,
                ..spec(2.0)
            },
            Follow {
                reach: 0.1,
                ..spec(2.0)
            },
            Follow {
                core: -0.1,
                ..spec(2.0)
            },
            Follow {
                ratio: f64::NAN,
                ..spec(2.0)
            },
        ] {
            assert!(matches!(bad(f), Err(FollowError::Spec(_))), "{f:?}");
        }
        assert!(matches!(
            follow_axis(&channel(), &[f64::NAN], &spec(2.0), None),
            Err(FollowError::Centre { index: 0, .. })
        ));
        assert!(matches!(
            follow_axis(&channel(), &[0.3], &spec(2.0), Some(3.0)),
            Err(FollowError::Period { .. })
        ));
        let every: Vec<f64> = (0..4).map(|i| -2.0 + i as f64).collect();
        for (centres, reach) in [(every, 0.6), (vec![0.3], 2.0)] {
            let f = Follow { reach, ..spec(1.5) };
            assert!(matches!(
                follow_axis(&channel(), &centres, &f, Some(L)),
                Err(FollowError::Covered { .. })
            ));
        }
    }

    #[test]
    fn the_isolated_zone_is_the_zone_of_a_lone_particle() {
        let iso = spec(2.0).isolated(COARSEST).unwrap();
        let f = follow_axis_zones(&channel(), &[0.3], &spec(2.0), Some(L), COARSEST).unwrap();
        assert_eq!(f.zones.len(), 1);
        assert!((f.zones[0].slope - iso.slope).abs() < 1e-12 * iso.slope);
        assert!((iso.coarsest - 2.831).abs() < 1e-3 && (iso.slope - 9.247).abs() < 1e-3);
        // closed form of the lone zone without cap: g rises from 1/r over u₁ to the peak P and
        // falls to 1 over R − u₁ (R = reach − core), so the balance is ln(r P²)/σ = R − (r − 1)core
        for (r, reach) in [(2.0, 0.6), (3.0, 0.9), (1.5, 0.3)] {
            let f = Follow { reach, ..spec(r) };
            let z = f.isolated(f64::INFINITY).unwrap();
            let big_r = reach - f.core;
            let peak = 1.0 / r + z.slope * 0.5 * (big_r + (1.0 - 1.0 / r) / z.slope);
            let lhs = (r * peak * peak).ln() / z.slope;
            let rhs = big_r - (r - 1.0) * f.core;
            assert!((lhs - rhs).abs() < 1e-13, "{lhs} {rhs}");
            assert!((z.coarsest - peak).abs() < 1e-12 * peak);
        }
        // an odd period: the span stays exact when vertex 0 moves
        let odd = Axis::uniform(-1.3, 2.4, 77);
        for c in [-1.25, 2.38, 0.0] {
            let ax = follow_axis(&odd, &[c], &spec(1.5), Some(3.7)).unwrap();
            assert_eq!(
                ax.vertices[77] - ax.vertices[0],
                odd.vertices[77] - odd.vertices[0]
            );
        }
        // the size a core gets
        assert!((spec(2.0).core_size(&channel(), 0.3) - 0.01).abs() < 1e-15);
        assert!((f.axis.min_size() - 0.01).abs() < 1e-12);
    }
}
