//! What a case implies beyond its fields: the particle radius and count, its mesh (base and
//! following), the initial particle positions, the solver's frame, its rates and time scales,
//! and the parameters of its set-up (δ, ε, r0*, spacing, channel) as the database's columns hold
//! them ([`PARAMETER_COLUMNS`]).

use serde_json::{json, Value};

use super::case::{CaseSpec, FrameChoice, Geometry, Layout, Model, DEFAULT_EXTRUSION_HEIGHT};
use crate::geometry::{layout, Extrusion};
use crate::mesh::{Axis, Films, FollowingMesh, Mesh, Shape};

/// Reach of the film refinement (`numerics.follow.films`), in radii, by default
/// (`numerics.follow.film_reach`): the zone holds 32 elements each side at a/8, so that the
/// core's ≈ 2E (E = 8: 16) come from tapers no more than [`FILM_COARSEST`] times coarser.
/// Measured: with 1.5 radii and no cap, E = 8 coarsened the particles' far sides to ≈ 0.3a and
/// turned Table 5.2's Wi = 2 pair (a string at E = 2 and 4) into one that separates.
pub const FILM_REACH: f64 = 4.0;
/// Largest element in a film's zone relative to the mesh's own there (`numerics.follow.films`).
pub const FILM_COARSEST: f64 = 1.5;
/// Largest refinement at a film (`numerics.follow.films`): a/8 → a/256, four elements across a
/// film of 0.016a; thinner films (near contact) get fewer.
pub const FILM_MAX_RATIO: f64 = 32.0;

/// The film refinement of a case (`numerics.follow.films = elements`, `film_reach` in radii or
/// [`FILM_REACH`]) for particles of radius `a`: what the following mesh, the resolved settings
/// and `validate film-polymer` all take.
pub fn film_refinement(a: f64, elements: f64, film_reach: Option<f64>) -> Films {
    Films {
        radius: a,
        elements,
        max_ratio: FILM_MAX_RATIO,
        reach: film_reach.unwrap_or(FILM_REACH) * a,
        coarsest: FILM_COARSEST,
    }
}

/// The columns of a case's parameters in the results database (`cases`), in the order of
/// [`CaseSpec::parameter_columns`]: what `xpflow query --where` and `xpflow sweep --where` select by.
pub const PARAMETER_COLUMNS: [&str; 15] = [
    "wi",
    "alpha",
    "beta",
    "delta",
    "n_particles",
    "a",
    "h",
    "l",
    "lx",
    "ly",
    "r0",
    "eps",
    "mesh",
    "dt",
    "t_end",
];

impl CaseSpec {
    /// The case's parameters by [`PARAMETER_COLUMNS`]: numbers, the mesh as `NxM` text, `null`
    /// where the set-up has none (δ of a Couette case, r0* of a channel).
    pub fn parameter_columns(&self) -> [(&'static str, Value); 15] {
        let (h, l) = self.channel().unzip();
        let (lx, ly) = self.spacing().unzip();
        let mut values = [
            json!(self.fluid.wi),
            json!(self.fluid.alpha),
            json!(self.fluid.beta),
            json!(self.delta()),
            json!(self.n_particles()),
            json!(self.radius()),
            json!(h),
            json!(l),
            json!(lx),
            json!(ly),
            json!(self.r0_star()),
            json!(self.eps()),
            json!(format!(
                "{}x{}",
                self.numerics.mesh[0], self.numerics.mesh[1]
            )),
            json!(self.numerics.dt.initial()),
            json!(self.numerics.t_end),
        ];
        std::array::from_fn(|i| (PARAMETER_COLUMNS[i], values[i].take()))
    }

    /// Particle radius a, or `None` without particles.
    pub fn radius(&self) -> Option<f64> {
        self.particles.as_ref().map(|p| p.radius)
    }

    /// The case's computational mesh before any refinement around particles: the confined-shear
    /// channel ([`Mesh::channel`]), the Couette annulus (`numerics.mesh` = [radial,
    /// azimuthal]) or the extrusion's (uniform, or refined at the die exit by
    /// `numerics.die_exit`); `None` for the cylinder channel (built by its validation).
    pub fn base_mesh(&self) -> Option<Mesh> {
        let n = &self.numerics;
        match self.geometry {
            Geometry::ConfinedShear { h, l, .. } => {
                Some(Mesh::channel(h, l, n.mesh, n.grading, n.grading_x))
            }
            Geometry::Couette { r1, r2, .. } => Some(Mesh::annulus(
                n.mesh[1],
                Axis::centred(r1, r2, n.mesh[0], n.grading),
            )),
            Geometry::Extrusion { .. } => self
                .extrusion_axes()
                .map(|(ax, ay)| Mesh::rectangle(ax, ay, false)),
            Geometry::CylinderChannel { .. } => None,
        }
    }

    /// The axes of an extrusion's mesh: `numerics.mesh` uniform, or refined at the die exit by
    /// `numerics.die_exit`; `None` for another geometry.
    pub fn extrusion_axes(&self) -> Option<(Axis, Axis)> {
        let (e, n) = (self.extrusion()?, &self.numerics);
        Some(match n.die_exit {
            Some(d) => d.axes(&e),
            None => e.uniform_axes(n.mesh[0], n.mesh[1]),
        })
    }

    /// The extrusion set-up of an `extrusion` geometry (the mesh height resolved).
    pub fn extrusion(&self) -> Option<Extrusion> {
        match self.geometry {
            Geometry::Extrusion {
                h0,
                die_length,
                extrudate_length,
                flow_rate,
                height,
            } => Some(Extrusion {
                h0,
                die_length,
                extrudate_length,
                flow_rate,
                top: height.unwrap_or(DEFAULT_EXTRUSION_HEIGHT * h0),
            }),
            _ => None,
        }
    }

    /// The mesh that follows the particles (`numerics.follow` on [`base_mesh`](Self::base_mesh);
    /// an annulus' θ axis refined by angles: arcs at the first particle's start radius), or
    /// `None` without `numerics.follow`.
    pub fn following_mesh(&self) -> Option<FollowingMesh> {
        let (f, a, base) = (self.numerics.follow?, self.radius()?, self.base_mesh()?);
        let x0 = self.initial_positions();
        let arc = match base.shape {
            Shape::Annulus => Some(x0.first()?[0].hypot(x0.first()?[1])),
            Shape::Rectangle => None,
        };
        let [x, y] = f.axes(a, arc);
        let films = f
            .films
            .map(|elements| film_refinement(a, elements, f.film_reach));
        Some(FollowingMesh { base, x, y, films })
    }

    /// Initial particle centres in the order the particles are numbered everywhere else.
    pub fn initial_positions(&self) -> Vec<[f64; 2]> {
        let Some(p) = &self.particles else {
            return Vec::new();
        };
        match &p.layout {
            Layout::String { n, lx, ly, perturb } => {
                let mut x = layout::string_positions(*n, *lx, *ly);
                if let Some([dx, dy]) = perturb {
                    x[n / 2] = [x[n / 2][0] + dx, x[n / 2][1] + dy];
                }
                x
            }
            Layout::Pair { lx, ly } => layout::pair_positions(*lx, *ly),
            Layout::Explicit { positions } => positions.clone(),
            Layout::Couette { r0_star, angle } => match self.geometry {
                Geometry::Couette { r1, r2, .. } => {
                    vec![layout::couette_position(r1, r2, *r0_star, *angle)]
                }
                // Validation rejects a Couette layout in another geometry; place it at the origin meanwhile.
                _ => vec![[0.0, 0.0]],
            },
        }
    }

    /// The frame the solver works in: (translation velocity along x, rotation rate about the
    /// origin), from `numerics.frame` or the explicit `frame_velocity` / `frame_rotation`.
    pub fn solver_frame(&self) -> (f64, f64) {
        let n = &self.numerics;
        if n.frame == FrameChoice::Lab {
            return (n.frame_velocity, n.frame_rotation);
        }
        let Some(&x0) = self.initial_positions().first() else {
            return (0.0, 0.0);
        };
        match self.geometry {
            // walls at ±U_w/2: the undisturbed u = U_w y/H
            Geometry::ConfinedShear { h, wall_speed, .. } => (wall_speed * x0[1] / h, 0.0),
            // u_θ = A r + B/r with A = −ω̄R1²/(R2² − R1²), B = ω̄R1²R2²/(R2² − R1²): Ω = A + B/r²
            Geometry::Couette {
                r1,
                r2,
                omega_inner,
            } => {
                let d = r2 * r2 - r1 * r1;
                let r_sq = x0[0] * x0[0] + x0[1] * x0[1];
                let omega = omega_inner * r1 * r1 / d * (r2 * r2 / r_sq - 1.0);
                (0.0, omega)
            }
            Geometry::CylinderChannel { .. } | Geometry::Extrusion { .. } => (0.0, 0.0),
        }
    }

    /// Number of particles N.
    pub fn n_particles(&self) -> usize {
        self.initial_positions().len()
    }

    /// Characteristic rate γ̇ that makes times and angular velocities dimensionless (t* = tγ̇, ω* = ω/γ̇):
    /// U_w/H (confined shear, thesis 5.7.1), ω̄ R1/(R2 − R1) (Couette, 3.5.1), U/R (cylinder channel),
    /// U/H0 = Q/H0² (extrusion, 6.5.1).
    pub fn characteristic_rate(&self) -> f64 {
        match self.geometry {
            Geometry::Extrusion { h0, flow_rate, .. } => flow_rate / (h0 * h0),
            Geometry::ConfinedShear { h, wall_speed, .. } => wall_speed / h,
            Geometry::Couette {
                r1,
                r2,
                omega_inner,
            } => omega_inner * r1 / (r2 - r1),
            Geometry::CylinderChannel {
                radius,
                mean_velocity,
                ..
            } => mean_velocity / radius,
        }
    }

    /// Relaxation time λ = Wi / γ̇ with the rate of [`Self::characteristic_rate`]: shear Wi = λU_w/H
    /// (thesis 5.6.3), Couette Wi = λω̄R1/(R2 − R1) (3.5.1), cylinder Wi = λU/R (Ch. 2), extrusion
    /// Wi = λU/H0 (6.5.1). 0 for Newtonian.
    pub fn relaxation_time(&self) -> f64 {
        if self.fluid.model == Model::Newtonian {
            return 0.0;
        }
        self.fluid.wi / self.characteristic_rate()
    }

    /// Solvent viscosity η_s = β η0 with η0 = 1 (all of η0 for a Newtonian fluid).
    pub fn solvent_viscosity(&self) -> f64 {
        if self.fluid.model == Model::Newtonian {
            1.0
        } else {
            self.fluid.beta
        }
    }

    /// Polymer viscosity η_p = (1 − β) η0 (0 for a Newtonian fluid).
    pub fn polymer_viscosity(&self) -> f64 {
        1.0 - self.solvent_viscosity()
    }

    /// Confinement ratio δ = H/2a (confined shear with particles, thesis 5.7.3).
    pub fn delta(&self) -> Option<f64> {
        match (&self.geometry, self.radius()) {
            (Geometry::ConfinedShear { h, .. }, Some(a)) => Some(h / (2.0 * a)),
            _ => None,
        }
    }

    /// Couette confinement ratio ε = 2a/(R2 − R1) (thesis 3.5.1).
    pub fn eps(&self) -> Option<f64> {
        match (&self.geometry, self.radius()) {
            (Geometry::Couette { r1, r2, .. }, Some(a)) => Some(2.0 * a / (r2 - r1)),
            _ => None,
        }
    }

    /// Initial dimensionless radial position r0* of the first particle (Couette).
    pub fn r0_star(&self) -> Option<f64> {
        match self.geometry {
            Geometry::Couette { r1, r2, .. } => self
                .initial_positions()
                .first()
                .map(|&p| layout::r_star(r1, r2, p)),
            _ => None,
        }
    }

    /// String spacing (l_x, l_y) as written in the layout (string or pair), if any.
    pub fn spacing(&self) -> Option<(f64, f64)> {
        match self.particles.as_ref().map(|p| &p.layout) {
            Some(Layout::String { lx, ly, .. }) | Some(Layout::Pair { lx, ly }) => Some((*lx, *ly)),
            _ => None,
        }
    }

    /// Channel height H and length L (channel geometries).
    pub fn channel(&self) -> Option<(f64, f64)> {
        match self.geometry {
            Geometry::ConfinedShear { h, l, .. } | Geometry::CylinderChannel { h, l, .. } => {
                Some((h, l))
            }
            Geometry::Couette { .. } | Geometry::Extrusion { .. } => None,
        }
    }
}
