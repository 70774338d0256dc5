//! A mesh axis refined around moving particles: the column (or row) coordinates of a tensor-product
//! mesh that follows the particles, same element count and numbering as the base axis
//! (docs/moving-mesh-plan.md, "a moving tensor-product grading").
//!
//! The axis is refined by equidistributing a Lipschitz size function around the centres; the
//! method, and how merging zones keep the vertices continuous, are described in
//! [`equidistribute`](super::equidistribute), which solves it on each connected zone.
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

use super::equidistribute::{components, solve, Component};
use super::films::Films;
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
    /// Refinement of both axes at the films between near particles and between a particle and
    /// the bottom or top wall, after the above (rectangles only).
    pub films: Option<Films>,
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
        let (ax, ay) = match (&self.films, base.shape) {
            (Some(films), Shape::Rectangle) => {
                // a rectangle's bottom and top are walls (films: confined shear)
                let walls = (base.ay.vertices[0], base.ay.vertices[base.ay.len()]);
                let [fx, fy] = films.between(centres, period, Some(walls));
                let ax = films
                    .refine(&ax, &fx, period)
                    .map_err(|e| format!("at a film, along the flow: {e}"))?;
                let ay = films
                    .refine(&ay, &fy, None)
                    .map_err(|e| format!("at a film, across the flow: {e}"))?;
                (ax, ay)
            }
            _ => (ax, ay),
        };
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
/// bounded one (ends fixed, zones clipped at them). See the module documentation and
/// [`equidistribute`](super::equidistribute).
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

#[cfg(test)]
mod tests;
