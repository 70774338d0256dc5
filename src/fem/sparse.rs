//! Sparse matrices in a fixed compressed-column pattern, built once per mesh from element dof lists,
//! and the element scatter (with symmetric elimination of constrained dofs).
//!
//! The pattern holds both triangles (the symmetric solver reads the lower one). Constrained dofs
//! (Dirichlet values, dofs of inactive XFEM elements) keep their place in the pattern and become
//! identity rows and columns, so the symbolic factorization never changes during a run.

use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};

/// A square sparse matrix with a fixed pattern (CSC, sorted row indices, full symmetric pattern).
#[derive(Debug, Clone)]
pub struct SparseMatrix {
    n: usize,
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    /// Values, aligned with the pattern.
    pub values: Vec<f64>,
}

/// Builds a pattern from element dof lists: every pair of dofs that share an element is coupled.
#[derive(Debug)]
pub struct PatternBuilder {
    cols: Vec<Vec<u32>>,
}

impl PatternBuilder {
    /// Empty pattern with `n` dofs (the diagonal is always present).
    pub fn new(n: usize) -> Self {
        Self {
            cols: (0..n).map(|j| vec![j as u32]).collect(),
        }
    }

    /// Couples all dofs of one element (or any group of dofs, e.g. a rigid-body unknown with a
    /// particle's boundary dofs).
    pub fn add_group(&mut self, dofs: &[usize]) {
        for &j in dofs {
            let col = &mut self.cols[j];
            col.extend(dofs.iter().map(|&i| i as u32));
            if col.len() > 512 {
                col.sort_unstable();
                col.dedup();
            }
        }
    }

    /// Couples two disjoint dof groups (rows `a` with columns `b` and vice versa).
    pub fn add_coupling(&mut self, a: &[usize], b: &[usize]) {
        for &j in b {
            self.cols[j].extend(a.iter().map(|&i| i as u32));
        }
        for &j in a {
            self.cols[j].extend(b.iter().map(|&i| i as u32));
        }
    }

    /// Finalizes the pattern into a zero matrix.
    pub fn build(self) -> SparseMatrix {
        let n = self.cols.len();
        let mut col_ptr = Vec::with_capacity(n + 1);
        col_ptr.push(0);
        let mut row_idx = Vec::new();
        for mut col in self.cols {
            col.sort_unstable();
            col.dedup();
            row_idx.extend(col.iter().map(|&i| i as usize));
            col_ptr.push(row_idx.len());
        }
        let nnz = row_idx.len();
        SparseMatrix {
            n,
            col_ptr,
            row_idx,
            values: vec![0.0; nnz],
        }
    }
}

/// The pattern of a scalar Q1 field: vertices coupled within each element (`groups`).
pub fn q1_pattern(n_vertices: usize, groups: &[[usize; 4]]) -> SparseMatrix {
    let mut pb = PatternBuilder::new(n_vertices);
    for g in groups {
        pb.add_group(g);
    }
    pb.build()
}

impl SparseMatrix {
    /// A zero matrix with the pattern given by columns (`col_ptr`, `row_idx` of compressed
    /// columns; the rows of each column sorted, without repeats).
    ///
    /// # Panics
    /// Panics if the pattern is not valid compressed-column storage.
    pub fn from_pattern(n: usize, col_ptr: Vec<usize>, row_idx: Vec<usize>) -> Self {
        // validates: sorted, in range, consistent pointers
        SymbolicSparseColMatRef::new_checked(n, n, &col_ptr, None, &row_idx);
        let nnz = row_idx.len();
        Self {
            n,
            col_ptr,
            row_idx,
            values: vec![0.0; nnz],
        }
    }

    /// The rows of column `j` and the range of their values in [`values`](Self::values).
    #[inline]
    pub fn column(&self, j: usize) -> (&[usize], std::ops::Range<usize>) {
        let range = self.col_ptr[j]..self.col_ptr[j + 1];
        (&self.row_idx[range.clone()], range)
    }

    /// The pattern (column pointers, row indices) of the transpose of the lower triangle: column
    /// j holds the rows i ≤ j for which a_ji is stored — the upper triangle as a symbolic
    /// analysis reads it, for a matrix that may store its lower triangle alone.
    pub fn upper_from_lower(&self) -> (Vec<usize>, Vec<usize>) {
        let n = self.n;
        let mut col_ptr = vec![0usize; n + 1];
        for j in 0..n {
            for &i in self.column(j).0.iter().filter(|&&i| i >= j) {
                col_ptr[i + 1] += 1;
            }
        }
        for j in 0..n {
            col_ptr[j + 1] += col_ptr[j];
        }
        let mut next = col_ptr.clone();
        let mut row_idx = vec![0usize; col_ptr[n]];
        // (columns ascending: each column's rows come out sorted)
        for j in 0..n {
            for &i in self.column(j).0.iter().filter(|&&i| i >= j) {
                row_idx[next[i]] = j;
                next[i] += 1;
            }
        }
        (col_ptr, row_idx)
    }

    /// Dimension.
    pub fn n(&self) -> usize {
        self.n
    }

    /// Number of stored entries (both triangles).
    pub fn nnz(&self) -> usize {
        self.row_idx.len()
    }

    /// Sets all values to zero (the pattern stays).
    pub fn zero(&mut self) {
        self.values.iter_mut().for_each(|v| *v = 0.0);
    }

    /// Position of entry (i, j) in `values`.
    ///
    /// # Panics
    /// Panics if (i, j) is not in the pattern (a broken assembly contract).
    #[inline]
    pub fn position(&self, i: usize, j: usize) -> usize {
        let (s, e) = (self.col_ptr[j], self.col_ptr[j + 1]);
        match self.row_idx[s..e].binary_search(&i) {
            Ok(k) => s + k,
            Err(_) => panic!("entry ({i}, {j}) not in the sparsity pattern"),
        }
    }

    /// Position of entry (i, j) in `values`, or `None` outside the pattern.
    #[inline]
    pub fn try_position(&self, i: usize, j: usize) -> Option<usize> {
        let (s, e) = (self.col_ptr[j], self.col_ptr[j + 1]);
        self.row_idx[s..e].binary_search(&i).ok().map(|k| s + k)
    }

    /// Adds `v` to entry (i, j).
    #[inline]
    pub fn add(&mut self, i: usize, j: usize, v: f64) {
        let p = self.position(i, j);
        self.values[p] += v;
    }

    /// Value of entry (i, j), zero outside the pattern.
    pub fn get(&self, i: usize, j: usize) -> f64 {
        let (s, e) = (self.col_ptr[j], self.col_ptr[j + 1]);
        self.row_idx[s..e]
            .binary_search(&i)
            .map(|k| self.values[s + k])
            .unwrap_or(0.0)
    }

    /// Scatters a dense local matrix `k` (row-major, `dofs.len()`²) and local vector `f` into the
    /// global system. Constrained dofs (`fixed[d] = Some(g)`) are eliminated symmetrically: their
    /// rows are skipped and their columns moved to the right-hand side as `−K_ij g_j`.
    pub fn scatter(
        &mut self,
        dofs: &[usize],
        k: &[f64],
        f: &[f64],
        rhs: &mut [f64],
        fixed: &[Option<f64>],
    ) {
        let nd = dofs.len();
        debug_assert_eq!(k.len(), nd * nd);
        for (b, &j) in dofs.iter().enumerate() {
            if let Some(g) = fixed[j] {
                for (a, &i) in dofs.iter().enumerate() {
                    if fixed[i].is_none() {
                        rhs[i] -= k[a * nd + b] * g;
                    }
                }
                continue;
            }
            let (s, e) = (self.col_ptr[j], self.col_ptr[j + 1]);
            let col = &self.row_idx[s..e];
            for (a, &i) in dofs.iter().enumerate() {
                if fixed[i].is_some() {
                    continue;
                }
                let kv = k[a * nd + b];
                if kv != 0.0 {
                    let p = s + col.binary_search(&i).expect("element entry in pattern");
                    self.values[p] += kv;
                }
            }
        }
        for (a, &i) in dofs.iter().enumerate() {
            if fixed[i].is_none() {
                rhs[i] += f[a];
            }
        }
    }

    /// Adds a dense local matrix `k` (row-major) at the `positions` of its entries in
    /// [`values`](Self::values) (see [`try_position`](Self::try_position); `u32::MAX` for an
    /// entry outside the pattern): the unconstrained [`scatter`](Self::scatter) without searching
    /// the pattern. Zero entries are skipped as there.
    ///
    /// # Panics
    /// If a nonzero entry has no position (a broken assembly contract, as in `scatter`).
    #[inline]
    pub fn add_at(&mut self, positions: &[u32], k: &[f64]) {
        debug_assert_eq!(positions.len(), k.len());
        for (&p, &kv) in positions.iter().zip(k) {
            if kv != 0.0 {
                assert!(p != u32::MAX, "element entry not in the sparsity pattern");
                self.values[p as usize] += kv;
            }
        }
    }

    /// [`add_at`](Self::add_at) for the leading `n` × `n` block of a local matrix `k` of row
    /// length `stride` (row-major): `positions` are the block's.
    pub fn add_block_at(&mut self, positions: &[u32], k: &[f64], stride: usize, n: usize) {
        debug_assert_eq!(positions.len(), n * n);
        for (row, at) in k.chunks(stride).zip(positions.chunks(n)) {
            self.add_at(at, &row[..n]);
        }
    }

    /// [`add_at`](Self::add_at) column by column (`n` × `n`, row-major `k` and `positions`):
    /// the order of [`scatter`](Self::scatter), so that an entry a local matrix holds more than
    /// once (repeated dofs) sums as scatter sums it.
    pub fn add_at_by_columns(&mut self, positions: &[u32], k: &[f64], n: usize) {
        debug_assert_eq!(positions.len(), n * n);
        debug_assert_eq!(k.len(), n * n);
        for b in 0..n {
            for a in 0..n {
                let kv = k[a * n + b];
                if kv != 0.0 {
                    let p = positions[a * n + b];
                    assert!(p != u32::MAX, "local entry not in the sparsity pattern");
                    self.values[p as usize] += kv;
                }
            }
        }
    }

    /// Adds the entries of a local matrix `k` (row-major, `dofs` its rows and columns, no
    /// constraints) outside its leading `n` × `n` block, which [`add_block_at`](Self::add_block_at)
    /// adds: the rows and columns of a cut element's rigid-body unknowns.
    pub fn add_border(&mut self, dofs: &[usize], k: &[f64], n: usize) {
        let nd = dofs.len();
        debug_assert_eq!(k.len(), nd * nd);
        for (b, &j) in dofs.iter().enumerate() {
            let (s, e) = (self.col_ptr[j], self.col_ptr[j + 1]);
            let col = &self.row_idx[s..e];
            let rows = if b < n { n } else { 0 };
            for (a, &i) in dofs.iter().enumerate().skip(rows) {
                let kv = k[a * nd + b];
                if kv != 0.0 {
                    let p = s + col.binary_search(&i).expect("element entry in pattern");
                    self.values[p] += kv;
                }
            }
        }
    }

    /// For each stored entry (i, j), the position of (j, i) — the pattern is symmetric — for
    /// [`eliminate_constraints`](Self::eliminate_constraints) (once per pattern).
    pub fn transpose_positions(&self) -> Vec<u32> {
        let mut next = self.col_ptr.clone();
        let mut transpose = vec![u32::MAX; self.row_idx.len()];
        // entries (i, j) in column order: column i's entries in row order are the transposes
        for j in 0..self.n {
            for p in self.col_ptr[j]..self.col_ptr[j + 1] {
                let i = self.row_idx[p];
                let q = next[i];
                debug_assert_eq!(self.row_idx[q], j, "symmetric pattern");
                next[i] += 1;
                transpose[p] = u32::try_from(q).expect("fewer than 2³² − 1 entries");
            }
        }
        transpose
    }

    /// For a matrix assembled without constraints: moves the columns of constrained dofs to the
    /// right-hand side (`rhs_i −= a_ij g_j` for unconstrained i) and zeroes the rows and columns
    /// of constrained dofs — what [`scatter`](Self::scatter) does element by element. Follow
    /// with [`apply_constraints`](Self::apply_constraints). Visits the constrained columns only:
    /// a constrained row's entry in an unconstrained column is found as the transpose
    /// (`transpose`, [`transpose_positions`](Self::transpose_positions) of this pattern).
    pub fn eliminate_constraints(
        &mut self,
        rhs: &mut [f64],
        fixed: &[Option<f64>],
        transpose: &[u32],
    ) {
        debug_assert_eq!(
            transpose.len(),
            self.row_idx.len(),
            "this pattern's transpose"
        );
        for (j, g) in fixed.iter().enumerate() {
            let Some(g) = *g else { continue };
            for p in self.col_ptr[j]..self.col_ptr[j + 1] {
                let i = self.row_idx[p];
                if fixed[i].is_none() {
                    rhs[i] -= self.values[p] * g;
                    self.values[transpose[p] as usize] = 0.0;
                }
                self.values[p] = 0.0;
            }
        }
    }

    /// Puts identity rows/columns on constrained dofs and their values in `rhs`.
    /// Call after all element scatters.
    pub fn apply_constraints(&mut self, rhs: &mut [f64], fixed: &[Option<f64>]) {
        for (d, g) in fixed.iter().enumerate() {
            if let Some(g) = g {
                let p = self.position(d, d);
                self.values[p] = 1.0;
                rhs[d] = *g;
            }
        }
    }

    /// y = A x.
    pub fn matvec(&self, x: &[f64], y: &mut [f64]) {
        y.iter_mut().for_each(|v| *v = 0.0);
        for j in 0..self.n {
            let xj = x[j];
            for p in self.col_ptr[j]..self.col_ptr[j + 1] {
                y[self.row_idx[p]] += self.values[p] * xj;
            }
        }
    }

    /// Symmetric equilibration factors d_i = 1/√(max_j max(|a_ij|, |a_ji|)) (1 for an empty row),
    /// so that D A D has entries of at most 1 in every row and column.
    pub fn equilibration(&self, d: &mut Vec<f64>) {
        d.clear();
        d.resize(self.n, 0.0);
        for j in 0..self.n {
            for p in self.col_ptr[j]..self.col_ptr[j + 1] {
                let v = self.values[p].abs();
                let i = self.row_idx[p];
                d[i] = d[i].max(v);
                d[j] = d[j].max(v);
            }
        }
        d.iter_mut()
            .for_each(|m| *m = if *m > 0.0 { 1.0 / m.sqrt() } else { 1.0 });
    }

    /// Writes D A D into `out` (same pattern; `out` is resized to match).
    pub fn scaled_into(&self, d: &[f64], out: &mut SparseMatrix) {
        if out.row_idx.len() != self.row_idx.len() || out.n != self.n {
            *out = self.clone();
        }
        for j in 0..self.n {
            for p in self.col_ptr[j]..self.col_ptr[j + 1] {
                out.values[p] = d[self.row_idx[p]] * self.values[p] * d[j];
            }
        }
    }

    /// faer view of the matrix.
    pub fn as_faer(&self) -> SparseColMatRef<'_, usize, f64> {
        SparseColMatRef::new(self.symbolic(), &self.values)
    }

    /// faer view of the pattern.
    pub fn symbolic(&self) -> SymbolicSparseColMatRef<'_, usize> {
        // SAFETY-free constructor: checked variant validates sorted, in-range indices.
        SymbolicSparseColMatRef::new_checked(self.n, self.n, &self.col_ptr, None, &self.row_idx)
    }

    /// Largest |A_ij − A_ji| over the pattern (0 for a symmetric matrix).
    pub fn asymmetry(&self) -> f64 {
        let mut worst: f64 = 0.0;
        for j in 0..self.n {
            for p in self.col_ptr[j]..self.col_ptr[j + 1] {
                let i = self.row_idx[p];
                worst = worst.max((self.values[p] - self.get(j, i)).abs());
            }
        }
        worst
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scatter_eliminates_constraints_symmetrically() {
        // 1D Laplacian on 3 nodes, node 0 fixed to 2: solution of [[1,0,0],[0,2,-1],[0,-1,1]] system.
        let mut pb = PatternBuilder::new(3);
        pb.add_group(&[0, 1]);
        pb.add_group(&[1, 2]);
        let mut a = pb.build();
        assert_eq!(a.nnz(), 7);
        let fixed = [Some(2.0), None, None];
        let mut rhs = vec![0.0; 3];
        let ke = [1.0, -1.0, -1.0, 1.0];
        a.scatter(&[0, 1], &ke, &[0.0, 0.0], &mut rhs, &fixed);
        a.scatter(&[1, 2], &ke, &[0.0, 0.0], &mut rhs, &fixed);
        a.apply_constraints(&mut rhs, &fixed);
        assert_eq!(rhs, vec![2.0, 2.0, 0.0]);
        assert_eq!(a.get(0, 1), 0.0);
        assert_eq!(a.get(1, 0), 0.0);
        assert_eq!(a.get(1, 1), 2.0);
        assert_eq!(a.asymmetry(), 0.0);
        let mut y = vec![0.0; 3];
        a.matvec(&[2.0, 2.0, 2.0], &mut y);
        assert_eq!(y, vec![2.0, 2.0, 0.0]);
    }

    #[test]
    fn eliminating_after_assembly_equals_eliminating_while_scattering() {
        // non-symmetric 4-node chain with two constraints (one at each end)
        let mut pb = PatternBuilder::new(4);
        for g in [[0, 1], [1, 2], [2, 3]] {
            pb.add_group(&g);
        }
        let mut a = pb.build();
        let mut b = a.clone();
        let fixed = [Some(1.5), None, None, Some(-0.5)];
        let free = [None; 4];
        let ke = [2.0, -0.7, -1.3, 3.0];
        let fe = [0.25, -1.0];
        let (mut ra, mut rb) = (vec![0.0; 4], vec![0.0; 4]);
        for g in [[0, 1], [1, 2], [2, 3]] {
            a.scatter(&g, &ke, &fe, &mut ra, &fixed);
            b.scatter(&g, &ke, &fe, &mut rb, &free);
        }
        a.apply_constraints(&mut ra, &fixed);
        let transpose = b.transpose_positions();
        b.eliminate_constraints(&mut rb, &fixed, &transpose);
        b.apply_constraints(&mut rb, &fixed);
        assert_eq!(a.values, b.values);
        assert_eq!(ra, rb);
    }

    /// For a symmetric pattern the transpose of the lower triangle is the upper triangle as
    /// stored; for the lower triangle alone it is the same.
    #[test]
    fn the_upper_pattern_is_the_transposed_lower_one() {
        let mut pb = PatternBuilder::new(6);
        pb.add_group(&[0, 2, 5]);
        pb.add_group(&[1, 2, 3]);
        pb.add_coupling(&[4], &[0, 5]);
        let full = pb.build();
        let upper = |m: &SparseMatrix| {
            let mut col_ptr = vec![0];
            let mut row_idx = Vec::new();
            for j in 0..m.n() {
                row_idx.extend(m.column(j).0.iter().filter(|&&i| i <= j));
                col_ptr.push(row_idx.len());
            }
            (col_ptr, row_idx)
        };
        assert_eq!(full.upper_from_lower(), upper(&full));
        let (mut col_ptr, mut row_idx) = (vec![0], Vec::new());
        for j in 0..full.n() {
            row_idx.extend(full.column(j).0.iter().filter(|&&i| i >= j));
            col_ptr.push(row_idx.len());
        }
        let lower = SparseMatrix::from_pattern(full.n(), col_ptr, row_idx);
        assert_eq!(lower.upper_from_lower(), upper(&full));
    }
}
