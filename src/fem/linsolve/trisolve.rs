//! Solves with the supernodal LBLᵀ factor by parts — forward substitution, the block-diagonal B,
//! backward substitution — on vectors in factor order, each part optionally restricted to the
//! trailing supernodes. A caller that solves twice with right-hand sides that differ only in the
//! dofs eliminated last ([`Substructured`](crate::fem::substructure::Substructured)) repeats
//! only the trailing part of the forward substitution.
//!
//! With P the elimination order (fill-reducing, then the intranode pivots) and D the
//! equilibration, the factor is P (D A D) Pᵀ = L B Lᵀ, so A⁻¹ b = D Pᵀ L⁻ᵀ B⁻¹ L⁻¹ P D b.

use faer::linalg::matmul::matmul;
use faer::perm::PermRef;
use faer::sparse::linalg::cholesky::{supernodal::SupernodalIntranodeLbltRef, SymbolicCholeskyRaw};
use faer::{Accum, ColMut, ColRef, Par};

use super::{Backend, DirectSolver, SolveError};

/// The parts of a supernodal LBLᵀ factor that a solve (or [`DirectSolver::schur_complement`])
/// reads.
pub(super) struct Parts<'a> {
    pub factor: SupernodalIntranodeLbltRef<'a, usize, f64>,
    pub n_supernodes: usize,
    /// The 2×2 pivots' off-diagonal entries by position (0: a 1×1 pivot).
    pub subdiag: &'a [f64],
    /// Intranode pivot: pattern index → position.
    pub pivot_inv: &'a [usize],
}

impl DirectSolver {
    pub(super) fn parts(&self) -> Result<Parts<'_>, SolveError> {
        if !self.factored {
            return Err(SolveError::NotFactored);
        }
        let Backend::Lblt {
            symbolic,
            l_values,
            subdiag,
            perm_fwd,
            perm_inv,
        } = &self.backend
        else {
            return Err(SolveError::Symbolic("solve by parts needs LBLᵀ".into()));
        };
        let SymbolicCholeskyRaw::Supernodal(sn) = symbolic.raw() else {
            return Err(SolveError::Symbolic(
                "solve by parts needs a supernodal factor".into(),
            ));
        };
        Ok(Parts {
            factor: SupernodalIntranodeLbltRef::new(
                sn,
                l_values,
                subdiag,
                PermRef::new_checked(perm_fwd, perm_inv, self.n),
            ),
            n_supernodes: sn.n_supernodes(),
            subdiag,
            pivot_inv: perm_inv,
        })
    }

    /// The dof at each position of the elimination order.
    pub fn dof_at_positions(&self) -> Vec<usize> {
        let Backend::Lblt {
            symbolic, perm_fwd, ..
        } = &self.backend
        else {
            return (0..self.n).collect();
        };
        match symbolic.perm() {
            Some(p) => perm_fwd.iter().map(|&i| p.arrays().0[i]).collect(),
            None => perm_fwd.clone(),
        }
    }

    /// The first supernode and its first position such that all of `dofs` are eliminated from
    /// there on.
    pub fn trailing_supernodes(&self, dofs: &[usize]) -> Result<(usize, usize), SolveError> {
        let parts = self.parts()?;
        let mut position = vec![0usize; self.n];
        self.at
            .iter()
            .enumerate()
            .for_each(|(p, &d)| position[d] = p);
        let first = dofs.iter().map(|&d| position[d]).min().unwrap_or(self.n);
        // the last supernode that starts at or before `first`
        let s0 = (0..parts.n_supernodes)
            .rev()
            .find(|&s| parts.factor.supernode(s).start() <= first)
            .unwrap_or(0);
        Ok((s0, parts.factor.supernode(s0).start()))
    }

    /// v ← P D b (b by dof, v by position).
    pub fn to_positions(&self, b: &[f64], at: &[usize], v: &mut [f64]) {
        for (vp, &d) in v.iter_mut().zip(at) {
            *vp = self.scale[d] * b[d];
        }
    }

    /// x ← D Pᵀ v (v by position, x by dof).
    pub fn from_positions(&self, v: &[f64], at: &[usize], x: &mut [f64]) {
        for (vp, &d) in v.iter().zip(at) {
            x[d] = self.scale[d] * vp;
        }
    }

    /// v ← L⁻¹ v over the supernodes `from..` (those before see zeros in v, or were done).
    ///
    /// Per supernode: the unit lower triangle of its diagonal block, then the update of the rows
    /// below it accumulated in a contiguous buffer (w = L₂₁ v₁) and scattered once.
    pub fn forward(&self, v: &mut [f64], from: usize) -> Result<(), SolveError> {
        let parts = self.parts()?;
        let mut w = Vec::new();
        for s in from..parts.n_supernodes {
            let node = parts.factor.supernode(s);
            let (start, vals, pattern) = (node.start(), node.val(), node.pattern());
            let size = vals.ncols();
            w.clear();
            w.resize(pattern.len(), 0.0);
            let mut any = false;
            for c in 0..size {
                let col = vals.col(c).try_as_col_major().expect("contiguous");
                let col = col.as_slice();
                let xc = v[start + c];
                if xc == 0.0 {
                    continue;
                }
                any = true;
                for (vr, l) in v[start + c + 1..start + size]
                    .iter_mut()
                    .zip(&col[c + 1..size])
                {
                    *vr -= l * xc;
                }
                for (wk, l) in w.iter_mut().zip(&col[size..]) {
                    *wk += l * xc;
                }
            }
            if any {
                for (&i, wk) in pattern.iter().zip(&w) {
                    v[parts.pivot_inv[i]] -= wk;
                }
            }
        }
        Ok(())
    }

    /// v ← B⁻¹ v over the supernodes `from..`.
    pub fn diagonal(&self, v: &mut [f64], from: usize) -> Result<(), SolveError> {
        let parts = self.parts()?;
        for s in from..parts.n_supernodes {
            let node = parts.factor.supernode(s);
            let (start, vals) = (node.start(), node.val());
            let size = vals.ncols();
            let mut idx = 0;
            while idx < size {
                let i = start + idx;
                let sub = parts.subdiag[i];
                if sub == 0.0 {
                    v[i] /= vals[(idx, idx)];
                    idx += 1;
                } else {
                    // the 2×2 block [[b11, sub], [sub, b22]], as faer solves it
                    let d21 = 1.0 / sub;
                    let d11 = d21 * vals[(idx, idx)];
                    let d22 = d21 * vals[(idx + 1, idx + 1)];
                    let denom = 1.0 / (d11 * d22 - 1.0);
                    let (xk, xk1) = (v[i] * d21, v[i + 1] * d21);
                    v[i] = (d22 * xk - xk1) * denom;
                    v[i + 1] = (d11 * xk1 - xk) * denom;
                    idx += 2;
                }
            }
        }
        Ok(())
    }

    /// v ← L⁻ᵀ v over the supernodes `from..` (the positions before them are left as they
    /// are: exact for the trailing positions only unless `from` = 0).
    ///
    /// Per supernode: the rows below it gathered once into a contiguous buffer g, the products
    /// L₂₁ᵀ g by faer's matrix–vector product (its SIMD kernels: the flow solve of an a/16
    /// study case 0.133 → 0.118 s against a four-sum dot product per column, whose sums waited
    /// on each other), then the unit upper triangle by dot products. The forward substitution
    /// keeps its column loop: the same product for its L₂₁ x₁ made that flow solve slower (0.125
    /// → 0.142 s), the loop skipping the zeros of v; faer's triangular solves for the diagonal
    /// blocks were slower as well (200×50 flow solve 0.032 → 0.035 s).
    pub fn backward(&self, v: &mut [f64], from: usize) -> Result<(), SolveError> {
        let parts = self.parts()?;
        let (mut g, mut below) = (Vec::new(), Vec::new());
        for s in (from..parts.n_supernodes).rev() {
            let node = parts.factor.supernode(s);
            let (start, vals, pattern) = (node.start(), node.val(), node.pattern());
            let size = vals.ncols();
            let column = |c: usize| {
                vals.col(c)
                    .try_as_col_major()
                    .expect("contiguous")
                    .as_slice()
            };
            g.clear();
            g.extend(pattern.iter().map(|&i| v[parts.pivot_inv[i]]));
            below.clear();
            below.resize(size, 0.0);
            if !pattern.is_empty() {
                matmul(
                    ColMut::from_slice_mut(&mut below),
                    Accum::Replace,
                    vals.subrows(size, pattern.len()).transpose(),
                    ColRef::from_slice(&g),
                    1.0,
                    Par::Seq,
                );
            }
            for c in (0..size).rev() {
                let inside = dot(&column(c)[c + 1..size], &v[start + c + 1..start + size]);
                v[start + c] -= below[c] + inside;
            }
        }
        Ok(())
    }
}

/// Σ aᵢ bᵢ of two slices of one length, in four independent sums (so that it vectorizes).
fn dot(a: &[f64], b: &[f64]) -> f64 {
    debug_assert_eq!(a.len(), b.len());
    let mut acc = [0.0; 4];
    let split = a.len() - a.len() % 4;
    let ((a4, a1), (b4, b1)) = (a.split_at(split), b.split_at(split));
    for (x, y) in a4.chunks_exact(4).zip(b4.chunks_exact(4)) {
        for k in 0..4 {
            acc[k] += x[k] * y[k];
        }
    }
    let tail: f64 = a1.iter().zip(b1).map(|(x, y)| x * y).sum();
    (acc[0] + acc[1]) + (acc[2] + acc[3]) + tail
}

#[cfg(test)]
mod tests {
    use super::super::SolverKind;
    use super::*;
    use crate::fem::sparse::{PatternBuilder, SparseMatrix};

    /// A symmetric indefinite matrix: a 2D 5-point Laplacian-like block with a few
    /// zero-diagonal constraint rows (so that 2×2 pivots occur).
    fn indefinite(m: usize) -> SparseMatrix {
        let n = m * m;
        let nc = m;
        let mut pb = PatternBuilder::new(n + nc);
        for i in 0..m {
            for j in 0..m {
                let k = i * m + j;
                if j + 1 < m {
                    pb.add_group(&[k, k + 1]);
                }
                if i + 1 < m {
                    pb.add_group(&[k, k + m]);
                }
            }
        }
        for c in 0..nc {
            pb.add_coupling(&[n + c], &[c * m, c * m + 1]);
        }
        let mut a = pb.build();
        for i in 0..m {
            for j in 0..m {
                let k = i * m + j;
                a.add(k, k, 4.0 + 0.01 * k as f64);
                for o in [k + 1, k + m] {
                    let ok = (o == k + 1 && j + 1 < m) || (o == k + m && i + 1 < m);
                    if ok {
                        a.add(k, o, -1.0);
                        a.add(o, k, -1.0);
                    }
                }
            }
        }
        for c in 0..nc {
            for (d, w) in [(c * m, 1.0), (c * m + 1, -0.5)] {
                a.add(n + c, d, w);
                a.add(d, n + c, w);
            }
        }
        a
    }

    #[test]
    fn solving_by_parts_equals_the_solve() {
        // the same operations in another order: round-off only
        const TOL: f64 = 1e-12;
        let a = indefinite(12);
        let n = a.n();
        // constraints after the dofs they constrain (a zero diagonal is no pivot otherwise)
        let order: Vec<usize> = (0..n).collect();
        let mut s = DirectSolver::analyze_with_order(&a, SolverKind::Lblt, &order).unwrap();
        s.factor(&a).unwrap();
        let b: Vec<f64> = (0..n).map(|i| (0.7 * i as f64).sin()).collect();
        let mut want = b.clone();
        s.solve_in_place(&mut want).unwrap();
        let at = s.dof_at_positions();
        let mut v = vec![0.0; n];
        s.to_positions(&b, &at, &mut v);
        s.forward(&mut v, 0).unwrap();
        s.diagonal(&mut v, 0).unwrap();
        s.backward(&mut v, 0).unwrap();
        let mut got = vec![0.0; n];
        s.from_positions(&v, &at, &mut got);
        let scale = want.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        for (g, w) in got.iter().zip(&want) {
            assert!((g - w).abs() <= TOL * scale, "{g} vs {w}");
        }
        // the trailing part alone: a right-hand side on the last dofs only
        let last: Vec<usize> = at[n - 5..].to_vec();
        let (s0, p1) = s.trailing_supernodes(&last).unwrap();
        assert!(p1 <= n - 5);
        let mut c = vec![0.0; n];
        last.iter().for_each(|&d| c[d] = 1.0 + d as f64);
        let mut want = c.clone();
        s.solve_in_place(&mut want).unwrap();
        let mut v = vec![0.0; n];
        s.to_positions(&c, &at, &mut v);
        s.forward(&mut v, s0).unwrap();
        s.diagonal(&mut v, 0).unwrap();
        s.backward(&mut v, 0).unwrap();
        s.from_positions(&v, &at, &mut got);
        let scale = want.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        for (g, w) in got.iter().zip(&want) {
            assert!((g - w).abs() <= TOL * scale, "{g} vs {w}");
        }
    }
}
