//! Weak forms and solvers.

pub mod ale;
pub mod bdf;
pub mod constitutive;
pub mod constitutive_projection;
pub mod constitutive_stress;
pub mod cutcells;
pub mod flow;
pub mod free_surface;
pub mod ghost;
pub mod log_conformation_history;
pub mod lubrication;
pub mod moving;
pub mod multiplier;
pub mod norms;
pub mod polymer_terms;
pub mod rigid;
pub mod supg;
pub mod viscoelastic;
