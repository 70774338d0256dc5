//! Weak forms and solvers.

pub mod norms;
pub mod rigid;
pub mod stokes;
