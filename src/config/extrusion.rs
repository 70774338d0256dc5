//! Validation of an extrusion case (thesis §6.5; `geometry.extrusion`): the set-up, the mesh's
//! grid lines, what the free surface supports, and where its particles may start.

use super::case::{CaseSpec, FrameChoice, Geometry, DEFAULT_EXTRUSION_HEIGHT};
use super::error::SpecError;
use super::limits::MAX_MESH_ELEMENTS;
use super::validate::{check_pairs, positive, TOUCH_TOLERANCE};
use crate::solver::multiplier::RigidCondition;

/// Largest growth of the element size per element away from a refined die exit: neighbouring
/// elements differing by more than 30 % cost the Q2/Q1 pair accuracy for nothing.
const MAX_EXIT_GROWTH: f64 = 1.3;

impl CaseSpec {
    /// The set-up's lengths, its mesh height and the mesh's grid lines on x = 0 and y = H0.
    pub(super) fn validate_extrusion_geometry(&self) -> Result<(), SpecError> {
        let Geometry::Extrusion {
            h0,
            die_length,
            extrudate_length,
            flow_rate,
            height,
        } = self.geometry
        else {
            return Ok(());
        };
        positive("geometry.extrusion.h0", h0)?;
        positive("geometry.extrusion.die_length", die_length)?;
        positive("geometry.extrusion.extrudate_length", extrudate_length)?;
        positive("geometry.extrusion.flow_rate", flow_rate)?;
        if let Some(top) = height {
            if top.is_nan() || top <= h0 {
                return Err(SpecError::new(
                    "geometry.extrusion.height",
                    format!(
                        "the mesh height {top} must exceed the die half-height H0 = {h0} \
                         (room for the swell; default {DEFAULT_EXTRUSION_HEIGHT} H0)"
                    ),
                ));
            }
        }
        let [nx, ny] = self.numerics.mesh;
        let fits = self.extrusion().is_some_and(|e| e.fits(nx, ny));
        if self.numerics.die_exit.is_none() && nx > 0 && ny > 0 && !fits {
            return Err(SpecError::new(
                "numerics.mesh",
                format!(
                    "{nx}×{ny} uniform elements put no grid line on the die exit x = 0 or \
                     the die wall y = H0: choose n_x with L_w/(L_w + L_fs)·n_x and n_y with \
                     H0/height·n_y whole numbers"
                ),
            ));
        }
        Ok(())
    }

    /// `numerics.die_exit` checked, and `numerics.mesh` set to the element counts it makes (a
    /// given `mesh`, `mesh_given`, must be those); without it, `mesh` must be given. Runs on a
    /// set-up whose geometry has been validated.
    pub(super) fn resolve_die_exit_mesh(&mut self, mesh_given: bool) -> Result<(), SpecError> {
        let Some(d) = self.numerics.die_exit else {
            if !mesh_given {
                return Err(SpecError::new(
                    "numerics.mesh",
                    "missing: give the element counts [n1, n2], e.g. [200, 50]",
                ));
            }
            return Ok(());
        };
        let Some(e) = self.extrusion() else {
            return Err(SpecError::new(
                "numerics.die_exit",
                "refines the die exit of an extrusion; this geometry has none: remove the field",
            ));
        };
        positive("numerics.die_exit.h", d.h)?;
        positive("numerics.die_exit.band", d.band)?;
        if !(d.growth >= 1.0 && d.growth <= MAX_EXIT_GROWTH) {
            return Err(SpecError::new(
                "numerics.die_exit.growth",
                format!(
                    "the element size's growth per element must be between 1 and \
                     {MAX_EXIT_GROWTH} (got {})",
                    d.growth
                ),
            ));
        }
        let room = e
            .die_length
            .min(e.extrudate_length)
            .min(e.h0)
            .min(e.top - e.h0);
        if d.band > room {
            return Err(SpecError::new(
                "numerics.die_exit.band",
                format!(
                    "the refined square |x| ≤ {b}, |y − H0| ≤ {b} must lie in the mesh: band ≤ \
                     {room} (the die and extrudate lengths, H0 and height − H0)",
                    b = d.band
                ),
            ));
        }
        // the refined square alone, before its axes are built
        let whole = d.band / d.h;
        let square = (2.0 * whole).powi(2);
        if square > MAX_MESH_ELEMENTS {
            return Err(SpecError::new(
                "numerics.die_exit.h",
                format!(
                    "h = {} puts {square:.3e} elements in the refined square alone, more than \
                     {MAX_MESH_ELEMENTS:.0e}: use a larger h",
                    d.h
                ),
            ));
        }
        if let Some(c) = d.coarsest {
            if !(c >= d.h && c.is_finite()) {
                return Err(SpecError::new(
                    "numerics.die_exit.coarsest",
                    format!("the largest element must be at least h = {} (got {c})", d.h),
                ));
            }
        }
        let (ax, ay) = d.axes(&e);
        if d.h > d.band || !e.has_grid_lines(&ax, &ay) {
            return Err(SpecError::new(
                "numerics.die_exit.h",
                format!(
                    "band/h = {whole} must be a whole number ≥ 1, so that the die exit x = 0 \
                     and the die wall y = H0 are grid lines (band = {})",
                    d.band
                ),
            ));
        }
        let counts = [ax.len(), ay.len()];
        if mesh_given && self.numerics.mesh != counts {
            return Err(SpecError::new(
                "numerics.mesh",
                format!(
                    "the die-exit refinement makes {}×{} elements, not {}×{}: leave \
                     numerics.mesh out (it is set from numerics.die_exit) or give those counts",
                    counts[0], counts[1], self.numerics.mesh[0], self.numerics.mesh[1]
                ),
            ));
        }
        self.numerics.mesh = counts;
        Ok(())
    }

    /// What an extrusion runs with: XFEM (the free surface is cut like the particles), the weak
    /// rigid-body condition and the lab frame (the die and the inflow stay put), a mesh uniform
    /// or refined at the die exit (`numerics.die_exit`), not graded by `numerics.grading`.
    pub(super) fn validate_extrusion_numerics(&self) -> Result<(), SpecError> {
        let n = &self.numerics;
        let not_with = |field: &str, what: &str| {
            Err(SpecError::new(
                field,
                format!(
                    "{what} is not available with a free surface (extrusion); remove the field"
                ),
            ))
        };
        if !n.method.is_xfem() {
            return not_with("numerics.method", "the fictitious domain method");
        }
        if n.rigid_condition != RigidCondition::Weak {
            return not_with("numerics.rigid_condition", "the multiplier condition");
        }
        if n.frame != FrameChoice::Lab || n.frame_velocity != 0.0 || n.frame_rotation != 0.0 {
            return not_with("numerics.frame", "a moving frame");
        }
        if n.grading != 1.0 {
            return not_with("numerics.grading", "a graded mesh");
        }
        Ok(())
    }

    /// The particles start in the die, clear of its wall, the inflow and the symmetry line.
    pub(super) fn validate_extrusion_particles(
        &self,
        positions: &[[f64; 2]],
        a: f64,
        layout_field: &str,
    ) -> Result<(), SpecError> {
        let slack = TOUCH_TOLERANCE * a;
        let Some(e) = self.extrusion() else {
            return Ok(());
        };
        for (i, q) in positions.iter().enumerate() {
            let inside = q[0] - a > -e.die_length && q[0] <= 0.0 && q[1] - a > 0.0;
            if !inside || e.die_wall_gap(*q, a) <= slack {
                return Err(SpecError::new(
                    layout_field,
                    format!(
                        "particle {i} at ({}, {}) must start inside the die, clear of its \
                         wall, the inflow and the symmetry line: −L_w + a < x ≤ 0, \
                         a < y < H0 − a with L_w = {}, H0 = {}, a = {a}",
                        q[0], q[1], e.die_length, e.h0
                    ),
                ));
            }
        }
        check_pairs(positions, a, None, layout_field)
    }
}
