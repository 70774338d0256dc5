//! Quadrature rules as pure data: points in reference coordinates and weights.
//!
//! Quadrilateral rules live on the reference square [-1, 1]² (tensor Gauss–Legendre);
//! triangle rules (module [`triangle`]) on the reference triangle with vertices
//! (0, 0), (1, 0), (0, 1).

pub mod triangle;

/// A quadrature rule in 2D: `points[q]` with weight `weights[q]`.
#[derive(Debug, Clone, PartialEq)]
pub struct QuadRule {
    /// Quadrature points in reference coordinates.
    pub points: Vec<[f64; 2]>,
    /// Weights; they sum to the area of the reference domain.
    pub weights: Vec<f64>,
}

impl QuadRule {
    /// Number of points.
    pub fn len(&self) -> usize {
        self.weights.len()
    }

    /// True when the rule has no points.
    pub fn is_empty(&self) -> bool {
        self.weights.is_empty()
    }
}

/// Gauss–Legendre points and weights on [-1, 1] with `n` points (1 ≤ n ≤ 5),
/// exact for polynomials of degree 2n − 1.
///
/// # Panics
/// Panics for `n` outside 1..=5 (a broken contract: the element code asks for fixed orders).
pub fn gauss_legendre_1d(n: usize) -> (Vec<f64>, Vec<f64>) {
    match n {
        1 => (vec![0.0], vec![2.0]),
        2 => {
            let a = 1.0 / 3f64.sqrt();
            (vec![-a, a], vec![1.0, 1.0])
        }
        3 => {
            let a = (0.6f64).sqrt();
            (vec![-a, 0.0, a], vec![5.0 / 9.0, 8.0 / 9.0, 5.0 / 9.0])
        }
        4 => {
            let s = (6.0f64 / 5.0).sqrt();
            let a = ((3.0 - 2.0 * s) / 7.0).sqrt();
            let b = ((3.0 + 2.0 * s) / 7.0).sqrt();
            let wa = (18.0 + 30f64.sqrt()) / 36.0;
            let wb = (18.0 - 30f64.sqrt()) / 36.0;
            (vec![-b, -a, a, b], vec![wb, wa, wa, wb])
        }
        5 => {
            let s = 2.0 * (10.0f64 / 7.0).sqrt();
            let a = (5.0 - s).sqrt() / 3.0;
            let b = (5.0 + s).sqrt() / 3.0;
            let w0 = 128.0 / 225.0;
            let wa = (322.0 + 13.0 * 70f64.sqrt()) / 900.0;
            let wb = (322.0 - 13.0 * 70f64.sqrt()) / 900.0;
            (vec![-b, -a, 0.0, a, b], vec![wb, wa, w0, wa, wb])
        }
        _ => panic!("gauss_legendre_1d: {n} points not tabulated (1..=5)"),
    }
}

/// Tensor-product Gauss rule with `n`×`n` points on [-1, 1]², exact for Q_{2n−1}.
pub fn gauss_quad(n: usize) -> QuadRule {
    let (x, w) = gauss_legendre_1d(n);
    let mut points = Vec::with_capacity(n * n);
    let mut weights = Vec::with_capacity(n * n);
    for j in 0..n {
        for i in 0..n {
            points.push([x[i], x[j]]);
            weights.push(w[i] * w[j]);
        }
    }
    QuadRule { points, weights }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Exact integral of x^a y^b over [-1, 1]².
    fn exact_square(a: u32, b: u32) -> f64 {
        let m = |k: u32| {
            if k % 2 == 1 {
                0.0
            } else {
                2.0 / (k as f64 + 1.0)
            }
        };
        m(a) * m(b)
    }

    #[test]
    fn gauss_rules_integrate_monomials_exactly() {
        // Round-off tolerance: sums of ≤ 25 terms of size O(1).
        const TOL: f64 = 1e-14;
        for n in 1..=5 {
            let rule = gauss_quad(n);
            let deg = 2 * n as u32 - 1;
            for a in 0..=deg {
                for b in 0..=deg {
                    let q: f64 = rule
                        .points
                        .iter()
                        .zip(&rule.weights)
                        .map(|(p, w)| w * p[0].powi(a as i32) * p[1].powi(b as i32))
                        .sum();
                    assert!(
                        (q - exact_square(a, b)).abs() < TOL,
                        "n={n} x^{a} y^{b}: {q} vs {}",
                        exact_square(a, b)
                    );
                }
            }
            // and not exact one degree higher in x (the rule is not over-claimed)
            let a = deg + 1;
            let q: f64 = rule
                .points
                .iter()
                .zip(&rule.weights)
                .map(|(p, w)| w * p[0].powi(a as i32))
                .sum();
            assert!((q - exact_square(a, 0)).abs() > 1e-6);
        }
    }
}
