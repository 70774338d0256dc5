//! XFEM geometry: level sets of the particles, element classification, cut-cell and interface
//! quadrature, active-dof masks.
//!
//! This module owns everything the one-sided Heaviside enrichment of thesis §2.3.2 / §5.3.2 needs
//! from geometry, element by element and without knowing the mesh type:
//! - [`level_set`]: the signed distance φ(x) = min_i (|x − X_i| − a_i) of a union of circles
//!   (positive in the fluid, periodic in x on request), its nearest particle and the fluid's
//!   outward normal on ∂P_i (pointing into the particle).
//! - [`ref_map`]: the [`RefMap`] trait an element's map ξ ∈ [-1, 1]² → x implements (rectangles,
//!   bilinear quadrilaterals and isoparametric Q2 elements here), and its Newton inverse.
//! - [`classify`] / [`cut_quadrature`]: [`CellLocation`] per element and the quadrature on the
//!   fluid part of cut elements — a quadtree of the reference square (default 5 levels, thesis
//!   §5.3.2), 3×3 Gauss on fluid sub-squares, interface-aligned triangles in the finest cut
//!   sub-squares with the 6- or 16-point rule chosen by A_int/A_elem and elements with
//!   A_int/A_elem ≤ 10⁻⁶ discarded (thesis Table 5.1). The triangles' interface edges are the
//!   thesis' straight chords ([`InterfaceApprox::Linear`]) or, by default, parabolas through the
//!   interface ([`InterfaceApprox::Quadratic`]: Table 2.2's disc area to ~3e-11 at level 5 where
//!   chords give ~3e-5). With these rules the fluid-domain integrals (·,·) of Eqs. (5.17)–(5.23)
//!   are taken over Ω(t) only (discretisation (5.30)–(5.34)).
//! - [`interface`]: quadrature on the particle boundaries ∂P_i ∩ element along the exact circle
//!   arcs, for the boundary terms (·,·)_{∂P_i} of Eqs. (5.17), (5.20) and (5.24).
//! - [`active`]: which nodes carry unknowns (touch an element with a fluid part).
//!
//! Points are returned in reference coordinates with weights in reference measure: the
//! assembler multiplies by det J(ξ) itself, as for an uncut element.

pub mod active;
pub mod classify;
pub mod cut_quadrature;
pub mod interface;
pub mod level_set;
pub mod ref_map;
mod roots;
mod subcell;

#[cfg(test)]
mod area_tests;
#[cfg(test)]
mod test_support;

pub use active::active_nodes;
pub use classify::{CellLocation, CutCell, DISCARD_RATIO, SIXTEEN_POINT_RATIO};
pub use cut_quadrature::{CutOptions, CutQuadrature, InterfaceApprox, DEFAULT_LEVEL, MAX_LEVEL};
pub use interface::{InterfaceOptions, InterfacePoint, InterfaceQuadrature};
pub use level_set::{Circle, CircleUnion, HalfPlane, LevelSet, Nearest};
pub use ref_map::{element_area, inverse_map, BilinearQuad, Q2Element, RectMap, RefMap};

/// Errors of the XFEM geometry; each says what to change.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum XfemError {
    /// A particle radius that is not a positive finite number.
    #[error("particle {index}: radius {radius} must be positive and finite")]
    InvalidRadius {
        /// Particle index.
        index: usize,
        /// The offending radius.
        radius: f64,
    },
    /// A particle centre with a NaN or infinite coordinate.
    #[error("particle {index}: centre {center:?} must be finite")]
    InvalidCenter {
        /// Particle index.
        index: usize,
        /// The offending centre.
        center: [f64; 2],
    },
    /// A period that is not finite or does not exceed every particle diameter.
    #[error(
        "period {period} must be finite and larger than the largest particle diameter {diameter} \
         (a particle may not overlap its own periodic image)"
    )]
    InvalidPeriod {
        /// The offending period.
        period: f64,
        /// The largest particle diameter.
        diameter: f64,
    },
    /// A half-plane normal that is zero or not finite.
    #[error("half-plane normal {normal:?} must be finite and non-zero")]
    InvalidNormal {
        /// The offending normal.
        normal: [f64; 2],
    },
    /// The point does not lie in the element.
    #[error(
        "point {x:?} lies outside the element (reference coordinates {xi:?}); \
         locate it in another element"
    )]
    OutsideElement {
        /// Physical point.
        x: [f64; 2],
        /// Where Newton's method ended in reference coordinates.
        xi: [f64; 2],
    },
    /// Newton's method for the inverse map did not converge.
    #[error(
        "inverse map of {x:?} did not converge: residual {residual:e} after {iterations} \
         Newton steps (is the element inverted or the point far outside it?)"
    )]
    InverseMapDiverged {
        /// Physical point.
        x: [f64; 2],
        /// Last residual |map(ξ) − x|.
        residual: f64,
        /// Newton steps taken.
        iterations: usize,
    },
    /// The element Jacobian is singular where Newton's method needed it.
    #[error(
        "singular element Jacobian at ξ = {xi:?} (det J = {det:e}): the element is degenerate"
    )]
    SingularJacobian {
        /// Reference point.
        xi: [f64; 2],
        /// Jacobian determinant there.
        det: f64,
    },
    /// A quadtree level outside the supported range.
    #[error("quadtree level {level} out of range 0..={max}")]
    InvalidLevel {
        /// Requested level.
        level: u32,
        /// Largest supported level.
        max: u32,
    },
    /// Gauss points per interface arc outside the tabulated range.
    #[error("{points} Gauss points per arc requested; choose 1..=5")]
    InvalidArcPoints {
        /// Requested number of points.
        points: usize,
    },
    /// A maximal arc angle that is not in (0, 2π].
    #[error("maximal arc angle {angle} must lie in (0, 2π]")]
    InvalidArcAngle {
        /// Requested angle.
        angle: f64,
    },
    /// Element locations and connectivity of different lengths.
    #[error("{locations} element locations but {connectivity} connectivity rows")]
    LengthMismatch {
        /// Number of locations.
        locations: usize,
        /// Number of connectivity rows.
        connectivity: usize,
    },
    /// A connectivity entry beyond the node count.
    #[error("element {element} refers to node {node}, but there are only {n_nodes} nodes")]
    NodeOutOfRange {
        /// Element index.
        element: usize,
        /// Offending node index.
        node: usize,
        /// Number of nodes.
        n_nodes: usize,
    },
}
