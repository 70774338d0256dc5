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
//!
//! Here: [`Stokes`] and its public API (setup, particle and mesh moves, solves); its parameters,
//! its solution and what its solves cost, the numbering of the unknowns, the sparsity pattern,
//! the constraints, the caches kept between steps, the assembly, the element kernels and the
//! particle forces are in the submodules.

mod assemble;
mod band;
mod cache;
mod constraints;
mod dofs;
mod forces;
mod kernels;
mod multipliers;
mod params;
mod pattern;
mod reach;
mod solution;
mod stats;
#[cfg(test)]
mod tests;

pub use crate::fem::substructure::Factorization as FlowFactorization;
pub use band::{BAND_FRACTION_LIMIT, INTERFACE_LIMIT};
pub use dofs::Layout;
pub use params::{StokesParams, FLOW_GHOST_PENALTY};
pub use solution::{mean_q1, StokesSolution};
pub use stats::{FlowSolverStats, Timings};

use std::collections::HashMap;
use std::time::Instant;

use crate::mesh::dilate;
use cache::{ElementPositions, FluidBase, GhostPatch, RectangleMatrices, MOVING_MARGIN};
use constraints::{push_condition_values, VelocityCondition};
use multipliers::{links_cover, ring_links, rings_for, RingLink};
use pattern::build_pattern;
use reach::{reach_for, Reach};

use crate::fem::linsolve::{DirectSolver, Pivoting, ProbeVerdict, SolveError, SolverKind};
use crate::fem::quadrature::{gauss_quad, QuadRule};
use crate::fem::sparse::SparseMatrix;
use crate::fem::substructure::Substructured;
use crate::mesh::Mesh;
use crate::solver::lubrication::Film;
use crate::solver::multiplier::{RigidCondition, Ring};
use crate::solver::polymer_terms::PolymerStress;
use crate::solver::rigid::{ElementCut, Particle};

/// Relative residual accepted from the direct solver (a few hundred ulps of the matrix norm).
const RESIDUAL_TOL: f64 = 1e-10;

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
    walls: Vec<VelocityCondition>,
    pressure_pinned: bool,
    solver: Option<DirectSolver>,
    /// The symmetric-part solver's comparison with a whole LU, kept for the solver of a rebuilt
    /// pattern (`fem::linsolve::probe`).
    probe_verdict: Option<ProbeVerdict>,
    factored_values: Option<Vec<f64>>,
    /// Numeric factorizations done so far (a solve reuses the last one when the matrix is
    /// unchanged).
    pub refactorizations: usize,
    /// Pattern (and symbolic analysis) rebuilds caused by [`set_particles`](Self::set_particles).
    pub pattern_rebuilds: usize,
    /// Placements of the band of [`FlowFactorization::Band`] (far-field factorizations).
    pub placements: usize,
    /// Solves, GMRES iterations and LU fallbacks so far.
    pub stats: FlowSolverStats,
    /// The films corrected by the last assembly ([`StokesParams::lubrication`]), for the
    /// reaction of the same solve.
    films: Vec<Film>,
    /// The band solver of the current placement.
    band_solver: Option<Substructured>,
    /// Solves of [`FlowFactorization::Band`] that fell back to the whole matrix because the
    /// band solver failed (its placement or a factorization); 0 in every run measured.
    pub band_fallbacks: usize,
    /// Placements of the band declined because its interface was too large
    /// ([`INTERFACE_LIMIT`]): the whole matrix was factored instead.
    pub band_declines: usize,
    /// The placement (pattern and base rebuild counts) whose band was declined.
    band_declined: Option<(usize, usize)>,
    /// Invalidations of the cached fluid base matrix by [`set_mesh`](Self::set_mesh) (an element
    /// outside the moving-element mask moved); the base is rebuilt at the next solve.
    pub base_rebuilds: usize,
    rule: QuadRule,
    particles: Vec<Particle>,
    cuts: Vec<ElementCut>,
    /// The particles' multiplier rings (empty with the weak condition).
    rings: Vec<Ring>,
    /// The multiplier couplings the pattern holds ([`multipliers::ring_links`]).
    links: Vec<RingLink>,
    /// Where the matrix may change while the pattern lasts (particles' reach, free-surface band).
    reach: Reach,
    /// Matrix values of the elements outside every particle's reach (fluid while the pattern
    /// lasts) and outside `moving`, without stress or constraints, and the (η, θ) they were
    /// built with: a step starts from them and assembles the matrix of the elements in reach or
    /// in `moving` only (with a semi-implicit stress, η_s = 0, also the stress's matrix of the
    /// others). (Subtracting cut
    /// elements from an all-fluid base instead lost the relative accuracy of the tiny entries of
    /// sliver rows to cancellation; for the same reason a moved element is never subtracted and
    /// re-added, the base is rebuilt without it.)
    fluid_base: Option<FluidBase>,
    /// The ghost-penalty faces' patch matrices of the last assembly, by face key (kept while
    /// their elements' coordinates stay).
    ghost_patches: HashMap<usize, GhostPatch>,
    /// The pattern's transpose positions (`SparseMatrix::transpose_positions`; empty: not
    /// built for this pattern).
    transpose: Vec<u32>,
    /// Per element, whether its coordinates may change ([`set_mesh`](Self::set_mesh)): such
    /// elements are left out of the fluid base and assembled every step.
    moving: Vec<bool>,
    /// Fluid element matrices of axis-parallel rectangles by their sides (the matrix of such an
    /// element depends on them only), for the elements assembled every step, with the (η, θ)
    /// they were built with: the columns of a mesh that follows the particles have one width
    /// each, so a step computes one matrix per column and row size instead of per element.
    rectangles: RectangleMatrices,
    /// Where each element's entries lie in the matrix (per pattern).
    positions: ElementPositions,
    /// Where each ghost-penalty face's patch entries lie in the matrix (per pattern; keyed
    /// by `assemble::face_key`).
    face_positions: ElementPositions,
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
        let rings = match params.rigid_condition {
            RigidCondition::Multiplier => rings_for(&mesh, &particles, &cuts),
            RigidCondition::Weak => Vec::new(),
        };
        let layout = Layout {
            n_nodes: mesh.n_nodes(),
            n_vertices: mesh.n_vertices(),
            with_g: params.theta > 0.0 && params.coupled_g,
            n_particles: particles.len(),
            n_ring_nodes: rings.iter().map(|r| r.nodes).sum(),
        };
        let reach = reach_for(&mesh, &particles, &cuts, vec![[0.0; 2]; particles.len()]);
        let links = ring_links(&rings, &cuts);
        let matrix = build_pattern(&mesh, &layout, &reach, &links, params.lubrication.is_some());
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
            probe_verdict: None,
            factored_values: None,
            refactorizations: 0,
            pattern_rebuilds: 0,
            placements: 0,
            stats: FlowSolverStats::default(),
            films: Vec::new(),
            band_solver: None,
            band_fallbacks: 0,
            band_declines: 0,
            band_declined: None,
            base_rebuilds: 0,
            rule: gauss_quad(3),
            particles,
            cuts,
            rings,
            links,
            reach,
            fluid_base: None,
            transpose: Vec::new(),
            ghost_patches: HashMap::new(),
            moving: vec![false; n_elements],
            rectangles: (0.0, 0.0, HashMap::new()),
            positions: ElementPositions::default(),
            face_positions: ElementPositions::default(),
            unconstrained: vec![None; n],
            timings: Timings::default(),
        };
        st.fixed = st.geometric_constraints();
        st
    }

    /// [`set_particles`](Self::set_particles) for particles placed rather than moved (a state
    /// restored into the solver): the jump from the old positions is not taken as the particles'
    /// drift, along which the reach is stretched.
    pub fn place_particles(&mut self, particles: Vec<Particle>, cuts: Vec<ElementCut>) {
        self.reach.forget();
        self.set_particles(particles, cuts);
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
        let links = ring_links(&self.rings, &self.cuts);
        self.reach.moved();
        if !self.reach.covers(&self.cuts)
            || self.reach.outlived(&self.mesh, &self.particles)
            || !links_cover(&self.links, &links)
        {
            self.reach = self.reach.renewed(&self.mesh, &self.particles, &self.cuts);
            self.links = links;
            self.matrix = build_pattern(
                &self.mesh,
                &self.layout,
                &self.reach,
                &self.links,
                self.params.lubrication.is_some(),
            );
            self.positions.clear();
            self.face_positions.clear();
            self.transpose.clear();
            if let Some(v) = self.solver.take().and_then(|s| s.probe_verdict()) {
                self.probe_verdict = Some(v);
            }
            self.band_solver = None;
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
            self.band_solver = None;
            self.base_rebuilds += 1;
        }
        self.ghost_patches
            .retain(|_, p| !p.elements.iter().any(|&e| changed[e]));
        self.mesh = mesh;
        self.factored_values = None;
        self.wall_values.clear();
        for condition in &self.walls {
            push_condition_values(&self.mesh, &self.layout, condition, &mut self.wall_values);
        }
        self.reset_constraints();
    }

    /// The particles.
    pub fn particles(&self) -> &[Particle] {
        &self.particles
    }

    /// The films the lubrication correction acted on in the last solve (none without it).
    pub fn films(&self) -> &[Film] {
        &self.films
    }

    /// Number of unknowns and of stored matrix entries.
    pub fn size(&self) -> (usize, usize) {
        (self.layout.n_dofs(), self.matrix.nnz())
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
        // the band's far field is condensed onto an interface of velocity dofs; the multipliers'
        // zero diagonals need the whole matrix's ordering (comparison mode: not optimized)
        if self.params.factorization == FlowFactorization::Band
            && self.params.solver == SolverKind::Lblt
            && self.params.rigid_condition == RigidCondition::Weak
        {
            if let Some((residual, times)) = self.solve_by_band()? {
                self.stats.solves += 1;
                self.stats.krylov_iterations += self
                    .band_solver
                    .as_ref()
                    .map_or(0, Substructured::last_polish_iterations);
                self.timings = Timings {
                    assembly: (t1 - t0).as_secs_f64(),
                    symbolic: 0.0,
                    placement: times.placement,
                    numeric: times.numeric,
                    solve: times.solve,
                };
                return Ok(self.extract(residual));
            }
        }
        let mut symbolic = 0.0;
        if self.solver.is_none() {
            self.solver = Some(match self.params.solver {
                SolverKind::Lblt => {
                    let mut solver = DirectSolver::analyze_blocked(
                        &self.matrix,
                        SolverKind::Lblt,
                        &self.dof_blocks(),
                    )?;
                    // without pivots where it solves (`fem::linsolve::unpivoted`): 200×50 with
                    // three particles factors in 0.20 s instead of 0.26
                    solver.set_pivoting(Pivoting::WhenNeeded);
                    solver
                }
                SolverKind::Lu => {
                    let mut solver = DirectSolver::analyze_blocked(
                        &self.matrix,
                        SolverKind::Lu,
                        &self.dof_blocks(),
                    )?;
                    if let Some(verdict) = self.probe_verdict {
                        solver.settle(verdict, &self.matrix)?;
                    }
                    solver
                }
            });
            symbolic = t1.elapsed().as_secs_f64();
        }
        let t2 = Instant::now();
        let solver = self.solver.as_mut().expect("analysed above");
        let fallbacks = solver.lu_fallbacks();
        let pivoted = solver.pivoted_refactors();
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
        self.stats.solves += 1;
        self.stats.krylov_iterations += solver.last_polish_iterations();
        self.stats.lu_fallbacks += solver.lu_fallbacks() - fallbacks;
        self.stats.pivoted_refactors += solver.pivoted_refactors() - pivoted;
        self.timings = Timings {
            assembly: (t1 - t0).as_secs_f64(),
            symbolic,
            placement: 0.0,
            numeric: (t3 - t2).as_secs_f64(),
            solve: t3.elapsed().as_secs_f64(),
        };
        Ok(self.extract(residual))
    }

    /// Largest asymmetry of the assembled matrix (0 up to round-off: the system is symmetric).
    pub fn matrix_asymmetry(&self) -> f64 {
        self.matrix.asymmetry()
    }
}
