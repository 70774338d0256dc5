//! Time stepper of a viscoelastic flow without particles (thesis §2.3.3, §3.3.5, §5.3.4 without
//! steps 1–3 and 6 of the particle scheme). Per step:
//!
//! 1. `solve_flow`: u^{n+1}, p^{n+1} (and G^{n+1} when DEVSS-G is coupled) from the momentum
//!    balance with the polymer stress of the projected conformation cⁿ (Eq. 5.28), either explicit
//!    `τ(cⁿ)` (Eq. 2.45, symmetric LBLᵀ, the fast path) or semi-implicit (Eq. 5.26/5.51, LU);
//!    with a decoupled DEVSS-G the lagged −θGⁿ is a load.
//! 2. `project_gradient` (decoupled DEVSS-G only): G^{n+1} = Π L(u^{n+1}) (Q1 mass matrix).
//! 3. `solve_stress`: s^{n+1} by SUPG/BDF2 (Eq. 5.29; Euler first step, Eq. 5.53).
//! 4. `project_conformation`: c^{n+1} = Π exp(s^{n+1}) (Eq. 5.28).
//! 5. steady test of §2.5.1: max nodal change of u and of s in this step below a tolerance.
//!
//! Initially the polymer stress is zero (`s = 0`); [`ViscoelasticFlow::start`] solves the flow at
//! t = 0 with that stress (and G⁰ = Π L(u⁰)). A fluid without polymer (η_p = 0) is Stokes flow:
//! only step 1 runs.
//!
//! Parameters and errors are in `params`; the history carried onto moved particles or a moved
//! mesh in `history`; the saved state and its restore in `state`; particle forces and stress
//! read-outs in `forces`; flow-rate control in `flow_rate`; what a step reports in `report`.

mod boundary;
mod coupling_lag;
mod flow_rate;
mod forces;
mod history;
mod params;
mod report;
mod state;

pub use history::HistoryMap;
pub use params::{ViscoelasticError, ViscoelasticParams, STEADY_TOL};
pub use report::{RunSummary, StepReport, StepTimings};
pub use state::FlowState;

use std::time::Instant;

use flow_rate::FlowRateControl;

use crate::fem::linsolve::SolverKind;
use crate::mesh::Mesh;
use crate::rheology::{Fluid, Sym2};
use crate::solver::constitutive::{
    LogConformationHistory, LogConformationTransport, TransportFlow,
};
use crate::solver::constitutive_projection::Q1Projection;
use crate::solver::constitutive_stress::{Coupling, CouplingStress};
use crate::solver::flow::{Stokes, StokesParams, StokesSolution};
use crate::solver::polymer_terms::PolymerStress;
use crate::solver::rigid::{ElementCut, Particle, WeakForm};

/// A viscoelastic flow on a fixed mesh, stepped in time.
pub struct ViscoelasticFlow {
    mesh: Mesh,
    stokes: Stokes,
    transport: LogConformationTransport,
    projection: Q1Projection,
    fluid: Fluid,
    params: ViscoelasticParams,
    history: LogConformationHistory,
    conformation: Vec<Sym2>,
    gradient: Vec<[f64; 4]>,
    velocity: Vec<[f64; 2]>,
    pressure: Vec<f64>,
    time: f64,
    started: bool,
    cuts: Vec<ElementCut>,
    flow_rate: Option<FlowRateControl>,
    /// Weak-condition reaction (force x, y, torque) of each particle in the last flow solve.
    reaction: Vec<[f64; 3]>,
    /// Traction integral −∫ σ(u_h, p_h)·n ds (solvent and pressure; n into the particle) of each
    /// particle in the last flow solve.
    traction: Vec<[f64; 3]>,
    /// Body force of the last flow solve (flow-rate control), 0 otherwise.
    body_force: f64,
    /// Whether each Q2 node lies in the fluid (the steady test ignores the extension values
    /// of nodes inside particles: they belong to cut elements with a possibly tiny fluid part
    /// and carry no physical meaning).
    fluid_node: Vec<bool>,
    /// Mesh velocity u_m at the Q2 nodes of the temporary ALE map of the coming step.
    mesh_velocity: Option<Vec<[f64; 2]>>,
    /// Rigid-body velocities (U_x, U_y, ω) of the particles in the last flow solve.
    rigid: Vec<[f64; 3]>,
    /// Projected c^{n−1} on the current configuration (none before the first step): the
    /// semi-implicit stress uses the BDF2 predictor with it (see
    /// [`crate::solver::constitutive_stress`]).
    conformation_prev: Option<Vec<Sym2>>,
    /// sⁿ as solved on its own configuration, kept by the last `move_particles` (with the step
    /// count it belongs to): the next move interpolates it once at the composite pre-image of
    /// Eq. 5.43. The mapped copy in `history.previous` lives on the configuration after that
    /// move; mapping it with the composite pre-image would carry it one step too far.
    unmapped: Option<(usize, Vec<Sym2>)>,
}

/// The flow of a step in progress ([`ViscoelasticFlow::solve_flow`]), to be finished by
/// [`ViscoelasticFlow::solve_stress`].
#[derive(Debug)]
pub struct FlowSolution {
    step: usize,
    u: Vec<[f64; 2]>,
    p: Vec<f64>,
    g: Option<Vec<[f64; 4]>>,
    started: Instant,
}

impl ViscoelasticFlow {
    /// Sets up the flow and stress solvers on `mesh` (LBLᵀ flow solver for the explicit coupling,
    /// LU for the semi-implicit one).
    ///
    /// # Errors
    /// [`ViscoelasticError::Fluid`] for invalid fluid parameters, [`ViscoelasticError::Time`] for
    /// a bad Δt or end time, [`ViscoelasticError::Theta`] for a bad θ,
    /// [`ViscoelasticError::NoViscosityInFlowMatrix`] for η_s = θ = 0 with explicit coupling.
    pub fn new(mesh: Mesh, params: ViscoelasticParams) -> Result<Self, ViscoelasticError> {
        let cuts = vec![ElementCut::Fluid; mesh.n_elements()];
        Self::with_particles(mesh, params, Vec::new(), cuts)
    }

    /// Like [`new`](Self::new), for a mesh cut by particles (`cuts` from
    /// [`crate::solver::cutcells::compute_cuts`]): the flow, the stress transport and the
    /// projections integrate over the fluid part only.
    ///
    /// # Errors
    /// As [`new`](Self::new).
    pub fn with_particles(
        mesh: Mesh,
        params: ViscoelasticParams,
        particles: Vec<Particle>,
        cuts: Vec<ElementCut>,
    ) -> Result<Self, ViscoelasticError> {
        let fluid = params.fluid()?;
        let solver = match (params.coupling, params.rigid_form) {
            (Coupling::Explicit, WeakForm::Symmetric) => SolverKind::Lblt,
            _ => SolverKind::Lu,
        };
        let mut sp = StokesParams::new(params.eta_s, params.theta, solver);
        sp.rigid_form = params.rigid_form;
        sp.rigid_condition = params.rigid_condition;
        sp.coupled_g = params.coupled_g;
        sp.factorization = params.factorization;
        sp.lubrication = params.lubrication;
        let (nv, nn) = (mesh.n_vertices(), mesh.n_nodes());
        let n_particles = particles.len();
        let mut transport = LogConformationTransport::new(&mesh);
        transport.supg = params.supg;
        transport.ghost_penalty = params.stress_ghost_penalty;
        let mut projection = Q1Projection::new(&mesh);
        if cuts.iter().any(|c| !matches!(c, ElementCut::Fluid)) {
            transport.set_cuts(&mesh, cuts.clone());
            projection.set_cuts(&mesh, cuts.clone());
        }
        let fluid_node = fluid_nodes(&mesh, &particles, &cuts);
        Ok(Self {
            fluid_node,
            mesh_velocity: None,
            rigid: vec![[0.0; 3]; n_particles],
            unmapped: None,
            conformation_prev: None,
            stokes: Stokes::with_particles(mesh.clone(), sp, particles, cuts.clone()),
            transport,
            projection,
            cuts,
            flow_rate: None,
            reaction: vec![[0.0; 3]; n_particles],
            traction: vec![[0.0; 3]; n_particles],
            body_force: 0.0,
            fluid,
            params,
            history: LogConformationHistory::at_rest(nv),
            conformation: vec![Sym2::IDENTITY; nv],
            gradient: vec![[0.0; 4]; nv],
            velocity: vec![[0.0; 2]; nn],
            pressure: vec![0.0; nv],
            time: 0.0,
            started: false,
            mesh,
        })
    }

    /// Rigid-body velocities (U_x, U_y, ω counter-clockwise) of the particles in the last flow
    /// solve.
    pub fn rigid_velocities(&self) -> &[[f64; 3]] {
        &self.rigid
    }

    /// Numeric factorizations of the flow matrix so far (steps that reused an older one by
    /// GMRES, or an unchanged matrix, do not count).
    pub fn flow_refactorizations(&self) -> usize {
        self.stokes.refactorizations
    }

    /// The flow solves' GMRES iterations, LU fallbacks, factorizations, pattern rebuilds and
    /// band placements so far.
    pub fn flow_solver_stats(&self) -> crate::solver::flow::FlowSolverStats {
        crate::solver::flow::FlowSolverStats {
            factorizations: self.stokes.refactorizations,
            pattern_rebuilds: self.stokes.pattern_rebuilds,
            placements: self.stokes.placements,
            ..self.stokes.stats
        }
    }

    /// How the log-conformation transport steps so far were solved.
    pub fn transport_stats(&self) -> crate::solver::constitutive::TransportStats {
        self.transport.stats
    }

    /// Placements of the flow's band solver (far-field factorizations) so far.
    pub fn flow_placements(&self) -> usize {
        self.stokes.placements
    }

    /// Pattern rebuilds of the flow matrix caused by moving particles (the rest reused the
    /// symbolic factorization).
    pub fn pattern_rebuilds(&self) -> usize {
        self.stokes.pattern_rebuilds
    }

    /// Solves the flow at t = 0 with zero polymer stress (s = 0) and sets G⁰.
    ///
    /// # Errors
    /// [`ViscoelasticError::Flow`] or [`ViscoelasticError::Stress`] if a solve fails.
    pub fn start(&mut self, force: &dyn Fn([f64; 2]) -> [f64; 2]) -> Result<(), ViscoelasticError> {
        // With decoupled DEVSS-G the flow matrix carries θ∇u balanced by θGⁿ on the right-hand
        // side; at t = 0 there is no Gⁿ yet, and θ∇u alone would act as a spurious non-symmetric
        // viscosity (free particles rotated 30 % off in the Couette cell). The fluid at rest with
        // τ = 0 is Newtonian with η_s: solve it without the DEVSS-G term (one extra
        // factorization per run), then G⁰ is projected from u⁰ and consistent.
        let decoupled_devss = !self.stokes.params.coupled_g && self.stokes.params.theta > 0.0;
        let theta = self.stokes.params.theta;
        if decoupled_devss && self.params.eta_s > 0.0 {
            self.stokes.params.theta = 0.0;
        }
        let sol = self.stokes.solve(force);
        self.stokes.params.theta = theta;
        let mut sol = sol.map_err(|source| ViscoelasticError::Flow { step: 0, source })?;
        self.body_force = self.control_flow_rate(&mut sol);
        self.reaction = sol.reaction;
        self.traction = sol.stress_force;
        self.rigid = sol.rigid;
        self.velocity = sol.u;
        self.pressure = sol.p;
        match sol.g {
            Some(g) => self.gradient = g,
            None => self.projection.project_velocity_gradient(
                &self.mesh,
                &self.velocity,
                &mut self.gradient,
            )?,
        }
        self.started = true;
        Ok(())
    }

    /// One time step (calls [`start`](Self::start) first if needed):
    /// [`solve_flow`](Self::solve_flow), then [`solve_stress`](Self::solve_stress).
    ///
    /// # Errors
    /// [`ViscoelasticError::Flow`] or [`ViscoelasticError::Stress`] if a solve fails or the
    /// log-conformation is not finite.
    pub fn step(
        &mut self,
        force: &dyn Fn([f64; 2]) -> [f64; 2],
    ) -> Result<StepReport, ViscoelasticError> {
        let solution = self.solve_flow(force)?;
        self.solve_stress(solution)
    }

    /// Step 1, solve_flow: u^{n+1}, p^{n+1} (and the rigid velocities, G^{n+1} when coupled) with
    /// the polymer stress of cⁿ (none without polymer); calls [`start`](Self::start) first if
    /// needed. The step ends with [`solve_stress`](Self::solve_stress).
    ///
    /// # Errors
    /// [`ViscoelasticError::Flow`] if the solve fails.
    pub fn solve_flow(
        &mut self,
        force: &dyn Fn([f64; 2]) -> [f64; 2],
    ) -> Result<FlowSolution, ViscoelasticError> {
        if !self.started {
            self.start(force)?;
        }
        let started = Instant::now();
        let step = self.history.steps() + 1;
        let mut sol = self.solve_stokes(force, step, self.params.extrapolate_stress)?;
        self.body_force = self.control_flow_rate(&mut sol);
        self.reaction = std::mem::take(&mut sol.reaction);
        self.traction = std::mem::take(&mut sol.stress_force);
        self.rigid = std::mem::take(&mut sol.rigid);
        Ok(FlowSolution {
            step,
            u: sol.u,
            p: sol.p,
            g: sol.g,
            started,
        })
    }

    /// The flow system with the polymer stress of the current fields (the conformation, G and
    /// the history levels the coupling reads; none without polymer), solved; `extrapolate`: the
    /// explicit stress at the extrapolated ĉ instead of cⁿ; `step` names a failure.
    fn solve_stokes(
        &mut self,
        force: &dyn Fn([f64; 2]) -> [f64; 2],
        step: usize,
        extrapolate: bool,
    ) -> Result<StokesSolution, ViscoelasticError> {
        let stress = CouplingStress {
            mesh: &self.mesh,
            model: self.fluid.polymer(),
            conformation: &self.conformation,
            coupling: self.params.coupling,
            dt: self.params.dt,
            bdf: self.history.bdf2(self.params.dt),
            mesh_velocity: self.mesh_velocity.as_deref(),
            devss: (!self.params.coupled_g && self.params.theta > 0.0)
                .then_some((self.params.theta, self.gradient.as_slice())),
            previous: self.conformation_prev.as_deref(),
            extrapolate,
        };
        let stress: Option<&dyn PolymerStress> = if self.params.has_polymer() {
            Some(&stress)
        } else {
            None
        };
        self.stokes
            .solve_with(force, stress)
            .map_err(|source| ViscoelasticError::Flow { step, source })
    }

    /// Steps 2–5, solve_stress: G^{n+1} (decoupled DEVSS-G), s^{n+1} by SUPG/BDF2, c^{n+1} = Π exp(s),
    /// the steady test, and the fields advanced to the flow `solution` of this step. Without
    /// polymer only the step count and the fields advance.
    ///
    /// # Errors
    /// [`ViscoelasticError::Stress`] if the stress solve or a projection fails.
    pub fn solve_stress(
        &mut self,
        solution: FlowSolution,
    ) -> Result<StepReport, ViscoelasticError> {
        let FlowSolution {
            step,
            u,
            p,
            g,
            started: t_step,
        } = solution;
        let dt = self.params.dt;
        if !self.params.has_polymer() {
            // Stokes flow: s = 0 stays, only the step count advances
            self.history.push_unchanged(dt);
            return Ok(self.finish_step(step, u, p, 0.0, 0.0, t_step));
        }
        // 2. project_gradient
        let t0 = Instant::now();
        match g {
            Some(g) => self.gradient = g,
            None => {
                self.projection
                    .project_velocity_gradient(&self.mesh, &u, &mut self.gradient)?
            }
        }
        let gradient_projection = t0.elapsed().as_secs_f64();
        // 3. solve_stress
        let flow = TransportFlow {
            velocity: &u,
            mesh_velocity: self.mesh_velocity.as_deref(),
            gradient: &self.gradient,
        };
        self.transport.step(
            &self.mesh,
            &self.fluid.polymer(),
            dt,
            &flow,
            &mut self.history,
        )?;
        // 4. project_conformation (cⁿ kept as c^{n−1} for the semi-implicit stress predictor or
        // the extrapolated explicit stress)
        let t1 = Instant::now();
        if self.params.needs_previous_conformation() {
            let mut prev = self
                .conformation_prev
                .take()
                .unwrap_or_else(|| vec![Sym2::IDENTITY; self.conformation.len()]);
            std::mem::swap(&mut prev, &mut self.conformation);
            self.conformation_prev = Some(prev);
        }
        self.projection.project_conformation(
            &self.mesh,
            &self.history.current,
            &mut self.conformation,
        )?;
        let conformation_projection = t1.elapsed().as_secs_f64();
        Ok(self.finish_step(
            step,
            u,
            p,
            gradient_projection,
            conformation_projection,
            t_step,
        ))
    }

    /// Step 5: the steady test of the step just solved (u^{n+1} = `u`), and the fields and time
    /// advanced to it.
    fn finish_step(
        &mut self,
        step: usize,
        u: Vec<[f64; 2]>,
        p: Vec<f64>,
        gradient_projection: f64,
        conformation_projection: f64,
        t_step: Instant,
    ) -> StepReport {
        let ft = self.stokes.timings;
        let fluid = &self.fluid_node;
        let (du_node, du_max) =
            arg_max(self.velocity.iter().zip(&u).zip(fluid).map(|((x, y), &f)| {
                if f {
                    (x[0] - y[0]).abs().max((x[1] - y[1]).abs())
                } else {
                    0.0
                }
            }));
        let node_of_vertex = &self.mesh.node_of_vertex;
        let (ds_vertex, ds_max) = match &self.history.previous {
            _ if !self.params.has_polymer() => (0, 0.0),
            Some(prev) => arg_max(self.history.current.iter().zip(prev).enumerate().map(
                |(v, (a, b))| {
                    if !fluid[node_of_vertex[v]] {
                        return 0.0;
                    }
                    let d = *a - *b;
                    d.xx.abs().max(d.xy.abs()).max(d.yy.abs())
                },
            )),
            None => (0, f64::INFINITY),
        };
        self.velocity = u;
        self.pressure = p;
        self.time += self.params.dt;
        let tol = self.params.steady_tol;
        StepReport {
            step,
            time: self.time,
            du_max,
            ds_max,
            du_node,
            ds_vertex,
            steady: du_max < tol && ds_max < tol,
            deviation: None,
            timings: StepTimings {
                ale: 0.0,
                classify: 0.0,
                flow_assembly: ft.assembly,
                flow_symbolic: ft.symbolic + ft.placement,
                flow_factor: ft.numeric,
                flow_solve: ft.solve,
                gradient_projection,
                transport: self.transport.timings,
                conformation_projection,
                total: t_step.elapsed().as_secs_f64(),
            },
        }
    }

    /// Steps until `t_end` (or, if `stop_when_steady`, until the steady criterion holds), calling
    /// `observe` after every step.
    ///
    /// # Errors
    /// As [`step`](Self::step).
    pub fn run(
        &mut self,
        force: &dyn Fn([f64; 2]) -> [f64; 2],
        stop_when_steady: bool,
        mut observe: impl FnMut(&Self, &StepReport),
    ) -> Result<RunSummary, ViscoelasticError> {
        let n_steps = (self.params.t_end / self.params.dt).round() as usize;
        let mut last = None;
        while self.history.steps() < n_steps {
            let rep = self.step(force)?;
            observe(self, &rep);
            last = Some(rep);
            if stop_when_steady && rep.steady {
                break;
            }
        }
        Ok(RunSummary {
            steps: self.history.steps(),
            time: self.time,
            steady: last.is_some_and(|r| r.steady),
            last,
        })
    }

    /// The mesh.
    pub fn mesh(&self) -> &Mesh {
        &self.mesh
    }

    /// The fluid.
    pub fn fluid(&self) -> Fluid {
        self.fluid
    }

    /// Sets Δt of the coming steps (variable steps: the BDF2 coefficients and the
    /// extrapolations follow the ratio to the last step, [`LogConformationHistory::bdf2`]).
    ///
    /// # Panics
    /// If `dt` is not positive and finite (the step controller never proposes such a step).
    pub fn set_dt(&mut self, dt: f64) {
        assert!(dt > 0.0 && dt.is_finite(), "set_dt: Δt = {dt}");
        self.params.dt = dt;
    }

    /// The parameters.
    pub fn params(&self) -> &ViscoelasticParams {
        &self.params
    }

    /// Current time.
    pub fn time(&self) -> f64 {
        self.time
    }

    /// Velocity at the Q2 nodes.
    pub fn velocity(&self) -> &[[f64; 2]] {
        &self.velocity
    }

    /// Pressure at the Q1 vertices.
    pub fn pressure(&self) -> &[f64] {
        &self.pressure
    }

    /// Velocity gradient G at the Q1 vertices.
    pub fn gradient(&self) -> &[[f64; 4]] {
        &self.gradient
    }

    /// Log-conformation time levels (sⁿ, s^{n−1}).
    pub fn history(&self) -> &LogConformationHistory {
        &self.history
    }

    /// Projected conformation cⁿ at the Q1 vertices.
    pub fn conformation(&self) -> &[Sym2] {
        &self.conformation
    }

    /// Number of unknowns of the flow system and of one log-conformation component.
    pub fn sizes(&self) -> (usize, usize) {
        (self.stokes.size().0, self.transport.size().0)
    }
}

/// Whether each Q2 node lies in the fluid: not a node of an element inside a particle, and
/// outside the particle images that cut its elements. With the fictitious domain method
/// (elements integrated whole) the particle interior is fluid: every node is.
fn fluid_nodes(mesh: &Mesh, particles: &[Particle], cuts: &[ElementCut]) -> Vec<bool> {
    let mut fluid = vec![true; mesh.n_nodes()];
    for (e, cut) in cuts.iter().enumerate() {
        match cut {
            ElementCut::Fluid => {}
            ElementCut::Cut(cut) if cut.whole => {}
            ElementCut::Inside => mesh.elements[e].iter().for_each(|&n| fluid[n] = false),
            ElementCut::Cut(cut) => {
                for pc in &cut.particles {
                    let r2 = particles[pc.particle].radius.powi(2);
                    for (&n, x) in mesh.elements[e].iter().zip(&mesh.element_coords[e]) {
                        let d2 = (x[0] - pc.center[0]).powi(2) + (x[1] - pc.center[1]).powi(2);
                        if d2 < r2 {
                            fluid[n] = false;
                        }
                    }
                }
            }
        }
    }
    fluid
}

/// Index and value of the largest item (0 and 0 when empty; NaN wins so that divergence shows).
fn arg_max(values: impl Iterator<Item = f64>) -> (usize, f64) {
    values.enumerate().fold((0, 0.0), |(i, m), (j, v)| {
        if v > m || v.is_nan() && !m.is_nan() {
            (j, v)
        } else {
            (i, m)
        }
    })
}
