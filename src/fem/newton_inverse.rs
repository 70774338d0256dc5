//! Newton's method for the inverse of an element map ξ ∈ [−1, 1]² ↦ x (isoparametric Q2, any
//! [`RefMap`](crate::xfem::RefMap), or Q2 plus an ALE displacement): the one iteration behind
//! the mesh's point location, the ghost-penalty extension, the XFEM inverse map and the ALE
//! pre-images. Each caller picks the start, the iteration cap, the step tolerance and what
//! happens to iterates far outside the element, and reads the outcome its own way.

/// What keeps Newton's iterates near the element.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Bound {
    /// Nothing: the iterates go where Newton sends them.
    Free,
    /// Each iterate is clamped into [−b, b]² (extrapolated maps may fold beyond it).
    Clamp(f64),
    /// The iteration stops ([`NewtonFailure::Escaped`]) once an iterate leaves [−b, b]² or is
    /// not finite.
    Abandon(f64),
}

/// Settings of [`newton_inverse`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Newton {
    /// Newton steps before giving up.
    pub max_iter: usize,
    /// Converged once a step's largest component (in reference coordinates) is below this.
    pub step_tol: f64,
    /// What keeps the iterates near the element.
    pub bound: Bound,
}

/// Why [`newton_inverse`] stopped without converging, and where.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum NewtonFailure {
    /// The Jacobian at `xi` is singular (or not finite) to round-off relative to its entries.
    Singular {
        /// Reference point.
        xi: [f64; 2],
        /// Jacobian determinant there.
        det: f64,
    },
    /// An iterate left the box of [`Bound::Abandon`] or is not finite.
    Escaped {
        /// The iterate.
        xi: [f64; 2],
    },
    /// `max_iter` steps without converging.
    NotConverged {
        /// The last iterate.
        xi: [f64; 2],
        /// |x − X(ξ)| at the iterate before it (where the last step was computed).
        residual: f64,
    },
}

impl NewtonFailure {
    /// Where the iteration stopped.
    pub fn xi(&self) -> [f64; 2] {
        match *self {
            Self::Singular { xi, .. } | Self::Escaped { xi } | Self::NotConverged { xi, .. } => xi,
        }
    }
}

/// Solves X(ξ) = x by Newton's method from `start`. `residual(ξ)` returns x − X(ξ) and the
/// Jacobian `J[i][j] = ∂X_i/∂ξ_j`; each step is ξ ← ξ + J⁻¹ (x − X(ξ)) (then bounded by
/// `newton.bound`), and the iteration has converged once a step is below `newton.step_tol`. The
/// converged ξ is not checked against [−1, 1]²: what a point outside means is the caller's.
///
/// # Errors
/// [`NewtonFailure`]: a singular Jacobian, an escaped iterate or no convergence.
pub fn newton_inverse(
    mut residual: impl FnMut([f64; 2]) -> ([f64; 2], [[f64; 2]; 2]),
    start: [f64; 2],
    newton: &Newton,
) -> Result<[f64; 2], NewtonFailure> {
    let mut xi = start;
    let mut last = [f64::INFINITY; 2];
    for _ in 0..newton.max_iter {
        let (r, j) = residual(xi);
        last = r;
        let det = j[0][0] * j[1][1] - j[0][1] * j[1][0];
        let scale = j[0][0].abs() + j[0][1].abs() + j[1][0].abs() + j[1][1].abs();
        if !(det.abs() > 1e-300 && det.abs() > 1e-14 * scale * scale) {
            return Err(NewtonFailure::Singular { xi, det });
        }
        let step = [
            (j[1][1] * r[0] - j[0][1] * r[1]) / det,
            (-j[1][0] * r[0] + j[0][0] * r[1]) / det,
        ];
        xi = [xi[0] + step[0], xi[1] + step[1]];
        match newton.bound {
            Bound::Free => {}
            Bound::Clamp(b) => xi = xi.map(|v| v.clamp(-b, b)),
            Bound::Abandon(b) => {
                if xi.iter().any(|v| !v.is_finite() || v.abs() > b) {
                    return Err(NewtonFailure::Escaped { xi });
                }
            }
        }
        if step[0].abs().max(step[1].abs()) < newton.step_tol {
            return Ok(xi);
        }
    }
    Err(NewtonFailure::NotConverged {
        xi,
        residual: last[0].hypot(last[1]),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// x = (2ξ + ξη, η + 0.1ξ²): smooth, invertible near the reference square.
    fn bent(x: [f64; 2]) -> impl Fn([f64; 2]) -> ([f64; 2], [[f64; 2]; 2]) {
        move |xi| {
            let p = [2.0 * xi[0] + xi[0] * xi[1], xi[1] + 0.1 * xi[0] * xi[0]];
            let j = [[2.0 + xi[1], xi[0]], [0.2 * xi[0], 1.0]];
            ([x[0] - p[0], x[1] - p[1]], j)
        }
    }

    const SETTINGS: Newton = Newton {
        max_iter: 30,
        step_tol: 1e-12,
        bound: Bound::Free,
    };

    #[test]
    fn converges_to_the_reference_point() {
        let xi = [0.3, -0.6];
        let x = [2.0 * xi[0] + xi[0] * xi[1], xi[1] + 0.1 * xi[0] * xi[0]];
        let got = newton_inverse(bent(x), [0.0, 0.0], &SETTINGS).unwrap();
        assert!((got[0] - xi[0]).abs() < 1e-12 && (got[1] - xi[1]).abs() < 1e-12);
    }

    #[test]
    fn reports_singular_jacobians_escapes_and_the_cap() {
        // ∂X/∂ξ vanishes at ξ = (0, −2)
        let singular = newton_inverse(bent([0.0, 0.0]), [0.0, -2.0], &SETTINGS);
        assert!(matches!(singular, Err(NewtonFailure::Singular { .. })));
        let far = [50.0, 0.0];
        let abandon = Newton {
            bound: Bound::Abandon(2.0),
            ..SETTINGS
        };
        let escaped = newton_inverse(bent(far), [0.0, 0.0], &abandon).unwrap_err();
        assert!(matches!(escaped, NewtonFailure::Escaped { .. }));
        assert!(escaped.xi()[0] > 2.0);
        let once = Newton {
            max_iter: 1,
            ..SETTINGS
        };
        let capped = newton_inverse(bent([1.0, 0.5]), [0.0, 0.0], &once).unwrap_err();
        match capped {
            NewtonFailure::NotConverged { residual, .. } => {
                assert!((residual - 1.0f64.hypot(0.5)).abs() < 1e-15)
            }
            other => panic!("unexpected {other:?}"),
        }
    }
}
