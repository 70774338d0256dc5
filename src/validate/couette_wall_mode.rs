//! The explicit coupling's wall mode in the circular Couette cell (issue 26, docs/validation.md
//! "The explicit coupling's wall mode"): the undisturbed Giesekus flow of the thesis' cell
//! (R2/R1 = 4, β = 0.1, α = 0.01) on the Couette family's 45×240 mesh, from rest with the
//! log-conformation seeded by an m = 9 perturbation at the inner cylinder. Measured: the growth
//! rate of the m = 9 Fourier component of tr c on the first vertex ring (r = R1 + h_r) once the
//! base flow has developed. At Wi = 1 the explicit coupling grows it at Δt = 0.08 (+0.134 per t*)
//! and damps it at 0.02; the semi-implicit stress damps it at 0.08.

use crate::geometry::CouetteGeometry;
use crate::rheology::Sym2;
use crate::solver::constitutive_stress::Coupling;
use crate::solver::moving::apply_walls;
use crate::solver::viscoelastic::{ViscoelasticError, ViscoelasticFlow, ViscoelasticParams};

/// The thesis' cell's viscosity ratio β = η_s/η0 (η0 = 1).
pub const BETA: f64 = 0.1;
/// The family's Giesekus mobility.
pub const ALPHA: f64 = 0.01;
/// The family's mesh: θ × r elements (the study's default; family (iv)'s ε = 2/15 runs on
/// 480 × 90).
pub const MESH: [usize; 2] = [240, 45];
/// The study's own Weissenberg number and step (with [`MESH`]: the set-up its verdict is for, the
/// one the Couette family's explicit runs broke down at).
pub const STUDY_WI: f64 = 1.0;
/// See [`STUDY_WI`].
pub const STUDY_DT: f64 = 0.08;
/// The seeded azimuthal wavenumber (the one the particle's run grew).
pub const WAVENUMBER: f64 = 9.0;
/// Start of the fit: the base flow has developed (≈ 7λ at Wi = 1).
pub const FIT_FROM: f64 = 20.0;
/// End of the fit and of each run.
pub const T_END: f64 = 36.0;
/// A growth rate (per unit t*) above this is the mode growing: with the particle (rotating
/// frame, adaptive Δt at 0.08) it grew at 0.122, without it at Δt = 0.08 at 0.134.
pub const GROWING: f64 = 0.05;
/// Seed amplitude of the log-conformation perturbation.
pub const SEED: f64 = 1e-2;
/// Radial decay length of the seed away from the inner cylinder.
pub const SEED_DEPTH: f64 = 0.1;
/// How often |c_m| is sampled (time units).
pub const SAMPLE_EVERY: f64 = 4.0;

/// One run of the seeded undisturbed flow.
#[derive(Debug, Clone)]
pub struct WallModeRun {
    /// Coupling of the polymer stress.
    pub coupling: Coupling,
    /// Time step.
    pub dt: f64,
    /// (t*, |c_m|) at the first step at or past each multiple of [`SAMPLE_EVERY`].
    pub samples: Vec<(f64, f64)>,
}

impl WallModeRun {
    /// Growth rate of |c_m| per unit t* from the first sample at or after [`FIT_FROM`] to the
    /// last one (at [`T_END`], or the first step past it when Δt does not divide it).
    pub fn growth_rate(&self) -> f64 {
        let first = self.samples.iter().find(|s| s.0 >= FIT_FROM - 1e-9);
        match (first, self.samples.last()) {
            (Some(&(t0, a0)), Some(&(t1, a1))) if t1 > t0 => (a1 / a0).ln() / (t1 - t0),
            _ => f64::NAN,
        }
    }
}

/// |Fourier component `m`| of tr c on the vertex ring at r = `ring` (about the ring mean).
pub fn ring_mode(flow: &ViscoelasticFlow, ring: f64, m: f64) -> f64 {
    let mesh = flow.mesh();
    let values: Vec<(f64, f64)> = flow
        .conformation()
        .iter()
        .enumerate()
        .filter_map(|(v, c)| {
            let x = mesh.nodes[mesh.node_of_vertex[v]];
            ((x[0].hypot(x[1]) - ring).abs() < 1e-9).then(|| (x[1].atan2(x[0]), c.xx + c.yy))
        })
        .collect();
    let n = values.len() as f64;
    let mean = values.iter().map(|v| v.1).sum::<f64>() / n;
    let (re, im) = values.iter().fold((0.0, 0.0), |(re, im), &(th, tr)| {
        (
            re + (tr - mean) * (m * th).cos(),
            im + (tr - mean) * (m * th).sin(),
        )
    });
    re.hypot(im) / n
}

/// The seeded undisturbed flow at `wi` (λ = Wi/γ̇, γ̇ = 1/3) on `mesh` (θ × r elements) to
/// [`T_END`] with step `dt` and `coupling`, lab frame; `progress` sees each sample (t*, |c_m|).
///
/// # Errors
/// [`ViscoelasticError`] if the flow cannot be set up or a step fails.
pub fn wall_mode_run(
    wi: f64,
    mesh: [usize; 2],
    coupling: Coupling,
    dt: f64,
    progress: &mut dyn FnMut(f64, f64),
) -> Result<WallModeRun, ViscoelasticError> {
    let g = CouetteGeometry::new(1.0, 4.0, 1.0).expect("the thesis' radii");
    let lambda = wi / g.shear_rate();
    let mut params = ViscoelasticParams::new(BETA, 1.0 - BETA, lambda, ALPHA, dt, T_END);
    params.coupling = coupling;
    let mut flow = ViscoelasticFlow::new(g.build_mesh(mesh[0], mesh[1]), params)?;
    apply_walls(&g, &mut flow)?;
    let ring = g.r1() + g.gap() / mesh[1] as f64;
    flow.set_initial_log_conformation(|x| {
        let (r, th) = (x[0].hypot(x[1]), x[1].atan2(x[0]));
        let s = SEED * (WAVENUMBER * th).cos() * (-(r - g.r1()) / SEED_DEPTH).exp();
        Sym2 {
            xx: s,
            xy: 0.0,
            yy: s,
        }
    })?;
    let mut samples = Vec::new();
    let mut next = SAMPLE_EVERY;
    while flow.time() < T_END - 1e-9 {
        flow.step(&|_| [0.0, 0.0])?;
        if flow.time() >= next - 1e-9 {
            let a = ring_mode(&flow, ring, WAVENUMBER);
            progress(flow.time(), a);
            samples.push((flow.time(), a));
            next += SAMPLE_EVERY;
        }
    }
    Ok(WallModeRun {
        coupling,
        dt,
        samples,
    })
}

/// The study at `wi` on `mesh`: the explicit coupling at `dt` and at `dt`/4, the semi-implicit
/// stress at `dt`. Its verdict (for `make validate`: Wi = 1, Δt = 0.08, [`MESH`]): the first
/// grows faster than [`GROWING`], the other two decay. Elsewhere the rates are the result (is the
/// explicit coupling stable there?), not a verdict.
///
/// # Errors
/// As [`wall_mode_run`].
pub fn wall_mode_study(
    wi: f64,
    dt: f64,
    mesh: [usize; 2],
    progress: &mut dyn FnMut(Coupling, f64, f64, f64),
) -> Result<(Vec<WallModeRun>, bool), ViscoelasticError> {
    let mut runs = Vec::new();
    for (coupling, step) in [
        (Coupling::Explicit, dt),
        (Coupling::Explicit, dt / 4.0),
        (Coupling::SemiImplicit, dt),
    ] {
        runs.push(wall_mode_run(wi, mesh, coupling, step, &mut |t, a| {
            progress(coupling, step, t, a)
        })?);
    }
    let rates: Vec<f64> = runs.iter().map(WallModeRun::growth_rate).collect();
    let passed = rates[0] > GROWING && rates[1] < 0.0 && rates[2] < 0.0;
    Ok((runs, passed))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The fit is exact for an exponential, whatever the sample times (a Δt that does not divide
    /// the sampling interval).
    #[test]
    fn the_growth_rate_of_an_exponential_is_its_exponent() {
        let samples = (1..=12)
            .map(|k| {
                let t = 3.97 * k as f64;
                (t, 2e-3 * (0.134 * t).exp())
            })
            .collect();
        let run = WallModeRun {
            coupling: Coupling::Explicit,
            dt: 0.07,
            samples,
        };
        assert!(
            (run.growth_rate() - 0.134).abs() < 1e-12,
            "{}",
            run.growth_rate()
        );
    }
}
