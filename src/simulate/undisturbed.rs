//! The undisturbed steady free surface H̄(x) = H(x, t → ∞) of an extrusion case without its
//! particles (thesis Eq. 6.65), against which a particle's separation s = Y + a − H̄(X) is
//! measured: the case's mesh, fluid and time step, stepped from the flat surface until the
//! steady test of §6.4 ([`STEADY_HEIGHT_TOL`]) or [`UNDISTURBED_T_MAX`]; a prelude of the case's
//! run that is saved and continued like the run ([`UndisturbedFlow`]).

use crate::config::CaseSpec;
use crate::geometry::SetUp;
use crate::solver::free_surface::{HeightFunction, STEADY_HEIGHT_TOL};
use crate::solver::moving::{MovingCheckpoint, MovingError, MovingParticles};

use super::{settings, Simulation};

/// The longest time the undisturbed flow is stepped towards the steady test (the UCM swell of
/// §6.4 is steady by t ≈ 17 at De = 1.5 with Δt = 0.05: 348 steps).
pub const UNDISTURBED_T_MAX: f64 = 40.0;

/// The undisturbed steady surface of a case and how it was reached.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Undisturbed {
    /// H̄ on the surface's line mesh.
    pub surface: HeightFunction,
    /// Steps taken.
    pub steps: usize,
    /// Whether the steady test was met (otherwise the surface at [`UNDISTURBED_T_MAX`]).
    pub steady: bool,
    /// Taken from an earlier case of the same undisturbed flow rather than stepped by this one.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub shared: bool,
}

impl Undisturbed {
    /// The swell ratio max H̄ / H0.
    pub fn swell(&self) -> f64 {
        self.surface.max() / self.surface.h0()
    }
}

/// The undisturbed flow of an extrusion case on its way to the steady surface: the prelude of the
/// case's run, stepped until [`done`](Self::done) and saved and continued like the run itself
/// ([`checkpoint`](Self::checkpoint), [`restore`](Self::restore)), so that a killed case does
/// not compute it again from the flat surface (on a fine mesh it takes thousands of steps).
pub struct UndisturbedFlow {
    flow: MovingParticles<SetUp>,
    steps: usize,
}

/// What [`UndisturbedFlow::checkpoint`] saves.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
struct SavedUndisturbed {
    steps: usize,
    moving: MovingCheckpoint,
}

impl UndisturbedFlow {
    /// The undisturbed flow of an extrusion `case` at its start, the flat surface (`None` for
    /// other geometries).
    ///
    /// # Errors
    /// [`MovingError`] if the set-up or the initial solve fails.
    pub fn new(case: &CaseSpec) -> Result<Option<Self>, MovingError> {
        let (Some(base), Some(radius)) = (case.base_mesh(), case.radius()) else {
            return Ok(None);
        };
        if case.extrusion().is_none() {
            return Ok(None);
        }
        let set_up = Simulation::set_up(case).map_err(|e| MovingError::Setup(e.to_string()))?;
        let flow = MovingParticles::free(
            base,
            settings::fluid_params(case),
            set_up,
            Vec::new(),
            radius,
            settings::discretization(case),
        )?;
        Ok(Some(Self { flow, steps: 0 }))
    }

    fn change(&self) -> f64 {
        self.flow.surface_change().unwrap_or(0.0)
    }

    /// Whether the surface is steady (§6.4's test) or the flow has reached
    /// [`UNDISTURBED_T_MAX`].
    pub fn done(&self) -> bool {
        self.change() < STEADY_HEIGHT_TOL || self.flow.time() >= UNDISTURBED_T_MAX
    }

    /// The time reached.
    pub fn time(&self) -> f64 {
        self.flow.time()
    }

    /// Steps taken so far (restored ones included).
    pub fn steps(&self) -> usize {
        self.steps
    }

    /// One time step.
    ///
    /// # Errors
    /// [`MovingError`] if the step fails.
    pub fn step(&mut self) -> Result<(), MovingError> {
        self.flow.step()?;
        self.steps += 1;
        Ok(())
    }

    /// The state after the last step as JSON (what [`restore`](Self::restore) continues from).
    pub fn checkpoint(&self) -> String {
        let saved = SavedUndisturbed {
            steps: self.steps,
            moving: self.flow.checkpoint(),
        };
        // (serializing plain numbers cannot fail)
        serde_json::to_string(&saved).unwrap_or_default()
    }

    /// Continues from a [`checkpoint`](Self::checkpoint) of the same case.
    ///
    /// # Errors
    /// The reason, if the text is not such a checkpoint or does not fit the case.
    pub fn restore(&mut self, saved: &str) -> Result<(), String> {
        let saved: SavedUndisturbed = serde_json::from_str(saved).map_err(|e| e.to_string())?;
        self.flow.restore(saved.moving).map_err(|e| e.to_string())?;
        self.steps = saved.steps;
        Ok(())
    }

    /// Steps to the end ([`done`](Self::done)) and returns the surface reached.
    ///
    /// # Errors
    /// [`MovingError`] if a step fails.
    pub fn run_to_end(mut self) -> Result<Undisturbed, MovingError> {
        while !self.done() {
            self.step()?;
        }
        Ok(self.finish())
    }

    /// The surface reached.
    pub fn finish(self) -> Undisturbed {
        Undisturbed {
            steady: self.change() < STEADY_HEIGHT_TOL,
            surface: self
                .flow
                .surface()
                .expect("an extrusion has a surface")
                .clone(),
            steps: self.steps,
            shared: false,
        }
    }
}

/// What the undisturbed flow of an extrusion `case` depends on, as a key: the id of the case
/// without its particles, its end time and what it records (the prelude runs to the steady test
/// or [`UNDISTURBED_T_MAX`], whatever `t_end`; its mesh, fluid, time step and numerics stay).
/// Cases of one sweep that differ only in their particles — the radius, the initial position —
/// share one prelude.
pub fn prelude_key(case: &CaseSpec) -> String {
    let mut undisturbed = case.clone();
    undisturbed.particles = None;
    undisturbed.numerics.t_end = 0.0;
    undisturbed.output = Default::default();
    undisturbed.stop = Default::default();
    format!(
        "undisturbed-{}",
        crate::sweep::expand::case_id(&undisturbed)
    )
}

/// The undisturbed steady surface of an extrusion `case` (`None` for other geometries), in one
/// go ([`UndisturbedFlow`] to its end).
///
/// # Errors
/// [`MovingError`] if the set-up or a step fails.
pub fn undisturbed_surface(case: &CaseSpec) -> Result<Option<Undisturbed>, MovingError> {
    UndisturbedFlow::new(case)?
        .map(UndisturbedFlow::run_to_end)
        .transpose()
}
