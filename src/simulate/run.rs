//! The step loop of a case with its observer: samples every step, snapshots and saved states
//! when due, resume from a saved state, and how the run ended — contact and the observer's stop
//! are ends of the physics, a non-finite state is divergence, a failed solve is a failure that
//! keeps its step and phase.

use super::{SetupError, Simulation};
use crate::config::CaseSpec;
use crate::observe::{CaseObserver, Control};
use crate::solver::moving::{MovingError, StepOutcome};
use crate::solver::viscoelastic::ViscoelasticError;

/// How a run ended.
#[derive(Debug, Clone, PartialEq)]
pub enum RunStatus {
    /// Reached the end time, a contact, or stopped because the observer asked to.
    Finished,
    /// The state became non-finite or impossible (particle velocities, the log-conformation, the
    /// mesh displacement): recorded as outcome `diverged` with the reason.
    Diverged {
        /// What went wrong, e.g. "step 120: non-finite particle velocity".
        reason: String,
    },
    /// The run could not be carried out (a failed solve, a panic, I/O, an unsupported option):
    /// recorded as status `failed` with the error (step, phase and residual where known).
    Failed {
        /// The error.
        error: String,
    },
}

/// Result of one run.
#[derive(Debug, Clone, PartialEq)]
pub struct CaseResult {
    /// How it ended.
    pub status: RunStatus,
    /// Number of time steps taken.
    pub steps: u64,
    /// Simulated time reached.
    pub t: f64,
}

impl CaseResult {
    /// A run that failed before its first step.
    pub fn failed(error: String) -> CaseResult {
        CaseResult {
            status: RunStatus::Failed { error },
            steps: 0,
            t: 0.0,
        }
    }
}

/// How often (in steps) the observer is asked to commit what it has when no state is due.
const CHECKPOINT_EVERY: u64 = 50;

/// Builds `case` and runs it to its end time (or until the observer stops it), reporting every
/// step; continues from the observer's saved state if it has one.
pub fn run_case(case: &CaseSpec, obs: &mut dyn CaseObserver) -> CaseResult {
    let mut sim = match Simulation::new(case) {
        Ok(sim) => sim,
        Err(SetupError::Solver(e)) => return ended_by(e, 0, 0.0),
        Err(e) => return CaseResult::failed(e.to_string()),
    };
    if let Some(saved) = obs.resume_state() {
        // an interrupted attempt saved its state: continue from there (the observer already
        // has everything up to that step)
        if let Err(e) = sim.restore(&saved) {
            return CaseResult::failed(format!(
                "cannot continue from the saved state ({e}); rerun with --retry-failed to start over"
            ));
        }
    } else {
        if obs.snapshot_due(0) {
            obs.on_snapshot(&sim.snapshot());
        }
        if obs.on_step(&sim.sample()) != Control::Continue {
            return finished(&sim);
        }
    }
    let n_steps = sim.settings().time.steps as u64;
    while sim.steps() < n_steps {
        let contact = match sim.step() {
            Err(e) => return ended_by(e, sim.steps() + 1, sim.time()),
            Ok(StepOutcome::Contact(_)) => return finished(&sim),
            Ok(StepOutcome::Stepped(_)) => false,
            Ok(StepOutcome::ContactAfter(..)) => true,
        };
        let step = sim.steps();
        if obs.snapshot_due(step) {
            obs.on_snapshot(&sim.snapshot());
        }
        let keep = obs.on_step(&sim.sample()) == Control::Continue;
        if keep && !contact && obs.state_due(step) {
            obs.save_state(step, &sim.checkpoint());
        } else if step.is_multiple_of(CHECKPOINT_EVERY) {
            obs.checkpoint();
        }
        if !keep || contact {
            break;
        }
    }
    // every end (end time, stop, contact) is a finished case: the observer classifies it
    finished(&sim)
}

fn finished(sim: &Simulation) -> CaseResult {
    CaseResult {
        status: RunStatus::Finished,
        steps: sim.steps(),
        t: sim.time(),
    }
}

/// The end of a run by an error of `step`: divergence for a non-finite state, otherwise a
/// failure naming the step and the phase.
fn ended_by(e: MovingError, step: u64, t: f64) -> CaseResult {
    let status = if diverged(&e) {
        RunStatus::Diverged {
            reason: e.to_string(),
        }
    } else {
        RunStatus::Failed {
            error: format!("step {step}, {}: {e}", e.phase()),
        }
    };
    CaseResult {
        status,
        steps: step.saturating_sub(1),
        t,
    }
}

/// Whether an error is a non-finite state of the physics (particle velocities, the
/// log-conformation, the mesh displacement) rather than a failure of the numerics.
fn diverged(e: &MovingError) -> bool {
    use crate::solver::ale::AleError;
    use crate::solver::constitutive::ConstitutiveError;
    matches!(
        e,
        MovingError::NonFinite { .. }
            | MovingError::Ale {
                source: AleError::NonFinite { .. },
                ..
            }
            | MovingError::Flow(ViscoelasticError::Stress(
                ConstitutiveError::NonFinite { .. }
            ))
    )
}
