//! The symmetric indefinite factorization without pivoting (LDLᵀ, D diagonal), tried before the
//! pivoted LBLᵀ where a caller allows it ([`Pivoting::WhenNeeded`]).
//!
//! faer's intranode LBLᵀ searches each supernode's columns for Bunch–Kaufman pivots, scalar work
//! that dominates a large dense supernode: a dense 1140 × 1140 block factors in 0.020 s by LBLᵀ
//! and 0.0056 s by Cholesky on the development machine, and the flow's band matrix M
//! ([`Substructured`](crate::fem::substructure::Substructured)), whose last supernode is the
//! dense interface block, factors in 0.065 s by LBLᵀ and 0.042 s by LDLᵀ (200×50, three
//! particles). An LDLᵀ exists for the flow's saddle-point matrices in the node-block order (each
//! pressure after the velocities of its node, so that its pivot is −B A⁻¹ Bᵀ of what was
//! eliminated), but nothing bounds its growth: a cut element with a sliver of fluid can make a
//! pivot tiny. Hence three guards: a zero or non-finite pivot falls back to LBLᵀ at once; a
//! checked solve whose residual misses its tolerance refactors with pivoting before any
//! iterative polishing ([`DirectSolver::solve_checked`], and the band solver's for M); and a
//! factor used for many solves is checked once by a test solve
//! ([`DirectSolver::check_unpivoted`], the band solver's K at each placement).
//!
//! The factor shares the LBLᵀ's storage and solve: the same supernodal layout of L with D on its
//! diagonal, no 2×2 pivots (zero subdiagonal) and the identity as intranode permutation.

use dyn_stack::MemStack;
use faer::sparse::linalg::cholesky::{SymbolicCholesky, SymbolicCholeskyRaw};
use faer::{Par, Side};

use super::{checked_solve, direct_solve, relative_residual, Backend, DirectSolver, SolveError};
use crate::fem::sparse::SparseMatrix;

/// How a [`SolverKind::Lblt`](super::SolverKind::Lblt) solver pivots.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum Pivoting {
    /// Bunch–Kaufman pivots inside each supernode (faer's intranode LBLᵀ), every factorization.
    #[default]
    Always,
    /// LDLᵀ without pivots first; LBLᵀ when a pivot is zero or not finite, when a checked solve
    /// misses its residual tolerance ([`DirectSolver::solve_checked`]) and when a caller asks
    /// for it ([`DirectSolver::factor_pivoted`], [`DirectSolver::check_unpivoted`]).
    WhenNeeded,
}

/// Factors `a` as it is (a symmetric scaling changes nothing without pivots) by LDLᵀ into the
/// LBLᵀ storage: L with D on its diagonal, `subdiag` zero, the intranode permutation the identity. Returns whether it succeeded (every
/// value finite); on failure the storage holds garbage and must be refactored.
fn factor_ldlt(
    symbolic: &SymbolicCholesky<usize>,
    l_values: &mut [f64],
    subdiag: &mut [f64],
    perm_fwd: &mut [usize],
    perm_inv: &mut [usize],
    a: &SparseMatrix,
    stack: &mut MemStack,
) -> bool {
    let factored = symbolic.factorize_numeric_ldlt(
        l_values,
        a.as_faer(),
        Side::Lower,
        Default::default(),
        Par::Seq,
        stack,
        Default::default(),
    );
    if factored.is_err() || !pivots_usable(symbolic, l_values) {
        return false;
    }
    subdiag.iter_mut().for_each(|s| *s = 0.0);
    for (i, (f, v)) in perm_fwd.iter_mut().zip(perm_inv.iter_mut()).enumerate() {
        *f = i;
        *v = i;
    }
    true
}

/// Whether every pivot of the factor in `l_values` is finite and not zero. The pivots suffice:
/// d_i = a_ii − Σ_j l_ij² d_j takes every entry of row i of L, so a non-finite entry anywhere in
/// L makes the pivot of its row non-finite (and a zero pivot makes the entries below it so).
fn pivots_usable(symbolic: &SymbolicCholesky<usize>, l_values: &[f64]) -> bool {
    let SymbolicCholeskyRaw::Supernodal(sn) = symbolic.raw() else {
        return l_values.iter().all(|v| v.is_finite());
    };
    (0..sn.n_supernodes()).all(|s| {
        let size = sn.supernode_end()[s] - sn.supernode_begin()[s];
        let rows = size + sn.col_ptr_for_row_idx()[s + 1] - sn.col_ptr_for_row_idx()[s];
        let first = sn.col_ptr_for_val()[s];
        (0..size).all(|c| {
            let d = l_values[first + c * rows + c];
            d.is_finite() && d != 0.0
        })
    })
}

/// A factored system whose factors may have been made without pivots: what
/// [`checked_solve_repivoting`] needs of it (a [`DirectSolver`], or the band solver whose M is).
pub trait Repivot {
    /// Solves in place with the current factors (`v` holds b on entry and x on exit).
    fn solve_factored(&mut self, v: &mut [f64]) -> Result<(), SolveError>;
    /// Whether a factor the solve uses was made without pivots and not yet checked by a solve.
    fn unpivoted_in_use(&self) -> bool;
    /// Refactors that factor with pivoting (`a` is the matrix the solves are of), and counts it.
    fn repivot(&mut self, a: &SparseMatrix) -> Result<(), SolveError>;
}

/// [`checked_solve`] for a system whose factor may lack pivots: when the direct solve with an
/// unpivoted factor misses `tol`, the factor is redone with pivoting ([`Repivot::repivot`])
/// before anything else, then solved and polished as [`checked_solve`] does. Returns the
/// residual and the GMRES iterations.
pub fn checked_solve_repivoting(
    system: &mut dyn Repivot,
    a: &SparseMatrix,
    b: &[f64],
    x: &mut [f64],
    tol: f64,
) -> Result<(f64, usize), SolveError> {
    if system.unpivoted_in_use() {
        if let Some(res) = direct_solve(a, b, x, tol, &mut |v| system.solve_factored(v))? {
            return Ok((res, 0));
        }
        system.repivot(a)?;
    }
    checked_solve(a, b, x, tol, &mut |v| system.solve_factored(v))
}

impl Repivot for DirectSolver {
    fn solve_factored(&mut self, v: &mut [f64]) -> Result<(), SolveError> {
        self.solve_in_place(v)
    }

    fn unpivoted_in_use(&self) -> bool {
        self.is_unpivoted()
    }

    fn repivot(&mut self, a: &SparseMatrix) -> Result<(), SolveError> {
        self.pivoted_refactors += 1;
        self.factor_pivoted(a)
    }
}

impl DirectSolver {
    /// Sets how an LBLᵀ solver pivots from its next factorization on ([`Pivoting`]).
    pub fn set_pivoting(&mut self, pivoting: Pivoting) {
        self.pivoting = pivoting;
    }

    /// Factorizations without pivots replaced by the pivoted one: their solve missed the
    /// tolerance ([`solve_checked`](Self::solve_checked), [`check_unpivoted`](Self::check_unpivoted)).
    pub fn pivoted_refactors(&self) -> usize {
        self.pivoted_refactors
    }

    /// Whether the last factorization was made without pivots ([`Pivoting::WhenNeeded`]).
    pub fn is_unpivoted(&self) -> bool {
        self.factored && self.unpivoted
    }

    /// LBLᵀ: factors `a` without pivots, unscaled (without pivots the factor of D A D is that of
    /// A scaled: no equilibration); returns whether it succeeded. Not yet marked factored.
    pub(super) fn factor_unpivoted(&mut self, a: &SparseMatrix) -> bool {
        let Backend::Lblt {
            symbolic,
            l_values,
            subdiag,
            perm_fwd,
            perm_inv,
        } = &mut self.backend
        else {
            return false;
        };
        let stack = MemStack::new(&mut self.buffer);
        if !factor_ldlt(symbolic, l_values, subdiag, perm_fwd, perm_inv, a, stack) {
            return false;
        }
        self.scale.clear();
        self.scale.resize(self.n, 1.0);
        self.unpivoted = true;
        true
    }

    /// [`factor`](Self::factor) with Bunch–Kaufman pivoting whatever the solver's
    /// [`Pivoting`]: for a matrix whose unpivoted factor solved it inaccurately.
    pub fn factor_pivoted(&mut self, a: &SparseMatrix) -> Result<(), SolveError> {
        self.factor_scaled(a, true, Pivoting::Always)
    }

    /// For a factor made without pivots: solves A x = A 1 and, when the relative residual misses
    /// `tol` (the factor's growth spoiled it), refactors `a` with pivoting. Returns whether it
    /// refactored. For a factor used many times, whose solves are not all checked.
    pub fn check_unpivoted(&mut self, a: &SparseMatrix, tol: f64) -> Result<bool, SolveError> {
        if !self.is_unpivoted() {
            return Ok(false);
        }
        let mut b = vec![0.0; self.n];
        a.matvec(&vec![1.0; self.n], &mut b);
        let mut x = b.clone();
        self.solve_in_place(&mut x)?;
        if relative_residual(a, &x, &b) <= tol {
            return Ok(false);
        }
        self.repivot(a)?;
        Ok(true)
    }
}
