//! Triangle quadrature rules on the reference triangle (0, 0), (1, 0), (0, 1), as pure data.
//!
//! Each table row is `[x, y, weight]`; the weights sum to the triangle area 1/2. The 6- and
//! 16-point rules are those of Dunavant (1985), exact to degree 4 and 8, used on the triangular
//! sub-domains of cut elements (thesis Table 5.1). The tabulated values were recomputed here to
//! full double precision by a Newton solve of the symmetric moment equations (they agree with
//! Dunavant's 15-digit tables) and are written in shortest round-trip form.

use super::QuadRule;

/// Centroid rule, exact to degree 1.
pub const TRI_1: [[f64; 3]; 1] = [[1.0 / 3.0, 1.0 / 3.0, 0.5]];

/// Strang–Fix interior 3-point rule, exact to degree 2.
pub const TRI_3: [[f64; 3]; 3] = [
    [1.0 / 6.0, 1.0 / 6.0, 1.0 / 6.0],
    [2.0 / 3.0, 1.0 / 6.0, 1.0 / 6.0],
    [1.0 / 6.0, 2.0 / 3.0, 1.0 / 6.0],
];

/// Dunavant 6-point rule, exact to degree 4 (two S21 orbits).
pub const TRI_6: [[f64; 3]; 6] = [
    [0.4459484909159649, 0.4459484909159649, 0.11169079483900574],
    [0.10810301816807023, 0.4459484909159649, 0.11169079483900574],
    [0.4459484909159649, 0.10810301816807023, 0.11169079483900574],
    [
        0.09157621350977074,
        0.09157621350977074,
        0.054975871827660935,
    ],
    [
        0.8168475729804585,
        0.09157621350977074,
        0.054975871827660935,
    ],
    [
        0.09157621350977074,
        0.8168475729804585,
        0.054975871827660935,
    ],
];

/// Dunavant 16-point rule, exact to degree 8 (centroid, three S21 orbits, one S111 orbit).
pub const TRI_16: [[f64; 3]; 16] = [
    [0.3333333333333333, 0.3333333333333333, 0.07215780383889359],
    [0.4592925882927232, 0.4592925882927232, 0.04754581713364231],
    [0.0814148234145537, 0.4592925882927232, 0.04754581713364231],
    [0.4592925882927232, 0.0814148234145537, 0.04754581713364231],
    [0.1705693077517602, 0.1705693077517602, 0.05160868526735912],
    [0.6588613844964796, 0.1705693077517602, 0.05160868526735912],
    [0.1705693077517602, 0.6588613844964796, 0.05160868526735912],
    [
        0.05054722831703098,
        0.05054722831703098,
        0.01622924881159904,
    ],
    [0.8989055433659381, 0.05054722831703098, 0.01622924881159904],
    [0.05054722831703098, 0.8989055433659381, 0.01622924881159904],
    [0.2631128296346381, 0.7284923929554042, 0.013615157087217496],
    [0.7284923929554042, 0.2631128296346381, 0.013615157087217496],
    [
        0.008394777409957605,
        0.7284923929554042,
        0.013615157087217496,
    ],
    [
        0.7284923929554042,
        0.008394777409957605,
        0.013615157087217496,
    ],
    [
        0.008394777409957605,
        0.2631128296346381,
        0.013615157087217496,
    ],
    [
        0.2631128296346381,
        0.008394777409957605,
        0.013615157087217496,
    ],
];

/// The tabulated triangle rules, by the polynomial degree they integrate exactly.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TriangleRule {
    /// 1 point, degree 1.
    Centroid,
    /// 3 points, degree 2.
    Degree2,
    /// Dunavant 6 points, degree 4.
    Dunavant6,
    /// Dunavant 16 points, degree 8.
    Dunavant16,
}

impl TriangleRule {
    /// The table rows `[x, y, weight]`.
    pub fn table(self) -> &'static [[f64; 3]] {
        match self {
            TriangleRule::Centroid => &TRI_1,
            TriangleRule::Degree2 => &TRI_3,
            TriangleRule::Dunavant6 => &TRI_6,
            TriangleRule::Dunavant16 => &TRI_16,
        }
    }

    /// Highest total degree integrated exactly.
    pub fn degree(self) -> u32 {
        match self {
            TriangleRule::Centroid => 1,
            TriangleRule::Degree2 => 2,
            TriangleRule::Dunavant6 => 4,
            TriangleRule::Dunavant16 => 8,
        }
    }

    /// The rule as a [`QuadRule`] on the reference triangle.
    pub fn rule(self) -> QuadRule {
        let t = self.table();
        QuadRule {
            points: t.iter().map(|r| [r[0], r[1]]).collect(),
            weights: t.iter().map(|r| r[2]).collect(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const ALL: [TriangleRule; 4] = [
        TriangleRule::Centroid,
        TriangleRule::Degree2,
        TriangleRule::Dunavant6,
        TriangleRule::Dunavant16,
    ];

    /// Exact integral of x^a y^b over the reference triangle: a! b! / (a + b + 2)!.
    fn exact_triangle(a: u32, b: u32) -> f64 {
        let fact = |n: u32| (1..=n).map(f64::from).product::<f64>();
        fact(a) * fact(b) / fact(a + b + 2)
    }

    fn apply(rule: &QuadRule, a: u32, b: u32) -> f64 {
        rule.points
            .iter()
            .zip(&rule.weights)
            .map(|(p, w)| w * p[0].powi(a as i32) * p[1].powi(b as i32))
            .sum()
    }

    #[test]
    fn triangle_rules_integrate_monomials_exactly_to_their_degree() {
        // Round-off: ≤ 16 terms of size ≤ 0.07 with values in [0, 1]; relative to the exact value.
        const TOL: f64 = 1e-14;
        for kind in ALL {
            let rule = kind.rule();
            let deg = kind.degree();
            for total in 0..=deg {
                for a in 0..=total {
                    let b = total - a;
                    let (q, e) = (apply(&rule, a, b), exact_triangle(a, b));
                    assert!(
                        ((q - e) / e).abs() < TOL,
                        "{kind:?} x^{a} y^{b}: {q:e} vs {e:e}"
                    );
                }
            }
        }
    }

    #[test]
    fn triangle_rules_are_not_exact_one_degree_higher() {
        // A genuine degree-(d+1) error is ≥ 1e-6 relative for these rules; round-off is 1e-15.
        const MIN_ERROR: f64 = 1e-6;
        for kind in ALL {
            let rule = kind.rule();
            let total = kind.degree() + 1;
            let worst = (0..=total)
                .map(|a| {
                    let e = exact_triangle(a, total - a);
                    ((apply(&rule, a, total - a) - e) / e).abs()
                })
                .fold(0.0, f64::max);
            assert!(worst > MIN_ERROR, "{kind:?} exact at degree {total}?");
        }
    }

    #[test]
    fn triangle_points_are_inside_and_weights_positive() {
        for kind in ALL {
            for r in kind.table() {
                assert!(r[0] > 0.0 && r[1] > 0.0 && r[0] + r[1] < 1.0 && r[2] > 0.0);
            }
        }
    }
}
