//! Viscoelastic validation without particles (`validation.md` §1):
//!
//! - [`steady_shear_table`]: start-up of plane Couette flow in the periodic channel to the steady
//!   state of §2.5.1; domain-mean τ_xy and N1 against [`giesekus_steady_shear`].
//! - [`homogeneous_deviation`]: the discrete fields in this homogeneous flow against the 0-D
//!   integrator [`HomogeneousLogConformation`] with the same Δt, at every step and vertex.
//! - [`oldroyd_b_startup_study`]: the Oldroyd-B transient against the closed form, order in Δt.
//! - [`transport_study`]: SUPG/BDF2 transport alone (λ → ∞, G = 0) of a smooth profile in a
//!   sheared periodic velocity, convergence in h (Δt ∝ h) and in Δt.
//! - [`channel_timings`]: time per step on a channel mesh.

use super::{ConvRow, ConvStudy};
use crate::fem::element::q2_map;
use crate::fem::quadrature::gauss_quad;
use crate::mesh::{Axis, Mesh, Side};
use crate::rheology::{
    giesekus_steady_shear, oldroyd_b_startup_shear, Giesekus, HomogeneousLogConformation, Sym2,
    VelocityGradient,
};
use crate::solver::constitutive::{
    ConstitutiveError, LogConformationHistory, LogConformationTransport, SupgVelocity,
    TransportFlow,
};
use crate::solver::constitutive_projection::sym_at;
use crate::solver::constitutive_stress::Coupling;
use crate::solver::viscoelastic::{
    StepTimings, ViscoelasticError, ViscoelasticFlow, ViscoelasticParams,
};

/// Required agreement of the steady shear functions with the analytic ones (the brief: 0.1 %).
pub const STEADY_SHEAR_TOL: f64 = 1e-3;
/// Minimum fitted order in Δt of the Oldroyd-B start-up (expected 2, STYLE: −0.15).
pub const MIN_ORDER_DT: f64 = 1.85;
/// Minimum fitted L² rate of the SUPG/BDF2 transport with Δt ∝ h (expected 2 for smooth
/// solutions on uniform meshes; SUPG theory guarantees 1.5).
pub const MIN_RATE_TRANSPORT: f64 = 1.85;

/// Plane Couette flow in the periodic channel [0, 1] × [−H/2, H/2], H = 1, walls at ∓U/2 with
/// U = 1 (γ̇ = 1), η0 = 1, λ = Wi, `nx × ny` elements.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CouetteCase {
    /// Weissenberg number λγ̇.
    pub wi: f64,
    /// Giesekus mobility.
    pub alpha: f64,
    /// Viscosity ratio β = η_s/η0.
    pub beta: f64,
    /// Elements along x.
    pub nx: usize,
    /// Elements across the gap.
    pub ny: usize,
    /// Stress coupling.
    pub coupling: Coupling,
}

impl CouetteCase {
    /// Set-up with time step `dt` and end time `t_end`.
    ///
    /// # Errors
    /// As [`ViscoelasticFlow::new`].
    pub fn build(&self, dt: f64, t_end: f64) -> Result<ViscoelasticFlow, ViscoelasticError> {
        let mesh = Mesh::rectangle(
            Axis::uniform(0.0, 1.0, self.nx),
            Axis::graded(-0.5, 0.5, self.ny, 0.0, 1.0),
            true,
        );
        let mut p =
            ViscoelasticParams::new(self.beta, 1.0 - self.beta, self.wi, self.alpha, dt, t_end);
        p.coupling = self.coupling;
        let mut flow = ViscoelasticFlow::new(mesh, p)?;
        flow.set_velocity(Side::Bottom, |_| [-0.5, 0.0]);
        flow.set_velocity(Side::Top, |_| [0.5, 0.0]);
        flow.pin_pressure();
        Ok(flow)
    }
}

/// No body force.
fn no_force(_: [f64; 2]) -> [f64; 2] {
    [0.0, 0.0]
}

/// One row of the steady shear table.
#[derive(Debug, Clone, Copy)]
pub struct SteadyShearRow {
    /// The case.
    pub case: CouetteCase,
    /// Steps to the steady state.
    pub steps: usize,
    /// Whether the steady criterion was met before the time limit.
    pub steady: bool,
    /// Computed τ_xy/(η0γ̇) (solvent + polymer, domain mean).
    pub shear_stress: f64,
    /// Computed N1/(η0γ̇).
    pub n1: f64,
    /// Relative error of τ_xy.
    pub err_shear: f64,
    /// Relative error of N1 (absolute for N1 = 0).
    pub err_n1: f64,
}

/// Runs one Couette case to the steady state (Δt = λ·`dt_per_lambda`, at most `max_t_per_lambda`
/// relaxation times) and compares with the analytic steady shear functions.
///
/// # Errors
/// As [`ViscoelasticFlow::step`].
pub fn steady_shear(
    case: CouetteCase,
    dt_per_lambda: f64,
    max_t_per_lambda: f64,
) -> Result<SteadyShearRow, ViscoelasticError> {
    let mut flow = case.build(dt_per_lambda * case.wi, max_t_per_lambda * case.wi)?;
    let summary = flow.run(&no_force, true, |_, _| {})?;
    let tau = flow.mean_extra_stress();
    let exact = giesekus_steady_shear(case.wi, case.alpha, case.beta);
    let n1 = tau.xx - tau.yy;
    let rel = |a: f64, b: f64| {
        if b == 0.0 {
            a.abs()
        } else {
            (a - b).abs() / b.abs()
        }
    };
    Ok(SteadyShearRow {
        case,
        steps: summary.steps,
        steady: summary.steady,
        shear_stress: tau.xy,
        n1,
        err_shear: rel(tau.xy, exact.shear_stress),
        err_n1: rel(n1, exact.n1),
    })
}

/// The steady shear table over Wi × α × β.
#[derive(Debug, Clone)]
pub struct SteadyShearTable {
    /// Rows.
    pub rows: Vec<SteadyShearRow>,
}

impl SteadyShearTable {
    /// Every case steady and within [`STEADY_SHEAR_TOL`].
    pub fn passed(&self) -> bool {
        self.rows
            .iter()
            .all(|r| r.steady && r.err_shear < STEADY_SHEAR_TOL && r.err_n1 < STEADY_SHEAR_TOL)
    }

    /// Largest relative error.
    pub fn worst(&self) -> f64 {
        self.rows
            .iter()
            .map(|r| r.err_shear.max(r.err_n1))
            .fold(0.0, f64::max)
    }

    /// Markdown table with verdict.
    pub fn to_markdown(&self) -> String {
        let mut s = String::from(
            "### Start-up of plane Couette flow: steady shear functions\n\n\
             | Wi | α | β | coupling | steps | τ_xy/(η0γ̇) | N1/(η0γ̇) | rel. err τ_xy | rel. err N1 |\n\
             |---|---|---|---|---|---|---|---|---|\n",
        );
        for r in &self.rows {
            s += &format!(
                "| {} | {} | {} | {:?} | {}{} | {:.7} | {:.7} | {:.2e} | {:.2e} |\n",
                r.case.wi,
                r.case.alpha,
                r.case.beta,
                r.case.coupling,
                r.steps,
                if r.steady { "" } else { " (not steady)" },
                r.shear_stress,
                r.n1,
                r.err_shear,
                r.err_n1
            );
        }
        s += &format!(
            "\nworst {:.2e}, required < {STEADY_SHEAR_TOL:e}; verdict: {}\n",
            self.worst(),
            if self.passed() { "PASS" } else { "FAIL" }
        );
        s
    }
}

/// Steady shear for Wi ∈ `wis`, α ∈ {0, 0.01, 0.2}, β ∈ {0, 0.1}.
///
/// # Errors
/// As [`steady_shear`].
pub fn steady_shear_table(
    wis: &[f64],
    coupling: Coupling,
    dt_per_lambda: f64,
) -> Result<SteadyShearTable, ViscoelasticError> {
    let mut rows = Vec::new();
    for &alpha in &[0.0, 0.01, 0.2] {
        for &beta in &[0.0, 0.1] {
            for &wi in wis {
                let case = CouetteCase {
                    wi,
                    alpha,
                    beta,
                    nx: 2,
                    ny: 4,
                    coupling,
                };
                rows.push(steady_shear(case, dt_per_lambda, 200.0)?);
            }
        }
    }
    Ok(SteadyShearTable { rows })
}

/// Largest deviation, over `n_steps` steps and all vertices, of the field log-conformation from
/// the 0-D reference integrator with the same Δt, relative to max(1, |s|).
///
/// # Errors
/// As [`ViscoelasticFlow::step`].
pub fn homogeneous_deviation(
    case: CouetteCase,
    dt: f64,
    n_steps: usize,
) -> Result<f64, ViscoelasticError> {
    let mut flow = case.build(dt, dt * n_steps as f64)?;
    let model = flow.fluid().polymer();
    let mut point = HomogeneousLogConformation::new(
        model,
        VelocityGradient::simple_shear(1.0),
        Sym2::ZERO,
        dt,
    )?;
    let mut worst: f64 = 0.0;
    for _ in 0..n_steps {
        flow.step(&no_force)?;
        let want = point.step();
        let scale = want.norm().max(1.0);
        for s in &flow.history().current {
            worst = worst.max((*s - want).norm() / scale);
        }
    }
    Ok(worst)
}

/// Oldroyd-B (β = `beta`) start-up, Wi = `wi`, compared at t = `t_end` (in units of λ) with the
/// closed form, for the time steps `dts` (in units of λ); columns τ_p,xy and N1.
///
/// # Errors
/// As [`ViscoelasticFlow::step`].
pub fn oldroyd_b_startup_study(
    wi: f64,
    beta: f64,
    t_end: f64,
    dts: &[f64],
    coupling: Coupling,
) -> Result<ConvStudy, ViscoelasticError> {
    let mut rows = Vec::new();
    for &dt in dts {
        let case = CouetteCase {
            wi,
            alpha: 0.0,
            beta,
            nx: 2,
            ny: 2,
            coupling,
        };
        let mut flow = case.build(dt * wi, t_end * wi)?;
        flow.run(&no_force, false, |_, _| {})?;
        let tau = flow.mean_polymer_stress();
        let exact = oldroyd_b_startup_shear(1.0 - beta, wi, 1.0, flow.time());
        rows.push(ConvRow {
            mesh: format!("Δt/λ = {dt}"),
            h: dt,
            dofs: flow.sizes().0,
            errors: vec![
                (tau.xy - exact.tau_xy).abs(),
                (tau.xx - tau.yy - exact.n1).abs(),
            ],
        });
    }
    Ok(ConvStudy {
        title: format!(
            "Oldroyd-B start-up of plane Couette flow, Wi = {wi}, β = {beta}, t = {t_end} λ: \
             error against the closed form, order in Δt"
        ),
        columns: vec!["|τ_xy − exact|".into(), "|N1 − exact|".into()],
        rows,
        min_rates: vec![MIN_ORDER_DT, MIN_ORDER_DT],
    })
}

/// Pure transport test problem on [0, 1]² (periodic in x, walls y = 0, 1 with v = 0):
/// u = (1 + y/2, 0), so s(x, y, t) = s⁰(x − (1 + y/2) t, y) with
/// s⁰ = (sin 2πx·cos πy, 0.5 cos 2πx·y, 0.3 sin(2πx + 1)·(1 − y²)) (xx, xy, yy).
fn transport_exact(x: [f64; 2], t: f64) -> Sym2 {
    let tp = 2.0 * std::f64::consts::PI;
    let xs = x[0] - (1.0 + 0.5 * x[1]) * t;
    Sym2::new(
        (tp * xs).sin() * (std::f64::consts::PI * x[1]).cos(),
        0.5 * (tp * xs).cos() * x[1],
        0.3 * (tp * xs + 1.0).sin() * (1.0 - x[1] * x[1]),
    )
}

/// L² error (all three components) of the transported profile on an `n × n` mesh with time step
/// `dt` at time `t_end` (an integer number of steps).
///
/// # Errors
/// [`ConstitutiveError`] if a solve fails.
pub fn transport_error(n: usize, dt: f64, t_end: f64) -> Result<f64, ConstitutiveError> {
    let (mesh, s) = transport_run(n, dt, t_end, SupgVelocity::Local)?;
    let t = (t_end / dt).round() * dt;
    Ok(l2_distance(&mesh, &s, |x| transport_exact(x, t)))
}

/// `‖s_h − f‖_L2` (all three components) with a 4×4 Gauss rule.
fn l2_distance(mesh: &Mesh, s: &[Sym2], f: impl Fn([f64; 2]) -> Sym2) -> f64 {
    let rule = gauss_quad(4);
    let mut err = 0.0;
    for e in 0..mesh.n_elements() {
        for (xi, w) in rule.points.iter().zip(&rule.weights) {
            let (x, _, det) = q2_map(&mesh.element_coords[e], *xi);
            let d = sym_at(mesh, s, e, *xi) - f(x);
            err += w * det * d.norm().powi(2);
        }
    }
    err.sqrt()
}

/// The transported field after `round(t_end/dt)` steps on the `n × n` mesh.
fn transport_run(
    n: usize,
    dt: f64,
    t_end: f64,
    supg: SupgVelocity,
) -> Result<(Mesh, Vec<Sym2>), ConstitutiveError> {
    let mesh = Mesh::rectangle(Axis::uniform(0.0, 1.0, n), Axis::uniform(0.0, 1.0, n), true);
    // λ → ∞ and G = 0: g ≡ 0 up to 1e-300, pure transport
    let model = Giesekus::oldroyd_b(1e300, 1.0).expect("valid model");
    let u: Vec<[f64; 2]> = mesh.nodes.iter().map(|x| [1.0 + 0.5 * x[1], 0.0]).collect();
    let g = vec![[0.0; 4]; mesh.n_vertices()];
    let s0 = mesh
        .node_of_vertex
        .iter()
        .map(|&k| transport_exact(mesh.nodes[k], 0.0))
        .collect();
    let mut hist = LogConformationHistory::from_field(s0);
    let mut tr = LogConformationTransport::new(&mesh);
    tr.supg = supg;
    let flow = TransportFlow {
        velocity: &u,
        mesh_velocity: None,
        gradient: &g,
    };
    let n_steps = (t_end / dt).round() as usize;
    for _ in 0..n_steps {
        tr.step(&mesh, &model, dt, &flow, &mut hist)?;
    }
    Ok((mesh, hist.current))
}

/// h-convergence with Δt = `courant`·h (both second order: the combined error is O(h²)), meshes
/// `n0`·2^l, up to `t_end`.
///
/// # Errors
/// As [`transport_error`].
pub fn transport_study(
    n0: usize,
    levels: usize,
    courant: f64,
    t_end: f64,
) -> Result<ConvStudy, ConstitutiveError> {
    let mut rows = Vec::new();
    for l in 0..levels {
        let n = n0 << l;
        let h = 1.0 / n as f64;
        rows.push(ConvRow {
            mesh: format!("{n}x{n}, Δt = {}", courant * h),
            h,
            dofs: (n * (n + 1)),
            errors: vec![transport_error(n, courant * h, t_end)?],
        });
    }
    Ok(ConvStudy {
        title: format!("SUPG/BDF2 transport of a smooth profile, Δt = {courant} h, t = {t_end}"),
        columns: vec!["‖s − s_h‖_L2".into()],
        rows,
        min_rates: vec![MIN_RATE_TRANSPORT],
    })
}

/// Δt-convergence on a fixed `n × n` mesh, t_end = 1, Δt = `dt0`/2^l, with the Δt-independent
/// SUPG parameter of Case 3 (Eq. 2.42, U_glob = 1) so that the spatial discretization is the same
/// for every Δt: errors against the solution with Δt = `dt0`/2^(levels+1) on the same mesh
/// (self-convergence; the thesis' Case 1 has τ = Δt/2 wherever the Courant number is below 1,
/// which mixes the spatial and temporal errors).
///
/// # Errors
/// As [`transport_error`].
pub fn transport_dt_study(
    n: usize,
    dt0: f64,
    levels: usize,
) -> Result<ConvStudy, ConstitutiveError> {
    let supg = SupgVelocity::Global(1.0);
    let dt_ref = dt0 / (1u32 << (levels + 1)) as f64;
    let (mesh, s_ref) = transport_run(n, dt_ref, 1.0, supg)?;
    let mut rows = Vec::new();
    for l in 0..levels {
        let dt = dt0 / (1u32 << l) as f64;
        let (_, s) = transport_run(n, dt, 1.0, supg)?;
        let diff: Vec<Sym2> = s.iter().zip(&s_ref).map(|(a, b)| *a - *b).collect();
        rows.push(ConvRow {
            mesh: format!("{n}x{n}, Δt = {dt}"),
            h: dt,
            dofs: n * (n + 1),
            errors: vec![l2_distance(&mesh, &diff, |_| Sym2::ZERO)],
        });
    }
    Ok(ConvStudy {
        title: format!(
            "SUPG/BDF2 transport, {n}x{n} mesh, SUPG Case 3: order in Δt against Δt = {dt_ref}"
        ),
        columns: vec!["‖s_Δt − s_ref‖_L2".into()],
        rows,
        min_rates: vec![MIN_ORDER_DT],
    })
}

/// Median phase timings over `steps` steps (after the first) of a Giesekus Couette flow on the
/// periodic channel [−15, 15] × [−2, 2] with `nx × ny` elements.
///
/// # Errors
/// As [`ViscoelasticFlow::step`].
pub fn channel_timings(
    nx: usize,
    ny: usize,
    steps: usize,
    coupling: Coupling,
) -> Result<(StepTimings, (usize, usize)), ViscoelasticError> {
    let mesh = Mesh::rectangle(
        Axis::uniform(-15.0, 15.0, nx),
        Axis::graded(-2.0, 2.0, ny, 0.0, 1.0),
        true,
    );
    let mut p = ViscoelasticParams::new(0.1, 0.9, 1.0, 0.2, 0.01, 1.0);
    p.coupling = coupling;
    let mut flow = ViscoelasticFlow::new(mesh, p)?;
    flow.set_velocity(Side::Bottom, |_| [-2.0, 0.0]);
    flow.set_velocity(Side::Top, |_| [2.0, 0.0]);
    flow.pin_pressure();
    let mut all = Vec::new();
    for _ in 0..=steps {
        all.push(flow.step(&no_force)?.timings);
    }
    let first = all.remove(0);
    let med = |f: &dyn Fn(&StepTimings) -> f64| {
        let mut v: Vec<f64> = all.iter().map(f).collect();
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let mut t = StepTimings {
        flow_assembly: med(&|t| t.flow_assembly),
        flow_symbolic: first.flow_symbolic,
        flow_factor: med(&|t| t.flow_factor),
        flow_solve: med(&|t| t.flow_solve),
        gradient_projection: med(&|t| t.gradient_projection),
        conformation_projection: med(&|t| t.conformation_projection),
        total: med(&|t| t.total),
        ..first
    };
    t.transport.assembly = med(&|t| t.transport.assembly);
    t.transport.symbolic = first.transport.symbolic;
    t.transport.factor = med(&|t| t.transport.factor);
    t.transport.solve = med(&|t| t.transport.solve);
    Ok((t, flow.sizes()))
}

/// Result of [`poiseuille_steady`].
#[derive(Debug, Clone, Copy)]
pub struct PoiseuilleResult {
    /// Steps to the steady state.
    pub steps: usize,
    /// Whether the steady criterion was met.
    pub steady: bool,
    /// max over nodes |u_h − u_exact| / u_max.
    pub u_err: f64,
    /// Relative error of the domain-mean N1.
    pub n1_err: f64,
    /// Relative error of the domain-mean |τ_p,xy|·sign(y) (τ_p,xy = −η_p f y/η0).
    pub tau_err: f64,
}

/// Oldroyd-B / UCM flow driven by a body force f = 8η0 (u_max = 1, γ̇_wall = 4) between fixed walls
/// y = ±1/2, periodic in x: a non-homogeneous flow (the stress gradient loads the momentum
/// balance) with the steady state u = 4(1/4 − y²), γ̇ = −8y, τ_p,xy = η_p γ̇, N1 = 2λη_p γ̇²,
/// mean N1 = 2λη_p·64/12. `wi` = λ γ̇_wall.
///
/// # Errors
/// As [`ViscoelasticFlow::step`].
pub fn poiseuille_steady(
    wi: f64,
    beta: f64,
    ny: usize,
    coupling: Coupling,
    dt_per_lambda: f64,
) -> Result<PoiseuilleResult, ViscoelasticError> {
    let lambda = wi / 4.0;
    let mesh = Mesh::rectangle(
        Axis::uniform(0.0, 1.0, 2),
        Axis::uniform(-0.5, 0.5, ny),
        true,
    );
    let mut p = ViscoelasticParams::new(
        beta,
        1.0 - beta,
        lambda,
        0.0,
        dt_per_lambda * lambda,
        400.0 * lambda,
    );
    p.coupling = coupling;
    let mut flow = ViscoelasticFlow::new(mesh, p)?;
    flow.set_velocity(Side::Bottom, |_| [0.0, 0.0]);
    flow.set_velocity(Side::Top, |_| [0.0, 0.0]);
    flow.pin_pressure();
    let force = |_: [f64; 2]| [8.0, 0.0];
    let summary = flow.run(&force, true, |_, _| {})?;
    let u_err = flow
        .mesh()
        .nodes
        .iter()
        .zip(flow.velocity())
        .map(|(x, u)| (u[0] - 4.0 * (0.25 - x[1] * x[1])).abs().max(u[1].abs()))
        .fold(0.0, f64::max);
    let tau = flow.mean_polymer_stress();
    let eta_p = 1.0 - beta;
    let n1_exact = 2.0 * lambda * eta_p * 64.0 / 12.0;
    // signed mean of τ_xy vanishes; compare the mean of τ_xy·sign(y) instead: η_p·8·(1/4)
    let mesh = flow.mesh();
    let cuts = vec![crate::solver::rigid::ElementCut::Fluid; mesh.n_elements()];
    let c = flow.conformation();
    let g = flow.fluid().polymer().modulus();
    let txy = crate::solver::constitutive_projection::fluid_mean(mesh, &cuts, |e, xi| {
        let y = q2_map(&mesh.element_coords[e], xi).0[1];
        [g * sym_at(mesh, c, e, xi).xy * y.signum()]
    })[0];
    let txy_exact = -eta_p * 8.0 * 0.25;
    Ok(PoiseuilleResult {
        steps: summary.steps,
        steady: summary.steady,
        u_err,
        n1_err: ((tau.xx - tau.yy) - n1_exact).abs() / n1_exact,
        tau_err: (txy - txy_exact).abs() / txy_exact.abs(),
    })
}
