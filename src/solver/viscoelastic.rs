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
//! t = 0 with that stress (and G⁰ = Π L(u⁰)).

use std::time::Instant;

use crate::fem::linsolve::{SolveError, SolverKind};
use crate::mesh::{Mesh, Side};
use crate::rheology::{Fluid, RheologyError, Sym2};
use crate::solver::ale::{extend_inside, StencilWeights, STENCIL_LEN};
use crate::solver::constitutive::{
    inactive_vertices, ConstitutiveError, LogConformationHistory, LogConformationTransport,
    TransportFlow, TransportTimings,
};
use crate::solver::constitutive_projection::{
    fluid_mean, sym_at, velocity_gradient_at, Q1Projection,
};
use crate::solver::constitutive_stress::{Coupling, CouplingStress};
use crate::solver::flow::{Stokes, StokesParams};
use crate::solver::rigid::{ElementCut, Particle, WeakForm};

/// Steady-state tolerance of thesis §2.5.1: nodal changes of u and s below 1e-6 per step.
pub const STEADY_TOL: f64 = 1e-6;

/// Parameters of a viscoelastic run (no dependency on the config module).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ViscoelasticParams {
    /// Solvent viscosity η_s (0 = UCM / Giesekus without solvent).
    pub eta_s: f64,
    /// Polymer viscosity η_p.
    pub eta_p: f64,
    /// Relaxation time λ.
    pub lambda: f64,
    /// Giesekus mobility α (0 = Oldroyd-B).
    pub alpha: f64,
    /// Time step Δt.
    pub dt: f64,
    /// End time.
    pub t_end: f64,
    /// Stress coupling in the flow solve.
    pub coupling: Coupling,
    /// DEVSS-G parameter θ (thesis: θ = η_p).
    pub theta: f64,
    /// DEVSS-G with G as flow unknowns (true) or decoupled: Gⁿ lagged in the momentum balance,
    /// G^{n+1} by a Q1 projection (false, the fast path).
    pub coupled_g: bool,
    /// Steady-state tolerance on the nodal change per step.
    pub steady_tol: f64,
    /// Form of the weak rigid-body condition; [`WeakForm::Thesis`] (non-symmetric, coercive for
    /// any κ however small the cut) needs an LU flow solver, chosen automatically.
    pub rigid_form: WeakForm,
}

impl ViscoelasticParams {
    /// Explicit coupling, decoupled DEVSS-G with θ = η_p, steady tolerance [`STEADY_TOL`].
    pub fn new(eta_s: f64, eta_p: f64, lambda: f64, alpha: f64, dt: f64, t_end: f64) -> Self {
        Self {
            eta_s,
            eta_p,
            lambda,
            alpha,
            dt,
            t_end,
            coupling: Coupling::Explicit,
            theta: eta_p,
            coupled_g: false,
            steady_tol: STEADY_TOL,
            rigid_form: WeakForm::Symmetric,
        }
    }

    /// The validated fluid.
    ///
    /// # Errors
    /// As in [`ViscoelasticFlow::new`].
    pub fn fluid(&self) -> Result<Fluid, ViscoelasticError> {
        let fluid = Fluid::new(self.eta_s, self.eta_p, self.lambda, self.alpha)?;
        if !(self.dt > 0.0 && self.dt.is_finite() && self.t_end >= 0.0 && self.t_end.is_finite()) {
            return Err(ViscoelasticError::Time {
                dt: self.dt,
                t_end: self.t_end,
            });
        }
        if !(self.theta >= 0.0 && self.theta.is_finite()) {
            return Err(ViscoelasticError::Theta(self.theta));
        }
        if self.coupling == Coupling::Explicit && self.eta_s + self.theta == 0.0 {
            return Err(ViscoelasticError::NoViscosityInFlowMatrix);
        }
        Ok(fluid)
    }
}

/// Errors of the viscoelastic time stepper; each says what to change.
#[derive(Debug, thiserror::Error)]
pub enum ViscoelasticError {
    /// Invalid fluid parameters.
    #[error("fluid parameters: {0}")]
    Fluid(#[from] RheologyError),
    /// Bad time parameters.
    #[error("time step Δt = {dt} must be positive and the end time {t_end} non-negative (finite)")]
    Time {
        /// Δt.
        dt: f64,
        /// End time.
        t_end: f64,
    },
    /// Bad DEVSS-G parameter.
    #[error("DEVSS-G parameter θ = {0} must be non-negative and finite")]
    Theta(f64),
    /// η_s = θ = 0 with the explicit coupling: the flow matrix has no viscous part.
    #[error(
        "η_s = 0 with explicit stress coupling and θ = 0 leaves the flow matrix singular: \
         use DEVSS-G (θ = η_p) or the semi-implicit coupling"
    )]
    NoViscosityInFlowMatrix,
    /// Flow-rate control superposes a unit-force response, valid only when the flow matrix does
    /// not depend on the stress.
    #[error("flow-rate control needs the explicit stress coupling (the semi-implicit flow matrix changes every step)")]
    FlowRateNeedsExplicit,
    /// The flow solve failed.
    #[error("flow solve failed at step {step}: {source}")]
    Flow {
        /// Time step number (0 = initial solve).
        step: usize,
        /// The solver error.
        #[source]
        source: SolveError,
    },
    /// Flow-rate control with moving particles.
    #[error("flow-rate control needs fixed bodies (its unit-force response belongs to one configuration)")]
    FlowRateNeedsFixedBodies,
    /// A saved state does not fit this flow.
    #[error("saved state does not fit: {0}")]
    Restore(String),
    /// The stress solve or a projection failed.
    #[error(transparent)]
    Stress(#[from] ConstitutiveError),
}

/// Wall-clock seconds of the phases of one step.
#[derive(Debug, Clone, Copy, Default)]
pub struct StepTimings {
    /// Flow: assembly.
    pub flow_assembly: f64,
    /// Flow: symbolic analysis (first solve only).
    pub flow_symbolic: f64,
    /// Flow: numeric factorization.
    pub flow_factor: f64,
    /// Flow: solve and residual check.
    pub flow_solve: f64,
    /// Q1 projection of G (decoupled DEVSS-G).
    pub gradient_projection: f64,
    /// Log-conformation transport.
    pub transport: TransportTimings,
    /// Q1 projection of exp(s).
    pub conformation_projection: f64,
    /// Whole step.
    pub total: f64,
}

/// What one step did.
#[derive(Debug, Clone, Copy)]
pub struct StepReport {
    /// Step number (1 = first step).
    pub step: usize,
    /// Time after the step.
    pub time: f64,
    /// max over the fluid's nodes and components of |u^{n+1} − uⁿ|.
    pub du_max: f64,
    /// max over the fluid's vertices and components of |s^{n+1} − sⁿ|.
    pub ds_max: f64,
    /// Q2 node where `du_max` is attained.
    pub du_node: usize,
    /// Q1 vertex where `ds_max` is attained.
    pub ds_vertex: usize,
    /// Both below the steady tolerance.
    pub steady: bool,
    /// Timings.
    pub timings: StepTimings,
}

/// How a run ended.
#[derive(Debug, Clone, Copy)]
pub struct RunSummary {
    /// Steps taken.
    pub steps: usize,
    /// Final time.
    pub time: f64,
    /// Whether the steady criterion was met (the run stops there when asked to).
    pub steady: bool,
    /// The last step's report.
    pub last: Option<StepReport>,
}

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

/// The time-dependent fields of a [`ViscoelasticFlow`] after a step (see
/// [`ViscoelasticFlow::state`]); serializable so that a long run can continue elsewhere.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FlowState {
    /// sⁿ and s^{n−1} with the step count.
    pub history: LogConformationHistory,
    /// sⁿ on its own configuration (moving particles).
    pub unmapped: Option<(usize, Vec<Sym2>)>,
    /// cⁿ projected on the current fluid domain.
    pub conformation: Vec<Sym2>,
    /// c^{n−1} (semi-implicit coupling).
    pub conformation_prev: Option<Vec<Sym2>>,
    /// Gⁿ.
    pub gradient: Vec<[f64; 4]>,
    /// uⁿ at the Q2 nodes.
    pub velocity: Vec<[f64; 2]>,
    /// pⁿ at the Q1 vertices.
    pub pressure: Vec<f64>,
    /// tⁿ.
    pub time: f64,
    /// Rigid-body velocities of the last flow solve.
    pub rigid: Vec<[f64; 3]>,
    /// Weak-condition reactions of the last flow solve.
    pub reaction: Vec<[f64; 3]>,
    /// Body force of the last flow solve.
    pub body_force: f64,
}

/// How the history moves onto the current configuration (temporary ALE map, thesis §5.3.3):
/// for every Q1 vertex x the interpolation at its pre-images xⁿ = Φₙ⁻¹(x) and
/// xⁿ⁻¹ = Φₙ₋₁⁻¹(xⁿ), Eqs. 5.42–5.43, and the mesh velocity of Eq. 5.44.
#[derive(Debug, Clone, Copy)]
pub struct HistoryMap<'a> {
    /// Interpolation of the fields at tⁿ (sⁿ, Gⁿ) at each vertex's pre-image.
    pub at_n: &'a [StencilWeights],
    /// Interpolation of s^{n−1}; `None` makes the coming step first order (Euler, Eq. 5.53).
    pub at_n_minus_1: Option<&'a [StencilWeights]>,
    /// Mesh velocity u_m^{n+1} at the Q2 nodes.
    pub mesh_velocity: &'a [[f64; 2]],
}

/// The four velocity-gradient components, as a vector space for interpolation.
#[derive(Debug, Clone, Copy)]
struct Grad4([f64; 4]);

impl std::ops::Add for Grad4 {
    type Output = Self;
    fn add(self, o: Self) -> Self {
        Grad4(std::array::from_fn(|i| self.0[i] + o.0[i]))
    }
}

impl std::ops::Mul<f64> for Grad4 {
    type Output = Self;
    fn mul(self, a: f64) -> Self {
        Grad4(self.0.map(|v| v * a))
    }
}

/// Moves sⁿ and s^{n−1} onto the new configuration (Eqs. 5.42–5.43). sⁿ is interpolated at
/// Φₙ⁻¹(x); s^{n−1} once at Φₙ₋₁⁻¹∘Φₙ⁻¹(x) from the copy of it as solved, which the previous
/// move left in `unmapped` (the copy in `history.previous` was already mapped by that move, and
/// the composite pre-image would carry it a step too far). Only when the last step did not move
/// (no unmapped copy of that step) is `history.previous` on the configuration of sⁿ, and then it
/// follows sⁿ's map. Leaves the unmapped sⁿ in `unmapped`.
fn carry_history(
    history: &mut LogConformationHistory,
    unmapped: &mut Option<(usize, Vec<Sym2>)>,
    map: &HistoryMap<'_>,
) {
    let steps = history.steps();
    let unmapped_nm1 = take_unmapped(unmapped, steps);
    history.previous = carry_previous(history.previous.take(), unmapped_nm1, map);
    let current = interpolate(&history.current, map.at_n);
    *unmapped = Some((steps, std::mem::replace(&mut history.current, current)));
}

/// The unmapped copy of the level before the current one, if the last move kept it one step
/// ago.
fn take_unmapped<T>(unmapped: &mut Option<(usize, Vec<T>)>, steps: usize) -> Option<Vec<T>> {
    unmapped
        .take()
        .filter(|(at, _)| at + 1 == steps)
        .map(|u| u.1)
}

/// The level n−1 on the new configuration: from its unmapped copy at the composite pre-image,
/// or, without one, the stored copy (then on the configuration of level n) at Φₙ⁻¹.
fn carry_previous<T>(
    mapped: Option<Vec<T>>,
    unmapped_nm1: Option<Vec<T>>,
    map: &HistoryMap<'_>,
) -> Option<Vec<T>>
where
    T: Copy + std::ops::Add<Output = T> + std::ops::Mul<f64, Output = T>,
{
    match (map.at_n_minus_1, unmapped_nm1, mapped) {
        (None, _, _) => None,
        (Some(at), Some(raw), _) => Some(interpolate(&raw, at)),
        (Some(_), None, Some(prev)) => Some(interpolate(&prev, map.at_n)),
        (Some(_), None, None) => None,
    }
}

fn interpolate<T>(field: &[T], at: &[StencilWeights]) -> Vec<T>
where
    T: Copy + std::ops::Add<Output = T> + std::ops::Mul<f64, Output = T>,
{
    at.iter()
        .map(|(v, w)| {
            let mut acc = field[v[0]] * w[0];
            for k in 1..STENCIL_LEN {
                if w[k] != 0.0 {
                    acc = acc + field[v[k]] * w[k];
                }
            }
            acc
        })
        .collect()
}

/// Flow-rate control of a periodic channel: Stokes flow is linear in the body force, and with the
/// explicit coupling the flow matrix does not depend on the stress, so the flow of each step is
/// u = u_τ + f u₁, with u₁ the response to a unit body force (computed once) and f chosen so
/// that the flux through the seam equals the target.
#[derive(Debug, Clone)]
struct FlowRateControl {
    target: f64,
    unit_u: Vec<[f64; 2]>,
    unit_p: Vec<f64>,
    unit_flux: f64,
    unit_reaction: Vec<[f64; 3]>,
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
        sp.coupled_g = params.coupled_g;
        let (nv, nn) = (mesh.n_vertices(), mesh.n_nodes());
        let n_particles = particles.len();
        let mut transport = LogConformationTransport::new(&mesh);
        let mut projection = Q1Projection::new(&mesh);
        if n_particles > 0 {
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

    /// Prescribes the velocity on a side (walls), for all times.
    pub fn set_velocity(
        &mut self,
        side: Side,
        f: impl Fn([f64; 2]) -> [f64; 2] + Send + Sync + 'static,
    ) {
        self.stokes.set_velocity(side, f);
    }

    /// Pins the pressure (enclosed flows).
    pub fn pin_pressure(&mut self) {
        self.stokes.pin_pressure();
    }

    /// Drives a periodic channel (walls and bodies at rest, x-periodic) at flow rate `q` with a
    /// uniform body force in x adjusted every step (u = u_τ + f u₁ with a precomputed unit-force
    /// response; exact because the explicit-coupling flow matrix does not depend on τ). Call after the
    /// boundary conditions are set; the `force` passed to [`step`](Self::step) must then be zero.
    ///
    /// # Errors
    /// [`ViscoelasticError::Flow`] if the unit solve fails, [`ViscoelasticError::FlowRateNeedsExplicit`]
    /// for the semi-implicit coupling (its flow matrix changes with the stress).
    pub fn set_flow_rate(&mut self, q: f64) -> Result<(), ViscoelasticError> {
        if self.params.coupling != Coupling::Explicit {
            return Err(ViscoelasticError::FlowRateNeedsExplicit);
        }
        let unit = self
            .stokes
            .solve(&|_| [1.0, 0.0])
            .map_err(|source| ViscoelasticError::Flow { step: 0, source })?;
        let unit_flux = self.mesh.flux_through_first_column(&unit.u);
        self.flow_rate = Some(FlowRateControl {
            target: q,
            unit_u: unit.u,
            unit_p: unit.p,
            unit_flux,
            unit_reaction: unit.reaction,
        });
        Ok(())
    }

    /// Adds the flow-rate correction f·(u₁, p₁) to a solution and returns f.
    fn control_flow_rate(
        &self,
        u: &mut [[f64; 2]],
        p: &mut [f64],
        reaction: &mut [[f64; 3]],
    ) -> f64 {
        let Some(fr) = &self.flow_rate else {
            return 0.0;
        };
        let f = (fr.target - self.mesh.flux_through_first_column(u)) / fr.unit_flux;
        u.iter_mut().zip(&fr.unit_u).for_each(|(a, b)| {
            a[0] += f * b[0];
            a[1] += f * b[1];
        });
        p.iter_mut().zip(&fr.unit_p).for_each(|(a, b)| *a += f * b);
        reaction
            .iter_mut()
            .zip(&fr.unit_reaction)
            .for_each(|(a, b)| {
                for c in 0..3 {
                    a[c] += f * b[c];
                }
            });
        f
    }

    /// Moves the particles to new positions (the predicted configuration of the coming step,
    /// with its `cuts`): the flow, transport and projection solvers take the new fluid domain,
    /// the history sⁿ, s^{n−1} and Gⁿ are carried over by the temporary ALE `map`, cⁿ is
    /// re-projected on the new fluid domain, and the coming step convects with u − u_m.
    ///
    /// # Errors
    /// [`ViscoelasticError::FlowRateNeedsFixedBodies`] with flow-rate control (its unit response
    /// belongs to one configuration), [`ViscoelasticError::Stress`] if the projection fails.
    ///
    /// # Panics
    /// Panics if the number of particles changes or the map does not cover every vertex.
    pub fn move_particles(
        &mut self,
        particles: Vec<Particle>,
        cuts: Vec<ElementCut>,
        map: HistoryMap<'_>,
    ) -> Result<(), ViscoelasticError> {
        self.move_particles_onto(None, particles, cuts, map)
    }

    /// [`move_particles`](Self::move_particles) onto a computational mesh `onto` whose vertex
    /// columns and rows have moved (same topology; `None`: the mesh stays): the `map` gives the
    /// pre-images of `onto`'s vertices in the current mesh (see
    /// [`TemporaryAle::advance_onto`](crate::solver::ale::TemporaryAle::advance_onto)) and
    /// `cuts` are the particles cut into `onto`.
    ///
    /// # Errors
    /// As [`move_particles`](Self::move_particles).
    ///
    /// # Panics
    /// As [`move_particles`](Self::move_particles), and if `onto` has another topology.
    pub fn move_particles_onto(
        &mut self,
        onto: Option<Mesh>,
        particles: Vec<Particle>,
        cuts: Vec<ElementCut>,
        map: HistoryMap<'_>,
    ) -> Result<(), ViscoelasticError> {
        if self.flow_rate.is_some() {
            return Err(ViscoelasticError::FlowRateNeedsFixedBodies);
        }
        let nv = self.mesh.n_vertices();
        assert_eq!(map.at_n.len(), nv, "one pre-image per vertex");
        // sⁿ and Gⁿ as solved on the old configuration, extended into the old particles
        let known: Vec<bool> = inactive_vertices(&self.mesh, &self.cuts)
            .iter()
            .map(Option::is_none)
            .collect();
        extend_inside(&self.mesh, &known, &mut self.history.current);
        let mut g: Vec<Grad4> = self.gradient.iter().map(|&g| Grad4(g)).collect();
        extend_inside(&self.mesh, &known, &mut g);
        carry_history(&mut self.history, &mut self.unmapped, &map);
        self.gradient = interpolate(&g, map.at_n).into_iter().map(|g| g.0).collect();
        // the carried fields are values at the new mesh's vertices from here on
        if let Some(mesh) = onto {
            self.set_mesh(mesh);
        }
        self.fluid_node = fluid_nodes(&self.mesh, &particles, &cuts);
        self.transport.set_cuts(&self.mesh, cuts.clone());
        self.projection.set_cuts(&self.mesh, cuts.clone());
        self.stokes.set_particles(particles, cuts.clone());
        self.cuts = cuts;
        self.mesh_velocity = Some(map.mesh_velocity.to_vec());
        self.projection.project_conformation(
            &self.mesh,
            &self.history.current,
            &mut self.conformation,
        )?;
        // c^{n−1} serves the semi-implicit predictor only
        let semi_implicit = self.params.coupling == Coupling::SemiImplicit;
        self.conformation_prev = match &self.history.previous {
            Some(prev) if semi_implicit => {
                let mut c = self
                    .conformation_prev
                    .take()
                    .unwrap_or_else(|| vec![Sym2::IDENTITY; nv]);
                self.projection
                    .project_conformation(&self.mesh, prev, &mut c)?;
                Some(c)
            }
            _ => None,
        };
        Ok(())
    }

    /// Swaps in a computational mesh of the same topology whose columns or rows have moved; the
    /// nodal fields are taken as values at its nodes (the caller has mapped them). The cuts must
    /// be set next (as [`move_particles_onto`](Self::move_particles_onto) and
    /// [`restore_on`](Self::restore_on) do).
    fn set_mesh(&mut self, mesh: Mesh) {
        // (the flow solver checks the topology)
        if (&mesh.ax, &mesh.ay) == (&self.mesh.ax, &self.mesh.ay) {
            return;
        }
        self.stokes.set_mesh(mesh.clone());
        self.projection.geometry_changed();
        self.mesh = mesh;
    }

    /// The time-dependent state after a step: what [`restore`](Self::restore) needs to continue
    /// a run from here in another process (everything else follows from the mesh, the
    /// parameters and the particle positions).
    pub fn state(&self) -> FlowState {
        FlowState {
            history: self.history.clone(),
            unmapped: self.unmapped.clone(),
            conformation: self.conformation.clone(),
            conformation_prev: self.conformation_prev.clone(),
            gradient: self.gradient.clone(),
            velocity: self.velocity.clone(),
            pressure: self.pressure.clone(),
            time: self.time,
            rigid: self.rigid.clone(),
            reaction: self.reaction.clone(),
            body_force: self.body_force,
        }
    }

    /// Continues from a saved [`state`](Self::state) with the particles (and their `cuts`) at
    /// the positions the state was computed at. The next step goes on exactly as the saved run
    /// would have, up to round-off (the flow pattern's reach is rebuilt around the current
    /// positions, which can reorder the factorization).
    ///
    /// # Errors
    /// [`ViscoelasticError::Restore`] if the state does not fit this mesh or particle count.
    pub fn restore(
        &mut self,
        state: FlowState,
        particles: Vec<Particle>,
        cuts: Vec<ElementCut>,
    ) -> Result<(), ViscoelasticError> {
        self.restore_on(None, state, particles, cuts)
    }

    /// [`restore`](Self::restore) a state computed on `mesh` (same topology, columns and rows
    /// possibly moved: a mesh that follows the particles; `None`: the current mesh), with `cuts`
    /// on that mesh.
    ///
    /// # Errors
    /// As [`restore`](Self::restore).
    ///
    /// # Panics
    /// If `mesh` has another topology.
    pub fn restore_on(
        &mut self,
        mesh: Option<Mesh>,
        state: FlowState,
        particles: Vec<Particle>,
        cuts: Vec<ElementCut>,
    ) -> Result<(), ViscoelasticError> {
        let (nv, nn) = (self.mesh.n_vertices(), self.mesh.n_nodes());
        let np = self.rigid.len();
        let fits = |what: &str, len: usize, want: usize| {
            if len == want {
                Ok(())
            } else {
                Err(ViscoelasticError::Restore(format!(
                    "{what} has {len} entries, this case has {want}"
                )))
            }
        };
        fits("sⁿ", state.history.current.len(), nv)?;
        if let Some(p) = &state.history.previous {
            fits("s^(n-1)", p.len(), nv)?;
        }
        if let Some((_, u)) = &state.unmapped {
            fits("unmapped sⁿ", u.len(), nv)?;
        }
        if let Some(c) = &state.conformation_prev {
            fits("c^(n-1)", c.len(), nv)?;
        }
        fits("c", state.conformation.len(), nv)?;
        fits("G", state.gradient.len(), nv)?;
        fits("p", state.pressure.len(), nv)?;
        fits("u", state.velocity.len(), nn)?;
        fits("particle velocities", state.rigid.len(), np)?;
        fits("particle reactions", state.reaction.len(), np)?;
        fits("particles", particles.len(), np)?;
        if self.flow_rate.is_some() {
            return Err(ViscoelasticError::FlowRateNeedsFixedBodies);
        }
        if let Some(mesh) = mesh {
            self.set_mesh(mesh);
        }
        self.fluid_node = fluid_nodes(&self.mesh, &particles, &cuts);
        if np > 0 {
            self.transport.set_cuts(&self.mesh, cuts.clone());
            self.projection.set_cuts(&self.mesh, cuts.clone());
            self.stokes.set_particles(particles, cuts.clone());
        }
        self.cuts = cuts;
        self.history = state.history;
        self.unmapped = state.unmapped;
        self.conformation = state.conformation;
        self.conformation_prev = state.conformation_prev;
        self.gradient = state.gradient;
        self.velocity = state.velocity;
        self.pressure = state.pressure;
        self.time = state.time;
        self.rigid = state.rigid;
        self.reaction = state.reaction;
        self.body_force = state.body_force;
        self.mesh_velocity = None;
        self.started = true;
        Ok(())
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

    /// Pattern rebuilds of the flow matrix caused by moving particles (the rest reused the
    /// symbolic factorization).
    pub fn pattern_rebuilds(&self) -> usize {
        self.stokes.pattern_rebuilds
    }

    /// Hydrodynamic force and torque on each particle: the weak-condition reaction of the last
    /// flow solve (solvent stress, pressure and stabilization, consistent with the discrete
    /// momentum balance) plus the polymer stress integral −∮ τ·n ds with the current τ. With
    /// flow-rate control the mean pressure gradient's traction f·(particle area) is included.
    pub fn particle_forces(&self) -> Vec<[f64; 3]> {
        let mut out = self.polymer_forces();
        for (f, r) in out.iter_mut().zip(&self.reaction) {
            (0..3).for_each(|c| f[c] += r[c]);
        }
        if self.flow_rate.is_some() {
            for (f, p) in out.iter_mut().zip(self.stokes.particles()) {
                f[0] += self.body_force * std::f64::consts::PI * p.radius * p.radius;
            }
        }
        out
    }

    /// The polymer part of [`particle_forces`](Self::particle_forces): force and torque
    /// ∮ τ·n ds (n out of the particle) with the current projected conformation; its x component
    /// is the K of thesis §5.4.
    pub fn polymer_forces(&self) -> Vec<[f64; 3]> {
        let g = self.fluid.polymer().modulus();
        let mut out = vec![[0.0; 3]; self.reaction.len()];
        for (e, cut) in self.cuts.iter().enumerate() {
            let ElementCut::Cut(cut) = cut else { continue };
            for pc in &cut.particles {
                for bp in &pc.points {
                    let c = sym_at(&self.mesh, &self.conformation, e, bp.xi);
                    let tau = (c - Sym2::IDENTITY) * g;
                    let t = [
                        -(tau.xx * bp.n[0] + tau.xy * bp.n[1]),
                        -(tau.xy * bp.n[0] + tau.yy * bp.n[1]),
                    ];
                    let r = [bp.x[0] - pc.center[0], bp.x[1] - pc.center[1]];
                    let f = &mut out[pc.particle];
                    f[0] += bp.w * t[0];
                    f[1] += bp.w * t[1];
                    f[2] += bp.w * (r[0] * t[1] - r[1] * t[0]);
                }
            }
        }
        out
    }

    /// Polymer stress τ = G(c − I) at a point (rectangle meshes), from the projected conformation.
    pub fn polymer_stress_at(&self, x: [f64; 2]) -> Option<Sym2> {
        let (e, xi) = self.mesh.locate(x)?;
        let c = sym_at(&self.mesh, &self.conformation, e, xi);
        Some((c - Sym2::IDENTITY) * self.fluid.polymer().modulus())
    }

    /// Body force of the last flow solve (flow-rate control), 0 without it.
    pub fn body_force(&self) -> f64 {
        self.body_force
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
        self.body_force = self.control_flow_rate(&mut sol.u, &mut sol.p, &mut sol.reaction);
        self.reaction = sol.reaction;
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

    /// One time step (calls [`start`](Self::start) first if needed).
    ///
    /// # Errors
    /// [`ViscoelasticError::Flow`] or [`ViscoelasticError::Stress`] if a solve fails or the
    /// log-conformation is not finite.
    pub fn step(
        &mut self,
        force: &dyn Fn([f64; 2]) -> [f64; 2],
    ) -> Result<StepReport, ViscoelasticError> {
        if !self.started {
            self.start(force)?;
        }
        let t_step = Instant::now();
        let step = self.history.steps() + 1;
        let dt = self.params.dt;
        // 1. solve_flow with the stress of cⁿ
        let stress = CouplingStress {
            mesh: &self.mesh,
            model: self.fluid.polymer(),
            conformation: &self.conformation,
            coupling: self.params.coupling,
            dt,
            mesh_velocity: self.mesh_velocity.as_deref(),
            devss: (!self.params.coupled_g && self.params.theta > 0.0)
                .then_some((self.params.theta, self.gradient.as_slice())),
            previous: self.conformation_prev.as_deref(),
        };
        let mut sol = self
            .stokes
            .solve_with(force, Some(&stress))
            .map_err(|source| ViscoelasticError::Flow { step, source })?;
        let ft = self.stokes.timings;
        self.body_force = self.control_flow_rate(&mut sol.u, &mut sol.p, &mut sol.reaction);
        self.reaction = std::mem::take(&mut sol.reaction);
        self.rigid = std::mem::take(&mut sol.rigid);
        // 2. project_gradient
        let t0 = Instant::now();
        match sol.g {
            Some(g) => self.gradient = g,
            None => {
                self.projection
                    .project_velocity_gradient(&self.mesh, &sol.u, &mut self.gradient)?
            }
        }
        let gradient_projection = t0.elapsed().as_secs_f64();
        // 3. solve_stress
        let flow = TransportFlow {
            velocity: &sol.u,
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
        // 4. project_conformation (cⁿ kept as c^{n−1} for the semi-implicit stress predictor)
        let t1 = Instant::now();
        if self.params.coupling == Coupling::SemiImplicit {
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
        // 5. steady test
        let fluid = &self.fluid_node;
        let (du_node, du_max) = arg_max(self.velocity.iter().zip(&sol.u).zip(fluid).map(
            |((x, y), &f)| {
                if f {
                    (x[0] - y[0]).abs().max((x[1] - y[1]).abs())
                } else {
                    0.0
                }
            },
        ));
        let node_of_vertex = &self.mesh.node_of_vertex;
        let (ds_vertex, ds_max) = match &self.history.previous {
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
        self.velocity = sol.u;
        self.pressure = sol.p;
        self.time = step as f64 * dt;
        let tol = self.params.steady_tol;
        Ok(StepReport {
            step,
            time: self.time,
            du_max,
            ds_max,
            du_node,
            ds_vertex,
            steady: du_max < tol && ds_max < tol,
            timings: StepTimings {
                flow_assembly: ft.assembly,
                flow_symbolic: ft.symbolic,
                flow_factor: ft.numeric,
                flow_solve: ft.solve,
                gradient_projection,
                transport: self.transport.timings,
                conformation_projection,
                total: t_step.elapsed().as_secs_f64(),
            },
        })
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

    /// Polymer stress τ = G(c − I) of the projected conformation cⁿ at the Q1 vertices (inside a
    /// particle: of its extension).
    pub fn polymer_stress(&self) -> Vec<Sym2> {
        let polymer = self.fluid.polymer();
        self.conformation
            .iter()
            .map(|&c| polymer.stress(c))
            .collect()
    }

    /// Domain mean of the polymer stress τ = G(c − I) (the mean of Π exp(s) equals that of
    /// exp(s_h): constants are Q1 test functions).
    pub fn mean_polymer_stress(&self) -> Sym2 {
        let cuts = self.projection.cuts();
        let m = fluid_mean(&self.mesh, cuts, |e, xi| {
            let c = crate::solver::constitutive_projection::sym_at(
                &self.mesh,
                &self.conformation,
                e,
                xi,
            );
            [c.xx, c.xy, c.yy]
        });
        self.fluid.polymer().stress(Sym2::new(m[0], m[1], m[2]))
    }

    /// Domain mean of the total extra stress 2η_s D(u) + τ.
    pub fn mean_extra_stress(&self) -> Sym2 {
        let cuts: &[ElementCut] = self.projection.cuts();
        let d = fluid_mean(&self.mesh, cuts, |e, xi| {
            let d = velocity_gradient_at(&self.mesh, &self.velocity, e, xi).rate_of_deformation();
            [d.xx, d.xy, d.yy]
        });
        2.0 * self.fluid.eta_s() * Sym2::new(d[0], d[1], d[2]) + self.mean_polymer_stress()
    }

    /// Number of unknowns of the flow system and of one log-conformation component.
    pub fn sizes(&self) -> (usize, usize) {
        (self.stokes.size().0, self.transport.size().0)
    }
}

/// Whether each Q2 node lies in the fluid: not a node of an element inside a particle, and
/// outside the particle images that cut its elements.
fn fluid_nodes(mesh: &Mesh, particles: &[Particle], cuts: &[ElementCut]) -> Vec<bool> {
    let mut fluid = vec![true; mesh.n_nodes()];
    for (e, cut) in cuts.iter().enumerate() {
        match cut {
            ElementCut::Fluid => {}
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Pre-image of vertex i is vertex i − k (clamped at 0), weight 1: a shift by k vertices.
    fn shift(n: usize, k: usize) -> Vec<StencilWeights> {
        (0..n)
            .map(|i| {
                let mut w = ([i.saturating_sub(k); STENCIL_LEN], [0.0; STENCIL_LEN]);
                w.1[0] = 1.0;
                w
            })
            .collect()
    }

    fn field(n: usize, offset: f64) -> Vec<Sym2> {
        (0..n)
            .map(|i| Sym2::new(offset + i as f64, 0.0, 0.0))
            .collect()
    }

    #[test]
    fn previous_level_is_mapped_once_at_the_composite_pre_image() {
        let n = 8;
        let (s1, s2) = (shift(n, 1), shift(n, 2));
        let velocity = vec![[0.0; 2]; 1];
        let mut h = LogConformationHistory::from_field(field(n, 0.0));
        let mut unmapped = None;
        // first move (Euler step): s⁰ follows Φ₀⁻¹, no s^{-1}
        let first = HistoryMap {
            at_n: &s1,
            at_n_minus_1: None,
            mesh_velocity: &velocity,
        };
        carry_history(&mut h, &mut unmapped, &first);
        assert!(h.previous.is_none());
        h.push(field(n, 100.0));
        // second move: s¹ at Φ₁⁻¹, s⁰ at Φ₀⁻¹∘Φ₁⁻¹ = a shift by 2 from s⁰ as solved
        let second = HistoryMap {
            at_n: &s1,
            at_n_minus_1: Some(&s2),
            mesh_velocity: &velocity,
        };
        carry_history(&mut h, &mut unmapped, &second);
        let prev = h.previous.as_ref().expect("BDF2 level");
        for i in 2..n {
            assert_eq!(h.current[i].xx, 100.0 + (i - 1) as f64);
            // mapping the already mapped copy would give i − 3
            assert_eq!(prev[i].xx, (i - 2) as f64, "vertex {i}");
        }
    }

    #[test]
    fn without_an_earlier_move_the_previous_level_follows_the_current_map() {
        let n = 8;
        let (s1, s2) = (shift(n, 1), shift(n, 2));
        let velocity = vec![[0.0; 2]; 1];
        let mut h = LogConformationHistory::from_field(field(n, 0.0));
        h.push(field(n, 100.0));
        let map = HistoryMap {
            at_n: &s1,
            at_n_minus_1: Some(&s2),
            mesh_velocity: &velocity,
        };
        let mut unmapped = None;
        carry_history(&mut h, &mut unmapped, &map);
        let prev = h.previous.as_ref().expect("BDF2 level");
        for i in 1..n {
            assert_eq!(prev[i].xx, (i - 1) as f64, "vertex {i}");
        }
    }
}
