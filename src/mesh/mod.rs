//! Structured quadrilateral meshes with Q2 nodes (rectangle, annulus), graded spacing, periodicity.
