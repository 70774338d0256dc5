//! Typed, validated case and sweep specifications.
//!
//! Owns [`CaseSpec`] (geometry, fluid, particles, numerics, output, stop rules; serde with
//! `deny_unknown_fields`, validated once by [`CaseSpec::from_value`]) and [`SweepSpec`] (a base case plus
//! axes). The dimensionless groups follow the thesis: Wi, α, β (5.6.3, 5.7), δ = H/2a (5.7.3),
//! ε = 2a/(R2 − R1) and r* = (r − R1)/(R2 − R1) (3.5.1). Validation rejects impossible physics (particles
//! overlapping each other or a wall, a ≥ H/2, Wi < 0, α or β outside [0, 1), Δt ≤ 0, N = 0) with an error
//! naming the field and saying what to change.
//!
//! `config` uses only the pure layout functions of [`crate::geometry::layout`], which themselves know no
//! configuration types.

mod case;
mod case_quantities;
mod error;
mod extrusion;
mod limits;
mod method;
mod numerics_checks;
mod search;
mod sweep_file;
mod text;
mod time_step;
mod tries;
mod validate;

pub use case::{
    CaseSpec, DieExit, Fluid, FollowMesh, FrameChoice, Geometry, HistoryRemap, InterfaceRule,
    Layout, Model, Numerics, Output, Particles, Stop, StressCoupling, DEFAULT_EXTRUSION_HEIGHT,
    DEFAULT_QUADTREE_LEVEL,
};
pub use case_quantities::{
    film_refinement, FILM_COARSEST, FILM_MAX_RATIO, FILM_REACH, PARAMETER_COLUMNS,
};
pub use error::{ConfigError, SpecError};
pub use limits::{
    COUPLED_G_STEP_COST, MAX_ELEMENTS_PER_STEP, MAX_MESH_ELEMENTS, MAX_RADII_PER_STEP,
    SEMI_IMPLICIT_STEP_COST,
};
pub use method::Method;
pub use search::{Change, SearchSpec};
pub use sweep_file::{Axis, PlannedCase, SweepSpec};
pub use text::parse as parse_text;
pub use time_step::{AdaptiveStep, TimeStep};
pub use tries::{TriesSpec, Until};
pub use validate::{MAX_DT_OVER_LAMBDA, MAX_EXTRAPOLATED_DT_OVER_BETA_LAMBDA};

#[cfg(test)]
mod extrusion_tests;
#[cfg(test)]
mod layout_tests;
#[cfg(test)]
mod tests;
