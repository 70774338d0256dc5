//! Finite elements: reference elements, quadrature, sparse assembly, linear solvers.

pub mod element;
pub mod ilu;
pub mod krylov;
pub mod linsolve;
pub mod newton_inverse;
pub mod quadrature;
pub mod sparse;
pub mod substructure;
