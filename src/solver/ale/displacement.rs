//! The mesh displacement of the temporary ALE map (thesis Eqs. 5.35–5.38): −∇²d_m = 0 on the
//! whole mesh, d_m = 0 on the walls, periodic with the mesh, d_m = X̂ⁿ⁺¹ − X̂ⁿ on a rigid patch of
//! each particle; one Q1 Laplace matrix for both components. With a background displacement (a
//! free surface's stretch, `TemporaryAle::background`) the harmonic part carries what the
//! background leaves: d_m = background + harmonic.

use super::{AleError, AleExtent, RigidMove, TemporaryAle};
use crate::fem::element::{q1, Q1_IN_Q2};
use crate::fem::linsolve::{DirectSolver, Pivoting, SolverKind};
use crate::fem::sparse::{q1_pattern, SparseMatrix};
use crate::mesh::{bounding_box, dilate, Mesh};
use crate::periodic::nearest_image;

/// Relative residual accepted from the Laplace solve.
const LAPLACE_RESIDUAL_TOL: f64 = 1e-10;

/// Rings of elements around a rigid patch over which [`AleExtent::Ring`] lets the displacement
/// fall to zero. The map's stretch there is about |d| / (rings · h) = C / rings for a particle
/// moving at Courant number C = |U|Δt/h. Measured on the §5.7.2 three-particle string (Wi = 2,
/// x-graded 200×50, docs/validation.md): against the whole mesh's map, 5 rings changed the
/// terminal gaps by 0.77 % and 0.49 % and ω* by up to 0.27 %; 10 rings by 0.21 %, 0.14 % and
/// 0.14 % (the bound is 0.5 %), for 3 ms more per step at 200×50 (ALE 0.030 → 0.033 s,
/// the whole mesh's 0.048).
pub const RING_ELEMENTS: usize = 10;

/// The Laplace problem of the mesh displacement on a region of elements (all of them, or a
/// ring around the rigid patches): its vertices, matrix and factorization, kept while the
/// region stays (the factorization while its fixed vertices stay too).
pub(super) struct LaplaceSystem {
    /// The region's elements (per element of the mesh).
    region: Vec<bool>,
    /// The region's elements, and their vertices in the local numbering.
    elements: Vec<(usize, [usize; 4])>,
    /// Local vertex → vertex of the mesh.
    global: Vec<usize>,
    /// Per local vertex, whether it lies on the region's boundary (a vertex of an element
    /// outside it): the displacement is zero there.
    on_edge: Vec<bool>,
    matrix: SparseMatrix,
    solver: Option<DirectSolver>,
    /// The fixed local vertices `solver` was factored for (empty: not factored).
    pub(super) factored_mask: Vec<bool>,
}

impl LaplaceSystem {
    fn new(mesh: &Mesh, region: Vec<bool>) -> Self {
        let mut local = vec![usize::MAX; mesh.n_vertices()];
        let mut global = Vec::new();
        let elements: Vec<(usize, [usize; 4])> = (0..mesh.n_elements())
            .filter(|&e| region[e])
            .map(|e| {
                let verts = mesh.element_vertices[e].map(|v| {
                    if local[v] == usize::MAX {
                        local[v] = global.len();
                        global.push(v);
                    }
                    local[v]
                });
                (e, verts)
            })
            .collect();
        let locals: Vec<[usize; 4]> = elements.iter().map(|(_, v)| *v).collect();
        let mut edge = vec![false; mesh.n_vertices()];
        for e in (0..mesh.n_elements()).filter(|&e| !region[e]) {
            for &v in &mesh.element_vertices[e] {
                edge[v] = true;
            }
        }
        Self {
            matrix: q1_pattern(global.len(), &locals),
            on_edge: global.iter().map(|&v| edge[v]).collect(),
            region,
            elements,
            global,
            solver: None,
            factored_mask: Vec::new(),
        }
    }

    /// The harmonic displacement at the local vertices with the `fixed` values (the symmetric
    /// elimination of the fixed values; the matrix assembled and factored again only when the
    /// set of fixed vertices changes, not their values).
    fn solve(
        &mut self,
        element_k: &[[f64; 16]],
        fixed: &[Option<[f64; 2]>],
    ) -> Result<Vec<[f64; 2]>, AleError> {
        let n = self.global.len();
        if n == 0 {
            return Ok(Vec::new());
        }
        let mask: Vec<bool> = fixed.iter().map(Option::is_some).collect();
        let refactor = self.solver.is_none() || self.factored_mask != mask;
        let mut rhs = [vec![0.0; n], vec![0.0; n]];
        for (e, verts) in &self.elements {
            let k = &element_k[*e];
            for (b, &j) in verts.iter().enumerate() {
                let Some(g) = fixed[j] else { continue };
                for (a, &i) in verts.iter().enumerate() {
                    if fixed[i].is_none() {
                        rhs[0][i] -= k[4 * a + b] * g[0];
                        rhs[1][i] -= k[4 * a + b] * g[1];
                    }
                }
            }
        }
        for (v, f) in fixed.iter().enumerate() {
            if let Some(g) = f {
                rhs[0][v] = g[0];
                rhs[1][v] = g[1];
            }
        }
        if refactor {
            let fx: Vec<Option<f64>> = mask.iter().map(|&m| m.then_some(0.0)).collect();
            let mut scratch = vec![0.0; n];
            self.matrix.zero();
            let zero = [0.0; 4];
            for (e, verts) in &self.elements {
                self.matrix
                    .scatter(verts, &element_k[*e], &zero, &mut scratch, &fx);
            }
            self.matrix.apply_constraints(&mut scratch, &fx);
            if self.solver.is_none() {
                let mut solver = DirectSolver::analyze(&self.matrix, SolverKind::Lblt)?;
                // a Laplacian: positive definite, so its LDLᵀ needs no pivots
                solver.set_pivoting(Pivoting::WhenNeeded);
                self.solver = Some(solver);
            }
            self.factored_mask = Vec::new();
            self.solver
                .as_mut()
                .expect("analysed above")
                .factor(&self.matrix)?;
            self.factored_mask = mask;
        }
        let solver = self.solver.as_mut().expect("factored above");
        let mut d = vec![[0.0; 2]; n];
        let mut sol = vec![0.0; n];
        for (c, r) in rhs.iter().enumerate() {
            solver.solve_checked(&self.matrix, r, &mut sol, LAPLACE_RESIDUAL_TOL)?;
            d.iter_mut().zip(&sol).for_each(|(d, s)| d[c] = *s);
        }
        Ok(d)
    }
}

impl TemporaryAle {
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
        let background = self.background.take();
        if let Some(b) = &background {
            assert_eq!(b.len(), nv, "one background displacement per vertex");
        }
        let outside = self.outside.take();
        if let Some(o) = &outside {
            assert_eq!(o.len(), nv, "one outside flag per vertex");
        }
        let d = self.harmonic(
            mesh,
            moves,
            period,
            background.as_deref(),
            outside.as_deref(),
        );
        self.background = background;
        self.outside = outside;
        d
    }

    /// The harmonic part of the displacement: rigid moves less `background` on the patches, zero
    /// on the walls and the vertices `outside` the fluid; the background added.
    fn harmonic(
        &mut self,
        mesh: &Mesh,
        moves: &[RigidMove],
        period: Option<f64>,
        background: Option<&[[f64; 2]]>,
        outside: Option<&[bool]>,
    ) -> Result<Vec<[f64; 2]>, AleError> {
        let nv = mesh.n_vertices();
        let bg = |v: usize| background.map_or([0.0; 2], |b| b[v]);
        if moves.iter().all(|m| m.displacement == [0.0, 0.0]) && background.is_none() {
            return Ok(vec![[0.0; 2]; nv]);
        }
        if (&mesh.ax, &mesh.ay) != (&self.k_axes.0, &self.k_axes.1) {
            // a mesh with moved columns or rows: same pattern, new element matrices
            self.element_k = laplace_elements(mesh);
            self.k_axes = (mesh.ax.clone(), mesh.ay.clone());
            if let Some(system) = &mut self.system {
                system.factored_mask.clear();
            }
        }
        // rigid patches: the nearest particle claims a vertex; walls win
        let mut claim: Vec<Option<(f64, [f64; 2])>> = vec![None; nv];
        let mut patch = vec![false; mesh.n_elements()];
        for (e, xe) in mesh.element_coords.iter().enumerate() {
            let (lo, hi) = bounding_box(xe);
            for m in moves {
                let c = nearest_image(m.center, 0.5 * (lo[0] + hi[0]), period);
                let q = [c[0].clamp(lo[0], hi[0]), c[1].clamp(lo[1], hi[1])];
                if (q[0] - c[0]).hypot(q[1] - c[1]) >= m.radius {
                    continue;
                }
                patch[e] = true;
                for (k, &v) in Q1_IN_Q2.iter().zip(&mesh.element_vertices[e]) {
                    let d = (xe[*k][0] - c[0]).hypot(xe[*k][1] - c[1]);
                    if claim[v].is_none_or(|(dc, _)| d < dc) {
                        claim[v] = Some((d, m.displacement));
                    }
                }
            }
        }
        let region = match self.extent {
            AleExtent::Whole => vec![true; mesh.n_elements()],
            AleExtent::Ring => dilate(&patch, mesh.dims(), mesh.periodic, RING_ELEMENTS),
        };
        if self.system.as_ref().is_none_or(|s| s.region != region) {
            self.system = Some(LaplaceSystem::new(mesh, region));
        }
        let system = self.system.as_mut().expect("set above");
        // the fixed vertices of the region's problem: walls, the vertices outside the fluid and
        // the region's boundary (zero), the rigid patches (their moves less the background)
        let fixed: Vec<Option<[f64; 2]>> = system
            .global
            .iter()
            .zip(&system.on_edge)
            .map(|(&v, &edge)| {
                if self.wall[v] || edge || outside.is_some_and(|o| o[v]) {
                    Some([0.0; 2])
                } else {
                    claim[v].map(|(_, m)| [m[0] - bg(v)[0], m[1] - bg(v)[1]])
                }
            })
            .collect();
        let harmonic = system.solve(&self.element_k, &fixed)?;
        let mut d = vec![[0.0; 2]; nv];
        for (&v, h) in system.global.iter().zip(harmonic) {
            d[v] = h;
        }
        if let Some(b) = background {
            d.iter_mut().zip(b).for_each(|(d, b)| {
                d[0] += b[0];
                d[1] += b[1];
            });
        }
        if let Some(vertex) = d
            .iter()
            .position(|v| !(v[0].is_finite() && v[1].is_finite()))
        {
            return Err(AleError::NonFinite { vertex });
        }
        Ok(d)
    }
}

/// Element matrices of the mesh Laplacian for the Q1 vertices (2×2 Gauss on the bilinear map
/// of the element corners: a smoothing operator, exactness is not needed).
pub(super) fn laplace_elements(mesh: &Mesh) -> Vec<[f64; 16]> {
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
