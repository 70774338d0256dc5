//! Initial particle layouts: point-symmetric strings of N particles (thesis 5.6.1, 5.7, Fig. 5.16),
//! the two-particle set-up of 5.6.1, and the Couette start position r0* (thesis 3.5.1).
//!
//! These are pure functions of plain numbers. They do not know the configuration types, so that
//! `config` can use them for its overlap checks without a dependency cycle.

/// Centres of a point-symmetric string of `n` particles, neighbours `lx` apart in x and `ly` apart in y.
///
/// Particle k (k = 0..n) sits at ((k − (n−1)/2)·lx, −(k − (n−1)/2)·ly): the first particle is the top-left
/// one, the string is point symmetric about the origin and, for odd n, the centre particle is at the origin.
/// For n = 3 this is the thesis set-up (−l_x, l_y), (0, 0), (l_x, −l_y) of section 5.7.
pub fn string_positions(n: usize, lx: f64, ly: f64) -> Vec<[f64; 2]> {
    let centre = (n as f64 - 1.0) / 2.0;
    (0..n)
        .map(|k| {
            let s = k as f64 - centre;
            [s * lx, -s * ly]
        })
        .collect()
}

/// Centres of the two-particle set-up of thesis 5.6.1: (−l_x, l_y) and (l_x, −l_y).
///
/// Note the convention differs from [`string_positions`] with n = 2, where l_x is the distance between the
/// two centres: `pair_positions(lx, ly) == string_positions(2, 2 lx, 2 ly)`.
pub fn pair_positions(lx: f64, ly: f64) -> Vec<[f64; 2]> {
    vec![[-lx, ly], [lx, -ly]]
}

/// Centre of a particle in circular Couette flow at dimensionless radial position
/// r0* = (r0 − R1)/(R2 − R1) (thesis 3.5.1) and polar angle `angle` (radians, counter-clockwise from +x);
/// the cylinders are centred at the origin.
pub fn couette_position(r1: f64, r2: f64, r0_star: f64, angle: f64) -> [f64; 2] {
    let r0 = r1 + r0_star * (r2 - r1);
    [r0 * angle.cos(), r0 * angle.sin()]
}

/// Dimensionless radial position r* = (r − R1)/(R2 − R1) of a point (thesis 3.5.1).
pub fn r_star(r1: f64, r2: f64, p: [f64; 2]) -> f64 {
    (p[0].hypot(p[1]) - r1) / (r2 - r1)
}

/// Gap between the surfaces of two particles of radius `radius` (negative when they overlap); with
/// `period = Some(L)` the x-distance is taken to the nearest periodic image.
pub fn surface_gap(p: [f64; 2], q: [f64; 2], radius: f64, period: Option<f64>) -> f64 {
    let dx = crate::periodic::fold(q[0] - p[0], period);
    dx.hypot(q[1] - p[1]) - 2.0 * radius
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Positions are sums and products of a few decimal numbers: only rounding error remains.
    const EXACT: f64 = 1e-12;

    #[test]
    fn three_particle_string_is_the_thesis_setup() {
        let p = string_positions(3, 0.5, 0.1);
        let want = [[-0.5, 0.1], [0.0, 0.0], [0.5, -0.1]];
        for (got, want) in p.iter().zip(want) {
            assert!((got[0] - want[0]).abs() < EXACT && (got[1] - want[1]).abs() < EXACT);
        }
    }

    #[test]
    fn strings_are_point_symmetric_with_neighbour_spacing() {
        for n in 1..=11 {
            let p = string_positions(n, 0.3, 0.05);
            assert_eq!(p.len(), n);
            for k in 0..n {
                let m = n - 1 - k;
                assert!((p[k][0] + p[m][0]).abs() < EXACT, "x symmetry n={n}");
                assert!((p[k][1] + p[m][1]).abs() < EXACT, "y symmetry n={n}");
            }
            for w in p.windows(2) {
                assert!((w[1][0] - w[0][0] - 0.3).abs() < EXACT);
                assert!((w[0][1] - w[1][1] - 0.05).abs() < EXACT);
            }
        }
    }

    #[test]
    fn pair_matches_string_with_double_spacing() {
        let a = pair_positions(0.5, 0.06);
        let b = string_positions(2, 1.0, 0.12);
        for (p, q) in a.iter().zip(&b) {
            assert!((p[0] - q[0]).abs() < EXACT && (p[1] - q[1]).abs() < EXACT);
        }
    }

    #[test]
    fn couette_position_round_trips_r_star() {
        let p = couette_position(1.0, 4.0, 0.3, 0.7);
        assert!((r_star(1.0, 4.0, p) - 0.3).abs() < EXACT);
    }

    #[test]
    fn periodic_gap_uses_nearest_image() {
        // Two particles near opposite ends of an L = 4 channel are 0.2 apart through the periodic boundary.
        let g = surface_gap([-1.9, 0.0], [1.9, 0.0], 0.05, Some(4.0));
        assert!((g - 0.1).abs() < EXACT);
        let g = surface_gap([-1.9, 0.0], [1.9, 0.0], 0.05, None);
        assert!((g - 3.7).abs() < EXACT);
    }
}
