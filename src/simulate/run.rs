//! The step loop of a case with its observer: samples every step, snapshots and saved states
//! when due, resume from a saved state, and how the run ended — contact and the observer's stop
//! are ends of the physics, a non-finite state is divergence, a failed solve is a failure that
//! keeps its step and phase.

use super::{SetupError, Simulation, Undisturbed};
use crate::config::CaseSpec;
use crate::observe::{CaseObserver, Control, UndisturbedSurface};
use crate::solver::flow::FlowSolverStats;
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
    /// Steps the adaptive step controller tried and redone, beside the `steps` kept (`None`:
    /// a fixed Δt, or a run that ended in an error).
    pub rejected_steps: Option<u64>,
    /// The flow solves' GMRES iterations and LU fallbacks in this process (`None`: a run that
    /// ended in an error, or no solver).
    pub flow_solver: Option<FlowSolverStats>,
}

impl CaseResult {
    /// A run that failed before its first step.
    pub fn failed(error: String) -> CaseResult {
        CaseResult {
            status: RunStatus::Failed { error },
            steps: 0,
            t: 0.0,
            rejected_steps: None,
            flow_solver: None,
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
        // (the initial solve is step 0)
        Err(SetupError::Solver(e)) => return ended_by(e, 0, 0.0),
        Err(e) => return CaseResult::failed(e.to_string()),
    };
    let resumed = obs.resume_state();
    if let Some(saved) = &resumed {
        // an interrupted attempt saved its state: continue from there (the observer already
        // has everything up to that step)
        if let Err(e) = sim.restore(saved) {
            return CaseResult::failed(format!(
                "cannot continue from the saved state ({e}); rerun with --retry-failed to start over"
            ));
        }
    }
    // (an extrusion's undisturbed surface, unless the saved state has it)
    if let Err((e, steps, t)) = settle(&mut sim, obs) {
        return ended_in_prelude(e, steps, t);
    }
    if resumed.is_none() {
        if let Some(u) = sim.undisturbed() {
            let s = &u.surface;
            obs.on_undisturbed_surface(&UndisturbedSurface {
                profile: s.profile(),
                swell: u.swell(),
                steps: u.steps,
                steady: u.steady,
                shared: u.shared,
            });
        }
        if obs.snapshot_due(0) {
            obs.on_snapshot(&sim.snapshot());
        }
        if obs.on_step(&sim.sample()) != Control::Continue {
            return finished(&sim);
        }
    }
    while !sim.at_end() {
        let contact = match sim.step() {
            Err(e) => {
                // a failed solve from touching particles is their contact, not a fault
                if let Some(c) = sim.touching().filter(|_| !non_finite_state(&e)) {
                    let error = failure_message(&e, sim.steps());
                    obs.on_contact_at_failure(&c, sim.time(), &error);
                    return finished(&sim);
                }
                let mut result = ended_by(e, sim.steps(), sim.time());
                note_film(&mut result, sim.sample().gap_elements);
                return result;
            }
            Ok(StepOutcome::Contact(c)) => {
                obs.on_contact(&c, sim.time());
                return finished(&sim);
            }
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

/// Steps the case's prelude (an extrusion's undisturbed flow) to its end, continuing from the
/// observer's saved prelude state if it has one (one that does not fit starts it over) and
/// handing it its state when due — unless the observer has the finished prelude of a case with
/// the same undisturbed flow, which it then takes; a prelude it finishes it shares. An error
/// comes with the prelude's completed steps and time.
fn settle(sim: &mut Simulation, obs: &mut dyn CaseObserver) -> Result<(), (MovingError, u64, f64)> {
    let at_start = |e| (e, 0, 0.0);
    let Some(key) = sim.prelude_key() else {
        return Ok(());
    };
    // another case with the same undisturbed flow may have computed it already (asked before
    // the prelude's flow is built: its set-up solves the flow once)
    let shared = obs
        .shared_prelude(&key)
        .and_then(|json| serde_json::from_str::<Undisturbed>(&json).ok());
    if let Some(undisturbed) = shared {
        sim.settle_with(Undisturbed {
            shared: true,
            ..undisturbed
        });
        return Ok(());
    }
    let Some(mut prelude) = sim.prelude().map_err(at_start)? else {
        return Ok(());
    };
    if let Some(saved) = obs.resume_prelude() {
        if prelude.restore(&saved).is_err() {
            // (a restore that failed half-way leaves a flow of neither state)
            prelude =
                (sim.prelude().map_err(at_start)?).expect("a case with a prelude has one again");
        }
    }
    while !prelude.done() {
        prelude
            .step()
            .map_err(|e| (e, prelude.steps() as u64, prelude.time()))?;
        obs.on_prelude_step(prelude.time(), prelude.steps());
        if obs.prelude_due() {
            obs.save_prelude(&prelude.checkpoint());
        }
    }
    let undisturbed = prelude.finish();
    if let Ok(json) = serde_json::to_string(&undisturbed) {
        obs.share_prelude(&key, &json);
    }
    sim.settle_with(undisturbed);
    Ok(())
}

fn finished(sim: &Simulation) -> CaseResult {
    CaseResult {
        status: RunStatus::Finished,
        steps: sim.steps(),
        t: sim.time(),
        rejected_steps: sim.rejected_steps(),
        flow_solver: Some(sim.flow_solver_stats()),
    }
}

/// The end of a run by an error of the step after `steps` completed ones: divergence for a
/// non-finite state, otherwise a failure naming the step and the phase.
fn ended_by(e: MovingError, steps: u64, t: f64) -> CaseResult {
    let status = if diverged(&e) {
        RunStatus::Diverged {
            reason: e.to_string(),
        }
    } else {
        RunStatus::Failed {
            error: failure_message(&e, steps),
        }
    };
    CaseResult {
        status,
        steps,
        t,
        rejected_steps: None,
        flow_solver: None,
    }
}

/// "step N, phase: error" for an error of the step after `steps` completed ones: N is the step
/// the error names where it names one (the flow counts a step before its surface's kinematic
/// step can fail), else the next.
fn failure_message(e: &MovingError, steps: u64) -> String {
    let step = e.step().unwrap_or(steps as usize + 1);
    format!("step {step}, {}: {e}", e.phase())
}

/// Adds the narrowest film at a failure to its message when fewer than
/// [`MIN_GAP_ELEMENTS`](crate::observe::outcome::MIN_GAP_ELEMENTS) elements resolve it: a solve
/// that fails as a film closes below what the mesh resolves is the physics of near contact meeting
/// the mesh, not a fault of the step (the §6.5 particle at Wi = 0.5 on a/4 failed in the flow
/// solve 0.03 elements from the free surface).
fn note_film(result: &mut CaseResult, gap_elements: Option<f64>) {
    let Some(film) = gap_elements.filter(|&g| g < crate::observe::outcome::MIN_GAP_ELEMENTS) else {
        return;
    };
    let note = format!(
        " [the narrowest film was {film:.2} elements across: unresolved, the failure may be its \
         closing]"
    );
    match &mut result.status {
        RunStatus::Diverged { reason } => reason.push_str(&note),
        RunStatus::Failed { error } => error.push_str(&note),
        _ => {}
    }
}

/// The end of a run by an error in its prelude (an extrusion's undisturbed flow) after `steps`
/// completed prelude steps at time `t`: as [`ended_by`], the message naming the prelude, its
/// step and time, and the run itself at step 0.
fn ended_in_prelude(e: MovingError, steps: u64, t: f64) -> CaseResult {
    let mut result = ended_by(e, steps, t);
    let prelude = format!("undisturbed prelude, t = {t:.4}: ");
    match &mut result.status {
        RunStatus::Diverged { reason } => reason.insert_str(0, &prelude),
        RunStatus::Failed { error } => error.insert_str(0, &prelude),
        RunStatus::Finished => {}
    }
    (result.steps, result.t) = (0, 0.0);
    result
}

/// Whether an error is a blown-up state (a non-finite state, or a flow system with non-finite
/// entries) rather than a failure of the numerics.
fn diverged(e: &MovingError) -> bool {
    // a flow system whose solve gives a NaN residual holds non-finite entries: the state blew up
    // (with touching particles the runner takes it for their contact first)
    let non_finite_system = matches!(
        e,
        MovingError::Flow(ViscoelasticError::Flow { source, .. }) if source.non_finite()
    );
    non_finite_system || non_finite_state(e)
}

/// Whether the error is a non-finite state (particles, mesh map or stress).
fn non_finite_state(e: &MovingError) -> bool {
    use crate::solver::ale::AleError;
    use crate::solver::constitutive::ConstitutiveError;
    matches!(
        e,
        MovingError::NonFinite { .. }
            | MovingError::Jumped { .. }
            | MovingError::Ale {
                source: AleError::NonFinite { .. },
                ..
            }
            | MovingError::Flow(ViscoelasticError::Stress(
                ConstitutiveError::NonFinite { .. }
            ))
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fem::linsolve::SolveError;
    use crate::solver::constitutive::ConstitutiveError;

    /// Non-finite states are divergence (physics), and so is a flow solve whose residual is NaN
    /// (its system holds them); a failed solve is a failure that names its step, phase and
    /// residual.
    #[test]
    fn a_failed_solve_is_a_failure_and_a_non_finite_state_divergence() {
        let blown = ended_by(MovingError::NonFinite { step: 8 }, 7, 0.7);
        assert!(
            matches!(blown.status, RunStatus::Diverged { .. }),
            "{blown:?}"
        );
        let stress = MovingError::Flow(ViscoelasticError::Stress(ConstitutiveError::NonFinite {
            step: 8,
            vertex: 3,
        }));
        assert!(matches!(
            ended_by(stress, 7, 0.7).status,
            RunStatus::Diverged { .. }
        ));
        let solve = MovingError::Flow(ViscoelasticError::Flow {
            step: 8,
            source: SolveError::Inaccurate { residual: 3.2e-3 },
        });
        let r = ended_by(solve, 7, 0.7);
        assert_eq!((r.steps, r.t), (7, 0.7));
        match &r.status {
            RunStatus::Failed { error } => {
                assert!(error.starts_with("step 8, solve_flow:"), "{error}");
                assert!(error.contains("3.200e-3"), "{error}");
            }
            s => panic!("a failed solve is not physics: {s:?}"),
        }
        // an error that names its step is reported at it, not at the steps counted plus one
        let escaped = MovingError::SurfaceEscaped {
            step: 455,
            x: 0.0667,
            height: -1.2,
            moved: 5.8,
        };
        let RunStatus::Failed { error } = ended_by(escaped, 455, 6.8).status else {
            panic!("a surface through the symmetry line is a failure");
        };
        assert!(error.starts_with("step 455, advance_surface:"), "{error}");
        // an unresolved film at the failure is named; a resolved one is not
        for (film, named) in [(Some(0.03), true), (Some(2.5), false), (None, false)] {
            let mut noted = r.clone();
            note_film(&mut noted, film);
            let RunStatus::Failed { error } = noted.status else {
                panic!("still a failure");
            };
            assert_eq!(error.contains("film was 0.03 elements"), named, "{error}");
        }
        // a NaN residual: the system itself is no longer finite (a blown-up state)
        let nan = MovingError::Flow(ViscoelasticError::Flow {
            step: 99,
            source: SolveError::Inaccurate { residual: f64::NAN },
        });
        assert!(matches!(
            ended_by(nan, 98, 1.47).status,
            RunStatus::Diverged { .. }
        ));
    }

    /// An error in an extrusion's prelude names the prelude, its step and time, not step 1 of
    /// the run.
    #[test]
    fn a_failure_in_the_prelude_names_the_prelude_step() {
        let solve = MovingError::Flow(ViscoelasticError::Flow {
            step: 2057,
            source: SolveError::Inaccurate { residual: 3.2e-3 },
        });
        let r = ended_in_prelude(solve, 2056, 15.42);
        assert_eq!((r.steps, r.t), (0, 0.0));
        match r.status {
            RunStatus::Failed { error } => {
                assert!(
                    error.starts_with("undisturbed prelude, t = 15.4200: step 2057, solve_flow:"),
                    "{error}"
                );
            }
            s => panic!("a failed solve is not physics: {s:?}"),
        }
    }
}
