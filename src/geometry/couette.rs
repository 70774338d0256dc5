//! Circular Couette cell (thesis §3.5.1): the annulus R1 ≤ r ≤ R2 centred at the origin, inner
//! cylinder rotating counter-clockwise at ω̄, outer cylinder at rest ([`CouetteGeometry`]), and
//! the same cell seen from a frame rotating about its axis ([`RotatingCouette`]).
//!
//! Scales: the characteristic shear rate is γ̇ = ω̄ R1/(R2 − R1) (so that Wi = λγ̇); times and
//! rotation rates are reported in units of ω̄ as in the thesis (t* = tω̄, ω* = ω/ω̄: the stored
//! `omega_star` and the figures); the radial position is r* = (r − R1)/(R2 − R1). The undisturbed flow is
//! u_θ(r) = A r + B/r, A = −ω̄ R1²/(R2² − R1²), B = ω̄ R1² R2²/(R2² − R1²), with the uniform vorticity
//! 2A.

use super::Confinement;
use crate::mesh::{Axis, Mesh, Side};
use crate::particles::{find_annulus_contact, Contact};

/// Invalid Couette geometry.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CouetteError {
    /// The radii must satisfy 0 < R1 < R2 (finite).
    #[error("cylinder radii must satisfy 0 < R1 < R2, got R1 = {r1}, R2 = {r2}")]
    Radii {
        /// Inner radius given.
        r1: f64,
        /// Outer radius given.
        r2: f64,
    },
    /// The angular velocity must be finite and non-zero (it sets the time scale).
    #[error("inner cylinder angular velocity must be finite and non-zero, got {omega}")]
    Omega {
        /// Angular velocity given.
        omega: f64,
    },
}

/// Two concentric cylinders centred at the origin; the inner one rotates, the outer one is at rest.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CouetteGeometry {
    r1: f64,
    r2: f64,
    omega: f64,
}

impl CouetteGeometry {
    /// Inner radius `r1`, outer radius `r2`, inner angular velocity `omega` (counter-clockwise
    /// positive).
    pub fn new(r1: f64, r2: f64, omega: f64) -> Result<Self, CouetteError> {
        if !(r1.is_finite() && r2.is_finite() && 0.0 < r1 && r1 < r2) {
            return Err(CouetteError::Radii { r1, r2 });
        }
        if !omega.is_finite() || omega == 0.0 {
            return Err(CouetteError::Omega { omega });
        }
        Ok(Self { r1, r2, omega })
    }

    /// Inner radius R1.
    pub fn r1(&self) -> f64 {
        self.r1
    }

    /// Outer radius R2.
    pub fn r2(&self) -> f64 {
        self.r2
    }

    /// Angular velocity ω̄ of the inner cylinder (counter-clockwise positive).
    pub fn omega(&self) -> f64 {
        self.omega
    }

    /// Gap width R2 − R1.
    pub fn gap(&self) -> f64 {
        self.r2 - self.r1
    }

    /// Characteristic shear rate γ̇ = |ω̄| R1/(R2 − R1): Wi = λγ̇ (and the steady test's time scale;
    /// results are reported in units of ω̄, see the module).
    pub fn shear_rate(&self) -> f64 {
        self.omega.abs() * self.r1 / self.gap()
    }

    /// Particle radius a = ε(R2 − R1)/2 for the confinement ratio ε = 2a/(R2 − R1).
    pub fn particle_radius(&self, confinement: f64) -> f64 {
        0.5 * confinement * self.gap()
    }

    /// Dimensionless radial position r* = (r − R1)/(R2 − R1) of a point.
    pub fn r_star(&self, x: [f64; 2]) -> f64 {
        (x[0].hypot(x[1]) - self.r1) / self.gap()
    }

    /// The point at r* = `r_star` and polar angle `angle` (radians, counter-clockwise from +x).
    pub fn position(&self, r_star: f64, angle: f64) -> [f64; 2] {
        let r = self.r1 + r_star * self.gap();
        [r * angle.cos(), r * angle.sin()]
    }

    /// Mesh of the gap: `n_theta` elements around and `n_r` uniform elements across.
    ///
    /// # Panics
    /// Panics if `n_theta` or `n_r` is zero.
    pub fn build_mesh(&self, n_theta: usize, n_r: usize) -> Mesh {
        Mesh::annulus(n_theta, Axis::uniform(self.r1, self.r2, n_r))
    }

    /// Like [`build_mesh`](Self::build_mesh) with the radial elements graded toward r* = `focus`
    /// ([`Axis::graded`] with strength `k`; k = 0 is uniform).
    ///
    /// # Panics
    /// Panics if a count is zero, `k < 0` or `focus` ∉ [0, 1].
    pub fn build_graded_mesh(&self, n_theta: usize, n_r: usize, focus: f64, k: f64) -> Mesh {
        let f = self.r1 + focus * self.gap();
        Mesh::annulus(n_theta, Axis::graded(self.r1, self.r2, n_r, f, k))
    }

    /// Velocity of the cylinder wall `side` at `x`: ω̄(−y, x) on the inner cylinder
    /// ([`Side::Bottom`]), zero on the outer one ([`Side::Top`]).
    ///
    /// # Panics
    /// Panics for [`Side::Left`] / [`Side::Right`], which an annulus does not have.
    pub fn wall_velocity(&self, side: Side, x: [f64; 2]) -> [f64; 2] {
        match side {
            Side::Bottom => [-self.omega * x[1], self.omega * x[0]],
            Side::Top => [0.0, 0.0],
            Side::Left | Side::Right => panic!("an annulus has no {side:?} side"),
        }
    }

    /// Coefficients (A, B) of the undisturbed Newtonian flow u_θ(r) = A r + B/r.
    pub fn couette_coefficients(&self) -> (f64, f64) {
        let (r1s, r2s) = (self.r1 * self.r1, self.r2 * self.r2);
        let d = r2s - r1s;
        (-self.omega * r1s / d, self.omega * r1s * r2s / d)
    }

    /// The undisturbed Newtonian velocity at `x` (Cartesian).
    pub fn couette_velocity(&self, x: [f64; 2]) -> [f64; 2] {
        let (a, b) = self.couette_coefficients();
        let f = a + b / (x[0] * x[0] + x[1] * x[1]);
        [-x[1] * f, x[0] * f]
    }

    /// The (uniform) vorticity 2A of the undisturbed Newtonian flow, counter-clockwise positive.
    pub fn couette_vorticity(&self) -> f64 {
        2.0 * self.couette_coefficients().0
    }
}

/// The lab frame (Ω = 0).
impl Confinement for CouetteGeometry {
    fn period(&self) -> Option<f64> {
        None
    }

    fn wall_velocity(&self, side: Side, x: [f64; 2]) -> [f64; 2] {
        CouetteGeometry::wall_velocity(self, side, x)
    }

    fn contact(&self, x: &[[f64; 2]], radius: &[f64], min_gap: f64) -> Option<Contact> {
        find_annulus_contact(x, radius, (self.r1(), self.r2()), min_gap)
    }

    fn shear_rate(&self) -> f64 {
        CouetteGeometry::shear_rate(self)
    }
}

/// The Couette cell seen from a frame rotating counter-clockwise at Ω about the axis: inner wall
/// at ω̄ − Ω, outer wall at −Ω. Inertialless flow with an objective constitutive model is the
/// same in a rigidly rotating frame, so a frame turning with a particle's orbit keeps the particle
/// nearly at rest on the (rotationally symmetric) mesh; velocities are relative to the frame
/// (ω_lab = ω + Ω).
#[derive(Debug, Clone, Copy)]
pub struct RotatingCouette {
    /// The cell.
    pub geometry: CouetteGeometry,
    /// Frame angular velocity Ω (counter-clockwise positive).
    pub frame: f64,
}

impl Confinement for RotatingCouette {
    fn period(&self) -> Option<f64> {
        None
    }

    /// The lab wall velocity minus the frame's rigid rotation Ω × x.
    fn wall_velocity(&self, side: Side, x: [f64; 2]) -> [f64; 2] {
        let w = self.geometry.wall_velocity(side, x);
        [w[0] + self.frame * x[1], w[1] - self.frame * x[0]]
    }

    fn contact(&self, x: &[[f64; 2]], radius: &[f64], min_gap: f64) -> Option<Contact> {
        self.geometry.contact(x, radius, min_gap)
    }

    fn shear_rate(&self) -> f64 {
        CouetteGeometry::shear_rate(&self.geometry)
    }
}
#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn geometry_scales_and_wall_velocities() {
        // all quantities are a few flops on exact inputs: round-off only
        const TOL: f64 = 1e-14;
        let g = CouetteGeometry::new(1.0, 4.0, 2.0).unwrap();
        assert!((g.shear_rate() - 2.0 / 3.0).abs() < TOL);
        assert!((g.particle_radius(4.0 / 15.0) - 0.4).abs() < TOL);
        let x = g.position(0.5, 0.3);
        assert!((g.r_star(x) - 0.5).abs() < TOL);
        // inner wall: tangential, counter-clockwise, speed ω̄R1; matches the undisturbed flow
        let xw = [0.6, 0.8];
        let uw = g.wall_velocity(Side::Bottom, xw);
        assert!((uw[0] + 1.6).abs() < TOL && (uw[1] - 1.2).abs() < TOL);
        let uc = g.couette_velocity(xw);
        assert!((uc[0] - uw[0]).abs() < TOL && (uc[1] - uw[1]).abs() < TOL);
        let uo = g.couette_velocity([0.0, 4.0]);
        assert!(uo[0].abs() < TOL && uo[1].abs() < TOL);
        assert_eq!(g.wall_velocity(Side::Top, [4.0, 0.0]), [0.0, 0.0]);
        // vorticity 2A = −2ω̄R1²/(R2² − R1²)
        assert!((g.couette_vorticity() + 4.0 / 15.0).abs() < TOL);
        assert!(CouetteGeometry::new(2.0, 1.0, 1.0).is_err());
        assert!(CouetteGeometry::new(1.0, 4.0, 0.0).is_err());
    }
}
