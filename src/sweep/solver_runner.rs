//! The case runner backed by the solver: maps a [`CaseSpec`] to a solver set-up and reports every
//! step to the sweep engine's observer.
//!
//! Supported today: confined shear flow of a Newtonian fluid (Wi = 0), quasi-static Stokes motion
//! of free particles ([`crate::solver::motion`]). Viscoelastic cases (Wi > 0) and Couette flow are
//! refused with a message until their solvers land.

use crate::config::{CaseSpec, Geometry};
use crate::fem::element::{q1, Q2_NODES};
use crate::mesh::Mesh;
use crate::observe::{CaseObserver, Control, FieldSnapshot, NodalField, ParticleState, Sample};
use crate::particles::RigidState;
use crate::solver::cutcells::level_set;
use crate::solver::motion::{FlowFields, MotionEnd, ShearCase};
use crate::sweep::runner::{CaseResult, CaseRunner, RunStatus};
use crate::xfem::LevelSet;
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

/// Field snapshot on the Q2 nodes (each element drawn as 4 sub-quadrilaterals; the periodic seam
/// gets its own column of nodes so that no quad spans the domain): velocity, pressure
/// (interpolated bilinearly from the Q1 vertices) and the particles' level set.
fn snapshot(step: u64, t: f64, mesh: &Mesh, f: &FlowFields, period: f64) -> FieldSnapshot {
    let (nx, ny) = mesh.dims();
    let cols = 2 * nx + 1;
    let n = cols * (2 * ny + 1);
    let mut coords = vec![[0.0; 2]; n];
    let mut u = vec![0.0; 2 * n];
    let mut p = vec![0.0; n];
    let mut quads = Vec::with_capacity(4 * nx * ny);
    for e in 0..mesh.n_elements() {
        let (ex, ey) = (e % nx, e / nx);
        let pv: Vec<f64> = mesh.element_vertices[e].iter().map(|&v| f.p[v]).collect();
        for b in 0..3 {
            for a in 0..3 {
                let id = (2 * ex + a) + cols * (2 * ey + b);
                let k = a + 3 * b;
                coords[id] = mesh.element_coords[e][k];
                let node = mesh.elements[e][k];
                u[2 * id] = f.u[node][0];
                u[2 * id + 1] = f.u[node][1];
                let psi = q1(Q2_NODES[k]).0;
                p[id] = (0..4).map(|m| psi[m] * pv[m]).sum();
            }
        }
        for (a, b) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
            let id = |da: usize, db: usize| (2 * ex + a + da) + cols * (2 * ey + b + db);
            quads.push([id(0, 0), id(1, 0), id(1, 1), id(0, 1)]);
        }
    }
    let mut fields = vec![
        NodalField {
            name: "u".into(),
            components: 2,
            values: u,
        },
        NodalField {
            name: "p".into(),
            components: 1,
            values: p,
        },
    ];
    if let Ok(ls) = level_set(&f.particles, Some(period)) {
        fields.push(NodalField {
            name: "level_set".into(),
            components: 1,
            values: coords.iter().map(|&x| ls.value(x)).collect(),
        });
    }
    FieldSnapshot {
        step,
        t,
        coords,
        quads,
        fields,
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
        let end = setup.run(&mut |step, t, state, mesh, fields| {
            last_step = step;
            last_t = t;
            if obs.snapshot_due(step) {
                obs.on_snapshot(&snapshot(step, t, mesh, fields, setup.l));
            }
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
