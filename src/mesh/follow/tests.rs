//! Unit tests of the axis that follows the particles.

use super::*;
use crate::mesh::equidistribute::base_index;

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
fn checked(base: &Axis, centres: &[f64], spec: &Follow, period: Option<f64>) -> (Axis, Vec<Zone>) {
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
