//! Problem set-ups — where particles move: walls and their velocities, periodicity, contact and
//! the characteristic shear rate ([`Confinement`]: confined shear flow, the Couette cell) — and
//! initial particle layouts. The cylinder-channel benchmark's set-up lives with its validation
//! (`validate::xstokes`); free surfaces (thesis Ch. 6) will be a set-up here.

pub mod confinement;
pub mod couette;
pub mod layout;
pub mod shear;

pub use confinement::{Confinement, SetUp};
pub use couette::{CouetteError, CouetteGeometry, RotatingCouette};
pub use shear::ConfinedShear;
