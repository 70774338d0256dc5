//! A channel periodic in x with length L: distances and images across its seam. One place for
//! the fold `d − L·round(d/L)` that particles, meshes, level sets, the ALE map and the
//! observers all take (`None`: no period, nothing folded).

/// `d` (an x-distance) folded by whole periods into [−L/2, L/2]; unchanged without a period.
pub fn fold(d: f64, period: Option<f64>) -> f64 {
    match period {
        Some(l) => d - l * (d / l).round(),
        None => d,
    }
}

/// `x` moved by whole periods along x to its image nearest to `near` (an x-coordinate).
pub fn nearest_image(x: [f64; 2], near: f64, period: Option<f64>) -> [f64; 2] {
    match period {
        Some(l) => [x[0] - l * ((x[0] - near) / l).round(), x[1]],
        None => x,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_fold_takes_the_shorter_way_round_and_nothing_without_a_period() {
        assert_eq!(fold(3.5, Some(4.0)), -0.5);
        assert_eq!(fold(-1.5, Some(4.0)), -1.5);
        assert_eq!(fold(-2.5, Some(4.0)), 1.5);
        assert_eq!(fold(3.5, None), 3.5);
        assert_eq!(nearest_image([1.75, 0.5], -1.75, Some(4.0)), [-2.25, 0.5]);
        assert_eq!(nearest_image([1.75, 0.5], 1.0, Some(4.0)), [1.75, 0.5]);
        assert_eq!(nearest_image([1.75, 0.5], -1.75, None), [1.75, 0.5]);
    }
}
