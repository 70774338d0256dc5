//! The linear solve of a transport step: GMRES with the ILU(0) of the step's matrix for the
//! three components, LU where that fails (module docs of
//! [`constitutive`](crate::solver::constitutive)).

use std::time::Instant;

use super::{ConstitutiveError, LogConformationHistory, LogConformationTransport};
use crate::fem::krylov::gmres;
use crate::fem::linsolve::{DirectSolver, SolverKind};

/// Relative residual ‖b − A s‖/‖b‖ of the iterative transport solve: a few hundred times the
/// round-off of the LU it replaces, far below the time discretization's error (the §5.6.3 pair
/// at l_y = 0.06 keeps every recorded digit; docs/validation.md).
pub const ITERATIVE_TOL: f64 = 1e-12;

/// GMRES iterations (one restart cycle) per component before the step falls back to LU. With the
/// incomplete factor the §5.7 bench case takes 6 per component on average at 200×50 and 6–29 at
/// 440×110, where s_yy stalls near 2e-12 in some steps: those steps fall back
/// (docs/performance.md).
pub const MAX_ITERATIONS: usize = 40;

/// How the transport steps of a run were solved.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct TransportStats {
    /// Steps solved by GMRES with ILU(0).
    pub iterative_steps: usize,
    /// GMRES iterations over those steps (three components each).
    pub krylov_iterations: usize,
    /// Steps solved by LU (the incomplete factor failed or GMRES missed [`ITERATIVE_TOL`]).
    pub lu_steps: usize,
}

impl LogConformationTransport {
    /// Solves the three components (right-hand sides in `rhs`, solutions left there) by GMRES
    /// with the ILU(0) of the matrix, each started from the history's extrapolation to t^{n+1}
    /// (ŝ of BDF2; sⁿ on the first step): seconds of the factor and of the solves, or `None`
    /// (and `rhs` untouched) when the factor fails or a component misses [`ITERATIVE_TOL`]
    /// within [`MAX_ITERATIONS`] — or in the comparison mode [`direct`](Self::direct).
    pub(super) fn solve_iteratively(
        &mut self,
        history: &LogConformationHistory,
        dt: f64,
    ) -> Option<(f64, f64)> {
        if self.direct {
            return None;
        }
        let t0 = Instant::now();
        if self.ilu.factor(&self.matrix).is_err() {
            return None;
        }
        let t1 = Instant::now();
        let (matrix, ilu) = (&self.matrix, &self.ilu);
        let apply_a = |v: &[f64], out: &mut [f64]| matrix.matvec(v, out);
        let mut precondition = |v: &mut [f64]| -> Result<(), std::convert::Infallible> {
            ilu.apply(v);
            Ok(())
        };
        let mut iterations = 0;
        let (w1, w0) = history.bdf2(dt).extrapolation();
        let start = |v: usize| match history.previous.as_deref() {
            Some(prev) => w1 * history.current[v] + w0 * prev[v],
            None => history.current[v],
        };
        for (c, (x, b)) in self.solution.iter_mut().zip(&self.rhs).enumerate() {
            for (v, xv) in x.iter_mut().enumerate() {
                let s = start(v);
                *xv = [s.xx, s.xy, s.yy][c];
            }
            let Ok(out) = gmres(
                &apply_a,
                &mut precondition,
                b,
                x,
                ITERATIVE_TOL,
                MAX_ITERATIONS,
                MAX_ITERATIONS,
            );
            iterations += out.iterations;
            // (a NaN residual fails too)
            if out.residual.is_nan() || out.residual > ITERATIVE_TOL {
                return None;
            }
        }
        std::mem::swap(&mut self.rhs, &mut self.solution);
        self.stats.iterative_steps += 1;
        self.stats.krylov_iterations += iterations;
        Some(((t1 - t0).as_secs_f64(), t1.elapsed().as_secs_f64()))
    }

    /// Solves the three components by LU (solutions left in `rhs`): seconds of the symbolic
    /// analysis (first LU only), the numeric factorization and the solves.
    pub(super) fn solve_directly(
        &mut self,
        step: usize,
    ) -> Result<(f64, f64, f64), ConstitutiveError> {
        let wrap = |source| ConstitutiveError::Solve {
            what: "log-conformation",
            step,
            source,
        };
        let t0 = Instant::now();
        if self.solver.is_none() {
            self.solver = Some(DirectSolver::analyze(&self.matrix, SolverKind::Lu).map_err(wrap)?);
        }
        let t1 = Instant::now();
        let solver = self.solver.as_mut().expect("analysed above");
        solver.factor(&self.matrix).map_err(wrap)?;
        let t2 = Instant::now();
        for r in &mut self.rhs {
            solver.solve_in_place(r).map_err(wrap)?;
        }
        self.stats.lu_steps += 1;
        Ok((
            (t1 - t0).as_secs_f64(),
            (t2 - t1).as_secs_f64(),
            t2.elapsed().as_secs_f64(),
        ))
    }
}
