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
//! the tolerance, [`DirectSolver`] refactors it with pivots first (and with pivots from then on,
//! for the pattern), and falls back to faer's LU when the symmetric part cannot be factored or
//! GMRES still misses.
//!
//! The symmetric part is written straight into the elimination order, its lower triangle only,
//! so that the factorization takes it as stored (faer would otherwise copy it into the order at
//! every factorization); the solves permute the right-hand side into that order and back.

use super::{DirectSolver, Pivoting, SolveError, SolverKind};
use crate::fem::sparse::SparseMatrix;

/// The LBLᵀ of (A + Aᵀ)/2 for one pattern, refreshed at every [`factor`](Self::factor).
pub(super) struct SymmetricPart {
    lblt: DirectSolver,
    /// The lower triangle of P (A + Aᵀ)/2 Pᵀ, P the elimination order.
    sym: SparseMatrix,
    /// For each entry of `sym`, the positions in A of the entry (i, j) it stands for and of
    /// (j, i).
    source: Vec<[usize; 2]>,
    /// The dof eliminated k-th (P), and a work vector in that order.
    order: Vec<usize>,
    work: Vec<f64>,
}

impl SymmetricPart {
    /// The symbolic analysis of the LBLᵀ with the elimination order `order` (`order[k]` = the
    /// dof eliminated k-th).
    ///
    /// `a`'s pattern must be symmetric (checked in debug builds, by
    /// [`SparseMatrix::transpose_positions`]).
    pub(super) fn analyze(a: &SparseMatrix, order: &[usize]) -> Result<Self, SolveError> {
        let n = a.n();
        let mut at = vec![0usize; n];
        for (k, &d) in order.iter().enumerate() {
            at[d] = k;
        }
        let mirror = a.transpose_positions();
        // column l of the permuted lower triangle: A's column order[l], rows at or below l
        let (mut col_ptr, mut row_idx, mut source) =
            (Vec::with_capacity(n + 1), Vec::new(), Vec::new());
        let mut column: Vec<(usize, [usize; 2])> = Vec::new();
        col_ptr.push(0);
        for (l, &j) in order.iter().enumerate() {
            let (rows, range) = a.column(j);
            column.clear();
            column.extend(
                rows.iter()
                    .zip(range)
                    .filter(|(&i, _)| at[i] >= l)
                    .map(|(&i, p)| (at[i], [p, mirror[p] as usize])),
            );
            column.sort_unstable_by_key(|e| e.0);
            row_idx.extend(column.iter().map(|e| e.0));
            source.extend(column.iter().map(|e| e.1));
            col_ptr.push(row_idx.len());
        }
        let sym = SparseMatrix::from_pattern(n, col_ptr, row_idx);
        let identity: Vec<usize> = (0..n).collect();
        let mut lblt = DirectSolver::analyze_with_order(&sym, SolverKind::Lblt, &identity)?;
        lblt.set_pivoting(Pivoting::WhenNeeded);
        Ok(Self {
            lblt,
            sym,
            source,
            order: order.to_vec(),
            work: vec![0.0; n],
        })
    }

    /// Factors the symmetric part of `a` (the analysed pattern, equilibrated by the caller).
    pub(super) fn factor(&mut self, a: &SparseMatrix) -> Result<(), SolveError> {
        for (v, &[p, q]) in self.sym.values.iter_mut().zip(&self.source) {
            *v = 0.5 * (a.values[p] + a.values[q]);
        }
        self.lblt.factor_equilibrated(&self.sym)
    }

    /// Whether the symmetric part was last factored without pivots.
    pub(super) fn is_unpivoted(&self) -> bool {
        self.lblt.is_unpivoted()
    }

    /// Refactors the symmetric part of the last [`factor`](Self::factor) with pivots (its
    /// unpivoted factor preconditioned too poorly), and every later one: finding that out cost a
    /// whole GMRES cycle, which a pattern whose unpivoted factor failed once should not pay at
    /// every step.
    pub(super) fn repivot(&mut self) -> Result<(), SolveError> {
        self.lblt.set_pivoting(Pivoting::Always);
        self.lblt.factor_scaled(&self.sym, false, Pivoting::Always)
    }

    /// Applies the inverse of the symmetric part (the preconditioner) in place.
    pub(super) fn solve_in_place(&mut self, rhs: &mut [f64]) -> Result<(), SolveError> {
        for (w, &d) in self.work.iter_mut().zip(&self.order) {
            *w = rhs[d];
        }
        self.lblt.solve_in_place(&mut self.work)?;
        for (w, &d) in self.work.iter().zip(&self.order) {
            rhs[d] = *w;
        }
        Ok(())
    }
}
