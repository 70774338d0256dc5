//! The case runner backed by the solver: maps a [`CaseSpec`] to a solver set-up and reports every
//! step to the sweep engine's observer.
//!
//! Supported today: confined shear flow of a Newtonian fluid (Wi = 0), quasi-static Stokes motion
//! of free particles ([`crate::solver::motion`]). Viscoelastic cases (Wi > 0) and Couette flow are
//! refused with a message until their solvers land.

use crate::config::{CaseSpec, Geometry};
use crate::observe::{CaseObserver, Control, ParticleState, Sample};
use crate::particles::RigidState;
use crate::solver::motion::{MotionEnd, ShearCase};
use crate::sweep::runner::{CaseResult, CaseRunner, RunStatus};
use crate::xfem::{CutOptions, InterfaceApprox};

/// Runs cases with the XFEM solver.
#[derive(Debug, Clone, Copy, Default)]
pub struct SolverRunner;

impl SolverRunner {
    fn shear_case(case: &CaseSpec) -> Option<ShearCase> {
        let Geometry::ConfinedShear { h, l, wall_speed } = case.geometry else {
            return None;
        };
        let x0 = case.initial_positions();
        let a = case.radius()?;
        Some(ShearCase {
            h,
            l,
            wall_speed,
            eta: case.solvent_viscosity() + case.polymer_viscosity(),
            radius: vec![a; x0.len()],
            x0,
            mesh: case.numerics.mesh,
            dt: case.numerics.dt,
            t_end: case.numerics.t_end,
            cut: CutOptions {
                level: case.numerics.quadtree_level,
                interface: InterfaceApprox::Linear,
            },
        })
    }
}

/// Observer sample from the solver state (ω and θ clockwise positive, as the store expects).
fn sample(step: u64, t: f64, s: &RigidState) -> Sample {
    Sample {
        step,
        t,
        particles: (0..s.x.len())
            .map(|i| ParticleState {
                x: s.x[i][0],
                y: s.x[i][1],
                u: s.u[i][0],
                v: s.u[i][1],
                omega: -s.omega[i],
                theta: -s.theta[i],
            })
            .collect(),
    }
}

impl CaseRunner for SolverRunner {
    fn supports(&self, case: &CaseSpec) -> Result<(), String> {
        match case.geometry {
            Geometry::ConfinedShear { .. } if case.fluid.wi == 0.0 && case.radius().is_some() => Ok(()),
            Geometry::ConfinedShear { .. } if case.radius().is_none() => {
                Err("confined shear without particles has nothing to simulate".into())
            }
            Geometry::ConfinedShear { .. } => Err(format!(
                "viscoelastic particle motion (Wi = {}) is not built yet (issues 4 and 5); Wi = 0 runs",
                case.fluid.wi
            )),
            _ => Err(format!("the solver for {} is not built yet", case.geometry.kind())),
        }
    }

    fn run(&self, case: &CaseSpec, _threads: usize, obs: &mut dyn CaseObserver) -> CaseResult {
        let Some(setup) = Self::shear_case(case) else {
            return CaseResult {
                status: RunStatus::Failed {
                    error: format!("unsupported case ({})", case.geometry.kind()),
                },
                steps: 0,
                t: 0.0,
            };
        };
        let (mut last_step, mut last_t) = (0, 0.0);
        let end = setup.run(&mut |step, t, state| {
            last_step = step;
            last_t = t;
            let keep = obs.on_step(&sample(step, t, state)) == Control::Continue;
            if step % 50 == 0 {
                obs.checkpoint();
            }
            keep
        });
        let status = match end {
            Ok(MotionEnd::EndTime | MotionEnd::Stopped | MotionEnd::Contact(_)) => {
                RunStatus::Finished
            }
            Err(e) => RunStatus::Diverged {
                reason: e.to_string(),
            },
        };
        CaseResult {
            status,
            steps: last_step,
            t: last_t,
        }
    }
}
