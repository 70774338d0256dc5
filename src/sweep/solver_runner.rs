//! The case runner backed by the solver: maps a [`CaseSpec`] to a solver set-up and reports every
//! step to the sweep engine's observer.
//!
//! Supported: confined shear flow and the circular Couette cell with free particles. Wi = 0 in
//! confined shear is quasi-static Stokes motion ([`crate::solver::motion`]); Wi > 0 (and every
//! Couette case) runs the viscoelastic moving-particle step of [`crate::solver::moving`] with the
//! stress coupling of `numerics.coupling` (default: explicit with LBLᵀ when β > 0, the
//! semi-implicit stress of thesis Eq. 5.51 for β = 0). The
//! cylinder-channel benchmark is run by `xpflow validate cylinder`, not as a sweep case.

use crate::config::{CaseSpec, Geometry, HistoryRemap, StressCoupling};
use crate::fem::element::{q1, Q2_NODES};
use crate::mesh::Mesh;
use crate::observe::{CaseObserver, Control, FieldSnapshot, NodalField, ParticleState, Sample};
use crate::particles::RigidState;
use crate::rheology::Sym2;
use crate::solver::ale::Remap;
use crate::solver::constitutive_stress::Coupling;
use crate::solver::couette::CouetteGeometry;
use crate::solver::cutcells::level_set;
use crate::solver::motion::{FlowFields, MotionEnd, ShearCase};
use crate::solver::moving::{
    ComputationalMesh, Domain, MovingCheckpoint, MovingEnd, MovingParticles, RotatingCouette,
    ShearDomain,
};
use crate::solver::rigid::{Motion, Particle};
use crate::solver::viscoelastic::ViscoelasticParams;
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
            grading: case.numerics.grading,
            grading_x: case.numerics.grading_x,
            dt: case.numerics.dt,
            t_end: case.numerics.t_end,
            cut: CutOptions {
                level: case.numerics.quadtree_level,
                interface: InterfaceApprox::Linear,
            },
        })
    }
}

/// The ALE interpolation of a case's `numerics.remap`.
pub fn ale_remap(remap: HistoryRemap) -> Remap {
    match remap {
        HistoryRemap::Bilinear => Remap::Bilinear,
        HistoryRemap::Biquadratic => Remap::Quadratic,
        HistoryRemap::Bicubic => Remap::Cubic,
    }
}

/// The frame the solver works in, relative to the lab ([`CaseSpec::solver_frame`]).
#[derive(Debug, Clone, Copy, PartialEq)]
enum Frame {
    /// Translating along x at this velocity.
    Translating(f64),
    /// Rotating counter-clockwise about the origin at this angular velocity.
    Rotating(f64),
}

impl Frame {
    const LAB: Frame = Frame::Translating(0.0);

    /// The frame of a case ([`CaseSpec::solver_frame`]).
    fn of(case: &CaseSpec) -> Frame {
        match case.solver_frame() {
            (_, rotation) if rotation != 0.0 => Frame::Rotating(rotation),
            (velocity, _) => Frame::Translating(velocity),
        }
    }

    /// A position and a velocity of the solver's frame at time t in the lab frame.
    fn to_lab(self, t: f64, x: [f64; 2], u: [f64; 2]) -> ([f64; 2], [f64; 2]) {
        match self {
            Frame::Translating(v) => ([x[0] + v * t, x[1]], [u[0] + v, u[1]]),
            Frame::Rotating(w) => {
                let (s, c) = (w * t).sin_cos();
                let rot = |p: [f64; 2]| [c * p[0] - s * p[1], s * p[0] + c * p[1]];
                let (xl, ul) = (rot(x), rot(u));
                // plus the frame's rigid rotation Ω × x
                (xl, [ul[0] - w * xl[1], ul[1] + w * xl[0]])
            }
        }
    }

    /// The frame's velocity along x.
    fn velocity(self) -> f64 {
        match self {
            Frame::Translating(v) => v,
            Frame::Rotating(_) => 0.0,
        }
    }

    /// The frame's angular velocity (counter-clockwise).
    fn spin(self) -> f64 {
        match self {
            Frame::Translating(_) => 0.0,
            Frame::Rotating(w) => w,
        }
    }
}

/// Observer sample from the solver state in the lab frame (ω and θ clockwise positive, as the
/// store expects).
fn sample(step: u64, t: f64, s: &RigidState, frame: Frame) -> Sample {
    Sample {
        step,
        t,
        particles: (0..s.x.len())
            .map(|i| {
                let (x, u) = frame.to_lab(t, s.x[i], s.u[i]);
                ParticleState {
                    x: x[0],
                    y: x[1],
                    u: u[0],
                    v: u[1],
                    omega: -(s.omega[i] + frame.spin()),
                    theta: -(s.theta[i] + frame.spin() * t),
                }
            })
            .collect(),
    }
}

/// The polymer-stress fields of a snapshot: tr τ and the components (xx, xy, yy).
const STRESS_FIELDS: [&str; 4] = ["tr_tau", "tau_xx", "tau_xy", "tau_yy"];

/// Field snapshot on the Q2 nodes (each element drawn as 4 sub-quadrilaterals; the periodic seam
/// gets its own column of nodes so that no quad spans the domain): velocity, pressure and, for a
/// viscoelastic fluid, the polymer stress ([`STRESS_FIELDS`]; both interpolated bilinearly from
/// the Q1 vertices), and the particles' level set.
fn snapshot(step: u64, t: f64, mesh: &Mesh, f: &FlowFields, period: Option<f64>) -> FieldSnapshot {
    let (nx, ny) = mesh.dims();
    let cols = 2 * nx + 1;
    let n = cols * (2 * ny + 1);
    let mut coords = vec![[0.0; 2]; n];
    let mut u = vec![0.0; 2 * n];
    let mut p = vec![0.0; n];
    let with_stress = !f.tau.is_empty();
    let mut stress = vec![vec![0.0; if with_stress { n } else { 0 }]; STRESS_FIELDS.len()];
    let mut quads = Vec::with_capacity(4 * nx * ny);
    for e in 0..mesh.n_elements() {
        let (ex, ey) = (e % nx, e / nx);
        let vs = mesh.element_vertices[e];
        for b in 0..3 {
            for a in 0..3 {
                let id = (2 * ex + a) + cols * (2 * ey + b);
                let k = a + 3 * b;
                coords[id] = mesh.element_coords[e][k];
                let node = mesh.elements[e][k];
                u[2 * id] = f.u[node][0];
                u[2 * id + 1] = f.u[node][1];
                let psi = q1(Q2_NODES[k]).0;
                p[id] = (0..4).map(|m| psi[m] * f.p[vs[m]]).sum();
                if with_stress {
                    let tau = (0..4).fold(Sym2::new(0.0, 0.0, 0.0), |acc, m| {
                        acc + psi[m] * f.tau[vs[m]]
                    });
                    let values = [tau.xx + tau.yy, tau.xx, tau.xy, tau.yy];
                    for (field, v) in stress.iter_mut().zip(values) {
                        field[id] = v;
                    }
                }
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
    if with_stress {
        for (name, values) in STRESS_FIELDS.iter().zip(stress) {
            fields.push(NodalField {
                name: (*name).into(),
                components: 1,
                values,
            });
        }
    }
    if let Ok(ls) = level_set(&f.particles, period) {
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

/// A snapshot of the solver's frame moved into the lab frame (node positions, velocity and the
/// polymer stress's components).
fn in_lab(mut snap: FieldSnapshot, frame: Frame) -> FieldSnapshot {
    if frame == Frame::LAB {
        return snap;
    }
    let t = snap.t;
    if let Frame::Rotating(w) = frame {
        // τ_lab = R τ Rᵀ with R the rotation by ωt (tr τ is invariant)
        let (s, c) = (w * t).sin_cos();
        let at: Vec<Option<usize>> = STRESS_FIELDS[1..]
            .iter()
            .map(|name| snap.fields.iter().position(|f| f.name == *name))
            .collect();
        if let [Some(ixx), Some(ixy), Some(iyy)] = at[..] {
            for k in 0..snap.coords.len() {
                let (xx, xy, yy) = (
                    snap.fields[ixx].values[k],
                    snap.fields[ixy].values[k],
                    snap.fields[iyy].values[k],
                );
                snap.fields[ixx].values[k] = c * c * xx - 2.0 * s * c * xy + s * s * yy;
                snap.fields[ixy].values[k] = s * c * (xx - yy) + (c * c - s * s) * xy;
                snap.fields[iyy].values[k] = s * s * xx + 2.0 * s * c * xy + c * c * yy;
            }
        }
    }
    let u = snap.fields.iter_mut().find(|f| f.name == "u");
    let mut u = u.map(|f| &mut f.values);
    for (k, c) in snap.coords.iter_mut().enumerate() {
        let uk = u.as_ref().map_or([0.0; 2], |u| [u[2 * k], u[2 * k + 1]]);
        let (x, ul) = frame.to_lab(t, *c, uk);
        *c = x;
        if let Some(u) = u.as_mut() {
            u[2 * k] = ul[0];
            u[2 * k + 1] = ul[1];
        }
    }
    snap
}

impl CaseRunner for SolverRunner {
    fn supports(&self, case: &CaseSpec) -> Result<(), String> {
        match case.geometry {
            Geometry::ConfinedShear { .. } | Geometry::Couette { .. } if case.radius().is_none() => {
                Err(format!(
                    "{} without particles has nothing to simulate",
                    case.geometry.kind()
                ))
            }
            Geometry::ConfinedShear { .. } | Geometry::Couette { .. } => Ok(()),
            Geometry::CylinderChannel { .. } => Err(
                "the cylinder-channel benchmark runs with `xpflow validate cylinder`, not as a case"
                    .into(),
            ),
        }
    }

    fn run(&self, case: &CaseSpec, _threads: usize, obs: &mut dyn CaseObserver) -> CaseResult {
        let viscoelastic = case.relaxation_time() > 0.0;
        match case.geometry {
            Geometry::ConfinedShear { h, l, wall_speed } if viscoelastic => {
                let Some(mesh) = case.base_mesh() else {
                    unreachable!("a confined-shear case has a mesh")
                };
                // a frame translating at U_f: walls at −U_f ± U_w/2
                let domain = ShearDomain {
                    h,
                    l,
                    wall_speed,
                    drift: -Frame::of(case).velocity(),
                };
                return run_moving(case, mesh, domain, obs);
            }
            Geometry::Couette {
                r1,
                r2,
                omega_inner,
            } => {
                let g = match CouetteGeometry::new(r1, r2, omega_inner) {
                    Ok(g) => g,
                    Err(e) => return failed(e.to_string()),
                };
                let Some(mesh) = case.base_mesh() else {
                    unreachable!("a Couette case has a mesh")
                };
                let domain = RotatingCouette {
                    geometry: g,
                    frame: Frame::of(case).spin(),
                };
                return run_moving(case, mesh, domain, obs);
            }
            _ => {}
        }
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
                obs.on_snapshot(&snapshot(step, t, mesh, fields, Some(setup.l)));
            }
            let keep = obs.on_step(&sample(step, t, state, Frame::LAB)) == Control::Continue;
            if step % 50 == 0 {
                obs.checkpoint();
            }
            keep
        });
        // every end (end time, stop, contact) is a finished case: the observer classifies it
        let end = end.map(|_: MotionEnd| ()).map_err(|e| e.to_string());
        case_result(end, last_step, last_t)
    }
}

fn failed(error: String) -> CaseResult {
    CaseResult {
        status: RunStatus::Failed { error },
        steps: 0,
        t: 0.0,
    }
}

/// Viscoelastic (or, in the Couette cell at Wi = 0, Newtonian) motion of free particles with the
/// moving-particle time step; every step goes to the observer, contact ends the case normally (the
/// observer classifies it), a failed solve or blow-up is recorded as divergence.
fn run_moving<D: Domain>(
    case: &CaseSpec,
    mesh: Mesh,
    domain: D,
    obs: &mut dyn CaseObserver,
) -> CaseResult {
    let (eta_s, eta_p) = (case.solvent_viscosity(), case.polymer_viscosity());
    let lambda = case.relaxation_time();
    let (dt, t_end) = (case.numerics.dt, case.numerics.t_end);
    let mut params = if lambda > 0.0 {
        ViscoelasticParams::new(eta_s, eta_p, lambda, case.fluid.alpha, dt, t_end)
    } else {
        // Newtonian: a polymer of negligible viscosity and relaxation time, i.e. Stokes flow
        // with the moving-particle machinery (the quasi-static path exists for confined shear)
        const TRACE: f64 = 1e-12;
        // (λ = 10Δt keeps the explicit relaxation term well inside its stability limit)
        ViscoelasticParams::new(
            eta_s + eta_p,
            TRACE * (eta_s + eta_p),
            10.0 * dt,
            0.0,
            dt,
            t_end,
        )
    };
    match case.numerics.coupling {
        // without solvent viscosity the explicit stress has no viscous term (thesis §5.3.2)
        StressCoupling::Auto if eta_s == 0.0 => params.coupling = Coupling::SemiImplicit,
        StressCoupling::Auto | StressCoupling::Explicit => params.coupling = Coupling::Explicit,
        StressCoupling::ExplicitCoupledG => {
            params.coupling = Coupling::Explicit;
            params.coupled_g = true;
        }
        StressCoupling::SemiImplicit => params.coupling = Coupling::SemiImplicit,
    }
    let x0 = case.initial_positions();
    let Some(a) = case.radius() else {
        return failed("no particles".into());
    };
    let cut = CutOptions {
        level: case.numerics.quadtree_level,
        interface: InterfaceApprox::Linear,
    };
    let period = domain.period();
    let frame = Frame::of(case);
    let mesh: ComputationalMesh = match case.following_mesh() {
        Some(follow) => follow.into(),
        None => mesh.into(),
    };
    let built = MovingParticles::free(mesh, params, domain, x0, a, cut);
    let mut sim = match built {
        Ok(s) => s,
        Err(e) => {
            return CaseResult {
                status: RunStatus::Diverged {
                    reason: e.to_string(),
                },
                steps: 0,
                t: 0.0,
            }
        }
    };
    sim.set_remap(ale_remap(case.numerics.remap));
    let fields = |sim: &MovingParticles<D>| FlowFields {
        u: sim.flow().velocity().to_vec(),
        p: sim.flow().pressure().to_vec(),
        tau: sim.flow().polymer_stress(),
        particles: sim
            .state()
            .x
            .iter()
            .map(|&center| Particle {
                center,
                radius: a,
                motion: Motion::Free,
            })
            .collect(),
    };
    if let Some(saved) = obs.resume_state() {
        // an interrupted attempt saved its state: continue from there (the observer already
        // has everything up to that step)
        let restored = serde_json::from_str::<MovingCheckpoint>(&saved)
            .map_err(|e| e.to_string())
            .and_then(|cp| sim.restore(cp).map_err(|e| e.to_string()));
        if let Err(e) = restored {
            return failed(format!(
                "cannot continue from the saved state ({e}); rerun with --retry-failed to start over"
            ));
        }
    } else {
        if obs.snapshot_due(0) {
            obs.on_snapshot(&in_lab(
                snapshot(0, 0.0, sim.flow().mesh(), &fields(&sim), period),
                frame,
            ));
        }
        if obs.on_step(&sample(0, 0.0, sim.state(), frame)) != Control::Continue {
            return CaseResult {
                status: RunStatus::Finished,
                steps: 0,
                t: 0.0,
            };
        }
    }
    let (mut last_step, mut last_t) = (sim.flow().history().steps() as u64, sim.time());
    let end = sim.run(t_end, false, |sim, report| {
        let step = report.flow.step as u64;
        let t = sim.time();
        last_step = step;
        last_t = t;
        if obs.snapshot_due(step) {
            obs.on_snapshot(&in_lab(
                snapshot(step, t, sim.flow().mesh(), &fields(sim), period),
                frame,
            ));
        }
        let keep = obs.on_step(&sample(step, t, sim.state(), frame)) == Control::Continue;
        if keep && obs.state_due(step) {
            // (serializing plain numbers cannot fail)
            if let Ok(state) = serde_json::to_string(&sim.checkpoint()) {
                obs.save_state(step, &state);
            }
        } else if step.is_multiple_of(50) {
            obs.checkpoint();
        }
        keep
    });
    let end = end.map(|_: MovingEnd| ()).map_err(|e| e.to_string());
    case_result(end, last_step, last_t)
}

/// A run that ended (`Ok`) is finished, whatever stopped it; an error is divergence.
fn case_result(end: Result<(), String>, steps: u64, t: f64) -> CaseResult {
    let status = match end {
        Ok(()) => RunStatus::Finished,
        Err(reason) => RunStatus::Diverged { reason },
    };
    CaseResult { status, steps, t }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// τ = e_x ⊗ e_x in a frame rotated by ωt = π/4 is ((1, 1), (1, 1))/2 in the lab (R τ Rᵀ
    /// with the rotation `to_lab` applies to positions); tr τ is unchanged.
    #[test]
    fn the_stress_of_a_rotating_frame_is_rotated_into_the_lab() {
        let scalar = |name: &str, v: f64| NodalField {
            name: name.into(),
            components: 1,
            values: vec![v],
        };
        let snap = FieldSnapshot {
            step: 1,
            t: 1.0,
            coords: vec![[1.0, 0.0]],
            quads: Vec::new(),
            fields: vec![
                scalar("tr_tau", 1.0),
                scalar("tau_xx", 1.0),
                scalar("tau_xy", 0.0),
                scalar("tau_yy", 0.0),
            ],
        };
        let lab = in_lab(snap, Frame::Rotating(std::f64::consts::FRAC_PI_4));
        let value = |name: &str| lab.fields.iter().find(|f| f.name == name).unwrap().values[0];
        for (name, expected) in [
            ("tr_tau", 1.0),
            ("tau_xx", 0.5),
            ("tau_xy", 0.5),
            ("tau_yy", 0.5),
        ] {
            assert!(
                (value(name) - expected).abs() < 1e-15,
                "{name} = {}",
                value(name)
            );
        }
        // the node itself went the same way: (1, 0) → (1, 1)/√2
        let s = std::f64::consts::FRAC_1_SQRT_2;
        assert!((lab.coords[0][0] - s).abs() < 1e-15 && (lab.coords[0][1] - s).abs() < 1e-15);
    }
}
