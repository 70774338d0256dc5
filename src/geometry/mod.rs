//! Problem set-ups — where particles move: walls and their velocities, periodicity, contact and
//! the characteristic shear rate ([`Confinement`]: confined shear flow, the Couette cell) — and
//! initial particle layouts; the cylinder-channel benchmark of Ch. 2 ([`CylinderChannel`]). Free
//! surfaces (thesis Ch. 6) and two-phase flow (Ch. 4) will be set-ups here.

pub mod confinement;
pub mod couette;
pub mod cylinder;
pub mod layout;
pub mod shear;

pub use confinement::{Confinement, SetUp};
pub use couette::{CouetteError, CouetteGeometry, RotatingCouette};
pub use cylinder::CylinderChannel;
pub use shear::ConfinedShear;
