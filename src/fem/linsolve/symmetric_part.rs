//! Non-symmetric systems whose pattern is symmetric — the flow with the semi-implicit polymer
//! stress of η_s = 0 (thesis Eq. 5.26) — solved by GMRES preconditioned by the LBLᵀ
//! factorization of the matrix's symmetric part (A + Aᵀ)/2, in the caller's (node-block nested
//! dissection) order.
//!
//! Why: faer's sparse LU orders the columns by COLAMD and reserves the structure of the Cholesky
//! factor of AᵀA (room for any row pivot); on the Q2/Q1 saddle-point matrices that costs about
//! 10× the LBLᵀ of the same pattern, and 25× at 200×62 (13.4 s against 0.55 s per factorization,
//! docs/performance.md "The semi-implicit flow"). The semi-implicit stress
//! `τ = GΔt (L·cⁿ + cⁿ·Lᵀ) + …` tested with D(v) is symmetric in its rate-of-strain part and
//! non-symmetric only through the vorticity and the convection `−GΔt u·∇cⁿ`, so the symmetric part
//! is close to A: GMRES needs about 3 iterations to the flow's residual tolerance.
//! The symmetric part is a saddle-point matrix like the explicit coupling's flow matrix and is
//! factored without pivots where that works ([`Pivoting::WhenNeeded`]): when GMRES then misses
//! the tolerance, [`DirectSolver`] refactors it with pivots first, and falls back to faer's LU
//! when the symmetric part cannot be factored or GMRES still misses.

use super::{DirectSolver, Pivoting, SolveError, SolverKind};
use crate::fem::sparse::SparseMatrix;

/// The LBLᵀ of (A + Aᵀ)/2 for one pattern, refreshed at every [`factor`](Self::factor).
pub(super) struct SymmetricPart {
    lblt: DirectSolver,
    sym: SparseMatrix,
    /// For the entry (i, j) at each position, the position of (j, i).
    mirror: Vec<usize>,
}

impl SymmetricPart {
    /// The symbolic analysis of the LBLᵀ with the elimination order `order` (`order[k]` = the
    /// dof eliminated k-th).
    ///
    /// # Panics
    /// If `a`'s pattern is not symmetric.
    pub(super) fn analyze(a: &SparseMatrix, order: &[usize]) -> Result<Self, SolveError> {
        let mut mirror = vec![0usize; a.nnz()];
        for j in 0..a.n() {
            let (rows, range) = a.column(j);
            for (&i, p) in rows.iter().zip(range) {
                mirror[p] = a.position(j, i);
            }
        }
        let sym = a.clone();
        let mut lblt = DirectSolver::analyze_with_order(&sym, SolverKind::Lblt, order)?;
        lblt.set_pivoting(Pivoting::WhenNeeded);
        Ok(Self { lblt, sym, mirror })
    }

    /// Factors the symmetric part of `a` (the analysed pattern, equilibrated by the caller).
    pub(super) fn factor(&mut self, a: &SparseMatrix) -> Result<(), SolveError> {
        for (p, v) in self.sym.values.iter_mut().enumerate() {
            *v = 0.5 * (a.values[p] + a.values[self.mirror[p]]);
        }
        self.lblt.factor_equilibrated(&self.sym)
    }

    /// Whether the symmetric part was last factored without pivots.
    pub(super) fn is_unpivoted(&self) -> bool {
        self.lblt.is_unpivoted()
    }

    /// Refactors the symmetric part of the last [`factor`](Self::factor) with pivots (its
    /// unpivoted factor preconditioned too poorly).
    pub(super) fn repivot(&mut self) -> Result<(), SolveError> {
        self.lblt.factor_scaled(&self.sym, false, Pivoting::Always)
    }

    /// Applies the inverse of the symmetric part (the preconditioner) in place.
    pub(super) fn solve_in_place(&mut self, rhs: &mut [f64]) -> Result<(), SolveError> {
        self.lblt.solve_in_place(rhs)
    }
}
