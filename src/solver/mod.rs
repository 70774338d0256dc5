//! Weak forms and solvers.
