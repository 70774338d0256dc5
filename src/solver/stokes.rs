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

use std::time::Instant;

use crate::fem::element::{physical_gradients, q1, q2, q2_map};
use crate::fem::linsolve::{DirectSolver, DofBlocks, SolveError, SolverKind};
use crate::fem::quadrature::{gauss_quad, QuadRule};
use crate::fem::sparse::{PatternBuilder, SparseMatrix};
use crate::mesh::{Mesh, Side};

/// Physical and numerical parameters of a Stokes solve.
#[derive(Debug, Clone, Copy)]
pub struct StokesParams {
    /// Viscosity η of the 2η D(u) term (the solvent viscosity in viscoelastic flow).
    pub eta: f64,
    /// DEVSS-G parameter θ (the polymer viscosity in viscoelastic flow); 0 = no G unknowns.
    pub theta: f64,
    /// Linear solver.
    pub solver: SolverKind,
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
    /// Total number of unknowns.
    pub fn n_dofs(&self) -> usize {
        2 * self.n_nodes + self.n_vertices + if self.with_g { 4 * self.n_vertices } else { 0 }
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
    /// Relative residual of the linear solve.
    pub residual: f64,
}

/// Maximum dofs of one element: 18 velocity + 4 pressure + 16 G.
const MAX_EL_DOFS: usize = 38;
/// Relative residual accepted from the direct solver (a few hundred ulps of the matrix norm).
const RESIDUAL_TOL: f64 = 1e-10;

/// A reusable Stokes solver on a fixed mesh: the pattern and the symbolic factorization are built
/// once; each [`solve`](Self::solve) assembles, refactors numerically and solves.
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
    pressure_pinned: bool,
    solver: Option<DirectSolver>,
    rule: QuadRule,
    /// Timings of the last solve.
    pub timings: Timings,
}

impl Stokes {
    /// Builds the unknown numbering and the sparsity pattern on `mesh`.
    pub fn new(mesh: Mesh, params: StokesParams) -> Self {
        let layout = Layout {
            n_nodes: mesh.n_nodes(),
            n_vertices: mesh.n_vertices(),
            with_g: params.theta > 0.0,
        };
        let mut pb = PatternBuilder::new(layout.n_dofs());
        let mut dofs = Vec::with_capacity(MAX_EL_DOFS);
        let (mut g_ij, mut u_i) = (Vec::with_capacity(4), Vec::with_capacity(9));
        for e in 0..mesh.n_elements() {
            element_dofs(&mesh, &layout, e, &mut dofs);
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
        let matrix = pb.build();
        let n = layout.n_dofs();
        Self {
            mesh,
            params,
            layout,
            matrix,
            rhs: vec![0.0; n],
            sol: vec![0.0; n],
            fixed: vec![None; n],
            pressure_pinned: false,
            solver: None,
            rule: gauss_quad(3),
            timings: Timings::default(),
        }
    }

    /// Number of unknowns and of stored matrix entries.
    pub fn size(&self) -> (usize, usize) {
        (self.layout.n_dofs(), self.matrix.nnz())
    }

    /// Prescribes the velocity `f(x)` at all nodes of the given sides.
    pub fn set_velocity(&mut self, side: Side, f: impl Fn([f64; 2]) -> [f64; 2]) {
        for k in self.mesh.side_nodes(side) {
            let v = f(self.mesh.nodes[k]);
            for (c, vc) in v.iter().enumerate() {
                self.fixed[self.layout.u(k, c)] = Some(*vc);
            }
        }
    }

    /// Pins the pressure at vertex 0 (for flows with velocity prescribed on the whole boundary).
    pub fn pin_pressure(&mut self) {
        self.fixed[self.layout.p(0)] = Some(0.0);
        self.pressure_pinned = true;
    }

    /// Assembles with body force `f`, factorizes (symbolic analysis on the first call only) and
    /// solves.
    pub fn solve(
        &mut self,
        f: &dyn Fn([f64; 2]) -> [f64; 2],
    ) -> Result<StokesSolution, SolveError> {
        let t0 = Instant::now();
        self.assemble(f);
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
        solver.factor(&self.matrix)?;
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

    fn assemble(&mut self, f: &dyn Fn([f64; 2]) -> [f64; 2]) {
        self.matrix.zero();
        self.rhs.iter_mut().for_each(|v| *v = 0.0);
        let lay = self.layout;
        let (eta, theta) = (self.params.eta, self.params.theta);
        let nd = 22 + if lay.with_g { 16 } else { 0 };
        let mut dofs = Vec::with_capacity(MAX_EL_DOFS);
        let mut ke = [0.0; MAX_EL_DOFS * MAX_EL_DOFS];
        let mut fe = [0.0; MAX_EL_DOFS];
        let tab: Vec<_> = self
            .rule
            .points
            .iter()
            .map(|&xi| (q2(xi), q1(xi).0))
            .collect();
        let mut dn = [[0.0; 2]; 9];
        for e in 0..self.mesh.n_elements() {
            element_dofs(&self.mesh, &lay, e, &mut dofs);
            let ke = &mut ke[..nd * nd];
            let fe = &mut fe[..nd];
            ke.iter_mut().for_each(|v| *v = 0.0);
            fe.iter_mut().for_each(|v| *v = 0.0);
            let xe = &self.mesh.element_coords[e];
            for (q, ((n2, dref), psi)) in tab.iter().enumerate() {
                let (x, jac, det) = q2_map(xe, self.rule.points[q]);
                let w = self.rule.weights[q] * det;
                physical_gradients(&jac, det, dref, &mut dn);
                let force = f(x);
                stokes_kernel(ke, fe, nd, w, eta, theta, n2, &dn, psi, force, lay.with_g);
            }
            self.matrix
                .scatter(&dofs, ke, fe, &mut self.rhs, &self.fixed);
        }
        self.matrix.apply_constraints(&mut self.rhs, &self.fixed);
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
        StokesSolution { u, p, g, residual }
    }

    /// Node blocks for the LBLᵀ ordering: each Q2 node's velocity, then (at vertices) its G, then
    /// its pressure last.
    fn dof_blocks(&self) -> DofBlocks {
        let lay = self.layout;
        let n = lay.n_dofs();
        let mut blocks = DofBlocks {
            block: vec![0; n],
            class: vec![0; n],
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
        blocks
    }

    /// Largest asymmetry of the assembled matrix (0 up to round-off: the system is symmetric).
    pub fn matrix_asymmetry(&self) -> f64 {
        self.matrix.asymmetry()
    }
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
