//! xpflow: XFEM simulation of rigid particles in viscoelastic fluids, with parameter sweeps.
//!
//! Module layering, each importing only modules before it (`docs/architecture.md`):
//! `fem, rheology, particles → mesh → xfem → geometry → config → solver → observe → simulate →
//! store → sweep → validate, bench → cli`.

// Index loops mirror the tensor notation of the weak forms (i, j, k, l); iterator chains would hide it.
#![allow(clippy::needless_range_loop)]

pub mod bench;
pub mod cli;
pub mod config;
pub mod fem;
pub mod geometry;
pub mod mesh;
pub mod observe;
pub mod particles;
pub mod periodic;
pub mod rheology;
pub mod simulate;
pub mod solver;
pub mod store;
pub mod sweep;
pub mod validate;
pub mod xfem;
