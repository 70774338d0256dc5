//! What the flow solver keeps between steps besides the factorization: the fluid base matrix
//! (elements outside every particle's reach and outside the moving-element mask), that mask,
//! the fluid matrices of axis-parallel rectangles by their sides, and where each element's
//! entries lie in the matrix's values.

use std::collections::HashMap;

use super::dofs::{element_dofs, MAX_EL_DOFS};
use super::kernels::{fluid_element_matrix, shape_table};
use super::reach::Reach;
use super::Stokes;
use crate::fem::element::RuleMaps;
use crate::fem::quadrature::QuadRule;
use crate::fem::sparse::SparseMatrix;
use crate::mesh::{bounding_box, Mesh};
use crate::solver::ghost::{ghost_patch_matrices, GhostFace};
use crate::solver::rigid::ElementCut;

/// Margin, in elements along each index direction, by which [`Stokes::set_mesh`] widens the
/// elements whose coordinates changed when it adds them to the moving-element mask (elements
/// assembled every step, outside the cached fluid base). A grading that travels with the
/// particles changes a band of columns and rows that moves with them by a fraction of an
/// element per time step: with the margin the band travels about this many elements before a
/// changed element falls outside the mask and the base must be rebuilt (one assembly of the
/// fluid elements) instead of at every step. The price is 2 × 4 more columns (and rows) of
/// elements assembled every step — 4 % of a 200×50 channel per column band — cheap beside the
/// numeric factorization that a moved mesh needs at every step anyway.
pub(super) const MOVING_MARGIN: usize = 4;

/// Whether element `e`'s matrix is assembled every step rather than cached in the fluid base:
/// it lies in the reach of a particle or a free surface (it may be cut while the pattern lasts) or in the
/// moving-element mask (its coordinates may change).
pub(super) fn assembled_each_step(reach: &Reach, moving: &[bool], e: usize) -> bool {
    moving[e] || reach.contains(e)
}

impl Stokes {
    /// Matrix values of the elements outside every reach and the moving-element mask (no stress,
    /// no constraints).
    fn fluid_values(&mut self) -> Vec<f64> {
        let lay = self.layout;
        let (eta, theta) = (self.params.eta, self.params.theta);
        let nd = 22 + if lay.with_g { 16 } else { 0 };
        let tab = shape_table(&self.rule);
        let mut dofs = Vec::with_capacity(MAX_EL_DOFS);
        let mut ke = vec![0.0; nd * nd];
        let zero = vec![0.0; nd];
        let mut scratch = vec![0.0; lay.n_dofs()];
        self.matrix.zero();
        for e in 0..self.mesh.n_elements() {
            // removed elements outside the reach lie beyond a free surface's band or above a die
            // wall (inside a particle an element is always in the particle's reach)
            if assembled_each_step(&self.reach, &self.moving, e)
                || matches!(self.cuts[e], ElementCut::Inside)
            {
                continue;
            }
            element_dofs(&self.mesh, &lay, e, &mut dofs);
            let xe = &self.mesh.element_coords[e];
            fluid_element_matrix(xe, &self.rule, &tab, eta, theta, lay.with_g, &mut ke);
            self.matrix
                .scatter(&dofs, &ke, &zero, &mut scratch, &self.unconstrained);
        }
        self.matrix.values.clone()
    }
}

/// Per element (or ghost-penalty face), the positions in the pattern's values of its local
/// matrix's entries (row-major; an element's own dofs of [`element_dofs`], not a cut element's
/// rigid dofs): an element scattered every step finds them once per pattern instead of by a
/// binary search per entry and step (7 % of a semi-implicit step, where every element is
/// scattered).
#[derive(Default)]
pub(super) struct ElementPositions {
    by_element: Vec<Option<Box<[u32]>>>,
}

impl ElementPositions {
    /// Forgets every element's positions (a new pattern).
    pub(super) fn clear(&mut self) {
        self.by_element.clear();
    }

    /// The positions of element (or face key) `e` with dofs `dofs` in `matrix`'s values, found
    /// on first use;
    /// [`NOT_IN_PATTERN`] where the pattern has no entry (a block that is structurally zero,
    /// such as G's rows against the pressure).
    pub(super) fn of(&mut self, e: usize, dofs: &[usize], matrix: &SparseMatrix) -> &[u32] {
        if self.by_element.len() <= e {
            self.by_element.resize(e + 1, None);
        }
        self.by_element[e].get_or_insert_with(|| {
            let positions: Vec<u32> = dofs
                .iter()
                .flat_map(|&i| dofs.iter().map(move |&j| (i, j)))
                .map(|(i, j)| {
                    matrix.try_position(i, j).map_or(NOT_IN_PATTERN, |p| {
                        u32::try_from(p).expect("fewer than 2³² − 1 entries")
                    })
                })
                .collect();
            positions.into_boxed_slice()
        })
    }
}

/// The position [`ElementPositions`] gives an entry the pattern does not hold.
pub(super) const NOT_IN_PATTERN: u32 = u32::MAX;

/// (η, θ) and the fluid element matrices by rectangle sides (see `Stokes::rectangles`).
pub(super) type RectangleMatrices = (f64, f64, HashMap<[u64; 2], Box<[f64]>>);

/// The fluid base of [`Stokes`]: the matrix values of the elements outside every reach and the
/// moving-element mask, the (η, θ) they were built with, and the element maps at the rule's
/// points (a base element's coordinates do not change while the base lasts), from which a step
/// assembles those elements' loads.
pub(super) struct FluidBase {
    pub values: Vec<f64>,
    pub eta: f64,
    pub theta: f64,
    pub maps: RuleMaps,
}

impl Stokes {
    /// The fluid base for the current reach, mask and (η, θ).
    pub(super) fn fluid_base(&mut self) -> FluidBase {
        FluidBase {
            values: self.fluid_values(),
            eta: self.params.eta,
            theta: self.params.theta,
            maps: RuleMaps::of(&self.mesh, &self.rule.points),
        }
    }
}

/// A ghost-penalty face's patch matrices ([`ghost_patch_matrices`]: Q2 over its 18 nodes, Q1
/// over its 8 vertices, and the patch size), which depend on the two elements' coordinates only:
/// [`Stokes`] keeps those of the last step's faces while the elements stay where they are.
pub(super) struct GhostPatch {
    pub elements: [usize; 2],
    pub k2: Box<[f64; 324]>,
    pub k1: [f64; 64],
    pub h: f64,
}

impl GhostPatch {
    pub(super) fn of(mesh: &Mesh, face: &GhostFace, rule: &QuadRule) -> Self {
        let (mut k2, mut k1) = (Box::new([0.0; 324]), [0.0; 64]);
        let h = ghost_patch_matrices(mesh, face, rule, &mut k2, &mut k1);
        Self {
            elements: [face.first, face.second],
            k2,
            k1,
            h,
        }
    }
}

/// Distinct rectangle sizes kept by [`Stokes`] between steps before it starts afresh (a mesh
/// that follows the particles creates a few hundred per step; 4096 matrices of 38×38 are 47 MB).
pub(super) const RECTANGLE_CACHE_LEN: usize = 4096;

/// The side lengths (bit patterns) of an axis-parallel rectangular element, whose fluid matrix
/// depends on them only, and the same element placed with its lower-left corner at the origin:
/// the matrix computed there is the same whichever element of these sides asks first (a
/// restored run assembles bit for bit what the saved one did).
pub(super) fn canonical_rectangle(xe: &[[f64; 2]; 9]) -> ([u64; 2], [[f64; 2]; 9]) {
    let (lo, hi) = bounding_box(xe);
    let side = [hi[0] - lo[0], hi[1] - lo[1]];
    let mut canonical = [[0.0; 2]; 9];
    for (y, x) in canonical.iter_mut().zip(xe) {
        for c in 0..2 {
            // the node's place along the side: 0, 1/2 or 1
            let t = (2.0 * (x[c] - lo[c]) / side[c]).round() * 0.5;
            y[c] = t * side[c];
        }
    }
    ([side[0].to_bits(), side[1].to_bits()], canonical)
}
