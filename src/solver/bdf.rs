//! Variable-step BDF2 (Gear) and the linear extrapolation that goes with it: the time levels of
//! every field with history (the log-conformation, the semi-implicit stress predictor, the
//! temporary ALE's mesh velocity) are combined with these coefficients, so that a step Δtₙ after
//! a step Δtₙ₋₁ stays second order. With ω = Δtₙ/Δtₙ₋₁,
//!
//! ```text
//! du/dt(tⁿ⁺¹) ≈ (c₀ uⁿ⁺¹ − c₁ uⁿ + c₂ uⁿ⁻¹) / Δtₙ,   c₀ = (1+2ω)/(1+ω), c₁ = 1+ω, c₂ = ω²/(1+ω)
//! û(tⁿ⁺¹)     ≈ (1+ω) uⁿ − ω uⁿ⁻¹
//! ```
//!
//! (ω = 1: the fixed-step 3/2, 2, 1/2 and 2uⁿ − uⁿ⁻¹, bit for bit.) The scheme is zero-stable for
//! ω < 1 + √2; the step controller keeps ω ≤ 2.

/// The coefficients of one step (see the module docs); Euler for a first step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bdf2 {
    /// c₀ (coefficient of the new level).
    pub c0: f64,
    /// c₁ (of uⁿ).
    pub c1: f64,
    /// c₂ (of uⁿ⁻¹; 0 for Euler).
    pub c2: f64,
    /// The extrapolation weight ω: û = (1+ω)uⁿ − ω uⁿ⁻¹ (0 for Euler: û = uⁿ).
    pub ratio: f64,
}

impl Bdf2 {
    /// Backward Euler: the first step, which has no earlier level.
    pub const EULER: Bdf2 = Bdf2 {
        c0: 1.0,
        c1: 1.0,
        c2: 0.0,
        ratio: 0.0,
    };

    /// BDF2 for the step ratio ω = Δtₙ/Δtₙ₋₁.
    pub fn with_ratio(ratio: f64) -> Bdf2 {
        let w = ratio;
        Bdf2 {
            c0: (1.0 + 2.0 * w) / (1.0 + w),
            c1: 1.0 + w,
            c2: w * w / (1.0 + w),
            ratio: w,
        }
    }

    /// The step `dt` after a step `previous` (`None`: Euler, the first step).
    pub fn after(dt: f64, previous: Option<f64>) -> Bdf2 {
        match previous {
            Some(p) => Bdf2::with_ratio(dt / p),
            None => Bdf2::EULER,
        }
    }

    /// Whether this is the Euler step.
    pub fn is_euler(&self) -> bool {
        self.c2 == 0.0 && self.ratio == 0.0
    }

    /// The extrapolation weights (of uⁿ, of uⁿ⁻¹): (1+ω, −ω).
    pub fn extrapolation(&self) -> (f64, f64) {
        (1.0 + self.ratio, -self.ratio)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Round-off of a few operations on O(1) numbers.
    const ROUND_OFF: f64 = 1e-13;

    #[test]
    fn fixed_steps_give_the_fixed_step_coefficients_exactly() {
        let b = Bdf2::after(0.02, Some(0.02));
        assert_eq!((b.c0, b.c1, b.c2), (1.5, 2.0, 0.5));
        assert_eq!(b.extrapolation(), (2.0, -1.0));
        assert!(Bdf2::after(0.02, None).is_euler());
    }

    #[test]
    fn variable_steps_differentiate_and_extrapolate_quadratics_and_lines_exactly() {
        // u = 3 + 2t − 5t²: BDF2 is exact for quadratics, the extrapolation for lines
        let u = |t: f64| 3.0 + 2.0 * t - 5.0 * t * t;
        let du = |t: f64| 2.0 - 10.0 * t;
        let line = |t: f64| 1.0 - 4.0 * t;
        for (dt_prev, dt) in [(0.1, 0.05), (0.1, 0.2), (0.3, 0.07), (0.02, 0.04)] {
            let (t0, t1) = (0.4, 0.4 + dt_prev);
            let t2 = t1 + dt;
            let b = Bdf2::after(dt, Some(dt_prev));
            let d = (b.c0 * u(t2) - b.c1 * u(t1) + b.c2 * u(t0)) / dt;
            assert!((d - du(t2)).abs() < ROUND_OFF / dt, "{dt_prev} → {dt}: {d}");
            let (w1, w0) = b.extrapolation();
            let hat = w1 * line(t1) + w0 * line(t0);
            assert!(
                (hat - line(t2)).abs() < ROUND_OFF,
                "{dt_prev} → {dt}: {hat}"
            );
        }
    }
}
