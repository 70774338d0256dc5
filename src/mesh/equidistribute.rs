//! Equidistribution of a Lipschitz size function on one axis: the new vertices of a connected
//! component of zones, for [`follow_axis`](super::follow_axis).
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

use super::follow::{Follow, FollowError, Zone};

/// A connected component of the union of zones with the centres making it up (sorted).
#[derive(Debug, Clone)]
pub(super) struct Component {
    pub(super) lo: f64,
    pub(super) hi: f64,
    pub(super) centres: Vec<f64>,
}

/// Components of the union of the open zones (c − reach, c + reach), clipped to [a, b]; zones
/// that only touch stay apart.
pub(super) fn components(centres: &[f64], reach: f64, a: f64, b: f64) -> Vec<Component> {
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
pub(super) struct Solution {
    pub(super) vertices: Vec<(usize, f64)>,
    pub(super) zone: Zone,
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
pub(super) fn base_index(verts: &[f64], x: f64) -> (usize, f64) {
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
pub(super) fn solve(
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
