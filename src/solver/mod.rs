//! Weak forms and solvers.

pub mod norms;
pub mod stokes;
