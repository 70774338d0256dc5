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
//! - Mesh velocity at the Q2 nodes by BDF2 (Eq. 5.44), first order on the first step.

use crate::fem::element::{q1, q2_map, Q1_IN_Q2};
use crate::fem::linsolve::{DirectSolver, SolveError, SolverKind};
use crate::fem::newton_inverse::{newton_inverse, Bound, Newton};
use crate::fem::sparse::{q1_pattern, SparseMatrix};
use crate::mesh::{bounding_box, Axis, Mesh, Shape, Side};

/// Newton tolerance of the point location, in reference coordinates. Round-off limits ξ to about
/// ε|x|/h (7e-14 for |x| = 2, h = 0.013): a tolerance of 1e-13 failed there (300×75 channel,
/// L = 4); 1e-11 still places the point to 1e-11 h.
const NEWTON_TOL: f64 = 1e-11;
/// Newton iterations before a candidate element is given up.
const NEWTON_MAX_ITER: usize = 30;
/// How far outside [−1, 1]² a converged ξ may lie and still count as inside (points on an edge
/// shared by two elements, round-off).
const INSIDE_TOL: f64 = 1e-9;
/// How far outside [−1, 1]² the nearest candidate of a point on a circle of the annulus may lie:
/// the discrete boundary (parabolas through the nodes) is up to R Δθ⁴/520 inside the circle
/// between its nodes, ≈ 6e-6 in ξ for R = 4, Δθ = 2π/64, h_r = 0.25 (a mesh that follows a
/// particle puts the new wall nodes there). Points missed in the interior are off by O(1).
const CURVED_BOUNDARY_TOL: f64 = 1e-4;
/// Relative residual accepted from the Laplace solve.
const LAPLACE_RESIDUAL_TOL: f64 = 1e-10;

/// How the history fields are interpolated at the pre-images.
///
/// Each step interpolates the history once more, so the interpolation error accumulates like the
/// numerical diffusion of an upwind scheme: with bilinear weights and a rigid shift by a fraction
/// ξ = |d|/h of an element per step, the error after a time T is ≈ ½|U|hT(1 − ξ)|s″|, whose
/// Δt-dependent part −½U²TΔt|s″| is first order in Δt. A biquadratic 3×3 vertex stencil leaves
/// ≈ (1 − ξ²)|U|h²T|s‴|/6, whose Δt-dependent part is O(Δt²); a bicubic 4×4 stencil one more
/// power of h. Per remap the error is ∝ h^{p+1}, per unit time ∝ h^{p+1}/Δt when a particle
/// crosses a sizeable fraction of an element per step: then a smaller Δt makes it worse
/// (docs/validation.md, single particle §5.5). This type's default is the thesis' bilinear map
/// (the validations name theirs); cases default to bicubic (`config::HistoryRemap`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Remap {
    /// Bilinear on the element holding the pre-image (thesis §5.3.3).
    #[default]
    Bilinear,
    /// Biquadratic Lagrange interpolation on the 3×3 vertices around the nearest vertex (in the
    /// structured mesh's index space; one-sided at walls). Not monotone.
    Quadratic,
    /// Bicubic Lagrange interpolation on the 4×4 vertices around the element holding the
    /// pre-image (index space; one-sided at walls). Not monotone; error O(h⁴) per remap.
    Cubic,
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

/// Most vertices one interpolation of the history uses (the 4×4 bicubic stencil).
pub const STENCIL_LEN: usize = 16;

/// Interpolation of a vertex field at a point: up to [`STENCIL_LEN`] vertices and their weights
/// (the four vertices of the element with bilinear weights, a 3×3 vertex stencil with
/// biquadratic ones, a 4×4 one with bicubic ones; unused entries have weight 0).
pub type StencilWeights = ([usize; STENCIL_LEN], [f64; STENCIL_LEN]);

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
    matrix: SparseMatrix,
    solver: Option<DirectSolver>,
    /// Vertices on walls (d = 0).
    wall: Vec<bool>,
    /// d_m^n of the previous step.
    previous: Option<Vec<[f64; 2]>>,
    /// The axes of the mesh `previous` was solved on (the mesh of s^{n−1}).
    previous_axes: Option<(Axis, Axis)>,
    /// Interpolation of the history at the pre-images.
    pub remap: Remap,
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
            matrix: q1_pattern(mesh.n_vertices(), &mesh.element_vertices),
            solver: None,
            wall,
            previous: None,
            previous_axes: None,
            remap: Remap::default(),
        }
    }

    /// Forgets the previous displacement: the next step is first order (after a restart).
    pub fn reset(&mut self) {
        self.previous = None;
        self.previous_axes = None;
    }

    /// The mesh displacement d_m for the given moves (Eqs. 5.35–5.38).
    ///
    /// # Errors
    /// [`AleError::Solve`] if the Laplace solve fails.
    pub fn displacement(
        &mut self,
        mesh: &Mesh,
        moves: &[RigidMove],
        period: Option<f64>,
    ) -> Result<Vec<[f64; 2]>, AleError> {
        let nv = mesh.n_vertices();
        if moves.iter().all(|m| m.displacement == [0.0, 0.0]) {
            return Ok(vec![[0.0; 2]; nv]);
        }
        if (&mesh.ax, &mesh.ay) != (&self.k_axes.0, &self.k_axes.1) {
            // a mesh with moved columns or rows: same pattern, new element matrices
            self.element_k = laplace_elements(mesh);
            self.k_axes = (mesh.ax.clone(), mesh.ay.clone());
        }
        // rigid patches: the nearest particle claims a vertex; walls win
        let mut claim: Vec<Option<(f64, [f64; 2])>> = vec![None; nv];
        for (e, xe) in mesh.element_coords.iter().enumerate() {
            let (lo, hi) = bounding_box(xe);
            for m in moves {
                let c = nearest_image(m.center, [0.5 * (lo[0] + hi[0]), 0.0], period);
                let q = [c[0].clamp(lo[0], hi[0]), c[1].clamp(lo[1], hi[1])];
                if (q[0] - c[0]).hypot(q[1] - c[1]) >= m.radius {
                    continue;
                }
                for (k, &v) in Q1_IN_Q2.iter().zip(&mesh.element_vertices[e]) {
                    let d = (xe[*k][0] - c[0]).hypot(xe[*k][1] - c[1]);
                    if claim[v].is_none_or(|(dc, _)| d < dc) {
                        claim[v] = Some((d, m.displacement));
                    }
                }
            }
        }
        let fixed: Vec<Option<[f64; 2]>> = (0..nv)
            .map(|v| {
                if self.wall[v] {
                    Some([0.0; 2])
                } else {
                    claim[v].map(|c| c.1)
                }
            })
            .collect();
        let fx: Vec<Option<f64>> = fixed.iter().map(|f| f.map(|d| d[0])).collect();
        self.matrix.zero();
        let mut rhs = [vec![0.0; nv], vec![0.0; nv]];
        let zero = [0.0; 4];
        for (verts, k) in mesh.element_vertices.iter().zip(&self.element_k) {
            self.matrix.scatter(verts, k, &zero, &mut rhs[0], &fx);
            // the same symmetric elimination for the y component
            for (b, &j) in verts.iter().enumerate() {
                let Some(g) = fixed[j] else { continue };
                for (a, &i) in verts.iter().enumerate() {
                    if fixed[i].is_none() {
                        rhs[1][i] -= k[4 * a + b] * g[1];
                    }
                }
            }
        }
        self.matrix.apply_constraints(&mut rhs[0], &fx);
        for (v, f) in fixed.iter().enumerate() {
            if let Some(g) = f {
                rhs[1][v] = g[1];
            }
        }
        if self.solver.is_none() {
            self.solver = Some(DirectSolver::analyze(&self.matrix, SolverKind::Lblt)?);
        }
        let solver = self.solver.as_mut().expect("analysed above");
        solver.factor(&self.matrix)?;
        let mut d = vec![[0.0; 2]; nv];
        let mut sol = vec![0.0; nv];
        for (c, r) in rhs.iter().enumerate() {
            solver.solve_checked(&self.matrix, r, &mut sol, LAPLACE_RESIDUAL_TOL)?;
            d.iter_mut().zip(&sol).for_each(|(d, s)| d[c] = *s);
        }
        if let Some(vertex) = d
            .iter()
            .position(|v| !(v[0].is_finite() && v[1].is_finite()))
        {
            return Err(AleError::NonFinite { vertex });
        }
        Ok(d)
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
    /// all Q2 nodes in x_ALE^{n+1} (and, unless `first_order` or on the first call, in x_ALE^n),
    /// the interpolation weights at the vertices and the mesh velocity (Eq. 5.44).
    ///
    /// # Errors
    /// [`AleError`] if the solve fails or a pre-image is not found.
    pub fn advance(
        &mut self,
        mesh: &Mesh,
        moves: &[RigidMove],
        period: Option<f64>,
        dt: f64,
        first_order: bool,
    ) -> Result<AleMap, AleError> {
        self.advance_onto(mesh, mesh, moves, period, dt, first_order)
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
        first_order: bool,
    ) -> Result<AleMap, AleError> {
        assert!(
            old.dims() == new.dims() && old.periodic == new.periodic && old.shape == new.shape,
            "TemporaryAle::advance_onto: meshes of different topology"
        );
        let d_new = self.displacement(old, moves, period)?;
        let previous_axes = self.previous_axes.take();
        let d_old = if first_order {
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
        let mut at_n = vec![([0; STENCIL_LEN], [0.0; STENCIL_LEN]); new.n_vertices()];
        let mut at_nm1 = d_old
            .as_ref()
            .map(|_| vec![([0; STENCIL_LEN], [0.0; STENCIL_LEN]); new.n_vertices()]);
        let mut mesh_velocity = vec![[0.0; 2]; nn];
        for k in 0..nn {
            let x = new.nodes[k];
            let (e1, xi1, xn) = pre_image(old, &d_new, x, period)?;
            let v = new.vertex_of_node[k];
            if let Some(v) = v {
                at_n[v] = stencil(old, e1, xi1, self.remap);
            }
            let u = match &d_old {
                None => [(x[0] - xn[0]) / dt, (x[1] - xn[1]) / dt],
                Some(d_old) => {
                    let (e2, xi2, xnm1) = pre_image(older, d_old, xn, period)?;
                    if let (Some(v), Some(at)) = (v, at_nm1.as_mut()) {
                        at[v] = stencil(older, e2, xi2, self.remap);
                    }
                    let xnm1 = nearest_image(xnm1, xn, period);
                    [
                        (1.5 * x[0] - 2.0 * xn[0] + 0.5 * xnm1[0]) / dt,
                        (1.5 * x[1] - 2.0 * xn[1] + 0.5 * xnm1[1]) / dt,
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

/// Layers of vertices inside particles that [`extend_inside`] fills. A vertex active at the new
/// configuration lies at most √2 h inside a particle (it belongs to a cut element); its
/// pre-image keeps that position relative to the particle (rigid patch), so the element holding
/// it has its vertices at most 2√2 h inside: two layers past the active ones, a third for
/// stretched cells, a fourth for the bicubic stencil (one vertex further out).
pub const EXTENSION_LAYERS: usize = 4;

/// Gives the vertices that touch no fluid element (`known[v] == false`: inside a particle)
/// values extrapolated from the fluid side, layer by layer, up to [`EXTENSION_LAYERS`] deep.
///
/// The history of a step is interpolated at pre-images that can fall in elements inside the
/// particle at tⁿ (a vertex that becomes active as the particle moves maps to the same place
/// relative to the old particle, which may be an inside element). Those vertices hold s = 0
/// (c = I) from the transport solve; interpolating them pollutes the fluid part of the new cut
/// element by an O(1) amount once per activation, an error that does not shrink with Δt. Each
/// new value is the linear extrapolation along a grid line from the two nearest known vertices
/// (mean over the directions that have two), or, without such a pair, the mean of the known
/// edge neighbours.
pub fn extend_inside<T>(mesh: &Mesh, known: &[bool], field: &mut [T])
where
    T: Copy + std::ops::Add<Output = T> + std::ops::Mul<f64, Output = T>,
{
    let (nx, ny) = mesh.dims();
    let cols = if mesh.periodic { nx } else { nx + 1 };
    let at = |i: isize, j: isize| -> Option<usize> {
        if j < 0 || j > ny as isize || (!mesh.periodic && (i < 0 || i >= cols as isize)) {
            return None;
        }
        Some(vertex_at(mesh, i, j as usize))
    };
    let x = |v: usize| mesh.nodes[mesh.node_of_vertex[v]];
    let dist = |a: usize, b: usize| {
        let (p, q) = (x(a), x(b));
        // periodic neighbours across the seam: the shorter way round
        let dx = match mesh.periodic && mesh.shape == Shape::Rectangle {
            true => {
                let l = mesh.ax.vertices[nx] - mesh.ax.vertices[0];
                let d = p[0] - q[0];
                d - l * (d / l).round()
            }
            false => p[0] - q[0],
        };
        dx.hypot(p[1] - q[1])
    };
    let mut known = known.to_vec();
    let mut fresh: Vec<(usize, T)> = Vec::new();
    for _ in 0..EXTENSION_LAYERS {
        fresh.clear();
        for j in 0..=ny as isize {
            for i in 0..cols as isize {
                let v = vertex_at(mesh, i, j as usize);
                if known[v] {
                    continue;
                }
                let (mut line, mut n_line) = (None::<T>, 0usize);
                let (mut near, mut n_near) = (None::<T>, 0usize);
                for (di, dj) in [(1, 0), (-1, 0), (0, 1), (0, -1)] {
                    let Some(a) = at(i + di, j + dj).filter(|&a| known[a]) else {
                        continue;
                    };
                    near = Some(near.map_or(field[a], |s| s + field[a]));
                    n_near += 1;
                    let Some(b) = at(i + 2 * di, j + 2 * dj).filter(|&b| known[b]) else {
                        continue;
                    };
                    let w = dist(v, a) / dist(a, b);
                    let e = field[a] * (1.0 + w) + field[b] * (-w);
                    line = Some(line.map_or(e, |s| s + e));
                    n_line += 1;
                }
                match (line, near) {
                    (Some(s), _) => fresh.push((v, s * (1.0 / n_line as f64))),
                    (None, Some(s)) => fresh.push((v, s * (1.0 / n_near as f64))),
                    _ => {}
                }
            }
        }
        if fresh.is_empty() {
            break;
        }
        for &(v, val) in &fresh {
            field[v] = val;
            known[v] = true;
        }
    }
}

/// Element matrices of the mesh Laplacian for the Q1 vertices (2×2 Gauss on the bilinear map
/// of the element corners: a smoothing operator, exactness is not needed).
fn laplace_elements(mesh: &Mesh) -> Vec<[f64; 16]> {
    let g = 1.0 / 3f64.sqrt();
    mesh.element_coords
        .iter()
        .map(|xe| {
            let c = Q1_IN_Q2.map(|k| xe[k]);
            let mut k = [0.0; 16];
            for xi in [[-g, -g], [g, -g], [-g, g], [g, g]] {
                let (_, dref) = q1(xi);
                let mut jac = [[0.0; 2]; 2];
                for a in 0..4 {
                    for i in 0..2 {
                        for d in 0..2 {
                            jac[i][d] += dref[a][d] * c[a][i];
                        }
                    }
                }
                let det = jac[0][0] * jac[1][1] - jac[0][1] * jac[1][0];
                let grad = dref.map(|r| {
                    [
                        (jac[1][1] * r[0] - jac[1][0] * r[1]) / det,
                        (-jac[0][1] * r[0] + jac[0][0] * r[1]) / det,
                    ]
                });
                for a in 0..4 {
                    for b in 0..4 {
                        k[4 * a + b] += det * (grad[a][0] * grad[b][0] + grad[a][1] * grad[b][1]);
                    }
                }
            }
            k
        })
        .collect()
}

/// Interpolation weights of a vertex field at reference point `xi` of element `e`.
fn stencil(mesh: &Mesh, e: usize, xi: [f64; 2], remap: Remap) -> StencilWeights {
    let mut out = ([0; STENCIL_LEN], [0.0; STENCIL_LEN]);
    let nx = mesh.dims().0;
    let (ex, ey) = (e % nx, e / nx);
    let x_axis = AxisStencil::new(&mesh.ax.vertices, ex, xi[0], mesh.periodic);
    let y_axis = AxisStencil::new(&mesh.ay.vertices, ey, xi[1], false);
    match remap {
        Remap::Bilinear => {
            out.0[..4].copy_from_slice(&mesh.element_vertices[e]);
            out.1[..4].copy_from_slice(&q1(xi).0);
            // unused entries repeat a valid vertex with weight 0
            out.0[4..].fill(mesh.element_vertices[e][0]);
        }
        Remap::Quadratic => tensor_stencil(mesh, x_axis.quadratic(), y_axis.quadratic(), &mut out),
        Remap::Cubic => tensor_stencil(mesh, x_axis.cubic(), y_axis.cubic(), &mut out),
    }
    out
}

/// Fills `out` with the N×N tensor stencil of 1-D stencils `(c, w)` along x and y: vertex
/// indices c − 1 … c + N − 2, weights w_a w_b.
fn tensor_stencil<const N: usize>(
    mesh: &Mesh,
    (ci, wi): (isize, [f64; N]),
    (cj, wj): (isize, [f64; N]),
    out: &mut StencilWeights,
) {
    for b in 0..N {
        for a in 0..N {
            let k = N * b + a;
            out.0[k] = vertex_at(mesh, ci + a as isize - 1, (cj + b as isize - 1) as usize);
            out.1[k] = wi[a] * wj[b];
        }
    }
}

/// A point on one axis of the mesh, at reference coordinate `xi` of element `ex`, and the 1-D
/// Lagrange stencils through the vertices around it. The weights use the vertices' coordinates
/// (unwrapped across a periodic seam), so that they are exact for polynomials of their degree on
/// graded axes too: weights in index space were exact only on uniform axes and, on a graded one,
/// put the point where the piecewise-linear inverse of the grading does, an O(h²) error per remap
/// whatever the stencil's order.
struct AxisStencil<'a> {
    vertices: &'a [f64],
    /// Element index along the axis.
    ex: usize,
    /// The point's position in index space (vertex i at i): picks the stencil's vertices.
    p: f64,
    /// The point's coordinate.
    x: f64,
    periodic: bool,
}

impl<'a> AxisStencil<'a> {
    fn new(vertices: &'a [f64], ex: usize, xi: f64, periodic: bool) -> Self {
        let t = 0.5 * (xi + 1.0);
        let x = vertices[ex] + t * (vertices[ex + 1] - vertices[ex]);
        AxisStencil {
            vertices,
            ex,
            p: ex as f64 + t,
            x,
            periodic,
        }
    }

    fn n(&self) -> usize {
        self.vertices.len() - 1
    }

    /// Coordinate of vertex `i` (any integer on a periodic axis, unwrapped by the period).
    fn coordinate(&self, i: isize) -> f64 {
        let n = self.n() as isize;
        let period = self.vertices[self.n()] - self.vertices[0];
        self.vertices[i.rem_euclid(n) as usize] + i.div_euclid(n) as f64 * period
    }

    /// Lagrange weights at the point of the N vertices first, first + 1, …
    fn weights<const N: usize>(&self, first: isize) -> [f64; N] {
        let z: [f64; N] = std::array::from_fn(|a| self.coordinate(first + a as isize));
        std::array::from_fn(|a| {
            (0..N)
                .filter(|&b| b != a)
                .map(|b| (self.x - z[b]) / (z[a] - z[b]))
                .product()
        })
    }

    /// Centre vertex index and quadratic weights (at centre − 1, centre, centre + 1); the stencil
    /// is shifted inward at the ends of a non-periodic axis.
    fn quadratic(&self) -> (isize, [f64; 3]) {
        let mut c = self.p.round() as isize;
        if !self.periodic && self.n() >= 2 {
            c = c.clamp(1, self.n() as isize - 1);
        }
        (c, self.weights(c - 1))
    }

    /// Base vertex index and cubic weights (at base − 1, base, base + 1, base + 2); the stencil is
    /// shifted inward at the ends of a non-periodic axis.
    fn cubic(&self) -> (isize, [f64; 4]) {
        let mut c = self.ex as isize;
        if !self.periodic && self.n() >= 3 {
            c = c.clamp(1, self.n() as isize - 2);
        }
        (c, self.weights(c - 1))
    }
}

/// Q1 vertex id at logical vertex position (i, j) (i wrapped on a periodic axis).
fn vertex_at(mesh: &Mesh, i: isize, j: usize) -> usize {
    let (nx, ny) = mesh.dims();
    let i = if mesh.periodic {
        i.rem_euclid(nx as isize) as usize
    } else {
        i as usize
    };
    let (ex, ey) = (i.min(nx - 1), j.min(ny - 1));
    mesh.element_vertices[ey * nx + ex][(i - ex) + 2 * (j - ey)]
}

/// The periodic image of `x` (shifted by multiples of `period` in x) nearest to `near` in x.
fn nearest_image(x: [f64; 2], near: [f64; 2], period: Option<f64>) -> [f64; 2] {
    match period {
        Some(l) => [x[0] - l * ((x[0] - near[0]) / l).round(), x[1]],
        None => x,
    }
}

/// Locates `x` in the mesh displaced by `d` and returns (element, ξ, X_E(ξ)) with the pre-image
/// X_E(ξ) as the periodic image nearest to `x`.
fn pre_image(
    mesh: &Mesh,
    d: &[[f64; 2]],
    x: [f64; 2],
    period: Option<f64>,
) -> Result<(usize, [f64; 2], [f64; 2]), AleError> {
    let not_found = || AleError::NotFound { x: x[0], y: x[1] };
    // pre-images of wall points may leave the domain by round-off: start from the wall
    let locate = |x: [f64; 2]| {
        mesh.locate(x).or_else(|| match mesh.shape {
            Shape::Rectangle => {
                let (y0, y1) = (mesh.ay.vertices[0], mesh.ay.vertices[mesh.ay.len()]);
                let (x0, x1) = (mesh.ax.vertices[0], mesh.ax.vertices[mesh.ax.len()]);
                let xx = if mesh.periodic {
                    x[0]
                } else {
                    x[0].clamp(x0, x1)
                };
                mesh.locate([xx, x[1].clamp(y0, y1)])
            }
            // a point of the discrete inner or outer boundary of another mesh (whose nodes on
            // the circle lie elsewhere) can be O(h⁴) outside the circles: onto the circle
            Shape::Annulus => {
                let (r1, r2) = (mesh.ay.vertices[0], mesh.ay.vertices[mesh.ay.len()]);
                let r = x[0].hypot(x[1]);
                let s = r.clamp(r1, r2) / r;
                mesh.locate([x[0] * s, x[1] * s])
            }
        })
    };
    let (e0, xi0) = locate(x).ok_or_else(not_found)?;
    // The pre-image X solves X + d(X) = x. Where d varies slowly (everywhere but across a few
    // elements next to a rigid patch) X ≈ x − d(x): search around that first, then around x.
    // A displacement of more than an element per step (a particle at speed U with UΔt > h, and
    // the first predicted step moves by 2UΔt) puts X beyond the neighbours of x's element.
    let dx = {
        let (n, _) = q1(xi0);
        let dv = mesh.element_vertices[e0].map(|v| d[v]);
        (0..4).fold([0.0; 2], |a, m| {
            [a[0] + n[m] * dv[m][0], a[1] + n[m] * dv[m][1]]
        })
    };
    let guess = locate([x[0] - dx[0], x[1] - dx[1]]);
    let (nx, ny) = mesh.dims();
    let mut best: Option<(f64, usize, [f64; 2])> = None;
    let mut tried = Vec::with_capacity(18);
    for (ec, xic) in guess.into_iter().chain(std::iter::once((e0, xi0))) {
        let (exc, eyc) = ((ec % nx) as isize, (ec / nx) as isize);
        // the centre element first (from the located ξ), then its neighbours
        for (dx, dy) in std::iter::once((0, 0)).chain(
            [-1, 0, 1]
                .into_iter()
                .flat_map(|a| [-1, 0, 1].map(move |b| (a, b)))
                .filter(|&p| p != (0, 0)),
        ) {
            let ey = eyc + dy;
            if ey < 0 || ey >= ny as isize {
                continue;
            }
            let mut ex = exc + dx;
            if mesh.periodic {
                ex = ex.rem_euclid(nx as isize);
            } else if ex < 0 || ex >= nx as isize {
                continue;
            }
            let e = ey as usize * nx + ex as usize;
            if tried.contains(&e) {
                continue;
            }
            tried.push(e);
            let xe = &mesh.element_coords[e];
            let xc = nearest_image(x, xe[4], period.filter(|_| mesh.shape == Shape::Rectangle));
            let start = if (dx, dy) == (0, 0) { xic } else { [0.0, 0.0] };
            let Some(xi) = newton(xe, &mesh.element_vertices[e], d, xc, start) else {
                continue;
            };
            let out = (xi[0].abs() - 1.0).max(xi[1].abs() - 1.0);
            if out <= INSIDE_TOL {
                let p = q2_map(xe, xi).0;
                return Ok((e, clamp(xi), nearest_image(p, x, period)));
            }
            if best.as_ref().is_none_or(|b| out < b.0) {
                best = Some((out, e, xi));
            }
        }
    }
    // points of the exact boundary just outside the discrete (curved) one: nearest candidate
    match best {
        Some((out, e, xi)) if out < CURVED_BOUNDARY_TOL => {
            let xi = clamp(xi);
            let p = q2_map(&mesh.element_coords[e], xi).0;
            Ok((e, xi, nearest_image(p, x, period)))
        }
        _ => Err(not_found()),
    }
}

fn clamp(xi: [f64; 2]) -> [f64; 2] {
    xi.map(|v| v.clamp(-1.0, 1.0))
}

/// Solves X_E(ξ) + Σ N_v(ξ) d_v = x for ξ by Newton ([`newton_inverse`]) from `start`; `None`
/// without convergence, at a singular Jacobian or once an iterate leaves [−10, 10]².
fn newton(
    xe: &[[f64; 2]; 9],
    verts: &[usize; 4],
    d: &[[f64; 2]],
    x: [f64; 2],
    start: [f64; 2],
) -> Option<[f64; 2]> {
    const NEWTON: Newton = Newton {
        max_iter: NEWTON_MAX_ITER,
        step_tol: NEWTON_TOL,
        bound: Bound::Abandon(10.0),
    };
    let dv = verts.map(|v| d[v]);
    let residual = |xi| {
        let (p, mut jac, _) = q2_map(xe, xi);
        let (n, dn) = q1(xi);
        let mut r = [x[0] - p[0], x[1] - p[1]];
        for a in 0..4 {
            for i in 0..2 {
                r[i] -= n[a] * dv[a][i];
                for k in 0..2 {
                    jac[i][k] += dn[a][k] * dv[a][i];
                }
            }
        }
        (r, jac)
    };
    newton_inverse(residual, start, &NEWTON).ok()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::Axis;

    /// Newton converged to 1e-13 in ξ on O(1) elements: positions to ~1e-12.
    const LOCATE_TOL: f64 = 1e-11;
    /// Solve residual 1e-10 relative on O(0.01) displacements.
    const SOLVE_TOL: f64 = 1e-11;
    /// Observed order of one bicubic remap under mesh refinement: 4 asymptotically; 3.5 leaves
    /// room for the pre-asymptotic range on 40 elements and is far above index-space weights' 2.
    const MIN_CUBIC_ORDER: f64 = 3.5;

    fn channel() -> Mesh {
        Mesh::rectangle(
            Axis::uniform(-1.0, 1.0, 20),
            Axis::uniform(-0.5, 0.5, 10),
            true,
        )
    }

    fn one_move(center: [f64; 2], disp: [f64; 2]) -> Vec<RigidMove> {
        vec![RigidMove {
            center,
            radius: 0.15,
            displacement: disp,
        }]
    }

    #[test]
    fn no_motion_is_the_identity() {
        let mesh = channel();
        let mut ale = TemporaryAle::new(&mesh);
        let m = ale
            .advance(
                &mesh,
                &one_move([0.1, 0.0], [0.0, 0.0]),
                Some(2.0),
                0.1,
                true,
            )
            .unwrap();
        assert!(m
            .mesh_velocity
            .iter()
            .all(|u| u[0].abs() + u[1].abs() < LOCATE_TOL));
        let f: Vec<f64> = mesh
            .node_of_vertex
            .iter()
            .map(|&k| mesh.nodes[k][0] * 3.0 + mesh.nodes[k][1])
            .collect();
        for (v, (vs, w)) in m.at_n.iter().enumerate() {
            let g: f64 = (0..STENCIL_LEN).map(|a| f[vs[a]] * w[a]).sum();
            assert!((g - f[v]).abs() < LOCATE_TOL);
        }
    }

    #[test]
    fn displacement_is_rigid_on_the_patch_zero_on_walls_and_bounded() {
        let mesh = channel();
        let mut ale = TemporaryAle::new(&mesh);
        // particle across the periodic seam
        let disp = [0.012, -0.004];
        let d = ale
            .displacement(&mesh, &one_move([0.97, 0.05], disp), Some(2.0))
            .unwrap();
        let mut on_patch = 0;
        for (v, &k) in mesh.node_of_vertex.iter().enumerate() {
            let x = mesh.nodes[k];
            if x[1].abs() > 0.5 - 1e-12 {
                assert_eq!(d[v], [0.0, 0.0]);
            }
            let dx = (x[0] - 0.97) - 2.0 * ((x[0] - 0.97) / 2.0).round();
            if dx.hypot(x[1] - 0.05) < 0.15 {
                assert!((d[v][0] - disp[0]).abs() + (d[v][1] - disp[1]).abs() < SOLVE_TOL);
                on_patch += 1;
            }
            // maximum principle, componentwise
            assert!(d[v][0] > -SOLVE_TOL && d[v][0] < disp[0] + SOLVE_TOL);
            assert!(d[v][1] < SOLVE_TOL && d[v][1] > disp[1] - SOLVE_TOL);
        }
        assert!(on_patch >= 4, "{on_patch}");
    }

    /// The pre-image xⁿ (in element e at ξ) moved by the displacement there: xⁿ + d(xⁿ).
    fn displaced(mesh: &Mesh, d: &[[f64; 2]], e: usize, xi: [f64; 2], xn: [f64; 2]) -> [f64; 2] {
        let dn = q1(xi).0;
        std::array::from_fn(|i| {
            xn[i]
                + (0..4)
                    .map(|a| dn[a] * d[mesh.element_vertices[e][a]][i])
                    .sum::<f64>()
        })
    }

    #[test]
    fn pre_images_invert_the_ale_mesh_and_bilinear_fields_map_exactly() {
        let mesh = channel();
        let mut ale = TemporaryAle::new(&mesh);
        assert_eq!(ale.remap, Remap::Bilinear);
        let moves = one_move([0.97, 0.05], [0.02, 0.01]);
        let m = ale.advance(&mesh, &moves, Some(2.0), 0.1, true).unwrap();
        let d = &m.displacement;
        let f = |p: [f64; 2]| 0.3 + 2.0 * p[1] + 0.7 * p[1] * p[1].abs().min(0.0);
        let fv: Vec<f64> = mesh
            .node_of_vertex
            .iter()
            .map(|&k| f(mesh.nodes[k]))
            .collect();
        for (v, &k) in mesh.node_of_vertex.iter().enumerate() {
            let x = mesh.nodes[k];
            let (e, xi, xn) = pre_image(&mesh, d, x, Some(2.0)).unwrap();
            // x = xⁿ + d(xⁿ)
            let back = displaced(&mesh, d, e, xi, xn);
            assert!((back[0] - x[0]).abs() < LOCATE_TOL, "{x:?} {xn:?}");
            assert!((back[1] - x[1]).abs() < LOCATE_TOL);
            // a field linear in y is interpolated exactly by Q1
            let (vs, w) = m.at_n[v];
            let g: f64 = (0..STENCIL_LEN).map(|a| fv[vs[a]] * w[a]).sum();
            assert!((g - f(xn)).abs() < LOCATE_TOL, "{g} {}", f(xn));
        }
    }

    #[test]
    fn pre_images_beyond_the_neighbouring_elements_are_found() {
        // A particle of radius 3h moving 1.7 elements in one step (the first predicted step
        // moves by 2UΔt: a particle at y = −0.4 with U ≈ −0.41, Δt = 0.02, a = 5h = 0.05 moved
        // 1.65h and its pre-images were lost when only the 3×3 elements around x were searched)
        let mesh = channel();
        let h = 0.1;
        let mut ale = TemporaryAle::new(&mesh);
        let moves = vec![RigidMove {
            center: [0.3, 0.0],
            radius: 3.0 * h,
            displacement: [-1.7 * h, 0.2 * h],
        }];
        let m = ale.advance(&mesh, &moves, Some(2.0), 0.1, true).unwrap();
        let d = &m.displacement;
        for &k in &mesh.node_of_vertex {
            let x = mesh.nodes[k];
            let (e, xi, xn) = pre_image(&mesh, d, x, Some(2.0)).unwrap();
            let back = nearest_image(displaced(&mesh, d, e, xi, xn), x, Some(2.0));
            assert!((back[0] - x[0]).abs() < LOCATE_TOL, "{x:?} {xn:?}");
            assert!((back[1] - x[1]).abs() < LOCATE_TOL);
        }
    }

    /// The channel graded along and across (largest element 3× / 2× the smallest).
    fn graded_channel() -> Mesh {
        Mesh::rectangle(
            Axis::centred(-1.0, 1.0, 20, 3.0),
            Axis::centred(-0.5, 0.5, 10, 2.0),
            true,
        )
    }

    /// The remap `remap` reproduces the field `f` (of the degree it interpolates exactly) at the
    /// pre-images of one move, walls (one-sided stencils) included, on the uniform and on the
    /// graded channel. Points near the periodic seam, where `f` is not periodic, are skipped.
    fn assert_remap_exact(remap: Remap, f: impl Fn([f64; 2]) -> f64) {
        assert_remap_exact_on(channel(), remap, &f);
        assert_remap_exact_on(graded_channel(), remap, &f);
    }

    fn assert_remap_exact_on(mesh: Mesh, remap: Remap, f: &impl Fn([f64; 2]) -> f64) {
        let mut ale = TemporaryAle::new(&mesh);
        ale.remap = remap;
        let moves = one_move([0.0, 0.05], [0.013, -0.007]);
        let m = ale.advance(&mesh, &moves, Some(2.0), 0.1, true).unwrap();
        let fv: Vec<f64> = mesh
            .node_of_vertex
            .iter()
            .map(|&k| f(mesh.nodes[k]))
            .collect();
        let mut checked = 0;
        for (v, &k) in mesh.node_of_vertex.iter().enumerate() {
            let x = mesh.nodes[k];
            if x[0].abs() > 0.7 {
                continue;
            }
            let (_, _, xn) = pre_image(&mesh, &m.displacement, x, Some(2.0)).unwrap();
            let (vs, w) = m.at_n[v];
            let g: f64 = (0..STENCIL_LEN).map(|a| fv[vs[a]] * w[a]).sum();
            assert!(
                (g - f(xn)).abs() < LOCATE_TOL,
                "{remap:?} at {x:?}: {g} vs {}",
                f(xn)
            );
            checked += 1;
        }
        assert!(checked > 100);
    }

    #[test]
    fn quadratic_remap_is_exact_for_biquadratic_fields() {
        assert_remap_exact(Remap::Quadratic, |p| {
            0.3 + 2.0 * p[1] - p[1] * p[1] + 0.7 * p[0] * p[0] + 0.4 * p[0] * p[1]
                - 1.3 * p[0] * p[0] * p[1] * p[1]
        });
    }

    /// A bicubic polynomial (degree 3 in x and in y) for the exactness tests.
    fn bicubic_field(p: [f64; 2]) -> f64 {
        let (x, y) = (p[0], p[1]);
        0.3 + 2.0 * y - y * y + 0.9 * y * y * y + 0.7 * x * x - 0.5 * x * x * x + 0.4 * x * y
            - 1.3 * x * x * y * y * y
            + 0.8 * x * x * x * y * y * y
    }

    /// A computational mesh moved by exactly one element column, without particle motion: every
    /// new vertex is an old vertex (the next column), so the history is relabelled exactly
    /// (Kronecker weights) and the mesh velocity is zero.
    #[test]
    fn a_mesh_moved_by_one_column_relabels_the_history_exactly() {
        let old = channel();
        let h = old.ax.vertices[1] - old.ax.vertices[0];
        let shifted = Axis {
            vertices: old.ax.vertices.iter().map(|x| x + h).collect(),
        };
        let new = old.with_axes(shifted, old.ay.clone());
        let mut ale = TemporaryAle::new(&old);
        ale.remap = Remap::Cubic;
        let still = one_move([0.0, 0.05], [0.0, 0.0]);
        let m = ale
            .advance_onto(&old, &new, &still, Some(2.0), 0.1, true)
            .unwrap();
        let (nx, _) = old.dims();
        for (v, (vs, w)) in m.at_n.iter().enumerate() {
            let (i, j) = (v % nx, v / nx);
            let next = ((i + 1) % nx) + nx * j;
            let weight_there: f64 = (0..STENCIL_LEN)
                .filter(|&a| vs[a] == next)
                .map(|a| w[a])
                .sum();
            assert!(
                (weight_there - 1.0).abs() < 1e-12,
                "vertex {v}: {weight_there}"
            );
        }
        assert!(m.mesh_velocity.iter().flatten().all(|u| u.abs() < 1e-9));
    }

    /// The Laplace problem follows the mesh it is solved on: after a solve on one mesh, a solve
    /// on a mesh with moved columns and rows equals that of a fresh solver built there.
    #[test]
    fn the_displacement_is_solved_on_the_mesh_given() {
        let (m0, m1) = (channel(), graded_channel());
        let moves = one_move([0.0, 0.05], [0.013, -0.007]);
        let mut reused = TemporaryAle::new(&m0);
        let on_m0 = reused.displacement(&m0, &moves, Some(2.0)).unwrap();
        let on_m1 = reused.displacement(&m1, &moves, Some(2.0)).unwrap();
        let fresh = TemporaryAle::new(&m1)
            .displacement(&m1, &moves, Some(2.0))
            .unwrap();
        assert_eq!(on_m1, fresh);
        assert_ne!(on_m0, on_m1, "the graded mesh has another Laplacian");
    }

    /// Onto a moved (graded) mesh, with a particle moving: the remap interpolates on the mesh of
    /// sⁿ and reproduces a bicubic field at the pre-images of the new mesh's vertices; a second
    /// step onto a third mesh locates x^{n−1} in the first mesh (the mesh of s^{n−1}) and
    /// reproduces the field there too.
    #[test]
    fn pre_images_of_a_moved_mesh_are_interpolated_on_the_meshes_of_the_history() {
        let m0 = channel();
        let m1 = graded_channel();
        let m2 = m0.with_axes(
            Axis::centred(-1.0, 1.0, 20, 2.0),
            Axis::centred(-0.5, 0.5, 10, 1.5),
        );
        let mut ale = TemporaryAle::new(&m0);
        ale.remap = Remap::Cubic;
        let (dt, period) = (0.1, Some(2.0));
        let field = |mesh: &Mesh| -> Vec<f64> {
            mesh.node_of_vertex
                .iter()
                .map(|&k| bicubic_field(mesh.nodes[k]))
                .collect()
        };
        let check = |at: &[StencilWeights], on: &Mesh, v: usize, xp: [f64; 2]| {
            let f = field(on);
            let (vs, w) = at[v];
            let g: f64 = (0..STENCIL_LEN).map(|a| f[vs[a]] * w[a]).sum();
            assert!(
                (g - bicubic_field(xp)).abs() < LOCATE_TOL,
                "{g} vs {} at {xp:?}",
                bicubic_field(xp)
            );
        };
        // step 1: s⁰ on m0, onto m1
        let moves = one_move([0.0, 0.05], [0.013, -0.007]);
        let a = ale
            .advance_onto(&m0, &m1, &moves, period, dt, true)
            .unwrap();
        let mut checked = 0;
        for (v, &k) in m1.node_of_vertex.iter().enumerate() {
            let x = m1.nodes[k];
            if x[0].abs() > 0.7 {
                continue; // the field is not periodic
            }
            let (_, _, xn) = pre_image(&m0, &a.displacement, x, period).unwrap();
            check(&a.at_n, &m0, v, xn);
            checked += 1;
        }
        assert!(checked > 100);
        // step 2: s¹ on m1 (s⁰ on m0), onto m2; the particle moved on
        let moves = one_move([0.013, 0.043], [0.011, -0.006]);
        let b = ale
            .advance_onto(&m1, &m2, &moves, period, dt, false)
            .unwrap();
        let at_nm1 = b.at_n_minus_1.as_ref().expect("second-order step");
        for (v, &k) in m2.node_of_vertex.iter().enumerate() {
            let x = m2.nodes[k];
            if x[0].abs() > 0.7 {
                continue;
            }
            let (_, _, xn) = pre_image(&m1, &b.displacement, x, period).unwrap();
            check(&b.at_n, &m1, v, xn);
            // x^{n−1} from the BDF2 mesh velocity: u = (1.5 x − 2 xⁿ + 0.5 x^{n−1})/Δt
            let u = b.mesh_velocity[k];
            let xnm1 = [0, 1].map(|c| 2.0 * (u[c] * dt - 1.5 * x[c] + 2.0 * xn[c]));
            check(at_nm1, &m0, v, xnm1);
        }
    }

    #[test]
    fn cubic_remap_is_exact_for_bicubic_fields() {
        assert_remap_exact(Remap::Cubic, bicubic_field);
    }

    /// On a graded axis the bicubic remap keeps its fourth order: one remap of sin(kx) under a
    /// shift of 0.37 of a mean element, x graded 3:1, on 40 / 80 / 160 elements. (Weights in
    /// index space gave 2.5e-3 / 7.9e-4 / 2.3e-4: second order.)
    #[test]
    fn cubic_remap_keeps_its_order_on_a_graded_axis() {
        let error = |nx: usize| -> f64 {
            let l = 2.0;
            let mesh = Mesh::rectangle(
                Axis::centred(-1.0, 1.0, nx, 3.0),
                Axis::uniform(-0.5, 0.5, 4),
                true,
            );
            let k = 2.0 * std::f64::consts::PI / l * 2.0;
            let d = vec![[0.37 * l / nx as f64, 0.0]; mesh.n_vertices()];
            let f = |x: f64| (k * x).sin();
            let fv: Vec<f64> = mesh
                .node_of_vertex
                .iter()
                .map(|&n| f(mesh.nodes[n][0]))
                .collect();
            let mut err: f64 = 0.0;
            for &n in &mesh.node_of_vertex {
                let (e, xi, xn) = pre_image(&mesh, &d, mesh.nodes[n], Some(l)).unwrap();
                let (v, w) = stencil(&mesh, e, xi, Remap::Cubic);
                let g: f64 = (0..STENCIL_LEN).map(|a| fv[v[a]] * w[a]).sum();
                err = err.max((g - f(xn[0])).abs());
            }
            err
        };
        let e: Vec<f64> = [40, 80, 160].into_iter().map(error).collect();
        for pair in e.windows(2) {
            let order = (pair[0] / pair[1]).log2();
            assert!(order > MIN_CUBIC_ORDER, "errors {e:?}: order {order:.2}");
        }
    }

    /// Repeated remaps of a smooth field under a uniform shift of a fraction θ of an element
    /// per step (a particle's neighbourhood crossing the fixed mesh): the error accumulates
    /// per remap like a semi-Lagrangian scheme's. Bound per step and mode sin(kx):
    /// Lagrange interpolation error |Π(θ + j)|/(p + 1)! · (kh)^{p+1} for the p + 1 stencil
    /// points j; the cubic remap must stay within N times its bound and beat the quadratic one.
    #[test]
    fn repeated_remaps_accumulate_the_interpolation_error_of_their_order() {
        let (nx, l) = (40, 2.0);
        let mesh = Mesh::rectangle(
            Axis::uniform(-1.0, 1.0, nx),
            Axis::uniform(-0.5, 0.5, 4),
            true,
        );
        let h = l / nx as f64;
        let theta = 0.66;
        let d = vec![[theta * h, 0.0]; mesh.n_vertices()];
        let k = 2.0 * std::f64::consts::PI / l * 2.0;
        let exact = |x: f64, t: usize| (k * (x - t as f64 * theta * h)).sin();
        let steps = 50;
        let run = |remap: Remap| -> f64 {
            let at: Vec<StencilWeights> = mesh
                .node_of_vertex
                .iter()
                .map(|&n| {
                    let (e, xi, _) = pre_image(&mesh, &d, mesh.nodes[n], Some(l)).unwrap();
                    stencil(&mesh, e, xi, remap)
                })
                .collect();
            let xs: Vec<f64> = mesh
                .node_of_vertex
                .iter()
                .map(|&n| mesh.nodes[n][0])
                .collect();
            let mut f: Vec<f64> = xs.iter().map(|&x| exact(x, 0)).collect();
            for _ in 0..steps {
                f = at
                    .iter()
                    .map(|(v, w)| (0..STENCIL_LEN).map(|a| f[v[a]] * w[a]).sum())
                    .collect();
            }
            xs.iter()
                .zip(&f)
                .map(|(&x, g)| (g - exact(x, steps)).abs())
                .fold(0.0, f64::max)
        };
        let (quadratic, cubic) = (run(Remap::Quadratic), run(Remap::Cubic));
        // the cubic stencil holds θ between its 2nd and 3rd points: nodes at θ + 1, θ, θ − 1, θ − 2
        let node_product = |nodes: &[f64]| nodes.iter().map(|z| z.abs()).product::<f64>();
        let cubic_bound =
            steps as f64 * node_product(&[theta + 1.0, theta, theta - 1.0, theta - 2.0]) / 24.0
                * (k * h).powi(4);
        assert!(
            cubic < cubic_bound,
            "cubic {cubic:.3e} above its bound {cubic_bound:.3e}"
        );
        assert!(
            cubic < quadratic / 3.0,
            "cubic {cubic:.3e} not well below quadratic {quadratic:.3e}"
        );
    }

    #[test]
    fn mesh_velocity_of_a_steadily_moving_particle() {
        let mesh = channel();
        let mut ale = TemporaryAle::new(&mesh);
        let (v, dt) = ([0.3, -0.1], 0.02);
        let step = [v[0] * dt, v[1] * dt];
        let mut c = [0.2, 0.0];
        let mut last = None;
        for first in [true, false, false] {
            last = Some(
                ale.advance(&mesh, &one_move(c, step), Some(2.0), dt, first)
                    .unwrap(),
            );
            c = [c[0] + step[0], c[1] + step[1]];
        }
        let m = last.unwrap();
        assert!(m.at_n_minus_1.is_some());
        // nodes well inside the rigid patch (r < a - h) move with the particle, walls stay
        let c_prev = [c[0] - step[0], c[1] - step[1]];
        for (k, x) in mesh.nodes.iter().enumerate() {
            let r = (x[0] - c_prev[0]).hypot(x[1] - c_prev[1]);
            if r < 0.05 {
                let u = m.mesh_velocity[k];
                assert!((u[0] - v[0]).abs() + (u[1] - v[1]).abs() < 1e-9, "{u:?}");
            }
            if x[1].abs() > 0.5 - 1e-12 {
                assert!(m.mesh_velocity[k][0].abs() + m.mesh_velocity[k][1].abs() < 1e-12);
            }
        }
    }
}

#[cfg(test)]
mod annulus_tests {
    use super::*;
    use crate::solver::couette::CouetteGeometry;

    #[test]
    fn extension_into_a_disc_is_exact_for_linear_fields() {
        // graded in x (distance-weighted extrapolation), periodic; hole: a disc across the seam
        use crate::mesh::Axis;
        let ax = Axis::banded(-2.0, 2.0, -1.9, 0.4, 0.1, 1.2);
        let mesh = Mesh::rectangle(ax, Axis::uniform(-1.0, 1.0, 20), true);
        let (c, r, h) = ([-1.8, 0.1], 0.55, 0.1);
        let f = |p: [f64; 2]| 0.3 + 1.7 * p[0] - 0.9 * p[1];
        let period = 4.0;
        let depth = |p: [f64; 2]| {
            let dx = p[0] - c[0] - period * ((p[0] - c[0]) / period).round();
            r - dx.hypot(p[1] - c[1])
        };
        let mut known = vec![true; mesh.n_vertices()];
        let mut field = vec![0.0; mesh.n_vertices()];
        for v in 0..mesh.n_vertices() {
            let p = mesh.nodes[mesh.node_of_vertex[v]];
            known[v] = depth(p) < 0.0;
            // the exact field seen across the seam from the hole: x unwrapped next to c
            let x = c[0] + (p[0] - c[0]) - period * ((p[0] - c[0]) / period).round();
            field[v] = if known[v] { f([x, p[1]]) } else { f64::NAN };
        }
        extend_inside(&mesh, &known, &mut field);
        let mut filled = 0;
        for v in 0..mesh.n_vertices() {
            let p = mesh.nodes[mesh.node_of_vertex[v]];
            let x = c[0] + (p[0] - c[0]) - period * ((p[0] - c[0]) / period).round();
            if known[v] {
                continue;
            }
            if field[v].is_finite() {
                filled += 1;
                assert!(
                    (field[v] - f([x, p[1]])).abs() < 1e-12,
                    "vertex at {p:?}: {} vs {}",
                    field[v],
                    f([x, p[1]])
                );
            } else {
                // two layers reach at least 2h deep
                assert!(
                    depth(p) > 2.0 * h,
                    "vertex at {p:?} (depth {}) not filled",
                    depth(p)
                );
            }
        }
        assert!(filled > 40, "{filled} vertices filled");
    }

    #[test]
    fn pre_images_on_the_annulus() {
        let g = CouetteGeometry::new(1.0, 4.0, 1.0).unwrap();
        let mesh = g.build_mesh(64, 12);
        let mut ale = TemporaryAle::new(&mesh);
        let mut c = g.position(0.5, 0.3);
        for first in [true, false, false] {
            let step = [-0.064 * 0.3f64.sin(), 0.064 * 0.3f64.cos()];
            let moves = vec![RigidMove {
                center: c,
                radius: 0.4,
                displacement: step,
            }];
            ale.advance(&mesh, &moves, None, 0.25, first).unwrap();
            c = [c[0] + step[0], c[1] + step[1]];
        }
    }

    /// A mesh that follows a particle in the Couette cell moves its θ columns: the wall nodes of
    /// the new mesh lie between those of the old one, where the old discrete (piecewise
    /// parabolic) boundary is O(h⁴) inside the circles. Their pre-images, and the second
    /// pre-images of those in the mesh before, must still be found; on the walls (d = 0) they
    /// are the nodes themselves, so the mesh velocity there vanishes but for that O(h⁴).
    #[test]
    fn pre_images_of_wall_nodes_on_a_moved_annulus() {
        let g = CouetteGeometry::new(1.0, 4.0, 1.0).unwrap();
        let base = g.build_mesh(64, 12);
        let two_pi = 2.0 * std::f64::consts::PI;
        let turned = |shift: f64| {
            let theta = Axis {
                vertices: (0..=64)
                    .map(|i| {
                        let s = i as f64 / 64.0;
                        shift + two_pi * s + 0.05 * (two_pi * s).sin()
                    })
                    .collect(),
            };
            base.with_axes(theta, base.ay.clone())
        };
        let meshes = [base.clone(), turned(-0.03), turned(-0.07)];
        let mut ale = TemporaryAle::new(&base);
        ale.remap = Remap::Cubic;
        let mut c = g.position(0.5, 0.0);
        let dt = 0.25;
        for (k, pair) in meshes.windows(2).enumerate() {
            let step = [0.0, -0.03];
            let moves = vec![RigidMove {
                center: c,
                radius: 0.4,
                displacement: step,
            }];
            let m = ale
                .advance_onto(&pair[0], &pair[1], &moves, None, dt, k == 0)
                .expect("every pre-image found");
            let wall_speed = [Side::Bottom, Side::Top]
                .iter()
                .flat_map(|&side| pair[1].side_nodes(side))
                .map(|n| m.mesh_velocity[n][0].hypot(m.mesh_velocity[n][1]))
                .fold(0.0, f64::max);
            // the Q2 circle's distance to the circle, R Δθ⁴/520 (R = 4, Δθ up to 1.3 × 2π/64 on
            // these θ axes), over Δt; measured 2.9e-6
            let bound = 4.0 * 4.0 * (1.3 * two_pi / 64.0f64).powi(4) / 520.0 / dt;
            assert!(
                wall_speed < bound,
                "step {k}: wall mesh speed {wall_speed:e} > {bound:e}"
            );
            c = [c[0] + step[0], c[1] + step[1]];
        }
    }
}
