//! Refinement of the films between near particles (issue 25): the columns and rows of a
//! following mesh moved towards each gap's midpoint so that the gap gets a set number of
//! elements across, at no change of the element count.
//!
//! `xpflow validate film-polymer` measured why this is needed: the polymer's normal push across
//! a sheared film (what holds a string's particles apart) converges only from about four
//! elements across the film, while along it a/10 holds it within 2 %; the studies' films are
//! 0.4–0.6 elements across. So the axis across a film is what has to be refined, and only there.
//!
//! A film between two particles of radius a with centres c₁, c₂ has thickness g = |c₂ − c₁| − 2a
//! and unit normal n = (c₂ − c₁)/|c₂ − c₁|; along axis k its surfaces are t_k = g/|n_k| apart,
//! and vertex lines h_k apart cross it t_k/h_k times. Each axis is refined at the film's midpoint
//! by `ratio = E·h/t_k` (h the axis' element size there), when that exceeds 1, capped at
//! [`Films::max_ratio`] and by the room in the zone ([`ROOM`], with the zone's elements at most
//! [`Films::coarsest`] times the axis' own): then the film is crossed E·n_k² times by each
//! axis' lines, E times in all, whatever its direction (a film along x is left to the columns, one at 45° shared). The
//! core (refined uniformly) has half-width t_k, at most half the reach: the film is at most
//! twice as thick there (|s| ≤ √(a g) along it); outside it the size grows linearly
//! ([`equidistribute`](super::equidistribute)) up to [`Films::reach`]. The core takes
//! (ratio − 1)·2t_k/h ≈ 2E extra elements whatever the gap, paid for by the taper. The ratio
//! is continuous in the centres (1 when t_k = E·h), so the vertices move continuously as a film
//! opens and closes. Films are refined one after another, each on the axis the previous left,
//! and again where a later one's taper coarsened an earlier one ([`Films::refine`]).
//! A film between a particle and a channel's wall is refined in the rows alike (its zone clipped
//! at the wall).

use super::follow::{follow_axis_zones, Follow, FollowError};
use super::Axis;

/// Share of the room in a film's zone the core may take: on a uniform axis, with the tapers'
/// elements at most `coarsest` times the axis' own, the core could take up to
/// (reach/core)(1 − 1/coarsest) + 1/coarsest times its elements; it takes at most ROOM of that
/// (the tapers rise linearly to the cap), so that a film on a coarse axis gets fewer elements
/// than asked rather than none.
pub const ROOM: f64 = 0.6;

/// Passes over the films of an axis at most ([`Films::refine`]).
pub const PASSES: usize = 3;
/// A film is refined again on a later pass when it is short of its elements by more than this
/// factor (5 %).
pub const PASS_TOL: f64 = 1.05;

/// How the films between near particles are refined.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Films {
    /// Particle radius (all particles).
    pub radius: f64,
    /// Elements wanted across a film (e.g. 4).
    pub elements: f64,
    /// Largest refinement of an axis at a film (relative to its element size there): films
    /// thinner than `elements·h/max_ratio` get fewer elements (near contact).
    pub max_ratio: f64,
    /// Half-width of the zone around a film's midpoint beyond which no vertex moves (> the core,
    /// e.g. four radii).
    pub reach: f64,
    /// Largest element in the zone relative to the axis' own there (≥ 1): the count the core
    /// takes is paid for by the tapers, which would otherwise coarsen the particles' own
    /// surroundings (e.g. 1.5; infinite: no cap).
    pub coarsest: f64,
}

/// One film as one axis sees it: where its midpoint lies, and its thickness along the axis
/// (g/|n_axis|: the distance between the film's surfaces along the axis).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FilmOnAxis {
    /// Midpoint's coordinate.
    pub at: f64,
    /// g/|n_axis|.
    pub thickness: f64,
}

impl Films {
    /// The films between the particles at `centres` (each pair once), and between each particle
    /// and the walls at `walls = Some((y_bottom, y_top))`, as the two axes see them:
    /// `([x films], [y films])`. `period = Some(L)` takes the nearest image along x.
    pub fn between(
        &self,
        centres: &[[f64; 2]],
        period: Option<f64>,
        walls: Option<(f64, f64)>,
    ) -> [Vec<FilmOnAxis>; 2] {
        let mut out = [Vec::new(), Vec::new()];
        if let Some((bottom, top)) = walls {
            for p in centres {
                for (wall, side) in [(bottom, -1.0), (top, 1.0)] {
                    let gap = (wall - p[1]) * side - self.radius;
                    if gap > 0.0 {
                        out[1].push(FilmOnAxis {
                            at: wall - side * 0.5 * gap,
                            thickness: gap,
                        });
                    }
                }
            }
        }
        for (i, p) in centres.iter().enumerate() {
            for q in &centres[i + 1..] {
                let mut d = [q[0] - p[0], q[1] - p[1]];
                if let Some(l) = period {
                    d[0] -= l * (d[0] / l).round();
                }
                let dist = d[0].hypot(d[1]);
                let gap = dist - 2.0 * self.radius;
                if gap.is_nan() || gap <= 0.0 {
                    continue; // overlapping (or coincident): no film to resolve
                }
                for (k, films) in out.iter_mut().enumerate() {
                    if d[k] != 0.0 {
                        films.push(FilmOnAxis {
                            at: p[k] + 0.5 * d[k],
                            thickness: gap * dist / d[k].abs(),
                        });
                    }
                }
            }
        }
        out
    }

    /// `axis` refined at each of `films` (on a periodic axis, `period` its span). Films are
    /// refined one after another; a later film's taper may coarsen an earlier film's core (by
    /// up to [`Films::coarsest`]: three particles in a string have films ≈ 2a apart), so the
    /// films short of their elements by more than [`PASS_TOL`] are refined again, up to
    /// [`PASSES`] passes in all. A film whose refinement finds no room (zones crowded by other
    /// films or a wall) is left as it is: its elements are fewer, the run goes on.
    ///
    /// # Errors
    /// [`FollowError`] other than no room (round-off breaking the vertices' order).
    pub fn refine(
        &self,
        axis: &Axis,
        films: &[FilmOnAxis],
        period: Option<f64>,
    ) -> Result<Axis, FollowError> {
        let mut out = axis.clone();
        for pass in 0..PASSES {
            let threshold = if pass == 0 { 1.0 } else { PASS_TOL };
            let mut changed = false;
            for film in films {
                let Some(spec) = self.spec_on(axis, &out, film, period, threshold) else {
                    continue;
                };
                match follow_axis_zones(&out, &[film.at], &spec, period, self.coarsest) {
                    Ok(refined) => {
                        out = refined.axis;
                        changed = true;
                    }
                    Err(FollowError::NoRoom { .. }) => {}
                    Err(e) => return Err(e),
                }
            }
            if !changed {
                break;
            }
        }
        Ok(out)
    }

    /// The largest refinement a core of half-width `core` has room for on a uniform axis (see
    /// [`ROOM`]).
    fn room(&self, core: f64) -> f64 {
        let c = self.coarsest.max(1.0);
        self.reach / core * (1.0 - 1.0 / c) + 1.0 / c
    }

    /// The refinement of `now` (refined from `base`) at `film` if it is more than `threshold`,
    /// capped at [`Films::max_ratio`] of `base`'s element there.
    fn spec_on(
        &self,
        base: &Axis,
        now: &Axis,
        film: &FilmOnAxis,
        period: Option<f64>,
        threshold: f64,
    ) -> Option<Follow> {
        let (lo, hi) = (now.vertices[0], now.vertices[now.len()]);
        let at = match period {
            Some(l) => lo + (film.at - lo).rem_euclid(l),
            None if film.at <= lo || film.at >= hi => return None,
            None => film.at,
        };
        let size = |a: &Axis| {
            let e = a.locate(at);
            a.vertices[e + 1] - a.vertices[e]
        };
        let h = size(now);
        let core = film.thickness.min(0.5 * self.reach);
        let ratio = (self.elements * h / film.thickness)
            .min(self.max_ratio * h / size(base))
            .min(ROOM * self.room(core));
        (ratio > threshold).then_some(Follow {
            ratio,
            core,
            reach: self.reach,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Table 5.2's channel along x (L = 4, 200 columns: h = a/5 for a = 0.1).
    fn channel() -> Axis {
        Axis::uniform(-2.0, 2.0, 200)
    }

    fn films(elements: f64) -> Films {
        Films {
            radius: 0.1,
            elements,
            max_ratio: 32.0,
            reach: 0.15,
            coarsest: f64::INFINITY,
        }
    }

    /// Elements between x0 and x1 on `axis`.
    fn elements_between(axis: &Axis, x0: f64, x1: f64) -> f64 {
        axis.index_coordinate(x1) - axis.index_coordinate(x0)
    }

    /// Two particles side by side along x, the gap g = 0.005 = 0.05a: a quarter of an element of
    /// the channel. Refined for E = 2, 4 the film gets E elements across (the core holds exactly
    /// the ratio), the count is kept and the vertices beyond the reach are the channel's. E = 8
    /// would take 16 elements in the core, of the 15 the zone (reach 1.5a) holds: it gets the
    /// room's [`ROOM`] share, 4.5 across.
    #[test]
    fn a_film_along_the_axis_gets_the_elements_asked_for() {
        let gap = 0.005;
        let centres = [[-0.1 - gap / 2.0, 0.0], [0.1 + gap / 2.0, 0.0]];
        let base = channel();
        let [xs, _] = films(8.0).between(&centres, Some(4.0), None);
        let ax = films(8.0).refine(&base, &xs, Some(4.0)).unwrap();
        let across = elements_between(&ax, -gap / 2.0, gap / 2.0);
        assert!((across - 4.5).abs() < 1e-9, "{across}");
        for e in [2.0, 4.0] {
            let f = films(e);
            let [xs, ys] = f.between(&centres, Some(4.0), None);
            assert_eq!(xs.len(), 1);
            assert!((xs[0].thickness - gap).abs() < 1e-15 && ys.is_empty());
            let ax = f.refine(&base, &xs, Some(4.0)).expect("room");
            assert_eq!(ax.len(), base.len());
            let across = elements_between(&ax, -gap / 2.0, gap / 2.0);
            assert!((across - e).abs() < 1e-9, "E = {e}: {across}");
            for (v, w) in ax.vertices.iter().zip(&base.vertices) {
                if v.abs() >= 0.15 + 1e-12 {
                    assert_eq!(v, w);
                }
            }
            // the rows are not touched by a film along x
            let ay = f.refine(&Axis::uniform(-0.5, 0.5, 50), &ys, None).unwrap();
            assert_eq!(ay, Axis::uniform(-0.5, 0.5, 50));
        }
    }

    /// A film already resolved (g·|n| ≥ E·h) leaves the axis alone; one a little thinner moves
    /// the vertices a little: the refinement switches on continuously.
    #[test]
    fn the_refinement_switches_on_continuously_as_a_film_closes() {
        let f = films(4.0);
        let base = channel();
        let film = |g: f64| FilmOnAxis {
            at: 0.003,
            thickness: g,
        };
        assert!(f
            .spec_on(&base, &base, &film(0.0801), Some(4.0), 1.0)
            .is_none());
        let near = f.refine(&base, &[film(0.07999)], Some(4.0)).unwrap();
        let shift = near
            .vertices
            .iter()
            .zip(&base.vertices)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(shift < 1e-4, "{shift}");
    }

    /// A film at 45°: each axis sees its surfaces g·√2 apart and is refined for E/2 crossings;
    /// a pair across the periodic end is found by its nearest image; overlapping particles have
    /// no film.
    #[test]
    fn films_are_seen_by_their_normal_and_across_the_period() {
        let f = films(4.0);
        let d = (0.2 + 0.01) / 2f64.sqrt();
        let [xs, ys] = f.between(&[[0.0, 0.0], [d, d]], None, None);
        let t = 0.01 * 2f64.sqrt();
        assert!((xs[0].thickness - t).abs() < 1e-12 && (ys[0].thickness - t).abs() < 1e-12);
        let ax = f.refine(&channel(), &xs, None).unwrap();
        let across = elements_between(&ax, 0.5 * d - 0.5 * t, 0.5 * d + 0.5 * t);
        assert!((across - 4.0).abs() < 1e-9, "{across}");
        // the midpoint −2.0025, i.e. 1.9975: the film's halves at both ends of the axis
        let [xs, _] = f.between(&[[-1.9, 0.0], [1.895, 0.0]], Some(4.0), None);
        assert!((xs[0].thickness - 0.005).abs() < 1e-12, "{:?}", xs[0]);
        let ax = f.refine(&channel(), &xs, Some(4.0)).unwrap();
        let wrap = |x: f64| ax.vertices[0] + (x - ax.vertices[0]).rem_euclid(4.0);
        let (lo, hi) = (wrap(1.995), wrap(2.0));
        let mut across = ax.index_coordinate(hi) - ax.index_coordinate(lo);
        if hi < lo {
            across += 200.0;
        }
        assert!((across - 4.0).abs() < 1e-9, "{across}");
        let [xs, ys] = f.between(&[[0.0, 0.0], [0.15, 0.0]], None, None);
        assert!(xs.is_empty() && ys.is_empty());
    }

    /// Three particles of a string 0.05a apart on Table 5.2's columns at the centre (a/8),
    /// zones of 4a capped at 1.5: the films 2.05a apart share their zones, and each still gets
    /// its four elements (the second's taper coarsened the first's by ≈ 1.3 before the passes).
    #[test]
    fn the_films_of_a_string_each_get_their_elements() {
        let f = Films {
            reach: 0.4,
            coarsest: 1.5,
            ..films(4.0)
        };
        let base = Axis::uniform(-2.0, 2.0, 320);
        let s = 0.205;
        let [xs, _] = f.between(&[[-s, 0.0], [0.0, 0.0], [s, 0.0]], Some(4.0), None);
        assert_eq!(
            xs.len(),
            3,
            "two films and the pair across the period: {xs:?}"
        );
        let ax = f.refine(&base, &xs, Some(4.0)).unwrap();
        for m in [-0.1025, 0.1025] {
            let across = elements_between(&ax, m - 0.0025, m + 0.0025);
            assert!((across - 4.0).abs() < 0.2, "film at {m}: {across}");
        }
        let mut single = base.clone();
        for film in &xs {
            if let Some(spec) = f.spec_on(&single, &single, film, Some(4.0), 1.0) {
                single = follow_axis_zones(&single, &[film.at], &spec, Some(4.0), 1.5)
                    .unwrap()
                    .axis;
            }
        }
        let first = elements_between(&single, -0.1025 - 0.0025, -0.1025 + 0.0025);
        assert!(first < 3.8, "one pass leaves the first film short: {first}");
    }

    /// A particle 0.005 from the top wall of a channel (H = 1, 50 rows: h = a/5): the rows get
    /// four elements in the film, which touches the wall (the zone is clipped there); the far
    /// wall's film (0.795) is resolved already.
    #[test]
    fn a_film_to_a_wall_is_refined_in_the_rows() {
        let f = films(4.0);
        let y = 0.5 - 0.1 - 0.005;
        let [xs, ys] = f.between(&[[0.3, y]], Some(4.0), Some((-0.5, 0.5)));
        assert!(xs.is_empty() && ys.len() == 2, "{ys:?}");
        let ay = f.refine(&Axis::uniform(-0.5, 0.5, 50), &ys, None).unwrap();
        assert_eq!(ay.len(), 50);
        let across = ay.index_coordinate(0.5) - ay.index_coordinate(0.495);
        assert!((across - 4.0).abs() < 0.05, "{across}");
        assert_eq!(
            ay.vertices[..20],
            Axis::uniform(-0.5, 0.5, 50).vertices[..20]
        );
    }
}
