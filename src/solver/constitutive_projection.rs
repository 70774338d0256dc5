//! L² projections onto Q1 and Q1 evaluation helpers for the stress–flow coupling.
//!
//! - [`Q1Projection`]: `(e, c) = (e, f)` for all Q1 test functions `e` with the consistent mass
//!   matrix over the fluid part (thesis Eq. 5.28 for `f = exp(s)`; also the decoupled DEVSS-G
//!   projection `(H, G − L(u)) = 0` of Eq. 5.19/5.50 when G is not a flow unknown). The mass
//!   matrix is assembled and factored (LBLᵀ, symbolic analysis kept) once per geometry and shared
//!   by all components.
//! - `*_at` functions: values and physical gradients of nodal Q1 (and Q2 velocity) fields at a
//!   reference point of an element, as the polymer stress of the flow solve needs them.

use crate::fem::element::{physical_gradients, q1, q2, q2_map, MapAt, RuleMaps, RULE_POINTS};
use crate::fem::linsolve::{DirectSolver, Pivoting, SolverKind};
use crate::fem::quadrature::gauss_quad;
use crate::fem::sparse::{q1_pattern, SparseMatrix};
use crate::mesh::Mesh;
use crate::rheology::{Sym2, VelocityGradient};
use crate::solver::constitutive::{inactive_vertices, ConstitutiveError};
use crate::solver::ghost::{face_vertices, ghost_face_matrix, ghost_faces, FacePattern, GhostFace};
use crate::solver::rigid::ElementCut;

/// Value of a nodal Q1 tensor field at reference point `xi` of element `e`.
#[inline]
pub fn sym_at(mesh: &Mesh, nodal: &[Sym2], e: usize, xi: [f64; 2]) -> Sym2 {
    let psi = q1(xi).0;
    let v = &mesh.element_vertices[e];
    (0..4).fold(Sym2::ZERO, |acc, a| acc + psi[a] * nodal[v[a]])
}

/// Physical gradient `[∂/∂x, ∂/∂y]` of a nodal Q1 tensor field at `xi` of element `e`.
#[inline]
pub fn sym_gradient_at(mesh: &Mesh, nodal: &[Sym2], e: usize, xi: [f64; 2]) -> [Sym2; 2] {
    let (_, jac, det) = q2_map(&mesh.element_coords[e], xi);
    let mut dpsi = [[0.0; 2]; 4];
    physical_gradients(&jac, det, &q1(xi).1, &mut dpsi);
    let v = &mesh.element_vertices[e];
    let mut out = [Sym2::ZERO; 2];
    for a in 0..4 {
        out[0] += dpsi[a][0] * nodal[v[a]];
        out[1] += dpsi[a][1] * nodal[v[a]];
    }
    out
}

/// Value of the nodal Q1 velocity-gradient field G (`[G_xx, G_xy, G_yx, G_yy]`) at `xi` of `e`.
#[inline]
pub fn gradient_field_at(mesh: &Mesh, g: &[[f64; 4]], e: usize, xi: [f64; 2]) -> VelocityGradient {
    let psi = q1(xi).0;
    let v = &mesh.element_vertices[e];
    let mut out = [0.0; 4];
    for a in 0..4 {
        for ij in 0..4 {
            out[ij] += psi[a] * g[v[a]][ij];
        }
    }
    VelocityGradient::new(out[0], out[1], out[2], out[3])
}

/// Velocity gradient `L_ij = ∂u_i/∂x_j` of the Q2 velocity field at `xi` of element `e`.
#[inline]
pub fn velocity_gradient_at(
    mesh: &Mesh,
    u: &[[f64; 2]],
    e: usize,
    xi: [f64; 2],
) -> VelocityGradient {
    let (_, jac, det) = q2_map(&mesh.element_coords[e], xi);
    let mut dn = [[0.0; 2]; 9];
    physical_gradients(&jac, det, &q2(xi).1, &mut dn);
    gradient_of(&dn, u, &mesh.elements[e])
}

/// `L_ij = Σ_a ∂N_a/∂x_j u_i(node a)` from the physical gradients `dn` of an element's Q2
/// functions at a point.
#[inline]
fn gradient_of(dn: &[[f64; 2]; 9], u: &[[f64; 2]], nodes: &[usize]) -> VelocityGradient {
    let mut l = [[0.0; 2]; 2];
    for a in 0..9 {
        for i in 0..2 {
            for j in 0..2 {
                l[i][j] += dn[a][j] * u[nodes[a]][i];
            }
        }
    }
    VelocityGradient::from_rows(l)
}

/// Mean `∫ f dΩ / |Ω|` over the fluid part of `mesh` of a function of (element, reference point).
pub fn fluid_mean<const N: usize>(
    mesh: &Mesh,
    cuts: &[ElementCut],
    f: impl Fn(usize, [f64; 2]) -> [f64; N],
) -> [f64; N] {
    let rule = gauss_quad(3);
    let full: Vec<([f64; 2], f64)> = rule.points.into_iter().zip(rule.weights).collect();
    let (mut int, mut area) = ([0.0; N], 0.0);
    for e in 0..mesh.n_elements() {
        let pts: &[([f64; 2], f64)] = match &cuts[e] {
            ElementCut::Inside => continue,
            ElementCut::Fluid => &full,
            ElementCut::Cut(c) => &c.vol,
        };
        for &(xi, w) in pts {
            let wq = w * q2_map(&mesh.element_coords[e], xi).2;
            let v = f(e, xi);
            for c in 0..N {
                int[c] += wq * v[c];
            }
            area += wq;
        }
    }
    int.map(|v| v / area)
}

/// L² projection onto Q1 over the fluid part, the mass matrix factored once per geometry.
pub struct Q1Projection {
    n_vertices: usize,
    matrix: SparseMatrix,
    fixed: Vec<Option<f64>>,
    solver: Option<DirectSolver>,
    factored: bool,
    rhs: Vec<Vec<f64>>,
    rule: Vec<([f64; 2], f64)>,
    /// Q1 shape values at the points of `rule`.
    rule_psi: Vec<[f64; 4]>,
    /// The element maps at the points of `rule` (for the mesh geometry in use; empty until the
    /// first projection and after [`geometry_changed`](Self::geometry_changed)).
    maps: RuleMaps,
    cuts: Vec<ElementCut>,
    ghost: Vec<GhostFace>,
    /// The faces the pattern of `matrix` holds.
    face_pattern: FacePattern,
}

/// Ghost-penalty factor of the projections: face coefficient γ h³, the scale of the mass
/// entries (see [`crate::solver::ghost`]). Keeps the values at vertices with a sliver of fluid a
/// smooth extension, which the temporary ALE map then interpolates at other points.
pub const PROJECTION_GHOST_PENALTY: f64 = 1e-4;

/// A point of the integrand on an uncut element: its index in the full rule and the element map
/// there (on cut elements the integrand gets `None` and works from ξ alone).
pub type FullPoint = Option<(usize, MapAt)>;

impl std::fmt::Debug for Q1Projection {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Q1Projection")
            .field("n_vertices", &self.n_vertices)
            .field("factored", &self.factored)
            .finish()
    }
}

impl Q1Projection {
    /// Q1 pattern of `mesh` (all elements), all elements fluid; the mass matrix is assembled and
    /// factored on the first projection.
    pub fn new(mesh: &Mesh) -> Self {
        let nv = mesh.n_vertices();
        let rule = gauss_quad(3);
        assert_eq!(rule.points.len(), RULE_POINTS, "3x3 Gauss");
        Self {
            n_vertices: nv,
            matrix: q1_pattern(nv, &mesh.element_vertices),
            fixed: vec![None; nv],
            solver: None,
            factored: false,
            rhs: Vec::new(),
            rule_psi: rule.points.iter().map(|&xi| q1(xi).0).collect(),
            maps: RuleMaps::default(),
            rule: rule.points.into_iter().zip(rule.weights).collect(),
            cuts: vec![ElementCut::Fluid; mesh.n_elements()],
            ghost: Vec::new(),
            face_pattern: FacePattern::default(),
        }
    }

    /// New element classification: the mass matrix is refactored on the next projection
    /// (vertices touching no fluid get the value 0).
    ///
    /// # Panics
    /// If `cuts.len()` differs from the number of elements.
    pub fn set_cuts(&mut self, mesh: &Mesh, cuts: Vec<ElementCut>) {
        assert_eq!(cuts.len(), mesh.n_elements(), "one ElementCut per element");
        self.fixed = inactive_vertices(mesh, &cuts);
        let ghost = ghost_faces(mesh, &cuts);
        // the faces couple vertices of neighbouring elements: a new pattern when they leave
        // those the last one was built for
        if let Some(matrix) = self.face_pattern.matrix_for(mesh, &ghost) {
            self.matrix = matrix;
            self.solver = None;
        }
        self.ghost = ghost;
        self.cuts = cuts;
        self.factored = false;
    }

    /// Marks the geometry as changed (moved mesh nodes): refactor on the next projection.
    pub fn geometry_changed(&mut self) {
        self.factored = false;
        self.maps = RuleMaps::default();
    }

    /// The element classification in use.
    pub fn cuts(&self) -> &[ElementCut] {
        &self.cuts
    }

    /// The uncut elements' maps at the rule's points, once per geometry.
    fn tabulate(&mut self, mesh: &Mesh) {
        if !self.maps.fits(mesh) {
            let points: Vec<[f64; 2]> = self.rule.iter().map(|&(xi, _)| xi).collect();
            self.maps = RuleMaps::of(mesh, &points);
        }
    }

    fn refresh(&mut self, mesh: &Mesh) -> Result<(), ConstitutiveError> {
        self.tabulate(mesh);
        self.matrix.zero();
        let mut scratch = vec![0.0; self.n_vertices];
        let mut kflat = [0.0; 16];
        for e in 0..mesh.n_elements() {
            kflat.fill(0.0);
            let mut add = |wq: f64, psi: &[f64; 4]| {
                for a in 0..4 {
                    for b in 0..4 {
                        kflat[4 * a + b] += wq * psi[a] * psi[b];
                    }
                }
            };
            match &self.cuts[e] {
                ElementCut::Inside => continue,
                ElementCut::Fluid => {
                    for ((map, psi), &(_, w)) in
                        self.maps.at(e).iter().zip(&self.rule_psi).zip(&self.rule)
                    {
                        add(w * map.2, psi);
                    }
                }
                ElementCut::Cut(c) => {
                    for &(xi, w) in &c.vol {
                        add(w * q2_map(&mesh.element_coords[e], xi).2, &q1(xi).0);
                    }
                }
            }
            self.matrix.scatter(
                &mesh.element_vertices[e],
                &kflat,
                &[0.0; 4],
                &mut scratch,
                &self.fixed,
            );
        }
        let mut kg = [0.0; 64];
        for face in &self.ghost {
            let h = ghost_face_matrix(mesh, face, &mut kg);
            let gamma = PROJECTION_GHOST_PENALTY * h * h * h;
            kg.iter_mut().for_each(|v| *v *= gamma);
            self.matrix.scatter(
                &face_vertices(mesh, face),
                &kg,
                &[0.0; 8],
                &mut scratch,
                &self.fixed,
            );
        }
        self.matrix.apply_constraints(&mut scratch, &self.fixed);
        let wrap = |source| ConstitutiveError::Solve {
            what: "Q1 projection",
            step: 0,
            source,
        };
        if self.solver.is_none() {
            let mut solver = DirectSolver::analyze(&self.matrix, SolverKind::Lblt).map_err(wrap)?;
            // a mass matrix (plus a ghost penalty): positive definite, so its LDLᵀ needs no pivots
            solver.set_pivoting(Pivoting::WhenNeeded);
            self.solver = Some(solver);
        }
        let solver = self.solver.as_mut().expect("analysed above");
        solver.factor(&self.matrix).map_err(wrap)?;
        self.factored = true;
        Ok(())
    }

    /// Projects `f(e, ξ, full) ∈ ℝᴺ` (evaluated at the quadrature points of the fluid part of
    /// element `e`; `full` is the point of the full rule on an uncut element, [`FullPoint`])
    /// onto Q1: `out[v]` are the nodal values.
    ///
    /// # Errors
    /// [`ConstitutiveError::Solve`] if the mass matrix cannot be factored.
    ///
    /// # Panics
    /// If `out.len()` or `mesh` do not match the topology given at construction.
    pub fn project<const N: usize>(
        &mut self,
        mesh: &Mesh,
        f: impl Fn(usize, [f64; 2], FullPoint) -> [f64; N],
        out: &mut [[f64; N]],
    ) -> Result<(), ConstitutiveError> {
        assert_eq!(mesh.n_vertices(), self.n_vertices, "mesh topology changed");
        assert_eq!(out.len(), self.n_vertices, "output size");
        if !self.factored {
            self.refresh(mesh)?;
        }
        self.rhs.resize_with(N, || vec![0.0; self.n_vertices]);
        self.rhs.iter_mut().for_each(|r| r.fill(0.0));
        for e in 0..mesh.n_elements() {
            let verts = &mesh.element_vertices[e];
            let (rhs, fixed) = (&mut self.rhs, &self.fixed);
            let mut add = |wq: f64, psi: &[f64; 4], val: [f64; N]| {
                for a in 0..4 {
                    if fixed[verts[a]].is_none() {
                        for c in 0..N {
                            rhs[c][verts[a]] += wq * psi[a] * val[c];
                        }
                    }
                }
            };
            match &self.cuts[e] {
                ElementCut::Inside => continue,
                ElementCut::Fluid => {
                    for (q, ((map, psi), &(xi, w))) in self
                        .maps
                        .at(e)
                        .iter()
                        .zip(&self.rule_psi)
                        .zip(&self.rule)
                        .enumerate()
                    {
                        add(w * map.2, psi, f(e, xi, Some((q, *map))));
                    }
                }
                ElementCut::Cut(c) => {
                    for &(xi, w) in &c.vol {
                        let wq = w * q2_map(&mesh.element_coords[e], xi).2;
                        add(wq, &q1(xi).0, f(e, xi, None));
                    }
                }
            }
        }
        let solver = self.solver.as_mut().expect("factored above");
        for c in 0..N {
            let r = &mut self.rhs[c];
            for (v, fx) in self.fixed.iter().enumerate() {
                if let Some(val) = fx {
                    r[v] = *val;
                }
            }
            solver
                .solve_in_place(r)
                .map_err(|source| ConstitutiveError::Solve {
                    what: "Q1 projection",
                    step: 0,
                    source,
                })?;
            for (o, x) in out.iter_mut().zip(r.iter()) {
                o[c] = *x;
            }
        }
        Ok(())
    }

    /// `c = Π exp(s)` (Eq. 5.28): the L² projection of the conformation of a Q1 log-conformation.
    ///
    /// # Errors
    /// As [`project`](Self::project).
    pub fn project_conformation(
        &mut self,
        mesh: &Mesh,
        s: &[Sym2],
        out: &mut [Sym2],
    ) -> Result<(), ConstitutiveError> {
        let mut buf = vec![[0.0; 3]; self.n_vertices];
        let psi = self.rule_psi.clone();
        self.project(
            mesh,
            |e, xi, full| {
                let c = match full {
                    // q1(ξ) tabulated at the full rule's points
                    Some((q, _)) => {
                        let v = &mesh.element_vertices[e];
                        (0..4).fold(Sym2::ZERO, |acc, a| acc + psi[q][a] * s[v[a]])
                    }
                    None => sym_at(mesh, s, e, xi),
                }
                .exp();
                [c.xx, c.xy, c.yy]
            },
            &mut buf,
        )?;
        for (o, b) in out.iter_mut().zip(&buf) {
            *o = Sym2::new(b[0], b[1], b[2]);
        }
        Ok(())
    }

    /// `G = Π L(u)`: the Q1 projection of the gradient of a Q2 velocity (decoupled DEVSS-G).
    ///
    /// # Errors
    /// As [`project`](Self::project).
    pub fn project_velocity_gradient(
        &mut self,
        mesh: &Mesh,
        u: &[[f64; 2]],
        out: &mut [[f64; 4]],
    ) -> Result<(), ConstitutiveError> {
        let dq2: Vec<[[f64; 2]; 9]> = self.rule.iter().map(|&(xi, _)| q2(xi).1).collect();
        self.project(
            mesh,
            |e, xi, full| {
                let l = match full {
                    // the reference gradients and the map tabulated at the full rule's points
                    Some((q, (_, jac, det))) => {
                        let mut dn = [[0.0; 2]; 9];
                        physical_gradients(&jac, det, &dq2[q], &mut dn);
                        gradient_of(&dn, u, &mesh.elements[e])
                    }
                    None => velocity_gradient_at(mesh, u, e, xi),
                };
                [l.dudx, l.dudy, l.dvdx, l.dvdy]
            },
            out,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::Axis;

    /// A direct solve with a well-conditioned mass matrix: a few hundred ulps.
    const SOLVE_TOL: f64 = 1e-12;

    fn mesh(n: usize) -> Mesh {
        Mesh::rectangle(
            Axis::uniform(0.0, 1.0, 2 * n),
            Axis::graded(0.0, 0.5, n, 0.25, 1.0),
            true,
        )
    }

    #[test]
    fn projection_reproduces_q1_fields_and_gradients_of_quadratic_velocity() {
        // f = 1 + 2y (bilinear and periodic in x) is in Q1; u = (y², 0) has L = [[0, 2y], [0, 0]]
        let m = mesh(4);
        let mut p = Q1Projection::new(&m);
        let mut out = vec![[0.0; 1]; m.n_vertices()];
        p.project(
            &m,
            |e, xi, _| [1.0 + 2.0 * q2_map(&m.element_coords[e], xi).0[1]],
            &mut out,
        )
        .unwrap();
        for (v, o) in out.iter().enumerate() {
            let y = m.nodes[m.node_of_vertex[v]][1];
            assert!((o[0] - 1.0 - 2.0 * y).abs() < SOLVE_TOL);
        }
        let u: Vec<[f64; 2]> = m.nodes.iter().map(|x| [x[1] * x[1], 0.0]).collect();
        let mut g = vec![[0.0; 4]; m.n_vertices()];
        p.project_velocity_gradient(&m, &u, &mut g).unwrap();
        for (v, gv) in g.iter().enumerate() {
            let y = m.nodes[m.node_of_vertex[v]][1];
            assert!((gv[1] - 2.0 * y).abs() < SOLVE_TOL, "{gv:?} at y = {y}");
            assert!(gv[0].abs() + gv[2].abs() + gv[3].abs() < SOLVE_TOL);
        }
    }

    #[test]
    fn conformation_projection_preserves_the_mean_and_converges_at_second_order() {
        // s = [[sin 2πx, 0.3 y, 0], …]: the projection error of exp(s) at the vertices is O(h²);
        // the mean of Π exp(s) equals the mean of exp(s_h) (constants are test functions).
        const MEAN_TOL: f64 = 1e-12;
        let mut errs = Vec::new();
        for n in [4, 8, 16] {
            let m = mesh(n);
            let s: Vec<Sym2> = m
                .node_of_vertex
                .iter()
                .map(|&k| {
                    let x = m.nodes[k];
                    Sym2::new((2.0 * std::f64::consts::PI * x[0]).sin(), 0.3 * x[1], 0.0)
                })
                .collect();
            let mut c = vec![Sym2::ZERO; m.n_vertices()];
            let mut p = Q1Projection::new(&m);
            p.project_conformation(&m, &s, &mut c).unwrap();
            let cuts = vec![ElementCut::Fluid; m.n_elements()];
            let mean_c = fluid_mean(&m, &cuts, |e, xi| [sym_at(&m, &c, e, xi).xx]);
            let mean_exp = fluid_mean(&m, &cuts, |e, xi| [sym_at(&m, &s, e, xi).exp().xx]);
            assert!((mean_c[0] - mean_exp[0]).abs() < MEAN_TOL);
            let worst = s
                .iter()
                .zip(&c)
                .map(|(sv, cv)| (sv.exp() - *cv).norm())
                .fold(0.0, f64::max);
            errs.push(worst);
        }
        let rate1 = (errs[0] / errs[1]).log2();
        let rate2 = (errs[1] / errs[2]).log2();
        // nodal error of an L² projection of a smooth function: O(h²) (±0.15, STYLE §8)
        assert!((rate2 - 2.0).abs() < 0.15 && rate1 > 1.7, "{errs:?}");
    }
}
