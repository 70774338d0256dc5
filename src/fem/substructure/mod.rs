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
//!
//! K keeps the caller's elimination order (a nested dissection of the mesh); the band interior
//! is reordered by AMD on its own node-block graph, which 200×50 with three particles factors
//! 7 % faster and with 12 % less fill than the caller's order restricted to it (its separators
//! are the whole mesh's, not the band's). M is factored without pivots first
//! ([`Pivoting::WhenNeeded`]): its dense Γ block, which dominates, factors at the dense kernels'
//! speed; a solve whose residual misses the tolerance refactors M with pivoting before any
//! polishing ([`Substructured::pivoted_refactors`]). So is K, checked once by a test solve at
//! the placement; its Γ then holds the factor's last positions, and S₀ is read from the Γ
//! block alone.
//!
//! Dofs the caller calls inert (those deep inside a particle: identity rows, whose couplings the
//! pattern stores as zeros so that a moving particle does not change it) have their zero
//! couplings left out of M's pattern, so that M's ordering and factorization see them decoupled
//! (a/12, three particles: M's factorization 0.189 → 0.146 s); [`Substructured::fits`] checks
//! that they are still zero.

use std::collections::HashMap;

use faer::linalg::matmul::matmul;
use faer::{Accum, ColMut, ColRef, Mat, Par};

use super::linsolve::{
    checked_solve_repivoting, DirectSolver, DofBlocks, Pivoting, Repivot, SolveError, SolverKind,
};
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
    /// Positions in A's values of the inert dofs' couplings left out of M (zero at the
    /// placement; [`fits`](Self::fits) checks that they still are).
    m_zero: Vec<usize>,
    m_solver: DirectSolver,
    /// Whether M is factored with its current values.
    m_factored: bool,
    /// Factorizations of M redone with pivoting because the unpivoted one solved inaccurately.
    pivoted_refactors: usize,
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
    /// field and Γ, eliminated in the order `blocks` gives all dofs, with Γ last) and condenses
    /// it onto Γ, and analyses M (the band interior in the AMD order of its blocks, then Γ). The
    /// band must not be empty. K is factored without pivots unless a test solve misses `tol`,
    /// the relative residual the solves must meet ([`DirectSolver::check_unpivoted`]).
    pub fn new(
        a: &SparseMatrix,
        band: &[bool],
        blocks: &DofBlocks,
        tol: f64,
    ) -> Result<Self, SolveError> {
        let inert = vec![false; a.n()];
        Self::with_interface(a, band, &Self::interface(a, band), &inert, blocks, tol)
    }

    /// [`new`](Self::new) with Γ already found ([`interface`](Self::interface)), and the band's
    /// inert dofs (`inert[d]`): dofs whose couplings to other dofs the caller expects to stay zero
    /// while the band stays (the dofs deep inside a particle, identity rows). Their off-diagonal
    /// entries in M's sparse part that are zero now are left out of M's pattern, so that M's
    /// ordering and factorization see them decoupled, and [`fits`](Self::fits) checks that they
    /// are still zero.
    pub fn with_interface(
        a: &SparseMatrix,
        band: &[bool],
        gamma: &[bool],
        inert: &[bool],
        blocks: &DofBlocks,
        tol: f64,
    ) -> Result<Self, SolveError> {
        // numberings in the elimination order: K = F then Γ, M = I then Γ
        let order = blocks.elimination_order(a)?;
        let far: Vec<usize> = order.iter().copied().filter(|&d| !band[d]).collect();
        let iface: Vec<usize> = order.iter().copied().filter(|&d| gamma[d]).collect();
        assert_eq!(inert.len(), a.n(), "one inert flag per dof");
        let inner = interior_order(a, band, gamma, inert, blocks)?;
        let k_dofs: Vec<usize> = far.iter().chain(&iface).copied().collect();
        let m_dofs: Vec<usize> = inner.iter().chain(&iface).copied().collect();
        let (n_far, n_interior, n_gamma) = (far.len(), inner.len(), iface.len());

        let (mut k, k_src, _) = submatrix(a, &k_dofs, None, None);
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
        k_solver.set_pivoting(Pivoting::WhenNeeded);
        k_solver.factor(&k)?;
        k_solver.check_unpivoted(&k, tol)?;
        let gamma_k: Vec<usize> = (n_far..k_dofs.len()).collect();
        let schur = k_solver.schur_complement(&gamma_k)?;
        let k_trailing = k_solver.trailing_supernodes(&gamma_k)?;
        let k_values = k_src.iter().map(|&p| a.values[p]).collect();

        let (m, m_src, m_zero) = submatrix(a, &m_dofs, Some(n_interior), Some(inert));
        let gamma_entries = gamma_block_entries(a, &m, &m_dofs, n_interior, &schur);
        let m_order: Vec<usize> = (0..m_dofs.len()).collect();
        let mut m_solver = DirectSolver::analyze_with_order(&m, SolverKind::Lblt, &m_order)?;
        m_solver.set_pivoting(Pivoting::WhenNeeded);
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
            m_zero,
            m_solver,
            m_factored: false,
            pivoted_refactors: 0,
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
    /// (bitwise; the band's, Γ × Γ included, may differ) and zeros where M leaves out the inert
    /// dofs' couplings: only then may [`factor`](Self::factor) take it.
    pub fn fits(&self, a: &SparseMatrix) -> bool {
        self.k_src
            .iter()
            .zip(&self.k_values)
            .all(|(&p, &v)| a.values[p].to_bits() == v.to_bits())
            && self.m_zero.iter().all(|&p| a.values[p] == 0.0)
    }

    /// Number of A's entries left out of M as inert couplings.
    pub fn inert_entries(&self) -> usize {
        self.m_zero.len()
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

    /// Solves A x = b and checks the relative residual against `tol`; when it misses with M
    /// factored without pivots, M is redone with pivoting and the solve repeated (K was checked
    /// at the placement);
    /// when it still misses, GMRES preconditioned with this solver polishes
    /// ([`checked_solve_repivoting`]).
    pub fn solve_checked(
        &mut self,
        a: &SparseMatrix,
        b: &[f64],
        x: &mut [f64],
        tol: f64,
    ) -> Result<f64, SolveError> {
        let (res, polish) = checked_solve_repivoting(self, a, b, x, tol)?;
        self.last_polish = polish;
        Ok(res)
    }

    /// GMRES iterations of the last [`solve_checked`](Self::solve_checked).
    pub fn last_polish_iterations(&self) -> usize {
        self.last_polish
    }

    /// Factorizations of M and K redone with pivoting because the unpivoted one missed the
    /// residual tolerance, since the placement (K's check at the placement included).
    pub fn pivoted_refactors(&self) -> usize {
        self.pivoted_refactors + self.k_solver.pivoted_refactors()
    }
}

impl Repivot for Substructured {
    fn solve_factored(&mut self, v: &mut [f64]) -> Result<(), SolveError> {
        self.solve_in_place(v)
    }

    fn unpivoted_in_use(&self) -> bool {
        self.m_solver.is_unpivoted()
    }

    /// M with pivoting (K was checked at the placement).
    fn repivot(&mut self, _a: &SparseMatrix) -> Result<(), SolveError> {
        self.pivoted_refactors += 1;
        self.m_factored = false;
        self.m_solver.factor_pivoted(&self.m)?;
        self.m_factored = true;
        Ok(())
    }
}

/// The band interior (band dofs outside Γ) in the order of block AMD on its own graph: the
/// blocks and their classes of `blocks` (each pressure after its node's velocities, which the
/// unpivoted factorization of M needs), without their given block order.
fn interior_order(
    a: &SparseMatrix,
    band: &[bool],
    gamma: &[bool],
    inert: &[bool],
    blocks: &DofBlocks,
) -> Result<Vec<usize>, SolveError> {
    let inner: Vec<usize> = (0..a.n()).filter(|&d| band[d] && !gamma[d]).collect();
    let (sub, _, _) = submatrix(a, &inner, None, Some(inert));
    // the blocks that have interior dofs, numbered anew
    let mut renumber = HashMap::new();
    let block: Vec<u32> = inner
        .iter()
        .map(|&d| {
            let next = renumber.len() as u32;
            *renumber.entry(blocks.block[d]).or_insert(next)
        })
        .collect();
    let sub_blocks = DofBlocks {
        block,
        class: inner.iter().map(|&d| blocks.class[d]).collect(),
        order: None,
    };
    let sub_order = sub_blocks.elimination_order(&sub)?;
    Ok(sub_order.into_iter().map(|k| inner[k]).collect())
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

/// The submatrix of `a` on `dofs` (new index → dof) as a pattern, for each of its entries the
/// position of the value in `a`, and the positions in `a` of the entries left out. With
/// `dense_from = Some(k)`, the lower triangle of the block of the indices `k..` is stored dense
/// and its entries have no source (they come last in each of its columns; the block's upper
/// triangle is left out: the factorization reads the lower triangle only). With `inert`, the
/// off-diagonal entries of an inert dof's row or column that are zero in `a` are left out (not
/// those of the dense block).
fn submatrix(
    a: &SparseMatrix,
    dofs: &[usize],
    dense_from: Option<usize>,
    inert: Option<&[bool]>,
) -> (SparseMatrix, Vec<usize>, Vec<usize>) {
    let m = dofs.len();
    let mut local = vec![usize::MAX; a.n()];
    dofs.iter().enumerate().for_each(|(k, &d)| local[d] = k);
    let dense = dense_from.unwrap_or(m);
    let mut col_ptr = Vec::with_capacity(m + 1);
    let mut row_idx = Vec::new();
    let mut src = Vec::new();
    let mut left_out = Vec::new();
    let mut entries: Vec<(usize, usize)> = Vec::new();
    let decoupled = |i: usize, d: usize, p: usize| {
        inert.is_some_and(|f| i != d && (f[i] || f[d]) && a.values[p] == 0.0)
    };
    col_ptr.push(0);
    for (j, &d) in dofs.iter().enumerate() {
        entries.clear();
        let (rows, range) = a.column(d);
        for (&i, p) in rows.iter().zip(range) {
            let k = local[i];
            if k != usize::MAX && !(j >= dense && k >= dense) {
                if decoupled(i, d, p) {
                    left_out.push(p);
                } else {
                    entries.push((k, p));
                }
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
    (
        SparseMatrix::from_pattern(m, col_ptr, row_idx),
        src,
        left_out,
    )
}

#[cfg(test)]
mod tests;
