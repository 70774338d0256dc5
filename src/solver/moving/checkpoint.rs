//! Saving a moving-particle run after a step and continuing it in another process:
//! [`MovingCheckpoint`] (the particles' time levels, the configuration of the fields, the ALE
//! displacement, a free surface, the fluid's state) and [`MovingParticles::checkpoint`] /
//! [`MovingParticles::restore`].

use super::surface::Surface;
use super::{make_particles, Confinement, MovingError, MovingParticles, SurfaceCheckpoint};
use crate::mesh::Axis;
use crate::particles::RigidState;
use crate::solver::cutcells::compute_cuts_bounded;
use crate::solver::viscoelastic::FlowState;
use crate::xfem::LevelSet;

/// Everything a moving-particle run needs to continue from the end of a step in another process
/// (see [`MovingParticles::checkpoint`]).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct MovingCheckpoint {
    /// Xⁿ, Uⁿ, ωⁿ.
    pub cur: RigidState,
    /// Xⁿ⁻¹.
    pub prev: Option<RigidState>,
    /// X̂ⁿ, where the fields were computed.
    pub fields_at: Vec<[f64; 2]>,
    /// The ALE mesh displacement of the last step (BDF2 mesh velocity).
    pub ale_displacement: Option<Vec<[f64; 2]>>,
    /// The free surface (extrusion; absent otherwise).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub surface: Option<SurfaceCheckpoint>,
    /// The vertex coordinates along x and y of the mesh that displacement was solved on, when
    /// the mesh follows the particles (absent in checkpoints of fixed-mesh runs).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ale_axes: Option<(Vec<f64>, Vec<f64>)>,
    /// The fluid.
    pub flow: FlowState,
}

impl<D: Confinement + Clone + 'static> MovingParticles<D> {
    /// The state after the last step, from which [`restore`](Self::restore) continues the run.
    pub fn checkpoint(&self) -> MovingCheckpoint {
        MovingCheckpoint {
            cur: self.cur.clone(),
            prev: self.prev.clone(),
            fields_at: self.fields_at.clone(),
            ale_displacement: self.ale.last_displacement().map(<[_]>::to_vec),
            surface: self.surface.as_ref().map(Surface::checkpoint),
            ale_axes: self
                .follow
                .as_ref()
                .and(self.ale.last_axes())
                .map(|(ax, ay)| (ax.vertices.clone(), ay.vertices.clone())),
            flow: self.flow.state(),
        }
    }

    /// Continues from a [`checkpoint`](Self::checkpoint) of the same set-up (mesh, parameters,
    /// particles): the following steps equal those of the run that wrote it up to round-off.
    ///
    /// # Errors
    /// [`MovingError::Setup`] if the checkpoint has another particle count,
    /// [`MovingError::Cut`] if the saved positions cannot be cut into the mesh,
    /// [`MovingError::Flow`] if the fields do not fit the mesh.
    pub fn restore(&mut self, cp: MovingCheckpoint) -> Result<(), MovingError> {
        let n = self.radius.len();
        let lens = [cp.cur.x.len(), cp.fields_at.len()];
        if lens.iter().any(|&l| l != n) || cp.prev.as_ref().is_some_and(|p| p.x.len() != n) {
            return Err(MovingError::Setup(format!(
                "the checkpoint has {} particles, this case {n}",
                cp.cur.x.len()
            )));
        }
        let step = cp.flow.history.steps();
        match (self.surface.as_mut(), cp.surface) {
            (Some(s), Some(saved)) => s.restore(saved)?,
            (None, None) => {}
            _ => {
                return Err(MovingError::Setup(
                    "the checkpoint and the case differ in having a free surface".into(),
                ))
            }
        }
        let particles = make_particles(&self.domain, &cp.fields_at, &self.radius, &self.motion);
        // a mesh that follows the particles is a function of the positions the fields are at
        let mesh = match &self.follow {
            Some(f) => Some(
                f.mesh_at(&cp.fields_at)
                    .map_err(|reason| MovingError::Follow { step, reason })?,
            ),
            None => None,
        };
        let on = mesh.as_ref().unwrap_or(self.flow.mesh());
        let bound = self.surface.as_ref().map(|s| s.level_set(s.fields_at()));
        let cuts = compute_cuts_bounded(
            on,
            &particles,
            self.domain.period(),
            self.method,
            bound.as_ref().map(|b| b as &dyn LevelSet),
        )
        .map_err(|source| MovingError::Cut { step, source })?;
        let ale_mesh = match (&self.follow, cp.ale_axes) {
            (Some(f), Some((ax, ay))) => {
                let fits = (ax.len(), ay.len()) == (f.base.ax.len() + 1, f.base.ay.len() + 1);
                if !fits {
                    return Err(MovingError::Setup(
                        "the checkpoint's ALE mesh has other element counts".into(),
                    ));
                }
                Some(
                    f.base
                        .with_axes(Axis { vertices: ax }, Axis { vertices: ay }),
                )
            }
            _ => None,
        };
        self.ale
            .set_last_displacement(cp.ale_displacement, ale_mesh.as_ref().unwrap_or(on))
            .map_err(|source| MovingError::Ale { step, source })?;
        self.flow.restore_on(mesh, cp.flow, particles, cuts)?;
        self.cur = cp.cur;
        self.prev = cp.prev;
        self.fields_at = cp.fields_at;
        Ok(())
    }
}
