//! Outcome classification from a trajectory, step by step. The rules (see `docs/sweeps.md`) in the order
//! they are checked at each step:
//! 1. `diverged`: a non-finite particle state.
//! 2. `wall_contact`: a particle penetrates a wall by more than [`CONTACT_OVERLAP`]·a.
//! 3. `jammed`: two particles overlap by more than [`CONTACT_OVERLAP`]·a — or would at the positions
//!    predicted for the next step, where the run stops ([`Classifier::contact`]; `wall_contact` alike),
//!    or touch at all where the next step failed ([`Classifier::contact_at_failure`]).
//! 4. `string` / `steady`: every particle's ω* = ω/γ̇ changes at a rate |dω*/dt*| below [`STEADY_OMEGA_RATE`]
//!    (the thesis' [`STEADY_OMEGA_TOL`] per step of [`STEADY_REFERENCE_DT`], so any step size tests the same)
//!    (thesis 5.7.2) for [`STEADY_HOLD_STEPS`] consecutive steps; `string` if N ≥ 2 and the particles form
//!    one chain (neighbour gaps below [`CHAIN_GAP`]·a), else `steady`. Not used for Couette.
//! 5. `pass` / `repel` (confined shear, N ≥ 2): with Δx the unwrapped x-distance from the first (top-left)
//!    to the last particle, Δx₀ its initial value: `pass` once Δx ≤ −Δx₀; `repel` once Δx has come down by
//!    at least [`MIN_APPROACH`]·a and then grown back to Δx₀ (reversed trajectories, thesis 5.6.2).
//!
//! At the end time, an undecided case is: Couette `migrated` if |r* − r0*| ≥ [`MIGRATION_MIN`], else
//! `steady` if ω* has met the steady test of rule 4 for its last [`STEADY_HOLD_STEPS`] steps, else
//! `timeout` (a run too short to tell); cylinder channel `steady`; confined shear with N ≥ 2 `string`
//! if the particles have formed one chain for the last [`DRIFTING_STRING_HOLD`] time units t* (a
//! string that translates, or whose ω* still wanders above the steady tolerance:
//! `final_state.steady = false`; strings of rule 4 have `steady = true`); otherwise `timeout`.
//!
//! An outcome other than `string` whose particles formed one chain for at least
//! [`DRIFTING_STRING_HOLD`] t* on the way (a string that came apart, or met a contact) says when:
//! `final_state.chain_held` {from, to}, the longest such chain.
//!
//! Every outcome carries the resolution it rests on: the fewest elements across the narrowest gap
//! up to the decision (`final_state.gap_elements_min`, and `gap_elements` at the decision), and a
//! `final_state.warning` when a decided outcome rests on fewer than [`MIN_GAP_ELEMENTS`].

use super::UndisturbedSurface;
use crate::solver::free_surface::STEADY_HEIGHT_TOL;
use serde_json::{json, Value};

use super::{ParticleState, Sample};
use crate::config::{CaseSpec, Geometry, DEFAULT_EXTRUSION_HEIGHT};
use crate::geometry::layout;
use crate::periodic;

/// Elements across the narrowest gap below which a decided outcome is flagged as possibly set by
/// the mesh. The film force of two cylinders is within 1 % of its converged value at one element
/// across and loses 3 % at half an element, 15–20 % at a quarter, when the film is as finely
/// resolved along it (`xpflow validate near-contact`); twice that margin, as the issue asks,
/// covers the coarser resolution along the film of the channel meshes (6 % lost at h_y = a/5).
pub const MIN_GAP_ELEMENTS: f64 = 2.0;

/// The thesis' steady-state tolerance on |ω*(tⁿ⁺¹) − ω*(tⁿ)| (section 5.7.2) for steps of
/// [`STEADY_REFERENCE_DT`].
pub const STEADY_OMEGA_TOL: f64 = 1e-6;
/// The step Δt* = Δt γ̇ at which the steady test is the thesis' per-step test (its Table 5.2 runs).
pub const STEADY_REFERENCE_DT: f64 = 0.02;
/// The steady test as a rate: |dω*/dt*| = |ω*(tⁿ⁺¹) − ω*(tⁿ)| / Δt* below this (5e-5), the same
/// for fixed and adaptive steps; at Δt* = 0.02 it is the thesis' 1e-6 per step.
pub const STEADY_OMEGA_RATE: f64 = STEADY_OMEGA_TOL / STEADY_REFERENCE_DT;
/// Consecutive steady steps required, so that ω* passing an extremum is not mistaken for a steady state.
pub const STEADY_HOLD_STEPS: u32 = 10;
/// Neighbours closer than this many radii (surface gap) belong to one chain; thesis strings have gaps of
/// 0.065a–0.15a (5.7.2), repelled particles end several radii apart.
pub const CHAIN_GAP: f64 = 0.5;
use crate::particles::Contact;
pub use crate::particles::CONTACT_OVERLAP;
/// Approach (in radii) of the end particles needed before a recovering Δx counts as `repel`, so that noise
/// at the start is not a reversal.
pub const MIN_APPROACH: f64 = 0.1;
/// Time t* = tγ̇ for which the particles must have formed one chain at the end time to count as a
/// (drifting) `string` without meeting the steady test: several times the ≈ 5–10 t* in which the
/// thesis' strings form and settle (5.7.2), so that particles passing through a chain on their way
/// apart do not count.
pub const DRIFTING_STRING_HOLD: f64 = 20.0;
/// Change in r* below which a Couette particle counts as `steady` rather than `migrated` at the end.
pub const MIGRATION_MIN: f64 = 0.01;

/// Kinds of outcome, stored as their snake_case name.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum OutcomeKind {
    /// All particles steady by the ω criterion and in one chain.
    String,
    /// Reversed trajectories.
    Repel,
    /// The end particles passed each other.
    Pass,
    /// Two particles overlap.
    Jammed,
    /// A particle penetrates a wall.
    WallContact,
    /// A particle touches a free surface (extrusion).
    SurfaceContact,
    /// The particle reached the outflow of the extrudate (extrusion): its trajectory is the
    /// result.
    Exited,
    /// Couette: the particle moved by at least [`MIGRATION_MIN`] in r*.
    Migrated,
    /// Steady without a chain, a Couette particle that stayed and rotates steadily, or a finished
    /// cylinder benchmark.
    Steady,
    /// Non-finite state, solver failure to converge or a panic.
    Diverged,
    /// Undecided at the end time.
    Timeout,
}

impl OutcomeKind {
    /// Every kind, in the order of the stored names' CHECK constraint.
    pub const ALL: [OutcomeKind; 11] = [
        OutcomeKind::String,
        OutcomeKind::Repel,
        OutcomeKind::Pass,
        OutcomeKind::Jammed,
        OutcomeKind::WallContact,
        OutcomeKind::SurfaceContact,
        OutcomeKind::Exited,
        OutcomeKind::Migrated,
        OutcomeKind::Steady,
        OutcomeKind::Diverged,
        OutcomeKind::Timeout,
    ];

    /// The stored name, e.g. `wall_contact`.
    pub fn as_str(self) -> &'static str {
        match self {
            OutcomeKind::String => "string",
            OutcomeKind::Repel => "repel",
            OutcomeKind::Pass => "pass",
            OutcomeKind::Jammed => "jammed",
            OutcomeKind::WallContact => "wall_contact",
            OutcomeKind::SurfaceContact => "surface_contact",
            OutcomeKind::Exited => "exited",
            OutcomeKind::Migrated => "migrated",
            OutcomeKind::Steady => "steady",
            OutcomeKind::Diverged => "diverged",
            OutcomeKind::Timeout => "timeout",
        }
    }
}

/// A decided outcome.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Outcome {
    /// The kind.
    pub kind: OutcomeKind,
    /// Number of particles in the chain (`string` only).
    pub string_length: Option<usize>,
    /// Time at which it was decided.
    pub t_decided: f64,
    /// Mean surface gap between chain neighbours in radii, d* = d/a (thesis 5.7.2), when N ≥ 2.
    pub mean_gap: Option<f64>,
    /// Final state: positions, ω*, r* (Couette), and a `reason` for `diverged`.
    pub final_state: Value,
}

/// Decides the outcome of one case from its samples, one step at a time (serializable: a resumed
/// case continues with the classifier it had).
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct Classifier {
    geometry: Geometry,
    radius: f64,
    rate: f64,
    period: Option<f64>,
    /// Unwrapped x of each particle.
    unwrapped: Vec<f64>,
    initial: Vec<[f64; 2]>,
    dx0: Option<f64>,
    dx_min: f64,
    last_omega: Option<Vec<f64>>,
    steady_steps: u32,
    /// Since when (t) the particles have formed one chain (confined shear, N ≥ 2).
    #[serde(default)]
    chained_since: Option<f64>,
    /// The longest time (from, to) the particles formed one chain for at least
    /// [`DRIFTING_STRING_HOLD`] t* before it broke: a string that formed and came apart.
    #[serde(default)]
    chain_held: Option<[f64; 2]>,
    last: Option<Sample>,
    /// Fewest elements across the narrowest gap so far (until the decision).
    #[serde(default)]
    min_gap_elements: Option<f64>,
    decided: Option<Outcome>,
    /// An extrusion's undisturbed surface (x, H̄) and swell ratio, for the final state.
    #[serde(default)]
    undisturbed: Option<UndisturbedSurface>,
    /// Why the step being decided diverged, when the reason is more than a non-finite state.
    #[serde(skip)]
    reason: Option<String>,
}

impl Classifier {
    /// A classifier for `spec`, starting from its initial layout.
    pub fn new(spec: &CaseSpec) -> Self {
        let initial = spec.initial_positions();
        let period = match spec.geometry {
            Geometry::ConfinedShear { l, .. } => Some(l),
            _ => None,
        };
        let dx0 = match (period, initial.len()) {
            (Some(_), n) if n >= 2 => Some(initial[n - 1][0] - initial[0][0]).filter(|d| *d > 0.0),
            _ => None,
        };
        Classifier {
            geometry: spec.geometry.clone(),
            radius: spec.radius().unwrap_or(0.0),
            rate: spec.characteristic_rate(),
            period,
            unwrapped: initial.iter().map(|p| p[0]).collect(),
            initial,
            dx0,
            dx_min: dx0.unwrap_or(0.0),
            last_omega: None,
            steady_steps: 0,
            chained_since: None,
            chain_held: None,
            last: None,
            min_gap_elements: None,
            decided: None,
            undisturbed: None,
            reason: None,
        }
    }

    /// Records an extrusion's undisturbed steady surface: the final state keeps it
    /// (`undisturbed_surface`: `x`, `h`, `swell`, `steps`, `steady`).
    pub fn set_undisturbed_surface(&mut self, surface: &UndisturbedSurface) {
        self.undisturbed = Some(surface.clone());
    }

    /// The outcome, if already decided.
    pub fn decided(&self) -> Option<&Outcome> {
        self.decided.as_ref()
    }

    /// Takes one step's sample; returns the outcome when this step decides it (once).
    pub fn push(&mut self, s: &Sample) -> Option<Outcome> {
        if self.decided.is_some() {
            self.last = Some(s.clone());
            return None;
        }
        if let Some(e) = s.gap_elements {
            self.min_gap_elements = Some(self.min_gap_elements.map_or(e, |m| m.min(e)));
        }
        let decision = self.decide(s);
        self.last = Some(s.clone());
        if let Some(kind) = decision {
            let reason = self.reason.take();
            let mut outcome = self.outcome(kind, s.t, reason.as_deref());
            if kind == OutcomeKind::String {
                outcome.final_state["steady"] = json!(true);
            }
            self.decided = Some(outcome.clone());
            return Some(outcome);
        }
        None
    }

    /// Records a contact predicted for the step after time `t` (the run stops there): `jammed`
    /// for two particles, `wall_contact` for a wall, unless the outcome is already decided; the
    /// final state keeps the last computed positions and says what was predicted (`contact`).
    pub fn contact(&mut self, contact: &Contact, t: f64) -> Option<Outcome> {
        self.contact_described(contact, t, format!("{contact} at the predicted positions"))
    }

    /// Records a contact of the last computed positions (any overlap) from which the next step
    /// failed with `error` — the flow solve can fail as the film between touching particles
    /// closes, before the overlap reaches the rules' threshold: `jammed` / `wall_contact` as in
    /// [`contact`](Self::contact), with the failure in `final_state.contact`.
    pub fn contact_at_failure(
        &mut self,
        contact: &Contact,
        t: f64,
        error: &str,
    ) -> Option<Outcome> {
        self.contact_described(
            contact,
            t,
            format!("{contact} at the last computed positions; the next step failed: {error}"),
        )
    }

    fn contact_described(&mut self, contact: &Contact, t: f64, what: String) -> Option<Outcome> {
        let kind = match contact {
            Contact::Overlap { .. } => OutcomeKind::Jammed,
            Contact::Wall { .. } => OutcomeKind::WallContact,
            Contact::Surface { .. } => OutcomeKind::SurfaceContact,
            Contact::Outflow { .. } => OutcomeKind::Exited,
        };
        if let Some(decided) = &mut self.decided {
            // the first decision stands; a run that went on past it (no early stop) says why it
            // ended before its end time
            decided.final_state["ended_by"] = json!({ "kind": kind, "t": t, "contact": what });
            return None;
        }
        let mut outcome = self.outcome(kind, t, None);
        outcome.final_state["contact"] = json!(what);
        self.decided = Some(outcome.clone());
        Some(outcome)
    }

    /// Records that the solver diverged (or panicked) at time `t` with `reason`.
    pub fn diverged(&mut self, t: f64, reason: &str) -> Outcome {
        let outcome = self.outcome(OutcomeKind::Diverged, t, Some(reason));
        self.decided = Some(outcome.clone());
        outcome
    }

    /// The outcome at the end of the run (decided earlier, or by the end-time rules). A decided
    /// outcome whose run went on (no early stop) keeps its state at the decision and adds the
    /// last sample's as `final_state.at_end` (t, positions, ω*, gaps): what became of a string.
    pub fn finish(mut self) -> Outcome {
        if let Some(mut o) = self.decided.take() {
            let t = self.last.as_ref().map_or(o.t_decided, |s| s.t);
            if t > o.t_decided {
                o.final_state["at_end"] = self.particles_at(t).0;
            }
            return o;
        }
        let t = self.last.as_ref().map_or(0.0, |s| s.t);
        let kind = match self.geometry {
            Geometry::Couette { r1, r2, .. } => {
                let moved = self
                    .last
                    .as_ref()
                    .and_then(|s| s.particles.first())
                    .map_or(0.0, |p| {
                        (layout::r_star(r1, r2, [p.x, p.y])
                            - layout::r_star(r1, r2, self.initial[0]))
                        .abs()
                    });
                if moved >= MIGRATION_MIN {
                    OutcomeKind::Migrated
                } else if self.steady_steps >= STEADY_HOLD_STEPS {
                    OutcomeKind::Steady
                } else {
                    // neither moved nor settled: the run was too short to tell
                    OutcomeKind::Timeout
                }
            }
            Geometry::CylinderChannel { .. } => OutcomeKind::Steady,
            // the end time came before the particle reached the outflow
            Geometry::Extrusion { .. } => OutcomeKind::Timeout,
            Geometry::ConfinedShear { .. } => {
                let held = self
                    .chained_since
                    .is_some_and(|t0| (t - t0) * self.rate >= DRIFTING_STRING_HOLD);
                if held {
                    OutcomeKind::String
                } else {
                    OutcomeKind::Timeout
                }
            }
        };
        let mut outcome = self.outcome(kind, t, None);
        if kind == OutcomeKind::String {
            outcome.final_state["steady"] = json!(false);
        }
        outcome
    }

    /// The longest time (from, to) the particles formed one chain for at least
    /// [`DRIFTING_STRING_HOLD`] t*: one that broke, or the one they form now.
    fn longest_chain(&self) -> Option<[f64; 2]> {
        let now = self
            .chained_since
            .zip(self.last.as_ref().map(|l| l.t))
            .map(|(a, b)| [a, b])
            .filter(|[a, b]| (b - a) * self.rate >= DRIFTING_STRING_HOLD);
        match (self.chain_held, now) {
            (Some(h), Some(n)) => Some(if n[1] - n[0] > h[1] - h[0] { n } else { h }),
            (h, n) => h.or(n),
        }
    }

    fn decide(&mut self, s: &Sample) -> Option<OutcomeKind> {
        let ps = &s.particles;
        if !s.t.is_finite() || ps.iter().any(|p| !state_is_finite(p)) {
            return Some(OutcomeKind::Diverged);
        }
        if let Some(reason) = self.outside(s) {
            self.reason = Some(reason);
            return Some(OutcomeKind::Diverged);
        }
        let a = self.radius;
        let slack = CONTACT_OVERLAP * a;
        let wall = match self.geometry {
            Geometry::ConfinedShear { h, .. } => ps.iter().any(|p| p.y.abs() + a > h / 2.0 + slack),
            Geometry::Couette { r1, r2, .. } => ps.iter().any(|p| {
                let r = p.x.hypot(p.y);
                r - a < r1 - slack || r + a > r2 + slack
            }),
            // the die wall above, the symmetry line below
            Geometry::Extrusion { h0, .. } => ps
                .iter()
                .any(|p| (p.x <= 0.0 && p.y + a > h0 + slack) || p.y - a < -slack),
            Geometry::CylinderChannel { .. } => false,
        };
        if wall {
            return Some(OutcomeKind::WallContact);
        }
        // an extrusion without particles (the extrudate swell): the steady test of thesis §6.4
        if ps.is_empty()
            && s.surface
                .as_ref()
                .is_some_and(|f| f.change < STEADY_HEIGHT_TOL)
        {
            return Some(OutcomeKind::Steady);
        }
        let centres: Vec<[f64; 2]> = ps.iter().map(|p| [p.x, p.y]).collect();
        for i in 0..centres.len() {
            for j in i + 1..centres.len() {
                if layout::surface_gap(centres[i], centres[j], a, self.period) < -slack {
                    return Some(OutcomeKind::Jammed);
                }
            }
        }
        let chained = ps.len() >= 2
            && chain_gaps(&centres, a, self.period)
                .iter()
                .all(|g| *g < CHAIN_GAP * a);
        if chained {
            self.chained_since = self.chained_since.or(Some(s.t));
        } else {
            // (the chain up to the last sample: kept if it is the longest that held)
            self.chain_held = self.longest_chain();
            self.chained_since = None;
        }
        // Steady-state test on the rate of change of ω* over the step.
        let omega: Vec<f64> = ps.iter().map(|p| p.omega / self.rate).collect();
        let dt_star = self.last.as_ref().map(|l| (s.t - l.t) * self.rate);
        let steady_now = match (self.last_omega.as_ref(), dt_star) {
            (Some(prev), Some(dt_star)) if dt_star > 0.0 => {
                prev.len() == omega.len()
                    && prev
                        .iter()
                        .zip(&omega)
                        .all(|(a, b)| (a - b).abs() < STEADY_OMEGA_RATE * dt_star)
            }
            _ => false,
        };
        self.steady_steps = if steady_now { self.steady_steps + 1 } else { 0 };
        self.last_omega = Some(omega);
        // (a Couette particle's outcome is its migration, an extruded one's its trajectory)
        let by_rotation = !matches!(
            self.geometry,
            Geometry::Couette { .. } | Geometry::Extrusion { .. }
        );
        if self.steady_steps >= STEADY_HOLD_STEPS && by_rotation && !ps.is_empty() {
            return Some(if chained {
                OutcomeKind::String
            } else {
                OutcomeKind::Steady
            });
        }
        // Pass / repel from the end particles' unwrapped x-distance.
        if let (Some(l), Some(dx0)) = (self.period, self.dx0) {
            for (u, p) in self.unwrapped.iter_mut().zip(ps) {
                *u += periodic::fold(p.x - *u, Some(l));
            }
            let dx = self.unwrapped[ps.len() - 1] - self.unwrapped[0];
            self.dx_min = self.dx_min.min(dx);
            if dx <= -dx0 {
                return Some(OutcomeKind::Pass);
            }
            if self.dx_min <= dx0 - MIN_APPROACH * a && dx >= dx0 {
                return Some(OutcomeKind::Repel);
            }
        }
        None
    }

    /// Why a sample is impossible, if it is: a particle centre outside the domain (beyond a
    /// wall of the channel, outside the Couette gap). No contact can put it there; a time step
    /// that carried it across the wall did (issue 28: y = −0.94 with H/2 = 0.5 after one step).
    fn outside(&self, s: &Sample) -> Option<String> {
        s.particles
            .iter()
            .enumerate()
            .find_map(|(i, p)| match self.geometry {
                Geometry::ConfinedShear { h, .. } if p.y.abs() > h / 2.0 => Some(format!(
                    "step {}: particle {i} at y = {:.6} is outside the channel (|y| > H/2 = {}): \
                 an impossible state, the time step carried it through a wall",
                    s.step,
                    p.y,
                    h / 2.0
                )),
                Geometry::Couette { r1, r2, .. } => {
                    let r = p.x.hypot(p.y);
                    (r < r1 || r > r2).then(|| {
                        format!(
                        "step {}: particle {i} at r = {r:.6} is outside the gap [{r1}, {r2}]: an \
                         impossible state, the time step carried it through a cylinder",
                        s.step
                    )
                    })
                }
                Geometry::Extrusion {
                    h0,
                    die_length,
                    extrudate_length,
                    height,
                    ..
                } => {
                    // the mesh's rectangle, and below the die's wall inside the die
                    let top = height.unwrap_or(DEFAULT_EXTRUSION_HEIGHT * h0);
                    let in_mesh = (-die_length..=extrudate_length).contains(&p.x)
                        && (0.0..=top).contains(&p.y);
                    let in_die_wall = p.x < 0.0 && p.y > h0;
                    (!in_mesh || in_die_wall).then(|| {
                        format!(
                            "step {}: particle {i} at ({:.6e}, {:.6e}) is outside the extrusion's \
                             fluid ([−{die_length}, {extrudate_length}] × [0, {top}], below y = \
                             {h0} in the die): an impossible state, the run diverged",
                            s.step, p.x, p.y
                        )
                    })
                }
                _ => None,
            })
    }

    /// The scale of ω* in the final state: γ̇ in confined shear (thesis §5.7), ω̄ of the inner
    /// cylinder in the Couette cell (thesis §3.5: ω* = ω/ω̄, as the figures and `query` use).
    fn omega_scale(&self) -> f64 {
        match self.geometry {
            Geometry::Couette { omega_inner, .. } => omega_inner,
            _ => self.rate,
        }
    }
}

fn state_is_finite(p: &ParticleState) -> bool {
    [p.x, p.y, p.u, p.v, p.omega, p.theta]
        .iter()
        .all(|v| v.is_finite())
}

/// Surface gaps between neighbours of the chain ordered by x along the string (periodic distance).
fn chain_gaps(centres: &[[f64; 2]], a: f64, period: Option<f64>) -> Vec<f64> {
    let mut order: Vec<usize> = (0..centres.len()).collect();
    order.sort_by(|&i, &j| centres[i][0].total_cmp(&centres[j][0]));
    order
        .windows(2)
        .map(|w| layout::surface_gap(centres[w[0]], centres[w[1]], a, period))
        .collect()
}

mod final_state;
#[cfg(test)]
mod tests;
