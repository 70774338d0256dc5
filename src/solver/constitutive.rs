//! Transport of the log-conformation `s = log c` (3 components s_xx, s_xy, s_yy on Q1) with SUPG
//! and the BDF2 (Gear) scheme of thesis Eq. 5.29 (Eq. 5.53 for the Euler first step):
//!
//! ```text
//!   (d + τ w·∇d, (3/2 s^{n+1} − 2sⁿ + ½ s^{n−1})/Δt + w·∇s^{n+1} − g(G^{n+1}, ŝ)) = 0,
//!   ŝ = 2sⁿ − s^{n−1},    w = u^{n+1} − u_m^{n+1}                                   (5.29)
//!   (d + τ w·∇d, (s^{n+1} − sⁿ)/Δt + w·∇s^{n+1} − g(G^{n+1}, sⁿ)) = 0            (5.53)
//! ```
//!
//! With steps of varying size the coefficients are those of variable-step BDF2 and ŝ the
//! matching extrapolation ([`Bdf2`](crate::solver::bdf::Bdf2): 3/2, 2, ½ and 2sⁿ − s^{n−1} for equal steps).
//!
//! with g the right-hand side of the log-conformation equation (Eqs. 2.7, 5.7;
//! [`log_conformation_rhs`]) evaluated explicitly at the quadrature points, G the velocity
//! gradient (Q1, `[G_xx, G_xy, G_yx, G_yy]`, `G_ij ≈ ∂u_i/∂x_j`) and the SUPG parameter of Eqs.
//! 3.22–3.24 (Case 1 of the "Note on the SUPG parameter", Eqs. 2.37–2.40):
//! `τ = β̄ h/(2‖w‖)` with `β̄ = min(1, C)`, `C = ‖w‖Δt/h`, i.e. `τ = min(h/(2‖w‖), Δt/2)`, where `h`
//! is the element length in the direction of `w` at the quadrature point.
//!
//! The left-hand side is the same scalar matrix for the three components: it is assembled once per
//! step into a fixed Q1 pattern (all elements, so that a moving particle never changes it) and
//! solved for three right-hand sides by GMRES preconditioned with its ILU(0) factor
//! ([`Ilu0`]), started from the BDF2 extrapolation ŝ, to the relative residual [`ITERATIVE_TOL`]. The matrix is a
//! mass matrix plus convection and changes every step; a sparse LU of it (COLAMD order,
//! supernodal fill) cost ≈ 5× the rest of the transport step. Where the incomplete factor fails
//! or GMRES misses the tolerance in [`MAX_ITERATIONS`], that step is solved by LU (symbolic
//! analysis done once and reused), counted in [`TransportStats::lu_steps`].
//! Only the fluid part of cut elements is integrated (the per-element [`ElementCut`] override, as
//! in the flow solver); vertices that touch no fluid become identity rows with `s = 0` (`c = I`).
//! Walls have `u·n = 0` and SUPG needs no boundary term there; an inflow boundary (the extrudate's
//! die, thesis §6.4) prescribes s at its vertices ([`LogConformationTransport::set_inflow`]: the
//! rows become s = s_in, the fully developed state upstream).
//!
//! The L² projection of `c = exp(s)` (Eq. 5.28) and the Q1 evaluation helpers live in
//! [`constitutive_projection`](super::constitutive_projection); the polymer stress handed to the
//! flow solver in [`constitutive_stress`](super::constitutive_stress).

use std::time::Instant;

use crate::fem::element::{physical_gradients, q1, q2, q2_map, MapAt, RuleMaps};
use crate::fem::ilu::Ilu0;
use crate::fem::linsolve::{DirectSolver, SolveError};
use crate::fem::quadrature::gauss_quad;
use crate::fem::sparse::{q1_pattern, SparseMatrix};
use crate::mesh::Mesh;
use crate::rheology::{log_conformation_rhs, Giesekus, Sym2, VelocityGradient};
use crate::solver::ghost::{face_vertices, ghost_face_matrix, ghost_faces, FacePattern, GhostFace};
pub use crate::solver::log_conformation_history::LogConformationHistory;
use crate::solver::rigid::ElementCut;
pub use crate::solver::supg::{length_along, supg_tau, SupgVelocity};

/// Ghost-penalty factor γ of the transport: face coefficient γ (a0 h³ + |w| h²), the scale of
/// the mass and convection entries of the rows it stabilizes (a0 = 3/(2Δt) or 1/Δt, h the face
/// length, w = u − u_m). 1e-3 keeps the leading edge of a moving particle bounded and moves the
/// fixed-cylinder drag by less than 5e-4; 0.1 moved it by −1.4 % (docs/validation.md).
pub const GHOST_PENALTY: f64 = 1e-3;

/// Errors of the constitutive (stress) solve; each says what to change.
#[derive(Debug, thiserror::Error)]
pub enum ConstitutiveError {
    /// A linear solve (transport matrix or mass matrix) failed.
    #[error("{what} solve failed at step {step}: {source}")]
    Solve {
        /// Which system (`"log-conformation"` or `"Q1 projection"`).
        what: &'static str,
        /// Time step number (0 for set-up solves).
        step: usize,
        /// The solver error.
        #[source]
        source: SolveError,
    },
    /// The new log-conformation is not finite: the explicit g term or the convection blew up.
    #[error(
        "log-conformation not finite at vertex {vertex} after step {step}: reduce Δt \
         (the explicit g(G, ŝ) limits it to a fraction of λ and of 1/‖∇u‖)"
    )]
    NonFinite {
        /// Time step number.
        step: usize,
        /// First offending Q1 vertex.
        vertex: usize,
    },
    /// Time step not positive or not finite.
    #[error("time step Δt = {0} must be positive and finite")]
    TimeStep(f64),
}

/// The flow seen by the transport step, all at `t^{n+1}`.
#[derive(Debug, Clone, Copy)]
pub struct TransportFlow<'a> {
    /// Fluid velocity at the Q2 nodes.
    pub velocity: &'a [[f64; 2]],
    /// Mesh velocity `u_m` at the Q2 nodes (`None`: fixed mesh).
    pub mesh_velocity: Option<&'a [[f64; 2]]>,
    /// Velocity gradient G at the Q1 vertices, `[G_xx, G_xy, G_yx, G_yy]`, for g(G, ŝ).
    pub gradient: &'a [[f64; 4]],
}

/// Wall-clock seconds of the last transport step.
#[derive(Debug, Clone, Copy, Default)]
pub struct TransportTimings {
    /// Element loop and scatter (matrix and three right-hand sides).
    pub assembly: f64,
    /// Symbolic analysis (first step only).
    pub symbolic: f64,
    /// The incomplete factorization (and the numeric LU on a fallback step).
    pub factor: f64,
    /// GMRES for three right-hand sides (and the LU's triangular solves on a fallback step).
    pub solve: f64,
}

/// Nodal data of one element for the transport kernel.
#[derive(Debug, Clone, Copy)]
pub struct TransportElement<'a> {
    /// Physical coordinates of the Q2 nodes.
    pub xe: &'a [[f64; 2]; 9],
    /// Convective velocity `w = u − u_m` at the Q2 nodes.
    pub w: [[f64; 2]; 9],
    /// G at the Q1 corners.
    pub g: [[f64; 4]; 4],
    /// History term at the corners: `(c₁sⁿ − c₂s^{n−1})/Δt` (BDF2, [`Bdf2`](crate::solver::bdf::Bdf2)) or `sⁿ/Δt` (Euler).
    pub history: [Sym2; 4],
    /// Argument of g at the corners: `ŝ = (1+ω)sⁿ − ωs^{n−1}` (BDF2) or `sⁿ` (Euler).
    pub s_arg: [Sym2; 4],
}

/// Local SUPG matrix `k[a][b] = Σ_q w_q (ψ_a + τ w·∇ψ_a)(a0 ψ_b + w·∇ψ_b)` and right-hand sides
/// `f[a] = Σ_q w_q (ψ_a + τ w·∇ψ_a)(history + g(G, s_arg))` of one element (or its fluid part),
/// for the quadrature `points` (reference point, reference weight). `a0` is `c₀/Δt` (BDF2: 3/(2Δt) for equal steps) or
/// `1/Δt` (Euler). Overwrites `k` and `f`.
///
/// `maps`: the element map at the points ([`RuleMaps`]), if the caller tabulated it; else it is
/// evaluated at every point.
#[allow(clippy::too_many_arguments)]
pub fn transport_element_kernel(
    el: &TransportElement<'_>,
    points: &[([f64; 2], f64)],
    maps: Option<&[MapAt]>,
    model: &Giesekus,
    supg: SupgVelocity,
    dt: f64,
    a0: f64,
    k: &mut [[f64; 4]; 4],
    f: &mut [Sym2; 4],
) {
    *k = [[0.0; 4]; 4];
    *f = [Sym2::ZERO; 4];
    let mut dpsi = [[0.0; 2]; 4];
    for (q, &(xi, wref)) in points.iter().enumerate() {
        let (_, jac, det) = match maps {
            Some(m) => m[q],
            None => q2_map(el.xe, xi),
        };
        let (psi, dref) = q1(xi);
        physical_gradients(&jac, det, &dref, &mut dpsi);
        let n2 = q2(xi).0;
        let mut w = [0.0; 2];
        for a in 0..9 {
            w[0] += n2[a] * el.w[a][0];
            w[1] += n2[a] * el.w[a][1];
        }
        let mut g = [0.0; 4];
        let (mut hist, mut s_arg) = (Sym2::ZERO, Sym2::ZERO);
        for a in 0..4 {
            for ij in 0..4 {
                g[ij] += psi[a] * el.g[a][ij];
            }
            hist += psi[a] * el.history[a];
            s_arg += psi[a] * el.s_arg[a];
        }
        let l = VelocityGradient::new(g[0], g[1], g[2], g[3]);
        let source = hist + log_conformation_rhs(model, l, s_arg);
        let speed = (w[0] * w[0] + w[1] * w[1]).sqrt();
        let tau = supg.tau(speed, length_along(&jac, det, w), dt);
        let wq = wref * det;
        let mut conv = [0.0; 4];
        for a in 0..4 {
            conv[a] = w[0] * dpsi[a][0] + w[1] * dpsi[a][1];
        }
        for a in 0..4 {
            let test = wq * (psi[a] + tau * conv[a]);
            for b in 0..4 {
                k[a][b] += test * (a0 * psi[b] + conv[b]);
            }
            f[a] += test * source;
        }
    }
}

/// The matrix positions of the inflow rows' entries, and each active inflow vertex with the
/// position of its diagonal and its value.
type InflowRows = (Vec<usize>, Vec<(usize, usize, Sym2)>);

/// The log-conformation transport solver on one mesh topology: fixed Q1 pattern, LU with the
/// symbolic analysis done on the first step.
pub struct LogConformationTransport {
    n_vertices: usize,
    n_elements: usize,
    matrix: SparseMatrix,
    rhs: [Vec<f64>; 3],
    fixed: Vec<Option<f64>>,
    /// Vertices where s is prescribed (an inflow boundary), and the value there.
    inflow: Vec<(usize, Sym2)>,
    /// Positions in `matrix` of the inflow vertices' rows and diagonals (active vertices only),
    /// found once per pattern and cut set (`None`: to be found).
    inflow_rows: Option<InflowRows>,
    solver: Option<DirectSolver>,
    /// Incomplete factor of the iterative solve, and its solution buffers.
    ilu: Ilu0,
    solution: [Vec<f64>; 3],
    /// Solve by LU only (comparison mode; default: GMRES with ILU(0), LU as fallback).
    pub direct: bool,
    /// How the steps so far were solved.
    pub stats: TransportStats,
    rule: Vec<([f64; 2], f64)>,
    /// The element maps at the points of `rule`, for the mesh of the last assembly.
    rule_maps: RuleMaps,
    cuts: Vec<ElementCut>,
    /// Faces with a ghost penalty (interior faces of cut elements).
    ghost: Vec<GhostFace>,
    /// The faces the pattern of `matrix` holds.
    face_pattern: FacePattern,
    /// Ghost-penalty factor (default [`GHOST_PENALTY`]; 0 switches it off).
    pub ghost_penalty: f64,
    /// Characteristic velocity of the SUPG parameter (default: Case 1, the thesis' choice).
    pub supg: SupgVelocity,
    /// Timings of the last step.
    pub timings: TransportTimings,
}

impl std::fmt::Debug for LogConformationTransport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LogConformationTransport")
            .field("n_vertices", &self.n_vertices)
            .field("nnz", &self.matrix.nnz())
            .finish()
    }
}

impl LogConformationTransport {
    /// Builds the Q1 pattern of `mesh` (every element, so the pattern survives moving particles);
    /// all elements fluid.
    pub fn new(mesh: &Mesh) -> Self {
        let nv = mesh.n_vertices();
        let rule = gauss_quad(3);
        Self {
            n_vertices: nv,
            n_elements: mesh.n_elements(),
            matrix: q1_pattern(nv, &mesh.element_vertices),
            rhs: [vec![0.0; nv], vec![0.0; nv], vec![0.0; nv]],
            fixed: vec![None; nv],
            inflow: Vec::new(),
            inflow_rows: None,
            solver: None,
            ilu: Ilu0::default(),
            solution: [vec![0.0; nv], vec![0.0; nv], vec![0.0; nv]],
            direct: false,
            stats: TransportStats::default(),
            rule: rule.points.into_iter().zip(rule.weights).collect(),
            rule_maps: RuleMaps::default(),
            cuts: vec![ElementCut::Fluid; mesh.n_elements()],
            ghost: Vec::new(),
            face_pattern: FacePattern::default(),
            ghost_penalty: GHOST_PENALTY,
            supg: SupgVelocity::Local,
            timings: TransportTimings::default(),
        }
    }

    /// Sets the element classification (fluid / cut with its fluid-part quadrature / inside):
    /// vertices touching no fluid become identity rows holding `s = 0`.
    ///
    /// # Panics
    /// If `cuts.len()` differs from the number of elements.
    pub fn set_cuts(&mut self, mesh: &Mesh, cuts: Vec<ElementCut>) {
        assert_eq!(cuts.len(), self.n_elements, "one ElementCut per element");
        self.fixed = inactive_vertices(mesh, &cuts);
        self.inflow_rows = None;
        let ghost = ghost_faces(mesh, &cuts);
        // the faces couple vertices of neighbouring elements: a new pattern when they leave
        // those the last one was built for
        if let Some(matrix) = self.face_pattern.matrix_for(mesh, &ghost) {
            self.matrix = matrix;
            self.solver = None;
        }
        self.ghost = ghost;
        self.cuts = cuts;
    }

    /// Prescribes s at the vertices of an inflow boundary, `(vertex, s_in)`, for every step (an
    /// inactive vertex keeps its identity row with s = 0).
    pub fn set_inflow(&mut self, inflow: Vec<(usize, Sym2)>) {
        assert!(
            inflow.iter().all(|&(v, _)| v < self.n_vertices),
            "inflow vertex"
        );
        self.inflow = inflow;
        self.inflow_rows = None;
    }

    /// Replaces the rows of the inflow vertices by s = s_in (after assembly; the LU solver needs
    /// no symmetry). The rows' positions are found once per pattern and cut set.
    fn apply_inflow(&mut self) {
        if self.inflow.is_empty() {
            return;
        }
        let (rows, diagonals) = self.inflow_rows.get_or_insert_with(|| {
            let mut row = vec![false; self.n_vertices];
            for &(v, _) in &self.inflow {
                row[v] = self.fixed[v].is_none();
            }
            let mut rows = Vec::new();
            for j in 0..self.n_vertices {
                let (col, range) = self.matrix.column(j);
                rows.extend(
                    col.iter()
                        .zip(range)
                        .filter(|&(&i, _)| row[i])
                        .map(|(_, p)| p),
                );
            }
            let diagonals = self
                .inflow
                .iter()
                .filter(|&&(v, _)| row[v])
                .map(|&(v, s)| (v, self.matrix.position(v, v), s))
                .collect();
            (rows, diagonals)
        });
        for &p in rows.iter() {
            self.matrix.values[p] = 0.0;
        }
        for &(v, p, s) in diagonals.iter() {
            self.matrix.values[p] = 1.0;
            self.rhs[0][v] = s.xx;
            self.rhs[1][v] = s.xy;
            self.rhs[2][v] = s.yy;
        }
    }

    /// Number of unknowns per component and stored matrix entries.
    pub fn size(&self) -> (usize, usize) {
        (self.n_vertices, self.matrix.nnz())
    }

    /// One step `sⁿ → s^{n+1}` (Euler when `history.previous` is `None`, BDF2 otherwise) in the
    /// flow at `t^{n+1}`; shifts the history.
    ///
    /// # Errors
    /// [`ConstitutiveError::TimeStep`] for a bad `dt`; [`ConstitutiveError::Solve`] if the LU
    /// fails; [`ConstitutiveError::NonFinite`] if the result is not finite.
    ///
    /// # Panics
    /// If `mesh`, `history` or `flow` do not match the topology given at construction.
    pub fn step(
        &mut self,
        mesh: &Mesh,
        model: &Giesekus,
        dt: f64,
        flow: &TransportFlow<'_>,
        history: &mut LogConformationHistory,
    ) -> Result<(), ConstitutiveError> {
        if !(dt > 0.0 && dt.is_finite()) {
            return Err(ConstitutiveError::TimeStep(dt));
        }
        assert_eq!(mesh.n_vertices(), self.n_vertices, "mesh topology changed");
        assert_eq!(mesh.n_elements(), self.n_elements, "mesh topology changed");
        assert_eq!(history.current.len(), self.n_vertices, "history size");
        assert_eq!(flow.velocity.len(), mesh.n_nodes(), "velocity size");
        assert_eq!(flow.gradient.len(), self.n_vertices, "gradient size");
        let step = history.steps() + 1;
        let t0 = Instant::now();
        self.assemble(mesh, model, dt, flow, history);
        let t1 = Instant::now();
        let (symbolic, factor, solve) = match self.solve_iteratively(history, dt) {
            Some(times) => (0.0, times.0, times.1),
            None => self.solve_directly(step)?,
        };
        // shift: s^{n−1} ← sⁿ, sⁿ ← new (reusing the old s^{n−1} buffer)
        let mut next = history
            .previous
            .take()
            .unwrap_or_else(|| vec![Sym2::ZERO; self.n_vertices]);
        for (v, s) in next.iter_mut().enumerate() {
            *s = Sym2::new(self.rhs[0][v], self.rhs[1][v], self.rhs[2][v]);
            if !s.is_finite() {
                return Err(ConstitutiveError::NonFinite { step, vertex: v });
            }
        }
        history.push(next, dt);
        self.timings = TransportTimings {
            assembly: (t1 - t0).as_secs_f64(),
            symbolic,
            factor,
            solve,
        };
        Ok(())
    }

    fn assemble(
        &mut self,
        mesh: &Mesh,
        model: &Giesekus,
        dt: f64,
        flow: &TransportFlow<'_>,
        history: &LogConformationHistory,
    ) {
        self.matrix.zero();
        self.rhs.iter_mut().for_each(|r| r.fill(0.0));
        let bdf = history.bdf2(dt);
        let previous = history.previous.as_deref();
        let a0 = bdf.c0 / dt;
        let (w1, w0) = bdf.extrapolation();
        let (mut k, mut f) = ([[0.0; 4]; 4], [Sym2::ZERO; 4]);
        let mut kflat = [0.0; 16];
        let mut fc = [0.0; 4];
        if !self.rule_maps.fits(mesh) {
            let points: Vec<[f64; 2]> = self.rule.iter().map(|&(xi, _)| xi).collect();
            self.rule_maps = RuleMaps::of(mesh, &points);
        }
        for e in 0..self.n_elements {
            let (points, maps): (&[([f64; 2], f64)], _) = match &self.cuts[e] {
                ElementCut::Inside => continue,
                ElementCut::Fluid => (&self.rule, Some(&self.rule_maps.at(e)[..])),
                ElementCut::Cut(c) => (&c.vol, None),
            };
            let nodes = &mesh.elements[e];
            let verts = &mesh.element_vertices[e];
            let mut el = TransportElement {
                xe: &mesh.element_coords[e],
                w: [[0.0; 2]; 9],
                g: [[0.0; 4]; 4],
                history: [Sym2::ZERO; 4],
                s_arg: [Sym2::ZERO; 4],
            };
            for a in 0..9 {
                let u = flow.velocity[nodes[a]];
                let um = flow.mesh_velocity.map_or([0.0; 2], |m| m[nodes[a]]);
                el.w[a] = [u[0] - um[0], u[1] - um[1]];
            }
            for a in 0..4 {
                let v = verts[a];
                el.g[a] = flow.gradient[v];
                let sn = history.current[v];
                match previous {
                    Some(prev) => {
                        el.history[a] = (1.0 / dt) * (bdf.c1 * sn - bdf.c2 * prev[v]);
                        el.s_arg[a] = w1 * sn + w0 * prev[v];
                    }
                    None => {
                        el.history[a] = (1.0 / dt) * sn;
                        el.s_arg[a] = sn;
                    }
                }
            }
            transport_element_kernel(&el, points, maps, model, self.supg, dt, a0, &mut k, &mut f);
            for a in 0..4 {
                kflat[4 * a..4 * a + 4].copy_from_slice(&k[a]);
            }
            // the matrix once (with the xx load), then the other two loads
            for a in 0..4 {
                fc[a] = f[a].xx;
            }
            self.matrix
                .scatter(verts, &kflat, &fc, &mut self.rhs[0], &self.fixed);
            for a in 0..4 {
                if self.fixed[verts[a]].is_none() {
                    self.rhs[1][verts[a]] += f[a].xy;
                    self.rhs[2][verts[a]] += f[a].yy;
                }
            }
        }
        if self.ghost_penalty > 0.0 {
            let mut kg = [0.0; 64];
            let zero = [0.0; 8];
            for face in &self.ghost {
                let h = ghost_face_matrix(mesh, face, &mut kg);
                let speed = [face.first, face.second]
                    .iter()
                    .flat_map(|&e| mesh.elements[e].iter())
                    .map(|&n| {
                        let u = flow.velocity[n];
                        let um = flow.mesh_velocity.map_or([0.0; 2], |m| m[n]);
                        (u[0] - um[0]).hypot(u[1] - um[1])
                    })
                    .fold(0.0, f64::max);
                let verts = face_vertices(mesh, face);
                // the time-derivative part penalizes the jump of the discrete derivative
                // (a0 s^{n+1} − history), so the penalty does not damp s at a rate 1/Δt
                let mass = self.ghost_penalty * h * h * h;
                let hist = verts.map(|j| match previous {
                    Some(prev) => (1.0 / dt) * (bdf.c1 * history.current[j] - bdf.c2 * prev[j]),
                    None => (1.0 / dt) * history.current[j],
                });
                for a in 0..8 {
                    if self.fixed[verts[a]].is_some() {
                        continue;
                    }
                    let i = verts[a];
                    let mut load = Sym2::ZERO;
                    for b in 0..8 {
                        load += (mass * kg[8 * a + b]) * hist[b];
                    }
                    self.rhs[0][i] += load.xx;
                    self.rhs[1][i] += load.xy;
                    self.rhs[2][i] += load.yy;
                }
                let gamma = self.ghost_penalty * (a0 * h * h * h + speed * h * h);
                kg.iter_mut().for_each(|v| *v *= gamma);
                // the constrained (inactive) vertices hold s = 0: eliminating them adds nothing
                self.matrix
                    .scatter(&verts, &kg, &zero, &mut self.rhs[0], &self.fixed);
            }
        }
        self.matrix.apply_constraints(&mut self.rhs[0], &self.fixed);
        for (v, fx) in self.fixed.iter().enumerate() {
            if let Some(val) = fx {
                self.rhs[1][v] = *val;
                self.rhs[2][v] = *val;
            }
        }
        self.apply_inflow();
    }
}

/// `Some(0.0)` for the Q1 vertices that touch no fluid element, `None` elsewhere.
pub fn inactive_vertices(mesh: &Mesh, cuts: &[ElementCut]) -> Vec<Option<f64>> {
    let mut active = vec![false; mesh.n_vertices()];
    for (e, cut) in cuts.iter().enumerate() {
        if !matches!(cut, ElementCut::Inside) {
            mesh.element_vertices[e]
                .iter()
                .for_each(|&v| active[v] = true);
        }
    }
    active
        .into_iter()
        .map(|a| if a { None } else { Some(0.0) })
        .collect()
}

mod linear_solve;
#[cfg(test)]
mod tests;

pub use linear_solve::{TransportStats, ITERATIVE_TOL, MAX_ITERATIONS};
