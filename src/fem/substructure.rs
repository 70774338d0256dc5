//! A direct solver for a sequence of matrices that differ only in the rows and columns of a
//! band of dofs: the rest (the far field F) is factored once per placement of the band and
//! condensed onto the band's boundary Γ; each new matrix pays the factorization of the band
//! alone.
//!
//! With the dofs split into far F, interface Γ (band dofs coupled to F) and band interior I,
//!
//! ```text
//!       [ A_FF  A_FΓ   0   ]
//!   A = [ A_ΓF  A_ΓΓ  A_ΓI ]      K = [ A_FF  A_FΓ ]      M = [ A_II  A_IΓ ]
//!       [  0    A_IΓ  A_II ]          [ A_ΓF  A_ΓΓ ]          [ A_ΓI  S    ]
//! ```
//!
//! where S = A_ΓΓ − A_ΓF A_FF⁻¹ A_FΓ is the Schur complement of K onto Γ (dense). K's far rows
//! and columns are fixed while the band stays where it is (they are checked at every
//! factorization), so K is factored and condensed once ([`DirectSolver::schur_complement`]).
//! S is linear in A_ΓΓ, so entries of A_ΓΓ may change too: M's Γ block is S₀ + (A_ΓΓ − A_ΓΓ,₀),
//! with S₀ and A_ΓΓ,₀ those of the placement — Γ may then lie on elements that change, and the
//! band needs no ring of unchanged elements around them. M changes in its I rows and its Γ block
//! but is small, and is factored for every new matrix. A solve is two solves with K and one with
//! M (K and S₀ as placed):
//!
//! ```text
//!   K [z_F; z_Γ] = [b_F; 0]               (z_Γ = −S⁻¹ A_ΓF A_FF⁻¹ b_F)
//!   M [x_I; x_Γ] = [b_I; b_Γ + S z_Γ]
//!   K [x_F; x_Γ] = [b_F; S (x_Γ − z_Γ)]
//! ```
//!
//! This is what a factorization of the whole matrix with the band eliminated last would do; the
//! far field's part of it is simply not repeated.

use faer::linalg::matmul::matmul;
use faer::{Accum, ColMut, ColRef, Mat, Par};

use super::linsolve::{checked_solve, DirectSolver, SolveError, SolverKind};
use super::sparse::SparseMatrix;

/// How a solver factors a matrix that changed since its last factorization (the flow solver's
/// choice; a case's `numerics.factorization`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Factorization {
    /// The whole matrix, every time.
    Whole,
    /// By substructuring ([`Substructured`]): the far field once per placement of a band around
    /// what changes (the particles, the moving elements), the band every time; the whole matrix
    /// when there is no band or it is too large to pay.
    #[default]
    Band,
}

impl Factorization {
    /// Whether this is the default, [`Factorization::Band`].
    pub fn is_band(&self) -> bool {
        *self == Factorization::Band
    }
}

/// The dofs of a band and of its far field, with K and its condensation onto Γ (fixed while the
/// band stays), and M (refactored for every new matrix).
pub struct Substructured {
    /// K index → dof: far dofs, then Γ.
    k_dofs: Vec<usize>,
    /// Number of far dofs (K indices below are F, the rest Γ).
    n_far: usize,
    /// The positions in A's values of K's entries outside Γ × Γ, ascending, and the values K
    /// was factored with there (what [`fits`](Self::fits) compares, in the order of A's storage).
    k_src: Vec<usize>,
    k_values: Vec<f64>,
    /// A's entries in Γ × Γ (M's lower triangle): where M's Γ block takes S₀ + (A_ΓΓ − A_ΓΓ,₀).
    gamma_entries: Vec<GammaEntry>,
    k_solver: DirectSolver,
    /// S on Γ, in the order of the Γ part of `k_dofs` (= of `m_dofs`).
    schur: Mat<f64>,
    /// M index → dof: band interior, then Γ.
    m_dofs: Vec<usize>,
    /// Number of interior dofs.
    n_interior: usize,
    m: SparseMatrix,
    /// Position in A's values of each of M's values outside the Γ × Γ block.
    m_src: Vec<usize>,
    m_solver: DirectSolver,
    /// Whether M is factored with its current values.
    m_factored: bool,
    /// The first of K's trailing supernodes, which hold Γ, and its first position.
    k_trailing: (usize, usize),
    /// Work vectors in K and M numbering, z_Γ, and two in K's factor positions.
    kb: Vec<f64>,
    y: Vec<f64>,
    v: Vec<f64>,
    mb: Vec<f64>,
    z: Vec<f64>,
    last_polish: usize,
}

impl std::fmt::Debug for Substructured {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Substructured")
            .field("far", &self.n_far)
            .field("interface", &(self.k_dofs.len() - self.n_far))
            .field("interior", &self.n_interior)
            .finish()
    }
}

/// Sizes of a [`Substructured`] split.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Split {
    /// Far dofs (F).
    pub far: usize,
    /// Interface dofs (Γ).
    pub interface: usize,
    /// Band interior dofs (I).
    pub interior: usize,
}

impl Substructured {
    /// Splits the dofs of `a` into the band (`band[d]`) and the far field, factors K (the far
    /// field and Γ, eliminated in the order of `order`, a fill-reducing order of all dofs, with
    /// Γ last) and condenses it onto Γ, and analyses M. The band must not be empty.
    pub fn new(a: &SparseMatrix, band: &[bool], order: &[usize]) -> Result<Self, SolveError> {
        Self::with_interface(a, band, &Self::interface(a, band), order)
    }

    /// [`new`](Self::new) with Γ already found ([`interface`](Self::interface)).
    pub fn with_interface(
        a: &SparseMatrix,
        band: &[bool],
        gamma: &[bool],
        order: &[usize],
    ) -> Result<Self, SolveError> {
        // numberings in the elimination order: K = F then Γ, M = I then Γ
        let far: Vec<usize> = order.iter().copied().filter(|&d| !band[d]).collect();
        let iface: Vec<usize> = order.iter().copied().filter(|&d| gamma[d]).collect();
        let inner: Vec<usize> = order
            .iter()
            .copied()
            .filter(|&d| band[d] && !gamma[d])
            .collect();
        let k_dofs: Vec<usize> = far.iter().chain(&iface).copied().collect();
        let m_dofs: Vec<usize> = inner.iter().chain(&iface).copied().collect();
        let (n_far, n_interior, n_gamma) = (far.len(), inner.len(), iface.len());

        let (mut k, k_src) = submatrix(a, &k_dofs, None);
        k.values
            .iter_mut()
            .zip(&k_src)
            .for_each(|(v, &p)| *v = a.values[p]);
        // K's entries outside Γ × Γ (both dofs in K = F ∪ Γ, one of them in F): those that must
        // not change while the band stays, read from A in its storage order (ascending positions)
        let in_k = |d: usize| !band[d] || gamma[d];
        let k_src: Vec<usize> = (0..a.n())
            .filter(|&j| in_k(j))
            .flat_map(|j| {
                let (rows, range) = a.column(j);
                rows.iter()
                    .zip(range)
                    .filter(move |(&i, _)| in_k(i) && (!band[i] || !band[j]))
                    .map(|(_, p)| p)
            })
            .collect();
        let k_order: Vec<usize> = (0..k_dofs.len()).collect();
        let mut k_solver = DirectSolver::analyze_with_order(&k, SolverKind::Lblt, &k_order)?;
        k_solver.factor(&k)?;
        let gamma_k: Vec<usize> = (n_far..k_dofs.len()).collect();
        let schur = k_solver.schur_complement(&gamma_k)?;
        let k_trailing = k_solver.trailing_supernodes(&gamma_k)?;
        let k_values = k_src.iter().map(|&p| a.values[p]).collect();

        let (m, m_src) = submatrix(a, &m_dofs, Some(n_interior));
        let gamma_entries = gamma_block_entries(a, &m, &m_dofs, n_interior, &schur);
        let m_order: Vec<usize> = (0..m_dofs.len()).collect();
        let m_solver = DirectSolver::analyze_with_order(&m, SolverKind::Lblt, &m_order)?;
        Ok(Self {
            kb: vec![0.0; k_dofs.len()],
            y: vec![0.0; k_dofs.len()],
            v: vec![0.0; k_dofs.len()],
            k_trailing,
            mb: vec![0.0; m_dofs.len()],
            z: vec![0.0; n_gamma],
            k_dofs,
            n_far,
            k_src,
            k_values,
            gamma_entries,
            k_solver,
            schur,
            m_dofs,
            n_interior,
            m,
            m_src,
            m_solver,
            m_factored: false,
            last_polish: 0,
        })
    }

    /// Γ, the dofs of the band (`band[d]`) coupled to a dof outside it, by dof.
    ///
    /// # Panics
    /// If `band` does not have one flag per dof of `a`.
    pub fn interface(a: &SparseMatrix, band: &[bool]) -> Vec<bool> {
        let n = a.n();
        assert_eq!(band.len(), n, "one band flag per dof");
        let mut gamma = vec![false; n];
        for j in (0..n).filter(|&j| !band[j]) {
            for &i in a.column(j).0 {
                if band[i] {
                    gamma[i] = true;
                }
            }
        }
        gamma
    }

    /// Sizes of the split.
    pub fn split(&self) -> Split {
        Split {
            far: self.n_far,
            interface: self.k_dofs.len() - self.n_far,
            interior: self.n_interior,
        }
    }

    /// Whether `a` has the values this split was made for in the far field's rows and columns
    /// (bitwise; the band's, Γ × Γ included, may differ): only then may [`factor`](Self::factor)
    /// take it.
    pub fn fits(&self, a: &SparseMatrix) -> bool {
        self.k_src
            .iter()
            .zip(&self.k_values)
            .all(|(&p, &v)| a.values[p].to_bits() == v.to_bits())
    }

    /// Factors M for `a`, which must [`fit`](Self::fits), unless its values are those of the
    /// last factorization; returns whether it factored.
    pub fn factor(&mut self, a: &SparseMatrix) -> Result<bool, SolveError> {
        debug_assert!(self.fits(a), "the far field changed: make a new split");
        let ni = self.n_interior;
        let ng = self.m_dofs.len() - ni;
        let first = !self.m_factored;
        let mut changed = first;
        let mut src = self.m_src.iter();
        for j in 0..self.m_dofs.len() {
            let (rows, range) = self.m.column(j);
            // the Γ × Γ block is S₀'s lower triangle, the last rows of a Γ column: written once,
            // then A_ΓΓ's changes on top (below)
            let dense = if j >= ni { ng - (j - ni) } else { 0 };
            let sparse_len = rows.len() - dense;
            let vals = &mut self.m.values[range];
            for v in &mut vals[..sparse_len] {
                let new = a.values[*src.next().expect("one source per entry")];
                changed |= v.to_bits() != new.to_bits();
                *v = new;
            }
            if first && dense > 0 {
                vals[sparse_len..].copy_from_slice(
                    &self
                        .schur
                        .col(j - ni)
                        .try_as_col_major()
                        .expect("contiguous")
                        .as_slice()[j - ni..],
                );
            }
        }
        // S₀ + (A_ΓΓ − A_ΓΓ,₀): S₀ itself where A_ΓΓ is the placement's
        for g in &mut self.gamma_entries {
            let new = a.values[g.a_pos];
            if first || new.to_bits() != g.last.to_bits() {
                changed = true;
                g.last = new;
                self.m.values[g.m_pos] = if new.to_bits() == g.a0.to_bits() {
                    g.s0
                } else {
                    g.s0 + (new - g.a0)
                };
            }
        }
        if changed {
            self.m_factored = false;
            self.m_solver.factor(&self.m)?;
            self.m_factored = true;
        }
        Ok(changed)
    }

    /// Solves A x = b in place for the last factored A (`rhs` holds b on entry, x on exit).
    pub fn solve_in_place(&mut self, rhs: &mut [f64]) -> Result<(), SolveError> {
        if !self.m_factored {
            return Err(SolveError::NotFactored);
        }
        let (nf, ni) = (self.n_far, self.n_interior);
        let k = &self.k_solver;
        let at = k.positions();
        let (s0, p1) = self.k_trailing;
        // K [z_F; z_Γ] = [b_F; 0]: the forward substitution y = L⁻¹ P D [b_F; 0] is kept for the
        // second solve; z_Γ needs B⁻¹ and L⁻ᵀ on the trailing supernodes (which hold Γ) only
        for (kb, &d) in self.kb.iter_mut().zip(&self.k_dofs[..nf]) {
            *kb = rhs[d];
        }
        self.kb[nf..].iter_mut().for_each(|v| *v = 0.0);
        k.to_positions(&self.kb, at, &mut self.y);
        k.forward(&mut self.y, 0)?;
        self.v.copy_from_slice(&self.y);
        k.diagonal(&mut self.v, s0)?;
        k.backward(&mut self.v, s0)?;
        k.from_positions(&self.v, at, &mut self.kb);
        self.z.copy_from_slice(&self.kb[nf..]);
        // M [x_I; x_Γ] = [b_I; b_Γ + S z_Γ]
        for (mb, &d) in self.mb.iter_mut().zip(&self.m_dofs) {
            *mb = rhs[d];
        }
        gemv(
            ColMut::from_slice_mut(&mut self.mb[ni..]),
            &self.schur,
            ColRef::from_slice(&self.z),
        );
        self.m_solver.solve_in_place(&mut self.mb)?;
        // K [x_F; x_Γ] = [b_F; S (x_Γ − z_Γ)]: L⁻¹ of the right-hand side is y plus L⁻¹ of its
        // Γ part, which lives in the trailing supernodes
        for (z, x) in self.z.iter_mut().zip(&self.mb[ni..]) {
            *z = x - *z;
        }
        self.kb.iter_mut().for_each(|v| *v = 0.0);
        gemv(
            ColMut::from_slice_mut(&mut self.kb[nf..]),
            &self.schur,
            ColRef::from_slice(&self.z),
        );
        k.to_positions(&self.kb, at, &mut self.v);
        k.forward(&mut self.v, s0)?;
        for (v, y) in self.v[p1..].iter_mut().zip(&self.y[p1..]) {
            *v += y;
        }
        self.v[..p1].copy_from_slice(&self.y[..p1]);
        k.diagonal(&mut self.v, 0)?;
        k.backward(&mut self.v, 0)?;
        k.from_positions(&self.v, at, &mut self.kb);
        for (kb, &d) in self.kb.iter().zip(&self.k_dofs[..nf]) {
            rhs[d] = *kb;
        }
        for (mb, &d) in self.mb.iter().zip(&self.m_dofs) {
            rhs[d] = *mb;
        }
        Ok(())
    }

    /// Solves A x = b and checks the relative residual against `tol`, polishing by GMRES
    /// preconditioned with this solver when it misses
    /// ([`checked_solve`]).
    pub fn solve_checked(
        &mut self,
        a: &SparseMatrix,
        b: &[f64],
        x: &mut [f64],
        tol: f64,
    ) -> Result<f64, SolveError> {
        let (res, polish) = checked_solve(a, b, x, tol, &mut |v| self.solve_in_place(v))?;
        self.last_polish = polish;
        Ok(res)
    }

    /// GMRES iterations of the last [`solve_checked`](Self::solve_checked).
    pub fn last_polish_iterations(&self) -> usize {
        self.last_polish
    }
}

/// An entry of A in Γ × Γ, in M's lower triangle.
#[derive(Debug, Clone, Copy)]
struct GammaEntry {
    /// Position in A's values.
    a_pos: usize,
    /// Position in M's values.
    m_pos: usize,
    /// A's value at the placement, and S's there.
    a0: f64,
    s0: f64,
    /// A's value M was last written with.
    last: f64,
}

/// The entries of A in Γ × Γ with their places in M's dense Γ block (lower triangle: rows from
/// the column down, M's Γ columns ending with the block's rows `j..`), and S₀'s values there.
fn gamma_block_entries(
    a: &SparseMatrix,
    m: &SparseMatrix,
    m_dofs: &[usize],
    n_interior: usize,
    schur: &Mat<f64>,
) -> Vec<GammaEntry> {
    let n_m = m_dofs.len();
    let ng = n_m - n_interior;
    let mut local = vec![usize::MAX; a.n()];
    m_dofs.iter().enumerate().for_each(|(k, &d)| local[d] = k);
    let mut entries = Vec::new();
    for j in n_interior..n_m {
        let (m_rows, m_range) = m.column(j);
        let dense_start = m_range.start + m_rows.len() - (ng - (j - n_interior));
        let (rows, range) = a.column(m_dofs[j]);
        for (&i, p) in rows.iter().zip(range) {
            let k = local[i];
            if k != usize::MAX && k >= j {
                let a0 = a.values[p];
                entries.push(GammaEntry {
                    a_pos: p,
                    m_pos: dense_start + (k - j),
                    a0,
                    s0: schur[(k - n_interior, j - n_interior)],
                    last: a0,
                });
            }
        }
    }
    entries
}

/// y += S x (dense).
fn gemv(y: ColMut<'_, f64>, s: &Mat<f64>, x: ColRef<'_, f64>) {
    matmul(y, Accum::Add, s, x, 1.0, Par::Seq);
}

/// The submatrix of `a` on `dofs` (new index → dof) as a pattern, and for each of its entries
/// the position of the value in `a`. With `dense_from = Some(k)`, the lower triangle of the
/// block of the indices `k..` is stored dense and its entries have no source (they come last in
/// each of its columns; the block's upper triangle is left out: the factorization reads the lower
/// triangle only).
fn submatrix(
    a: &SparseMatrix,
    dofs: &[usize],
    dense_from: Option<usize>,
) -> (SparseMatrix, Vec<usize>) {
    let m = dofs.len();
    let mut local = vec![usize::MAX; a.n()];
    dofs.iter().enumerate().for_each(|(k, &d)| local[d] = k);
    let dense = dense_from.unwrap_or(m);
    let mut col_ptr = Vec::with_capacity(m + 1);
    let mut row_idx = Vec::new();
    let mut src = Vec::new();
    let mut entries: Vec<(usize, usize)> = Vec::new();
    col_ptr.push(0);
    for (j, &d) in dofs.iter().enumerate() {
        entries.clear();
        let (rows, range) = a.column(d);
        for (&i, p) in rows.iter().zip(range) {
            let k = local[i];
            if k != usize::MAX && !(j >= dense && k >= dense) {
                entries.push((k, p));
            }
        }
        entries.sort_unstable();
        for &(k, p) in &entries {
            row_idx.push(k);
            src.push(p);
        }
        if j >= dense {
            // the lower triangle (the factorization reads no other)
            row_idx.extend(j..m);
        }
        col_ptr.push(row_idx.len());
    }
    (SparseMatrix::from_pattern(m, col_ptr, row_idx), src)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fem::sparse::PatternBuilder;

    /// A Stokes-like saddle-point matrix on a 1D chain: velocities 0..n (tridiagonal, SPD), a
    /// pressure per three velocities.
    fn chain(n: usize, band_scale: f64, band: std::ops::Range<usize>) -> SparseMatrix {
        let np = n / 3;
        let mut pb = PatternBuilder::new(n + np);
        for i in 0..n - 1 {
            pb.add_group(&[i, i + 1]);
        }
        for p in 0..np {
            pb.add_coupling(&[n + p], &[3 * p, 3 * p + 1, 3 * p + 2]);
        }
        let mut a = pb.build();
        for i in 0..n - 1 {
            // the band's elements change between matrices
            let s = if band.contains(&i) && band.contains(&(i + 1)) {
                band_scale
            } else {
                1.0 + 0.01 * i as f64
            };
            for (r, c, v) in [(i, i, s), (i + 1, i + 1, s), (i, i + 1, -s), (i + 1, i, -s)] {
                a.add(r, c, v);
            }
        }
        a.add(0, 0, 1.0);
        for p in 0..np {
            for c in [3 * p, 3 * p + 1, 3 * p + 2] {
                a.add(n + p, c, 1.0);
                a.add(c, n + p, 1.0);
            }
        }
        a
    }

    /// The band solver's solution of `a x = b` is the whole factorization's.
    fn assert_solves_as_whole(sub: &mut Substructured, a: &SparseMatrix, b: &[f64], what: &str) {
        // relative residual accepted (the flow solver's)
        const TOL: f64 = 1e-10;
        let nd = a.n();
        assert!(sub.fits(a), "{what}: only the band changed");
        sub.factor(a).unwrap();
        let mut x = vec![0.0; nd];
        let res = sub.solve_checked(a, b, &mut x, TOL).unwrap();
        assert!(res <= TOL, "{what}: residual {res:.2e}");
        let mut whole = DirectSolver::analyze(a, SolverKind::Lblt).unwrap();
        whole.factor(a).unwrap();
        let mut y = vec![0.0; nd];
        whole.solve_checked(a, b, &mut y, TOL).unwrap();
        let err = x
            .iter()
            .zip(&y)
            .map(|(p, q)| (p - q).abs())
            .fold(0.0, f64::max);
        let size = y.iter().map(|v| v.abs()).fold(0.0, f64::max);
        assert!(
            err <= 1e-8 * size,
            "{what}: solutions differ by {err:.2e} of {size:.2e}"
        );
        assert_eq!(
            sub.last_polish_iterations(),
            0,
            "{what}: exact up to round-off"
        );
    }

    /// The chain's band: the velocities 27..48 and their pressures (Γ = velocities 27 and 47).
    fn chain_band(n: usize, nd: usize) -> Vec<bool> {
        (0..nd)
            .map(|d| {
                if d < n {
                    (27..48).contains(&d)
                } else {
                    (9..16).contains(&(d - n))
                }
            })
            .collect()
    }

    /// The chain of 90 velocities whose elements 30..45 change, and its band solver.
    fn chain_split() -> (usize, std::ops::Range<usize>, usize, Substructured) {
        let (n, range) = (90, 30..45);
        let a0 = chain(n, 2.0, range.clone());
        let nd = a0.n();
        let order: Vec<usize> = (0..nd).collect();
        let sub = Substructured::new(&a0, &chain_band(n, nd), &order).unwrap();
        (n, range, nd, sub)
    }

    #[test]
    fn substructured_solves_match_the_whole_factorization() {
        let (n, range, nd, mut sub) = chain_split();
        assert!(sub.split().interface > 0 && sub.split().interior > 0);
        let b: Vec<f64> = (0..nd).map(|i| (0.3 * i as f64).cos()).collect();
        for scale in [2.0, 1e-4, 50.0] {
            let a = chain(n, scale, range.clone());
            assert!(sub.factor(&a).unwrap(), "a new band");
            assert!(!sub.factor(&a).unwrap(), "the same band");
            assert_solves_as_whole(&mut sub, &a, &b, &format!("band scale {scale}"));
        }
        // a change outside the band is noticed
        let mut far = chain(n, 2.0, range);
        far.add(3, 3, 1.0);
        assert!(!sub.fits(&far));
    }

    /// Γ's own entries may change with the band (S is linear in A_ΓΓ): the solution follows
    /// them, and back to the placement's values M is again S₀'s.
    #[test]
    fn the_interface_block_may_change() {
        let (n, range, nd, mut sub) = chain_split();
        assert_eq!(sub.split().interface, 2, "Γ = velocities 27 and 47");
        let b: Vec<f64> = (0..nd).map(|i| (0.7 * i as f64).sin()).collect();
        for (d27, d47) in [(0.0, 0.0), (0.5, -0.25), (3.0, 1e-3), (0.0, 0.0)] {
            let mut a = chain(n, 7.0, range.clone());
            a.add(27, 27, d27);
            a.add(47, 47, d47);
            assert_solves_as_whole(&mut sub, &a, &b, &format!("Γ diagonal + ({d27}, {d47})"));
        }
        let mut a = chain(n, 2.0, range);
        sub.factor(&a).unwrap();
        let with_s0 = sub.m.values.clone();
        a.add(47, 47, 0.5);
        assert!(sub.factor(&a).unwrap(), "a change in Γ × Γ refactors");
        assert_ne!(sub.m.values, with_s0);
        a.add(47, 47, -0.5);
        sub.factor(&a).unwrap();
        assert_eq!(sub.m.values, with_s0, "S₀ again, bitwise");
    }
}
