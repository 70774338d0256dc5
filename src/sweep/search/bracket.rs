//! Brackets along the searched axis and the values a round puts into them: pure functions of the
//! values measured so far (no store, no runner), so that a search replayed from the database
//! chooses exactly what the interrupted one chose.
//!
//! A bracket is a pair of neighbouring measured values whose outcomes fall in different classes
//! ([`crate::config::Change::class_of`]). A round puts `per_bracket` evenly spaced values into
//! every bracket wider than the tolerance (`per_bracket` = 1: bisection), within the budget; a
//! bracket of width w is then at most w/(per_bracket + 1) wide. Values whose case failed (no
//! outcome) bracket nothing and are not chosen again.

use crate::config::SearchSpec;

/// One value of a line (a combination of the other axes) and what its case gave.
#[derive(Debug, Clone, PartialEq)]
pub struct Point {
    /// Value of the searched axis.
    pub value: f64,
    /// The class of its outcome; `None` while unknown or when the case failed.
    pub class: Option<String>,
}

/// Two neighbouring measured values with outcomes in different classes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bracket {
    /// Index of the lower point (in the points' order by value).
    pub below: usize,
    /// Index of the upper point.
    pub above: usize,
    /// Lower value.
    pub lo: f64,
    /// Upper value.
    pub hi: f64,
}

impl Bracket {
    /// Its width along the axis.
    pub fn width(&self) -> f64 {
        self.hi - self.lo
    }
}

/// The `coarse` evenly spaced values of the first round, both ends exact.
pub fn coarse_values(spec: &SearchSpec) -> Vec<f64> {
    let n = spec.coarse.max(2);
    (0..n)
        .map(|k| match k {
            0 => spec.lo,
            _ if k == n - 1 => spec.hi,
            _ => spec.lo + (spec.hi - spec.lo) * k as f64 / (n - 1) as f64,
        })
        .collect()
}

/// The brackets of `points` (sorted by value): neighbours among the points with a class whose
/// classes differ, in order along the axis.
pub fn brackets(points: &[Point]) -> Vec<Bracket> {
    let known: Vec<usize> = (0..points.len())
        .filter(|&i| points[i].class.is_some())
        .collect();
    known
        .windows(2)
        .filter(|w| points[w[0]].class != points[w[1]].class)
        .map(|w| Bracket {
            below: w[0],
            above: w[1],
            lo: points[w[0]].value,
            hi: points[w[1]].value,
        })
        .collect()
}

/// The values of the next round on one line, given its `points` (sorted by value) and the cases
/// it may still run (`remaining`): `per_bracket` values evenly spaced in each bracket wider than
/// `spec.tol`; when the budget does not reach, one value at a time to the widest brackets first.
/// Values the line has already are left out. Empty when every bracket is narrow enough or the
/// budget is spent.
pub fn next_values(points: &[Point], spec: &SearchSpec, remaining: usize) -> Vec<f64> {
    let open: Vec<Bracket> = brackets(points)
        .into_iter()
        .filter(|b| b.width() > spec.tol)
        .collect();
    // widest first; equal widths in order along the axis (a stable sort keeps it)
    let mut order: Vec<usize> = (0..open.len()).collect();
    order.sort_by(|&i, &j| open[j].width().total_cmp(&open[i].width()));
    let mut counts = vec![0_usize; open.len()];
    let mut left = remaining;
    'deal: for _ in 0..spec.per_bracket {
        for &i in &order {
            if left == 0 {
                break 'deal;
            }
            counts[i] += 1;
            left -= 1;
        }
    }
    let mut values = Vec::new();
    for (b, k) in open.iter().zip(counts) {
        for j in 1..=k {
            let v = b.lo + b.width() * j as f64 / (k + 1) as f64;
            if !points.iter().any(|p| p.value == v) {
                values.push(v);
            }
        }
    }
    values
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::Change;

    fn spec(per_bracket: usize) -> SearchSpec {
        SearchSpec {
            axis: "fluid.wi".into(),
            lo: 0.0,
            hi: 3.0,
            tol: 0.1,
            budget: 100,
            coarse: 4,
            per_bracket,
            change: Change::Kind,
        }
    }

    fn points(v: &[(f64, Option<&str>)]) -> Vec<Point> {
        v.iter()
            .map(|(value, class)| Point {
                value: *value,
                class: class.map(str::to_string),
            })
            .collect()
    }

    #[test]
    fn coarse_values_include_both_ends() {
        assert_eq!(coarse_values(&spec(1)), vec![0.0, 1.0, 2.0, 3.0]);
    }

    #[test]
    fn every_change_is_a_bracket_and_failed_values_are_skipped() {
        let p = points(&[
            (0.0, Some("pass")),
            (1.0, Some("pass")),
            (1.5, None),
            (2.0, Some("repel")),
            (3.0, Some("string")),
        ]);
        let b = brackets(&p);
        assert_eq!(b.len(), 2);
        assert_eq!((b[0].lo, b[0].hi, b[0].below, b[0].above), (1.0, 2.0, 1, 3));
        assert_eq!((b[1].lo, b[1].hi), (2.0, 3.0));
        // bisection: one value per bracket, the failed 1.5 is not chosen again
        assert_eq!(next_values(&p, &spec(1), 10), vec![2.5]);
        assert_eq!(
            next_values(&p, &spec(3), 10),
            vec![1.25, 1.75, 2.25, 2.5, 2.75]
        );
    }

    #[test]
    fn the_budget_goes_to_the_widest_brackets_first() {
        let p = points(&[
            (0.0, Some("pass")),
            (0.5, Some("repel")),
            (2.0, Some("repel")),
            (3.0, Some("string")),
        ]);
        assert_eq!(
            next_values(&p, &spec(2), 3),
            vec![0.25, 2.0 + 1.0 / 3.0, 2.0 + 2.0 / 3.0]
        );
        assert_eq!(next_values(&p, &spec(2), 1), vec![2.5]);
        assert!(next_values(&p, &spec(2), 0).is_empty());
    }

    #[test]
    fn narrow_brackets_are_left_alone() {
        let p = points(&[(1.0, Some("pass")), (1.05, Some("repel"))]);
        assert_eq!(brackets(&p).len(), 1);
        assert!(next_values(&p, &spec(3), 10).is_empty());
    }
}
