//! Second order with variable steps (issue 27): the translating cylinder of thesis §5.4
//! ([`super::moving`]) run with a random sequence of steps whose consecutive ratios lie in
//! [½, 2] (the range the step controller of `simulate::adaptive` allows), for several mean step
//! sizes, up to t ≤ λ; K(t) at the steps' own times is compared with a fine fixed-step reference interpolated
//! there (cubic Lagrange on the reference's uniform times, whose own error is far below the
//! compared ones). Everything with history sees the varying steps: the log-conformation BDF2,
//! the semi-implicit stress predictor, the temporary ALE's mesh velocity, the particle predictor.

use super::moving::{
    fitted_slope, translating_cylinder, translating_cylinder_steps, CylinderStress, Frame, LAMBDA,
};
use crate::solver::ale::Remap;
use crate::solver::moving::MovingError;
use crate::xfem::CutOptions;

/// Required fitted order, as for fixed steps ([`super::moving::MIN_TIME_RATE`]).
pub const MIN_VARIABLE_RATE: f64 = 1.8;

/// Smallest and largest ratio of consecutive steps in a sequence.
const RATIO_RANGE: (f64, f64) = (0.5, 2.0);

/// A random sequence of steps from t = 0 up to at most `t_end`: sizes between ½ and 2 times
/// `base`, each 0.5–2 times the previous (a random walk in log Δt reflected at ±ln 2, a fixed
/// `seed`); it stops before the step that would pass `t_end`.
pub fn random_steps(base: f64, t_end: f64, seed: u64) -> Vec<f64> {
    let mut state = seed;
    let mut uniform = || {
        // 64-bit LCG (Knuth's MMIX constants), top 53 bits
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let (lo, hi) = (RATIO_RANGE.0.ln(), RATIO_RANGE.1.ln());
    let mut log_size = 0.0f64;
    let mut steps = Vec::new();
    let mut t = 0.0;
    loop {
        let dt = base * log_size.exp();
        if t + dt > t_end * (1.0 + 1e-12) {
            return steps;
        }
        steps.push(dt);
        t += dt;
        // the next size: a step of the walk (a ratio in [½, 2]), reflected at ±ln 2
        let mut next = log_size + lo + (hi - lo) * uniform();
        if next > hi {
            next = 2.0 * hi - next;
        }
        if next < lo {
            next = 2.0 * lo - next;
        }
        log_size = next;
    }
}

/// One row of the variable-step study.
#[derive(Debug, Clone, Copy)]
pub struct VariableRow {
    /// Mean step size.
    pub mean_dt: f64,
    /// Steps taken.
    pub steps: usize,
    /// Smallest and largest ratio of consecutive steps.
    pub ratios: (f64, f64),
    /// Relative L² error of K over the run (0 ≤ t ≤ λ) against the interpolated reference.
    pub error: f64,
}

/// The study: rows coarse to fine and the fitted order of error against mean step.
#[derive(Debug, Clone)]
pub struct VariableConvergence {
    /// Element size.
    pub h: f64,
    /// Reference (fixed) step.
    pub dt_ref: f64,
    /// Rows.
    pub rows: Vec<VariableRow>,
    /// Least-squares slope of log error against log mean Δt.
    pub rate: f64,
}

impl VariableConvergence {
    /// Whether the fitted order reaches [`MIN_VARIABLE_RATE`].
    pub fn passed(&self) -> bool {
        self.rate >= MIN_VARIABLE_RATE
    }

    /// Markdown table with the fitted rate and the verdict.
    pub fn to_markdown(&self) -> String {
        let mut s = format!(
            "Translating cylinder with random variable steps, h = {}, reference Δt = {}\n\n\
             | mean Δt | steps | step ratios | relative L² error of K |\n|---|---|---|---|\n",
            self.h, self.dt_ref
        );
        for r in &self.rows {
            s += &format!(
                "| {:.4} | {} | {:.2}–{:.2} | {:.3e} |\n",
                r.mean_dt, r.steps, r.ratios.0, r.ratios.1, r.error
            );
        }
        s += &format!(
            "\nfitted order: {:.3} (required ≥ {MIN_VARIABLE_RATE}): {}\n",
            self.rate,
            if self.passed() { "PASS" } else { "FAIL" }
        );
        s
    }
}

/// Runs the reference with `dt_ref` (which must divide λ) and, for each mean step in `bases`,
/// a random step sequence ([`random_steps`], one seed per row).
///
/// # Errors
/// As [`translating_cylinder`].
pub fn variable_step_convergence(
    h: f64,
    bases: &[f64],
    dt_ref: f64,
    cut: CutOptions,
    remap: Remap,
    frame: Frame,
    stress: CylinderStress,
) -> Result<VariableConvergence, MovingError> {
    let reference = translating_cylinder(h, dt_ref, cut, remap, frame, stress)?;
    let mut rows = Vec::new();
    for (i, &base) in bases.iter().enumerate() {
        let steps = random_steps(base, LAMBDA, 27 + i as u64);
        let k = translating_cylinder_steps(h, &steps, cut, remap, frame, stress)?;
        let ratios = steps
            .windows(2)
            .map(|w| w[1] / w[0])
            .fold((f64::INFINITY, 0.0f64), |(lo, hi), r| {
                (lo.min(r), hi.max(r))
            });
        rows.push(VariableRow {
            mean_dt: steps.iter().sum::<f64>() / steps.len() as f64,
            steps: steps.len(),
            ratios,
            error: relative_error(&k, &reference, dt_ref),
        });
    }
    let rate = fitted_slope(rows.iter().map(|r| (r.mean_dt.ln(), r.error.ln())));
    Ok(VariableConvergence {
        h,
        dt_ref,
        rows,
        rate,
    })
}

/// Relative L² difference over time (trapezoidal on the non-uniform times of `k`) of `k` from
/// the reference series of uniform step `dt_ref`, interpolated at those times.
fn relative_error(k: &[(f64, f64)], reference: &[(f64, f64)], dt_ref: f64) -> f64 {
    let (mut num, mut den) = (0.0, 0.0);
    for i in 0..k.len() {
        let (t, kh) = k[i];
        let left = if i > 0 { t - k[i - 1].0 } else { 0.0 };
        let right = if i + 1 < k.len() { k[i + 1].0 - t } else { 0.0 };
        let w = 0.5 * (left + right);
        let kr = interpolate(reference, dt_ref, t);
        num += w * (kh - kr).powi(2);
        den += w * kr * kr;
    }
    (num / den).sqrt()
}

/// Cubic Lagrange interpolation of a uniform series (times j·dt) at `t`.
fn interpolate(series: &[(f64, f64)], dt: f64, t: f64) -> f64 {
    let n = series.len();
    let j = ((t / dt).floor() as usize).clamp(1, n.saturating_sub(3));
    let s = t / dt - j as f64;
    let y = |m: usize| series[m].1;
    // nodes at j−1, j, j+1, j+2 (s = −1, 0, 1, 2)
    -s * (s - 1.0) * (s - 2.0) / 6.0 * y(j - 1) + (s + 1.0) * (s - 1.0) * (s - 2.0) / 2.0 * y(j)
        - (s + 1.0) * s * (s - 2.0) / 2.0 * y(j + 1)
        + (s + 1.0) * s * (s - 1.0) / 6.0 * y(j + 2)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn random_steps_end_at_t_end_with_ratios_in_range() {
        for (base, seed) in [(0.04, 27), (0.02, 28), (0.01, 29), (0.005, 30)] {
            let steps = random_steps(base, LAMBDA, seed);
            let total: f64 = steps.iter().sum();
            assert!(
                total <= LAMBDA * (1.0 + 1e-12) && total > LAMBDA - 4.0 * base,
                "{total}"
            );
            for w in steps.windows(2) {
                let r = w[1] / w[0];
                assert!((0.5 - 1e-12..=2.0 + 1e-12).contains(&r), "ratio {r}");
            }
            assert!(steps.iter().all(|&d| d <= 2.0 * base * (1.0 + 1e-12)));
            let distinct = steps
                .windows(2)
                .filter(|w| (w[1] / w[0] - 1.0).abs() > 0.1)
                .count();
            assert!(distinct > steps.len() / 3, "the steps do vary");
        }
    }

    #[test]
    fn cubic_interpolation_is_exact_for_cubics() {
        let f = |t: f64| 1.0 - 2.0 * t + 3.0 * t * t - 0.5 * t * t * t;
        let dt = 0.1;
        let series: Vec<(f64, f64)> = (0..20).map(|j| (j as f64 * dt, f(j as f64 * dt))).collect();
        for t in [0.0, 0.03, 0.55, 1.234, 1.79, 1.9] {
            assert!((interpolate(&series, dt, t) - f(t)).abs() < 1e-12, "{t}");
        }
    }
}
