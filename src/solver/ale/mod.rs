//! Temporary ALE map of thesis §5.3.3 (Eqs. 5.35–5.44): carries the history fields of a step onto
//! the particle configuration of the next one while the particles move over the fixed mesh.
//!
//! - Mesh displacement d_m (Q1, at the vertices): −∇²d_m = 0 on the whole mesh (fictitious-domain
//!   style, Eq. 5.35), d_m = 0 on the walls (Eq. 5.36), periodic with the mesh (Eq. 5.37) and
//!   d_m = X̂ⁿ⁺¹ − X̂ⁿ on a rigid patch of each particle (Eq. 5.38): every vertex of an element the
//!   old disc overlaps. The whole neighbourhood of a particle translates, so a point of the
//!   particle surface at tⁿ⁺¹ maps exactly onto the surface at tⁿ and the mesh velocity there is
//!   the particle's. One scalar matrix for both components; its pattern (and symbolic
//!   factorization) never changes.
//! - ALE mesh x_ALE^{n+1} = x_m + d_m^{n+1} (Eq. 5.39); a point x is located in it (element E,
//!   reference ξ with X_E(ξ) + d(E, ξ) = x, Newton) and its pre-image is Φₙ⁻¹(x) = X_E(ξ) on the
//!   fixed mesh, where sⁿ is interpolated (Eq. 5.42); repeating with the previous displacement
//!   gives xⁿ⁻¹ and s^{n−1} (Eq. 5.43).
//! - Mesh velocity at the Q2 nodes by BDF2 (Eq. 5.44; variable-step coefficients, `Bdf2`), first
//!   order on the first step.
//!
//! Here: [`TemporaryAle`] and its step (pre-images, stencils and mesh velocity of all nodes); the
//! displacement solve, the point location, the stencils and the extension into the particles
//! are in the submodules.

mod displacement;
mod extend;
mod locate;
mod stencil;

#[cfg(test)]
mod annulus_tests;
#[cfg(test)]
mod remap_tests;
#[cfg(test)]
mod ring_tests;
#[cfg(test)]
mod tests;

pub use extend::{extend_inside, EXTENSION_LAYERS};
pub use stencil::{stencil_at, Remap, StencilWeights, STENCIL_LEN};

use crate::periodic::nearest_image;
pub use displacement::RING_ELEMENTS;
use displacement::{laplace_elements, LaplaceSystem};
use locate::pre_image;
use stencil::stencil;

use crate::fem::linsolve::SolveError;
use crate::mesh::{Axis, Mesh, Side};
use crate::solver::bdf::Bdf2;

/// Where the mesh displacement is solved for.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum AleExtent {
    /// On the whole mesh (thesis Eq. 5.35): every node moves a little, and every node's
    /// history is interpolated at its pre-image every step.
    #[default]
    Whole,
    /// On a ring of [`RING_ELEMENTS`] elements around the rigid patches, zero beyond it: the
    /// far field keeps its nodes (no pre-image search, no interpolation, no mesh velocity
    /// there), and the cost of the map follows the particles, not the mesh.
    Ring,
}

impl AleExtent {
    /// Whether this is the default, [`AleExtent::Whole`].
    pub fn is_whole(&self) -> bool {
        *self == AleExtent::Whole
    }
}

/// A particle's move over one step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RigidMove {
    /// Centre at tⁿ (the configuration the history fields belong to).
    pub center: [f64; 2],
    /// Radius.
    pub radius: f64,
    /// X̂ⁿ⁺¹ − X̂ⁿ.
    pub displacement: [f64; 2],
}

/// Errors of the temporary ALE map.
#[derive(Debug, thiserror::Error)]
pub enum AleError {
    /// The mesh-displacement solve failed.
    #[error("mesh displacement solve failed: {0}")]
    Solve(#[from] SolveError),
    /// The mesh displacement is not finite (a failed factorization the residual check missed).
    #[error("mesh displacement not finite at vertex {vertex}")]
    NonFinite {
        /// First vertex with a non-finite displacement.
        vertex: usize,
    },
    /// A point has no pre-image in the displaced mesh (displacement too large for the mesh, or
    /// the point is outside the domain).
    #[error("point ({x:.6}, {y:.6}) not found in the displaced mesh: reduce Δt")]
    NotFound {
        /// x.
        x: f64,
        /// y.
        y: f64,
    },
    /// A saved displacement does not fit the mesh.
    #[error("saved mesh displacement has {len} vertices, the mesh {want}")]
    Restore {
        /// Saved length.
        len: usize,
        /// Vertices of the mesh.
        want: usize,
    },
}

/// The map of one step: interpolation of the fields at tⁿ and t^{n−1} at the pre-images of the
/// vertices, and the mesh velocity at the Q2 nodes.
#[derive(Debug, Clone)]
pub struct AleMap {
    /// Q1 interpolation at xⁿ = Φₙ⁻¹(x) of each vertex.
    pub at_n: Vec<StencilWeights>,
    /// Q1 interpolation at xⁿ⁻¹ (second-order steps only).
    pub at_n_minus_1: Option<Vec<StencilWeights>>,
    /// u_m^{n+1} at the Q2 nodes (Eq. 5.44).
    pub mesh_velocity: Vec<[f64; 2]>,
    /// Mesh displacement d_m^{n+1} at the vertices.
    pub displacement: Vec<[f64; 2]>,
}

/// The temporary ALE scheme: the Laplace solver and the previous step's displacement.
pub struct TemporaryAle {
    /// Element stiffness of −∇² for the Q1 vertices (4×4, row-major).
    element_k: Vec<[f64; 16]>,
    /// The axes of the mesh `element_k` belongs to.
    k_axes: (Axis, Axis),
    /// Where the displacement is solved for.
    pub extent: AleExtent,
    /// The Laplace problem on the last region.
    system: Option<LaplaceSystem>,
    /// Vertices on walls (d = 0).
    wall: Vec<bool>,
    /// d_m^n of the previous step.
    previous: Option<Vec<[f64; 2]>>,
    /// The axes of the mesh `previous` was solved on (the mesh of s^{n−1}).
    previous_axes: Option<(Axis, Axis)>,
    /// Interpolation of the history at the pre-images.
    pub remap: Remap,
    /// Where each node of the mesh lies in it, kept while the mesh stays.
    homes: Option<NodeHomes>,
    /// A displacement of the vertices that the next steps add to the particles' (a free
    /// surface's stretch, `free_surface::stretch_displacement`; `None`: none): the Laplace
    /// solution then carries the particles' rigid moves less the background on their patches
    /// and zero on the walls, so that the patches still move rigidly in the sum and the walls by
    /// the background.
    pub background: Option<Vec<[f64; 2]>>,
    /// Vertices outside the fluid (above a free surface; `None`: none): they move by the
    /// background alone and never with a particle's rigid patch, so that a particle close to
    /// the surface does not drag the mesh beyond it against the surface's stretch.
    pub outside: Option<Vec<bool>>,
}

/// Where each node of the mesh with these axes lies in it ([`Mesh::locate`]: element and ξ): the
/// pre-image search of a node starts there instead of locating the node again every step.
struct NodeHomes {
    axes: (Axis, Axis),
    at: Vec<Option<(usize, [f64; 2])>>,
}

impl std::fmt::Debug for TemporaryAle {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("TemporaryAle")
            .field("n_vertices", &self.wall.len())
            .finish_non_exhaustive()
    }
}

impl TemporaryAle {
    /// Assembles the element matrices of the mesh Laplacian (2×2 Gauss on the bilinear map of
    /// the element corners: a smoothing operator, exactness is not needed).
    pub fn new(mesh: &Mesh) -> Self {
        let element_k = laplace_elements(mesh);
        let mut wall = vec![false; mesh.n_vertices()];
        let mut sides = vec![Side::Bottom, Side::Top];
        if !mesh.periodic {
            sides.extend([Side::Left, Side::Right]);
        }
        for side in sides {
            for k in mesh.side_nodes(side) {
                if let Some(v) = mesh.vertex_of_node[k] {
                    wall[v] = true;
                }
            }
        }
        Self {
            element_k,
            k_axes: (mesh.ax.clone(), mesh.ay.clone()),
            extent: AleExtent::default(),
            system: None,
            wall,
            previous: None,
            previous_axes: None,
            remap: Remap::default(),
            homes: None,
            background: None,
            outside: None,
        }
    }

    /// Forgets the previous displacement: the next step is first order (after a restart).
    pub fn reset(&mut self) {
        self.previous = None;
        self.previous_axes = None;
    }

    /// The mesh displacement of the last step (kept for the next step's second pre-image).
    pub fn last_displacement(&self) -> Option<&[[f64; 2]]> {
        self.previous.as_deref()
    }

    /// The vertex coordinates (x and y axes) of the mesh the last displacement was solved on.
    pub fn last_axes(&self) -> Option<&(Axis, Axis)> {
        self.previous_axes.as_ref()
    }

    /// Sets the last step's mesh displacement (continuing a saved run).
    ///
    /// # Errors
    /// [`AleError::Restore`] if it does not have one entry per vertex of `mesh`.
    pub fn set_last_displacement(
        &mut self,
        d: Option<Vec<[f64; 2]>>,
        mesh: &Mesh,
    ) -> Result<(), AleError> {
        if let Some(d) = &d {
            if d.len() != mesh.n_vertices() {
                return Err(AleError::Restore {
                    len: d.len(),
                    want: mesh.n_vertices(),
                });
            }
        }
        self.previous_axes = d.as_ref().map(|_| (mesh.ax.clone(), mesh.ay.clone()));
        self.previous = d;
        Ok(())
    }

    /// One step of the temporary ALE scheme: the displacement for `moves`, the pre-images of
    /// all Q2 nodes in x_ALE^{n+1} (and, unless `bdf` is Euler or on the first call, in x_ALE^n),
    /// the interpolation weights at the vertices and the mesh velocity (Eq. 5.44, with the
    /// variable-step coefficients of `bdf`).
    ///
    /// # Errors
    /// [`AleError`] if the solve fails or a pre-image is not found.
    pub fn advance(
        &mut self,
        mesh: &Mesh,
        moves: &[RigidMove],
        period: Option<f64>,
        dt: f64,
        bdf: Bdf2,
    ) -> Result<AleMap, AleError> {
        self.advance_onto(mesh, mesh, moves, period, dt, bdf)
    }

    /// [`advance`](Self::advance) onto a computational mesh `new` whose vertex columns and rows
    /// may have moved (same topology): the displacement is solved on `old`, the mesh of sⁿ (the
    /// particles' tⁿ configuration), the pre-images of `new`'s nodes are located in `old` and
    /// interpolated there, and those of the second pre-image in the mesh of the previous call's
    /// `old` (the mesh of s^{n−1}). The ALE map does not depend on the computational mesh
    /// (thesis §3.3.4): with `new == old` this is [`advance`](Self::advance).
    ///
    /// # Errors
    /// [`AleError`] if the solve fails or a pre-image is not found.
    ///
    /// # Panics
    /// If the meshes differ in topology.
    pub fn advance_onto(
        &mut self,
        old: &Mesh,
        new: &Mesh,
        moves: &[RigidMove],
        period: Option<f64>,
        dt: f64,
        bdf: Bdf2,
    ) -> Result<AleMap, AleError> {
        assert!(
            old.dims() == new.dims() && old.periodic == new.periodic && old.shape == new.shape,
            "TemporaryAle::advance_onto: meshes of different topology"
        );
        let d_new = self.displacement(old, moves, period)?;
        let previous_axes = self.previous_axes.take();
        let d_old = if bdf.is_euler() {
            None
        } else {
            self.previous.take()
        };
        // the mesh of s^{n−1}: `old` unless its columns or rows have moved since
        let moved = previous_axes
            .filter(|(ax, ay)| (ax, ay) != (&old.ax, &old.ay))
            .map(|(ax, ay)| old.with_axes(ax, ay));
        let older = moved.as_ref().unwrap_or(old);
        let nn = new.n_nodes();
        // the nodes of `new` located in `old` (once per mesh: the same when they are one)
        let same = old.ax == new.ax && old.ay == new.ay;
        let stale = |h: &NodeHomes| h.axes.0 != old.ax || h.axes.1 != old.ay;
        if same && self.homes.as_ref().is_none_or(stale) {
            self.homes = Some(NodeHomes {
                axes: (old.ax.clone(), old.ay.clone()),
                at: old.nodes.iter().map(|&x| old.locate(x)).collect(),
            });
        }
        let homes = self.homes.as_ref().filter(|_| same).map(|h| &h.at);
        let mut at_n = vec![([0; STENCIL_LEN], [0.0; STENCIL_LEN]); new.n_vertices()];
        let mut at_nm1 = d_old
            .as_ref()
            .map(|_| vec![([0; STENCIL_LEN], [0.0; STENCIL_LEN]); new.n_vertices()]);
        let mut mesh_velocity = vec![[0.0; 2]; nn];
        // a node whose element has no displacement at its vertices is its own pre-image
        let still =
            |d: &[[f64; 2]], e: usize| old.element_vertices[e].iter().all(|&v| d[v] == [0.0, 0.0]);
        let identity = |v: usize| {
            let mut w = ([v; STENCIL_LEN], [0.0; STENCIL_LEN]);
            w.1[0] = 1.0;
            w
        };
        for k in 0..nn {
            let x = new.nodes[k];
            let home = homes.and_then(|h| h[k]);
            let v = new.vertex_of_node[k];
            let own = home.filter(|&(e, _)| still(&d_new, e));
            let (e1, xi1, xn) = match own {
                Some((e, xi)) => (e, xi, x),
                None => pre_image(old, &d_new, x, period, home)?,
            };
            if let Some(v) = v {
                at_n[v] = match own {
                    Some(_) => identity(v),
                    None => stencil(old, e1, xi1, self.remap),
                };
            }
            // still at both levels (the mesh of s^{n−1} being `old`): no mesh velocity
            if own.is_some()
                && d_old
                    .as_ref()
                    .is_none_or(|d| moved.is_none() && still(d, e1))
            {
                if let (Some(v), Some(at)) = (v, at_nm1.as_mut()) {
                    at[v] = identity(v);
                }
                continue;
            }
            let u = match &d_old {
                None => [(x[0] - xn[0]) / dt, (x[1] - xn[1]) / dt],
                Some(d_old) => {
                    // xⁿ = X_{e1}(ξ1) on `old`, which is `older` unless the mesh moved
                    let at = moved.is_none().then_some((e1, xi1));
                    let (e2, xi2, xnm1) = pre_image(older, d_old, xn, period, at)?;
                    if let (Some(v), Some(at)) = (v, at_nm1.as_mut()) {
                        at[v] = stencil(older, e2, xi2, self.remap);
                    }
                    let xnm1 = nearest_image(xnm1, xn[0], period);
                    [
                        (bdf.c0 * x[0] - bdf.c1 * xn[0] + bdf.c2 * xnm1[0]) / dt,
                        (bdf.c0 * x[1] - bdf.c1 * xn[1] + bdf.c2 * xnm1[1]) / dt,
                    ]
                }
            };
            mesh_velocity[k] = u;
        }
        self.previous_axes = Some((old.ax.clone(), old.ay.clone()));
        // a first-order step too leaves d^{n+1} for the next step's second pre-image
        self.previous = Some(d_new.clone());
        Ok(AleMap {
            at_n,
            at_n_minus_1: at_nm1,
            mesh_velocity,
            displacement: d_new,
        })
    }
}
