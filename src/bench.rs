//! Performance benchmarks behind `xpflow bench` (results recorded in docs/performance.md).

use std::time::Instant;

use crate::fem::linsolve::{SolveError, SolverKind};
use crate::mesh::{Axis, Mesh, Side};
use crate::solver::flow::{Stokes, StokesParams, Timings};

/// Result of the Stokes benchmark.
#[derive(Debug, Clone)]
pub struct StokesBench {
    /// Mesh label.
    pub mesh: String,
    /// Solver used.
    pub solver: SolverKind,
    /// Whether DEVSS-G unknowns were included.
    pub with_g: bool,
    /// Unknowns.
    pub unknowns: usize,
    /// Stored non-zeros (both triangles).
    pub nnz: usize,
    /// Pattern construction (seconds).
    pub pattern: f64,
    /// Timings of the first solve (includes the symbolic analysis).
    pub first: Timings,
    /// Median timings of the repeated solves (numeric refactorization reusing the symbolic analysis).
    pub repeat: Timings,
    /// Peak resident memory of the process after the runs (MB), if readable.
    pub peak_rss_mb: Option<f64>,
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    v[v.len() / 2]
}

/// Stokes solve on the periodic channel [−15, 15] × [−2, 2] (the Ch. 2 benchmark box) with
/// `nx × ny` elements, graded toward the centre, sliding walls and a body force; the first solve
/// does the symbolic analysis, the `repeats` further solves only assemble, refactor and solve.
pub fn stokes(
    nx: usize,
    ny: usize,
    solver: SolverKind,
    with_g: bool,
    repeats: usize,
) -> Result<StokesBench, SolveError> {
    let t = Instant::now();
    let mesh = Mesh::rectangle(
        Axis::graded(-15.0, 15.0, nx, 0.0, 2.0),
        Axis::graded(-2.0, 2.0, ny, 0.0, 1.0),
        true,
    );
    let mut st = Stokes::new(
        mesh,
        StokesParams::new(0.59, if with_g { 0.41 } else { 0.0 }, solver),
    );
    let pattern = t.elapsed().as_secs_f64();
    st.set_velocity(Side::Bottom, |_| [-0.5, 0.0]);
    st.set_velocity(Side::Top, |_| [0.5, 0.0]);
    st.pin_pressure();
    let force = |x: [f64; 2]| [1.0 + 0.1 * x[1], 0.05 * (x[0] * 0.2).sin()];
    st.solve(&force)?;
    let first = st.timings;
    let mut runs = Vec::new();
    for _ in 0..repeats {
        // a slightly different viscosity each time, so that the matrix changes and the numeric
        // refactorization is measured (an unchanged matrix reuses the factorization)
        st.params.eta *= 1.0 + 1e-3;
        st.solve(&force)?;
        runs.push(st.timings);
    }
    let repeat = Timings {
        assembly: median(runs.iter().map(|r| r.assembly).collect()),
        symbolic: 0.0,
        placement: median(runs.iter().map(|r| r.placement).collect()),
        numeric: median(runs.iter().map(|r| r.numeric).collect()),
        solve: median(runs.iter().map(|r| r.solve).collect()),
    };
    let (unknowns, nnz) = st.size();
    Ok(StokesBench {
        mesh: format!("{nx}x{ny}"),
        solver,
        with_g,
        unknowns,
        nnz,
        pattern,
        first,
        repeat,
        peak_rss_mb: peak_rss_mb(),
    })
}

/// Resets the peak resident set size of this process to the current one (Linux: `5` written to
/// `/proc/self/clear_refs`), so that [`peak_rss_mb`] measures what follows; false if it cannot.
pub fn reset_peak_rss() -> bool {
    std::fs::write("/proc/self/clear_refs", "5").is_ok()
}

/// Peak resident set size of this process in MB (Linux `VmHWM`).
pub fn peak_rss_mb() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb / 1024.0)
}

impl std::fmt::Display for StokesBench {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "stokes {} {:?}{}: unknowns {}, nnz {}",
            self.mesh,
            self.solver,
            if self.with_g { " +G" } else { "" },
            self.unknowns,
            self.nnz
        )?;
        writeln!(f, "  pattern            {:9.4} s", self.pattern)?;
        writeln!(f, "  assembly           {:9.4} s", self.repeat.assembly)?;
        writeln!(f, "  symbolic           {:9.4} s", self.first.symbolic)?;
        writeln!(f, "  numeric (first)    {:9.4} s", self.first.numeric)?;
        writeln!(f, "  numeric (refactor) {:9.4} s", self.repeat.numeric)?;
        writeln!(f, "  solve              {:9.4} s", self.repeat.solve)?;
        writeln!(
            f,
            "  step (asm+refactor+solve) {:9.4} s",
            self.repeat.assembly + self.repeat.numeric + self.repeat.solve
        )?;
        match self.peak_rss_mb {
            Some(m) => write!(f, "  peak RSS           {m:9.0} MB"),
            None => write!(f, "  peak RSS           n/a"),
        }
    }
}

/// Result of the moving-particle benchmark: medians over the timed steps.
#[derive(Debug, Clone)]
pub struct MovingBench {
    /// Mesh label.
    pub mesh: String,
    /// Number of particles.
    pub particles: usize,
    /// (flow unknowns, stress unknowns per component).
    pub unknowns: (usize, usize),
    /// Steps timed (after the warm-up steps).
    pub steps: usize,
    /// Median seconds of each phase over the timed steps (each phase's own median).
    pub median: crate::solver::viscoelastic::StepTimings,
    /// Mean seconds of a timed step: unlike the median it carries the band's placements (a
    /// far-field factorization at each pattern rebuild) spread over the steps they serve.
    pub mean_step: f64,
    /// Flow-matrix pattern rebuilds over the run (warm-up included).
    pub pattern_rebuilds: usize,
    /// Numeric flow factorizations over the run (warm-up and the initial solve included).
    pub flow_factorizations: usize,
    /// How the flow matrix was factored and where the ALE map was solved.
    pub path: MovingPath,
    /// Placements of the band solver (far-field factorizations) over the run.
    pub placements: usize,
    /// GMRES iterations that polished inexact flow solves over the run (0: every direct solve
    /// met the residual tolerance).
    pub polish_iterations: usize,
    /// Band factorizations without pivots redone with pivoting over the run (their solve
    /// missed the residual tolerance).
    pub pivoted_refactors: usize,
    /// How the log-conformation transport steps of the run were solved.
    pub transport: crate::solver::constitutive::TransportStats,
    /// Steps of the run (warm-up included).
    pub run_steps: usize,
    /// Peak resident memory (MB) the run added ([`moving`]), if readable.
    pub peak_rss_mb: Option<f64>,
}

/// What a run of [`moving`] does where the paths differ: how the flow matrix is factored
/// (`numerics.factorization`) and where the ALE's mesh displacement is solved
/// (`numerics.ale_extent`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MovingPath {
    /// The flow factorization.
    pub factorization: crate::fem::substructure::Factorization,
    /// The extent of the ALE map.
    pub ale: crate::solver::ale::AleExtent,
}

impl MovingPath {
    /// The refactor-every-step path as it was before the band and the ring: the whole flow
    /// matrix factored every step, the ALE map solved on the whole mesh.
    pub const REFACTOR: MovingPath = MovingPath {
        factorization: crate::fem::substructure::Factorization::Whole,
        ale: crate::solver::ale::AleExtent::Whole,
    };

    /// The label of the path in the table.
    pub fn label(&self) -> String {
        use crate::fem::substructure::Factorization;
        use crate::solver::ale::AleExtent;
        let f = match self.factorization {
            Factorization::Band => "band",
            Factorization::Whole => "whole (refactor)",
        };
        match self.ale {
            AleExtent::Whole => f.to_string(),
            AleExtent::Ring => format!("{f}, ALE ring"),
        }
    }
}

/// The case of [`moving`]: `n` free particles in confined shear flow (thesis §5.7: H = 1, L = 4,
/// a = 0.1, Giesekus Wi = 1, α = 0.01, β = 0.1, Δt = 0.01) on an `nx × ny` mesh, particles on
/// the line through the origin of slope −0.2 spaced 0.5 apart (the three-particle start of
/// §5.7.2 for n = 3); explicit coupling with the lagged Gⁿ, or with G as flow unknowns if
/// `coupled_g`; with `follow = Some(r)` on a mesh that follows the particles along x (columns r
/// times finer within 1.5a, count kept out to 12a, as `sweeps/three_particles_follow.toml`);
/// `cut` = (quadtree level, interface rule) if not the case default; the flow matrix factored as
/// `path` says. Everything else is the case default.
pub fn moving_case(
    nx: usize,
    ny: usize,
    n: usize,
    coupled_g: bool,
    follow: Option<f64>,
    cut: Option<(u32, crate::config::InterfaceRule)>,
    path: MovingPath,
) -> Result<crate::config::CaseSpec, crate::config::SpecError> {
    let l = 4.0;
    let spacing = if n <= 7 { 0.5 } else { l / n as f64 };
    let x0: Vec<[f64; 2]> = (0..n)
        .map(|i| {
            let s = (i as f64 - 0.5 * (n as f64 - 1.0)) * spacing;
            [s, -0.2 * s]
        })
        .collect();
    let mut numerics = serde_json::json!({ "mesh": [nx, ny], "dt": 0.01, "t_end": 1.0 });
    if coupled_g {
        numerics["coupling"] = "explicit_coupled_g".into();
    }
    if let Some((level, interface)) = cut {
        numerics["quadtree_level"] = level.into();
        // (a unit variant always serializes)
        numerics["interface"] = serde_json::to_value(interface).unwrap_or_default();
    }
    if !path.factorization.is_band() {
        numerics["factorization"] = serde_json::to_value(path.factorization).unwrap_or_default();
    }
    if !path.ale.is_whole() {
        numerics["ale_extent"] = serde_json::to_value(path.ale).unwrap_or_default();
    }
    if let Some(ratio) = follow {
        numerics["follow"] =
            serde_json::json!({ "ratio": ratio, "ratio_y": 1.0, "core": 1.5, "reach": 12.0 });
    }
    crate::config::CaseSpec::from_value(serde_json::json!({
        "geometry": { "confined_shear": { "h": 1.0, "l": l, "wall_speed": 1.0 } },
        "fluid": { "model": "giesekus", "wi": 1.0, "alpha": 0.01, "beta": 0.1 },
        "particles": { "radius": 0.1, "layout": { "explicit": { "positions": x0 } } },
        "numerics": numerics,
    }))
}

/// The case of a path of [`moving`] (from the benchmark's own [`moving_case`] or a study's).
pub type CaseOnPath<'a> =
    dyn Fn(MovingPath) -> Result<crate::config::CaseSpec, crate::config::SpecError> + 'a;

/// What [`moving`] runs: the case on each path, the label of its mesh column, and the state all
/// paths start from.
pub struct MovingSource<'a> {
    /// The mesh column of the table.
    pub label: String,
    /// The case on a path.
    pub case: &'a CaseOnPath<'a>,
    /// A checkpoint ([`crate::simulate::Simulation::checkpoint`], as a sweep saves it) every
    /// path continues from instead of starting from rest.
    pub state: Option<&'a str>,
}

impl<'a> MovingSource<'a> {
    /// The benchmark's own case ([`moving_case`]) of `n` particles on an `nx × ny` mesh.
    pub fn standard(nx: usize, ny: usize, follow: Option<f64>, case: &'a CaseOnPath<'a>) -> Self {
        MovingSource {
            label: match follow {
                Some(r) => format!("{nx}x{ny} following ×{r}"),
                None => format!("{nx}x{ny}"),
            },
            case,
            state: None,
        }
    }
}

/// A case with the factorization and ALE extent of `path`.
pub fn on_path(mut case: crate::config::CaseSpec, path: MovingPath) -> crate::config::CaseSpec {
    case.numerics.factorization = path.factorization;
    case.numerics.ale_extent = path.ale;
    case
}

/// One viscoelastic time step of `source`'s case, built by
/// [`crate::simulate::Simulation::new`] as every case is, once per path of `paths` (from the
/// source's state if it has one): each built and stepped `warm_up` untimed steps in turn, then
/// their timed steps alternated (one of each in turn, so that a machine whose speed drifts slows
/// them alike), medians over `steps` steps. The memory reported is the peak resident memory a
/// path added while it was built and warmed up (the process's peak reset before,
/// [`reset_peak_rss`]; the process's peak if it cannot be reset).
///
/// # Errors
/// The case's validation error, a set-up, restore or step failure, or particles touching.
pub fn moving(
    source: &MovingSource<'_>,
    warm_up: usize,
    steps: usize,
    paths: &[MovingPath],
) -> anyhow::Result<Vec<MovingBench>> {
    use crate::simulate::Simulation;
    use crate::solver::moving::StepOutcome;
    use crate::solver::viscoelastic::StepTimings;
    let step = |sim: &mut Simulation| -> anyhow::Result<StepTimings> {
        match sim.step()? {
            StepOutcome::Stepped(r) => Ok(r.timings),
            StepOutcome::Contact(c) | StepOutcome::ContactAfter(_, c) => {
                anyhow::bail!("bench: particles touched: {c}")
            }
        }
    };
    let mut sims = Vec::new();
    let mut memory = Vec::new();
    for &path in paths {
        let case = (source.case)(path)?;
        let before = current_rss_mb();
        let reset = reset_peak_rss();
        let mut sim = Simulation::new(&case)?;
        if let Some(state) = source.state {
            sim.restore(state)
                .map_err(|e| anyhow::anyhow!("bench: the saved state does not fit: {e}"))?;
        }
        for _ in 0..warm_up {
            step(&mut sim)?;
        }
        memory.push(match (reset, before, peak_rss_mb()) {
            (true, Some(b), Some(p)) => Some(p - b),
            (_, _, p) => p,
        });
        sims.push(sim);
    }
    let mut timings: Vec<Vec<StepTimings>> = vec![Vec::new(); sims.len()];
    for _ in 0..steps {
        for (sim, t) in sims.iter_mut().zip(&mut timings) {
            t.push(step(sim)?);
        }
    }
    let benches = sims
        .iter()
        .zip(&timings)
        .zip(paths.iter().zip(memory))
        .map(|((sim, reports), (&path, peak_rss_mb))| {
            let med = |f: &dyn Fn(&StepTimings) -> f64| median(reports.iter().map(f).collect());
            let flow = sim.stepper().flow();
            MovingBench {
                mesh: source.label.clone(),
                particles: sim.stepper().state().x.len(),
                unknowns: flow.sizes(),
                steps,
                median: StepTimings {
                    ale: med(&|t| t.ale),
                    classify: med(&|t| t.classify),
                    flow_assembly: med(&|t| t.flow_assembly),
                    flow_symbolic: med(&|t| t.flow_symbolic),
                    flow_factor: med(&|t| t.flow_factor),
                    flow_solve: med(&|t| t.flow_solve),
                    gradient_projection: med(&|t| t.gradient_projection),
                    transport: crate::solver::constitutive::TransportTimings {
                        assembly: med(&|t| t.transport.assembly),
                        symbolic: med(&|t| t.transport.symbolic),
                        factor: med(&|t| t.transport.factor),
                        solve: med(&|t| t.transport.solve),
                    },
                    conformation_projection: med(&|t| t.conformation_projection),
                    total: med(&|t| t.total),
                },
                mean_step: reports.iter().map(|t| t.total).sum::<f64>()
                    / reports.len().max(1) as f64,
                pattern_rebuilds: flow.pattern_rebuilds(),
                flow_factorizations: flow.flow_refactorizations(),
                path,
                placements: flow.flow_placements(),
                polish_iterations: flow.flow_solver_stats().krylov_iterations,
                pivoted_refactors: flow.flow_solver_stats().pivoted_refactors,
                transport: flow.transport_stats(),
                run_steps: warm_up + steps,
                peak_rss_mb,
            }
        })
        .collect();
    Ok(benches)
}

/// Current resident set size of this process in MB (Linux `VmRSS`).
pub fn current_rss_mb() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmRSS:"))?;
    let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb / 1024.0)
}

impl MovingBench {
    /// Markdown table header matching [`to_row`](Self::to_row).
    pub const HEADER: &'static str = "| mesh | particles | factorization | flow / stress unknowns | ALE | classify | flow asm | flow sym + placement | flow factor | flow solve | G proj | s asm | s factor | s solve | c proj | step | step (mean) | pattern rebuilds | placements | flow factorizations | polish iterations / pivoted refactors | s: GMRES iterations / LU steps | peak RSS |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|";

    /// One markdown table row (seconds).
    pub fn to_row(&self) -> String {
        format!(
            "| {} | {} | {} | {} / {} | {:.4} | {:.4} | {:.4} | {:.4} | {:.4} | {:.4} | {:.4} | {:.4} | {:.4} | {:.4} | {:.4} | **{:.3}** | {:.3} | {} of {} | {} | {} of {} | {} / {} | {} / {} | {} |",
            self.mesh,
            self.particles,
            self.path.label(),
            self.unknowns.0,
            self.unknowns.1,
            self.median.ale,
            self.median.classify,
            self.median.flow_assembly,
            self.median.flow_symbolic,
            self.median.flow_factor,
            self.median.flow_solve,
            self.median.gradient_projection,
            self.median.transport.assembly,
            self.median.transport.factor,
            self.median.transport.solve,
            self.median.conformation_projection,
            self.median.total,
            self.mean_step,
            self.pattern_rebuilds,
            self.run_steps,
            self.placements,
            self.flow_factorizations,
            self.run_steps + 1,
            self.polish_iterations,
            self.pivoted_refactors,
            self.transport.krylov_iterations,
            self.transport.lu_steps,
            self.peak_rss_mb.map_or("—".into(), |m| format!("{m:.0} MB")),
        )
    }
}

/// The row comparing two runs of [`moving`] phase by phase: `old`/`new` (above 1: the new run
/// is faster), and the ratio of their peak memory.
pub fn ratio_row(new: &MovingBench, old: &MovingBench) -> String {
    let r = |o: f64, n: f64| {
        if n > 0.0 && o > 0.0 {
            format!("{:.2}×", o / n)
        } else {
            "—".into()
        }
    };
    let (a, b) = (&old.median, &new.median);
    format!(
        "| ratio ({} / {}) | | | | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | **{}** | {} | | | | | | {} |",
        old.path.label(),
        new.path.label(),
        r(a.ale, b.ale),
        r(a.classify, b.classify),
        r(a.flow_assembly, b.flow_assembly),
        r(a.flow_symbolic, b.flow_symbolic),
        r(a.flow_factor, b.flow_factor),
        r(a.flow_solve, b.flow_solve),
        r(a.gradient_projection, b.gradient_projection),
        r(a.transport.assembly, b.transport.assembly),
        r(a.transport.factor, b.transport.factor),
        r(a.transport.solve, b.transport.solve),
        r(a.conformation_projection, b.conformation_projection),
        r(a.total, b.total),
        r(old.mean_step, new.mean_step),
        match (old.peak_rss_mb, new.peak_rss_mb) {
            (Some(o), Some(n)) => format!("memory {:.2}× of the second", n / o),
            _ => "—".into(),
        },
    )
}

/// The closing line of a comparison: median step of the new path, of the refactor path, and
/// their ratio.
pub fn step_line(new: &MovingBench, old: &MovingBench) -> String {
    format!(
        "step: new {:.3} s, refactor path {:.3} s, ratio {:.2}",
        new.median.total,
        old.median.total,
        old.median.total / new.median.total
    )
}

/// Sweep expansion of an `n`×`n` grid (Wi × α over the three-particle shear case): the best of
/// `repeats` expansions in seconds (issue 28: a quadratic duplicate search took 7.2 s at 200²).
///
/// # Errors
/// If the grid's sweep file is refused (it is valid by construction).
pub fn expansion(n: usize, repeats: usize) -> Result<f64, crate::config::ConfigError> {
    let text = format!(
        "name = \"grid\"\n[base]\n\
         geometry.confined_shear = {{ h = 1.0, l = 4.0 }}\n\
         fluid = {{ model = \"giesekus\", wi = 1.0, alpha = 0.01, beta = 0.1 }}\n\
         particles = {{ radius = 0.1, layout.string = {{ n = 2, lx = 0.5, ly = 0.1 }} }}\n\
         numerics = {{ mesh = [40, 10], dt = 0.01, t_end = 0.2 }}\n\
         [axes]\n\
         fluid.wi = {{ start = 1.0, stop = {n}.0, step = 1.0 }}\n\
         fluid.alpha = {{ start = 0.0, stop = 0.5, num = {n} }}\n"
    );
    let spec = crate::config::SweepSpec::from_str(&text, false, std::path::Path::new("grid.toml"))?;
    let mut best = f64::INFINITY;
    for _ in 0..repeats.max(1) {
        let t = Instant::now();
        let cases = crate::sweep::expand::expand(&spec)?;
        best = best.min(t.elapsed().as_secs_f64());
        assert_eq!(cases.len(), n * n, "an n×n grid");
    }
    Ok(best)
}
