//! What a step reports: its changes (the steady test), the particles' deviation from their
//! extrapolation (the step controller's estimate) and the timings of its phases.

use crate::particles::Deviation;
use crate::solver::constitutive::TransportTimings;

/// Wall-clock seconds of the phases of one step (the one timing record of a step: a step with
/// moving particles fills in its ALE and classify phases too).
#[derive(Debug, Clone, Copy, Default)]
pub struct StepTimings {
    /// Moving particles: following mesh, ALE displacement, point location, history mapping.
    pub ale: f64,
    /// Moving particles: level set and cut-cell quadrature at the predicted positions.
    pub classify: f64,
    /// Flow: assembly.
    pub flow_assembly: f64,
    /// Flow: symbolic analysis (first solve only, or after a pattern rebuild) and new placements
    /// of the band solver (far-field factorization and condensation).
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
    /// Moving particles: how far the step's particles are from their extrapolation (the error
    /// estimate of `simulate::adaptive`); `None` on a first step and without particles.
    pub deviation: Option<Deviation>,
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
