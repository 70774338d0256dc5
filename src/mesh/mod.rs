//! Structured quadrilateral meshes with Q2 nodes (rectangle, annulus), graded spacing, periodicity.

pub mod axis;
pub mod equidistribute;
pub mod films;
pub mod follow;
mod ordering;
pub mod resolution;
pub mod structured;

pub use axis::Axis;
pub use films::Films;
pub use follow::{follow_axis, Follow, FollowError, FollowingMesh};
pub use structured::{bounding_box, dilate, Mesh, Shape, Side};
