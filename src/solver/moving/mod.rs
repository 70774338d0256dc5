//! Rigid particles moving freely (or with prescribed velocities) in a viscoelastic fluid on the
//! fixed mesh: the full time step of thesis §5.3.4,
//!
//! predict (Eqs. 5.45–5.47) → ale_map (temporary ALE, §5.3.3: sⁿ, s^{n−1}, Gⁿ carried onto the
//! predicted configuration, mesh velocity of Eq. 5.44) → classify (cut cells at the predicted
//! positions) → solve_flow (u, p, U_i, ω_i with force- and torque-free particles imposed weakly,
//! Eq. 5.48) → solve_stress (SUPG/BDF2 with u − u_m, Eq. 5.52) → correct (trapezoidal rule,
//! Eqs. 5.54–5.56) → observe (contact; divergence is a non-finite correction, the steady rotation of §5.7.2 is
//! decided by `observe::outcome`).
//!
//! The confinement (walls, period, contact) is a [`Confinement`] of `crate::geometry`. An
//! extrusion ([`Boundary::Extrusion`]) adds a free surface, moved with the particles in the same
//! step (thesis §6.3.4, `surface`): predicted with them, the background of their ALE map, a bound
//! of the cut cells, advanced by the kinematic equation after the stress. A fluid
//! without polymer (η_p = 0) runs the same pipeline without the ALE map and the stress solve:
//! quasi-static Stokes motion, the flow pattern and its symbolic factorization kept across steps.

mod checkpoint;
mod end;
mod surface;

use std::time::Instant;

use crate::geometry::Boundary;
pub use crate::geometry::Confinement;
pub use crate::mesh::follow::FollowingMesh;
use crate::mesh::{Mesh, Side};
use crate::particles::{correct, deviation, extrapolate, Contact, RigidState, CONTACT_OVERLAP};
use crate::solver::ale::{AleExtent, AleMap, Remap, RigidMove, TemporaryAle};
use crate::solver::cutcells::{compute_cuts_bounded, Discretization};
use crate::solver::free_surface::HeightFunction;
use crate::solver::rigid::{ElementCut, Motion, Particle};
use crate::solver::viscoelastic::{
    FlowSolution, HistoryMap, StepReport, ViscoelasticError, ViscoelasticFlow, ViscoelasticParams,
};
use crate::xfem::LevelSet;
pub use checkpoint::MovingCheckpoint;
pub use end::{MovingEnd, MovingError, StepOutcome};
use surface::{apply_extrusion, Surface};
pub use surface::{die_log_conformation, SurfaceCheckpoint};

/// Steps of size `dt` to reach `t_end` (the end time counts as reached within round-off of
/// t_end/dt).
pub fn step_count(t_end: f64, dt: f64) -> usize {
    (t_end / dt - 1e-9).ceil() as usize
}

/// Prescribes the confinement's wall velocities on the flow's bottom and top sides and pins the
/// pressure ([`Boundary::Walls`]: the flow is enclosed), or the die's conditions of an extrusion.
///
/// # Errors
/// [`ViscoelasticError::Stress`] if an extrusion's initial conformation cannot be projected.
pub fn apply_walls<D: Confinement + Clone + 'static>(
    domain: &D,
    flow: &mut ViscoelasticFlow,
) -> Result<(), ViscoelasticError> {
    if let Boundary::Extrusion(e) = domain.boundary() {
        return apply_extrusion(e, flow);
    }
    for side in [Side::Bottom, Side::Top] {
        let d = domain.clone();
        flow.set_velocity(side, move |x| d.wall_velocity(side, x));
    }
    flow.pin_pressure();
    Ok(())
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

/// A viscoelastic flow with moving rigid particles.
pub struct MovingParticles<D: Confinement> {
    domain: D,
    flow: ViscoelasticFlow,
    ale: TemporaryAle,
    radius: Vec<f64>,
    motion: Vec<Motion>,
    /// XFEM with its cut rule, or the fictitious domain method.
    method: Discretization,
    /// Xⁿ, Uⁿ, ωⁿ.
    cur: RigidState,
    /// Xⁿ⁻¹ (none before the first step).
    prev: Option<RigidState>,
    /// X̂ⁿ: the (predicted) positions at which the current fields were computed.
    fields_at: Vec<[f64; 2]>,
    /// The mesh that follows the particles (`None`: fixed mesh).
    follow: Option<FollowingMesh>,
    /// The free surface of an extrusion (`None`: walls only).
    surface: Option<Surface>,
}

impl<D: Confinement + Clone + 'static> MovingParticles<D> {
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
        method: impl Into<Discretization>,
    ) -> Result<Self, MovingError> {
        let method = method.into();
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
        let surface = match domain.boundary() {
            Boundary::Extrusion(e) => Some(Surface::new(&mesh, e)?),
            Boundary::Walls => None,
        };
        let particles = make_particles(&domain, &x0, &radius, &motion);
        let bound = surface.as_ref().map(|s| s.level_set(s.fields_at()));
        let cuts = compute_cuts_bounded(
            &mesh,
            &particles,
            domain.period(),
            method,
            bound.as_ref().map(|b| b as &dyn LevelSet),
        )
        .map_err(|source| MovingError::Cut { step: 0, source })?;
        let ale = TemporaryAle::new(&mesh);
        let mut flow = ViscoelasticFlow::with_particles(mesh, params, particles, cuts)?;
        apply_walls(&domain, &mut flow)?;
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
            method,
            cur,
            prev: None,
            fields_at: x0,
            follow,
            surface,
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
        method: impl Into<Discretization>,
    ) -> Result<Self, MovingError> {
        let n = x0.len();
        Self::new(
            mesh,
            params,
            domain,
            x0,
            vec![radius; n],
            vec![Motion::Free; n],
            method,
        )
    }

    /// One time step, the pipeline of thesis §5.3.4 (one private method each): `predict` →
    /// `ale_map` → `classify` → `solve_flow` → `solve_stress` → `correct` → `observe`.
    /// [`StepOutcome::Contact`] when the predicted particles touch (the step is not taken),
    /// [`StepOutcome::ContactAfter`] when the corrected ones do.
    ///
    /// # Errors
    /// [`MovingError`] when the geometry, the ALE map or a solve fails, or velocities blow up.
    pub fn step(&mut self) -> Result<StepOutcome, MovingError> {
        let t_step = Instant::now();
        let step = self.flow.history().steps() + 1;
        let (expected, x_pred) = self.predict();
        let dt_prev = self.last_dt();
        let surface = match &self.surface {
            Some(s) => {
                let predicted = s.predicted(self.dt(), dt_prev);
                s.inside(&predicted, step)?;
                Some(predicted)
            }
            None => None,
        };
        if let Some(c) = self.contact(&x_pred, surface.as_ref()) {
            return Ok(StepOutcome::Contact(c));
        }
        let t0 = Instant::now();
        let (onto, map) = self.ale_map(&x_pred, surface.as_ref(), step)?;
        let mut ale = t0.elapsed().as_secs_f64();
        let t0 = Instant::now();
        let target = onto.as_ref().unwrap_or(self.flow.mesh());
        let (particles, cuts) = self.classify(target, &x_pred, surface.as_ref(), step)?;
        let classify = t0.elapsed().as_secs_f64();
        let t0 = Instant::now();
        let history = map.as_ref().map(|m| HistoryMap {
            at_n: &m.at_n,
            at_n_minus_1: m.at_n_minus_1.as_deref(),
            mesh_velocity: &m.mesh_velocity,
        });
        self.flow
            .move_particles_onto(onto, particles, cuts, history)?;
        ale += t0.elapsed().as_secs_f64();
        let solution = self.solve_flow()?;
        let mut report = self.solve_stress(solution)?;
        if let Some(predicted) = surface {
            self.advance_surface(predicted, dt_prev, step)?;
        }
        self.correct(x_pred, step)?;
        report.deviation = expected.map(|e| deviation(&self.cur, &e, &self.radius));
        report.timings.ale = ale;
        report.timings.classify = classify;
        report.timings.total = t_step.elapsed().as_secs_f64();
        Ok(match self.observe() {
            Some(c) => StepOutcome::ContactAfter(report, c),
            None => StepOutcome::Stepped(report),
        })
    }

    /// Step 1, predict: the state extrapolated to tⁿ⁺¹ (`None` before the first step) and its
    /// centres X̂ⁿ⁺¹ = Xⁿ + ω(Xⁿ − Xⁿ⁻¹), ω = Δtₙ/Δtₙ₋₁ (Eqs. 5.45–5.47; Xⁿ at the first step).
    fn predict(&self) -> (Option<RigidState>, Vec<[f64; 2]>) {
        let expected = extrapolate(self.prev.as_ref(), &self.cur, self.step_ratio());
        let x = expected
            .as_ref()
            .map_or_else(|| self.cur.x.clone(), |e| e.x.clone());
        (expected, x)
    }

    /// ω = Δtₙ/Δtₙ₋₁ of the coming step (1 before the first step or when the last is unknown).
    fn step_ratio(&self) -> f64 {
        self.dt() / self.last_dt()
    }

    /// Δt of the last step (that of the coming one before the first).
    fn last_dt(&self) -> f64 {
        self.flow.history().last_dt().unwrap_or(self.dt())
    }

    /// A contact of the particles at `x` with each other, the set-up's walls or the free
    /// `surface` (predicted with them).
    fn contact(&self, x: &[[f64; 2]], surface: Option<&HeightFunction>) -> Option<Contact> {
        let min_gap = self.min_gap();
        self.domain.contact(x, &self.radius, min_gap).or_else(|| {
            let (s, at) = (self.surface.as_ref()?, surface?);
            s.contact(at, x, &self.radius, min_gap)
        })
    }

    /// Δt of the coming step.
    pub fn dt(&self) -> f64 {
        self.flow.params().dt
    }

    /// Sets Δt of the coming steps (variable steps: the predictor, the ALE mesh velocity and the
    /// BDF2 stress follow the ratio to the last step; keep it within [½, 2] for second order and
    /// stability).
    ///
    /// # Panics
    /// If `dt` is not positive and finite.
    pub fn set_dt(&mut self, dt: f64) {
        self.flow.set_dt(dt);
    }

    /// Step 2, ale_map: the computational mesh of the coming step (refined around X̂ⁿ⁺¹ if it
    /// follows the particles; `None`: the mesh stays) and the temporary ALE map that carries the
    /// history from X̂ⁿ onto it (thesis §5.3.3; `None` for a fluid without polymer, which has
    /// no history).
    fn ale_map(
        &mut self,
        x_pred: &[[f64; 2]],
        surface: Option<&HeightFunction>,
        step: usize,
    ) -> Result<(Option<Mesh>, Option<AleMap>), MovingError> {
        let onto = match &self.follow {
            Some(f) => Some(
                f.mesh_at(x_pred)
                    .map_err(|reason| MovingError::Follow { step, reason })?,
            ),
            None => None,
        };
        if !self.flow.params().has_polymer() {
            return Ok((onto, None));
        }
        let moves: Vec<RigidMove> = self
            .fields_at
            .iter()
            .zip(x_pred)
            .zip(&self.radius)
            .map(|((from, to), &radius)| RigidMove {
                center: self.domain.wrap(*from),
                radius,
                displacement: [to[0] - from[0], to[1] - from[1]],
            })
            .collect();
        let bdf = self.flow.history().bdf2(self.dt());
        let target = onto.as_ref().unwrap_or(self.flow.mesh());
        // the surface's stretch under the particles' moves (onto a fixed mesh: no follow)
        (self.ale.background, self.ale.outside) = match self.surface.as_ref().zip(surface) {
            Some((s, at)) => {
                let (stretch, outside) = s.background(self.flow.mesh(), at);
                (Some(stretch), Some(outside))
            }
            None => (None, None),
        };
        let map = self
            .ale
            .advance_onto(
                self.flow.mesh(),
                target,
                &moves,
                self.domain.period(),
                self.dt(),
                bdf,
            )
            .map_err(|source| MovingError::Ale { step, source })?;
        Ok((onto, Some(map)))
    }

    /// Step 3, classify: the particles at X̂ⁿ⁺¹ and their cut cells on `mesh`, in the fluid
    /// below the predicted `surface` if there is one.
    fn classify(
        &self,
        mesh: &Mesh,
        x_pred: &[[f64; 2]],
        surface: Option<&HeightFunction>,
        step: usize,
    ) -> Result<(Vec<Particle>, Vec<ElementCut>), MovingError> {
        let particles = make_particles(&self.domain, x_pred, &self.radius, &self.motion);
        let bound = self
            .surface
            .as_ref()
            .zip(surface)
            .map(|(s, at)| s.level_set(at));
        let cuts = compute_cuts_bounded(
            mesh,
            &particles,
            self.domain.period(),
            self.method,
            bound.as_ref().map(|b| b as &dyn LevelSet),
        )
        .map_err(|source| MovingError::Cut { step, source })?;
        Ok((particles, cuts))
    }

    /// Step 5b, advance_surface: Hⁿ⁺¹ by the kinematic equation with the new velocity on the
    /// predicted surface (thesis §6.3.4 step 5).
    fn advance_surface(
        &mut self,
        predicted: HeightFunction,
        dt_prev: f64,
        step: usize,
    ) -> Result<(), MovingError> {
        let dt = self.dt();
        let tau_dt = self.flow.params().supg.step(dt);
        let surface = self
            .surface
            .as_mut()
            .expect("a predicted surface has a surface");
        surface.advance(
            self.flow.mesh(),
            self.flow.velocity(),
            predicted,
            [dt, dt_prev, tau_dt],
            step,
        )?;
        Ok(())
    }

    /// Step 4, solve_flow: u, p, Uᵢ, ωᵢ at X̂ⁿ⁺¹ (Eq. 5.48).
    fn solve_flow(&mut self) -> Result<FlowSolution, MovingError> {
        Ok(self.flow.solve_flow(&|_| [0.0, 0.0])?)
    }

    /// Step 5, solve_stress: s^{n+1} with u − u_m (Eq. 5.52; nothing without polymer).
    fn solve_stress(&mut self, solution: FlowSolution) -> Result<StepReport, MovingError> {
        Ok(self.flow.solve_stress(solution)?)
    }

    /// Step 6, correct: Xⁿ⁺¹ by the trapezoidal rule (Eqs. 5.54–5.56).
    fn correct(&mut self, x_pred: Vec<[f64; 2]>, step: usize) -> Result<(), MovingError> {
        let rigid = self.flow.rigid_velocities();
        let u: Vec<[f64; 2]> = rigid.iter().map(|r| [r[0], r[1]]).collect();
        let omega: Vec<f64> = rigid.iter().map(|r| r[2]).collect();
        let next = correct(&self.cur, &u, &omega, self.dt(), self.prev.is_none());
        if !finite(&next) {
            return Err(MovingError::NonFinite { step });
        }
        self.prev = Some(std::mem::replace(&mut self.cur, next));
        self.fields_at = x_pred;
        Ok(())
    }

    /// Step 7, observe: contact of the corrected particles with each other or a wall.
    fn observe(&self) -> Option<Contact> {
        self.domain
            .contact(&self.cur.x, &self.radius, self.min_gap())
    }

    /// The gap below which particles are in contact: a small overlap of the smallest radius.
    fn min_gap(&self) -> f64 {
        -CONTACT_OVERLAP * self.radius.iter().copied().fold(f64::INFINITY, f64::min)
    }

    /// Steps until `t_end`, a contact, or until `observe` returns false; `observe` sees every
    /// step taken. (Whether a case has become steady is the observer's to decide:
    /// `observe::outcome`.)
    ///
    /// # Errors
    /// As [`step`](Self::step).
    pub fn run(
        &mut self,
        t_end: f64,
        mut observe: impl FnMut(&Self, &StepReport) -> bool,
    ) -> Result<MovingEnd, MovingError> {
        let n_steps = step_count(t_end, self.dt());
        while self.flow.history().steps() < n_steps {
            let rep = match self.step()? {
                StepOutcome::Stepped(rep) => rep,
                StepOutcome::Contact(c) => return Ok(MovingEnd::Contact(c)),
                StepOutcome::ContactAfter(rep, c) => {
                    if !observe(self, &rep) {
                        return Ok(MovingEnd::Stopped);
                    }
                    return Ok(MovingEnd::Contact(c));
                }
            };
            if !observe(self, &rep) {
                return Ok(MovingEnd::Stopped);
            }
        }
        Ok(MovingEnd::EndTime)
    }

    /// The explicit coupling's lag of the step just taken
    /// ([`ViscoelasticFlow::coupling_lag`]): the largest change of a particle's velocity when
    /// the step's flow is solved again with the stress at its end, |ΔU|/a and |Δω| (radii per
    /// unit time, like [`crate::particles::Deviation::velocity`]); `None` without a lag
    /// (Newtonian, semi-implicit).
    ///
    /// # Errors
    /// [`MovingError`] if the solve fails.
    pub fn coupling_lag(&mut self) -> Result<Option<f64>, MovingError> {
        let Some(lag) = self.flow.coupling_lag(&|_| [0.0, 0.0])? else {
            return Ok(None);
        };
        Ok(Some(lag.iter().zip(&self.radius).fold(0.0, |m, (d, a)| {
            m.max(d[0].hypot(d[1]) / a).max(d[2].abs())
        })))
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

    /// Chooses where the ALE's mesh displacement is solved (default [`AleExtent::Whole`]).
    pub fn set_ale_extent(&mut self, extent: AleExtent) {
        self.ale.extent = extent;
    }

    /// The fluid.
    pub fn flow(&self) -> &ViscoelasticFlow {
        &self.flow
    }

    /// The free surface Hⁿ of an extrusion (`None` without one).
    pub fn surface(&self) -> Option<&HeightFunction> {
        self.surface.as_ref().map(Surface::height)
    }

    /// How far the free surface moved in the last step, max|Hⁿ − Hⁿ⁻¹| (`None` without one;
    /// infinite before the first step or after a restore).
    pub fn surface_change(&self) -> Option<f64> {
        self.surface.as_ref().map(Surface::change)
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

fn make_particles<D: Confinement>(
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
