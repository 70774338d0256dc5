//! Fill-reducing orderings of dofs grouped into blocks (e.g. all unknowns at one mesh node): a
//! given block order or AMD on the block graph, expanded to dofs with a class order inside each
//! block.

use dyn_stack::{MemBuffer, MemStack};
use faer::sparse::linalg::amd;
use faer::sparse::SymbolicSparseColMatRef;

use super::SolveError;
use crate::fem::sparse::SparseMatrix;

/// Grouping of dofs into blocks for [`DirectSolver::analyze_blocked`](super::DirectSolver::analyze_blocked).
#[derive(Debug, Clone)]
pub struct DofBlocks {
    /// Block id of each dof (blocks numbered 0..n_blocks).
    pub block: Vec<u32>,
    /// Elimination class of each dof inside its block (lower first).
    pub class: Vec<u8>,
    /// Elimination order of the blocks (a permutation of 0..n_blocks, e.g. a nested dissection
    /// of the mesh); `None`: AMD on the block graph.
    pub order: Option<Vec<u32>>,
}

impl DofBlocks {
    /// The elimination order of the dofs of `a` (`order[k]` = the dof eliminated k-th): the block
    /// order (given, or AMD on the block graph of `a`) expanded to dofs.
    pub fn elimination_order(&self, a: &SparseMatrix) -> Result<Vec<usize>, SolveError> {
        Ok(block_amd_ordering(a, self)?.0)
    }
}

/// Block order (given, or AMD on the block graph of `a`) expanded to dofs; returns (forward, inverse) permutations
/// (`forward[new] = old`).
pub(crate) fn block_amd_ordering(
    a: &SparseMatrix,
    blocks: &DofBlocks,
) -> Result<(Vec<usize>, Vec<usize>), SolveError> {
    let n = a.n();
    assert_eq!(blocks.block.len(), n, "one block id per dof");
    let nb = blocks
        .block
        .iter()
        .map(|&b| b as usize + 1)
        .max()
        .unwrap_or(0);
    let bperm: Vec<usize> = match &blocks.order {
        Some(order) => {
            assert_eq!(
                order.len(),
                nb,
                "the block order is a permutation of the blocks"
            );
            order.iter().map(|&b| b as usize).collect()
        }
        None => block_amd(a, blocks, nb)?,
    };
    // dofs of each block, sorted by (class, dof)
    let mut members: Vec<Vec<usize>> = vec![Vec::new(); nb];
    for d in 0..n {
        members[blocks.block[d] as usize].push(d);
    }
    let mut fwd = Vec::with_capacity(n);
    for &b in &bperm {
        let m = &mut members[b];
        m.sort_by_key(|&d| (blocks.class[d], d));
        fwd.extend_from_slice(m);
    }
    let mut inv = vec![0usize; n];
    for (new, &old) in fwd.iter().enumerate() {
        inv[old] = new;
    }
    Ok((fwd, inv))
}

/// AMD on the block graph of `a` (blocks numbered 0..nb); returns the block order.
fn block_amd(a: &SparseMatrix, blocks: &DofBlocks, nb: usize) -> Result<Vec<usize>, SolveError> {
    let n = a.n();
    let mut adj: Vec<Vec<u32>> = vec![Vec::new(); nb];
    let sym = a.symbolic();
    for j in 0..n {
        let bj = blocks.block[j];
        let col = &mut adj[bj as usize];
        for &i in sym.row_idx_of_col_raw(j) {
            let bi = blocks.block[i];
            if bi != bj {
                col.push(bi);
            }
        }
        if col.len() > 256 {
            col.sort_unstable();
            col.dedup();
        }
    }
    let mut col_ptr = Vec::with_capacity(nb + 1);
    let mut row_idx = Vec::new();
    col_ptr.push(0usize);
    for mut c in adj {
        c.sort_unstable();
        c.dedup();
        row_idx.extend(c.iter().map(|&i| i as usize));
        col_ptr.push(row_idx.len());
    }
    let graph = SymbolicSparseColMatRef::new_checked(nb, nb, &col_ptr, None, &row_idx);
    let (mut bperm, mut bperm_inv) = (vec![0usize; nb], vec![0usize; nb]);
    let mut buf = MemBuffer::new(amd::order_scratch::<usize>(nb, row_idx.len()));
    amd::order(
        &mut bperm,
        &mut bperm_inv,
        graph,
        amd::Control::default(),
        MemStack::new(&mut buf),
    )
    .map_err(|e| SolveError::Symbolic(format!("block AMD: {e:?}")))?;
    Ok(bperm)
}
