//! The checks of a case's `numerics` table: mesh, time step, quadrature, coupling, history
//! remap, frame, following mesh, solver options and the combinations they refuse, each error
//! naming its field.

use super::case::{CaseSpec, FrameChoice, Geometry, HistoryRemap, StressCoupling};
use super::error::SpecError;
use super::validate::positive;

/// Largest quadtree level accepted: level 10 already integrates the disc area to 1e-10 (thesis Table 2.2).
const MAX_QUADTREE_LEVEL: u32 = 12;

impl CaseSpec {
    pub(super) fn validate_numerics(&self) -> Result<(), SpecError> {
        let n = &self.numerics;
        if n.mesh[0] == 0 || n.mesh[1] == 0 {
            return Err(SpecError::new(
                "numerics.mesh",
                "both element counts must be ≥ 1",
            ));
        }
        if self.fluid.wi > 0.0 {
            // the history remap's stencil: N vertices per axis, distinct on a periodic axis too
            let (stencil, name) = match n.remap {
                HistoryRemap::Bilinear => (2, "bilinear"),
                HistoryRemap::Biquadratic => (3, "biquadratic"),
                HistoryRemap::Bicubic => (4, "bicubic"),
            };
            if n.mesh[0].min(n.mesh[1]) < stencil {
                return Err(SpecError::new(
                    "numerics.mesh",
                    format!(
                        "the {name} history remap interpolates on {stencil}×{stencil} vertices: \
                         the mesh needs at least {stencil} elements in each direction (got {}×{})",
                        n.mesh[0], n.mesh[1]
                    ),
                ));
            }
        }
        for (field, ratio, direction) in [
            ("numerics.grading", n.grading, "across"),
            ("numerics.grading_x", n.grading_x, "along"),
        ] {
            if !(ratio >= 1.0 && ratio.is_finite()) {
                return Err(SpecError::new(
                    field,
                    format!(
                        "the ratio of the largest to the smallest element {direction} the channel \
                         must be ≥ 1 (got {ratio})"
                    ),
                ));
            }
        }
        if n.grading_x != 1.0 && !matches!(self.geometry, Geometry::ConfinedShear { .. }) {
            return Err(SpecError::new(
                "numerics.grading_x",
                "grading along x applies to the confined-shear channel only; remove it",
            ));
        }
        if let Some(f) = &n.follow {
            let moving = match self.geometry {
                Geometry::ConfinedShear { .. } => self.fluid.wi > 0.0,
                Geometry::Couette { .. } => true,
                Geometry::CylinderChannel { .. } | Geometry::Extrusion { .. } => false,
            };
            if !moving {
                return Err(SpecError::new(
                    "numerics.follow",
                    "a mesh that follows the particles applies to the moving-particle runs \
                     (Couette cell, confined shear with Wi > 0) only, not yet to extrusion; \
                     remove the field",
                ));
            }
            for (field, ratio) in [
                ("numerics.follow.ratio", f.ratio),
                ("numerics.follow.ratio_y", f.ratio_y.unwrap_or(1.0)),
            ] {
                if !(ratio >= 1.0 && ratio.is_finite()) {
                    return Err(SpecError::new(
                        field,
                        format!("the core refinement must be ≥ 1 (got {ratio})"),
                    ));
                }
            }
            if let Some(e) = f.films {
                if !matches!(self.geometry, Geometry::ConfinedShear { .. }) {
                    return Err(SpecError::new(
                        "numerics.follow.films",
                        "the film refinement applies to the confined-shear channel only; remove \
                         the field",
                    ));
                }
                if !(e >= 1.0 && e.is_finite()) {
                    return Err(SpecError::new(
                        "numerics.follow.films",
                        format!("elements across a film must be ≥ 1 (got {e})"),
                    ));
                }
                if let Some(r) = f.film_reach.filter(|r| !r.is_finite() || *r <= 0.0) {
                    return Err(SpecError::new(
                        "numerics.follow.film_reach",
                        format!("a film's zone must be a positive number of radii (got {r})"),
                    ));
                }
            }
            if !(f.core > 0.0 && f.reach > f.core && f.reach.is_finite()) {
                return Err(SpecError::new(
                    "numerics.follow",
                    format!(
                        "need 0 < core < reach (in particle radii; got core {}, reach {})",
                        f.core, f.reach
                    ),
                ));
            }
        }
        if n.grid_deformation {
            return Err(SpecError::new(
                "numerics.grid_deformation",
                "the grid deformation method (thesis 3.3.4) is not implemented; remove the field \
                 (numerics.follow refines the mesh around moving particles, numerics.grading the \
                 centre of the channel)",
            ));
        }
        let explicit = matches!(
            n.coupling,
            StressCoupling::Explicit
                | StressCoupling::ExplicitCoupledG
                | StressCoupling::ExplicitExtrapolated
        );
        if explicit && self.fluid.beta == 0.0 && self.fluid.wi > 0.0 {
            return Err(SpecError::new(
                "numerics.coupling",
                "the explicit stress coupling needs a solvent viscosity (β > 0): with β = 0 the \
                 flow matrix has no viscous term; use \"semi_implicit\" or \"auto\"",
            ));
        }
        let confined = matches!(self.geometry, Geometry::ConfinedShear { .. });
        let couette = matches!(self.geometry, Geometry::Couette { .. });
        for (field, v, fits, only) in [
            (
                "numerics.frame_velocity",
                n.frame_velocity,
                confined,
                "a translating frame applies to the periodic channel (confined_shear) only",
            ),
            (
                "numerics.frame_rotation",
                n.frame_rotation,
                couette,
                "a rotating frame applies to the Couette cell only",
            ),
        ] {
            if !v.is_finite() {
                return Err(SpecError::new(field, "must be finite"));
            }
            if v != 0.0 && !fits {
                return Err(SpecError::new(field, only));
            }
        }
        if n.frame == FrameChoice::Particle {
            if n.frame_velocity != 0.0 || n.frame_rotation != 0.0 {
                return Err(SpecError::new(
                    "numerics.frame",
                    "\"particle\" computes the frame itself: remove frame_velocity / frame_rotation",
                ));
            }
            if matches!(self.geometry, Geometry::CylinderChannel { .. }) {
                return Err(SpecError::new(
                    "numerics.frame",
                    "the cylinder channel has no particle to follow",
                ));
            }
            if confined && self.fluid.wi == 0.0 {
                return Err(SpecError::new(
                    "numerics.frame",
                    "the quasi-static Stokes runner (Wi = 0) has no moving frame; remove the field",
                ));
            }
        }
        if n.frame_velocity != 0.0 && self.fluid.wi == 0.0 {
            return Err(SpecError::new(
                "numerics.frame_velocity",
                "the quasi-static Stokes runner (Wi = 0) has no translating frame; remove the field",
            ));
        }
        n.dt.validate()?;
        positive("numerics.t_end", n.t_end)?;
        if let Some(dt) = n.supg_dt {
            positive("numerics.supg_dt", dt)?;
            if self.relaxation_time() == 0.0 {
                return Err(SpecError::new(
                    "numerics.supg_dt",
                    "a Newtonian case (no relaxation time) transports no stress: remove the field",
                ));
            }
        }
        if n.t_end < n.dt.initial() {
            return Err(SpecError::new(
                "numerics.t_end",
                format!(
                    "t_end = {} is shorter than one time step dt = {}",
                    n.t_end,
                    n.dt.initial()
                ),
            ));
        }
        if n.quadtree_level > MAX_QUADTREE_LEVEL {
            return Err(SpecError::new(
                "numerics.quadtree_level",
                format!(
                    "level {} is more than {MAX_QUADTREE_LEVEL}; levels above 10 gain nothing",
                    n.quadtree_level
                ),
            ));
        }
        n.method.check(n)?;
        if self.extrusion().is_some() {
            self.validate_extrusion_numerics()?;
        }
        if self.output.sample_every == 0 {
            return Err(SpecError::new(
                "output.sample_every",
                "must be ≥ 1 (store every k-th step)",
            ));
        }
        if !self.output.undisturbed_surface && self.extrusion().is_none() {
            return Err(SpecError::new(
                "output.undisturbed_surface",
                "only an extrusion has an undisturbed surface to skip; remove the field",
            ));
        }
        Ok(())
    }
}
