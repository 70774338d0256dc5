//! One path from a validated case to a running simulation: [`Simulation::new`] builds a
//! [`CaseSpec`]'s set-up (`crate::geometry`), mesh or following mesh, fluid, particles, cut rule,
//! history remap and frame — every numerical default resolved once in [`Settings`] — and
//! [`run::run_case`] steps it, reporting every step to a [`crate::observe::CaseObserver`]. The sweep runner,
//! `xpflow run`, the particle validations and `xpflow bench moving` all build their cases here,
//! so that what is validated is what users run.
//!
//! Supported: free particles in confined shear flow and in the circular Couette cell, with or
//! without polymer (without: quasi-static Stokes motion through the same stepper). The
//! cylinder-channel benchmark is a fixed body, computed by `xpflow validate cylinder`.

pub mod adaptive;
pub mod frame;
pub mod run;
pub mod settings;
pub mod snapshot;
pub mod undisturbed;

pub use frame::Frame;
pub use run::{CaseResult, RunStatus};
pub use settings::Settings;
pub use undisturbed::{Undisturbed, UndisturbedFlow};

use crate::config::{CaseSpec, Geometry};
use crate::geometry::Confinement;
use crate::geometry::{ConfinedShear, CouetteError, CouetteGeometry, RotatingCouette, SetUp};
use crate::mesh::resolution::{elements_between, gaps, Between};
use crate::observe::{FieldSnapshot, Sample, SurfaceSample};
use crate::particles::Contact;
use crate::solver::free_surface;
use crate::solver::moving::{
    ComputationalMesh, MovingCheckpoint, MovingError, MovingParticles, StepOutcome,
};
use crate::solver::rigid::{Motion, Particle};
use adaptive::{StepController, Verdict};
use serde::{Deserialize, Serialize};
use snapshot::{in_lab, snapshot, FlowFields};

/// Why a case cannot be set up.
#[derive(Debug, thiserror::Error)]
pub enum SetupError {
    /// The case is of a kind no simulation is built for.
    #[error("{0}")]
    Unsupported(String),
    /// Invalid Couette cylinders.
    #[error(transparent)]
    Couette(#[from] CouetteError),
    /// The first solve or the geometry failed.
    #[error(transparent)]
    Solver(#[from] MovingError),
}

/// A case in progress: the moving-particle stepper in the case's set-up and frame.
pub struct Simulation {
    settings: Settings,
    stepper: MovingParticles<SetUp>,
    frame: Frame,
    radius: f64,
    /// The step controller of an adaptive step (`None`: a fixed Δt).
    control: Option<StepController>,
    /// An extrusion case, until its undisturbed surface is known ([`Simulation::settle`]).
    unsettled: Option<CaseSpec>,
    /// The undisturbed steady free surface H̄ of an extrusion (separations are measured from it).
    undisturbed: Option<Undisturbed>,
}

/// What a saved state holds: the stepper's checkpoint and, for an adaptive step, the
/// controller (the flattened layout keeps states saved before adaptive steps readable).
#[derive(Debug, Clone, Serialize, Deserialize)]
struct SavedRun {
    #[serde(flatten)]
    moving: MovingCheckpoint,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    control: Option<StepController>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    undisturbed: Option<Undisturbed>,
}

impl Simulation {
    /// `Ok` if a simulation can be built for `case`, otherwise the reason (shown to the user
    /// before anything runs).
    ///
    /// # Errors
    /// The reason, for cases without particles and for the cylinder-channel benchmark.
    pub fn supports(case: &CaseSpec) -> Result<(), String> {
        match case.geometry {
            Geometry::ConfinedShear { .. } | Geometry::Couette { .. } if case.radius().is_none() => {
                Err(format!(
                    "{} without particles has nothing to simulate",
                    case.geometry.kind()
                ))
            }
            Geometry::ConfinedShear { .. } | Geometry::Couette { .. } => Ok(()),
            // without particles: the extrudate swell
            Geometry::Extrusion { .. } => Ok(()),
            Geometry::CylinderChannel { .. } => Err(
                "the cylinder-channel benchmark runs with `xpflow validate cylinder`, not as a case"
                    .into(),
            ),
        }
    }

    /// The set-up of a case in the frame it is solved in.
    ///
    /// # Errors
    /// [`SetupError::Unsupported`] for the cylinder channel, [`SetupError::Couette`] for
    /// invalid cylinders.
    pub fn set_up(case: &CaseSpec) -> Result<SetUp, SetupError> {
        let frame = Frame::of(case);
        match case.geometry {
            // a frame translating at U_f: walls at −U_f ± U_w/2
            Geometry::ConfinedShear { h, l, wall_speed } => {
                Ok(SetUp::ConfinedShear(ConfinedShear {
                    h,
                    l,
                    wall_speed,
                    drift: -frame.velocity(),
                }))
            }
            Geometry::Couette {
                r1,
                r2,
                omega_inner,
            } => Ok(SetUp::Couette(RotatingCouette {
                geometry: CouetteGeometry::new(r1, r2, omega_inner)?,
                frame: frame.spin(),
            })),
            Geometry::Extrusion { .. } => Ok(SetUp::Extrusion(
                case.extrusion().expect("an extrusion geometry"),
            )),
            Geometry::CylinderChannel { .. } => {
                Err(SetupError::Unsupported(Self::supports(case).unwrap_err()))
            }
        }
    }

    /// Builds the case and solves its initial flow (the particles' initial velocities).
    ///
    /// # Errors
    /// [`SetupError`] if the case is unsupported or its geometry or first solve fails.
    pub fn new(case: &CaseSpec) -> Result<Simulation, SetupError> {
        Self::supports(case).map_err(SetupError::Unsupported)?;
        let settings = Settings::of(case);
        let set_up = Self::set_up(case)?;
        // (an extrusion may have no particles: its radius is never used)
        let (Some(radius), Some(base)) = (
            case.radius().or(case.extrusion().map(|_| 0.0)),
            case.base_mesh(),
        ) else {
            unreachable!("a supported case has particles (or a free surface) and a mesh")
        };
        let mesh: ComputationalMesh = match case.following_mesh() {
            Some(follow) => follow.into(),
            None => base.into(),
        };
        let mut stepper = MovingParticles::free(
            mesh,
            settings::fluid_params(case),
            set_up,
            case.initial_positions(),
            radius,
            settings::discretization(case),
        )?;
        stepper.set_remap(settings::ale_remap(case.numerics.remap));
        stepper.set_ale_extent(case.numerics.ale_extent);
        Ok(Simulation {
            settings,
            stepper,
            frame: Frame::of(case),
            radius,
            control: case
                .numerics
                .dt
                .adaptive()
                .map(|a| StepController::new(a, case.characteristic_rate())),
            // (an extrusion's undisturbed surface, unless the case skips it)
            unsettled: case
                .extrusion()
                .filter(|_| case.output.undisturbed_surface)
                .map(|_| case.clone()),
            undisturbed: None,
        })
    }

    /// Computes what a case needs before its first sample and is not part of a step: an
    /// extrusion's undisturbed steady surface H̄ (`undisturbed`; kept in the saved state, so a
    /// restored case does not compute it again), in one go. Nothing for other cases.
    ///
    /// # Errors
    /// [`MovingError`] if the undisturbed flow fails.
    pub fn settle(&mut self) -> Result<(), MovingError> {
        if let Some(prelude) = self.prelude()? {
            self.settle_with(prelude.run_to_end()?);
        }
        Ok(())
    }

    /// What [`settle`](Self::settle) steps, for a caller that saves it on the way (the case
    /// runner): an extrusion's undisturbed flow at its start, unless its surface is known
    /// already (from a saved state). `None` for other cases and once settled.
    ///
    /// # Errors
    /// [`MovingError`] if the undisturbed flow's set-up fails.
    pub fn prelude(&mut self) -> Result<Option<UndisturbedFlow>, MovingError> {
        match &self.unsettled {
            Some(case) if self.undisturbed.is_none() => UndisturbedFlow::new(case),
            _ => Ok(None),
        }
    }

    /// What identifies the case's prelude (see [`undisturbed::prelude_key`]): cases of one key
    /// have the same undisturbed surface. `None` without a prelude to run (none, or its surface
    /// known already, as after a restore).
    pub fn prelude_key(&self) -> Option<String> {
        self.unsettled
            .as_ref()
            .filter(|_| self.undisturbed.is_none())
            .map(undisturbed::prelude_key)
    }

    /// Takes the undisturbed surface a [`prelude`](Self::prelude) reached.
    pub fn settle_with(&mut self, undisturbed: Undisturbed) {
        self.unsettled = None;
        self.undisturbed = Some(undisturbed);
    }

    /// The undisturbed steady surface of an extrusion, once [`settle`](Self::settle)d.
    pub fn undisturbed(&self) -> Option<&Undisturbed> {
        self.undisturbed.as_ref()
    }

    /// The resolved numerical settings.
    pub fn settings(&self) -> &Settings {
        &self.settings
    }

    /// One time step (see [`MovingParticles::step`]); with an adaptive step, the step the
    /// controller accepts (rejected ones are redone from the state before them, `adaptive`),
    /// never past the end time.
    ///
    /// # Errors
    /// As [`MovingParticles::step`]; [`MovingError::Setup`] if the state before a rejected step
    /// cannot be restored.
    pub fn step(&mut self) -> Result<StepOutcome, MovingError> {
        let Some(control) = self.control.as_mut() else {
            return self.stepper.step();
        };
        loop {
            let remaining = self.settings.time.t_end - self.stepper.time();
            let dt = control.dt().min(remaining);
            self.stepper.set_dt(dt);
            let before = self.stepper.checkpoint();
            let report = match self.stepper.step()? {
                StepOutcome::Contact(_) if control.retry_contact(dt) => continue,
                StepOutcome::Stepped(report) => report,
                ended => return Ok(ended),
            };
            let lag = if control.estimates_lag() {
                self.stepper.coupling_lag()?
            } else {
                None
            };
            let error = control.error_of(report.deviation, lag);
            let limit = motion_limit(&self.stepper, dt);
            match control.judge(dt, error, limit) {
                Verdict::Accept => return Ok(StepOutcome::Stepped(report)),
                Verdict::Reject => self.stepper.restore(before)?,
                Verdict::Diverged { error } => {
                    return Err(MovingError::Jumped {
                        step: self.stepper.flow().history().steps(),
                        error,
                        dt,
                    })
                }
            }
        }
    }

    /// Whether the run has reached its end time (a fixed step: its step count).
    pub fn at_end(&self) -> bool {
        match self.settings.time.steps {
            Some(n) => self.steps() >= n as u64,
            None => self.settings.time.t_end - self.time() <= END_TIME_ROUND_OFF * self.dt(),
        }
    }

    /// Δt of the next step.
    pub fn dt(&self) -> f64 {
        self.control
            .as_ref()
            .map_or(self.stepper.dt(), StepController::dt)
    }

    /// Steps tried and redone by the step controller (`None`: a fixed Δt).
    pub fn rejected_steps(&self) -> Option<u64> {
        self.control.as_ref().map(StepController::rejected)
    }

    /// What the flow solves cost beyond their factorizations since this process built the
    /// case (a resumed case counts from its resume).
    pub fn flow_solver_stats(&self) -> crate::solver::flow::FlowSolverStats {
        self.stepper.flow().flow_solver_stats()
    }

    /// Steps taken.
    pub fn steps(&self) -> u64 {
        self.stepper.flow().history().steps() as u64
    }

    /// Current time.
    pub fn time(&self) -> f64 {
        self.stepper.time()
    }

    /// The stepper (for benchmarks and studies that read the flow).
    pub fn stepper(&self) -> &MovingParticles<SetUp> {
        &self.stepper
    }

    /// The particles now, in the lab frame.
    pub fn sample(&self) -> Sample {
        let state = self.stepper.state();
        let mut sample = frame::sample(
            self.steps(),
            self.time(),
            state,
            self.frame,
            self.narrowest_gap_elements(),
        );
        if let Some(u) = &self.undisturbed {
            for p in &mut sample.particles {
                p.separation = Some(p.y + self.radius - u.surface.at(p.x));
            }
        }
        if let (Some(s), Some(change)) = (self.stepper.surface(), self.stepper.surface_change()) {
            sample.surface = Some(SurfaceSample {
                change,
                profile: s.profile(),
            });
        }
        sample
    }

    /// The narrowest gap of the particles now, in elements (`mesh::resolution::gaps`): between
    /// them and to the walls — in an extrusion to the symmetry line and to the fluid's upper
    /// boundary, the die wall or the free surface, instead of the mesh top, which bounds no
    /// fluid there. `None` without particles.
    fn narrowest_gap_elements(&self) -> Option<f64> {
        let mesh = self.stepper.flow().mesh();
        let x = &self.stepper.state().x;
        let radii = vec![self.radius; x.len()];
        let surface = self.stepper.surface();
        let walls = gaps(mesh, x, &radii)
            .into_iter()
            .filter(|g| surface.is_none() || !matches!(g.between, Between::TopWall(_)))
            .map(|g| g.elements);
        let films = surface.into_iter().flat_map(|s| {
            x.iter()
                .map(move |&c| free_surface::film_elements(mesh, s, c, self.radius))
        });
        walls.chain(films).reduce(f64::min)
    }

    /// A contact of the particles as they are now (after the last step taken) at any overlap,
    /// however small: below [`crate::particles::CONTACT_OVERLAP`] the run goes on, but a step that
    /// fails from such a state has met the contact (the flow solve fails as the film closes).
    pub fn touching(&self) -> Option<Contact> {
        let x = &self.stepper.state().x;
        let radius = vec![self.radius; x.len()];
        self.stepper.domain().contact(x, &radius, 0.0)
    }

    /// The fields now on the Q2 nodes, in the lab frame.
    pub fn snapshot(&self) -> FieldSnapshot {
        let flow = self.stepper.flow();
        let fields = FlowFields {
            u: flow.velocity().to_vec(),
            p: flow.pressure().to_vec(),
            tau: flow.polymer_stress(),
            particles: self
                .stepper
                .state()
                .x
                .iter()
                .map(|&center| Particle {
                    center,
                    radius: self.radius,
                    motion: Motion::Free,
                })
                .collect(),
        };
        let period = crate::geometry::Confinement::period(self.stepper.domain());
        in_lab(
            snapshot(self.steps(), self.time(), flow.mesh(), &fields, period),
            self.frame,
        )
    }

    /// The state after the last step as JSON (what [`restore`](Self::restore) continues from),
    /// with the step controller of an adaptive step.
    pub fn checkpoint(&self) -> String {
        let saved = SavedRun {
            moving: self.stepper.checkpoint(),
            control: self.control.clone(),
            undisturbed: self.undisturbed.clone(),
        };
        // (serializing plain numbers cannot fail)
        serde_json::to_string(&saved).unwrap_or_default()
    }

    /// Continues from a [`checkpoint`](Self::checkpoint) of the same case.
    ///
    /// # Errors
    /// The reason, if the text is not a checkpoint or does not fit the case.
    pub fn restore(&mut self, saved: &str) -> Result<(), String> {
        let saved = serde_json::from_str::<SavedRun>(saved).map_err(|e| e.to_string())?;
        if let (Some(control), Some(saved)) = (self.control.as_mut(), saved.control) {
            // the case's bounds and rate, the run's progress (Δt, last error, rejections)
            control.resume_from(&saved);
        }
        if saved.undisturbed.is_some() {
            self.undisturbed = saved.undisturbed;
        }
        self.stepper
            .restore(saved.moving)
            .map_err(|e| e.to_string())
    }
}

/// Round-off (in steps) within which the end time counts as reached.
const END_TIME_ROUND_OFF: f64 = 1e-9;

/// The largest Δt in which no particle crosses more than
/// [`adaptive::MOTION_ELEMENTS_PER_STEP`] elements at its present velocity (over the mesh, in the
/// frame of the solve), measured over the step `dt` just taken.
fn motion_limit(stepper: &MovingParticles<SetUp>, dt: f64) -> f64 {
    let state = stepper.state();
    let mesh = stepper.flow().mesh();
    let crossed = state
        .x
        .iter()
        .zip(&state.u)
        .map(|(x, u)| elements_between(mesh, *x, [x[0] + u[0] * dt, x[1] + u[1] * dt]))
        .fold(0.0, f64::max);
    if crossed > 0.0 {
        adaptive::MOTION_ELEMENTS_PER_STEP * dt / crossed
    } else {
        f64::INFINITY
    }
}
