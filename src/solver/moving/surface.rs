//! The free surface of an extrusion in the moving-particle step (thesis §6.3.4): the boundary
//! conditions of the die, the surface predicted with the particles (Eq. 6.52), its stretch as
//! the background of the particles' temporary ALE map (§6.3.3), the fluid bounded by it in the
//! cut cells, its contact with a particle, and its kinematic step with the velocity of the flow
//! on the predicted surface (step 5).

use super::MovingError;
use crate::geometry::Extrusion;
use crate::mesh::{Mesh, Side};
use crate::particles::Contact;
use crate::rheology::{giesekus_steady_shear_conformation, Sym2};
use crate::solver::free_surface::{stretch_displacement, surface_gap, velocity_on, HeightFunction};
use crate::solver::viscoelastic::{ViscoelasticError, ViscoelasticFlow};

/// The surface of a flow and the configuration its fields belong to.
#[derive(Debug, Clone)]
pub(super) struct Surface {
    extrusion: Extrusion,
    /// Hⁿ (and Hⁿ⁻¹).
    height: HeightFunction,
    /// Ĥⁿ: the surface below which the current fields were computed.
    fields_at: HeightFunction,
    /// Element height across the die wall (the die level's offset, `free_surface::DIE_OFFSET`).
    wall_element: f64,
    /// max|Hⁿ − Hⁿ⁻¹| of the last step (infinite before the first).
    change: f64,
}

/// What a saved state keeps of the surface.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SurfaceCheckpoint {
    /// Hⁿ and Hⁿ⁻¹.
    pub height: HeightFunction,
    /// Ĥⁿ.
    pub fields_at: HeightFunction,
}

impl Surface {
    /// The flat surface H = H0 (Eq. 6.16) on the Q2 node columns of `mesh` from the die exit on
    /// (two P1 elements per Q2 element, §6.3.4 step 5).
    ///
    /// # Errors
    /// [`MovingError::Setup`] if the die exit x = 0 or the die wall y = H0 is not a grid line.
    pub(super) fn new(mesh: &Mesh, extrusion: Extrusion) -> Result<Self, MovingError> {
        let on = |a: f64, b: f64| (a - b).abs() < 1e-9 * extrusion.h0;
        let exit = mesh.ax.vertices.iter().position(|&x| on(x, 0.0));
        let wall = mesh.ay.vertices.iter().position(|&y| on(y, extrusion.h0));
        let (Some(exit), Some(wall)) = (exit, wall) else {
            return Err(MovingError::Setup(
                "the extrusion mesh needs grid lines on x = 0 and y = H0".into(),
            ));
        };
        let wall_element = mesh.ay.vertices[wall + 1] - mesh.ay.vertices[wall];
        let xs = (2 * exit..=2 * mesh.ax.len())
            .map(|i| mesh.ax.q2_coord(i))
            .collect();
        let height = HeightFunction::flat(xs, extrusion.h0);
        Ok(Self {
            extrusion,
            fields_at: height.clone(),
            height,
            wall_element,
            change: f64::INFINITY,
        })
    }

    /// Hⁿ.
    pub(super) fn height(&self) -> &HeightFunction {
        &self.height
    }

    /// max|Hⁿ − Hⁿ⁻¹| of the last step: below [`crate::solver::free_surface::STEADY_HEIGHT_TOL`] the surface is
    /// steady (thesis §6.4).
    pub(super) fn change(&self) -> f64 {
        self.change
    }

    /// Ĥⁿ⁺¹ for a step `dt` after `dt_prev` (Eq. 6.52; Hⁿ on the first step, Eq. 6.54).
    pub(super) fn predicted(&self, dt: f64, dt_prev: f64) -> HeightFunction {
        self.height.predicted(dt, dt_prev)
    }

    /// The surface the current fields belong to (Ĥⁿ): the bound of their cut cells.
    pub(super) fn fields_at(&self) -> &HeightFunction {
        &self.fields_at
    }

    /// The level set of the fluid below `surface` and the die wall.
    pub(super) fn level_set<'a>(
        &self,
        surface: &'a HeightFunction,
    ) -> crate::solver::free_surface::SurfaceLevelSet<'a> {
        surface.level_set(self.wall_element)
    }

    /// A particle closer to `surface` than `min_gap`.
    pub(super) fn contact(
        &self,
        surface: &HeightFunction,
        x: &[[f64; 2]],
        radius: &[f64],
        min_gap: f64,
    ) -> Option<Contact> {
        x.iter()
            .zip(radius)
            .enumerate()
            .filter(|(_, (c, _))| c[0] > 0.0)
            .map(|(i, (c, &a))| (i, surface_gap(surface, *c, a)))
            .find(|&(_, gap)| gap < min_gap)
            .map(|(i, gap)| Contact::Surface { i, gap })
    }

    /// The stretch that carries the fields' configuration Ĥⁿ onto `predicted`, at the vertices:
    /// the background of the particles' temporary ALE map; and the vertices that move by the
    /// stretch alone: those outside the fluid of Ĥⁿ (above the surface) and, in the die, the wall
    /// and above it (d = 0 on walls, thesis Eq. 5.36; the stretch is zero there).
    pub(super) fn background(
        &self,
        mesh: &Mesh,
        predicted: &HeightFunction,
    ) -> (Vec<[f64; 2]>, Vec<bool>) {
        let outside = mesh
            .node_of_vertex
            .iter()
            .map(|&k| {
                let [x, y] = mesh.nodes[k];
                if x <= 0.0 {
                    y >= self.extrusion.h0 * (1.0 - 1e-9)
                } else {
                    y > self.fields_at.at(x)
                }
            })
            .collect();
        let stretch = stretch_displacement(mesh, self.extrusion.top, predicted, &self.fields_at);
        (stretch, outside)
    }

    /// Step 5 of §6.3.4: Hⁿ⁺¹ by the kinematic equation with the flow's `velocity` (Q2 nodes of
    /// `mesh`) on `predicted`, its SUPG τ at `tau_dt` ([`HeightFunction::advance`]), then
    /// Ĥⁿ⁺¹ = `predicted` becomes the fields' configuration. Returns max|Hⁿ⁺¹ − Hⁿ|.
    ///
    /// # Errors
    /// [`MovingError::SurfaceEscaped`] if a point of the predicted or the new surface has left
    /// the mesh: above its top (the swell outgrew the mesh height) or at or below the symmetry
    /// line (an unstable step; the stretch of the next temporary ALE map would fold the mesh).
    pub(super) fn advance(
        &mut self,
        mesh: &Mesh,
        velocity: &[[f64; 2]],
        predicted: HeightFunction,
        [dt, dt_prev, tau_dt]: [f64; 3],
        step: usize,
    ) -> Result<f64, MovingError> {
        let moved = self.change;
        let escaped = |(x, height)| MovingError::SurfaceEscaped {
            step,
            x,
            height,
            moved,
        };
        let u = velocity_on(mesh, velocity, &predicted, self.extrusion.top).map_err(escaped)?;
        self.fields_at = predicted;
        self.change = self.height.advance(&u, dt, dt_prev, tau_dt);
        self.inside(&self.height, step)?;
        Ok(self.change)
    }

    /// `surface` (Hⁿ⁺¹, or the predicted Ĥⁿ⁺¹ before the step's ALE map uses it) lies between
    /// the symmetry line and the mesh top.
    ///
    /// # Errors
    /// [`MovingError::SurfaceEscaped`] at its first node outside.
    pub(super) fn inside(&self, surface: &HeightFunction, step: usize) -> Result<(), MovingError> {
        let top = self.extrusion.top;
        let outside = surface
            .nodes()
            .iter()
            .zip(surface.heights())
            .find(|&(_, &h)| h <= 0.0 || h >= top);
        match outside {
            Some((&x, &height)) => Err(MovingError::SurfaceEscaped {
                step,
                x,
                height,
                moved: self.change,
            }),
            None => Ok(()),
        }
    }

    /// The state to save.
    pub(super) fn checkpoint(&self) -> SurfaceCheckpoint {
        SurfaceCheckpoint {
            height: self.height.clone(),
            fields_at: self.fields_at.clone(),
        }
    }

    /// Continues from a saved state.
    ///
    /// # Errors
    /// [`MovingError::Setup`] if it has another line mesh.
    pub(super) fn restore(&mut self, saved: SurfaceCheckpoint) -> Result<(), MovingError> {
        if saved.height.nodes() != self.height.nodes()
            || saved.fields_at.nodes() != self.height.nodes()
        {
            return Err(MovingError::Setup(
                "the checkpoint's free surface has other nodes".into(),
            ));
        }
        self.height = saved.height;
        self.fields_at = saved.fields_at;
        Ok(())
    }
}

/// The fully developed log-conformation s = log c in the die of `e` at height `y` (0 ≤ y ≤ H0):
/// the steady simple-shear state of a Giesekus fluid (relaxation time `lambda`, mobility
/// `alpha`; UCM/Oldroyd-B at α = 0) at the die's shear rate γ̇(y)
/// ([`giesekus_steady_shear_conformation`]).
pub fn die_log_conformation(e: &Extrusion, lambda: f64, alpha: f64, y: f64) -> Sym2 {
    giesekus_steady_shear_conformation(lambda * e.die_shear_rate(y), alpha)
        .log()
        .expect("the fully developed conformation is positive definite")
}

/// The die's boundary conditions (thesis Eqs. 6.8–6.14): the fully developed profile at the
/// inflow (the thesis imposes the flow rate Q by a multiplier with open conditions; upstream of a
/// long die the two agree), no-slip on the die wall y = H0 (a grid line, x ≤ 0), symmetry
/// u_y = 0 on y = 0, traction-free outflow and surface (natural, so the pressure is not pinned);
/// with a polymer the fully developed conformation enters at the inflow and fills the die at the
/// start (the thesis starts at rest; a stress front entering from the inflow blew up the UCM
/// swell on fine meshes, docs/validation.md). The extrudate starts stress-free: the die's shear
/// stresses under a flat free surface drove its outflow end out of the mesh within a few steps
/// (Giesekus Wi = 0.4 and 0.5 on h = 1/30, the undisturbed run of sweeps/extrusion_particle.toml).
///
/// # Errors
/// [`ViscoelasticError::Stress`] if the initial conformation cannot be projected.
pub(super) fn apply_extrusion(
    e: Extrusion,
    flow: &mut ViscoelasticFlow,
) -> Result<(), ViscoelasticError> {
    let tol = 1e-9 * e.h0;
    flow.set_velocity(Side::Left, move |x| [e.inflow_velocity(x[1]), 0.0]);
    flow.set_velocity_where(move |x| {
        if x[0] <= tol && (x[1] - e.h0).abs() < tol {
            [Some(0.0), Some(0.0)]
        } else if x[1].abs() < tol {
            [None, Some(0.0)]
        } else {
            [None, None]
        }
    });
    let params = flow.params();
    if !params.has_polymer() {
        return Ok(());
    }
    let (lambda, alpha) = (params.lambda, params.alpha);
    let die = move |y: f64| die_log_conformation(&e, lambda, alpha, y);
    flow.set_initial_log_conformation(|x| {
        if x[0] <= 0.0 && x[1] <= e.h0 {
            die(x[1])
        } else {
            Sym2::ZERO
        }
    })?;
    flow.set_inflow_log_conformation(Side::Left, move |x| (x[1] <= e.h0 + tol).then(|| die(x[1])));
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A die and an extrudate of length 1, H0 = 1, the mesh top at 2, on 10 × 10 elements.
    fn unit_die() -> (Extrusion, Mesh) {
        let e = Extrusion {
            h0: 1.0,
            die_length: 1.0,
            extrudate_length: 1.0,
            flow_rate: 1.0,
            top: 2.0,
        };
        (e, e.mesh(10, 10))
    }

    /// The vertices that move by the surface's stretch alone: in the die the wall and above it
    /// (a wall of the ALE map), in the extrudate those above the surface; the rest are free for
    /// the particles' map. The stretch is zero in the die.
    #[test]
    fn the_die_wall_and_the_outside_follow_the_stretch_alone() {
        let (e, mesh) = unit_die();
        let s = Surface::new(&mesh, e).unwrap();
        let mut predicted = s.height().clone();
        predicted = predicted.predicted(0.1, 0.1);
        let (stretch, fixed) = s.background(&mesh, &predicted);
        for (v, &k) in mesh.node_of_vertex.iter().enumerate() {
            let [x, y] = mesh.nodes[k];
            let want = if x <= 0.0 { y >= 1.0 } else { y > 1.0 };
            assert_eq!(fixed[v], want, "({x}, {y})");
            if x <= 0.0 {
                assert_eq!(stretch[v], [0.0, 0.0]);
            }
        }
    }

    /// A kinematic step that takes the surface through the symmetry line or above the mesh is
    /// refused where it happens, naming the node, the height and the cause — before the next
    /// step's temporary ALE map folds the mesh on it (the §6.5 particle at Wi = 0.5 failed there
    /// with "point not found in the displaced mesh: reduce Δt", which named neither).
    #[test]
    fn a_surface_that_leaves_the_mesh_is_refused_with_its_cause() {
        let (e, mesh) = unit_die();
        for (u_y, below) in [(-100.0, true), (100.0, false)] {
            let mut s = Surface::new(&mesh, e).unwrap();
            let velocity = vec![[1.0, u_y]; mesh.n_nodes()];
            let predicted = s.predicted(0.1, 0.1);
            let err = s
                .advance(&mesh, &velocity, predicted, [0.1, 0.1, 0.1], 7)
                .unwrap_err();
            let MovingError::SurfaceEscaped {
                step, x, height, ..
            } = err
            else {
                panic!("{err}");
            };
            assert_eq!(step, 7);
            assert_eq!(
                x,
                s.height().nodes()[1],
                "the first node past the pinned one"
            );
            assert!(
                (height <= 0.0) == below && (height >= 2.0) != below,
                "H = {height}"
            );
            let cause = if below {
                "symmetry line"
            } else {
                "geometry.extrusion.height"
            };
            assert!(err.to_string().contains(cause), "{err}");
            assert!(
                s.inside(&s.height().clone(), 8).is_err(),
                "the predicted check"
            );
        }
    }
}
