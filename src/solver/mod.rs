//! Weak forms and solvers.

pub mod cutcells;
pub mod motion;
pub mod norms;
pub mod polymer_terms;
pub mod rigid;
pub mod stokes;
