//! Extrudate swell (thesis §6.4, Table 6.3): a planar die of half-width H0 = 1 and length 2
//! (x ∈ [−2, 0]), an extrudate of length 3 (x ∈ [0, 3]) whose free surface y = H(x, t) is
//! immersed in the fixed mesh ([`crate::solver::free_surface`]), flow rate Q = 1 per half-width
//! (the Crochet–Keunings set-up), a Newtonian fluid (De = 0) or a UCM fluid. The study is an
//! `extrusion` case without particles run through the one simulation path
//! ([`crate::simulate::Simulation`], as `xpflow run` and the sweeps run it; the boundary
//! conditions and the start are `solver::moving::surface`'s): the surface starts flat
//! (Eq. 6.16) and moves by the kinematic equation until max|Hⁿ⁺¹ − Hⁿ| < [`STEADY_HEIGHT_TOL`]
//! (the thesis' 10⁻⁷); the swell ratio is H_max/H0. Published (Table 6.3, De = 0): 1.188 on
//! the thesis' meshes M2–M4, the boundary-fitted reference and Crochet & Keunings alike.

use crate::config::{CaseSpec, SpecError, MAX_DT_OVER_LAMBDA};
use crate::geometry::extrusion::{EXIT_BAND, EXIT_GROWTH};
use crate::simulate::{SetupError, Simulation};
use crate::solver::constitutive_projection::sym_at;
use crate::solver::moving::{die_log_conformation, MovingError, StepOutcome};

pub use crate::solver::free_surface::STEADY_HEIGHT_TOL;

/// The published Newtonian swell ratio (Table 6.3, De = 0: M2–M4, MBFM and Crochet & Keunings).
pub const NEWTONIAN_SWELL: f64 = 1.188;

/// Table 6.3 of the thesis: De, then the swell ratio on its finest mesh M4 (6080 → 9187
/// elements agree to three decimals up to De = 0.75), the moving boundary-fitted mesh (MBFM; `None`:
/// unstable) and Crochet & Keunings (`None`: not published).
pub const PUBLISHED_SWELL: [(f64, f64, Option<f64>, Option<f64>); 9] = [
    (0.0, 1.188, Some(1.188), Some(1.188)),
    (0.25, 1.168, Some(1.169), Some(1.169)),
    (0.5, 1.189, Some(1.191), Some(1.189)),
    (0.6, 1.203, Some(1.207), Some(1.205)),
    (0.75, 1.232, Some(1.237), Some(1.236)),
    (1.0, 1.290, None, None),
    (1.25, 1.362, None, None),
    (1.5, 1.448, None, None),
    (1.7, 1.526, None, None),
];

/// The thesis' M4 swell at Deborah number `de` (Table 6.3), if it printed one.
pub fn published_swell(de: f64) -> Option<f64> {
    PUBLISHED_SWELL
        .iter()
        .find(|r| (r.0 - de).abs() < 1e-9)
        .map(|r| r.1)
}

/// The tolerance against Table 6.3 up to De = 0.75 (relative): the spread of the
/// published values there (M4, MBFM, Crochet & Keunings differ by up to 0.4 %).
pub const VISCOELASTIC_SWELL_TOL: f64 = 5e-3;

/// The verdict's tolerance on the swell extrapolated from the two finest meshes: Table 6.3
/// prints three decimals (±5e-4) and its coarsest mesh (M1) is 1e-3 off; the first-order
/// extrapolation of a corner-singular solution adds its own error of that order.
pub const SWELL_TOL: f64 = 1.5e-3;

/// The time step of the study and the longest time it runs (the surface is steady by t ≈ 6).
pub const SWELL_DT: f64 = 0.05;
/// See [`SWELL_DT`].
pub const SWELL_T_MAX: f64 = 40.0;

/// The study's time step at Deborah number `de`: [`SWELL_DT`], or below λ = De/3 at low De the
/// largest multiple of 0.01 within [`MAX_DT_OVER_LAMBDA`] λ (the cases' limit on an explicit
/// relaxation term: 0.04 at De = 0.25, as `sweeps/extrudate_swell.toml`).
pub fn swell_dt(de: f64) -> f64 {
    let limit = MAX_DT_OVER_LAMBDA * de / 3.0;
    if de == 0.0 || SWELL_DT <= limit {
        SWELL_DT
    } else {
        ((limit * 100.0 + 1e-9).floor() / 100.0).max(0.001)
    }
}

/// Richardson extrapolation of swells on meshes h and h/2 with the observed order `order` (the
/// die-exit corner makes the error first order on uniform meshes: measured 1.0).
pub fn extrapolate(coarse: f64, fine: f64, order: f64) -> f64 {
    fine + (fine - coarse) / (2f64.powf(order) - 1.0)
}

/// Die half-width H0, die length and extrudate length (thesis §6.4).
const H0: f64 = 1.0;
const DIE_LENGTH: f64 = 2.0;
const EXTRUDATE_LENGTH: f64 = 3.0;
/// Height of the mesh above the symmetry line: room for the swell (Table 6.3: up to 1.24 for
/// De ≤ 0.75, 1.53 at De = 1.7).
fn mesh_height(de: f64) -> f64 {
    if de <= 0.75 {
        1.5
    } else {
        2.0
    }
}

/// The mesh of the study: element size `h` uniform, or (`graded`) refined around the die-exit
/// corner (0, H0), where the stress is singular: `numerics.die_exit = { h }`, i.e. `h` in the
/// square of half-width [`EXIT_BAND`] and elements growing by [`EXIT_GROWTH`] away from it (the
/// thesis' meshes M1–M4 are refined there, §6.4). Grid lines on x = 0 and y = H0 either way.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SwellMesh {
    /// Element size (at the die exit, when graded).
    pub h: f64,
    /// Refined around the die exit, coarser away from it.
    pub graded: bool,
}

impl SwellMesh {
    /// The study at Deborah number `de` as a case: the set-up above, a Newtonian fluid (De = 0) or
    /// UCM (Oldroyd-B with β = 0, Wi = λU/H0 = De/3), time step `dt` to `t_max`.
    ///
    /// # Errors
    /// What the case's validation refuses (e.g. Δt above [`MAX_DT_OVER_LAMBDA`] λ: see
    /// [`swell_dt`]).
    pub fn case(&self, de: f64, dt: f64, t_max: f64) -> Result<CaseSpec, SpecError> {
        let top = mesh_height(de);
        let numerics = if self.graded {
            serde_json::json!({
                "die_exit": { "h": self.h, "band": EXIT_BAND, "growth": EXIT_GROWTH },
                "dt": dt, "t_end": t_max
            })
        } else {
            let nx = ((DIE_LENGTH + EXTRUDATE_LENGTH) / self.h).round() as usize;
            let ny = (top / self.h).round() as usize;
            serde_json::json!({ "mesh": [nx, ny], "dt": dt, "t_end": t_max })
        };
        let fluid = if de == 0.0 {
            serde_json::json!({ "model": "newtonian", "wi": 0.0 })
        } else {
            serde_json::json!({ "model": "oldroyd_b", "wi": de / 3.0 })
        };
        CaseSpec::from_value(serde_json::json!({
            "geometry": { "extrusion": {
                "h0": H0, "die_length": DIE_LENGTH, "extrudate_length": EXTRUDATE_LENGTH,
                "flow_rate": 1.0, "height": top
            } },
            "fluid": fluid,
            "numerics": numerics,
            "output": { "sample_every": 1, "snapshot_every": 0 }
        }))
    }
}

/// What one mesh gave.
#[derive(Debug, Clone)]
pub struct SwellRun {
    /// Element size.
    pub h: f64,
    /// Elements of the fixed mesh.
    pub elements: usize,
    /// H_max/H0 at the end.
    pub swell: f64,
    /// Steps taken.
    pub steps: u64,
    /// Whether the steady test was met before `t_max`.
    pub steady: bool,
    /// max|Hⁿ⁺¹ − Hⁿ| of the last step.
    pub last_change: f64,
    /// Largest relative difference of the conformation in the die (x = −1.5, −1; y = 0.25 … 0.9)
    /// from the fully developed one at the end (0 for a Newtonian fluid).
    pub die_error: f64,
    /// The surface at the end: (x, H).
    pub profile: Vec<(f64, f64)>,
    /// How the surface approached its end, one sample per step.
    pub history: Vec<SwellSample>,
    /// Wall-clock seconds.
    pub seconds: f64,
}

/// The surface after one step of [`swell`]: whether and where it still moves.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SwellSample {
    /// Time after the step.
    pub t: f64,
    /// H_max/H0.
    pub swell: f64,
    /// max|Hⁿ⁺¹ − Hⁿ| over the surface's nodes (the steady test's quantity).
    pub change: f64,
    /// Hⁿ⁺¹ − Hⁿ at that node (its sign: rising or falling).
    pub signed_change: f64,
    /// x of that node (0 at the die exit).
    pub x_change: f64,
}

impl SwellSample {
    /// The sample of a step that took the surface from the heights `before` to `after` on
    /// `nodes`.
    fn between(t: f64, nodes: &[f64], before: &[f64], after: &[f64]) -> Self {
        let (i, d) = before
            .iter()
            .zip(after)
            .map(|(b, a)| a - b)
            .enumerate()
            .fold((0, 0.0), |(i, d), (j, e)| {
                if e.abs() > f64::abs(d) {
                    (j, e)
                } else {
                    (i, d)
                }
            });
        let max = after.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        Self {
            t,
            swell: max / H0,
            change: d.abs(),
            signed_change: d,
            x_change: nodes[i],
        }
    }
}

/// Errors of the study.
#[derive(Debug, thiserror::Error)]
pub enum SwellError {
    /// The case's validation refused the study's parameters.
    #[error("{0}")]
    Case(#[from] SpecError),
    /// The case could not be set up (or its first solve failed).
    #[error(transparent)]
    SetUp(#[from] SetupError),
    /// A step failed (a solve, a non-finite stress, the surface leaving the mesh).
    #[error("step {step}: {source}")]
    Step {
        /// Step.
        step: u64,
        /// Cause.
        source: MovingError,
    },
}

/// The Newtonian extrudate swell: [`swell`] at De = 0.
///
/// # Errors
/// [`SwellError`].
pub fn newtonian_swell(h: f64, dt: f64, t_max: f64) -> Result<SwellRun, SwellError> {
    swell(SwellMesh { h, graded: false }, 0.0, dt, t_max)
}

/// The extrudate swell at Deborah number `de` = λγ̇_w (γ̇_w = 3: De = 0 is Newtonian, De > 0 the
/// UCM fluid of §6.4, η_s = 0, η_p = 1, λ = De/3, semi-implicit stress coupling) on the mesh
/// `grid`, time step `dt`, until the steady test or `t_max`: the case [`SwellMesh::case`] stepped
/// by the one simulation path. The stress enters fully developed at the inflow and fills the die
/// at the start; the extrudate starts stress-free (`solver::moving::surface`).
///
/// # Errors
/// [`SwellError`].
pub fn swell(grid: SwellMesh, de: f64, dt: f64, t_max: f64) -> Result<SwellRun, SwellError> {
    let start = std::time::Instant::now();
    let case = grid.case(de, dt, t_max)?;
    let mut sim = Simulation::new(&case)?;
    let mut change = f64::INFINITY;
    let mut history = Vec::new();
    let no_surface = "an extrusion case has a free surface";
    // Hⁿ, overwritten after each step (no allocation per step)
    let mut before = sim
        .stepper()
        .surface()
        .expect(no_surface)
        .heights()
        .to_vec();
    while change >= STEADY_HEIGHT_TOL && !sim.at_end() {
        let step = sim.steps();
        let failed = |source| SwellError::Step { step, source };
        match sim.step().map_err(failed)? {
            StepOutcome::Stepped(_) => {}
            // (no particles: nothing to touch)
            StepOutcome::Contact(c) | StepOutcome::ContactAfter(_, c) => {
                unreachable!("a contact without particles: {c:?}")
            }
        }
        change = sim.stepper().surface_change().unwrap_or(f64::INFINITY);
        let after = sim.stepper().surface().expect(no_surface);
        history.push(SwellSample::between(
            sim.time(),
            after.nodes(),
            &before,
            after.heights(),
        ));
        before.copy_from_slice(after.heights());
    }
    let flow = sim.stepper().flow();
    let mesh = flow.mesh();
    // the die's fully developed state, away from the inflow and the exit
    let mut die_error: f64 = 0.0;
    if de > 0.0 {
        let (lambda, die) = (
            case.relaxation_time(),
            case.extrusion().expect("an extrusion"),
        );
        for x in [-1.5, -1.0] {
            for y in [0.25, 0.5, 0.75, 0.9] {
                let (e, xi) = mesh.locate([x, y]).expect("the die lies in the mesh");
                let c = sym_at(mesh, flow.conformation(), e, xi);
                let want = die_log_conformation(&die, lambda, 0.0, y).exp();
                die_error = die_error.max((c - want).norm() / want.norm());
            }
        }
    }
    let surface = sim
        .stepper()
        .surface()
        .expect("an extrusion case has a free surface");
    Ok(SwellRun {
        h: grid.h,
        elements: mesh.n_elements(),
        swell: surface.max() / H0,
        steps: sim.steps(),
        steady: change < STEADY_HEIGHT_TOL,
        last_change: change,
        die_error,
        profile: surface
            .nodes()
            .iter()
            .copied()
            .zip(surface.heights().iter().copied())
            .collect(),
        history,
        seconds: start.elapsed().as_secs_f64(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_sample_names_the_largest_change_with_its_sign_and_place() {
        let nodes = [0.0, 0.5, 1.0, 1.5];
        let before = [1.0, 1.10, 1.15, 1.16];
        let after = [1.0, 1.11, 1.13, 1.161];
        let s = SwellSample::between(2.5, &nodes, &before, &after);
        assert_eq!(s.t, 2.5);
        assert_eq!(s.x_change, 1.0, "the node that moved most");
        assert!((s.signed_change + 0.02).abs() < 1e-12, "falling there");
        assert!((s.change - 0.02).abs() < 1e-12);
        assert!(
            (s.swell - 1.161).abs() < 1e-12,
            "the largest height after the step"
        );
    }
}
