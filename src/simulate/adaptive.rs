//! Error-controlled time steps (`numerics.dt = { initial, min, max, tol }`).
//!
//! Every history term of the step is second order for varying steps (`solver::bdf`: the
//! log-conformation BDF2, the ALE mesh velocity, the semi-implicit stress predictor; the particle
//! predictor X̂ = Xⁿ + ω(Xⁿ − Xⁿ⁻¹) and the trapezoidal corrector). The error estimate of a step
//! is how far the particles' state is from its extrapolation Ŷ = Yⁿ + ω(Yⁿ − Yⁿ⁻¹), max over
//! particles of |Xⁿ⁺¹ − X̂| and a|Θⁿ⁺¹ − Θ̂| (in radii) over `tol` and of |Uⁿ⁺¹ − Û| and
//! a|ωⁿ⁺¹ − ω̂| (in radii per 1/γ̇) over [`VELOCITY_TOL_FACTOR`] `tol`, each ≈ ½(1+ω)Δt²|Ÿ| for
//! smooth motion; e ≤ 1 accepts the step. The particles carry what an outcome is made of
//! (positions, gaps, ω*), and their acceleration carries the stress build-up that drives them.
//! The velocities are needed: with positions and angles alone (tol = 1e-3, three particles,
//! Wi = 2, 100×25) the steps grew to 0.1–0.2 and the middle particle's ω* (the smallest, set by
//! the difference of its neighbours') wandered up to 20 % from the Δt = 0.02 run's while the
//! positions stayed within 1 % of a. The log-conformation's deviation from its extrapolation is
//! no time-error estimate: on the same case it was 2.1e-3 at Δt = 0.002 and 2.4e-3 at Δt = 0.02,
//! the remap and cut-cell changes of each step rather than Δt², and held the step at the fixed
//! one.
//!
//! The explicit stress coupling adds an error the extrapolation does not see: the flow of a
//! step is solved with the stress of cⁿ, so while the stress builds up the particles' velocities
//! lag by O(Δt |dτ/dt|), one sign over many steps, which the positions integrate (measured:
//! three particles, Wi = 1, β = 0.5, 100×25, t* = 30, the gaps end 0.122a / 0.149a / 0.157a at
//! fixed Δt = 0.04 / 0.02 / 0.01 while the deviation from the extrapolation stays below 1e-3).
//! With `coupling_lag = true` each step is solved once more with the stress at its end
//! ([`MovingParticles::coupling_lag`](crate::solver::moving::MovingParticles::coupling_lag),
//! the step's factorization reused) and the change of the velocities, in radii per 1/γ̇, is
//! held below [`LAG_TOL_FACTOR`] `tol`: a drift of at most `tol` radii per unit time.
//!
//! The next step comes from a PI controller for an estimate of order 2 (Gustafsson; Hairer &
//! Wanner §IV.2), Δtₙ₊₁ = Δtₙ · SAFETY · e⁻⁰·³⁵ · (eₙ₋₁/eₙ)⁰·², its ratio to Δtₙ kept in
//! [`MIN_RATIO`, `MAX_RATIO`] (variable-step BDF2 is zero-stable for ratios below 1 + √2), within
//! [min, max] and below the step in which a particle would cross [`MOTION_ELEMENTS_PER_STEP`]
//! (a proposal within [`KEEP_BAND`] of the step keeps it: Δt changes in jumps, not by drift)
//! elements of the mesh. A step with e > 1 is rejected and redone from the saved state with a
//! smaller Δt (unless Δt is at `min`: then it is taken); so is a step whose predicted particles
//! touch, until Δt is at `min` (a large step's extrapolation is no evidence of contact).
//!
//! The largest step is also bounded by the case validation (`max` ≤ `MAX_DT_OVER_LAMBDA` λ: the
//! relaxation term is explicit).

use serde::{Deserialize, Serialize};

use crate::config::{AdaptiveStep, MAX_ELEMENTS_PER_STEP};
use crate::particles::Deviation;

/// What `xpflow run --resolved` prints for the controller.
pub const DESCRIPTION: &str = "PI controller on the particles' deviation from their extrapolation \
     (positions and angles in radii over tol, velocities in radii per 1/γ̇ over 10 tol) and, with \
     coupling_lag, on the explicit coupling's lag (the velocities solved again with the stress at \
     the end of the step, radii per 1/γ̇ over tol); a proposal within [0.8, 1.25] of the step \
     keeps it, otherwise 0.5-2 times it; at most half an element of particle motion per step; \
     rejected steps redone; SUPG τ at the initial Δt";

/// Smallest ratio of one step to the last (a rejection or a fast transient).
pub const MIN_RATIO: f64 = 0.5;
/// Largest ratio of one step to the last (the range; zero-stable BDF2 needs < 1 + √2).
pub const MAX_RATIO: f64 = 2.0;
/// Safety factor of the step proposal.
pub const SAFETY: f64 = 0.9;
/// An accepted step's proposal between these factors keeps the step as it is: Δt changes only in
/// jumps (as in DASSL and CVODE). Every change of Δt kicks the particle velocities, which lag the
/// stress by a step (an O(|Δtₙ − Δtₙ₋₁|) jump), and the velocities are part of the error: a
/// controller that followed every small change fed its own jitter (measured: three particles,
/// Wi = 2, 200×50, Δt wandering 0.09–0.105 from step to step kept the middle particle's ω*
/// swinging 0.075–0.102 around its steady 0.088 from t* = 60 to 140, never steady).
pub const KEEP_BAND: (f64, f64) = (0.8, 1.25);
/// Integral and proportional exponents of the PI controller for an estimate ∝ Δt²
/// (0.7/2 and 0.4/2, Hairer & Wanner).
const K_I: f64 = 0.35;
const K_P: f64 = 0.2;
/// Elements of the mesh a particle may cross in one step: half the case validation's limit for a
/// fixed step ([`MAX_ELEMENTS_PER_STEP`]), since the predictor extrapolates the motion.
pub const MOTION_ELEMENTS_PER_STEP: f64 = 0.5 * MAX_ELEMENTS_PER_STEP;
/// The velocities' tolerance is this many times the positions' (both in radii, velocities per
/// 1/γ̇). The explicit stress coupling lags the stress by a step, so a particle's velocity is
/// off by O(Δtₙ) and a varying step shows as a velocity jitter of O(|Δtₙ − Δtₙ₋₁|) that the
/// positions integrate away; and at the start the velocities deviate by ≈ 1e-3 whatever the
/// step (measured: 1.3e-3 to 1.0e-3 from Δt = 0.025 down to 0.006, three particles, Wi = 2,
/// 100×25). With the same tolerance as the positions the controller would chase that floor; ten
/// times it still catches the oscillations of too large a step (4e-3 and up at Δt = 0.16–0.2).
pub const VELOCITY_TOL_FACTOR: f64 = 10.0;
/// The coupling lag's tolerance is this many times the positions' (radii per 1/γ̇ against
/// radii). The lag is a velocity error of the whole step, first order in Δt and of one sign
/// while the stress builds up, so the positions integrate it rather than average it away (unlike
/// the extrapolation's velocity jitter, [`VELOCITY_TOL_FACTOR`]). Measured (three particles,
/// Wi = 1, β = 0.5, x-graded 100×25, t* = 30): lag ≤ tol with tol = 1e-3 and max 0.08 ends
/// within 1.3 % of fixed Δt = 0.01 in the gaps in 958 steps (3000); without it the steps of the
/// stress build-up stay large and the gaps end 8 % (tol 2e-4) to 50 % (tol 1e-3) off, with the
/// lag held at the velocities' 10 tol (tol 2e-4) 4 % (docs/validation.md, "The explicit
/// coupling's lag"). At β = 0.1 (Wi = 2) the same rule takes 4.4× the steps of the controller
/// without it (1723 against 393) for gaps that differ by < 1 %: hence opt-in.
pub const LAG_TOL_FACTOR: f64 = 1.0;
/// Smallest error taken into the controller (an exactly predicted step would propose ∞).
const ERROR_FLOOR: f64 = 1e-10;

/// Scaled error (1: the tolerance) above which a step at the minimum Δt ends the run as
/// diverged instead of being kept. At the minimum the controller keeps steps above the
/// tolerance (it may not shrink further), but a step a thousand times above it is not a
/// slightly-too-large step: the particles' positions or velocities jumped. Measured: the Couette
/// case that failed on 2026-12-05 (Wi = 1, r0* = 1/2, t* = 160.18) kept a step at Δt = 0.002
/// whose particle velocity had gone from 0.14 to 243 (a scaled error ≈ 1e5), and its next step
/// failed in the ALE map with the advice to reduce Δt.
pub const DIVERGED_ERROR: f64 = 1e3;

/// Whether a step stands.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Verdict {
    /// Keep the step; the next one is [`StepController::dt`].
    Accept,
    /// Redo the step from its saved state with [`StepController::dt`].
    Reject,
    /// The step's scaled error is above [`DIVERGED_ERROR`] at the minimum Δt: the run has
    /// diverged (a smaller step is not allowed and would not help).
    Diverged {
        /// The scaled error.
        error: f64,
    },
}

/// The controller's state: part of a saved state, so that a resumed run takes the steps the
/// uninterrupted one would have.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StepController {
    spec: AdaptiveStep,
    /// The case's characteristic rate γ̇ (velocities are compared in radii per 1/γ̇).
    rate: f64,
    /// Δt of the next step (before clipping to the end time).
    dt: f64,
    /// The error of the last accepted step.
    last_error: Option<f64>,
    /// Steps tried and redone so far (an error above the tolerance or a predicted contact).
    #[serde(default)]
    rejected: u64,
}

impl StepController {
    /// A controller starting at the case's initial Δt, for a case of characteristic rate
    /// `rate` (γ̇).
    pub fn new(spec: AdaptiveStep, rate: f64) -> Self {
        Self {
            spec,
            rate,
            dt: spec.initial,
            last_error: None,
            rejected: 0,
        }
    }

    /// Continues the progress of `saved` (its Δt, last error and rejections) under this
    /// controller's own bounds and rate, those of the case being run: a state saved by a build
    /// whose defaults differed, or edited, cannot carry other bounds into the run. The saved Δt
    /// is clipped to [min, max].
    pub fn resume_from(&mut self, saved: &StepController) {
        self.dt = saved.dt.clamp(self.spec.min, self.spec.max);
        self.last_error = saved.last_error;
        self.rejected = saved.rejected;
    }

    /// Steps tried and redone so far (each costs a step's work beside the accepted ones).
    pub fn rejected(&self) -> u64 {
        self.rejected
    }

    /// Δt of the next step.
    pub fn dt(&self) -> f64 {
        self.dt
    }

    /// Whether the step's error includes the explicit coupling's lag (`coupling_lag`).
    pub fn estimates_lag(&self) -> bool {
        self.spec.coupling_lag
    }

    /// The scaled error of a step (≤ 1 meets the tolerance) from the particles' deviation from
    /// their extrapolation and the coupling's `lag` (both in radii per unit time for the
    /// velocities); `None` without a deviation (a first step).
    pub fn error_of(&self, deviation: Option<Deviation>, lag: Option<f64>) -> Option<f64> {
        deviation.map(|d| {
            let velocity = d.velocity / (self.rate * VELOCITY_TOL_FACTOR);
            let lag = lag.unwrap_or(0.0) / (self.rate * LAG_TOL_FACTOR);
            d.position.max(velocity).max(lag) / self.spec.tol
        })
    }

    /// Judges a step of size `taken` with scaled error `error` (≤ 1 meets the tolerance; `None`:
    /// no estimate, a first step) and sets the next Δt, at most `limit` (the particles' motion).
    pub fn judge(&mut self, taken: f64, error: Option<f64>, limit: f64) -> Verdict {
        let Some(e) = error.map(|e| e.max(ERROR_FLOOR)) else {
            self.dt = self.bounded(taken, taken, limit);
            return Verdict::Accept;
        };
        if e > 1.0 && taken > self.spec.min {
            let factor = (SAFETY * e.powf(-0.5)).clamp(MIN_RATIO, 1.0);
            self.dt = (taken * factor).max(self.spec.min);
            self.rejected += 1;
            return Verdict::Reject;
        }
        if e > DIVERGED_ERROR {
            return Verdict::Diverged { error: e };
        }
        let memory = self.last_error.map_or(1.0, |last| (last / e).powf(K_P));
        let mut factor = (SAFETY * e.powf(-K_I) * memory).clamp(MIN_RATIO, MAX_RATIO);
        if (KEEP_BAND.0..KEEP_BAND.1).contains(&factor) {
            factor = 1.0;
        }
        self.last_error = Some(e);
        self.dt = self.bounded(taken * factor, taken, limit);
        Verdict::Accept
    }

    /// After a predicted contact: halves Δt and asks for the step to be tried again, or `false`
    /// when Δt is already at `min` (then the contact stands).
    pub fn retry_contact(&mut self, taken: f64) -> bool {
        if taken <= self.spec.min {
            return false;
        }
        self.dt = (MIN_RATIO * taken).max(self.spec.min);
        self.rejected += 1;
        true
    }

    /// `proposed` within [min, max], at most `limit` and at most [`MAX_RATIO`] times `taken`.
    fn bounded(&self, proposed: f64, taken: f64, limit: f64) -> f64 {
        proposed
            .min(MAX_RATIO * taken)
            .min(self.spec.max)
            .min(limit)
            .max(self.spec.min)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn controller() -> StepController {
        StepController::new(
            AdaptiveStep {
                initial: 0.02,
                min: 0.001,
                max: 0.2,
                tol: 1e-3,
                coupling_lag: true,
            },
            2.0,
        )
    }

    #[test]
    fn a_resumed_controller_keeps_the_cases_bounds_and_the_saved_progress() {
        let mut saved = controller();
        saved.judge(0.02, None, f64::INFINITY);
        saved.judge(0.02, Some(1e-6), f64::INFINITY);
        assert_eq!(saved.judge(0.04, Some(4.0), f64::INFINITY), Verdict::Reject);
        // the case as run now: a smaller max than the state was saved with
        let mut spec = controller().spec;
        spec.max = 0.015;
        let mut resumed = StepController::new(spec, 2.0);
        resumed.resume_from(&saved);
        assert_eq!(resumed.spec, spec, "the case's bounds, not the state's");
        assert_eq!(
            resumed.dt(),
            0.015,
            "the saved Δt clipped to the case's max"
        );
        assert_eq!(resumed.rejected(), 1);
        assert_eq!(resumed.last_error, saved.last_error);
        // within the bounds the saved Δt is taken as it is
        let mut same = controller();
        same.resume_from(&saved);
        assert_eq!((same.dt(), same.rejected()), (saved.dt(), 1));
    }

    #[test]
    fn small_errors_grow_the_step_by_at_most_the_ratio_limit_and_up_to_max() {
        let mut c = controller();
        assert_eq!(c.judge(0.02, None, f64::INFINITY), Verdict::Accept);
        assert_eq!(c.dt(), 0.02);
        assert_eq!(c.judge(0.02, Some(1e-6), f64::INFINITY), Verdict::Accept);
        assert_eq!(c.dt(), 0.04);
        let mut dt = c.dt();
        for _ in 0..10 {
            c.judge(dt, Some(1e-6), f64::INFINITY);
            dt = c.dt();
        }
        assert_eq!(dt, 0.2, "max bounds the step");
        c.judge(dt, Some(1e-6), 0.05);
        assert_eq!(c.dt(), 0.05, "the particles' motion bounds the step");
    }

    #[test]
    fn a_large_error_rejects_and_shrinks_the_step_but_not_below_min_where_a_huge_one_diverges() {
        let mut c = controller();
        c.judge(0.02, None, f64::INFINITY);
        assert_eq!(c.judge(0.02, Some(4.0), f64::INFINITY), Verdict::Reject);
        // 0.9/√4 = 0.45 < ½: the ratio limit
        assert_eq!(c.dt(), 0.01);
        assert_eq!(c.judge(0.0015, Some(100.0), f64::INFINITY), Verdict::Reject);
        assert_eq!(c.dt(), 0.001);
        assert_eq!(c.rejected(), 2, "each rejection is counted");
        assert_eq!(
            c.judge(0.001, Some(100.0), f64::INFINITY),
            Verdict::Accept,
            "at min a step above the tolerance is taken"
        );
        assert_eq!(
            c.judge(0.001, Some(DIVERGED_ERROR), f64::INFINITY),
            Verdict::Accept,
            "up to DIVERGED_ERROR"
        );
        // beyond it the run has diverged: the velocity jump of 2026-12-05 (≈ 1e5)
        assert_eq!(
            c.judge(0.001, Some(1.2e5), f64::INFINITY),
            Verdict::Diverged { error: 1.2e5 }
        );
        // above the minimum the same error only rejects
        assert_eq!(c.judge(0.004, Some(1.2e5), f64::INFINITY), Verdict::Reject);
    }

    #[test]
    fn an_error_near_the_tolerance_keeps_the_step_and_a_far_one_changes_it() {
        // e = 1: SAFETY · 1 = 0.9, inside KEEP_BAND: Δt stays
        let mut c = controller();
        c.judge(0.02, None, f64::INFINITY);
        c.judge(0.02, Some(1.0), f64::INFINITY);
        assert_eq!(c.dt(), 0.02);
        // e = 0.25 after 1: 0.9 · 0.25^-0.35 · 4^0.2 = 1.89: grows
        c.judge(0.02, Some(0.25), f64::INFINITY);
        let expect = 0.02 * 0.9 * 0.25f64.powf(-0.35) * 4f64.powf(0.2);
        assert!((c.dt() - expect).abs() < 1e-15, "{}", c.dt());
        // e = 0.9 after 0.25: 0.9 · 0.9^-0.35 · (0.25/0.9)^0.2 = 0.72: shrinks
        let taken = c.dt();
        c.judge(taken, Some(0.9), f64::INFINITY);
        let expect = taken * 0.9 * 0.9f64.powf(-0.35) * (0.25f64 / 0.9).powf(0.2);
        assert!((c.dt() - expect).abs() < 1e-15, "{}", c.dt());
    }

    #[test]
    fn a_predicted_contact_halves_the_step_until_min() {
        let mut c = controller();
        assert!(c.retry_contact(0.02));
        assert_eq!(c.dt(), 0.01);
        assert!(c.retry_contact(0.0015));
        assert_eq!(c.dt(), 0.001);
        assert!(!c.retry_contact(0.001));
        assert_eq!(
            c.rejected(),
            2,
            "a retried step is a rejected one, the last was taken"
        );
    }

    #[test]
    fn the_error_is_the_larger_deviation_over_the_tolerance_with_velocities_per_rate() {
        let c = controller();
        assert_eq!(c.error_of(None, Some(1.0)), None);
        let d = |position, velocity| Some(Deviation { position, velocity });
        assert_eq!(c.error_of(d(2e-3, 1e-3), None), Some(2.0));
        // velocities in radii per 1/γ̇ (γ̇ = 2), VELOCITY_TOL_FACTOR times more tolerated
        let e = c
            .error_of(d(1e-3, 2.0 * VELOCITY_TOL_FACTOR * 3e-3), None)
            .unwrap();
        assert!((e - 3.0).abs() < 1e-12, "{e}");
        // the coupling's lag in radii per 1/γ̇, LAG_TOL_FACTOR times the positions' tolerance
        let e = c
            .error_of(d(1e-3, 0.0), Some(2.0 * LAG_TOL_FACTOR * 4e-3))
            .unwrap();
        assert!((e - 4.0).abs() < 1e-12, "{e}");
        assert_eq!(c.error_of(d(1e-3, 0.0), Some(0.0)), Some(1.0));
    }
}
