//! The Schur complement of a factored matrix onto the dofs it eliminates last, read from the
//! supernodal LBLᵀ factor instead of being computed by one solve per condensed dof.
//!
//! With the dofs W eliminated last, the factor P (D A D) Pᵀ = L B Lᵀ splits as
//! `L = [[L₁₁, 0], [L₂₁, L₂₂]]`, and the Schur complement of the leading block is
//! `D_W S D_W = L₂₂ B₂₂ L₂₂ᵀ` (B is block diagonal, so B₂₂ is its trailing part), for any split
//! that does not cut a 2×2 pivot. When the requested dofs hold the last positions of the factor
//! (no pivot moved another dof among them: always without pivots, [`super::Pivoting`]), W is
//! exactly them. Otherwise — a supernode's Bunch–Kaufman pivoting permutes within the
//! supernode — W is taken from the start of the supernode that holds the first requested dof,
//! and the dofs of W that were not requested are then eliminated densely (the band's K on
//! 200×50: 1503 positions for 1050 interface dofs, 3.3× the flops).

use faer::linalg::matmul::matmul;
use faer::prelude::Solve;
use faer::{Accum, Mat, Par};

use super::{DirectSolver, SolveError};

/// Largest number of dofs, as a multiple of the requested ones plus [`MAX_EXTRA`], that
/// [`DirectSolver::schur_complement`] reconstructs densely (the rest is a caller's ordering
/// error: the requested dofs must come last).
const MAX_EXTRA_FACTOR: usize = 3;
/// See [`MAX_EXTRA_FACTOR`].
const MAX_EXTRA: usize = 512;

impl DirectSolver {
    /// The Schur complement S = A_ΓΓ − A_ΓR A_RR⁻¹ A_RΓ of the last factored matrix A onto the
    /// dofs Γ = `dofs` (dense, rows and columns in the order of `dofs`), R being all other dofs.
    /// The dofs must be among the last ones of the elimination order (give them last to
    /// [`analyze_with_order`](Self::analyze_with_order); the symbolic analysis may postorder
    /// them among the last few); the factorization must be LBLᵀ.
    ///
    /// Costs m³ flops for the m dofs eliminated after the start of the supernode holding the
    /// first of `dofs` (about |Γ| when Γ forms the root supernode), instead of the |Γ| solves
    /// with the whole factor that A_RR⁻¹ A_RΓ would take.
    pub fn schur_complement(&self, dofs: &[usize]) -> Result<Mat<f64>, SolveError> {
        let parts = self.parts()?;
        let n = self.n;
        // the requested dofs alone when they are the last positions and no 2×2 pivot straddles
        // the split before them
        let mut requested = vec![false; n];
        dofs.iter().for_each(|&d| requested[d] = true);
        match n.checked_sub(dofs.len()) {
            Some(q) if self.at[q..].iter().all(|&d| requested[d]) && !pair_at(&parts, q) => {
                self.schur_complement_from(dofs, q)
            }
            _ => self.schur_complement_from(dofs, self.trailing_supernodes(dofs)?.1),
        }
    }

    /// [`schur_complement`](Self::schur_complement) condensing first onto the positions
    /// `start..` (all of `dofs` among them, no 2×2 pivot cut), then onto `dofs`.
    fn schur_complement_from(&self, dofs: &[usize], start: usize) -> Result<Mat<f64>, SolveError> {
        let parts = self.parts()?;
        let n = self.n;
        // the supernode holding `start`
        let s0 = (0..parts.n_supernodes)
            .rev()
            .find(|&s| parts.factor.supernode(s).start() <= start)
            .unwrap_or(0);
        let m = n - start;
        if m > MAX_EXTRA_FACTOR * dofs.len() + MAX_EXTRA {
            return Err(SolveError::Symbolic(format!(
                "Schur complement onto {} dofs: they are not among the last of the elimination \
                 order ({m} dofs follow the first of them)",
                dofs.len()
            )));
        }
        // L₂₂ (unit lower) of the positions start..n, and L₂₂ B₂₂ (B is diagonal with 2×2
        // blocks: a scaling of L's columns)
        let mut l = Mat::<f64>::zeros(m, m);
        for s in s0..parts.n_supernodes {
            let node = parts.factor.supernode(s);
            let (s_start, vals, pattern) = (node.start(), node.val(), node.pattern());
            let size = vals.ncols();
            for c in start.saturating_sub(s_start)..size {
                let col = s_start + c - start;
                l[(col, col)] = 1.0;
                for r in c + 1..size {
                    l[(s_start + r - start, col)] = vals[(r, c)];
                }
                for (k, &i) in pattern.iter().enumerate() {
                    l[(parts.pivot_inv[i] - start, col)] = vals[(size + k, c)];
                }
            }
        }
        let mut lb = Mat::<f64>::zeros(m, m);
        for s in s0..parts.n_supernodes {
            let node = parts.factor.supernode(s);
            let (s_start, vals) = (node.start(), node.val());
            let size = vals.ncols();
            // (a split inside a supernode falls between pivots: start at it)
            let mut c = start.saturating_sub(s_start);
            while c < size {
                let col = s_start + c - start;
                let sub = parts.subdiag[s_start + c];
                if sub != 0.0 {
                    let (b11, b22) = (vals[(c, c)], vals[(c + 1, c + 1)]);
                    for r in col..m {
                        let (l1, l2) = (l[(r, col)], l[(r, col + 1)]);
                        lb[(r, col)] = l1 * b11 + l2 * sub;
                        lb[(r, col + 1)] = l1 * sub + l2 * b22;
                    }
                    c += 2;
                } else {
                    let d = vals[(c, c)];
                    for r in col..m {
                        lb[(r, col)] = l[(r, col)] * d;
                    }
                    c += 1;
                }
            }
        }
        let mut s_w = Mat::<f64>::zeros(m, m);
        matmul(&mut s_w, Accum::Replace, &lb, l.transpose(), 1.0, Par::Seq);
        // undo the equilibration: the factor is of D A D
        let w = &self.at[start..];
        for j in 0..m {
            for i in 0..m {
                s_w[(i, j)] /= self.scale[w[i]] * self.scale[w[j]];
            }
        }
        // condense the leading dofs of the supernode that were not asked for
        let mut local = vec![usize::MAX; n];
        w.iter().enumerate().for_each(|(k, &d)| local[d] = k);
        let gamma: Vec<usize> = dofs.iter().map(|&d| local[d]).collect();
        let mut is_gamma = vec![false; m];
        gamma.iter().for_each(|&k| is_gamma[k] = true);
        let extra: Vec<usize> = (0..m).filter(|&k| !is_gamma[k]).collect();
        let g = gamma.len();
        let mut s = Mat::<f64>::from_fn(g, g, |i, j| s_w[(gamma[i], gamma[j])]);
        if !extra.is_empty() {
            let e = extra.len();
            let s_ee = Mat::<f64>::from_fn(e, e, |i, j| s_w[(extra[i], extra[j])]);
            let s_eg = Mat::<f64>::from_fn(e, g, |i, j| s_w[(extra[i], gamma[j])]);
            let x = s_ee.partial_piv_lu().solve(&s_eg);
            let s_ge = Mat::<f64>::from_fn(g, e, |i, j| s_w[(gamma[i], extra[j])]);
            matmul(&mut s, Accum::Add, &s_ge, &x, -1.0, Par::Seq);
        }
        if s.col_iter().all(|c| c.iter().all(|v| v.is_finite())) {
            Ok(s)
        } else {
            Err(SolveError::Numeric("non-finite Schur complement".into()))
        }
    }
}

/// Whether positions `q − 1` and `q` form a 2×2 pivot (`subdiag` holds a pair's off-diagonal
/// entry at its first position).
fn pair_at(parts: &super::trisolve::Parts<'_>, q: usize) -> bool {
    q > 0 && parts.subdiag[q - 1] != 0.0 && !(q > 1 && pair_at(parts, q - 1))
}

#[cfg(test)]
mod tests {
    use super::super::{Pivoting, SolverKind};
    use super::*;
    use crate::fem::sparse::{PatternBuilder, SparseMatrix};

    /// A symmetric saddle-point matrix on a chain of `n` velocity-like dofs with a pressure-like
    /// dof per three of them (zero diagonal), and entries over several orders of magnitude.
    fn chain_saddle(n: usize) -> SparseMatrix {
        let np = n / 3;
        let mut pb = PatternBuilder::new(n + np);
        for i in 0..n - 1 {
            pb.add_group(&[i, i + 1]);
        }
        for p in 0..np {
            pb.add_coupling(&[n + p], &[3 * p, 3 * p + 1, 3 * p + 2]);
            if p + 1 < np {
                pb.add_group(&[n + p, 3 * p + 3]);
            }
        }
        let mut a = pb.build();
        // a diagonally dominant velocity block with couplings from 1e-2 to 1e2
        let s = |i: usize| 10f64.powi((i % 5) as i32 - 2);
        for i in 0..n {
            let left = if i > 0 { s(i - 1) } else { 0.0 };
            a.add(i, i, 2.0 * (s(i) + left) + 1.0);
            if i + 1 < n {
                a.add(i, i + 1, -s(i));
                a.add(i + 1, i, -s(i));
            }
        }
        for p in 0..np {
            for c in [3 * p, 3 * p + 1, 3 * p + 2] {
                a.add(n + p, c, 1.0 + 0.1 * c as f64);
                a.add(c, n + p, 1.0 + 0.1 * c as f64);
            }
            if p + 1 < np {
                a.add(n + p, 3 * p + 3, 0.5);
                a.add(3 * p + 3, n + p, 0.5);
            }
        }
        a
    }

    fn dense(a: &SparseMatrix) -> Mat<f64> {
        Mat::from_fn(a.n(), a.n(), |i, j| a.get(i, j))
    }

    #[test]
    fn schur_complement_matches_the_dense_one() {
        // round-off of a few eliminations on entries of up to 1e2 (relative to max |S_ij|)
        const TOL: f64 = 1e-11;
        let a = chain_saddle(60);
        let n = a.n();
        // condense onto sets scattered through the chain (velocity and pressure dofs; A_RR must
        // stay regular: no pressure left without a velocity), which the symbolic analysis
        // postorders among other dofs
        // with pivots, and without (then the requested dofs are the factor's last positions)
        let cases = [vec![7, 30, 31, 64, 70], vec![1, 2, 20, 21, 22, 61, 62, 79]]
            .into_iter()
            .flat_map(|g| [(g.clone(), Pivoting::Always), (g, Pivoting::WhenNeeded)]);
        for (gamma, pivoting) in cases {
            let mut order: Vec<usize> = (0..n).filter(|d| !gamma.contains(d)).collect();
            order.extend(&gamma);
            let mut s = DirectSolver::analyze_with_order(&a, SolverKind::Lblt, &order).unwrap();
            s.set_pivoting(pivoting);
            s.factor(&a).unwrap();
            assert_eq!(s.is_unpivoted(), pivoting == Pivoting::WhenNeeded);
            // the requested dofs alone, and from the start of the supernode before theirs (the
            // path of a pivot that moved another dof among them)
            let s0 = s.trailing_supernodes(&gamma).unwrap().0;
            let supernode_start = s.parts().unwrap().factor.supernode(s0 - 1).start();
            for got in [
                s.schur_complement(&gamma).unwrap(),
                s.schur_complement_from(&gamma, supernode_start).unwrap(),
            ] {
                let full = dense(&a);
                let rest: Vec<usize> = order[..n - gamma.len()].to_vec();
                let (r, g) = (rest.len(), gamma.len());
                let a_rr = Mat::<f64>::from_fn(r, r, |i, j| full[(rest[i], rest[j])]);
                let a_rg = Mat::<f64>::from_fn(r, g, |i, j| full[(rest[i], gamma[j])]);
                let x = a_rr.partial_piv_lu().solve(&a_rg);
                let mut want = Mat::<f64>::from_fn(g, g, |i, j| full[(gamma[i], gamma[j])]);
                let a_gr = Mat::<f64>::from_fn(g, r, |i, j| full[(gamma[i], rest[j])]);
                matmul(&mut want, Accum::Add, &a_gr, &x, -1.0, Par::Seq);
                let scale = want
                    .col_iter()
                    .flat_map(|c| c.iter().map(|v| v.abs()).collect::<Vec<_>>())
                    .fold(0.0, f64::max);
                for i in 0..g {
                    for j in 0..g {
                        assert!(
                            (got[(i, j)] - want[(i, j)]).abs() <= TOL * scale,
                            "S[{i},{j}] = {} vs {}",
                            got[(i, j)],
                            want[(i, j)]
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn schur_complement_refuses_dofs_not_eliminated_last() {
        let a = chain_saddle(900);
        let order: Vec<usize> = (0..a.n()).collect();
        let mut s = DirectSolver::analyze_with_order(&a, SolverKind::Lblt, &order).unwrap();
        s.factor(&a).unwrap();
        assert!(s.schur_complement(&[0, 1]).is_err());
        let r = s.schur_complement(&[a.n() - 2, a.n() - 1]);
        assert!(r.is_ok(), "{r:?}");
    }
}
