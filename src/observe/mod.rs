//! Observables and outcome classification from trajectories.
//!
//! Owns the contract between a running case and whoever records it: per-step particle states
//! ([`Sample`]), optional nodal field snapshots ([`FieldSnapshot`]) and the [`CaseObserver`] trait a solver
//! calls; and the outcome rules ([`outcome::Classifier`]): string formation by the steady-state test of
//! thesis 5.7.2 (|ω*(tⁿ⁺¹) − ω*(tⁿ)| < 10⁻⁶ for every particle) plus a chain condition, repel (reversed
//! trajectories, thesis 5.6.2), pass, jammed (overlap), wall contact, Couette migration by the final
//! r* = (r − R1)/(R2 − R1) (thesis 3.5.1), diverged and timeout. The rules are written out in
//! `docs/sweeps.md`.

pub mod outcome;
pub mod synthetic;

pub use outcome::{Classifier, Outcome, OutcomeKind};

/// State of one rigid particle at one time (angles and angular velocities positive clockwise, as in
/// thesis 5.7.1).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ParticleState {
    /// Centre x.
    pub x: f64,
    /// Centre y.
    pub y: f64,
    /// Translational velocity U.
    pub u: f64,
    /// Translational velocity V.
    pub v: f64,
    /// Angular velocity ω (clockwise positive).
    pub omega: f64,
    /// Rotation angle θ (clockwise positive).
    pub theta: f64,
    /// Separation from the undisturbed steady free surface H̄, s = Y + a − H̄(X) (extrusion,
    /// thesis Eq. 6.65: s < 0 with the particle's top below the surface, s > 0 above it; H̄ = H0
    /// in the die); `None` without a free surface.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub separation: Option<f64>,
}

/// Particle states after one time step.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Sample {
    /// Time step number (1 for the first step after t = 0; 0 for the initial state).
    pub step: u64,
    /// Time after the step.
    pub t: f64,
    /// One state per particle, in the order of [`crate::config::CaseSpec::initial_positions`].
    pub particles: Vec<ParticleState>,
    /// Elements across the narrowest gap (particle–particle, particle–wall, or in an extrusion
    /// particle–die wall or –free surface) on the mesh of this step
    /// ([`crate::mesh::resolution`]); `None` where no mesh is known (the fake runner,
    /// samples read back from a database).
    #[serde(default)]
    pub gap_elements: Option<f64>,
    /// The free surface of an extrusion (`None` without one).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub surface: Option<SurfaceSample>,
}

/// A free surface after one time step.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SurfaceSample {
    /// How far it moved in the step, max|Hⁿ⁺¹ − Hⁿ| (the steady test of thesis §6.4).
    pub change: f64,
    /// (x, H) from the die exit (where H = H0) on.
    pub profile: Vec<[f64; 2]>,
}

impl SurfaceSample {
    /// The swell ratio max H / H0.
    pub fn swell(&self) -> f64 {
        let h0 = self.profile.first().map_or(1.0, |p| p[1]);
        self.profile.iter().map(|p| p[1]).fold(f64::MIN, f64::max) / h0
    }
}

/// A nodal field on the mesh of a snapshot.
#[derive(Debug, Clone, PartialEq)]
pub struct NodalField {
    /// Name as shown in ParaView, e.g. `u`, `p`, `tr_tau`, `level_set`.
    pub name: String,
    /// 1 (scalar) or 2 (vector, stored as x, y per node).
    pub components: usize,
    /// `components` values per node, node-major.
    pub values: Vec<f64>,
}

/// Field snapshot: the (possibly deformed) mesh and nodal fields at one time.
#[derive(Debug, Clone, PartialEq)]
pub struct FieldSnapshot {
    /// Time step number.
    pub step: u64,
    /// Time.
    pub t: f64,
    /// Node coordinates.
    pub coords: Vec<[f64; 2]>,
    /// Quadrilaterals as four node indices, counter-clockwise (Q1 vertices of the Q2 elements).
    pub quads: Vec<[usize; 4]>,
    /// Nodal fields: u, p, tr τ, level set (any subset).
    pub fields: Vec<NodalField>,
}

/// Whether the runner should go on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Control {
    /// Keep stepping.
    Continue,
    /// Stop now and return `Finished`: the outcome is decided and early stop is on.
    Stop,
}

/// What a running case reports to. A case runner (`simulate::run::run_case`, the sweep engine's
/// fake runner) must call [`CaseObserver::on_step`] after
/// every time step (the steady-state test compares consecutive steps), honour [`Control::Stop`], offer a
/// snapshot when [`CaseObserver::snapshot_due`] says so, and may call [`CaseObserver::checkpoint`] when it
/// is a good moment to persist what has been observed so far.
pub trait CaseObserver {
    /// Particle states after a step (and once for the initial state with step 0, optional).
    fn on_step(&mut self, sample: &Sample) -> Control;
    /// True when a field snapshot for `step` is wanted.
    fn snapshot_due(&self, step: u64) -> bool;
    /// A field snapshot.
    fn on_snapshot(&mut self, snapshot: &FieldSnapshot);
    /// Persist what has been observed so far (long cases).
    fn checkpoint(&mut self);
    /// True when the runner should hand its state to [`CaseObserver::save_state`] after `step`
    /// (after reporting that step to [`CaseObserver::on_step`]).
    fn state_due(&self, _step: u64) -> bool {
        false
    }
    /// The runner's state after `step` (JSON, opaque to the observer): if the process dies, the
    /// case continues from here instead of from the start.
    fn save_state(&mut self, _step: u64, _state: &str) {}
    /// The state an interrupted case continues from (what [`CaseObserver::save_state`] got,
    /// once): the runner restores it, skips the initial report and goes on from the step after.
    fn resume_state(&mut self) -> Option<String> {
        None
    }
    /// The run stops at time `t` because the particles would touch at the positions predicted
    /// for the next step (the step was not taken; the last [`CaseObserver::on_step`] is the
    /// state before it): a contact the outcome must record, though the last state's overlap may
    /// still be below the outcome rules' threshold.
    fn on_contact(&mut self, _contact: &crate::particles::Contact, _t: f64) {}
    /// The step after time `t` failed (`error`) from a state whose particles already touch
    /// (`contact`: any overlap, below the outcome rules' threshold too): the film between them
    /// has closed, and the case ends in that contact rather than as a failure.
    fn on_contact_at_failure(&mut self, contact: &crate::particles::Contact, t: f64, _error: &str) {
        self.on_contact(contact, t);
    }
    /// The undisturbed steady free surface H̄ of an extrusion (before the first step;
    /// separations are measured from it).
    fn on_undisturbed_surface(&mut self, _surface: &UndisturbedSurface) {}
    /// A step of the case's prelude (an extrusion's undisturbed flow, before the first sample)
    /// reached time `t` after `steps` steps: for progress displays.
    fn on_prelude_step(&mut self, _t: f64, _steps: usize) {}
    /// True when the runner should hand the state of the case's prelude (an extrusion's
    /// undisturbed flow, stepped before the case's first sample) to
    /// [`CaseObserver::save_prelude`], after one of its steps.
    fn prelude_due(&self) -> bool {
        false
    }
    /// The prelude's state after a step (JSON, opaque to the observer): if the process dies
    /// before the case's first saved state, the prelude continues from here.
    fn save_prelude(&mut self, _state: &str) {}
    /// The prelude state an interrupted case continues from (what
    /// [`CaseObserver::save_prelude`] got last), taken once.
    fn resume_prelude(&mut self) -> Option<String> {
        None
    }
    /// The finished prelude of another case with the same undisturbed flow (`key`: see
    /// [`crate::simulate::undisturbed::prelude_key`]), as [`CaseObserver::share_prelude`] got
    /// it: the case takes it instead of stepping its own.
    fn shared_prelude(&mut self, _key: &str) -> Option<String> {
        None
    }
    /// A finished prelude (JSON, opaque to the observer) for the cases of the same `key` that
    /// come later.
    fn share_prelude(&mut self, _key: &str, _finished: &str) {}
}

/// An extrusion's undisturbed steady free surface H̄ (the case without its particles).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct UndisturbedSurface {
    /// (x, H̄) from the die exit on.
    pub profile: Vec<[f64; 2]>,
    /// The swell ratio max H̄/H0.
    pub swell: f64,
    /// Steps it took.
    pub steps: usize,
    /// Whether it met the steady test (else: the surface at the time limit).
    pub steady: bool,
    /// Whether the case took it from an earlier case of the same undisturbed flow (its `steps`
    /// are that case's, not this one's work).
    #[serde(default)]
    pub shared: bool,
}
