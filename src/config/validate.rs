//! Building a [`CaseSpec`] from a JSON value: shorthand resolution (δ → H, ε → a), typed deserialization
//! with field paths in errors, and physical validation (ranges, particles overlapping each other or a wall).

use serde_json::Value;

use super::case::{CaseSpec, Geometry, Layout, Model, StressCoupling};
use super::error::{json_path_at_line, SpecError};
use super::time_step::TimeStep;
use crate::geometry::layout;

/// Particles may touch each other or a wall initially (the thesis' δ = 2 set-up touches the walls, 5.7.3);
/// only overlaps deeper than this fraction of the radius are rejected, to forgive decimal rounding.
pub(super) const TOUCH_TOLERANCE: f64 = 1e-9;

/// Largest Δt/λ accepted. The Gear scheme treats the relaxation term explicitly (thesis
/// Eq. 5.52): a stress-free start with Δt ≫ λ diverged (a Wi → 0 case with Δt = 10λ), and the
/// Giesekus relaxation rate grows above 1/λ with the stress; half of λ leaves that margin.
pub const MAX_DT_OVER_LAMBDA: f64 = 0.5;

/// Largest Δt/(βλ) accepted with the extrapolated explicit stress (`explicit_extrapolated`). The
/// extrapolation makes the explicit coupling unstable where the solvent's share of the viscosity
/// is small against the step: three particles at Wi = 1 (λ = 1) diverged at β = 0.1 with
/// Δt = 0.04 and ran at 0.02; β = 0.2 ran at 0.04, β = 0.5 at 0.08 (docs/validation.md, "Why the
/// lag decides some runs"). 0.2 βλ is the largest step seen stable at each β.
pub const MAX_EXTRAPOLATED_DT_OVER_BETA_LAMBDA: f64 = 0.2;

impl CaseSpec {
    /// Builds and validates a case from a JSON value (the base table of a sweep with its axis values set).
    ///
    /// Shorthands are resolved first: `geometry.confined_shear.delta = δ` sets H = 2aδ and `particles.eps = ε`
    /// (Couette) sets a = ε (R2 − R1)/2. The error names the field path and says what to change.
    pub fn from_value(mut value: Value) -> Result<CaseSpec, SpecError> {
        resolve_shorthands(&mut value)?;
        check_mesh_shape(&value)?;
        let mesh_given = value.pointer("/numerics/mesh").is_some();
        // Deserialize from pretty text so that serde's line number locates the field.
        let pretty =
            serde_json::to_string_pretty(&value).map_err(|e| SpecError::new("", e.to_string()))?;
        let mut spec: CaseSpec = serde_json::from_str(&pretty).map_err(|e| {
            let text = e.to_string();
            let message = match text.find(" at line ") {
                Some(i) => text[..i].to_string(),
                None => text,
            };
            SpecError::new(json_path_at_line(&pretty, e.line()), message)
        })?;
        // (the die-exit refinement is built on a valid set-up, and sets the element counts the
        // other checks use)
        spec.validate_geometry()?;
        spec.resolve_die_exit_mesh(mesh_given)?;
        spec.validate()?;
        Ok(spec)
    }

    /// Checks the physics: positive sizes, parameter ranges, particles inside the domain and apart.
    fn validate(&self) -> Result<(), SpecError> {
        self.validate_geometry()?;
        self.validate_fluid()?;
        self.validate_numerics()?;
        self.validate_mesh_size()?;
        self.validate_time_step()?;
        self.validate_particles()?;
        self.validate_distance_per_step()?;
        self.validate_follow_room()
    }

    fn validate_time_step(&self) -> Result<(), SpecError> {
        let lambda = self.relaxation_time();
        let (dt, field) = match self.numerics.dt {
            TimeStep::Fixed(dt) => (dt, "numerics.dt"),
            TimeStep::Adaptive(a) => (a.max, "numerics.dt.max"),
        };
        if lambda > 0.0 && lambda.is_finite() && dt > MAX_DT_OVER_LAMBDA * lambda {
            return Err(SpecError::new(
                field,
                format!(
                    "Δt = {dt} is more than {MAX_DT_OVER_LAMBDA} λ (λ = Wi/γ̇ = {lambda:.4}): the \
                     relaxation term is explicit in the time scheme and diverges for Δt ≳ λ; \
                     use dt ≤ {:.4}",
                    MAX_DT_OVER_LAMBDA * lambda
                ),
            ));
        }
        let limit = MAX_EXTRAPOLATED_DT_OVER_BETA_LAMBDA * self.fluid.beta * lambda;
        if self.numerics.coupling == StressCoupling::ExplicitExtrapolated
            && lambda > 0.0
            && lambda.is_finite()
            && dt > limit
        {
            return Err(SpecError::new(
                field,
                format!(
                    "Δt = {dt} is more than {MAX_EXTRAPOLATED_DT_OVER_BETA_LAMBDA} βλ (β = {}, \
                     λ = {lambda:.4}): the extrapolated explicit stress is unstable at such steps \
                     with this little solvent; use dt ≤ {limit:.4}, or numerics.coupling = \
                     \"explicit_coupled_g\"",
                    self.fluid.beta
                ),
            ));
        }
        Ok(())
    }

    fn validate_geometry(&self) -> Result<(), SpecError> {
        match self.geometry {
            Geometry::ConfinedShear { h, l, wall_speed } => {
                positive("geometry.confined_shear.h", h)?;
                positive("geometry.confined_shear.l", l)?;
                positive("geometry.confined_shear.wall_speed", wall_speed)
            }
            Geometry::Couette {
                r1,
                r2,
                omega_inner,
            } => {
                positive("geometry.couette.r1", r1)?;
                positive("geometry.couette.omega_inner", omega_inner)?;
                if r2.is_nan() || r2 <= r1 {
                    return Err(SpecError::new(
                        "geometry.couette.r2",
                        format!("R2 = {r2} must exceed R1 = {r1}"),
                    ));
                }
                Ok(())
            }
            Geometry::Extrusion { .. } => self.validate_extrusion_geometry(),
            Geometry::CylinderChannel {
                radius,
                h,
                l,
                mean_velocity,
            } => {
                positive("geometry.cylinder_channel.radius", radius)?;
                positive("geometry.cylinder_channel.mean_velocity", mean_velocity)?;
                if h.is_nan() || h <= 2.0 * radius {
                    return Err(SpecError::new(
                        "geometry.cylinder_channel.h",
                        format!("H = {h} must exceed the cylinder diameter 2R = {} (the benchmark uses H = 4R)", 2.0 * radius),
                    ));
                }
                if l.is_nan() || l <= 2.0 * radius {
                    return Err(SpecError::new(
                        "geometry.cylinder_channel.l",
                        format!("L = {l} must exceed the cylinder diameter (the benchmark uses L = 30R)"),
                    ));
                }
                Ok(())
            }
        }
    }

    fn validate_fluid(&self) -> Result<(), SpecError> {
        let f = &self.fluid;
        if !(f.wi >= 0.0 && f.wi.is_finite()) {
            return Err(SpecError::new(
                "fluid.wi",
                format!("Wi = {} must be a finite number ≥ 0", f.wi),
            ));
        }
        if !(0.0..1.0).contains(&f.alpha) {
            return Err(SpecError::new(
                "fluid.alpha",
                format!("α = {} must be in [0, 1)", f.alpha),
            ));
        }
        if !(0.0..1.0).contains(&f.beta) {
            return Err(SpecError::new(
                "fluid.beta",
                format!("β = {} must be in [0, 1)", f.beta),
            ));
        }
        match f.model {
            Model::Newtonian if f.wi != 0.0 => Err(SpecError::new(
                "fluid.wi",
                format!("a newtonian fluid has Wi = 0 (got {}); use model = \"giesekus\" or \"oldroyd_b\"", f.wi),
            )),
            Model::OldroydB if f.alpha != 0.0 => Err(SpecError::new(
                "fluid.alpha",
                format!("oldroyd_b has no mobility (got α = {}); set alpha = 0 or use model = \"giesekus\"", f.alpha),
            )),
            _ => Ok(()),
        }
    }

    /// A mesh that follows the particles must have room for its cores around the initial
    /// positions (after the particles are known to be valid and inside the domain).
    fn validate_follow_room(&self) -> Result<(), SpecError> {
        let Some(follow) = self.following_mesh() else {
            return Ok(());
        };
        follow
            .mesh_at(&self.initial_positions())
            .map(|_| ())
            .map_err(|e| {
                SpecError::new(
                    "numerics.follow",
                    format!("no room to refine the mesh around the initial positions, {e}"),
                )
            })
    }

    fn validate_particles(&self) -> Result<(), SpecError> {
        let Some(p) = &self.particles else {
            return match self.geometry {
                // an extrusion without particles: the extrudate swell
                Geometry::CylinderChannel { .. } | Geometry::Extrusion { .. } => Ok(()),
                _ => Err(SpecError::new(
                    "particles",
                    "this geometry needs a [particles] table with radius and layout",
                )),
            };
        };
        if matches!(self.geometry, Geometry::CylinderChannel { .. }) {
            return Err(SpecError::new(
                "particles",
                "cylinder_channel has its fixed cylinder in the geometry; remove the [particles] table",
            ));
        }
        positive("particles.radius", p.radius)?;
        let a = p.radius;
        match &p.layout {
            Layout::String { n, lx, ly, perturb } => {
                if *n == 0 {
                    return Err(SpecError::new(
                        "particles.layout.string.n",
                        "N = 0: a string needs at least one particle",
                    ));
                }
                finite("particles.layout.string.lx", *lx)?;
                finite("particles.layout.string.ly", *ly)?;
                for d in perturb.iter().flatten() {
                    finite("particles.layout.string.perturb", *d)?;
                }
            }
            Layout::Pair { lx, ly } => {
                finite("particles.layout.pair.lx", *lx)?;
                finite("particles.layout.pair.ly", *ly)?;
            }
            Layout::Explicit { positions } => {
                if positions.is_empty() {
                    return Err(SpecError::new(
                        "particles.layout.explicit.positions",
                        "N = 0: give at least one centre",
                    ));
                }
                for (i, q) in positions.iter().enumerate() {
                    finite(&format!("particles.layout.explicit.positions[{i}]"), q[0])?;
                    finite(&format!("particles.layout.explicit.positions[{i}]"), q[1])?;
                }
            }
            Layout::Couette { r0_star, .. } => {
                finite("particles.layout.couette.r0_star", *r0_star)?;
                if !matches!(self.geometry, Geometry::Couette { .. }) {
                    return Err(SpecError::new(
                        "particles.layout.couette",
                        "the couette layout needs geometry.couette; use string, pair or explicit",
                    ));
                }
            }
        }
        let layout_field = match &p.layout {
            Layout::String { .. } => "particles.layout.string",
            Layout::Pair { .. } => "particles.layout.pair",
            Layout::Explicit { .. } => "particles.layout.explicit",
            Layout::Couette { .. } => "particles.layout.couette",
        };
        let positions = self.initial_positions();
        let slack = TOUCH_TOLERANCE * a;
        match self.geometry {
            Geometry::ConfinedShear { h, l, .. } => {
                if a >= h / 2.0 {
                    return Err(SpecError::new(
                        "particles.radius",
                        format!("a = {a} ≥ H/2 = {}: the particle does not fit in the channel; make a < H/2", h / 2.0),
                    ));
                }
                for (i, q) in positions.iter().enumerate() {
                    if q[1].abs() + a > h / 2.0 + slack {
                        return Err(SpecError::new(
                            layout_field,
                            format!(
                                "particle {i} at y = {} overlaps a wall (|y| + a = {} > H/2 = {}); reduce l_y or a, or increase H",
                                q[1],
                                q[1].abs() + a,
                                h / 2.0
                            ),
                        ));
                    }
                    if q[0].abs() > l / 2.0 {
                        return Err(SpecError::new(
                            layout_field,
                            format!("particle {i} at x = {} lies outside the channel [−L/2, L/2] with L = {l}", q[0]),
                        ));
                    }
                }
                check_pairs(&positions, a, Some(l), layout_field)
            }
            Geometry::Couette { r1, r2, .. } => {
                for (i, q) in positions.iter().enumerate() {
                    let r = q[0].hypot(q[1]);
                    if r - a < r1 - slack || r + a > r2 + slack {
                        let eps = 2.0 * a / (r2 - r1);
                        return Err(SpecError::new(
                            layout_field,
                            format!(
                                "particle {i} at r* = {:.4} overlaps a cylinder; r* must lie in [ε/2, 1 − ε/2] = [{:.4}, {:.4}]",
                                layout::r_star(r1, r2, *q),
                                eps / 2.0,
                                1.0 - eps / 2.0
                            ),
                        ));
                    }
                }
                check_pairs(&positions, a, None, layout_field)
            }
            Geometry::Extrusion { .. } => {
                self.validate_extrusion_particles(&positions, a, layout_field)
            }
            Geometry::CylinderChannel { .. } => Ok(()),
        }
    }
}

/// Rejects pairs of particles that overlap (periodic in x with period `period`).
pub(super) fn check_pairs(
    positions: &[[f64; 2]],
    a: f64,
    period: Option<f64>,
    field: &str,
) -> Result<(), SpecError> {
    for i in 0..positions.len() {
        for j in i + 1..positions.len() {
            let gap = layout::surface_gap(positions[i], positions[j], a, period);
            if gap < -TOUCH_TOLERANCE * a {
                return Err(SpecError::new(
                    field,
                    format!("particles {i} and {j} overlap (surface gap {gap:.4}); increase l_x/l_y or reduce a"),
                ));
            }
        }
    }
    Ok(())
}

pub(super) fn positive(field: &str, x: f64) -> Result<(), SpecError> {
    if x > 0.0 && x.is_finite() {
        Ok(())
    } else {
        Err(SpecError::new(
            field,
            format!("must be a finite number > 0 (got {x})"),
        ))
    }
}

fn finite(field: &str, x: f64) -> Result<(), SpecError> {
    if x.is_finite() {
        Ok(())
    } else {
        Err(SpecError::new(
            field,
            format!("must be a finite number (got {x})"),
        ))
    }
}

/// `numerics.mesh` is two whole numbers: said so by name (serde's message for three entries is
/// "trailing characters").
fn check_mesh_shape(value: &Value) -> Result<(), SpecError> {
    let Some(mesh) = value.pointer("/numerics/mesh") else {
        return Ok(());
    };
    let counts = mesh.as_array().filter(|m| m.len() == 2);
    if counts.is_none_or(|m| m.iter().any(|n| n.as_u64().is_none())) {
        return Err(SpecError::new(
            "numerics.mesh",
            format!(
                "give two element counts [n1, n2] as whole numbers, e.g. [200, 50] (got {mesh})"
            ),
        ));
    }
    Ok(())
}

/// Replaces `geometry.confined_shear.delta` by `h` and `particles.eps` by `radius`.
fn resolve_shorthands(value: &mut Value) -> Result<(), SpecError> {
    let number = |v: &Value, field: &str| {
        v.as_f64()
            .ok_or_else(|| SpecError::new(field, format!("invalid type: {v}, expected a number")))
    };
    // ε → a (Couette), before δ → H, which needs a.
    if let Some(eps) = value.pointer("/particles/eps").cloned() {
        let eps = number(&eps, "particles.eps")?;
        let (r1, r2) = match value.pointer("/geometry/couette") {
            Some(c) => (
                c.get("r1").and_then(Value::as_f64).unwrap_or(f64::NAN),
                c.get("r2").and_then(Value::as_f64).unwrap_or(f64::NAN),
            ),
            None => {
                return Err(SpecError::new(
                    "particles.eps",
                    "ε is for Couette flow; give particles.radius instead",
                ))
            }
        };
        if value.pointer("/particles/radius").is_some() {
            return Err(SpecError::new(
                "particles.eps",
                "give either particles.radius or particles.eps, not both",
            ));
        }
        if !(eps > 0.0 && eps < 1.0) {
            return Err(SpecError::new(
                "particles.eps",
                format!("ε = 2a/(R2 − R1) = {eps} must be in (0, 1)"),
            ));
        }
        if let Some(p) = value.get_mut("particles").and_then(Value::as_object_mut) {
            p.remove("eps");
            p.insert("radius".into(), Value::from(eps * (r2 - r1) / 2.0));
        }
    }
    if let Some(delta) = value.pointer("/geometry/confined_shear/delta").cloned() {
        let delta = number(&delta, "geometry.confined_shear.delta")?;
        if value.pointer("/geometry/confined_shear/h").is_some() {
            return Err(SpecError::new(
                "geometry.confined_shear.delta",
                "give either h or delta = H/2a, not both (remove h from the base when sweeping delta)",
            ));
        }
        let Some(a) = value.pointer("/particles/radius").and_then(Value::as_f64) else {
            return Err(SpecError::new(
                "geometry.confined_shear.delta",
                "delta = H/2a needs particles.radius",
            ));
        };
        if delta.is_nan() || delta <= 1.0 {
            return Err(SpecError::new(
                "geometry.confined_shear.delta",
                format!("δ = H/2a = {delta} must exceed 1 for the particle to fit (a < H/2)"),
            ));
        }
        if let Some(g) = value
            .pointer_mut("/geometry/confined_shear")
            .and_then(Value::as_object_mut)
        {
            g.remove("delta");
            g.insert("h".into(), Value::from(2.0 * a * delta));
        }
    }
    Ok(())
}
