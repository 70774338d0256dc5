//! Active degrees of freedom: nodes that carry unknowns in the one-sided enrichment.
//!
//! Shape functions are kept only for nodes whose support meets the fluid (thesis §2.3.2, §5.3.2:
//! "the shape functions are only defined in the nodes inside the fluid domain Ω and associated
//! to the elements intersected by the interface"). A node is active when it belongs to at least
//! one element with a fluid part ([`CellLocation::Fluid`] or [`CellLocation::Cut`]); the other
//! nodes become identity rows of the fixed-pattern global system.

use super::classify::CellLocation;
use super::XfemError;

/// The mask of active nodes, given each element's location and node list (any slice-like rows,
/// e.g. `[usize; 9]` or `Vec<usize>`) and the number of nodes.
///
/// Errors when the two lists differ in length or a node index is out of range.
pub fn active_nodes<C: AsRef<[usize]>>(
    locations: &[CellLocation],
    connectivity: &[C],
    n_nodes: usize,
) -> Result<Vec<bool>, XfemError> {
    if locations.len() != connectivity.len() {
        return Err(XfemError::LengthMismatch {
            locations: locations.len(),
            connectivity: connectivity.len(),
        });
    }
    let mut active = vec![false; n_nodes];
    for (element, (loc, nodes)) in locations.iter().zip(connectivity).enumerate() {
        for &node in nodes.as_ref() {
            if node >= n_nodes {
                return Err(XfemError::NodeOutOfRange {
                    element,
                    node,
                    n_nodes,
                });
            }
            if loc.has_fluid() {
                active[node] = true;
            }
        }
    }
    Ok(active)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nodes_touching_fluid_or_cut_elements_are_active() {
        // Three Q1 elements in a row, nodes 0..8 (bottom 0..4, top 4..8):
        // fluid | particle | particle. Only the first element's nodes are active.
        let conn = [[0, 1, 4, 5], [1, 2, 5, 6], [2, 3, 6, 7]];
        let locs = [
            CellLocation::Fluid,
            CellLocation::Particle,
            CellLocation::Particle,
        ];
        let mask = active_nodes(&locs, &conn, 8).expect("consistent");
        assert_eq!(
            mask,
            [true, true, false, false, true, true, false, false].to_vec()
        );
        let err = active_nodes(&locs[..2], &conn, 8).expect_err("length mismatch");
        assert!(matches!(err, XfemError::LengthMismatch { .. }));
        let err = active_nodes(&locs, &conn, 7).expect_err("node 7 of 7");
        assert!(matches!(err, XfemError::NodeOutOfRange { node: 7, .. }));
    }
}
