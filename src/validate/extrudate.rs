//! Extrudate swell (thesis §6.4, Table 6.3), the Newtonian limit De = 0: a planar die of
//! half-width H0 = 1 and length 2 (x ∈ [−2, 0]), an extrudate of length 3 (x ∈ [0, 3]) whose free
//! surface y = H(x, t) is immersed in the fixed mesh ([`crate::solver::free_surface`]), flow rate
//! Q = 1 per half-width (the Crochet–Keunings set-up). Boundary conditions (Eqs. 6.8–6.14): the
//! fully developed profile u = (3/2)(1 − y²) at the inflow (Q = 1, which the thesis imposes by a
//! multiplier with open conditions; the profile is what that gives 2 widths upstream of the exit
//! for a Newtonian fluid), no-slip on the die wall y = H0 (a grid line), symmetry u_y = 0 on
//! y = 0, and traction-free outflow and free surface (natural). The surface starts flat
//! (Eq. 6.16) and moves by the kinematic equation with the velocity of the Stokes flow on the
//! predicted surface (§6.3.4 steps 1, 3 and 5) until max|Hⁿ⁺¹ − Hⁿ| < [`STEADY_HEIGHT_TOL`]
//! (the thesis' 10⁻⁷); the swell ratio is H_max/H0. Published (Table 6.3, De = 0): 1.188 on
//! the thesis' meshes M2–M4, the boundary-fitted reference and Crochet & Keunings alike.

use crate::fem::element::q2;
use crate::fem::linsolve::SolverKind;
use crate::mesh::{Axis, Mesh, Side};
use crate::solver::cutcells::{surface_cuts, CutError};
use crate::solver::flow::{FlowFactorization, Stokes, StokesParams};
use crate::solver::free_surface::HeightFunction;
use crate::xfem::CutOptions;

/// The steady test of §6.4: every surface node moves less than this in a step.
pub const STEADY_HEIGHT_TOL: f64 = 1e-7;

/// The published Newtonian swell ratio (Table 6.3, De = 0: M2–M4, MBFM and Crochet & Keunings).
pub const NEWTONIAN_SWELL: f64 = 1.188;

/// The verdict's tolerance on the swell extrapolated from the two finest meshes: Table 6.3
/// prints three decimals (±5e-4) and its coarsest mesh (M1) is 1e-3 off; the first-order
/// extrapolation of a corner-singular solution adds its own error of that order.
pub const SWELL_TOL: f64 = 1.5e-3;

/// The time step of the study and the longest time it runs (the surface is steady by t ≈ 6).
pub const SWELL_DT: f64 = 0.05;
/// See [`SWELL_DT`].
pub const SWELL_T_MAX: f64 = 40.0;

/// Richardson extrapolation of swells on meshes h and h/2 with the observed order `order` (the
/// die-exit corner makes the error first order on uniform meshes: measured 1.0).
pub fn extrapolate(coarse: f64, fine: f64, order: f64) -> f64 {
    fine + (fine - coarse) / (2f64.powf(order) - 1.0)
}

/// Die half-width H0, die length and extrudate length (thesis §6.4).
const H0: f64 = 1.0;
const DIE_LENGTH: f64 = 2.0;
const EXTRUDATE_LENGTH: f64 = 3.0;
/// Height of the mesh above the symmetry line (room for the swell).
const MESH_HEIGHT: f64 = 1.5;

/// What one mesh gave.
#[derive(Debug, Clone)]
pub struct SwellRun {
    /// Element size.
    pub h: f64,
    /// Elements of the fixed mesh, and those with fluid at the end.
    pub elements: (usize, usize),
    /// H_max/H0 at the end.
    pub swell: f64,
    /// Steps taken.
    pub steps: usize,
    /// Whether the steady test was met before `t_max`.
    pub steady: bool,
    /// max|Hⁿ⁺¹ − Hⁿ| of the last step.
    pub last_change: f64,
    /// The surface at the end: (x, H).
    pub profile: Vec<(f64, f64)>,
    /// Wall-clock seconds.
    pub seconds: f64,
}

/// Errors of the study.
#[derive(Debug, thiserror::Error)]
pub enum SwellError {
    /// The cut cells failed.
    #[error(transparent)]
    Cut(#[from] CutError),
    /// The flow solve failed.
    #[error("step {step}: {source}")]
    Solve {
        /// Step.
        step: usize,
        /// Cause.
        source: crate::fem::linsolve::SolveError,
    },
    /// A surface point left the mesh (it rose above the mesh height).
    #[error("step {step}: the free surface left the mesh at x = {x} (H = {height})")]
    Escaped {
        /// Step.
        step: usize,
        /// Where.
        x: f64,
        /// Its height.
        height: f64,
    },
}

/// The Newtonian extrudate swell on a uniform mesh of element size `h` (1/h an integer: the die
/// wall is a grid line), time step `dt`, until the steady test or `t_max`.
///
/// # Errors
/// [`SwellError`].
pub fn newtonian_swell(h: f64, dt: f64, t_max: f64) -> Result<SwellRun, SwellError> {
    let start = std::time::Instant::now();
    let nx = ((DIE_LENGTH + EXTRUDATE_LENGTH) / h).round() as usize;
    let ny = (MESH_HEIGHT / h).round() as usize;
    let ax = Axis::uniform(-DIE_LENGTH, EXTRUDATE_LENGTH, nx);
    // the surface's nodes: the Q2 node columns from the die exit on (two P1 per Q2 element)
    let exit = (2.0 * DIE_LENGTH / h).round() as usize;
    let xs: Vec<f64> = (exit..=2 * nx).map(|i| ax.q2_coord(i)).collect();
    let mesh = Mesh::rectangle(ax, Axis::uniform(0.0, MESH_HEIGHT, ny), false);
    let mut surface = HeightFunction::flat(xs, H0);
    let on = move |a: f64, b: f64| (a - b).abs() < 1e-9 * h;
    // one flow solver for the whole run: a new surface gives new cuts; the pattern and its
    // symbolic factorization last while the surface stays within their band (`set_particles`)
    let cuts = surface_cuts(&mesh, &surface.level_set(h), CutOptions::default())?;
    let mut params = StokesParams::new(1.0, 0.0, SolverKind::Lblt);
    params.factorization = FlowFactorization::Whole;
    let mut flow = Stokes::with_particles(mesh.clone(), params, Vec::new(), cuts);
    flow.set_velocity(Side::Left, |x| {
        [
            if x[1] <= H0 {
                1.5 * (1.0 - x[1] * x[1])
            } else {
                0.0
            },
            0.0,
        ]
    });
    flow.set_velocity_where(move |x| {
        if x[0] <= 1e-9 && on(x[1], H0) {
            [Some(0.0), Some(0.0)] // die wall
        } else if on(x[1], 0.0) {
            [None, Some(0.0)] // symmetry line
        } else {
            [None, None]
        }
    });
    let (mut steps, mut change, mut fluid_elements) = (0, f64::INFINITY, 0);
    while change >= STEADY_HEIGHT_TOL && (steps as f64) * dt < t_max - 1e-12 {
        let predicted = surface.predicted(dt, dt);
        let cuts = surface_cuts(&mesh, &predicted.level_set(h), CutOptions::default())?;
        fluid_elements = cuts
            .iter()
            .filter(|c| !matches!(c, crate::solver::rigid::ElementCut::Inside))
            .count();
        flow.set_particles(Vec::new(), cuts);
        let sol = flow
            .solve(&|_| [0.0, 0.0])
            .map_err(|source| SwellError::Solve {
                step: steps,
                source,
            })?;
        let mut u = Vec::with_capacity(predicted.nodes().len());
        for (&x, &y) in predicted.nodes().iter().zip(predicted.heights()) {
            let Some((e, xi)) = mesh.locate([x, y]) else {
                return Err(SwellError::Escaped {
                    step: steps,
                    x,
                    height: y,
                });
            };
            let (n, _) = q2(xi);
            let mut v = [0.0; 2];
            for (k, &node) in mesh.elements[e].iter().enumerate() {
                v[0] += n[k] * sol.u[node][0];
                v[1] += n[k] * sol.u[node][1];
            }
            u.push(v);
        }
        change = surface.advance(&u, dt, dt);
        steps += 1;
        if surface.max() >= MESH_HEIGHT - h {
            let i = surface
                .heights()
                .iter()
                .position(|&y| y >= MESH_HEIGHT - h)
                .unwrap_or(0);
            return Err(SwellError::Escaped {
                step: steps,
                x: surface.nodes()[i],
                height: surface.heights()[i],
            });
        }
    }
    Ok(SwellRun {
        h,
        elements: (mesh.n_elements(), fluid_elements),
        swell: surface.max() / H0,
        steps,
        steady: change < STEADY_HEIGHT_TOL,
        last_change: change,
        profile: surface
            .nodes()
            .iter()
            .copied()
            .zip(surface.heights().iter().copied())
            .collect(),
        seconds: start.elapsed().as_secs_f64(),
    })
}
