//! The interface between the sweep engine and whatever simulates a case ([`CaseRunner`]), and a
//! deterministic fake runner for tests.

use std::time::Duration;

use crate::config::CaseSpec;
use crate::observe::{synthetic, CaseObserver, Control, OutcomeKind};

pub use crate::simulate::{CaseResult, RunStatus};

/// Something that simulates cases. Implementations must be deterministic for a given spec and call the
/// observer as described in [`CaseObserver`]. A case runs on one thread (cases run in parallel).
pub trait CaseRunner: Sync {
    /// `Ok` if this runner can simulate `case`, otherwise the reason (shown to the user).
    fn supports(&self, case: &CaseSpec) -> Result<(), String>;
    /// Simulates `case`, reporting to `obs`.
    fn run(&self, case: &CaseSpec, obs: &mut dyn CaseObserver) -> CaseResult;
    /// The resolved numerical settings `case` runs with, stored with its result (none by default).
    fn settings(&self, _case: &CaseSpec) -> Option<serde_json::Value> {
        None
    }
}

/// The runner the CLI uses: the solver-backed one.
pub fn default_runner() -> Box<dyn CaseRunner> {
    Box::new(super::solver_runner::SolverRunner)
}

/// What a [`FakeRunner`] does with a case.
#[derive(Debug, Clone, PartialEq)]
pub enum FakeBehaviour {
    /// Play the synthetic trajectory that ends in this outcome kind.
    Produce(OutcomeKind),
    /// Report divergence with this reason after a few steps.
    Diverge(String),
    /// Panic after a few steps.
    Panic,
    /// Return `Failed` at once.
    Fail(String),
}

/// Steps a [`FakeRunner`] takes before it diverges, panics or checkpoints.
const FAKE_STEPS_BEFORE_TROUBLE: u64 = 5;

/// Deterministic stand-in for the solver: plays [`synthetic`] trajectories chosen per case.
pub struct FakeRunner {
    /// Picks the behaviour from the case.
    pub behaviour: Box<dyn Fn(&CaseSpec) -> FakeBehaviour + Sync + Send>,
    /// Wall-clock pause per step (for kill and concurrency tests).
    pub step_delay: Duration,
    /// Cases the runner refuses (by `supports`).
    pub refuse: Box<dyn Fn(&CaseSpec) -> bool + Sync + Send>,
}

impl FakeRunner {
    /// A fake runner with the given behaviour, no delay, refusing nothing.
    pub fn new(behaviour: impl Fn(&CaseSpec) -> FakeBehaviour + Sync + Send + 'static) -> Self {
        FakeRunner {
            behaviour: Box::new(behaviour),
            step_delay: Duration::ZERO,
            refuse: Box::new(|_| false),
        }
    }
}

impl CaseRunner for FakeRunner {
    fn supports(&self, case: &CaseSpec) -> Result<(), String> {
        if (self.refuse)(case) {
            Err("the fake runner refuses this case".into())
        } else {
            Ok(())
        }
    }

    fn run(&self, case: &CaseSpec, obs: &mut dyn CaseObserver) -> CaseResult {
        let behaviour = (self.behaviour)(case);
        let kind = match &behaviour {
            FakeBehaviour::Produce(k) => *k,
            FakeBehaviour::Fail(e) => return CaseResult::failed(e.clone()),
            _ => OutcomeKind::Timeout,
        };
        let dt = case.numerics.dt.initial();
        let steps = (case.numerics.t_end / dt).round() as u64;
        let mut t = 0.0;
        // a saved state is the step it was saved after: the trajectory is a function of the step
        let first = obs
            .resume_state()
            .and_then(|s| serde_json::from_str::<u64>(&s).ok())
            .map_or(1, |step| step + 1);
        for step in first..=steps {
            t = step as f64 * dt;
            if !self.step_delay.is_zero() {
                std::thread::sleep(self.step_delay);
            }
            if step == FAKE_STEPS_BEFORE_TROUBLE {
                match &behaviour {
                    FakeBehaviour::Diverge(reason) => {
                        return CaseResult {
                            status: RunStatus::Diverged {
                                reason: reason.clone(),
                            },
                            steps: step,
                            t,
                            rejected_steps: None,
                            flow_solver: None,
                        }
                    }
                    FakeBehaviour::Panic => panic!("fake solver panicked at step {step}"),
                    _ => obs.checkpoint(),
                }
            }
            if obs.snapshot_due(step) {
                obs.on_snapshot(&fake_snapshot(step, t));
            }
            if obs.on_step(&synthetic::sample(kind, case, step, t)) == Control::Stop {
                return CaseResult {
                    status: RunStatus::Finished,
                    steps: step,
                    t,
                    rejected_steps: None,
                    flow_solver: None,
                };
            }
            if obs.state_due(step) {
                obs.save_state(step, &step.to_string());
            }
        }
        CaseResult {
            status: RunStatus::Finished,
            steps,
            t,
            rejected_steps: None,
            flow_solver: None,
        }
    }
}

/// A 2 × 1 element mesh with the four fields of a real snapshot.
fn fake_snapshot(step: u64, t: f64) -> crate::observe::FieldSnapshot {
    use crate::observe::{FieldSnapshot, NodalField};
    let coords = vec![
        [0.0, 0.0],
        [1.0, 0.0],
        [2.0, 0.0],
        [0.0, 1.0],
        [1.0, 1.0],
        [2.0, 1.0],
    ];
    let scalar = |name: &str, f: &dyn Fn([f64; 2]) -> f64| NodalField {
        name: name.into(),
        components: 1,
        values: coords.iter().map(|c| f(*c)).collect(),
    };
    FieldSnapshot {
        step,
        t,
        quads: vec![[0, 1, 4, 3], [1, 2, 5, 4]],
        fields: vec![
            NodalField {
                name: "u".into(),
                components: 2,
                values: coords.iter().flat_map(|c| [c[1] * t, 0.0]).collect(),
            },
            scalar("p", &|c| c[0] * t),
            scalar("tr_tau", &|c| c[0] + c[1]),
            scalar("level_set", &|c| c[0] - 1.0),
        ],
        coords,
    }
}
