//! Circular Couette cell (thesis §3.5.1): the annulus R1 ≤ r ≤ R2 centred at the origin, inner
//! cylinder rotating counter-clockwise at ω̄, outer cylinder at rest; and the quasi-static Stokes
//! motion of free particles in it, the same pipeline as the channel's
//! [`ShearCase`](crate::solver::motion::ShearCase): predict (Eq. 5.45) → classify (cut cells) →
//! solve the flow with force- and torque-free particles (Eqs. 5.21–5.24, τ = 0) → correct
//! (trapezoidal, Eqs. 5.54–5.56) → contact check.
//!
//! Scales: the characteristic shear rate is γ̇ = ω̄ R1/(R2 − R1) (so that Wi = λγ̇), with
//! t* = tγ̇ and ω* = ω/γ̇; the radial position is r* = (r − R1)/(R2 − R1). The undisturbed flow is
//! u_θ(r) = A r + B/r, A = −ω̄ R1²/(R2² − R1²), B = ω̄ R1² R2²/(R2² − R1²), with the uniform vorticity
//! 2A.

use crate::fem::linsolve::SolverKind;
use crate::mesh::{Axis, Mesh, Side};
use crate::particles::{correct, find_annulus_contact, predict, RigidState, CONTACT_OVERLAP};
use crate::solver::cutcells::compute_cuts;
use crate::solver::flow::{Stokes, StokesParams};
use crate::solver::motion::{FlowFields, MotionEnd, MotionError, RigidSolve};
use crate::solver::rigid::{Motion, Particle};
use crate::xfem::CutOptions;

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

    /// Characteristic shear rate γ̇ = |ω̄| R1/(R2 − R1): t* = tγ̇, ω* = ω/γ̇, Wi = λγ̇.
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

/// Quasi-static Stokes motion of free particles in a circular Couette cell.
#[derive(Debug, Clone)]
pub struct CouetteCase {
    /// Cylinders and their rotation.
    pub geometry: CouetteGeometry,
    /// Viscosity.
    pub eta: f64,
    /// Particle radii.
    pub radius: Vec<f64>,
    /// Initial centres.
    pub x0: Vec<[f64; 2]>,
    /// Elements around and across (uniform).
    pub mesh: [usize; 2],
    /// Time step.
    pub dt: f64,
    /// End time.
    pub t_end: f64,
    /// Cut-cell quadrature options.
    pub cut: CutOptions,
}

impl CouetteCase {
    /// The mesh of the gap.
    pub fn build_mesh(&self) -> Mesh {
        self.geometry.build_mesh(self.mesh[0], self.mesh[1])
    }

    /// Velocities (U, ω) of free particles at centres `x` (ω counter-clockwise positive) and the
    /// flow. The annulus elements carry physical coordinates across the θ seam, so the cut cells
    /// need no period.
    pub fn rigid_velocities(
        &self,
        mesh: &Mesh,
        x: &[[f64; 2]],
        step: u64,
    ) -> Result<RigidSolve, MotionError> {
        let particles: Vec<Particle> = x
            .iter()
            .zip(&self.radius)
            .map(|(&center, &radius)| Particle {
                center,
                radius,
                motion: Motion::Free,
            })
            .collect();
        let cuts = compute_cuts(mesh, &particles, None, self.cut)
            .map_err(|source| MotionError::Cut { step, source })?;
        let mut st = Stokes::with_particles(
            mesh.clone(),
            StokesParams::new(self.eta, 0.0, SolverKind::Lblt),
            particles.clone(),
            cuts,
        );
        let g = self.geometry;
        st.set_velocity(Side::Bottom, move |x| g.wall_velocity(Side::Bottom, x));
        st.set_velocity(Side::Top, move |x| g.wall_velocity(Side::Top, x));
        st.pin_pressure();
        let sol = st
            .solve(&|_| [0.0, 0.0])
            .map_err(|source| MotionError::Solve { step, source })?;
        let u: Vec<[f64; 2]> = sol.rigid.iter().map(|r| [r[0], r[1]]).collect();
        let omega: Vec<f64> = sol.rigid.iter().map(|r| r[2]).collect();
        if u.iter().flatten().chain(&omega).any(|v| !v.is_finite()) {
            return Err(MotionError::NonFinite { step });
        }
        let fields = FlowFields {
            u: sol.u,
            p: sol.p,
            particles,
            tau: Vec::new(),
        };
        Ok(RigidSolve { u, omega, fields })
    }

    /// Runs to `t_end`; `on_step(step, t, state, mesh, fields)` is called after every step (and
    /// with step 0 for the initial state, whose velocities are solved too) with the flow of that
    /// step's solve (at the predicted configuration), and returns false to stop.
    pub fn run(
        &self,
        on_step: &mut dyn FnMut(u64, f64, &RigidState, &Mesh, &FlowFields) -> bool,
    ) -> Result<MotionEnd, MotionError> {
        let mesh = self.build_mesh();
        let mut cur = RigidState::at_rest(self.x0.clone());
        let first = self.rigid_velocities(&mesh, &cur.x, 0)?;
        cur.u = first.u;
        cur.omega = first.omega;
        if !on_step(0, 0.0, &cur, &mesh, &first.fields) {
            return Ok(MotionEnd::Stopped);
        }
        let mut prev: Option<RigidState> = None;
        // the end time counts as reached within round-off of t_end/dt
        let n_steps = (self.t_end / self.dt - 1e-9).ceil() as u64;
        let cylinders = (self.geometry.r1, self.geometry.r2);
        let min_radius = self.radius.iter().copied().fold(f64::INFINITY, f64::min);
        let min_gap = -CONTACT_OVERLAP * min_radius;
        for step in 1..=n_steps {
            let x_pred = predict(prev.as_ref(), &cur);
            if let Some(c) = find_annulus_contact(&x_pred, &self.radius, cylinders, min_gap) {
                return Ok(MotionEnd::Contact(c));
            }
            let solved = self.rigid_velocities(&mesh, &x_pred, step)?;
            let next = correct(&cur, &solved.u, &solved.omega, self.dt, prev.is_none());
            prev = Some(std::mem::replace(&mut cur, next));
            if !on_step(step, step as f64 * self.dt, &cur, &mesh, &solved.fields) {
                return Ok(MotionEnd::Stopped);
            }
            if let Some(c) = find_annulus_contact(&cur.x, &self.radius, cylinders, min_gap) {
                return Ok(MotionEnd::Contact(c));
            }
        }
        Ok(MotionEnd::EndTime)
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
