//! Problem set-ups — where particles move: walls and their velocities, periodicity, contact and
//! the characteristic shear rate ([`Confinement`]: confined shear flow, the Couette cell) — and
//! initial particle layouts; the cylinder-channel benchmark of Ch. 2 ([`CylinderChannel`]); the
//! extrusion die and extrudate of Ch. 6 ([`Extrusion`]). Two-phase flow (Ch. 4) will be a set-up
//! here.

pub mod confinement;
pub mod couette;
pub mod cylinder;
pub mod extrusion;
pub mod layout;
pub mod shear;

pub use confinement::{Boundary, Confinement, SetUp};
pub use couette::{CouetteError, CouetteGeometry, RotatingCouette};
pub use cylinder::CylinderChannel;
pub use extrusion::Extrusion;
pub use shear::ConfinedShear;
