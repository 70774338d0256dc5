//! Stokes flow with Taylor–Hood Q2/Q1 elements and the optional DEVSS-G projection (thesis Eqs.
//! 2.13, 2.14, 2.16 without polymer stress and particles), assembled as one symmetric system.
//!
//! Weak form, with L(u)_{ij} = ∂u_i/∂x_j the velocity gradient and G its Q1 projection:
//!
//! ```text
//!   (2η D(u), D(v)) + θ (L(u) − G, L(v)) − (∇·v, p) = (f, v)        ∀ v   (2.13)
//!   −(q, ∇·u)                                        = 0             ∀ q   (2.14)
//!   −θ (H, L(u) − G)                                 = 0             ∀ H   (2.16, scaled by −θ)
//! ```
//!
//! Scaling the projection equation by −θ makes the block matrix symmetric,
//! `[[A, −θCᵀ, Bᵀ], [−θC, θM, 0], [B, 0, 0]]`, and its (u, G) block positive semi-definite
//! (`uᵀAu − 2θ Gᵀ C u + θ Gᵀ M G = ‖2η^{1/2} D(u)‖² + θ ‖L(u) − G‖²`), so the symmetric indefinite
//! LBLᵀ factorization applies. θ = 0 drops G altogether (plain Stokes).
//! Dirichlet velocities are eliminated symmetrically; for enclosed flows the pressure is pinned
//! at one vertex and shifted to zero mean afterwards.

use std::collections::HashMap;
use std::time::Instant;

use crate::fem::element::{physical_gradients, q1, q2, q2_map};
use crate::fem::linsolve::{DirectSolver, DofBlocks, SolveError, SolverKind};
use crate::fem::quadrature::{gauss_quad, QuadRule};
use crate::fem::sparse::{PatternBuilder, SparseMatrix};
use crate::mesh::{bounding_box, Mesh, Shape, Side};
use crate::solver::ghost::{faces_where, ghost_faces, ghost_patch_matrices};
use crate::solver::polymer_terms::{boundary_terms, volume_terms, PolymerStress};
use crate::solver::rigid::{
    jump_vectors, weak_rigid_kernel, CutElement, ElementCut, Motion, Particle, WeakForm,
};

/// Physical and numerical parameters of a Stokes solve.
#[derive(Debug, Clone, Copy)]
pub struct StokesParams {
    /// Viscosity η of the 2η D(u) term (the solvent viscosity in viscoelastic flow).
    pub eta: f64,
    /// DEVSS-G parameter θ (the polymer viscosity in viscoelastic flow); 0 = no G unknowns.
    pub theta: f64,
    /// Linear solver.
    pub solver: SolverKind,
    /// Form of the weak rigid-body condition on particles.
    pub rigid_form: WeakForm,
    /// Stabilization parameter κ of the weak rigid-body condition (thesis: κ = η0).
    pub kappa: f64,
    /// With θ > 0: G as coupled unknowns (true) or supplied explicitly by the caller through
    /// [`PolymerStress`] as −θGⁿ (false; the flow matrix then has no G block).
    pub coupled_g: bool,
    /// Patch ghost penalty of velocity and pressure on the faces of cut elements
    /// ([`ghost_patch_matrices`]): velocity γ (η + θ)/h², pressure −γ/(η + θ); 0 = none.
    pub ghost_penalty: f64,
}

impl StokesParams {
    /// Parameters with viscosity `eta`, DEVSS-G `theta`, the given solver, and the weak rigid-body
    /// condition in its symmetric form with κ = η + θ (= η0).
    pub fn new(eta: f64, theta: f64, solver: SolverKind) -> Self {
        Self {
            eta,
            theta,
            solver,
            rigid_form: WeakForm::Symmetric,
            kappa: eta + theta,
            coupled_g: true,
            ghost_penalty: FLOW_GHOST_PENALTY,
        }
    }
}

/// Numbering of the unknowns: velocity (2 per Q2 node), pressure (1 per Q1 vertex), then G
/// (4 per Q1 vertex, components G_xx, G_xy, G_yx, G_yy) when θ > 0.
#[derive(Debug, Clone, Copy)]
pub struct Layout {
    /// Number of Q2 nodes.
    pub n_nodes: usize,
    /// Number of Q1 vertices.
    pub n_vertices: usize,
    /// Whether G unknowns exist.
    pub with_g: bool,
    /// Number of particles (3 rigid unknowns each: U_x, U_y, ω).
    pub n_particles: usize,
}

impl Layout {
    /// Velocity component `c` at node `k`.
    #[inline]
    pub fn u(&self, k: usize, c: usize) -> usize {
        2 * k + c
    }
    /// Pressure at vertex `v`.
    #[inline]
    pub fn p(&self, v: usize) -> usize {
        2 * self.n_nodes + v
    }
    /// G component `ij = 2i + j` at vertex `v`.
    #[inline]
    pub fn g(&self, v: usize, ij: usize) -> usize {
        2 * self.n_nodes + self.n_vertices + 4 * v + ij
    }
    /// Rigid unknown `c` (0: U_x, 1: U_y, 2: ω) of particle `i`.
    #[inline]
    pub fn rigid(&self, i: usize, c: usize) -> usize {
        self.n_field_dofs() + 3 * i + c
    }
    /// Number of field unknowns (velocity, pressure, G).
    pub fn n_field_dofs(&self) -> usize {
        2 * self.n_nodes + self.n_vertices + if self.with_g { 4 * self.n_vertices } else { 0 }
    }
    /// Total number of unknowns.
    pub fn n_dofs(&self) -> usize {
        self.n_field_dofs() + 3 * self.n_particles
    }
}

/// Wall-clock seconds spent in the phases of the last solve.
#[derive(Debug, Clone, Copy, Default)]
pub struct Timings {
    /// Element loop and scatter.
    pub assembly: f64,
    /// Symbolic analysis (only on the first solve).
    pub symbolic: f64,
    /// Numeric factorization.
    pub numeric: f64,
    /// Triangular solves and residual check.
    pub solve: f64,
}

/// A Stokes solution in nodal form.
#[derive(Debug, Clone)]
pub struct StokesSolution {
    /// Velocity at each Q2 node.
    pub u: Vec<[f64; 2]>,
    /// Pressure at each Q1 vertex (zero mean for enclosed flows).
    pub p: Vec<f64>,
    /// Projected velocity gradient at each Q1 vertex (when θ > 0), `[G_xx, G_xy, G_yx, G_yy]`.
    pub g: Option<Vec<[f64; 4]>>,
    /// Rigid velocities (U_x, U_y, ω) of the particles.
    pub rigid: Vec<[f64; 3]>,
    /// Hydrodynamic force and torque (F_x, F_y, T) on each particle from the weak-condition
    /// reaction (consistent with the discrete momentum balance; ≈ 0 for free particles).
    pub reaction: Vec<[f64; 3]>,
    /// The same from the stress integral −∫ σ(u_h, p_h)·n ds over the particle boundary.
    pub stress_force: Vec<[f64; 3]>,
    /// Relative residual of the linear solve.
    pub residual: f64,
}

/// How far beyond its boundary, in sizes of the element concerned, a particle's rigid-body
/// unknowns are coupled in the matrix pattern. A particle can move about this far before an
/// element it cuts lies outside the coupled set and the pattern and its symbolic factorization
/// must be rebuilt; the unused couplings store zeros.
const RIGID_REACH: f64 = 2.0;

/// Default patch ghost-penalty coefficient of the flow ([`StokesParams::ghost_penalty`]). Chosen
/// by measurement (docs/validation.md): 0.001 removes the sliver velocities (|u| ≤ wall speed,
/// point symmetry to 1e-8) and perturbs the free Couette particle's ω by 3e-4 on 64×12; 0.01
/// perturbs it by 3e-3 and 0.1 moves the confined-cylinder drag by 5e-4 at h = 0.2R.
pub const FLOW_GHOST_PENALTY: f64 = 0.001;

/// Per particle, the elements whose velocity and pressure the pattern couples to its rigid-body
/// unknowns: bounding box within the radius plus [`RIGID_REACH`] element sizes of the centre
/// (nearest periodic image on a periodic rectangle).
fn rigid_reach(mesh: &Mesh, particles: &[Particle]) -> Vec<Vec<bool>> {
    let period = (mesh.periodic && mesh.shape == Shape::Rectangle)
        .then(|| mesh.ax.vertices[mesh.ax.len()] - mesh.ax.vertices[0]);
    particles
        .iter()
        .map(|p| {
            mesh.element_coords
                .iter()
                .map(|xe| {
                    let (lo, hi) = bounding_box(xe);
                    let size = (hi[0] - lo[0]).max(hi[1] - lo[1]);
                    let mut c = p.center;
                    if let Some(l) = period {
                        let mid = 0.5 * (lo[0] + hi[0]);
                        c[0] -= l * ((c[0] - mid) / l).round();
                    }
                    let q = [c[0].clamp(lo[0], hi[0]), c[1].clamp(lo[1], hi[1])];
                    (q[0] - c[0]).hypot(q[1] - c[1]) <= p.radius + RIGID_REACH * size
                })
                .collect()
        })
        .collect()
}

/// [`rigid_reach`] of the particles, or every element for every particle if that does not cover
/// `cuts` (cuts not of these positions: a caller's choice).
fn reach_for(mesh: &Mesh, particles: &[Particle], cuts: &[ElementCut]) -> Vec<Vec<bool>> {
    let reach = rigid_reach(mesh, particles);
    if reach_covers(&reach, cuts) {
        reach
    } else {
        vec![vec![true; mesh.n_elements()]; particles.len()]
    }
}

/// Whether every cut element's particles are coupled to it in the pattern.
fn reach_covers(reach: &[Vec<bool>], cuts: &[ElementCut]) -> bool {
    cuts.iter().enumerate().all(|(e, c)| match c {
        ElementCut::Cut(c) => c.particles.iter().all(|pc| reach[pc.particle][e]),
        _ => true,
    })
}

/// Whether the pattern couples the two elements of the face between `e` and `o` for the ghost
/// penalty: faces next to an element in a particle's reach (only those can be cut while the
/// pattern lasts). The pattern and the nested-dissection ordering must agree on this.
fn patched_face(reach: &[Vec<bool>], e: usize, o: usize) -> bool {
    reach.iter().any(|r| r[e] || r[o])
}

/// The sparsity pattern of the flow matrix: every element (also those inside particles, which
/// store zeros next to identity rows, so that a particle crossing the mesh does not change the
/// pattern) and the rigid-body couplings of the elements in each particle's reach.
fn build_pattern(mesh: &Mesh, layout: &Layout, reach: &[Vec<bool>]) -> SparseMatrix {
    let mut pb = PatternBuilder::new(layout.n_dofs());
    let mut dofs = Vec::with_capacity(MAX_EL_DOFS);
    let (mut g_ij, mut u_i) = (Vec::with_capacity(4), Vec::with_capacity(9));
    let mut group = Vec::with_capacity(25);
    for e in 0..mesh.n_elements() {
        element_dofs(mesh, layout, e, &mut dofs);
        for (i, r) in reach.iter().enumerate() {
            if r[e] {
                group.clear();
                group.extend_from_slice(&dofs[..22]);
                group.extend((0..3).map(|c| layout.rigid(i, c)));
                pb.add_group(&group);
            }
        }
        // velocity and pressure couple fully; each G_ij only with itself and u_i (a third of
        // the entries a full element block would store)
        pb.add_group(&dofs[..22]);
        if layout.with_g {
            for ij in 0..4 {
                g_ij.clear();
                g_ij.extend(mesh.element_vertices[e].iter().map(|&v| layout.g(v, ij)));
                u_i.clear();
                u_i.extend(mesh.elements[e].iter().map(|&k| layout.u(k, ij / 2)));
                pb.add_group(&g_ij);
                pb.add_coupling(&g_ij, &u_i);
            }
        }
    }
    for face in faces_where(mesh, |e, o| patched_face(reach, e, o)) {
        group.clear();
        for e in [face.first, face.second] {
            element_dofs(mesh, layout, e, &mut dofs);
            group.extend_from_slice(&dofs[..22]);
        }
        group.sort_unstable();
        group.dedup();
        pb.add_group(&group);
        if layout.with_g {
            for ij in 0..4 {
                g_ij.clear();
                for e in [face.first, face.second] {
                    g_ij.extend(mesh.element_vertices[e].iter().map(|&v| layout.g(v, ij)));
                }
                g_ij.sort_unstable();
                g_ij.dedup();
                pb.add_group(&g_ij);
            }
        }
    }
    // a particle's three rigid unknowns couple with each other even outside any cut
    for i in 0..layout.n_particles {
        pb.add_group(&[layout.rigid(i, 0), layout.rigid(i, 1), layout.rigid(i, 2)]);
    }
    pb.build()
}

/// Maximum dofs of one element: 18 velocity + 4 pressure + 16 G + 3 rigid for up to 4 particle pieces.
const MAX_EL_DOFS: usize = 50;
/// Relative residual accepted from the direct solver (a few hundred ulps of the matrix norm).
const RESIDUAL_TOL: f64 = 1e-10;

/// Largest lattice region (in Q2 nodes) the nested-dissection ordering keeps in natural order.
const ND_LEAF: usize = 4;

/// Margin, in elements along each index direction, by which [`Stokes::set_mesh`] widens the
/// elements whose coordinates changed when it adds them to the moving-element mask (elements
/// assembled every step, outside the cached fluid base). A grading that travels with the
/// particles changes a band of columns and rows that moves with them by a fraction of an
/// element per time step: with the margin the band travels about this many elements before a
/// changed element falls outside the mask and the base must be rebuilt (one assembly of the
/// fluid elements) instead of at every step. The price is 2 × 4 more columns (and rows) of
/// elements assembled every step — 4 % of a 200×50 channel per column band — cheap beside the
/// numeric factorization that a moved mesh needs at every step anyway.
const MOVING_MARGIN: usize = 4;

/// A wall velocity x ↦ u(x) of [`Stokes::set_velocity`], kept to re-evaluate it on a moved mesh.
type WallVelocity = Box<dyn Fn([f64; 2]) -> [f64; 2] + Send + Sync>;

/// Whether element `e`'s matrix is assembled every step rather than cached in the fluid base:
/// it lies in some particle's reach (it may be cut while the pattern lasts) or in the
/// moving-element mask (its coordinates may change).
fn assembled_each_step(reach: &[Vec<bool>], moving: &[bool], e: usize) -> bool {
    moving[e] || reach.iter().any(|r| r[e])
}

/// The elements of `marked` (numbered `ey·nx + ex`, `dims` = (nx, ny)) widened by `margin`
/// elements along each index direction (a box), wrapping around a periodic first direction.
fn dilate(marked: &[bool], (nx, ny): (usize, usize), periodic: bool, margin: usize) -> Vec<bool> {
    let m = margin as isize;
    let mut wide = vec![false; nx * ny];
    for e in (0..nx * ny).filter(|&e| marked[e]) {
        let (ex, ey) = ((e % nx) as isize, e / nx);
        for d in -m..=m {
            let x = ex + d;
            let x = if periodic {
                x.rem_euclid(nx as isize)
            } else if (0..nx as isize).contains(&x) {
                x
            } else {
                continue;
            };
            wide[ey * nx + x as usize] = true;
        }
    }
    let mut out = vec![false; nx * ny];
    for e in (0..nx * ny).filter(|&e| wide[e]) {
        let (ex, ey) = (e % nx, (e / nx) as isize);
        for y in (ey - m).max(0)..=(ey + m).min(ny as isize - 1) {
            out[y as usize * nx + ex] = true;
        }
    }
    out
}

/// Appends the (dof, value) pairs of the velocity `f` at the nodes of `side`.
fn push_wall_values(
    mesh: &Mesh,
    layout: &Layout,
    side: Side,
    f: &dyn Fn([f64; 2]) -> [f64; 2],
    out: &mut Vec<(usize, f64)>,
) {
    for k in mesh.side_nodes(side) {
        let v = f(mesh.nodes[k]);
        for (c, vc) in v.iter().enumerate() {
            out.push((layout.u(k, c), *vc));
        }
    }
}

/// A reusable Stokes solver on a mesh of fixed topology: the pattern and the symbolic
/// factorization are built once; each [`solve`](Self::solve) assembles, refactors numerically and
/// solves. The mesh's vertex columns and rows may move ([`set_mesh`](Self::set_mesh)).
pub struct Stokes {
    /// The mesh.
    pub mesh: Mesh,
    /// Parameters.
    pub params: StokesParams,
    /// Unknown numbering.
    pub layout: Layout,
    matrix: SparseMatrix,
    rhs: Vec<f64>,
    sol: Vec<f64>,
    fixed: Vec<Option<f64>>,
    /// Wall velocities (dof, value) set by [`set_velocity`](Self::set_velocity), kept when
    /// the particles move.
    wall_values: Vec<(usize, f64)>,
    /// The wall velocities as given, in call order, re-evaluated on a moved mesh.
    walls: Vec<(Side, WallVelocity)>,
    pressure_pinned: bool,
    solver: Option<DirectSolver>,
    factored_values: Option<Vec<f64>>,
    /// Numeric factorizations done so far (a solve reuses the last one when the matrix is
    /// unchanged).
    pub refactorizations: usize,
    /// Pattern (and symbolic analysis) rebuilds caused by [`set_particles`](Self::set_particles).
    pub pattern_rebuilds: usize,
    /// Invalidations of the cached fluid base matrix by [`set_mesh`](Self::set_mesh) (an element
    /// outside the moving-element mask moved); the base is rebuilt at the next solve.
    pub base_rebuilds: usize,
    rule: QuadRule,
    particles: Vec<Particle>,
    cuts: Vec<ElementCut>,
    /// Per particle, the elements coupled to its rigid-body unknowns in the pattern.
    reach: Vec<Vec<bool>>,
    /// Matrix values of the elements outside every particle's reach (fluid while the pattern
    /// lasts) and outside `moving`, without stress or constraints, and the (η, θ) they were
    /// built with: with no stress in the matrix (explicit coupling) a step starts from them and
    /// assembles the matrix of the elements in reach or in `moving` only. (Subtracting cut
    /// elements from an all-fluid base instead lost the relative accuracy of the tiny entries of
    /// sliver rows to cancellation; for the same reason a moved element is never subtracted and
    /// re-added, the base is rebuilt without it.)
    fluid_base: Option<(Vec<f64>, f64, f64)>,
    /// Per element, whether its coordinates may change ([`set_mesh`](Self::set_mesh)): such
    /// elements are left out of the fluid base and assembled every step.
    moving: Vec<bool>,
    /// Fluid element matrices of axis-parallel rectangles by their sides (the matrix of such an
    /// element depends on them only), for the elements assembled every step, with the (η, θ)
    /// they were built with: the columns of a mesh that follows the particles have one width
    /// each, so a step computes one matrix per column and row size instead of per element.
    rectangles: RectangleMatrices,
    /// All dofs unconstrained (assembly before the elimination of constraints).
    unconstrained: Vec<Option<f64>>,
    /// Timings of the last solve.
    pub timings: Timings,
}

impl Stokes {
    /// Builds the unknown numbering and the sparsity pattern on `mesh` (no particles).
    pub fn new(mesh: Mesh, params: StokesParams) -> Self {
        let cuts = vec![ElementCut::Fluid; mesh.n_elements()];
        Self::with_particles(mesh, params, Vec::new(), cuts)
    }

    /// Builds the solver for a mesh cut by particles: `cuts[e]` says whether element `e` is fluid,
    /// inside a particle or cut (with its fluid-part and boundary quadrature). Dofs of nodes that
    /// touch no fluid become identity rows; prescribed particle motions are eliminated.
    ///
    /// # Panics
    /// Panics if `cuts.len()` differs from the number of elements.
    pub fn with_particles(
        mesh: Mesh,
        params: StokesParams,
        particles: Vec<Particle>,
        cuts: Vec<ElementCut>,
    ) -> Self {
        assert_eq!(cuts.len(), mesh.n_elements(), "one ElementCut per element");
        let layout = Layout {
            n_nodes: mesh.n_nodes(),
            n_vertices: mesh.n_vertices(),
            with_g: params.theta > 0.0 && params.coupled_g,
            n_particles: particles.len(),
        };
        let reach = reach_for(&mesh, &particles, &cuts);
        let matrix = build_pattern(&mesh, &layout, &reach);
        let n = layout.n_dofs();
        let n_elements = mesh.n_elements();
        let mut st = Self {
            mesh,
            params,
            layout,
            matrix,
            rhs: vec![0.0; n],
            sol: vec![0.0; n],
            fixed: Vec::new(),
            wall_values: Vec::new(),
            walls: Vec::new(),
            pressure_pinned: false,
            solver: None,
            factored_values: None,
            refactorizations: 0,
            pattern_rebuilds: 0,
            base_rebuilds: 0,
            rule: gauss_quad(3),
            particles,
            cuts,
            reach,
            fluid_base: None,
            moving: vec![false; n_elements],
            rectangles: (0.0, 0.0, HashMap::new()),
            unconstrained: vec![None; n],
            timings: Timings::default(),
        };
        st.fixed = st.geometric_constraints();
        st
    }

    /// Moves the particles (same number, new centres and motions) and cuts: the pattern and the
    /// symbolic factorization are kept while every cut element lies in its particles' reach
    /// (about two element sizes of travel) and rebuilt around the new positions
    /// otherwise. Wall velocities and the pressure pin are kept. After
    /// [`set_mesh`](Self::set_mesh), `cuts` are those of the new mesh.
    ///
    /// # Panics
    /// Panics if the number of particles or of cuts changes.
    pub fn set_particles(&mut self, particles: Vec<Particle>, cuts: Vec<ElementCut>) {
        assert_eq!(particles.len(), self.particles.len(), "same particles");
        assert_eq!(
            cuts.len(),
            self.mesh.n_elements(),
            "one ElementCut per element"
        );
        self.particles = particles;
        self.cuts = cuts;
        if !reach_covers(&self.reach, &self.cuts) {
            self.reach = reach_for(&self.mesh, &self.particles, &self.cuts);
            self.matrix = build_pattern(&self.mesh, &self.layout, &self.reach);
            self.solver = None;
            self.fluid_base = None;
            self.pattern_rebuilds += 1;
        }
        self.factored_values = None;
        self.reset_constraints();
    }

    /// Moves the mesh's vertex columns and rows: `mesh` has this mesh's topology (shape, element
    /// counts, periodicity and period; typically `self.mesh.with_axes(ax, ay)`), only its
    /// coordinates differ. The pattern, the particles' reach and the symbolic factorization are
    /// kept (they depend on the topology only); the numeric factorization is redone, the wall
    /// velocities of [`set_velocity`](Self::set_velocity) are evaluated at the new node
    /// coordinates and the pressure pin is kept.
    ///
    /// Elements whose coordinates changed (exact comparison) must lie in a mask of elements
    /// assembled every step; the cached matrix of the elements outside it and outside the
    /// particles' reach is kept while they do. Otherwise the mask becomes the changed elements
    /// widened by a few elements (`MOVING_MARGIN`, 4) and that matrix is rebuilt at the next
    /// solve.
    ///
    /// The cuts are not recomputed: with particles, call [`set_particles`](Self::set_particles)
    /// next, with cuts computed on the new mesh, before solving.
    ///
    /// # Panics
    /// Panics if the shape, the element counts, the periodicity or the period differ.
    pub fn set_mesh(&mut self, mesh: Mesh) {
        let old = &self.mesh;
        assert!(
            mesh.shape == old.shape && mesh.periodic == old.periodic && mesh.dims() == old.dims(),
            "Stokes::set_mesh: another topology"
        );
        let span = |m: &Mesh| m.ax.vertices[m.ax.len()] - m.ax.vertices[0];
        assert!(
            !mesh.periodic || (span(&mesh) - span(old)).abs() <= 1e-12 * span(old),
            "Stokes::set_mesh: another period"
        );
        debug_assert!(
            mesh.elements == old.elements && mesh.element_vertices == old.element_vertices
        );
        let changed: Vec<bool> = (mesh.element_coords.iter().zip(&old.element_coords))
            .map(|(a, b)| a != b)
            .collect();
        if changed.iter().zip(&self.moving).any(|(&c, &m)| c && !m) {
            // the base is rebuilt from the current coordinates: the mask need only hold the band
            // that moves now (a mask that only grew would empty the base of a particle that
            // travels along the channel)
            self.moving = dilate(&changed, mesh.dims(), mesh.periodic, MOVING_MARGIN);
            self.fluid_base = None;
            self.base_rebuilds += 1;
        }
        self.mesh = mesh;
        self.factored_values = None;
        self.wall_values.clear();
        for (side, f) in &self.walls {
            push_wall_values(&self.mesh, &self.layout, *side, f, &mut self.wall_values);
        }
        self.reset_constraints();
    }

    /// The constraints of the current cuts, particle motions, wall velocities and pressure pin.
    fn reset_constraints(&mut self) {
        self.fixed = self.geometric_constraints();
        for &(dof, v) in &self.wall_values {
            self.fixed[dof] = Some(v);
        }
        if self.pressure_pinned {
            self.pin_pressure();
        }
    }

    /// Identity rows of the nodes touching no fluid and the prescribed particle motions.
    fn geometric_constraints(&self) -> Vec<Option<f64>> {
        let (mesh, layout) = (&self.mesh, &self.layout);
        let mut fixed = vec![None; layout.n_dofs()];
        let mut active = vec![false; layout.n_nodes];
        for (e, cut) in self.cuts.iter().enumerate() {
            if !matches!(cut, ElementCut::Inside) {
                mesh.elements[e].iter().for_each(|&k| active[k] = true);
            }
        }
        for k in 0..layout.n_nodes {
            if !active[k] {
                fixed[layout.u(k, 0)] = Some(0.0);
                fixed[layout.u(k, 1)] = Some(0.0);
                if let Some(v) = mesh.vertex_of_node[k] {
                    fixed[layout.p(v)] = Some(0.0);
                    if layout.with_g {
                        (0..4).for_each(|ij| fixed[layout.g(v, ij)] = Some(0.0));
                    }
                }
            }
        }
        for (i, p) in self.particles.iter().enumerate() {
            if let Motion::Prescribed { u, omega } = p.motion {
                fixed[layout.rigid(i, 0)] = Some(u[0]);
                fixed[layout.rigid(i, 1)] = Some(u[1]);
                fixed[layout.rigid(i, 2)] = Some(omega);
            }
        }
        fixed
    }

    /// The particles.
    pub fn particles(&self) -> &[Particle] {
        &self.particles
    }

    /// Number of unknowns and of stored matrix entries.
    pub fn size(&self) -> (usize, usize) {
        (self.layout.n_dofs(), self.matrix.nnz())
    }

    /// Prescribes the velocity `f(x)` at all nodes of the given side (a later call wins at nodes
    /// shared by two sides). `f` is kept and re-evaluated when the mesh moves
    /// ([`set_mesh`](Self::set_mesh)).
    pub fn set_velocity(
        &mut self,
        side: Side,
        f: impl Fn([f64; 2]) -> [f64; 2] + Send + Sync + 'static,
    ) {
        let start = self.wall_values.len();
        push_wall_values(&self.mesh, &self.layout, side, &f, &mut self.wall_values);
        for &(dof, v) in &self.wall_values[start..] {
            self.fixed[dof] = Some(v);
        }
        self.walls.push((side, Box::new(f)));
    }

    /// Pins the pressure at vertex 0 (for flows with velocity prescribed on the whole boundary).
    pub fn pin_pressure(&mut self) {
        let v = (0..self.layout.n_vertices)
            .find(|&v| self.fixed[self.layout.p(v)].is_none())
            .expect("some pressure vertex touches the fluid");
        self.fixed[self.layout.p(v)] = Some(0.0);
        self.pressure_pinned = true;
    }

    /// Assembles with body force `f`, factorizes (symbolic analysis on the first call only) and
    /// solves.
    pub fn solve(
        &mut self,
        f: &dyn Fn([f64; 2]) -> [f64; 2],
    ) -> Result<StokesSolution, SolveError> {
        self.solve_with(f, None)
    }

    /// Like [`solve`](Self::solve), with a polymer stress in the momentum balance (volume and
    /// particle-boundary terms). An implicit stress needs the LU solver (non-symmetric matrix).
    pub fn solve_with(
        &mut self,
        f: &dyn Fn([f64; 2]) -> [f64; 2],
        stress: Option<&dyn PolymerStress>,
    ) -> Result<StokesSolution, SolveError> {
        if let Some(ps) = stress {
            assert!(
                !(ps.is_implicit() && self.params.solver == SolverKind::Lblt),
                "an implicit polymer stress makes the flow matrix non-symmetric: use SolverKind::Lu"
            );
        }
        let t0 = Instant::now();
        self.assemble(f, stress);
        let t1 = Instant::now();
        let mut symbolic = 0.0;
        if self.solver.is_none() {
            self.solver = Some(match self.params.solver {
                SolverKind::Lblt => DirectSolver::analyze_blocked(
                    &self.matrix,
                    SolverKind::Lblt,
                    &self.dof_blocks(),
                )?,
                SolverKind::Lu => DirectSolver::analyze(&self.matrix, SolverKind::Lu)?,
            });
            symbolic = t1.elapsed().as_secs_f64();
        }
        let t2 = Instant::now();
        let solver = self.solver.as_mut().expect("analysed above");
        // The matrix depends on the geometry, the constraints and an implicit stress only: when
        // its values are bitwise those of the last factorization (explicit stress coupling on a
        // fixed geometry) the factorization is reused and only the solve is paid.
        if self.factored_values.as_deref() != Some(self.matrix.values.as_slice()) {
            solver.factor(&self.matrix)?;
            self.factored_values = Some(self.matrix.values.clone());
            self.refactorizations += 1;
        }
        let t3 = Instant::now();
        let residual =
            solver.solve_checked(&self.matrix, &self.rhs, &mut self.sol, RESIDUAL_TOL)?;
        self.timings = Timings {
            assembly: (t1 - t0).as_secs_f64(),
            symbolic,
            numeric: (t3 - t2).as_secs_f64(),
            solve: t3.elapsed().as_secs_f64(),
        };
        Ok(self.extract(residual))
    }

    fn assemble(&mut self, f: &dyn Fn([f64; 2]) -> [f64; 2], stress: Option<&dyn PolymerStress>) {
        let lay = self.layout;
        let (eta, theta) = (self.params.eta, self.params.theta);
        let nd = 22 + if lay.with_g { 16 } else { 0 };
        // without stress in the matrix, fluid elements contribute the same every step
        let cached = stress.is_none_or(|ps| !ps.is_implicit());
        if cached {
            if self
                .fluid_base
                .as_ref()
                .is_none_or(|b| (b.1, b.2) != (eta, theta))
            {
                self.fluid_base = Some((self.fluid_values(), eta, theta));
            }
            let base = &self.fluid_base.as_ref().expect("built above").0;
            self.matrix.values.copy_from_slice(base);
        } else {
            self.matrix.zero();
        }
        self.rhs.iter_mut().for_each(|v| *v = 0.0);
        let rectangles = cached && self.mesh.shape == Shape::Rectangle;
        if rectangles
            && ((self.rectangles.0, self.rectangles.1) != (eta, theta)
                || self.rectangles.2.len() > RECTANGLE_CACHE_LEN)
        {
            self.rectangles = (eta, theta, HashMap::new());
        }
        let mut dofs = Vec::with_capacity(MAX_EL_DOFS);
        let mut ke = [0.0; MAX_EL_DOFS * MAX_EL_DOFS];
        let mut fe = [0.0; MAX_EL_DOFS];
        let tab = shape_table(&self.rule);
        let mut dn = [[0.0; 2]; 9];
        for e in 0..self.mesh.n_elements() {
            element_dofs(&self.mesh, &lay, e, &mut dofs);
            let xe = &self.mesh.element_coords[e];
            // outside every particle's reach an element is fluid while the pattern lasts and,
            // unless it may move, its matrix is in the base (built without the reach and the
            // moving elements: no cancellation on cut rows)
            let in_base = cached && !assembled_each_step(&self.reach, &self.moving, e);
            let cut = match &self.cuts[e] {
                ElementCut::Inside => continue,
                ElementCut::Fluid => None,
                ElementCut::Cut(c) => Some(c),
            };
            let ndc = nd + 3 * cut.map_or(0, |c| c.particles.len());
            assert!(
                ndc <= MAX_EL_DOFS,
                "element {e} is cut by more than 4 particle pieces"
            );
            let ke = &mut ke[..ndc * ndc];
            let fe = &mut fe[..ndc];
            ke.iter_mut().for_each(|v| *v = 0.0);
            fe.iter_mut().for_each(|v| *v = 0.0);
            // a fluid rectangle outside the base: its matrix from the sides, the loads below
            let by_sides = rectangles && cut.is_none() && !in_base;
            match cut {
                None if in_base || by_sides => {
                    // the matrix part is in the base or known from the sides: the loads only
                    for (q, ((n2, dref), _)) in tab.iter().enumerate() {
                        let (x, jac, det) = q2_map(xe, self.rule.points[q]);
                        let w = self.rule.weights[q] * det;
                        let force = f(x);
                        for a in 0..9 {
                            fe[2 * a] += w * n2[a] * force[0];
                            fe[2 * a + 1] += w * n2[a] * force[1];
                        }
                        if let Some(ps) = stress {
                            physical_gradients(&jac, det, dref, &mut dn);
                            let lin = ps.at(e, self.rule.points[q], x, false);
                            debug_assert!(lin.a.is_none() && lin.b_u.is_none());
                            volume_terms(ke, fe, ndc, w, n2, &dn, &lin);
                        }
                    }
                    if !by_sides {
                        for (a, &i) in dofs.iter().enumerate() {
                            self.rhs[i] += fe[a];
                        }
                        continue;
                    }
                    let (key, canonical) = canonical_rectangle(xe);
                    let m = self.rectangles.2.entry(key).or_insert_with(|| {
                        let mut m = vec![0.0; nd * nd];
                        let rule = &self.rule;
                        fluid_element_matrix(
                            &canonical, rule, &tab, eta, theta, lay.with_g, &mut m,
                        );
                        m.into_boxed_slice()
                    });
                    ke.copy_from_slice(m);
                }
                None => {
                    for (q, ((n2, dref), psi)) in tab.iter().enumerate() {
                        let (x, jac, det) = q2_map(xe, self.rule.points[q]);
                        let w = self.rule.weights[q] * det;
                        physical_gradients(&jac, det, dref, &mut dn);
                        stokes_kernel(ke, fe, ndc, w, eta, theta, n2, &dn, psi, f(x), lay.with_g);
                        if let Some(ps) = stress {
                            let lin = ps.at(e, self.rule.points[q], x, false);
                            volume_terms(ke, fe, ndc, w, n2, &dn, &lin);
                        }
                    }
                }
                Some(cut) => {
                    for &(xi, wref) in &cut.vol {
                        let (x, jac, det) = q2_map(xe, xi);
                        let (n2, dref) = q2(xi);
                        physical_gradients(&jac, det, &dref, &mut dn);
                        let psi = q1(xi).0;
                        stokes_kernel(
                            ke,
                            fe,
                            ndc,
                            wref * det,
                            eta,
                            theta,
                            &n2,
                            &dn,
                            &psi,
                            f(x),
                            lay.with_g,
                        );
                        if let Some(ps) = stress {
                            let lin = ps.at(e, xi, x, false);
                            volume_terms(ke, fe, ndc, wref * det, &n2, &dn, &lin);
                        }
                    }
                    for (slot, pc) in cut.particles.iter().enumerate() {
                        dofs.extend((0..3).map(|c| lay.rigid(pc.particle, c)));
                        let ce = CutElement {
                            xe,
                            vol: &cut.vol,
                            bnd: &pc.points,
                        };
                        let off = nd + 3 * slot;
                        weak_rigid_kernel(
                            ke,
                            ndc,
                            off,
                            &ce,
                            pc.center,
                            eta,
                            self.params.kappa,
                            self.params.rigid_form,
                        );
                        if let Some(ps) = stress {
                            for bp in &pc.points {
                                let (_, jac, det) = q2_map(xe, bp.xi);
                                let (n2, dref) = q2(bp.xi);
                                physical_gradients(&jac, det, &dref, &mut dn);
                                let r = [bp.x[0] - pc.center[0], bp.x[1] - pc.center[1]];
                                let jv = jump_vectors(&n2, r);
                                let lin = ps.at(e, bp.xi, bp.x, true);
                                boundary_terms(ke, fe, ndc, off, bp.w, &jv, &n2, &dn, bp.n, &lin);
                            }
                        }
                    }
                }
            }
            self.matrix
                .scatter(&dofs, ke, fe, &mut self.rhs, &self.unconstrained);
        }
        if self.params.ghost_penalty > 0.0 {
            self.assemble_ghost_penalty();
        }
        self.matrix
            .eliminate_constraints(&mut self.rhs, &self.fixed);
        self.matrix.apply_constraints(&mut self.rhs, &self.fixed);
    }

    /// Adds the patch ghost penalty of velocity and pressure on the faces of cut elements.
    fn assemble_ghost_penalty(&mut self) {
        let lay = self.layout;
        let visc = self.params.eta + self.params.theta;
        let (mut k2, mut k1) = ([0.0; 324], [0.0; 64]);
        const N: usize = 44;
        let mut ke = [0.0; N * N];
        let zero = [0.0; N];
        let mut dofs = [0usize; N];
        for face in ghost_faces(&self.mesh, &self.cuts) {
            let h = ghost_patch_matrices(&self.mesh, &face, &self.rule, &mut k2, &mut k1);
            let (gu, gp) = (
                self.params.ghost_penalty * visc / (h * h),
                -self.params.ghost_penalty / visc,
            );
            let (e1, e2) = (face.first, face.second);
            let nodes = [self.mesh.elements[e1], self.mesh.elements[e2]];
            let verts = [
                self.mesh.element_vertices[e1],
                self.mesh.element_vertices[e2],
            ];
            for a in 0..18 {
                let k = nodes[a / 9][a % 9];
                dofs[2 * a] = lay.u(k, 0);
                dofs[2 * a + 1] = lay.u(k, 1);
            }
            for a in 0..8 {
                dofs[36 + a] = lay.p(verts[a / 4][a % 4]);
            }
            ke.fill(0.0);
            for a in 0..18 {
                for b in 0..18 {
                    let v = gu * k2[18 * a + b];
                    ke[(2 * a) * N + 2 * b] = v;
                    ke[(2 * a + 1) * N + 2 * b + 1] = v;
                }
            }
            for a in 0..8 {
                for b in 0..8 {
                    ke[(36 + a) * N + 36 + b] = gp * k1[8 * a + b];
                }
            }
            self.matrix
                .scatter(&dofs, &ke, &zero, &mut self.rhs, &self.unconstrained);
            if lay.with_g {
                // G's rows are an L² projection (θ(G, H)): the same patch term, unscaled by h
                let kg = k1.map(|v| self.params.ghost_penalty * self.params.theta * v);
                for ij in 0..4 {
                    let g_dofs: [usize; 8] =
                        std::array::from_fn(|a| lay.g(verts[a / 4][a % 4], ij));
                    self.matrix.scatter(
                        &g_dofs,
                        &kg,
                        &zero[..8],
                        &mut self.rhs,
                        &self.unconstrained,
                    );
                }
            }
        }
    }

    /// Matrix values of the elements outside every reach and the moving-element mask (no stress,
    /// no constraints).
    fn fluid_values(&mut self) -> Vec<f64> {
        let lay = self.layout;
        let (eta, theta) = (self.params.eta, self.params.theta);
        let nd = 22 + if lay.with_g { 16 } else { 0 };
        let tab = shape_table(&self.rule);
        let mut dofs = Vec::with_capacity(MAX_EL_DOFS);
        let mut ke = vec![0.0; nd * nd];
        let zero = vec![0.0; nd];
        let mut scratch = vec![0.0; lay.n_dofs()];
        self.matrix.zero();
        for e in 0..self.mesh.n_elements() {
            if assembled_each_step(&self.reach, &self.moving, e) {
                continue;
            }
            element_dofs(&self.mesh, &lay, e, &mut dofs);
            let xe = &self.mesh.element_coords[e];
            fluid_element_matrix(xe, &self.rule, &tab, eta, theta, lay.with_g, &mut ke);
            self.matrix
                .scatter(&dofs, &ke, &zero, &mut scratch, &self.unconstrained);
        }
        self.matrix.values.clone()
    }

    fn extract(&self, residual: f64) -> StokesSolution {
        let lay = self.layout;
        let u = (0..lay.n_nodes)
            .map(|k| [self.sol[lay.u(k, 0)], self.sol[lay.u(k, 1)]])
            .collect();
        let mut p: Vec<f64> = (0..lay.n_vertices).map(|v| self.sol[lay.p(v)]).collect();
        if self.pressure_pinned {
            let mean = mean_q1(&self.mesh, &p);
            p.iter_mut().for_each(|v| *v -= mean);
        }
        let g = lay.with_g.then(|| {
            (0..lay.n_vertices)
                .map(|v| [0, 1, 2, 3].map(|ij| self.sol[lay.g(v, ij)]))
                .collect()
        });
        let rigid = (0..lay.n_particles)
            .map(|i| [0, 1, 2].map(|c| self.sol[lay.rigid(i, c)]))
            .collect();
        let (reaction, stress_force) = self.particle_forces();
        StokesSolution {
            u,
            p,
            g,
            rigid,
            reaction,
            stress_force,
            residual,
        }
    }

    /// Force and torque on each particle: from the rigid rows of the weak condition (reaction)
    /// and from the stress integral over the boundary quadrature.
    fn particle_forces(&self) -> (Vec<[f64; 3]>, Vec<[f64; 3]>) {
        let lay = self.layout;
        let np = lay.n_particles;
        let (mut reaction, mut stress) = (vec![[0.0; 3]; np], vec![[0.0; 3]; np]);
        if np == 0 {
            return (reaction, stress);
        }
        let nd = 22 + if lay.with_g { 16 } else { 0 };
        let mut dofs = Vec::with_capacity(MAX_EL_DOFS);
        let mut ke = vec![0.0; (nd + 3) * (nd + 3)];
        let mut dn = [[0.0; 2]; 9];
        for (e, cut) in self.cuts.iter().enumerate() {
            let ElementCut::Cut(cut) = cut else { continue };
            element_dofs(&self.mesh, &lay, e, &mut dofs);
            let xe = &self.mesh.element_coords[e];
            let ue: Vec<[f64; 2]> = self.mesh.elements[e]
                .iter()
                .map(|&k| [self.sol[lay.u(k, 0)], self.sol[lay.u(k, 1)]])
                .collect();
            let pe: Vec<f64> = self.mesh.element_vertices[e]
                .iter()
                .map(|&v| self.sol[lay.p(v)])
                .collect();
            for pc in &cut.particles {
                let i = pc.particle;
                // reaction: −(rigid rows of the weak-condition kernel) · x
                ke.iter_mut().for_each(|v| *v = 0.0);
                let ce = CutElement {
                    xe,
                    vol: &cut.vol,
                    bnd: &pc.points,
                };
                weak_rigid_kernel(
                    &mut ke,
                    nd + 3,
                    nd,
                    &ce,
                    pc.center,
                    self.params.eta,
                    self.params.kappa,
                    self.params.rigid_form,
                );
                for c in 0..3 {
                    let row = &ke[(nd + c) * (nd + 3)..(nd + c + 1) * (nd + 3)];
                    let mut r: f64 = (0..nd).map(|a| row[a] * self.sol[dofs[a]]).sum();
                    r += (0..3)
                        .map(|d| row[nd + d] * self.sol[lay.rigid(i, d)])
                        .sum::<f64>();
                    reaction[i][c] -= r;
                }
                // stress integral: force on the particle = −∫ σ(u_h, p_h)·n_fluid ds
                for bp in &pc.points {
                    let (_, jac, det) = q2_map(xe, bp.xi);
                    let dref = q2(bp.xi).1;
                    physical_gradients(&jac, det, &dref, &mut dn);
                    let psi = q1(bp.xi).0;
                    let mut l = [[0.0; 2]; 2];
                    for k in 0..9 {
                        for a in 0..2 {
                            for b in 0..2 {
                                l[a][b] += dn[k][b] * ue[k][a];
                            }
                        }
                    }
                    let p: f64 = (0..4).map(|m| psi[m] * pe[m]).sum();
                    let eta = self.params.eta;
                    let sig = [
                        [-p + 2.0 * eta * l[0][0], eta * (l[0][1] + l[1][0])],
                        [eta * (l[0][1] + l[1][0]), -p + 2.0 * eta * l[1][1]],
                    ];
                    let t = [
                        -(sig[0][0] * bp.n[0] + sig[0][1] * bp.n[1]),
                        -(sig[1][0] * bp.n[0] + sig[1][1] * bp.n[1]),
                    ];
                    let r = [bp.x[0] - pc.center[0], bp.x[1] - pc.center[1]];
                    stress[i][0] += bp.w * t[0];
                    stress[i][1] += bp.w * t[1];
                    stress[i][2] += bp.w * (r[0] * t[1] - r[1] * t[0]);
                }
            }
        }
        (reaction, stress)
    }

    /// Node blocks for the LBLᵀ ordering: each Q2 node's velocity, then (at vertices) its G, then
    /// its pressure last.
    fn dof_blocks(&self) -> DofBlocks {
        let lay = self.layout;
        let n = lay.n_dofs();
        // geometric nested dissection of the structured mesh: 17 % (200×50) and 27 % (440×110)
        // less flow factorization time than AMD on the node-block graph
        // (its separators must also cut the pattern's ghost-penalty patches)
        let mut order: Vec<u32> = self
            .mesh
            .nested_dissection(ND_LEAF, &|e, o| patched_face(&self.reach, e, o))
            .into_iter()
            .map(|k| k as u32)
            .collect();
        order.extend((0..lay.n_particles).map(|i| (lay.n_nodes + i) as u32));
        let mut blocks = DofBlocks {
            block: vec![0; n],
            class: vec![0; n],
            order: Some(order),
        };
        for k in 0..lay.n_nodes {
            for c in 0..2 {
                blocks.block[lay.u(k, c)] = k as u32;
            }
        }
        for v in 0..lay.n_vertices {
            let k = self.mesh.node_of_vertex[v] as u32;
            blocks.block[lay.p(v)] = k;
            blocks.class[lay.p(v)] = 2;
            if lay.with_g {
                for ij in 0..4 {
                    blocks.block[lay.g(v, ij)] = k;
                    blocks.class[lay.g(v, ij)] = 1;
                }
            }
        }
        for i in 0..lay.n_particles {
            for c in 0..3 {
                blocks.block[lay.rigid(i, c)] = (lay.n_nodes + i) as u32;
            }
        }
        blocks
    }

    /// Largest asymmetry of the assembled matrix (0 up to round-off: the system is symmetric).
    pub fn matrix_asymmetry(&self) -> f64 {
        self.matrix.asymmetry()
    }
}

/// (η, θ) and the fluid element matrices by rectangle sides (see `Stokes::rectangles`).
type RectangleMatrices = (f64, f64, HashMap<[u64; 2], Box<[f64]>>);

/// Distinct rectangle sizes kept by [`Stokes`] between steps before it starts afresh (a mesh
/// that follows the particles creates a few hundred per step; 4096 matrices of 38×38 are 47 MB).
const RECTANGLE_CACHE_LEN: usize = 4096;

/// The side lengths (bit patterns) of an axis-parallel rectangular element, whose fluid matrix
/// depends on them only, and the same element placed with its lower-left corner at the origin:
/// the matrix computed there is the same whichever element of these sides asks first (a
/// restored run assembles bit for bit what the saved one did).
fn canonical_rectangle(xe: &[[f64; 2]; 9]) -> ([u64; 2], [[f64; 2]; 9]) {
    let (lo, hi) = bounding_box(xe);
    let side = [hi[0] - lo[0], hi[1] - lo[1]];
    let mut canonical = [[0.0; 2]; 9];
    for (y, x) in canonical.iter_mut().zip(xe) {
        for c in 0..2 {
            // the node's place along the side: 0, 1/2 or 1
            let t = (2.0 * (x[c] - lo[c]) / side[c]).round() * 0.5;
            y[c] = t * side[c];
        }
    }
    ([side[0].to_bits(), side[1].to_bits()], canonical)
}

/// Local dof list of element `e`: 18 velocity, 4 pressure, then 16 G (if present).
fn element_dofs(mesh: &Mesh, lay: &Layout, e: usize, dofs: &mut Vec<usize>) {
    dofs.clear();
    for &k in &mesh.elements[e] {
        dofs.push(lay.u(k, 0));
        dofs.push(lay.u(k, 1));
    }
    for &v in &mesh.element_vertices[e] {
        dofs.push(lay.p(v));
    }
    if lay.with_g {
        for &v in &mesh.element_vertices[e] {
            for ij in 0..4 {
                dofs.push(lay.g(v, ij));
            }
        }
    }
}

/// Per Gauss point: Q2 values and reference gradients, Q1 values.
type ShapeTable = (([f64; 9], [[f64; 2]; 9]), [f64; 4]);

fn shape_table(rule: &QuadRule) -> Vec<ShapeTable> {
    rule.points.iter().map(|&xi| (q2(xi), q1(xi).0)).collect()
}

/// The Stokes matrix (viscous, DEVSS-G and pressure terms) of the element with nodes `xe` as
/// fully fluid, into `ke` (`nd`×`nd`, local order of [`element_dofs`] without rigid-body slots).
fn fluid_element_matrix(
    xe: &[[f64; 2]; 9],
    rule: &QuadRule,
    tab: &[ShapeTable],
    eta: f64,
    theta: f64,
    with_g: bool,
    ke: &mut [f64],
) {
    let nd = 22 + if with_g { 16 } else { 0 };
    let mut fe = [0.0; MAX_EL_DOFS];
    let mut dn = [[0.0; 2]; 9];
    ke.iter_mut().for_each(|v| *v = 0.0);
    for (q, ((n2, dref), psi)) in tab.iter().enumerate() {
        let (_, jac, det) = q2_map(xe, rule.points[q]);
        physical_gradients(&jac, det, dref, &mut dn);
        let w = rule.weights[q] * det;
        stokes_kernel(
            ke,
            &mut fe[..nd],
            nd,
            w,
            eta,
            theta,
            n2,
            &dn,
            psi,
            [0.0; 2],
            with_g,
        );
    }
}

/// Adds one quadrature point's contribution (weight `w` = Gauss weight × det J) to the local
/// matrix `ke` (row-major, `nd`×`nd`, local order as in [`element_dofs`]) and vector `fe`.
#[allow(clippy::too_many_arguments)]
#[inline]
fn stokes_kernel(
    ke: &mut [f64],
    fe: &mut [f64],
    nd: usize,
    w: f64,
    eta: f64,
    theta: f64,
    n2: &[f64; 9],
    dn: &[[f64; 2]; 9],
    psi: &[f64; 4],
    force: [f64; 2],
    with_g: bool,
) {
    for a in 0..9 {
        for c in 0..2 {
            let row = 2 * a + c;
            fe[row] += w * n2[a] * force[c];
            for b in 0..9 {
                let gg = dn[a][0] * dn[b][0] + dn[a][1] * dn[b][1];
                for d in 0..2 {
                    // 2η D(v):D(u) = η [δ_cd ∇N_a·∇N_b + ∂_d N_a ∂_c N_b]; θ δ_cd ∇N_a·∇N_b
                    let mut v = eta * dn[a][d] * dn[b][c];
                    if c == d {
                        v += (eta + theta) * gg;
                    }
                    ke[row * nd + 2 * b + d] += w * v;
                }
            }
            for m in 0..4 {
                // −(∇·v, p) and its transpose −(q, ∇·u)
                let v = -w * psi[m] * dn[a][c];
                ke[row * nd + 18 + m] += v;
                ke[(18 + m) * nd + row] += v;
                if with_g {
                    for j in 0..2 {
                        // −θ (G, L(v)): v = N_a e_c, L(v)_{cj} = ∂_j N_a; and the transpose
                        let gcol = 22 + 4 * m + 2 * c + j;
                        let v = -w * theta * psi[m] * dn[a][j];
                        ke[row * nd + gcol] += v;
                        ke[gcol * nd + row] += v;
                    }
                }
            }
        }
    }
    if with_g {
        for l in 0..4 {
            for m in 0..4 {
                let v = w * theta * psi[l] * psi[m];
                for ij in 0..4 {
                    ke[(22 + 4 * l + ij) * nd + 22 + 4 * m + ij] += v;
                }
            }
        }
    }
}

/// Mean of a Q1 field over the mesh.
pub fn mean_q1(mesh: &Mesh, p: &[f64]) -> f64 {
    let rule = gauss_quad(2);
    let (mut int, mut area) = (0.0, 0.0);
    for e in 0..mesh.n_elements() {
        for (xi, w) in rule.points.iter().zip(&rule.weights) {
            let det = q2_map(&mesh.element_coords[e], *xi).2;
            let psi = q1(*xi).0;
            let val: f64 = (0..4)
                .map(|k| psi[k] * p[mesh.element_vertices[e][k]])
                .sum();
            int += w * det * val;
            area += w * det;
        }
    }
    int / area
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::Axis;
    use crate::solver::cutcells::compute_cuts;
    use crate::xfem::CutOptions;

    /// Same matrix entries assembled in the same order: only the factorization's round-off
    /// differs (when the pattern is rebuilt the ordering may differ).
    const SAME_SYSTEM_TOL: f64 = 1e-10;

    fn channel() -> Mesh {
        Mesh::rectangle(
            Axis::uniform(-1.0, 1.0, 16),
            Axis::uniform(-0.5, 0.5, 8),
            true,
        )
    }

    /// The period of a periodic channel.
    fn period(mesh: &Mesh) -> f64 {
        mesh.ax.vertices[mesh.ax.len()] - mesh.ax.vertices[0]
    }

    fn solve_at(st: &mut Stokes) -> StokesSolution {
        st.solve(&|_| [0.0, 0.0]).unwrap()
    }

    fn fresh(mesh: &Mesh, center: [f64; 2]) -> Stokes {
        let p = vec![Particle {
            center,
            radius: 0.2,
            motion: Motion::Free,
        }];
        let cuts = compute_cuts(mesh, &p, Some(period(mesh)), CutOptions::default()).unwrap();
        let mut st = Stokes::with_particles(
            mesh.clone(),
            StokesParams::new(1.0, 0.0, SolverKind::Lblt),
            p,
            cuts,
        );
        st.set_velocity(Side::Bottom, |_| [-0.5, 0.0]);
        st.set_velocity(Side::Top, |_| [0.5, 0.0]);
        st.pin_pressure();
        st
    }

    fn moved(st: &mut Stokes, center: [f64; 2]) {
        let p = vec![Particle {
            center,
            radius: 0.2,
            motion: Motion::Free,
        }];
        let cuts =
            compute_cuts(&st.mesh, &p, Some(period(&st.mesh)), CutOptions::default()).unwrap();
        st.set_particles(p, cuts);
    }

    fn max_diff(a: &StokesSolution, b: &StokesSolution) -> f64 {
        let du =
            a.u.iter()
                .zip(&b.u)
                .map(|(x, y)| (x[0] - y[0]).abs().max((x[1] - y[1]).abs()));
        let dr = a
            .rigid
            .iter()
            .zip(&b.rigid)
            .flat_map(|(x, y)| (0..3).map(move |c| (x[c] - y[c]).abs()));
        du.chain(dr).fold(0.0, f64::max)
    }

    /// A Stokes whose mesh moved and one built on the moved mesh assemble the same element
    /// matrices, summed in another order (cached base or every step) and factored in another
    /// elimination order (the fresh pattern's reach is taken from the new coordinates): they
    /// differ by the round-off of a direct solve, relative to the solution's scale.
    const FRESH_BUILD_TOL: f64 = 1e-10;

    /// The channel of the moving-mesh tests, 32×16: wide enough that the moving-element mask
    /// (the changed columns and rows widened by [`MOVING_MARGIN`]) leaves elements in the base.
    fn long_channel() -> Mesh {
        Mesh::rectangle(
            Axis::uniform(-2.0, 2.0, 32),
            Axis::uniform(-0.5, 0.5, 16),
            true,
        )
    }

    /// `axis` with the vertices `lo..=hi` moved toward `c` by the factor `s` (a local grading).
    fn squeezed(axis: &Axis, lo: usize, hi: usize, c: f64, s: f64) -> Axis {
        let mut vertices = axis.vertices.clone();
        vertices[lo..=hi]
            .iter_mut()
            .for_each(|x| *x = c + s * (*x - c));
        Axis { vertices }
    }

    /// `mesh` graded around the test particle: columns 13..=18 and rows 6..=9 move, elements of
    /// the fluid base among them.
    fn graded_around_the_particle(mesh: &Mesh) -> Mesh {
        mesh.with_axes(
            squeezed(&mesh.ax, 14, 18, 0.0, 0.8),
            squeezed(&mesh.ay, 7, 9, 0.1, 0.8),
        )
    }

    /// Largest difference of velocity, pressure and rigid velocities relative to the largest of
    /// them in `b`.
    fn rel_diff(a: &StokesSolution, b: &StokesSolution) -> f64 {
        let dp = a.p.iter().zip(&b.p).map(|(x, y)| (x - y).abs());
        let scale = (b.u.iter().flatten().chain(&b.p))
            .chain(b.rigid.iter().flatten())
            .fold(0.0, |m: f64, v| m.max(v.abs()));
        dp.fold(max_diff(a, b), f64::max) / scale
    }

    #[test]
    fn a_moved_mesh_solves_like_a_stokes_built_on_it() {
        let mesh = long_channel();
        let c = [0.013, 0.101];
        let mut st = fresh(&mesh, c);
        // builds the fluid base on the uniform mesh
        let before = solve_at(&mut st);
        let graded = graded_around_the_particle(&mesh);
        st.set_mesh(graded.clone());
        moved(&mut st, c);
        let a = solve_at(&mut st);
        assert_eq!((st.pattern_rebuilds, st.base_rebuilds), (0, 1));
        let b = solve_at(&mut fresh(&graded, c));
        let d = rel_diff(&a, &b);
        eprintln!("moved mesh vs fresh: {d:.2e}");
        assert!(d < FRESH_BUILD_TOL, "{d}");
        // not vacuous: the nodes moved in the shear flow
        assert!(max_diff(&a, &before) > 1e-3, "{}", max_diff(&a, &before));
    }

    #[test]
    fn moves_inside_the_mask_keep_the_fluid_base() {
        let mesh = long_channel();
        let c = [0.013, 0.101];
        let mut st = fresh(&mesh, c);
        let _ = solve_at(&mut st);
        let graded = graded_around_the_particle(&mesh);
        st.set_mesh(graded);
        moved(&mut st, c);
        let _ = solve_at(&mut st);
        assert_eq!(st.base_rebuilds, 1);
        // the grading travels on with the particle: columns 13..=19 and rows 6..=10 change,
        // inside the mask (columns 9..=22, rows 2..=13)
        let c2 = [0.05, 0.11];
        let next = mesh.with_axes(
            squeezed(&mesh.ax, 15, 19, 0.05, 0.7),
            squeezed(&mesh.ay, 7, 10, 0.11, 0.8),
        );
        st.set_mesh(next.clone());
        moved(&mut st, c2);
        let a = solve_at(&mut st);
        assert_eq!((st.pattern_rebuilds, st.base_rebuilds), (0, 1));
        let d = rel_diff(&a, &solve_at(&mut fresh(&next, c2)));
        eprintln!("second move vs fresh: {d:.2e}");
        assert!(d < FRESH_BUILD_TOL, "{d}");
        // back to the uniform axes
        st.set_mesh(mesh.clone());
        moved(&mut st, c);
        let a = solve_at(&mut st);
        assert_eq!((st.pattern_rebuilds, st.base_rebuilds), (0, 1));
        let d = rel_diff(&a, &solve_at(&mut fresh(&mesh, c)));
        eprintln!("moved back vs fresh: {d:.2e}");
        assert!(d < FRESH_BUILD_TOL, "{d}");
        // columns moved outside the mask (across the periodic seam) grow it: one more rebuild
        let far = mesh.with_axes(squeezed(&mesh.ax, 1, 3, 0.0, 0.9), mesh.ay.clone());
        st.set_mesh(far.clone());
        moved(&mut st, c);
        let a = solve_at(&mut st);
        assert_eq!((st.pattern_rebuilds, st.base_rebuilds), (0, 2));
        let d = rel_diff(&a, &solve_at(&mut fresh(&far, c)));
        eprintln!("far columns vs fresh: {d:.2e}");
        assert!(d < FRESH_BUILD_TOL, "{d}");
    }

    #[test]
    fn a_moved_annulus_re_evaluates_the_wall_velocities() {
        // circular Couette flow: inner cylinder turning at ω = 1, outer at rest
        let couette = |mesh: &Mesh| {
            let params = StokesParams::new(1.0, 0.0, SolverKind::Lblt);
            let mut st = Stokes::new(mesh.clone(), params);
            st.set_velocity(Side::Bottom, |x| [-x[1], x[0]]);
            st.set_velocity(Side::Top, |_| [0.0, 0.0]);
            st.pin_pressure();
            st
        };
        let n = 24;
        let mesh = Mesh::annulus(n, Axis::uniform(1.0, 2.0, 4));
        let mut st = couette(&mesh);
        let before = solve_at(&mut st);
        // a non-uniform θ axis with the same span: the wall nodes slide along the circles
        let tau = 2.0 * std::f64::consts::PI;
        let mut vertices: Vec<f64> = (0..=n)
            .map(|i| {
                let s = i as f64 / n as f64;
                tau * s + 0.3 * (tau * s).sin()
            })
            .collect();
        vertices[n] = mesh.ax.vertices[n];
        let theta = Axis { vertices };
        let moved_mesh = mesh.with_axes(theta, mesh.ay.clone());
        st.set_mesh(moved_mesh.clone());
        let a = solve_at(&mut st);
        let d = rel_diff(&a, &solve_at(&mut couette(&moved_mesh)));
        eprintln!("moved annulus vs fresh: {d:.2e}");
        assert!(d < FRESH_BUILD_TOL, "{d}");
        // not vacuous: the wall nodes moved, and with them their velocities
        let k = moved_mesh.side_nodes(Side::Bottom)[3];
        assert!((a.u[k][0] - before.u[k][0]).abs() > 1e-2);
        assert_eq!(a.u[k], [-moved_mesh.nodes[k][1], moved_mesh.nodes[k][0]]);
    }

    #[test]
    fn moving_a_particle_equals_building_anew_and_reuses_the_pattern() {
        let mesh = channel();
        let mut st = fresh(&mesh, [0.013, 0.101]);
        let _ = solve_at(&mut st);
        // a small move keeps every element's kind: same pattern, same symbolic analysis
        moved(&mut st, [0.0135, 0.1012]);
        let a = solve_at(&mut st);
        assert_eq!(st.pattern_rebuilds, 0);
        let b = solve_at(&mut fresh(&mesh, [0.0135, 0.1012]));
        assert!(max_diff(&a, &b) < SAME_SYSTEM_TOL, "{}", max_diff(&a, &b));
        // a long move across the seam changes the cut elements: the pattern is rebuilt
        moved(&mut st, [0.95, -0.1]);
        let a = solve_at(&mut st);
        assert_eq!(st.pattern_rebuilds, 1);
        let b = solve_at(&mut fresh(&mesh, [0.95, -0.1]));
        assert!(max_diff(&a, &b) < SAME_SYSTEM_TOL, "{}", max_diff(&a, &b));
        // wall velocities survive the move
        let top = mesh.side_nodes(Side::Top)[3];
        assert_eq!(a.u[top], [0.5, 0.0]);
    }
}
