//! Rigid particles moving freely (or with prescribed velocities) in a viscoelastic fluid on the
//! fixed mesh: the full time step of thesis §5.3.4,
//!
//! predict (Eqs. 5.45–5.47) → ale_map (temporary ALE, §5.3.3: sⁿ, s^{n−1}, Gⁿ carried onto the
//! predicted configuration, mesh velocity of Eq. 5.44) → classify (cut cells at the predicted
//! positions) → solve_flow (u, p, U_i, ω_i with force- and torque-free particles imposed weakly,
//! Eq. 5.48) → solve_stress (SUPG/BDF2 with u − u_m, Eq. 5.52) → correct (trapezoidal rule,
//! Eqs. 5.54–5.56) → observe (contact, divergence, steady rotation of §5.7.2).
//!
//! Two confinements: [`ShearDomain`] (walls at y = ±H/2 sliding at ±U_w/2, periodic in x) and
//! the circular Couette flow of [`crate::solver::couette`].

use std::time::Instant;

pub use crate::mesh::follow::FollowingMesh;
use crate::mesh::{Axis, Mesh, Side};
use crate::particles::{
    correct, find_annulus_contact, find_contact, predict, Contact, RigidState, CONTACT_OVERLAP,
};
use crate::solver::ale::{AleError, Remap, RigidMove, TemporaryAle};
use crate::solver::couette::CouetteGeometry;
use crate::solver::cutcells::{compute_cuts, CutError};
use crate::solver::rigid::{Motion, Particle};
use crate::solver::viscoelastic::{
    FlowState, HistoryMap, StepReport, ViscoelasticError, ViscoelasticFlow, ViscoelasticParams,
};
use crate::xfem::CutOptions;

/// Steady rotation of §5.7.2: |ω*(tⁿ⁺¹) − ω*(tⁿ)| below this for every particle.
pub const STEADY_ROTATION_TOL: f64 = 1e-6;

/// Where the particles move: walls, periodicity, contact and the characteristic shear rate.
pub trait Domain: Send + Sync {
    /// Period in x of a periodic rectangle (`None` otherwise; the annulus needs none).
    fn period(&self) -> Option<f64>;
    /// Sets the wall velocities (and pins the pressure where the flow is enclosed).
    fn apply_walls(&self, flow: &mut ViscoelasticFlow);
    /// A particle–particle or particle–wall gap below `min_gap`.
    fn contact(&self, x: &[[f64; 2]], radius: &[f64], min_gap: f64) -> Option<Contact>;
    /// Characteristic shear rate γ̇ (t* = tγ̇, ω* = ω/γ̇).
    fn shear_rate(&self) -> f64;
    /// The point moved into the period (identity without one).
    fn wrap(&self, x: [f64; 2]) -> [f64; 2] {
        match self.period() {
            Some(l) => [x[0] - l * (x[0] / l).round(), x[1]],
            None => x,
        }
    }
}

/// Confined shear flow (thesis §5.6.1): walls at y = ±H/2 moving at drift ± U_w/2, periodic in
/// x with period L centred on x = 0.
#[derive(Debug, Clone, Copy)]
pub struct ShearDomain {
    /// Channel height H.
    pub h: f64,
    /// Period L.
    pub l: f64,
    /// Relative wall speed U_w (γ̇ = U_w/H).
    pub wall_speed: f64,
    /// Velocity in x common to both walls (0 for the thesis' set-ups; −U puts a body moving at U
    /// through fluid at rest into its own frame).
    pub drift: f64,
}

impl Domain for ShearDomain {
    fn period(&self) -> Option<f64> {
        Some(self.l)
    }

    fn apply_walls(&self, flow: &mut ViscoelasticFlow) {
        let (uw, d) = (0.5 * self.wall_speed, self.drift);
        flow.set_velocity(Side::Bottom, move |_| [d - uw, 0.0]);
        flow.set_velocity(Side::Top, move |_| [d + uw, 0.0]);
        flow.pin_pressure();
    }

    fn contact(&self, x: &[[f64; 2]], radius: &[f64], min_gap: f64) -> Option<Contact> {
        let walls = Some((-0.5 * self.h, 0.5 * self.h));
        find_contact(x, radius, walls, Some(self.l), min_gap)
    }

    fn shear_rate(&self) -> f64 {
        self.wall_speed / self.h
    }
}

/// Circular Couette flow (thesis §3.5): inner cylinder rotating at ω̄, outer at rest, no period.
impl Domain for CouetteGeometry {
    fn period(&self) -> Option<f64> {
        None
    }

    fn apply_walls(&self, flow: &mut ViscoelasticFlow) {
        // the lab frame is the rotating one at Ω = 0
        RotatingCouette {
            geometry: *self,
            frame: 0.0,
        }
        .apply_walls(flow);
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

impl Domain for RotatingCouette {
    fn period(&self) -> Option<f64> {
        None
    }

    fn apply_walls(&self, flow: &mut ViscoelasticFlow) {
        let (g, frame) = (self.geometry, self.frame);
        // the lab wall velocity minus the frame's rigid rotation Ω × x
        let relative = move |side: Side, x: [f64; 2]| {
            let w = g.wall_velocity(side, x);
            [w[0] + frame * x[1], w[1] - frame * x[0]]
        };
        flow.set_velocity(Side::Bottom, move |x| relative(Side::Bottom, x));
        flow.set_velocity(Side::Top, move |x| relative(Side::Top, x));
        flow.pin_pressure();
    }

    fn contact(&self, x: &[[f64; 2]], radius: &[f64], min_gap: f64) -> Option<Contact> {
        self.geometry.contact(x, radius, min_gap)
    }

    fn shear_rate(&self) -> f64 {
        CouetteGeometry::shear_rate(&self.geometry)
    }
}

/// Why a run stopped.
#[derive(Debug, Clone, PartialEq)]
pub enum MovingEnd {
    /// End time reached.
    EndTime,
    /// Every particle rotates steadily (§5.7.2) and the caller asked to stop there.
    Steady,
    /// The step callback asked to stop.
    Stopped,
    /// Particles touched each other or a wall.
    Contact(Contact),
}

/// Errors of a moving-particle run; the sweep engine records them as divergence.
#[derive(Debug, thiserror::Error)]
pub enum MovingError {
    /// Cut-cell geometry failed.
    #[error("step {step}: {source}")]
    Cut {
        /// Step.
        step: usize,
        /// Cause.
        source: CutError,
    },
    /// The temporary ALE map failed.
    #[error("step {step}: temporary ALE map: {source}")]
    Ale {
        /// Step.
        step: usize,
        /// Cause.
        source: AleError,
    },
    /// A flow or stress solve failed.
    #[error(transparent)]
    Flow(#[from] ViscoelasticError),
    /// A particle velocity is not finite.
    #[error("step {step}: non-finite particle velocity")]
    NonFinite {
        /// Step.
        step: usize,
    },
    /// The mesh that follows the particles cannot be built around their positions.
    #[error("step {step}: mesh that follows the particles: {reason}")]
    Follow {
        /// Step.
        step: usize,
        /// Cause.
        reason: String,
    },
    /// Inconsistent set-up.
    #[error("{0}")]
    Setup(String),
}

/// The computational mesh of a moving-particle run.
#[derive(Debug, Clone)]
pub enum ComputationalMesh {
    /// The same mesh at every step.
    Fixed(Mesh),
    /// Refined around the particles at every step.
    Following(FollowingMesh),
}

impl From<Mesh> for ComputationalMesh {
    fn from(mesh: Mesh) -> Self {
        ComputationalMesh::Fixed(mesh)
    }
}

impl From<FollowingMesh> for ComputationalMesh {
    fn from(mesh: FollowingMesh) -> Self {
        ComputationalMesh::Following(mesh)
    }
}

/// Wall-clock seconds of the particle-specific phases of one step (the flow and stress phases
/// are in [`StepReport::timings`]).
#[derive(Debug, Clone, Copy, Default)]
pub struct MovingTimings {
    /// Mesh displacement, point location and mapping of the history.
    pub ale: f64,
    /// Level set and cut-cell quadrature at the predicted positions.
    pub classify: f64,
    /// Whole step.
    pub total: f64,
}

/// What one step did.
#[derive(Debug, Clone)]
pub struct MovingReport {
    /// The fluid step.
    pub flow: StepReport,
    /// max over particles of |ω*(tⁿ⁺¹) − ω*(tⁿ)|.
    pub d_omega_star: f64,
    /// All particles rotate steadily.
    pub steady: bool,
    /// Timings of the particle phases.
    pub timings: MovingTimings,
}

/// Everything a moving-particle run needs to continue from the end of a step in another process
/// (see [`MovingParticles::checkpoint`]).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct MovingCheckpoint {
    /// Xⁿ, Uⁿ, ωⁿ.
    pub cur: RigidState,
    /// Xⁿ⁻¹.
    pub prev: Option<RigidState>,
    /// X̂ⁿ, where the fields were computed.
    pub fields_at: Vec<[f64; 2]>,
    /// The ALE mesh displacement of the last step (BDF2 mesh velocity).
    pub ale_displacement: Option<Vec<[f64; 2]>>,
    /// The vertex coordinates along x and y of the mesh that displacement was solved on, when
    /// the mesh follows the particles (absent in checkpoints of fixed-mesh runs).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ale_axes: Option<(Vec<f64>, Vec<f64>)>,
    /// The fluid.
    pub flow: FlowState,
}

/// A viscoelastic flow with moving rigid particles.
pub struct MovingParticles<D: Domain> {
    domain: D,
    flow: ViscoelasticFlow,
    ale: TemporaryAle,
    radius: Vec<f64>,
    motion: Vec<Motion>,
    cut: CutOptions,
    /// Xⁿ, Uⁿ, ωⁿ.
    cur: RigidState,
    /// Xⁿ⁻¹ (none before the first step).
    prev: Option<RigidState>,
    /// X̂ⁿ: the (predicted) positions at which the current fields were computed.
    fields_at: Vec<[f64; 2]>,
    dt: f64,
    /// The mesh that follows the particles (`None`: fixed mesh).
    follow: Option<FollowingMesh>,
}

impl<D: Domain> MovingParticles<D> {
    /// Places the particles at `x0` in the fluid at rest and solves the initial flow (τ = 0),
    /// which gives the initial particle velocities; `mesh` is a fixed [`Mesh`] or a
    /// [`FollowingMesh`] (then the run starts on its mesh at `x0`).
    ///
    /// # Errors
    /// [`MovingError::Setup`] for mismatched lengths,
    /// [`MovingError::Follow`] if the refinement does not fit around `x0`, [`MovingError::Cut`]
    /// or [`MovingError::Flow`] if the geometry or the first solve fails.
    pub fn new(
        mesh: impl Into<ComputationalMesh>,
        params: ViscoelasticParams,
        domain: D,
        x0: Vec<[f64; 2]>,
        radius: Vec<f64>,
        motion: Vec<Motion>,
        cut: CutOptions,
    ) -> Result<Self, MovingError> {
        let (mesh, follow) = match mesh.into() {
            ComputationalMesh::Fixed(mesh) => (mesh, None),
            ComputationalMesh::Following(f) => {
                let mesh = f
                    .mesh_at(&x0)
                    .map_err(|reason| MovingError::Follow { step: 0, reason })?;
                (mesh, Some(f))
            }
        };
        if x0.len() != radius.len() || x0.len() != motion.len() {
            return Err(MovingError::Setup(format!(
                "{} positions, {} radii and {} motions: one of each per particle",
                x0.len(),
                radius.len(),
                motion.len()
            )));
        }
        let particles = make_particles(&domain, &x0, &radius, &motion);
        let cuts = compute_cuts(&mesh, &particles, domain.period(), cut)
            .map_err(|source| MovingError::Cut { step: 0, source })?;
        let ale = TemporaryAle::new(&mesh);
        let mut flow = ViscoelasticFlow::with_particles(mesh, params, particles, cuts)?;
        domain.apply_walls(&mut flow);
        flow.start(&|_| [0.0, 0.0])?;
        let mut cur = RigidState::at_rest(x0.clone());
        set_velocities(&mut cur, flow.rigid_velocities());
        if !finite(&cur) {
            return Err(MovingError::NonFinite { step: 0 });
        }
        Ok(Self {
            domain,
            flow,
            ale,
            radius,
            motion,
            cut,
            cur,
            prev: None,
            fields_at: x0,
            dt: params.dt,
            follow,
        })
    }

    /// [`new`](Self::new) for `x0.len()` free particles of one radius.
    ///
    /// # Errors
    /// As [`new`](Self::new).
    pub fn free(
        mesh: impl Into<ComputationalMesh>,
        params: ViscoelasticParams,
        domain: D,
        x0: Vec<[f64; 2]>,
        radius: f64,
        cut: CutOptions,
    ) -> Result<Self, MovingError> {
        let n = x0.len();
        Self::new(
            mesh,
            params,
            domain,
            x0,
            vec![radius; n],
            vec![Motion::Free; n],
            cut,
        )
    }

    /// One time step; `Ok(Err(contact))` when the predicted particles would touch (the step is
    /// not taken).
    ///
    /// # Errors
    /// [`MovingError`] when the geometry, the ALE map or a solve fails, or velocities blow up.
    pub fn step(&mut self) -> Result<Result<MovingReport, Contact>, MovingError> {
        let t_step = Instant::now();
        let step = self.flow.history().steps() + 1;
        let min_gap = -CONTACT_OVERLAP * self.radius.iter().copied().fold(f64::INFINITY, f64::min);
        // 1. predict
        let x_pred = predict(self.prev.as_ref(), &self.cur);
        if let Some(c) = self.domain.contact(&x_pred, &self.radius, min_gap) {
            return Ok(Err(c));
        }
        // 2. ale_map: the mesh follows the particles from X̂ⁿ to X̂ⁿ⁺¹
        let t0 = Instant::now();
        let moves: Vec<RigidMove> = self
            .fields_at
            .iter()
            .zip(&x_pred)
            .zip(&self.radius)
            .map(|((from, to), &radius)| RigidMove {
                center: self.domain.wrap(*from),
                radius,
                displacement: [to[0] - from[0], to[1] - from[1]],
            })
            .collect();
        let first_order = self.flow.history().previous.is_none();
        // the computational mesh of the coming step: refined around X̂ⁿ⁺¹ if it follows them
        let onto = match &self.follow {
            Some(f) => Some(
                f.mesh_at(&x_pred)
                    .map_err(|reason| MovingError::Follow { step, reason })?,
            ),
            None => None,
        };
        let target = onto.as_ref().unwrap_or(self.flow.mesh());
        let map = self
            .ale
            .advance_onto(
                self.flow.mesh(),
                target,
                &moves,
                self.domain.period(),
                self.dt,
                first_order,
            )
            .map_err(|source| MovingError::Ale { step, source })?;
        let ale = t0.elapsed().as_secs_f64();
        // 3. classify at the predicted configuration
        let t1 = Instant::now();
        let particles = make_particles(&self.domain, &x_pred, &self.radius, &self.motion);
        let cuts = compute_cuts(target, &particles, self.domain.period(), self.cut)
            .map_err(|source| MovingError::Cut { step, source })?;
        let classify = t1.elapsed().as_secs_f64();
        let t2 = Instant::now();
        self.flow.move_particles_onto(
            onto,
            particles,
            cuts,
            HistoryMap {
                at_n: &map.at_n,
                at_n_minus_1: map.at_n_minus_1.as_deref(),
                mesh_velocity: &map.mesh_velocity,
            },
        )?;
        let ale = ale + t2.elapsed().as_secs_f64();
        // 4.–5. solve_flow, solve_stress
        let flow = self.flow.step(&|_| [0.0, 0.0])?;
        // 6. correct
        let rigid = self.flow.rigid_velocities();
        let u: Vec<[f64; 2]> = rigid.iter().map(|r| [r[0], r[1]]).collect();
        let omega: Vec<f64> = rigid.iter().map(|r| r[2]).collect();
        let next = correct(&self.cur, &u, &omega, self.dt, self.prev.is_none());
        if !finite(&next) {
            return Err(MovingError::NonFinite { step });
        }
        // γ̇ = 0 (a body pushed through fluid at rest): ω in the units of the problem
        let rate = Some(self.domain.shear_rate())
            .filter(|r| *r > 0.0)
            .unwrap_or(1.0);
        let d_omega_star = next
            .omega
            .iter()
            .zip(&self.cur.omega)
            .map(|(a, b)| (a - b).abs() / rate)
            .fold(0.0, f64::max);
        self.prev = Some(std::mem::replace(&mut self.cur, next));
        self.fields_at = x_pred;
        Ok(Ok(MovingReport {
            flow,
            d_omega_star,
            steady: d_omega_star < STEADY_ROTATION_TOL,
            timings: MovingTimings {
                ale,
                classify,
                total: t_step.elapsed().as_secs_f64(),
            },
        }))
    }

    /// Steps until `t_end`, a contact, the steady rotation (if `stop_when_steady`) or until
    /// `observe` returns false; `observe` sees every step.
    ///
    /// # Errors
    /// As [`step`](Self::step).
    pub fn run(
        &mut self,
        t_end: f64,
        stop_when_steady: bool,
        mut observe: impl FnMut(&Self, &MovingReport) -> bool,
    ) -> Result<MovingEnd, MovingError> {
        let n_steps = (t_end / self.dt - 1e-9).ceil() as usize;
        let min_gap = -CONTACT_OVERLAP * self.radius.iter().copied().fold(f64::INFINITY, f64::min);
        while self.flow.history().steps() < n_steps {
            let rep = match self.step()? {
                Ok(rep) => rep,
                Err(c) => return Ok(MovingEnd::Contact(c)),
            };
            if !observe(self, &rep) {
                return Ok(MovingEnd::Stopped);
            }
            if let Some(c) = self.domain.contact(&self.cur.x, &self.radius, min_gap) {
                return Ok(MovingEnd::Contact(c));
            }
            if stop_when_steady && rep.steady {
                return Ok(MovingEnd::Steady);
            }
        }
        Ok(MovingEnd::EndTime)
    }

    /// The state after the last step, from which [`restore`](Self::restore) continues the run.
    pub fn checkpoint(&self) -> MovingCheckpoint {
        MovingCheckpoint {
            cur: self.cur.clone(),
            prev: self.prev.clone(),
            fields_at: self.fields_at.clone(),
            ale_displacement: self.ale.last_displacement().map(<[_]>::to_vec),
            ale_axes: self
                .follow
                .as_ref()
                .and(self.ale.last_axes())
                .map(|(ax, ay)| (ax.vertices.clone(), ay.vertices.clone())),
            flow: self.flow.state(),
        }
    }

    /// Continues from a [`checkpoint`](Self::checkpoint) of the same set-up (mesh, parameters,
    /// particles): the following steps equal those of the run that wrote it up to round-off.
    ///
    /// # Errors
    /// [`MovingError::Setup`] if the checkpoint has another particle count,
    /// [`MovingError::Cut`] if the saved positions cannot be cut into the mesh,
    /// [`MovingError::Flow`] if the fields do not fit the mesh.
    pub fn restore(&mut self, cp: MovingCheckpoint) -> Result<(), MovingError> {
        let n = self.radius.len();
        let lens = [cp.cur.x.len(), cp.fields_at.len()];
        if lens.iter().any(|&l| l != n) || cp.prev.as_ref().is_some_and(|p| p.x.len() != n) {
            return Err(MovingError::Setup(format!(
                "the checkpoint has {} particles, this case {n}",
                cp.cur.x.len()
            )));
        }
        let step = cp.flow.history.steps();
        let particles = make_particles(&self.domain, &cp.fields_at, &self.radius, &self.motion);
        // a mesh that follows the particles is a function of the positions the fields are at
        let mesh = match &self.follow {
            Some(f) => Some(
                f.mesh_at(&cp.fields_at)
                    .map_err(|reason| MovingError::Follow { step, reason })?,
            ),
            None => None,
        };
        let on = mesh.as_ref().unwrap_or(self.flow.mesh());
        let cuts = compute_cuts(on, &particles, self.domain.period(), self.cut)
            .map_err(|source| MovingError::Cut { step, source })?;
        let ale_mesh = match (&self.follow, cp.ale_axes) {
            (Some(f), Some((ax, ay))) => {
                let fits = (ax.len(), ay.len()) == (f.base.ax.len() + 1, f.base.ay.len() + 1);
                if !fits {
                    return Err(MovingError::Setup(
                        "the checkpoint's ALE mesh has other element counts".into(),
                    ));
                }
                Some(
                    f.base
                        .with_axes(Axis { vertices: ax }, Axis { vertices: ay }),
                )
            }
            _ => None,
        };
        self.ale
            .set_last_displacement(cp.ale_displacement, ale_mesh.as_ref().unwrap_or(on))
            .map_err(|source| MovingError::Ale { step, source })?;
        self.flow.restore_on(mesh, cp.flow, particles, cuts)?;
        self.cur = cp.cur;
        self.prev = cp.prev;
        self.fields_at = cp.fields_at;
        Ok(())
    }

    /// Positions, orientations and velocities at the current time level.
    pub fn state(&self) -> &RigidState {
        &self.cur
    }

    /// Chooses how the history is interpolated at the ALE pre-images (default
    /// [`Remap::Bilinear`]).
    pub fn set_remap(&mut self, remap: Remap) {
        self.ale.remap = remap;
    }

    /// The fluid.
    pub fn flow(&self) -> &ViscoelasticFlow {
        &self.flow
    }

    /// The confinement.
    pub fn domain(&self) -> &D {
        &self.domain
    }

    /// Current time.
    pub fn time(&self) -> f64 {
        self.flow.time()
    }
}

fn make_particles<D: Domain>(
    domain: &D,
    x: &[[f64; 2]],
    radius: &[f64],
    motion: &[Motion],
) -> Vec<Particle> {
    x.iter()
        .zip(radius)
        .zip(motion)
        .map(|((c, &radius), &motion)| Particle {
            center: domain.wrap(*c),
            radius,
            motion,
        })
        .collect()
}

fn set_velocities(state: &mut RigidState, rigid: &[[f64; 3]]) {
    state.u = rigid.iter().map(|r| [r[0], r[1]]).collect();
    state.omega = rigid.iter().map(|r| r[2]).collect();
}

fn finite(s: &RigidState) -> bool {
    s.x.iter()
        .chain(&s.u)
        .flatten()
        .chain(&s.omega)
        .all(|v| v.is_finite())
}
