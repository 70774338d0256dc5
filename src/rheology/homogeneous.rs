//! The log-conformation time scheme of the stress solve reduced to a point: a homogeneous flow with
//! a constant velocity gradient `L`, no convection, `ds/dt = g(L, s)`.
//!
//! First step explicit Euler (thesis Eq. 5.53 without convection),
//! `s¹ = s⁰ + Δt g(L, s⁰)`; then the second-order Gear (BDF2) scheme of Eq. 5.29,
//! ```text
//!   (3/2 s^{n+1} − 2 sⁿ + 1/2 s^{n−1}) / Δt = g(L, ŝ^{n+1}),     ŝ^{n+1} = 2 sⁿ − s^{n−1},
//! ```
//! or, as [`Extrapolation::RightHandSide`], with the extrapolated right-hand side
//! `2 g(L, sⁿ) − g(L, s^{n−1})` of Eq. 5.52 (the thesis uses both; both are second order).
//! A steady state `g(L, s*) = 0` is a fixed point of either scheme exactly, whatever `Δt`.
//!
//! This is the reference for the field solver's tests: a spatially uniform field must follow it.

use super::log_conformation::log_conformation_rhs;
use super::model::Giesekus;
use super::tensor::{Sym2, VelocityGradient};
use super::RheologyError;

/// Where the BDF2 step extrapolates (see the module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Extrapolation {
    /// `g(L, 2sⁿ − s^{n−1})` (Eq. 5.29; the default).
    #[default]
    Argument,
    /// `2 g(L, sⁿ) − g(L, s^{n−1})` (Eq. 5.52).
    RightHandSide,
}

/// Stepper of `ds/dt = g(L, s)` at a point: Euler start, then BDF2.
#[derive(Clone, Copy, Debug)]
pub struct HomogeneousLogConformation {
    model: Giesekus,
    l: VelocityGradient,
    dt: f64,
    extrapolation: Extrapolation,
    steps: usize,
    s: Sym2,
    /// `(s^{n−1}, g(L, s^{n−1}))` once a step has been taken.
    previous: Option<(Sym2, Sym2)>,
}

impl HomogeneousLogConformation {
    /// Stepper from `s⁰` (e.g. `Sym2::ZERO`, the stress-free state) with time step `dt`.
    ///
    /// # Errors
    /// [`RheologyError::TimeStep`] unless `dt > 0` and finite.
    pub fn new(
        model: Giesekus,
        l: VelocityGradient,
        s0: Sym2,
        dt: f64,
    ) -> Result<Self, RheologyError> {
        if !(dt > 0.0 && dt.is_finite()) {
            return Err(RheologyError::TimeStep(dt));
        }
        Ok(HomogeneousLogConformation {
            model,
            l,
            dt,
            extrapolation: Extrapolation::Argument,
            steps: 0,
            s: s0,
            previous: None,
        })
    }

    /// The same stepper with another BDF2 extrapolation.
    pub fn with_extrapolation(mut self, extrapolation: Extrapolation) -> Self {
        self.extrapolation = extrapolation;
        self
    }

    /// Current time `n Δt`.
    pub fn time(&self) -> f64 {
        self.steps as f64 * self.dt
    }

    /// Number of steps taken.
    pub fn steps(&self) -> usize {
        self.steps
    }

    /// Current log-conformation `sⁿ`.
    pub fn log_conformation(&self) -> Sym2 {
        self.s
    }

    /// Current conformation `cⁿ = exp(sⁿ)`.
    pub fn conformation(&self) -> Sym2 {
        self.s.exp()
    }

    /// Current polymer stress `τ(cⁿ)`.
    pub fn stress(&self) -> Sym2 {
        self.model.stress(self.conformation())
    }

    /// Advance one step and return `s^{n+1}`.
    pub fn step(&mut self) -> Sym2 {
        let g_now = log_conformation_rhs(&self.model, self.l, self.s);
        let next = match self.previous {
            None => self.s + self.dt * g_now,
            Some((s_prev, g_prev)) => {
                let g_hat = match self.extrapolation {
                    Extrapolation::Argument => {
                        log_conformation_rhs(&self.model, self.l, 2.0 * self.s - s_prev)
                    }
                    Extrapolation::RightHandSide => 2.0 * g_now - g_prev,
                };
                // 3/2 s^{n+1} = 2 sⁿ − 1/2 s^{n−1} + Δt ĝ.
                (1.0 / 3.0) * (4.0 * self.s - s_prev + (2.0 * self.dt) * g_hat)
            }
        };
        self.previous = Some((self.s, g_now));
        self.s = next;
        self.steps += 1;
        next
    }
}

/// `s(t_n)`, `n = 0..=n_steps`, of `ds/dt = g(L, s)` from `s0` with the scheme of the module docs
/// (Eq. 5.29 extrapolation).
///
/// # Errors
/// [`RheologyError::TimeStep`] unless `dt > 0` and finite.
pub fn integrate_log_conformation(
    model: Giesekus,
    l: VelocityGradient,
    s0: Sym2,
    dt: f64,
    n_steps: usize,
) -> Result<Vec<Sym2>, RheologyError> {
    let mut stepper = HomogeneousLogConformation::new(model, l, s0, dt)?;
    let mut out = Vec::with_capacity(n_steps + 1);
    out.push(s0);
    out.extend((0..n_steps).map(|_| stepper.step()));
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rheology::model::Fluid;
    use crate::rheology::viscometric::{giesekus_steady_shear, oldroyd_b_startup_shear};

    /// Required agreement of the steady state with the analytic viscometric functions.
    const STEADY_REL_TOL: f64 = 1e-4;
    /// Expected order of the scheme and the accepted deviation of the fitted slope (STYLE.md §8).
    const EXPECTED_ORDER: f64 = 2.0;
    const ORDER_TOL: f64 = 0.15;
    /// `n Δt` against the intended end time: one rounding of a product.
    const CLOCK_TOL: f64 = 1e-12;

    /// Start-up of simple shear (γ̇ = 1, so λ = Wi) from rest up to `t_end`; total stresses
    /// scaled by η0γ̇ = 1 (η0 = 1).
    fn shear_run(fluid: &Fluid, dt: f64, t_end: f64, extrapolation: Extrapolation) -> (f64, f64) {
        let l = VelocityGradient::simple_shear(1.0);
        let mut stepper = HomogeneousLogConformation::new(fluid.polymer(), l, Sym2::ZERO, dt)
            .unwrap()
            .with_extrapolation(extrapolation);
        let n = (t_end / dt).round() as usize;
        for _ in 0..n {
            stepper.step();
        }
        let tau = fluid.extra_stress(l, stepper.conformation());
        (tau.xy, tau.xx - tau.yy)
    }

    #[test]
    fn rejects_bad_time_steps() {
        let m = Giesekus::oldroyd_b(1.0, 1.0).unwrap();
        for dt in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            assert!(matches!(
                HomogeneousLogConformation::new(m, VelocityGradient::default(), Sym2::ZERO, dt),
                Err(RheologyError::TimeStep(_))
            ));
        }
        let traj =
            integrate_log_conformation(m, VelocityGradient::simple_shear(1.0), Sym2::ZERO, 0.1, 5)
                .unwrap();
        assert_eq!(traj.len(), 6);
        assert_eq!(traj[0], Sym2::ZERO);
    }

    #[test]
    fn steady_simple_shear_matches_analytic_viscometric_functions() {
        let mut worst: f64 = 0.0;
        for alpha in [0.0, 0.01, 0.2] {
            for beta in [0.0, 0.1] {
                for wi in [0.5, 1.0, 2.0, 3.0] {
                    let fluid = Fluid::from_ratio(1.0, beta, wi, alpha).unwrap();
                    // Many relaxation times: the approach to steady state decays like e^{−t/λ}
                    // (slower for the weakly damped small-α oscillation at Wi = 3).
                    let (tau_xy, n1) =
                        shear_run(&fluid, 0.02 * wi, 60.0 * wi, Extrapolation::Argument);
                    let exact = giesekus_steady_shear(wi, alpha, beta);
                    let e_tau = (tau_xy - exact.shear_stress).abs() / exact.shear_stress;
                    let e_n1 = (n1 - exact.n1).abs() / exact.n1;
                    worst = worst.max(e_tau).max(e_n1);
                    assert!(
                        e_tau < STEADY_REL_TOL,
                        "α {alpha} β {beta} Wi {wi}: τ_xy {tau_xy} vs {exact:?}"
                    );
                    assert!(
                        e_n1 < STEADY_REL_TOL,
                        "α {alpha} β {beta} Wi {wi}: N1 {n1} vs {exact:?}"
                    );
                }
            }
        }
        eprintln!("0-D steady shear vs analytic: worst relative error {worst:.2e}");
    }

    /// Least-squares slope of log(err) against log(dt).
    fn fitted_order(dts: &[f64], errs: &[f64]) -> f64 {
        let xs: Vec<f64> = dts.iter().map(|d| d.ln()).collect();
        let ys: Vec<f64> = errs.iter().map(|e| e.ln()).collect();
        let n = xs.len() as f64;
        let (mx, my) = (xs.iter().sum::<f64>() / n, ys.iter().sum::<f64>() / n);
        let sxy: f64 = xs.iter().zip(&ys).map(|(x, y)| (x - mx) * (y - my)).sum();
        let sxx: f64 = xs.iter().map(|x| (x - mx) * (x - mx)).sum();
        sxy / sxx
    }

    #[test]
    fn oldroyd_b_startup_converges_at_second_order() {
        // UCM, λ = 1, γ̇ = 1.5 (Wi = 1.5), compared at t = 2λ with the closed form.
        let (lambda, rate, t_end) = (1.0, 1.5, 2.0);
        let fluid = Fluid::ucm(1.0, lambda).unwrap();
        let l = VelocityGradient::simple_shear(rate);
        let exact = oldroyd_b_startup_shear(1.0, lambda, rate, t_end);
        let dts = [0.01, 0.005, 0.0025, 0.00125];
        for extrapolation in [Extrapolation::Argument, Extrapolation::RightHandSide] {
            let (mut e_tau, mut e_n1) = (Vec::new(), Vec::new());
            for &dt in &dts {
                let mut st = HomogeneousLogConformation::new(fluid.polymer(), l, Sym2::ZERO, dt)
                    .unwrap()
                    .with_extrapolation(extrapolation);
                while st.steps() < (t_end / dt).round() as usize {
                    st.step();
                }
                assert!((st.time() - t_end).abs() < CLOCK_TOL);
                let tau = st.stress();
                e_tau.push((tau.xy - exact.tau_xy).abs());
                e_n1.push((tau.xx - tau.yy - exact.n1).abs());
            }
            let (p_tau, p_n1) = (fitted_order(&dts, &e_tau), fitted_order(&dts, &e_n1));
            let show = |v: &[f64]| {
                v.iter()
                    .map(|e| format!("{e:.3e}"))
                    .collect::<Vec<_>>()
                    .join(" ")
            };
            eprintln!(
                "{extrapolation:?}: τ_xy errors {} order {p_tau:.3}; N1 errors {} order {p_n1:.3}",
                show(&e_tau),
                show(&e_n1)
            );
            assert!(
                (p_tau - EXPECTED_ORDER).abs() < ORDER_TOL,
                "τ_xy order {p_tau}"
            );
            assert!((p_n1 - EXPECTED_ORDER).abs() < ORDER_TOL, "N1 order {p_n1}");
        }
    }
}
