//! Small 2×2 tensors of the constitutive layer: the symmetric [`Sym2`] (conformation, log-conformation,
//! stress), the [`VelocityGradient`] `L` with the usual convention `L_ij = ∂u_i/∂x_j`, the closed-form
//! eigen-decomposition [`SymEigen`] of a symmetric 2×2, and the matrix exponential and logarithm
//! through it (`c = exp(s)`, `s = log(c)`, thesis Eqs. 2.7 and 5.7).
//!
//! Everything is `Copy`, stack-only and branch-light: these functions run at every quadrature point.

use std::ops::{Add, AddAssign, Mul, Neg, Sub};

use super::RheologyError;

/// A symmetric 2×2 tensor `[[xx, xy], [xy, yy]]` (Cartesian components); serialized as
/// `[xx, xy, yy]`.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(from = "[f64; 3]", into = "[f64; 3]")]
pub struct Sym2 {
    /// Component `xx`.
    pub xx: f64,
    /// Component `xy` (= `yx`).
    pub xy: f64,
    /// Component `yy`.
    pub yy: f64,
}

impl From<[f64; 3]> for Sym2 {
    fn from([xx, xy, yy]: [f64; 3]) -> Self {
        Sym2 { xx, xy, yy }
    }
}

impl From<Sym2> for [f64; 3] {
    fn from(s: Sym2) -> Self {
        [s.xx, s.xy, s.yy]
    }
}

impl Sym2 {
    /// The zero tensor.
    pub const ZERO: Sym2 = Sym2::new(0.0, 0.0, 0.0);
    /// The unit tensor `I`.
    pub const IDENTITY: Sym2 = Sym2::new(1.0, 0.0, 1.0);

    /// The tensor `[[xx, xy], [xy, yy]]`.
    pub const fn new(xx: f64, xy: f64, yy: f64) -> Self {
        Sym2 { xx, xy, yy }
    }

    /// `a I`.
    pub const fn scaled_identity(a: f64) -> Self {
        Sym2::new(a, 0.0, a)
    }

    /// The symmetric part `(m + mᵀ)/2` of a general matrix given by rows (`m[i][j]`).
    pub fn symmetric_part(m: [[f64; 2]; 2]) -> Self {
        Sym2::new(m[0][0], 0.5 * (m[0][1] + m[1][0]), m[1][1])
    }

    /// The full matrix by rows.
    pub fn to_rows(self) -> [[f64; 2]; 2] {
        [[self.xx, self.xy], [self.xy, self.yy]]
    }

    /// Component `(i, j)`, `i, j ∈ {0, 1}` (0 = x, 1 = y).
    ///
    /// # Panics
    /// If `i` or `j` is not 0 or 1.
    pub fn get(self, i: usize, j: usize) -> f64 {
        match (i, j) {
            (0, 0) => self.xx,
            (0, 1) | (1, 0) => self.xy,
            (1, 1) => self.yy,
            _ => panic!("Sym2 index ({i}, {j}) out of range"),
        }
    }

    /// Trace `xx + yy`.
    pub fn trace(self) -> f64 {
        self.xx + self.yy
    }

    /// Determinant `xx·yy − xy²`.
    pub fn det(self) -> f64 {
        self.xx * self.yy - self.xy * self.xy
    }

    /// Frobenius norm `sqrt(xx² + 2 xy² + yy²)`.
    pub fn norm(self) -> f64 {
        (self.xx * self.xx + 2.0 * self.xy * self.xy + self.yy * self.yy).sqrt()
    }

    /// The matrix square `a·a` (symmetric, and commuting with `a`).
    pub fn square(self) -> Self {
        Sym2::new(
            self.xx * self.xx + self.xy * self.xy,
            self.xy * self.trace(),
            self.yy * self.yy + self.xy * self.xy,
        )
    }

    /// `true` if all three components are finite.
    pub fn is_finite(self) -> bool {
        self.xx.is_finite() && self.xy.is_finite() && self.yy.is_finite()
    }

    /// `true` if the tensor is symmetric positive definite (`xx > 0` and `det > 0`; false for NaN).
    pub fn is_positive_definite(self) -> bool {
        self.xx > 0.0 && self.det() > 0.0
    }

    /// Closed-form eigen-decomposition, eigenvalues in descending order; see [`SymEigen`].
    ///
    /// With `m = (xx + yy)/2`, `p = (xx − yy)/2`, `r = sqrt(p² + xy²)` the eigenvalues are `m ± r`;
    /// the one of smaller magnitude is recomputed as `det / (the other)` (when `det` is finite),
    /// which is exact for diagonal tensors. The first eigenvector is `(cos θ, sin θ)` with `2θ = atan2(xy, p)`, computed with one
    /// square root from the half-angle formulas on the better-conditioned branch. For `r = 0`
    /// (`a = m I`, equal eigenvalues) the basis is the Cartesian one: no NaN, and every spectral
    /// function built on it ([`SymEigen::compose`]) is continuous there.
    pub fn eigen(self) -> SymEigen {
        let m = 0.5 * (self.xx + self.yy);
        let p = 0.5 * (self.xx - self.yy);
        let r = (p * p + self.xy * self.xy).sqrt();
        let (mut hi, mut lo) = (m + r, m - r);
        let det = self.det();
        if det.is_finite() {
            if m > 0.0 {
                lo = det / hi;
            } else if m < 0.0 {
                hi = det / lo;
            }
        }
        if r == 0.0 {
            return SymEigen {
                values: [hi, lo],
                cos: 1.0,
                sin: 0.0,
            };
        }
        let (cos2, sin2) = (p / r, self.xy / r);
        let (cos, sin) = if cos2 >= 0.0 {
            let c = (0.5 * (1.0 + cos2)).sqrt();
            (c, 0.5 * sin2 / c)
        } else {
            let s = (0.5 * (1.0 - cos2)).sqrt().copysign(sin2);
            // sin2 = ±0 with cos2 = −1 gives s = ±1: θ = ±π/2, both valid.
            (0.5 * sin2 / s, s)
        };
        SymEigen {
            values: [hi, lo],
            cos,
            sin,
        }
    }

    /// Matrix exponential `exp(a) = R diag(e^{μ1}, e^{μ2}) Rᵀ` (always SPD); used for `c = exp(s)`.
    pub fn exp(self) -> Self {
        let e = self.eigen();
        e.compose([e.values[0].exp(), e.values[1].exp()])
    }

    /// Matrix logarithm of an SPD tensor, `log(c) = R diag(ln μ1, ln μ2) Rᵀ`; used for `s = log(c)`.
    ///
    /// # Errors
    /// [`RheologyError::NotPositiveDefinite`] if the tensor is not SPD (or not finite).
    pub fn log(self) -> Result<Self, RheologyError> {
        let e = self.eigen();
        if !(self.is_positive_definite() && e.values[1] > 0.0 && e.values[0].is_finite()) {
            return Err(RheologyError::NotPositiveDefinite {
                xx: self.xx,
                xy: self.xy,
                yy: self.yy,
            });
        }
        Ok(e.compose([e.values[0].ln(), e.values[1].ln()]))
    }
}

impl Add for Sym2 {
    type Output = Sym2;
    fn add(self, o: Sym2) -> Sym2 {
        Sym2::new(self.xx + o.xx, self.xy + o.xy, self.yy + o.yy)
    }
}

impl AddAssign for Sym2 {
    fn add_assign(&mut self, o: Sym2) {
        *self = *self + o;
    }
}

impl Sub for Sym2 {
    type Output = Sym2;
    fn sub(self, o: Sym2) -> Sym2 {
        Sym2::new(self.xx - o.xx, self.xy - o.xy, self.yy - o.yy)
    }
}

impl Neg for Sym2 {
    type Output = Sym2;
    fn neg(self) -> Sym2 {
        Sym2::new(-self.xx, -self.xy, -self.yy)
    }
}

impl Mul<Sym2> for f64 {
    type Output = Sym2;
    fn mul(self, a: Sym2) -> Sym2 {
        Sym2::new(self * a.xx, self * a.xy, self * a.yy)
    }
}

impl Mul<f64> for Sym2 {
    type Output = Sym2;
    fn mul(self, k: f64) -> Sym2 {
        k * self
    }
}

/// Eigen-decomposition `a = R diag(values) Rᵀ` of a symmetric 2×2 tensor, with the rotation
/// `R = [[cos, −sin], [sin, cos]]`: its columns `(cos, sin)` and `(−sin, cos)` are the eigenvectors of
/// `values[0] ≥ values[1]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SymEigen {
    /// Eigenvalues, descending.
    pub values: [f64; 2],
    /// `cos θ` of the rotation from the Cartesian to the eigenbasis.
    pub cos: f64,
    /// `sin θ` of the rotation from the Cartesian to the eigenbasis.
    pub sin: f64,
}

impl SymEigen {
    /// Unit eigenvector `k ∈ {0, 1}`.
    ///
    /// # Panics
    /// If `k > 1`.
    pub fn vector(&self, k: usize) -> [f64; 2] {
        match k {
            0 => [self.cos, self.sin],
            1 => [-self.sin, self.cos],
            _ => panic!("eigenvector index {k} out of range"),
        }
    }

    /// `R diag(d) Rᵀ`: the spectral function with eigenvalues `d` on this basis. Continuous across
    /// equal eigenvalues when `d[0] − d[1] → 0` as `values[0] − values[1] → 0`.
    pub fn compose(&self, d: [f64; 2]) -> Sym2 {
        self.from_eigenbasis(Sym2::new(d[0], 0.0, d[1]))
    }

    /// `R g Rᵀ`: a symmetric tensor given by its components `g` in the eigenbasis, back to Cartesian.
    pub fn from_eigenbasis(&self, g: Sym2) -> Sym2 {
        let (c, s) = (self.cos, self.sin);
        let (cc, ss, cs) = (c * c, s * s, c * s);
        Sym2::new(
            cc * g.xx - 2.0 * cs * g.xy + ss * g.yy,
            cs * (g.xx - g.yy) + (cc - ss) * g.xy,
            ss * g.xx + 2.0 * cs * g.xy + cc * g.yy,
        )
    }

    /// `Rᵀ L R` by rows: a general tensor (here a velocity gradient) in the eigenbasis,
    /// `m[a][b] = v_aᵀ L v_b`.
    pub fn to_eigenbasis(&self, l: VelocityGradient) -> [[f64; 2]; 2] {
        let (v0, v1) = (self.vector(0), self.vector(1));
        let lv0 = l.apply(v0);
        let lv1 = l.apply(v1);
        let dot = |a: [f64; 2], b: [f64; 2]| a[0] * b[0] + a[1] * b[1];
        [[dot(v0, lv0), dot(v0, lv1)], [dot(v1, lv0), dot(v1, lv1)]]
    }
}

/// The velocity gradient `L`, **usual convention** `L_ij = ∂u_i/∂x_j` (row = velocity component).
///
/// The thesis writes `∇u` with `(∇u)_ij = ∂u_j/∂x_i` and its constitutive terms with `(∇u)ᵀ = L`:
/// the upper-convected derivative (Eq. 2.5) is `∂c/∂t + u·∇c − L·c − c·Lᵀ`, and `g((∇u)ᵀ, s)` of
/// Eq. 2.7 is our `g(L, s)`. Build it from a thesis-style `∇u` with
/// [`VelocityGradient::from_thesis_grad_u`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct VelocityGradient {
    /// `∂u/∂x = L_xx`.
    pub dudx: f64,
    /// `∂u/∂y = L_xy`.
    pub dudy: f64,
    /// `∂v/∂x = L_yx`.
    pub dvdx: f64,
    /// `∂v/∂y = L_yy`.
    pub dvdy: f64,
}

impl VelocityGradient {
    /// `L` from its four components.
    pub const fn new(dudx: f64, dudy: f64, dvdx: f64, dvdy: f64) -> Self {
        VelocityGradient {
            dudx,
            dudy,
            dvdx,
            dvdy,
        }
    }

    /// `L` from rows with `l[i][j] = ∂u_i/∂x_j`.
    pub fn from_rows(l: [[f64; 2]; 2]) -> Self {
        VelocityGradient::new(l[0][0], l[0][1], l[1][0], l[1][1])
    }

    /// `L = (∇u)ᵀ` from the thesis' `∇u`, rows `grad_u[i][j] = ∂u_j/∂x_i`.
    pub fn from_thesis_grad_u(grad_u: [[f64; 2]; 2]) -> Self {
        VelocityGradient::new(grad_u[0][0], grad_u[1][0], grad_u[0][1], grad_u[1][1])
    }

    /// Simple shear `u = (γ̇ y, 0)`: only `∂u/∂y = γ̇`.
    pub const fn simple_shear(shear_rate: f64) -> Self {
        VelocityGradient::new(0.0, shear_rate, 0.0, 0.0)
    }

    /// Rows `l[i][j] = ∂u_i/∂x_j`.
    pub fn to_rows(self) -> [[f64; 2]; 2] {
        [[self.dudx, self.dudy], [self.dvdx, self.dvdy]]
    }

    /// Component `L_ij = ∂u_i/∂x_j`, `i, j ∈ {0, 1}`.
    ///
    /// # Panics
    /// If `i` or `j` is not 0 or 1.
    pub fn get(self, i: usize, j: usize) -> f64 {
        self.to_rows()[i][j]
    }

    /// `L·v`.
    pub fn apply(self, v: [f64; 2]) -> [f64; 2] {
        [
            self.dudx * v[0] + self.dudy * v[1],
            self.dvdx * v[0] + self.dvdy * v[1],
        ]
    }

    /// Rate-of-deformation tensor `D = (L + Lᵀ)/2`.
    pub fn rate_of_deformation(self) -> Sym2 {
        Sym2::symmetric_part(self.to_rows())
    }

    /// The stretching part of the upper-convected derivative, `L·c + c·Lᵀ` (thesis `(∇u)ᵀ·c + c·∇u`).
    pub fn stretch(self, c: Sym2) -> Sym2 {
        // (L c)_ij = Σ_k L_ik c_kj; the sum with its transpose is symmetric.
        let lc_xx = self.dudx * c.xx + self.dudy * c.xy;
        let lc_xy = self.dudx * c.xy + self.dudy * c.yy;
        let lc_yx = self.dvdx * c.xx + self.dvdy * c.xy;
        let lc_yy = self.dvdx * c.xy + self.dvdy * c.yy;
        Sym2::new(2.0 * lc_xx, lc_xy + lc_yx, 2.0 * lc_yy)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rheology::test_support::{rel_diff, TestRng};

    /// Round trips (eigen-reconstruction, exp∘log, log∘exp) lose a few ulps per operation, amplified
    /// by the condition number of the spectrum (up to e^6 ≈ 400 here): 1e-12 relative is ample.
    const ROUND_TRIP_TOL: f64 = 1e-12;
    /// Independent truncated Taylor series of exp, summed to 60 terms: agreement to roundoff.
    const TAYLOR_TOL: f64 = 1e-13;
    /// A 2×2 product is two multiplications and one addition per entry: a few ulps.
    const PRODUCT_TOL: f64 = 1e-14;

    fn matmul(a: [[f64; 2]; 2], b: [[f64; 2]; 2]) -> [[f64; 2]; 2] {
        let mut m = [[0.0; 2]; 2];
        for i in 0..2 {
            for j in 0..2 {
                m[i][j] = a[i][0] * b[0][j] + a[i][1] * b[1][j];
            }
        }
        m
    }

    /// Random SPD tensors with log-eigenvalues in [−3, 3], plus exact and near-equal eigenvalues.
    fn samples() -> Vec<Sym2> {
        let mut rng = TestRng::new(7);
        let mut v: Vec<Sym2> = (0..200).map(|_| rng.spd(3.0)).collect();
        for mu in [1.0, 0.3, 25.0] {
            v.push(Sym2::scaled_identity(mu));
            let e = Sym2::new(0.3, 0.4, -0.1).eigen();
            v.push(e.compose([mu * (1.0 + 1e-12), mu]));
            v.push(e.compose([mu * (1.0 + 1e-7), mu]));
        }
        v.push(Sym2::new(2.0, 0.0, 5.0)); // diagonal, ascending
        v.push(Sym2::new(5.0, 0.0, 2.0));
        v
    }

    #[test]
    fn eigen_reconstructs_and_is_orthonormal() {
        for a in samples() {
            let e = a.eigen();
            assert!(e.values[0] >= e.values[1], "{a:?}");
            assert!((e.cos * e.cos + e.sin * e.sin - 1.0).abs() < ROUND_TRIP_TOL);
            let back = e.compose(e.values);
            assert!(rel_diff(back, a) < ROUND_TRIP_TOL, "{a:?} -> {back:?}");
            // A v = μ v for both eigenpairs.
            let rows = a.to_rows();
            for k in 0..2 {
                let v = e.vector(k);
                for i in 0..2 {
                    let av = rows[i][0] * v[0] + rows[i][1] * v[1];
                    assert!((av - e.values[k] * v[i]).abs() < ROUND_TRIP_TOL * a.norm());
                }
            }
            // Invariants: trace and determinant.
            assert!((e.values[0] + e.values[1] - a.trace()).abs() < ROUND_TRIP_TOL * a.norm());
            assert!(
                (e.values[0] * e.values[1] - a.det()).abs() < ROUND_TRIP_TOL * a.norm().powi(2)
            );
        }
    }

    #[test]
    fn exp_log_round_trips() {
        let mut worst: f64 = 0.0;
        for c in samples() {
            let s = c.log().expect("sample is SPD");
            assert!(s.is_finite());
            worst = worst
                .max(rel_diff(s.exp(), c))
                .max(rel_diff(s.exp().log().unwrap(), s));
            assert!(
                rel_diff(s.exp(), c) < ROUND_TRIP_TOL,
                "exp(log c) != c for {c:?}"
            );
            assert!(
                rel_diff(s.exp().log().unwrap(), s) < ROUND_TRIP_TOL,
                "log(exp s) != s"
            );
        }
        eprintln!("exp/log round trips: worst relative difference {worst:.2e}");
    }

    #[test]
    fn exp_matches_taylor_series_and_log_of_identity_is_zero() {
        let mut rng = TestRng::new(11);
        for _ in 0..50 {
            let s = Sym2::new(
                rng.uniform(-1.5, 1.5),
                rng.uniform(-1.5, 1.5),
                rng.uniform(-1.5, 1.5),
            );
            let a = s.to_rows();
            let (mut term, mut sum) = ([[1.0, 0.0], [0.0, 1.0]], [[1.0, 0.0], [0.0, 1.0]]);
            for k in 1..60 {
                term = matmul(term, a);
                for row in term.iter_mut() {
                    for x in row.iter_mut() {
                        *x /= k as f64;
                    }
                }
                for i in 0..2 {
                    for j in 0..2 {
                        sum[i][j] += term[i][j];
                    }
                }
            }
            assert!(rel_diff(s.exp(), Sym2::symmetric_part(sum)) < TAYLOR_TOL);
        }
        assert_eq!(Sym2::IDENTITY.log().unwrap(), Sym2::ZERO);
        assert_eq!(Sym2::ZERO.exp(), Sym2::IDENTITY);
    }

    #[test]
    fn log_rejects_non_spd() {
        for bad in [
            Sym2::new(1.0, 2.0, 1.0),
            Sym2::new(-1.0, 0.0, 2.0),
            Sym2::ZERO,
            Sym2::new(f64::NAN, 0.0, 1.0),
        ] {
            assert!(matches!(
                bad.log(),
                Err(RheologyError::NotPositiveDefinite { .. })
            ));
        }
    }

    #[test]
    fn stretch_is_l_c_plus_c_lt() {
        let mut rng = TestRng::new(3);
        for _ in 0..20 {
            let l = rng.gradient(2.0);
            let c = rng.spd(2.0);
            let lc = matmul(l.to_rows(), c.to_rows());
            let clt = matmul(c.to_rows(), [[l.dudx, l.dvdx], [l.dudy, l.dvdy]]);
            let want = Sym2::new(
                lc[0][0] + clt[0][0],
                lc[0][1] + clt[0][1],
                lc[1][1] + clt[1][1],
            );
            let scale = c.norm() * 4.0; // |L| ≤ 2 per entry
            assert!((lc[1][0] + clt[1][0] - want.xy).abs() < PRODUCT_TOL * scale);
            assert!(rel_diff(l.stretch(c), want) < PRODUCT_TOL * 4.0);
            // Convention check: the thesis' ∇u is the transpose of L.
            let t = VelocityGradient::from_thesis_grad_u([[l.dudx, l.dvdx], [l.dudy, l.dvdy]]);
            assert_eq!(t, l);
        }
    }
}
