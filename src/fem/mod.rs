//! Finite elements: reference elements, quadrature, dof maps, sparse assembly, linear solvers.

pub mod quadrature;
