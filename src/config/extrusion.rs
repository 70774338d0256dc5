//! Validation of an extrusion case (thesis §6.5; `geometry.extrusion`): the set-up, the mesh's
//! grid lines, what the free surface supports, and where its particles may start.

use super::case::{CaseSpec, FrameChoice, Geometry, DEFAULT_EXTRUSION_HEIGHT};
use super::error::SpecError;
use super::validate::{check_pairs, positive, TOUCH_TOLERANCE};
use crate::solver::multiplier::RigidCondition;

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
        if nx > 0 && ny > 0 && !fits {
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

    /// What an extrusion runs with: XFEM (the free surface is cut like the particles), the weak
    /// rigid-body condition and the lab frame (the die and the inflow stay put), a uniform mesh.
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
