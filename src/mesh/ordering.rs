//! Geometric nested-dissection elimination order of a structured mesh's Q2 node lattice (for
//! the sparse direct solvers), with separators widened across coupled (ghost-penalty) faces.

use super::structured::Mesh;

impl Mesh {
    /// Nodes in a geometric nested-dissection elimination order: the node lattice is split by a
    /// column or row of nodes on element edges (which no element crosses), the two halves are
    /// ordered recursively and the separator after them; regions of at most `leaf` nodes keep
    /// the natural order. On a periodic direction the seam is the outermost separator.
    ///
    /// `coupled(e, o)`: whether the face between neighbouring elements `e` and `o` couples all
    /// their nodes in the matrix (a ghost-penalty patch). A separator line crossing such a face
    /// takes the nodes of both elements too, so that it still separates.
    pub fn nested_dissection(
        &self,
        leaf: usize,
        coupled: &dyn Fn(usize, usize) -> bool,
    ) -> Vec<usize> {
        let nd = Dissection {
            mesh: self,
            leaf: leaf.max(1),
            coupled,
        };
        let rows = 2 * self.ay.len() + 1;
        let cols = self.n_node_cols;
        let mut taken = vec![false; self.n_nodes()];
        let mut order = Vec::with_capacity(self.n_nodes());
        if self.periodic {
            // the seam: line i = 0 of the unwrapped lattice [0, 2·nx]
            let seam = nd.separator_in(0, Dir::Column, [0, cols + 1], [0, rows], &mut taken);
            nd.dissect([1, cols], [0, rows], &mut taken, &mut order);
            nd.emit_list(&seam, &mut order);
        } else {
            nd.dissect([0, cols], [0, rows], &mut taken, &mut order);
        }
        debug_assert_eq!(order.len(), self.n_nodes());
        order
    }
}

/// Direction of a separator line of [`Mesh::nested_dissection`].
#[derive(Clone, Copy, PartialEq, Eq)]
enum Dir {
    /// A line of constant i (lattice column).
    Column,
    /// A line of constant j (lattice row).
    Row,
}

/// State of [`Mesh::nested_dissection`]. Lattice ranges are half-open; a periodic lattice is
/// addressed unwrapped (i up to 2·nx, where i = 2·nx is the seam i = 0 again).
struct Dissection<'a> {
    mesh: &'a Mesh,
    leaf: usize,
    coupled: &'a dyn Fn(usize, usize) -> bool,
}

impl Dissection<'_> {
    fn id(&self, i: usize, j: usize) -> usize {
        i % self.mesh.n_node_cols + self.mesh.n_node_cols * j
    }

    /// Orders the free nodes of the region `i ∈ [i[0], i[1])`, `j ∈ [j[0], j[1])`.
    fn dissect(&self, i: [usize; 2], j: [usize; 2], taken: &mut [bool], order: &mut Vec<usize>) {
        let (ni, nj) = (i[1].saturating_sub(i[0]), j[1].saturating_sub(j[0]));
        if ni == 0 || nj == 0 {
            return;
        }
        // An even line strictly inside [lo, hi) (lo < s < hi − 1 keeps both sides non-empty),
        // near the middle: within a fifth of the width either side, the one crossing the fewest
        // coupled faces (each widens the separator by the nodes of two elements), then the
        // closest to the middle.
        let split = |lo: usize, hi: usize, dir: Dir, other: [usize; 2]| -> Option<usize> {
            let mid = (lo + hi) / 2;
            let reach = ((hi - lo) / 5).max(2);
            (mid.saturating_sub(reach)..=mid + reach)
                .filter(|&s| s % 2 == 0 && s > lo && s + 1 < hi)
                .min_by_key(|&s| (self.crossed(s, dir, other).count(), s.abs_diff(mid)))
        };
        let cut = if ni * nj <= self.leaf {
            None
        } else if ni >= nj {
            split(i[0], i[1], Dir::Column, j)
                .map(|s| (Dir::Column, s))
                .or_else(|| split(j[0], j[1], Dir::Row, i).map(|s| (Dir::Row, s)))
        } else {
            split(j[0], j[1], Dir::Row, i)
                .map(|s| (Dir::Row, s))
                .or_else(|| split(i[0], i[1], Dir::Column, j).map(|s| (Dir::Column, s)))
        };
        match cut {
            None => {
                let mut region = Vec::new();
                for b in j[0]..j[1] {
                    for a in i[0]..i[1] {
                        let k = self.id(a, b);
                        if !taken[k] {
                            taken[k] = true;
                            region.push(k);
                        }
                    }
                }
                self.emit_list(&region, order);
            }
            Some((Dir::Column, s)) => {
                let sep = self.separator_in(s, Dir::Column, i, j, taken);
                self.dissect([i[0], s], j, taken, order);
                self.dissect([s + 1, i[1]], j, taken, order);
                self.emit_list(&sep, order);
            }
            Some((Dir::Row, s)) => {
                let sep = self.separator_in(s, Dir::Row, i, j, taken);
                self.dissect(i, [j[0], s], taken, order);
                self.dissect(i, [s + 1, j[1]], taken, order);
                self.emit_list(&sep, order);
            }
        }
    }

    /// The coupled faces that line `s` (direction `dir`) crosses over the range `other` of the
    /// other lattice direction, as the element row (column line) or column (row line) index.
    fn crossed(&self, s: usize, dir: Dir, other: [usize; 2]) -> impl Iterator<Item = usize> + '_ {
        let (nx, ny) = self.mesh.dims();
        let n = if dir == Dir::Column { ny } else { nx };
        (0..n).filter(move |&k| {
            // the element pair either side of the line (a column line at the seam s = 0: nx − 1, 0)
            let (e, o) = match dir {
                Dir::Column => (k * nx + (s / 2 + nx - 1) % nx, k * nx + (s / 2) % nx),
                Dir::Row => ((s / 2 - 1) * nx + k, (s / 2) * nx + k),
            };
            2 * k + 2 >= other[0] && 2 * k < other[1] && (self.coupled)(e, o)
        })
    }

    /// The free nodes of line `s` (direction `dir`) within the region, plus the free nodes of the
    /// element pairs across it whose face is coupled; all reserved (`taken`).
    fn separator_in(
        &self,
        s: usize,
        dir: Dir,
        i: [usize; 2],
        j: [usize; 2],
        taken: &mut [bool],
    ) -> Vec<usize> {
        let nx = self.mesh.dims().0;
        let mut sep = Vec::new();
        let mut take = |a: usize, b: usize, sep: &mut Vec<usize>| {
            if a >= i[0] && a < i[1] && b >= j[0] && b < j[1] {
                let k = self.id(a, b);
                if !taken[k] {
                    taken[k] = true;
                    sep.push(k);
                }
            }
        };
        match dir {
            Dir::Column => {
                for b in j[0]..j[1] {
                    take(s, b, &mut sep);
                }
                let centre = if s == 0 { 2 * nx } else { s };
                for ey in self.crossed(s, dir, j) {
                    for b in 2 * ey..=2 * ey + 2 {
                        for a in centre - 2..=centre + 2 {
                            // beyond the seam: the first columns again
                            let a = if a > 2 * nx { a - 2 * nx } else { a };
                            take(a, b, &mut sep);
                        }
                    }
                }
            }
            Dir::Row => {
                for a in i[0]..i[1] {
                    take(a, s, &mut sep);
                }
                for ex in self.crossed(s, dir, i) {
                    for b in s - 2..=s + 2 {
                        for a in 2 * ex..=2 * ex + 2 {
                            take(a, b, &mut sep);
                        }
                    }
                }
            }
        }
        sep
    }

    /// Appends `nodes`, mid-side and centre nodes before vertices: a vertex carries the pressure,
    /// whose diagonal is zero until the velocities it couples to are eliminated (the LBLᵀ pivots
    /// only within a supernode).
    fn emit_list(&self, nodes: &[usize], order: &mut Vec<usize>) {
        for vertices in [false, true] {
            for &k in nodes {
                let (a, b) = self.mesh.node_ij(k);
                if (a % 2 == 0 && b % 2 == 0) == vertices {
                    order.push(k);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::Axis;

    #[test]
    fn nested_dissection_is_a_permutation_ending_with_its_separators() {
        for periodic in [false, true] {
            let m = Mesh::rectangle(
                Axis::uniform(0.0, 4.0, 12),
                Axis::uniform(0.0, 1.0, 3),
                periodic,
            );
            let order = m.nested_dissection(4, &|_, _| false);
            let mut seen = vec![false; m.n_nodes()];
            for &k in &order {
                assert!(!seen[k], "node {k} twice");
                seen[k] = true;
            }
            assert!(seen.iter().all(|&s| s), "every node ordered");
            // the outermost separators come last: a whole node column each (7 nodes high),
            // mid-side nodes before vertices
            let tail: Vec<(usize, usize)> = order[order.len() - 7..]
                .iter()
                .map(|&k| m.node_ij(k))
                .collect();
            let col = if periodic { 0 } else { 12 };
            assert!(tail.iter().all(|&(i, _)| i == col), "{tail:?}");
            let js: Vec<usize> = tail.iter().map(|&(_, j)| j).collect();
            assert_eq!(js, [1, 3, 5, 0, 2, 4, 6]);
            // the periodic strip opened at the seam is then cut in the middle
            if periodic {
                let mid = order[order.len() - 14..order.len() - 7].to_vec();
                let i_mid = m.node_ij(mid[0]).0;
                assert!(mid.iter().all(|&k| m.node_ij(k).0 == i_mid));
                assert_eq!(i_mid % 2, 0, "separators lie on element edges");
            }
        }
    }

    #[test]
    fn nested_dissection_with_coupled_faces_is_a_permutation() {
        for periodic in [false, true] {
            let m = Mesh::rectangle(
                Axis::uniform(0.0, 4.0, 16),
                Axis::uniform(0.0, 1.0, 4),
                periodic,
            );
            // every face coupled: the widest separators, on every line and the seam
            let all = |_: usize, _: usize| true;
            let some = |e: usize, _: usize| e.is_multiple_of(3);
            let cases: [&dyn Fn(usize, usize) -> bool; 2] = [&all, &some];
            for coupled in cases {
                let order = m.nested_dissection(4, coupled);
                let mut seen = vec![false; m.n_nodes()];
                for &k in &order {
                    assert!(!seen[k], "node {k} twice");
                    seen[k] = true;
                }
                assert!(seen.iter().all(|&s| s), "every node ordered");
            }
        }
    }
}
