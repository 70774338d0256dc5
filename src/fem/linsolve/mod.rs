//! Sparse direct solvers with the symbolic analysis done once per pattern and reused for every
//! numeric factorization (faer, single-threaded: on 2 cores we parallelize across cases instead).
//!
//! Two kinds:
//! - [`SolverKind::Lblt`]: symmetric indefinite LBLᵀ (supernodal, Bunch–Kaufman pivoting inside
//!   supernodes) for symmetric systems — the Stokes/DEVSS-G saddle-point matrix assembled
//!   symmetrically. About 10× less memory and time than LU on our patterns (see docs/performance.md).
//! - [`SolverKind::Lu`]: non-symmetric systems. With an elimination order given
//!   ([`DirectSolver::analyze_blocked`], [`DirectSolver::analyze_with_order`]: a symmetric pattern,
//!   the flow's) GMRES preconditioned by the LBLᵀ of the symmetric part (`symmetric_part`), with
//!   faer's LU as the fallback; without one (SUPG transport) faer's general sparse LU with partial
//!   pivoting.

use std::time::Instant;

use dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::cholesky::lblt::factor::LbltParams;
use faer::perm::PermRef;
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, CholeskySymbolicParams, SymbolicCholesky, SymmetricOrdering,
};
use faer::sparse::linalg::lu::{
    factorize_symbolic_lu, LuRef, LuSymbolicParams, NumericLu, SymbolicLu,
};
use faer::sparse::linalg::{SupernodalThreshold, SymbolicSupernodalParams};
use faer::sparse::SymbolicSparseColMatRef;
use faer::{Conj, MatMut, Par, Side, Spec};

use super::krylov::gmres;
use super::sparse::SparseMatrix;

mod order;
mod probe;
mod schur;
mod symmetric_part;
mod trisolve;
mod unpivoted;

use order::block_amd_ordering;
pub use order::DofBlocks;
use probe::Probe;
pub use probe::{ProbeVerdict, PROBE_MAX_UNKNOWNS};
use symmetric_part::SymmetricPart;
pub use unpivoted::{checked_solve_repivoting, Pivoting, Repivot};

/// Which factorization to use.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SolverKind {
    /// Symmetric indefinite LBLᵀ (the matrix must be symmetric; the lower triangle is read).
    Lblt,
    /// General LU with partial pivoting.
    Lu,
}

/// Errors of the direct solvers.
#[derive(Debug, thiserror::Error)]
pub enum SolveError {
    /// The symbolic analysis failed (out of memory or index overflow).
    #[error("symbolic factorization failed: {0}")]
    Symbolic(String),
    /// The numeric factorization failed (singular matrix).
    #[error("numeric factorization failed: {0}")]
    Numeric(String),
    /// The solution is not finite or the residual is too large.
    #[error("linear solve inaccurate: relative residual {residual:.3e}")]
    Inaccurate {
        /// ‖b − A x‖ / ‖b‖.
        residual: f64,
    },
    /// `solve` was called before `factor`.
    #[error("solve called before a numeric factorization")]
    NotFactored,
}

impl SolveError {
    /// Whether the system itself was not finite: a NaN residual (b − Ax with a finite A, b and a
    /// finite or zeroed x is finite), as a caller's blown-up state gives.
    pub fn non_finite(&self) -> bool {
        matches!(self, SolveError::Inaccurate { residual } if residual.is_nan())
    }
}

enum Backend {
    Lblt {
        symbolic: SymbolicCholesky<usize>,
        l_values: Vec<f64>,
        subdiag: Vec<f64>,
        perm_fwd: Vec<usize>,
        perm_inv: Vec<usize>,
    },
    Lu {
        symbolic: SymbolicLu<usize>,
        numeric: NumericLu<usize, f64>,
    },
    /// GMRES preconditioned by the LBLᵀ of the symmetric part (see [`SymmetricPart`]).
    SymmetricPart(Box<SymmetricPart>),
}

/// faer's default supernode relaxation: two adjacent supernodes of n columns in all are merged
/// when the fraction z of explicit zeros this adds stays below the bound for n.
const DEFAULT_RELAX: [(usize, f64); 4] = [(4, 1.0), (16, 0.8), (48, 0.1), (usize::MAX, 0.05)];

/// Supernode relaxation with a given elimination order: the default without its last rule
/// (supernodes of any size merged below 5 % zeros), so that the dofs a caller put last stay a
/// supernode of their own instead of absorbing the separator before them — which
/// [`DirectSolver::schur_complement`] would otherwise reconstruct and condense (measured on the
/// flow's band split, 200×50: 1170 interface dofs, 433 absorbed, condensation 0.6 s). Costs
/// nothing measurable in the factorization.
const GIVEN_ORDER_RELAX: [(usize, f64); 3] = [(4, 1.0), (16, 0.8), (48, 0.1)];

/// A direct solver bound to one sparsity pattern.
pub struct DirectSolver {
    backend: Backend,
    buffer: MemBuffer,
    factored: bool,
    n: usize,
    /// Symmetric equilibration D of the last factored matrix (the factor is of D A D).
    scale: Vec<f64>,
    scaled: Option<SparseMatrix>,
    last_polish: usize,
    lu_fallbacks: usize,
    /// The symmetric-part path's choice against a whole LU, by measurement.
    probe: Probe,
    /// Seconds of the last numeric factorization.
    factor_time: f64,
    /// LBLᵀ: the dof at each position of the elimination order of the last factorization (the
    /// pivoting changes it), and a work vector by position.
    at: Vec<usize>,
    work: Vec<f64>,
    /// LBLᵀ: whether to try the factorization without pivots first, and whether the last one
    /// was made without.
    pivoting: Pivoting,
    unpivoted: bool,
    pivoted_refactors: usize,
}

impl std::fmt::Debug for DirectSolver {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("DirectSolver")
            .field("kind", &self.kind())
            .field("n", &self.n)
            .field("factored", &self.factored)
            .finish()
    }
}

impl DirectSolver {
    /// Symbolic analysis of the pattern of `a` (fill-reducing ordering, elimination tree,
    /// supernodes). Done once; every later [`factor`](Self::factor) reuses it.
    pub fn analyze(a: &SparseMatrix, kind: SolverKind) -> Result<Self, SolveError> {
        Self::analyze_ordered(a, kind, None)
    }

    /// Like [`analyze`](Self::analyze), but for [`SolverKind::Lblt`] with a *node-block*
    /// fill-reducing ordering: dofs are grouped into blocks (`blocks.block[d]`, e.g. all unknowns
    /// living at one mesh node), AMD orders the block graph, and within a block the dofs follow
    /// `blocks.class[d]` (ascending). Putting the pressure last in its node block means the
    /// velocity it couples to is eliminated first, so the saddle-point system does not meet a
    /// structurally zero pivot — the LBLᵀ only pivots inside supernodes and fails otherwise.
    pub fn analyze_blocked(
        a: &SparseMatrix,
        kind: SolverKind,
        blocks: &DofBlocks,
    ) -> Result<Self, SolveError> {
        let (fwd, inv) = block_amd_ordering(a, blocks)?;
        Self::analyze_ordered(a, kind, Some((&fwd, &inv)))
    }

    /// Like [`analyze`](Self::analyze), with the elimination order given: `order[k]` is the dof
    /// eliminated k-th (a permutation of 0..n). [`schur_complement`](Self::schur_complement)
    /// needs the dofs it condenses onto at the end of it.
    pub fn analyze_with_order(
        a: &SparseMatrix,
        kind: SolverKind,
        order: &[usize],
    ) -> Result<Self, SolveError> {
        let mut inv = vec![0usize; order.len()];
        for (new, &old) in order.iter().enumerate() {
            inv[old] = new;
        }
        Self::analyze_ordered(a, kind, Some((order, &inv)))
    }

    fn analyze_ordered(
        a: &SparseMatrix,
        kind: SolverKind,
        order: Option<(&[usize], &[usize])>,
    ) -> Result<Self, SolveError> {
        let par = Par::Seq;
        let n = a.n();
        let (backend, req) = match kind {
            SolverKind::Lblt => {
                let params = CholeskySymbolicParams {
                    // always supernodal: the simplicial variant does not pivot
                    supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SUPERNODAL,
                    supernodal_params: SymbolicSupernodalParams {
                        relax: Some(if order.is_some() {
                            &GIVEN_ORDER_RELAX
                        } else {
                            &DEFAULT_RELAX
                        }),
                    },
                    ..Default::default()
                };
                let ordering = match order {
                    // the identity given as such: faer then factors the matrix as it is stored,
                    // where a permutation would copy it into the order at every factorization
                    // (a fifth of the band matrix M's factorization, 200×50)
                    Some((fwd, _)) if fwd.iter().enumerate().all(|(k, &d)| k == d) => {
                        SymmetricOrdering::Identity
                    }
                    Some((fwd, inv)) => {
                        SymmetricOrdering::Custom(PermRef::new_checked(fwd, inv, n))
                    }
                    None => SymmetricOrdering::Amd,
                };
                // without a permutation faer reads the upper triangle as it is stored: give it
                // the lower one's transpose (a matrix may store its lower triangle only)
                let upper;
                let (pattern, side) = match &ordering {
                    SymmetricOrdering::Identity => {
                        upper = a.upper_from_lower();
                        (
                            SymbolicSparseColMatRef::new_checked(n, n, &upper.0, None, &upper.1),
                            Side::Upper,
                        )
                    }
                    _ => (a.symbolic(), Side::Lower),
                };
                let symbolic = factorize_symbolic_cholesky(pattern, side, ordering, params)
                    .map_err(|e| SolveError::Symbolic(format!("{e:?}")))?;
                let req = StackReq::any_of(&[
                    symbolic.factorize_numeric_intranode_lblt_scratch::<f64>(
                        par,
                        Spec::<LbltParams, f64>::default(),
                    ),
                    symbolic.factorize_numeric_ldlt_scratch::<f64>(par, Default::default()),
                    symbolic.solve_in_place_scratch::<f64>(1, par),
                ]);
                let len = symbolic.len_val();
                (
                    Backend::Lblt {
                        symbolic,
                        l_values: vec![0.0; len],
                        subdiag: vec![0.0; n],
                        perm_fwd: vec![0; n],
                        perm_inv: vec![0; n],
                    },
                    req,
                )
            }
            SolverKind::Lu => match order {
                // the caller's order is the LBLᵀ's: a matrix whose pattern is symmetric
                Some((fwd, _)) => (
                    Backend::SymmetricPart(Box::new(SymmetricPart::analyze(a, fwd)?)),
                    StackReq::EMPTY,
                ),
                None => lu_backend(a)?,
            },
        };
        Ok(Self {
            backend,
            buffer: MemBuffer::new(req),
            factored: false,
            n,
            scale: Vec::new(),
            scaled: None,
            last_polish: 0,
            lu_fallbacks: 0,
            probe: Probe::initial(n),
            factor_time: 0.0,
            at: Vec::new(),
            work: Vec::new(),
            pivoting: Pivoting::Always,
            unpivoted: false,
            pivoted_refactors: 0,
        })
    }

    /// LBLᵀ: the dof at each position of the elimination order of the last factorization
    /// (empty before one).
    pub fn positions(&self) -> &[usize] {
        &self.at
    }

    /// The factorization kind.
    pub fn kind(&self) -> SolverKind {
        match self.backend {
            Backend::Lblt { .. } => SolverKind::Lblt,
            Backend::Lu { .. } | Backend::SymmetricPart(_) => SolverKind::Lu,
        }
    }

    /// Numeric factorization of `a` (same pattern as at [`analyze`](Self::analyze)), reusing the
    /// symbolic analysis and the factor storage.
    pub fn factor(&mut self, a: &SparseMatrix) -> Result<(), SolveError> {
        self.factor_scaled(a, true, self.pivoting)
    }

    /// Like [`factor`](Self::factor) for a matrix equilibrated already (the symmetric part of an
    /// equilibrated matrix): no second equilibration and copy.
    pub(super) fn factor_equilibrated(&mut self, a: &SparseMatrix) -> Result<(), SolveError> {
        self.factor_scaled(a, false, self.pivoting)
    }

    fn factor_scaled(
        &mut self,
        a: &SparseMatrix,
        equilibrate: bool,
        pivoting: Pivoting,
    ) -> Result<(), SolveError> {
        assert_eq!(
            a.n(),
            self.n,
            "matrix size differs from the analysed pattern"
        );
        let original = a;
        if let Probe::Pending { symmetric_cost } = self.probe {
            // time one whole LU against the symmetric part's last factorization and solve
            let (backend, req) = lu_backend(a)?;
            let Backend::SymmetricPart(parked) = std::mem::replace(&mut self.backend, backend)
            else {
                unreachable!("a probe is pending on the symmetric-part path only")
            };
            self.buffer = MemBuffer::new(req);
            self.probe = Probe::Probing {
                symmetric_cost,
                parked,
            };
        }
        // (the LU's symbolic analysis above is paid once: not part of the comparison)
        let start = Instant::now();
        self.unpivoted = false;
        if pivoting == Pivoting::WhenNeeded && self.factor_unpivoted(a) {
            self.finish_factorization(start);
            return Ok(());
        }
        let a: &SparseMatrix = if equilibrate {
            // cut elements with tiny fluid parts spread the entries over many orders of
            // magnitude, which the supernode-local pivoting of LBLᵀ handles poorly
            a.equilibration(&mut self.scale);
            let scaled = self.scaled.get_or_insert_with(|| a.clone());
            a.scaled_into(&self.scale, scaled);
            scaled
        } else {
            self.scale.clear();
            self.scale.resize(self.n, 1.0);
            a
        };
        let stack = MemStack::new(&mut self.buffer);
        match &mut self.backend {
            Backend::Lblt {
                symbolic,
                l_values,
                subdiag,
                perm_fwd,
                perm_inv,
            } => {
                symbolic.factorize_numeric_intranode_lblt(
                    l_values,
                    subdiag,
                    perm_fwd,
                    perm_inv,
                    a.as_faer(),
                    Side::Lower,
                    Par::Seq,
                    stack,
                    Default::default(),
                );
                if l_values.iter().any(|v| !v.is_finite()) {
                    self.factored = false;
                    return Err(SolveError::Numeric(
                        "non-finite LBLᵀ factor (singular matrix?)".into(),
                    ));
                }
            }
            Backend::Lu { symbolic, numeric } => {
                symbolic
                    .factorize_numeric_lu(numeric, a.as_faer(), Par::Seq, stack, Default::default())
                    .map_err(|e| SolveError::Numeric(format!("{e:?}")))?;
            }
            Backend::SymmetricPart(sp) => {
                if sp.factor(a).is_err() {
                    // a symmetric part the LBLᵀ cannot factor: factor A itself
                    return self.fall_back_to_lu(original);
                }
            }
        }
        self.finish_factorization(start);
        Ok(())
    }

    /// Marks the solver factored at `start`'s cost; LBLᵀ: the positions of the new factor.
    pub(super) fn finish_factorization(&mut self, start: Instant) {
        self.factored = true;
        self.factor_time = start.elapsed().as_secs_f64();
        if matches!(self.backend, Backend::Lblt { .. }) {
            self.at = self.dof_at_positions();
            self.work.resize(self.n, 0.0);
        }
    }

    /// Solves A x = b in place (`rhs` holds b on entry and x on exit).
    pub fn solve_in_place(&mut self, rhs: &mut [f64]) -> Result<(), SolveError> {
        if !self.factored {
            return Err(SolveError::NotFactored);
        }
        if let Backend::Lblt { .. } = self.backend {
            // by parts, with plain loops: faer's supernodal solve pays a dispatch per supernode
            // (thousands of small ones in a nested-dissection order)
            let mut v = std::mem::take(&mut self.work);
            self.to_positions(rhs, &self.at, &mut v);
            self.forward(&mut v, 0)?;
            self.diagonal(&mut v, 0)?;
            self.backward(&mut v, 0)?;
            self.from_positions(&v, &self.at, rhs);
            self.work = v;
            return Ok(());
        }
        let n = self.n;
        rhs.iter_mut().zip(&self.scale).for_each(|(b, d)| *b *= d);
        match &mut self.backend {
            Backend::Lu { symbolic, numeric } => {
                let x = MatMut::from_column_major_slice_mut(&mut *rhs, n, 1);
                LuRef::new_unchecked(symbolic, numeric).solve_in_place_with_conj(
                    Conj::No,
                    x,
                    Par::Seq,
                    MemStack::new(&mut self.buffer),
                );
            }
            Backend::SymmetricPart(sp) => sp.solve_in_place(rhs)?,
            Backend::Lblt { .. } => unreachable!("solved above"),
        }
        rhs.iter_mut().zip(&self.scale).for_each(|(x, d)| *x *= d);
        Ok(())
    }

    /// Solves and checks the relative residual against `tol`. When the direct solution misses it
    /// (cut elements with tiny fluid parts make the system ill-conditioned, and the LBLᵀ pivots
    /// only inside supernodes), GMRES preconditioned by the same factorization polishes it, at
    /// most [`MAX_POLISH_ITERATIONS`] iterations. A factor made without pivots that misses it
    /// is first replaced by the pivoted one ([`pivoted_refactors`](Self::pivoted_refactors)).
    pub fn solve_checked(
        &mut self,
        a: &SparseMatrix,
        b: &[f64],
        x: &mut [f64],
        tol: f64,
    ) -> Result<f64, SolveError> {
        let start = Instant::now();
        let solved = checked_solve_repivoting(self, a, b, x, tol);
        let (res, polish) = match solved {
            Err(SolveError::Inaccurate { .. })
                if matches!(self.backend, Backend::SymmetricPart(_)) =>
            {
                // a symmetric part factored without pivots: with pivots first
                let mut repivoted = None;
                if let Backend::SymmetricPart(sp) = &mut self.backend {
                    if sp.is_unpivoted() {
                        sp.repivot()?;
                        self.pivoted_refactors += 1;
                        repivoted =
                            Some(checked_solve(a, b, x, tol, &mut |v| self.solve_in_place(v)));
                    }
                }
                match repivoted {
                    Some(Ok(solved)) => solved,
                    Some(Err(e)) if !matches!(e, SolveError::Inaccurate { .. }) => return Err(e),
                    _ => {
                        // the symmetric part no longer preconditions A well enough: factor A
                        // itself
                        self.probe = Probe::Decided;
                        self.fall_back_to_lu(a)?;
                        checked_solve(a, b, x, tol, &mut |v| self.solve_in_place(v))?
                    }
                }
            }
            other => other?,
        };
        self.last_polish = polish;
        let cost = self.factor_time + start.elapsed().as_secs_f64();
        self.record_probe(polish, cost);
        Ok(res)
    }

    /// Replaces the symmetric-part preconditioner by faer's LU of `a` (for good: a pattern whose
    /// symmetric part failed once is factored whole from then on) and factors `a`.
    fn fall_back_to_lu(&mut self, a: &SparseMatrix) -> Result<(), SolveError> {
        let (backend, req) = lu_backend(a)?;
        self.backend = backend;
        self.buffer = MemBuffer::new(req);
        self.lu_fallbacks += 1;
        self.factor(a)
    }

    /// How often the symmetric-part preconditioner gave way to a whole LU (0 or 1): it could not
    /// be factored, GMRES missed the tolerance, or a timed LU was cheaper.
    pub fn lu_fallbacks(&self) -> usize {
        self.lu_fallbacks
    }

    /// GMRES iterations of the last [`solve_checked`](Self::solve_checked) (0 when the direct
    /// solve was accurate).
    pub fn last_polish_iterations(&self) -> usize {
        self.last_polish
    }
}

/// faer's sparse LU (COLAMD column order, partial pivoting) for the pattern of `a`.
fn lu_backend(a: &SparseMatrix) -> Result<(Backend, StackReq), SolveError> {
    let symbolic = factorize_symbolic_lu(a.symbolic(), LuSymbolicParams::default())
        .map_err(|e| SolveError::Symbolic(format!("{e:?}")))?;
    let req = StackReq::any_of(&[
        symbolic.factorize_numeric_lu_scratch::<f64>(Par::Seq, Default::default()),
        symbolic.solve_in_place_scratch::<f64>(1, Par::Seq),
    ]);
    Ok((
        Backend::Lu {
            symbolic,
            numeric: NumericLu::new(),
        },
        req,
    ))
}

/// Solves A x = b with an (approximate) inverse `solve` of A, which replaces its argument b by
/// x, and checks the relative residual against `tol`; when it misses it, GMRES preconditioned
/// by `solve` polishes x, at most [`MAX_POLISH_ITERATIONS`] iterations. Returns the residual
/// and the GMRES iterations.
pub fn checked_solve(
    a: &SparseMatrix,
    b: &[f64],
    x: &mut [f64],
    tol: f64,
    solve: &mut dyn FnMut(&mut [f64]) -> Result<(), SolveError>,
) -> Result<(f64, usize), SolveError> {
    if let Some(res) = direct_solve(a, b, x, tol, solve)? {
        return Ok((res, 0));
    }
    if !x.iter().all(|v| v.is_finite()) {
        x.iter_mut().for_each(|v| *v = 0.0);
    }
    let apply_a = |v: &[f64], out: &mut [f64]| a.matvec(v, out);
    let out = gmres(
        &apply_a,
        solve,
        b,
        x,
        tol,
        MAX_POLISH_ITERATIONS,
        MAX_POLISH_ITERATIONS,
    )?;
    let res = relative_residual(a, x, b);
    if res.is_finite() && res <= 10.0 * tol {
        Ok((res, out.iterations))
    } else {
        Err(SolveError::Inaccurate { residual: res })
    }
}

/// Most GMRES iterations polishing a direct solve in [`DirectSolver::solve_checked`]; a good
/// factorization as preconditioner needs a handful.
pub const MAX_POLISH_ITERATIONS: usize = 30;

/// Solves A x = b with `solve` alone (which replaces its argument b by x); the relative
/// residual if it meets `tol`, `None` if it does not (or is not finite).
fn direct_solve(
    a: &SparseMatrix,
    b: &[f64],
    x: &mut [f64],
    tol: f64,
    solve: &mut dyn FnMut(&mut [f64]) -> Result<(), SolveError>,
) -> Result<Option<f64>, SolveError> {
    x.copy_from_slice(b);
    solve(x)?;
    let res = relative_residual(a, x, b);
    Ok((res <= tol).then_some(res))
}

/// ‖b − A x‖/‖b‖ (or ‖b − A x‖ if b = 0); NaN or infinite for a non-finite x.
pub fn relative_residual(a: &SparseMatrix, x: &[f64], b: &[f64]) -> f64 {
    let mut ax = vec![0.0; b.len()];
    a.matvec(x, &mut ax);
    let (mut rr, mut bb) = (0.0, 0.0);
    for (bi, axi) in b.iter().zip(&ax) {
        rr += (bi - axi) * (bi - axi);
        bb += bi * bi;
    }
    if bb > 0.0 {
        (rr / bb).sqrt()
    } else {
        rr.sqrt()
    }
}

#[cfg(test)]
mod tests;
