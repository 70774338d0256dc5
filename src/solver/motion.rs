//! Quasi-static particle motion in Stokes flow (no history fields): at each step the particles
//! are placed at the predicted positions (Eq. 5.45), the flow with force- and torque-free rigid
//! particles is solved (Eqs. 5.21–5.24 with τ = 0), and the positions are corrected with the
//! trapezoidal rule (Eqs. 5.54–5.56). Geometry: confined shear flow, periodic in x, walls at
//! y = ±H/2 moving at ±U_w/2 (thesis §5.6.1).

use crate::fem::linsolve::SolverKind;
use crate::mesh::{Mesh, Side};
use crate::particles::{correct, find_contact, predict, Contact, RigidState, CONTACT_OVERLAP};
use crate::rheology::Sym2;
use crate::solver::cutcells::{compute_cuts, CutError};
use crate::solver::flow::{Stokes, StokesParams};
use crate::solver::rigid::{Motion, Particle};
use crate::xfem::CutOptions;

/// A confined-shear set-up for quasi-static Stokes motion.
#[derive(Debug, Clone)]
pub struct ShearCase {
    /// Channel height H (walls at y = ±H/2).
    pub h: f64,
    /// Period L (x ∈ [−L/2, L/2]).
    pub l: f64,
    /// Relative wall speed U_w.
    pub wall_speed: f64,
    /// Viscosity.
    pub eta: f64,
    /// Particle radii.
    pub radius: Vec<f64>,
    /// Initial centres.
    pub x0: Vec<[f64; 2]>,
    /// Elements in x and y (uniform).
    pub mesh: [usize; 2],
    /// Largest / smallest element height across the channel, finest at the centre line (1 = uniform).
    pub grading: f64,
    /// Largest / smallest element length along the channel, finest at x = 0 (1 = uniform).
    pub grading_x: f64,
    /// Time step.
    pub dt: f64,
    /// End time.
    pub t_end: f64,
    /// Cut-cell quadrature options.
    pub cut: CutOptions,
}

/// The flow fields of the last solve, for snapshots.
#[derive(Debug, Clone)]
pub struct FlowFields {
    /// Velocity at the Q2 nodes.
    pub u: Vec<[f64; 2]>,
    /// Pressure at the Q1 vertices.
    pub p: Vec<f64>,
    /// Particles (centres wrapped into the period) of that solve.
    pub particles: Vec<Particle>,
    /// Polymer stress τ at the Q1 vertices (viscoelastic runs; empty for a Newtonian fluid).
    pub tau: Vec<Sym2>,
}

/// Rigid velocities of free particles at one configuration, with the flow that produced them.
#[derive(Debug, Clone)]
pub struct RigidSolve {
    /// Translational velocities.
    pub u: Vec<[f64; 2]>,
    /// Angular velocities (counter-clockwise positive).
    pub omega: Vec<f64>,
    /// The flow fields.
    pub fields: FlowFields,
}

/// Why a quasi-static run stopped.
#[derive(Debug, Clone, PartialEq)]
pub enum MotionEnd {
    /// End time reached.
    EndTime,
    /// The step callback asked to stop.
    Stopped,
    /// Particles touched each other or a wall (beyond the allowed overlap).
    Contact(Contact),
}

/// Errors of a quasi-static run (recorded as divergence by the sweep engine).
#[derive(Debug, thiserror::Error)]
pub enum MotionError {
    /// Cut-cell geometry failed.
    #[error("step {step}: {source}")]
    Cut {
        /// Step.
        step: u64,
        /// Cause.
        source: CutError,
    },
    /// The flow solve failed.
    #[error("step {step}: flow solve failed: {source}")]
    Solve {
        /// Step.
        step: u64,
        /// Cause.
        source: crate::fem::linsolve::SolveError,
    },
    /// Non-finite particle velocity.
    #[error("step {step}: non-finite particle velocity")]
    NonFinite {
        /// Step.
        step: u64,
    },
}

/// Wraps x into [−L/2, L/2).
fn wrap(x: f64, l: f64) -> f64 {
    x - l * ((x + 0.5 * l) / l).floor()
}

impl ShearCase {
    /// The mesh of the channel: graded along it by `grading_x` (finest at x = 0), across it by
    /// `grading` (finest at the centre line).
    pub fn build_mesh(&self) -> Mesh {
        Mesh::channel(self.h, self.l, self.mesh, self.grading, self.grading_x)
    }

    /// Velocities (U, ω) of free particles at centres `x` (ω counter-clockwise positive) and the flow.
    pub fn rigid_velocities(
        &self,
        mesh: &Mesh,
        x: &[[f64; 2]],
        step: u64,
    ) -> Result<RigidSolve, MotionError> {
        let particles: Vec<Particle> = x
            .iter()
            .zip(&self.radius)
            .map(|(c, &r)| Particle {
                center: [wrap(c[0], self.l), c[1]],
                radius: r,
                motion: Motion::Free,
            })
            .collect();
        let cuts = compute_cuts(mesh, &particles, Some(self.l), self.cut)
            .map_err(|source| MotionError::Cut { step, source })?;
        let mut st = Stokes::with_particles(
            mesh.clone(),
            StokesParams::new(self.eta, 0.0, SolverKind::Lblt),
            particles.clone(),
            cuts,
        );
        let uw = 0.5 * self.wall_speed;
        st.set_velocity(Side::Bottom, move |_| [-uw, 0.0]);
        st.set_velocity(Side::Top, move |_| [uw, 0.0]);
        st.pin_pressure();
        let sol = st
            .solve(&|_| [0.0, 0.0])
            .map_err(|source| MotionError::Solve { step, source })?;
        let u: Vec<[f64; 2]> = sol.rigid.iter().map(|r| [r[0], r[1]]).collect();
        let w: Vec<f64> = sol.rigid.iter().map(|r| r[2]).collect();
        if u.iter().flatten().chain(&w).any(|v| !v.is_finite()) {
            return Err(MotionError::NonFinite { step });
        }
        let fields = FlowFields {
            u: sol.u,
            p: sol.p,
            particles,
            tau: Vec::new(),
        };
        Ok(RigidSolve {
            u,
            omega: w,
            fields,
        })
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
        let n_steps = (self.t_end / self.dt - 1e-9).ceil() as u64;
        let walls = Some((-0.5 * self.h, 0.5 * self.h));
        let min_radius = self.radius.iter().copied().fold(f64::INFINITY, f64::min);
        for step in 1..=n_steps {
            let x_pred = predict(prev.as_ref(), &cur);
            if let Some(c) = find_contact(
                &x_pred,
                &self.radius,
                walls,
                Some(self.l),
                -CONTACT_OVERLAP * min_radius,
            ) {
                return Ok(MotionEnd::Contact(c));
            }
            let solved = self.rigid_velocities(&mesh, &x_pred, step)?;
            let next = correct(&cur, &solved.u, &solved.omega, self.dt, prev.is_none());
            prev = Some(std::mem::replace(&mut cur, next));
            if !on_step(step, step as f64 * self.dt, &cur, &mesh, &solved.fields) {
                return Ok(MotionEnd::Stopped);
            }
            if let Some(c) = find_contact(
                &cur.x,
                &self.radius,
                walls,
                Some(self.l),
                -CONTACT_OVERLAP * min_radius,
            ) {
                return Ok(MotionEnd::Contact(c));
            }
        }
        Ok(MotionEnd::EndTime)
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn wrap_maps_into_the_period() {
        assert!((super::wrap(2.5, 4.0) + 1.5).abs() < 1e-15);
        assert!((super::wrap(-2.5, 4.0) - 1.5).abs() < 1e-15);
        assert!((super::wrap(0.3, 4.0) - 0.3).abs() < 1e-15);
    }
}
