//! Command-line interface: thin wrappers over the library (`main.rs` only calls [`main_with_args`]).

pub mod sweep_cmds;

use std::process::ExitCode;

use clap::{Parser, Subcommand, ValueEnum};

use crate::fem::linsolve::SolverKind;
use crate::validate::stokes::{circular_couette, plane_couette_max_error, stokes_mms, Domain};

/// xpflow: rigid particles in viscoelastic fluids (XFEM), with parameter sweeps.
#[derive(Debug, Parser)]
#[command(name = "xpflow", version, about, long_about = None)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// Subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Run one case (a case file: the `[base]` table of a sweep file) and write its trajectories.
    Run {
        /// Case file.
        case: std::path::PathBuf,
    },
    /// Expand a sweep file into cases and run them (resumable).
    Sweep(sweep_cmds::SweepArgs),
    /// Print results tables from a results database.
    Query(sweep_cmds::QueryArgs),
    /// Per-sweep counts of done / running / failed / pending cases.
    Status(sweep_cmds::StatusArgs),
    /// Run a validation study and print its numbers and verdict.
    Validate {
        /// Which study.
        study: Study,
        /// Number of mesh levels for convergence studies.
        #[arg(long, default_value_t = 4)]
        levels: usize,
        /// Linear solver.
        #[arg(long, value_enum, default_value_t = SolverArg::Lblt)]
        solver: SolverArg,
        /// Weissenberg number (cylinder study).
        #[arg(long, default_value_t = 0.0)]
        wi: f64,
        /// Element sizes near the cylinder, in units of R (cylinder study; comma-separated,
        /// coarse to fine; the verdict is the finest one's). Default: 0.1,0.05,0.03 for Wi = 0;
        /// for Wi > 0 one mesh that runs in a minute or two (0.1 up to Wi = 0.45, 0.07 above).
        #[arg(long, alias = "mesh", value_delimiter = ',')]
        h: Option<Vec<f64>>,
        /// Directory for CSV output (trajectories).
        #[arg(long, default_value = "results/validate")]
        out: std::path::PathBuf,
        /// Time step (viscoelastic cylinder study).
        #[arg(long, default_value_t = 0.01)]
        dt: f64,
        /// Longest simulated time before giving up on the steady state (viscoelastic cylinder).
        #[arg(long, default_value_t = 20.0)]
        t_max: f64,
        /// Quadtree levels of the cut-cell quadrature (parabolic interface in the finest cells).
        #[arg(long, default_value_t = 3)]
        cut_level: u32,
    },
    /// Run a performance benchmark.
    Bench {
        /// Which benchmark.
        name: BenchName,
        /// Mesh as NXxNY (elements), e.g. 200x50 (moving benchmark: comma-separated list).
        #[arg(long, default_value = "200x50")]
        mesh: String,
        /// Linear solver.
        #[arg(long, value_enum, default_value_t = SolverArg::Lblt)]
        solver: SolverArg,
        /// Include the DEVSS-G unknowns (stokes benchmark; moving benchmark: coupled DEVSS-G
        /// instead of the lagged Gⁿ).
        #[arg(long)]
        with_g: bool,
        /// Repeated solves after the first (median reported).
        #[arg(long, default_value_t = 5)]
        repeats: usize,
        /// Number of particles (moving benchmark; comma-separated for several runs).
        #[arg(long, value_delimiter = ',', default_values_t = vec![3])]
        particles: Vec<usize>,
        /// Element sizes near the cylinder in units of R (drag benchmark; comma-separated).
        #[arg(long, value_delimiter = ',', default_values_t = vec![0.2, 0.1, 0.05, 0.03])]
        h: Vec<f64>,
        /// Quadtree levels of the cut-cell quadrature (drag benchmark).
        #[arg(long, default_value_t = 3)]
        cut_level: u32,
        /// Moving benchmark: a mesh that follows the particles along x, columns this many times
        /// finer around each (`numerics.follow.ratio`).
        #[arg(long)]
        follow: Option<f64>,
    },
}

/// Validation studies.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum Study {
    /// Manufactured solution, periodic channel and annulus, with and without DEVSS-G.
    StokesMms,
    /// Plane and circular Couette flow.
    Couette,
    /// Newtonian / Oldroyd-B drag on the confined cylinder (Ch. 2): prints `K = <value>`.
    Cylinder,
    /// XFEM Stokes around a cylinder with the exact solution of thesis §2.4 (rates).
    XfemStokes,
    /// Free particle at the centre of plane Couette flow: ω/γ̇ against confinement 2a/H.
    FreeParticle,
    /// Two particles in confined Stokes shear flow (thesis §5.6.2): reverse / pass.
    TwoParticles,
    /// Translating cylinder in a Giesekus fluid (thesis §5.4): order in Δt of K(t), 0 ≤ t ≤ λ,
    /// over Δt = 0.04 … 0.005 against Δt = 0.0025, on the first `--h` (units of a).
    TranslatingCylinder,
    /// The translating cylinder held at rest with η_s = 0.1 and the explicit coupling: order in
    /// Δt (0.02 … 0.005 against 0.0025) with the lagged Gⁿ and with G as flow unknowns, on the
    /// first `--h`; the verdict asks second order of the latter.
    ExplicitCoupling,
    /// A particle crossing the fixed mesh (thesis §5.5, Y0/H = 0.1, 160×80, 0.66 elements per
    /// step) in the lab frame against a frame moving with it: ω*, V* per history remap up to
    /// t* = 2.5 (≈ 4 min); the verdict is the default (bicubic) remap's.
    LabFrame,
    /// The Couette particle (thesis §3.5.2, 30×160) up to t* = 10 in the rotating frame, in the
    /// lab frame on the fixed mesh and on a mesh that follows it (≈ 6 min); the verdict asks
    /// the following mesh's r*(10) to be within 1e-3 of the rotating frame's.
    CouetteFrame,
}

/// Benchmarks.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum BenchName {
    /// One Stokes (Q2/Q1) solve: assembly, symbolic, numeric, refactor, solve.
    Stokes,
    /// The unfitted Stokes drag problem (confined cylinder, Wi = 0): K, its error and the time of
    /// each phase, for element sizes `--h`.
    Drag,
    /// One viscoelastic time step with moving particles in confined shear flow (thesis §5.7
    /// set-up) on `--mesh` with `--particles`: every phase, medians over `--repeats` steps.
    Moving,
}

/// Linear solver choice.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum SolverArg {
    /// Symmetric indefinite LBLᵀ.
    Lblt,
    /// General LU.
    Lu,
}

impl From<SolverArg> for SolverKind {
    fn from(s: SolverArg) -> Self {
        match s {
            SolverArg::Lblt => SolverKind::Lblt,
            SolverArg::Lu => SolverKind::Lu,
        }
    }
}

/// Parses `NXxNY`.
fn parse_mesh(s: &str) -> anyhow::Result<(usize, usize)> {
    let (a, b) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| anyhow::anyhow!("--mesh must look like 200x50, got '{s}'"))?;
    let (nx, ny) = (a.trim().parse()?, b.trim().parse()?);
    anyhow::ensure!(
        nx > 0 && ny > 0,
        "--mesh needs positive element counts, got '{s}'"
    );
    Ok((nx, ny))
}

/// Runs the CLI on already-parsed arguments.
pub fn run(cli: Cli) -> anyhow::Result<ExitCode> {
    match cli.command {
        Command::Run { case } => run_case(&case),
        Command::Sweep(args) => sweep_cmds::run_sweep(&args),
        Command::Query(args) => sweep_cmds::run_query(&args),
        Command::Status(args) => sweep_cmds::run_status(&args),
        Command::Validate {
            study,
            levels,
            solver,
            wi,
            h,
            out,
            dt,
            t_max,
            cut_level,
        } => match study {
            Study::StokesMms | Study::Couette => validate(study, levels, solver.into()),
            _ => validate_particles(
                study,
                levels,
                wi,
                &h.unwrap_or_else(|| default_cylinder_meshes(wi)),
                &out,
                dt,
                t_max,
                cut_options(cut_level),
            ),
        },
        Command::Bench {
            name,
            mesh,
            solver,
            with_g,
            repeats,
            particles,
            h,
            cut_level,
            follow,
        } => match name {
            BenchName::Moving => {
                println!("{}", crate::bench::MovingBench::HEADER);
                for m in mesh.split(',') {
                    let (nx, ny) = parse_mesh(m)?;
                    for &n in &particles {
                        let b = crate::bench::moving(nx, ny, n, 3, repeats.max(1), with_g, follow)?;
                        println!("{}", b.to_row());
                    }
                }
                Ok(ExitCode::SUCCESS)
            }
            BenchName::Stokes => {
                let (nx, ny) = parse_mesh(&mesh)?;
                let b = crate::bench::stokes(nx, ny, solver.into(), with_g, repeats)?;
                println!("{b}");
                Ok(ExitCode::SUCCESS)
            }
            BenchName::Drag => {
                use crate::solver::rigid::WeakForm;
                use crate::validate::xstokes::cylinder_drag;
                // published K (thesis Table 2.3)
                const K_REF: f64 = 132.358;
                println!("| h/R | unknowns | K | rel. error | cut cells | assembly | symbolic | numeric | solve | total |");
                println!("|---|---|---|---|---|---|---|---|---|---|");
                for hh in h {
                    let r = cylinder_drag(hh, WeakForm::Symmetric, cut_options(cut_level))?;
                    let t = r.timings;
                    println!(
                        "| {hh} | {} | {:.4} | {:.1e} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.2} s |",
                        r.dofs,
                        r.k_reaction,
                        ((r.k_reaction - K_REF) / K_REF).abs(),
                        r.cut_seconds,
                        t.assembly,
                        t.symbolic,
                        t.numeric,
                        t.solve,
                        r.seconds
                    );
                }
                Ok(ExitCode::SUCCESS)
            }
        },
    }
}

fn validate(study: Study, levels: usize, solver: SolverKind) -> anyhow::Result<ExitCode> {
    let mut ok = true;
    match study {
        Study::StokesMms => {
            for domain in [Domain::Channel, Domain::Annulus] {
                for with_g in [false, true] {
                    let s = stokes_mms(domain, with_g, levels, solver)?;
                    println!("{}", s.to_markdown());
                    ok &= s.passed();
                }
            }
        }
        Study::Couette => {
            // Q2 contains the linear profile: only round-off remains
            const ROUND_OFF: f64 = 1e-11;
            for with_g in [false, true] {
                let e = plane_couette_max_error(with_g)?;
                let pass = e < ROUND_OFF;
                println!(
                    "plane Couette ({}): max nodal error {e:.3e} (≤ {ROUND_OFF:e}: {})\n",
                    if with_g { "DEVSS-G" } else { "Stokes" },
                    if pass { "PASS" } else { "FAIL" }
                );
                ok &= pass;
            }
            let s = circular_couette(levels)?;
            println!("{}", s.to_markdown());
            ok &= s.passed();
        }
        _ => unreachable!("particle studies go through validate_particles"),
    }
    Ok(if ok {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}

#[allow(clippy::too_many_arguments)]
fn validate_particles(
    study: Study,
    levels: usize,
    wi: f64,
    hs: &[f64],
    out: &std::path::Path,
    dt: f64,
    t_max: f64,
    cut: crate::xfem::CutOptions,
) -> anyhow::Result<ExitCode> {
    use crate::solver::rigid::WeakForm;
    use crate::validate::xstokes::{
        couette_free_particle, cylinder_drag, cylinder_exact, FREE_PARTICLE_REFERENCE,
    };
    let mut ok = true;
    match study {
        Study::Cylinder => {
            if wi != 0.0 {
                return validate_cylinder_viscoelastic(wi, hs, dt, t_max, out, cut);
            }
            // published K = 132.358 (thesis Table 2.3); the issue asks for 0.05 %
            const K_REF: f64 = 132.358;
            const REL_TOL: f64 = 5e-4;
            println!(
                "Confined cylinder, Newtonian (Wi = 0), H = 4R, L = 30R, reference K = {K_REF}"
            );
            println!("| h/R | mesh | unknowns | K (reaction) | K (stress integral) | error | time |\n|---|---|---|---|---|---|---|");
            let mut last = 0.0;
            for &h in hs {
                let r = cylinder_drag(h, WeakForm::Symmetric, cut)?;
                let err = (r.k_reaction - K_REF) / K_REF;
                println!(
                    "| {h} | {} | {} | {:.4} | {:.4} | {:+.2e} | {:.1} s |",
                    r.mesh, r.dofs, r.k_reaction, r.k_stress, err, r.seconds
                );
                ok &= err.abs() < REL_TOL;
                last = r.k_reaction;
            }
            println!("K = {last:.4}");
        }
        Study::XfemStokes => {
            for form in [WeakForm::Symmetric, WeakForm::Thesis] {
                let s = cylinder_exact(levels, form, cut)?;
                println!("{}", s.to_markdown());
                ok &= s.passed();
            }
        }
        Study::FreeParticle => {
            // cross-check tolerance of the reference table (validation.md §1)
            const REL_TOL: f64 = 3e-3;
            println!("| 2a/H | U_x | U_y | ω/γ̇ | reference | rel. difference |\n|---|---|---|---|---|---|");
            for conf in [0.4, 0.2, 0.1, 0.05, 0.04] {
                let r = couette_free_particle(conf, WeakForm::Symmetric, cut)?;
                let reference = FREE_PARTICLE_REFERENCE
                    .iter()
                    .find(|(c, _)| (c - conf).abs() < 1e-12)
                    .map(|(_, w)| *w);
                let (refs, diff) = match reference {
                    Some(w) => {
                        let d = (r[2].abs() - w) / w;
                        ok &= d.abs() < REL_TOL;
                        (format!("{w}"), format!("{d:+.2e}"))
                    }
                    None => (
                        "(limit 0.5)".to_string(),
                        format!("{:+.2e} from 0.5", r[2].abs() - 0.5),
                    ),
                };
                println!(
                    "| {conf} | {:.1e} | {:.1e} | {:.5} | {refs} | {diff} |",
                    r[0], r[1], r[2]
                );
            }
        }
        Study::TranslatingCylinder => {
            use crate::solver::ale::Remap;
            use crate::validate::moving::{
                relative_l2_difference, translating_cylinder_convergence, CylinderStress, Frame,
            };
            let h = hs.first().copied().unwrap_or(0.125);
            let mut refs = Vec::new();
            for (frame, remap) in [
                (Frame::Cylinder, Remap::Bilinear),
                (Frame::Channel, Remap::Quadratic),
                (Frame::Channel, Remap::Bilinear),
                (Frame::Channel, Remap::Cubic),
            ] {
                let s = translating_cylinder_convergence(
                    h,
                    &[0.04, 0.02, 0.01, 0.005],
                    0.0025,
                    cut,
                    remap,
                    frame,
                    CylinderStress::Thesis,
                )?;
                match frame {
                    Frame::Cylinder => println!("cylinder frame (no ALE)\n{}", s.to_markdown()),
                    Frame::Channel => {
                        println!(
                            "channel frame, history remap {remap:?}\n{}",
                            s.to_markdown()
                        )
                    }
                }
                // the verdict is the default remap's (and the higher-order one's)
                ok &= frame != Frame::Channel || remap == Remap::Bilinear || s.passed();
                refs.push(s.reference);
            }
            for (i, name) in [(1, "quadratic"), (2, "bilinear"), (3, "cubic")] {
                println!(
                    "channel frame ({name} remap) vs cylinder frame, reference Δt: relative L² \
                     difference of K = {:.3e}",
                    relative_l2_difference(&refs[i], &refs[0])
                );
            }
        }
        Study::ExplicitCoupling => {
            use crate::solver::ale::Remap;
            use crate::validate::moving::{
                translating_cylinder_convergence, CylinderStress, Frame, MIN_TIME_RATE,
            };
            let h = hs.first().copied().unwrap_or(0.25);
            for coupled_g in [false, true] {
                let s = translating_cylinder_convergence(
                    h,
                    &[0.02, 0.01, 0.005],
                    0.0025,
                    cut,
                    Remap::Bilinear,
                    Frame::Cylinder,
                    CylinderStress::Explicit { coupled_g },
                )?;
                let g = if coupled_g {
                    "coupled G"
                } else {
                    "lagged Gⁿ"
                };
                println!(
                    "cylinder frame, η_s = 0.1, explicit coupling, {g}\n{}",
                    s.to_markdown()
                );
                ok &= !coupled_g || s.rate >= MIN_TIME_RATE;
            }
        }
        Study::TwoParticles => {
            let runs = crate::validate::particles::two_particles_stokes([240, 60], 0.1, Some(out))?;
            println!("| l_y | outcome | expected | decided at t | steps | time |\n|---|---|---|---|---|---|");
            for r in &runs {
                println!(
                    "| {:.2} | {} | {} | {:.1} | {} | {:.0} s |",
                    r.ly,
                    r.kind.as_str(),
                    r.expected.as_str(),
                    r.t_decided,
                    r.steps,
                    r.seconds
                );
                ok &= r.kind == r.expected;
            }
            println!("trajectories: {}/two_particles_ly*.csv", out.display());
        }
        Study::LabFrame => {
            use crate::validate::particles::{
                lab_frame_comparison, max_omega_difference, LabRun, LAB_FRAME_OMEGA_TOL,
            };
            let lab = |remap, follow| LabRun { remap, follow };
            let runs = lab_frame_comparison(
                [160, 80],
                2.5,
                &[
                    lab("bicubic", None),
                    lab("biquadratic", None),
                    lab("bicubic", Some(2.0)),
                ],
            );
            // every 15th sample: t* = 0, 0.3, 0.6, …
            ok &= print_frame_runs(
                "Single particle (thesis §5.5, Y0/H = 0.1, 160×80, Δt = 0.02): ω* / V* per run",
                &runs,
                15,
                |a, b| format!("{a:.4} / {b:+.5}"),
            );
            for (k, r) in runs.iter().enumerate().skip(1) {
                let d = max_omega_difference(r, &runs[0]);
                println!(
                    "{}: max |ω* − ω*(co-moving)| = {d:.4} ({:.0} s)",
                    r.label, r.seconds
                );
                // the default remap, on the fixed and on the following mesh
                if k == 1 || k == 3 {
                    ok &= d <= LAB_FRAME_OMEGA_TOL;
                }
            }
            println!("tolerance (default remap, fixed and following mesh): {LAB_FRAME_OMEGA_TOL}");
        }
        Study::CouetteFrame => {
            use crate::validate::particles::{couette_frame_comparison, COUETTE_FOLLOW_TOL};
            let runs = couette_frame_comparison(10.0);
            // every 25th sample (sampled every 5 steps): t* = 0, 0.5, 1, …
            ok &= print_frame_runs(
                "Couette particle (thesis §3.5.2, 30×160, bicubic, Δt = 0.02): r* / ω* per run",
                &runs,
                25,
                |a, b| format!("{a:.5} / {b:.4}"),
            );
            let end = |r: &crate::validate::particles::FrameRun| r.series.last().map(|s| s.1);
            if let (Some(reference), true) = (end(&runs[0]), ok) {
                for (k, r) in runs.iter().enumerate().skip(1) {
                    let d = end(r).unwrap_or(f64::NAN) - reference;
                    println!(
                        "{}: r*(end) − rotating frame = {d:+.5} ({:.0} s)",
                        r.label, r.seconds
                    );
                    if k == 2 {
                        ok &= d.abs() <= COUETTE_FOLLOW_TOL;
                    }
                }
            }
            println!("tolerance (following mesh): {COUETTE_FOLLOW_TOL}");
        }
        Study::StokesMms | Study::Couette => unreachable!("handled by validate"),
    }
    println!("verdict: {}", if ok { "PASS" } else { "FAIL" });
    Ok(if ok {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}

/// Prints the runs of a frame comparison as a markdown table (every `every`-th sample, the two
/// quantities by `cell`) and the runs that stopped early; false if one did.
fn print_frame_runs(
    title: &str,
    runs: &[crate::validate::particles::FrameRun],
    every: usize,
    cell: impl Fn(f64, f64) -> String,
) -> bool {
    let header: Vec<&str> = runs.iter().map(|r| r.label.as_str()).collect();
    println!(
        "{title}\n\n| t* | {} |\n|---|{}",
        header.join(" | "),
        "---|".repeat(runs.len())
    );
    let n = runs.iter().map(|r| r.series.len()).min().unwrap_or(0);
    for i in (0..n).step_by(every) {
        let cells: Vec<String> = runs
            .iter()
            .map(|r| cell(r.series[i].1, r.series[i].2))
            .collect();
        println!("| {:.2} | {} |", runs[0].series[i].0, cells.join(" | "));
    }
    println!();
    let mut ok = true;
    for r in runs {
        if let Some(e) = &r.error {
            println!("{} stopped early: {e}", r.label);
            ok = false;
        }
    }
    ok
}

/// Element sizes of `xpflow validate cylinder` without `--h`: the Newtonian study's sequence, or
/// for Wi > 0 the coarsest mesh that meets the tolerance in about a minute (measured:
/// Wi = 0.3 h = 0.1 +6.7e-4 of the 0.1 %; Wi = 0.6 h = 0.1 +2.3e-3 misses the 0.2 %, h = 0.07
/// see docs/validation.md).
fn default_cylinder_meshes(wi: f64) -> Vec<f64> {
    if wi == 0.0 {
        vec![0.1, 0.05, 0.03]
    } else if wi <= 0.45 {
        vec![0.1]
    } else {
        vec![0.07]
    }
}

/// Oldroyd-B confined cylinder: K per mesh, the K(t) history as CSV, a `K = <value>` line.
/// The verdict is that of the finest (last) mesh; coarser rows show the convergence.
fn validate_cylinder_viscoelastic(
    wi: f64,
    hs: &[f64],
    dt: f64,
    t_max: f64,
    out: &std::path::Path,
    cut: crate::xfem::CutOptions,
) -> anyhow::Result<ExitCode> {
    use crate::validate::xstokes::cylinder_drag_viscoelastic;
    // Hulsen et al. (2005) reference values quoted in thesis Table 2.4, and the tolerances
    let reference = [(0.3, 123.193, 1e-3), (0.6, 117.792, 2e-3)];
    let refv = reference.iter().find(|r| (r.0 - wi).abs() < 1e-12);
    println!("Confined cylinder, Oldroyd-B, η_s/η0 = 0.59, Wi = {wi}, Δt = {dt}");
    println!("| h/R | unknowns | steps | steady | K | rel. to reference | s/step |\n|---|---|---|---|---|---|---|");
    std::fs::create_dir_all(out)?;
    let mut ok = true;
    let mut last = f64::NAN;
    for &h in hs {
        let r = cylinder_drag_viscoelastic(wi, h, dt, t_max, cut)?;
        let rel = refv.map(|(_, k, _)| (r.k - k) / k);
        ok = match (rel, refv) {
            (Some(rel), Some((_, _, tol))) => rel.abs() < *tol && r.steady,
            // no published value at this Wi: the run must reach the steady criterion
            _ => r.steady,
        };
        println!(
            "| {h} | {} | {} | {} | {:.4} | {} | {:.3} |",
            r.dofs,
            r.steps,
            r.steady,
            r.k,
            rel.map_or("—".into(), |v| format!("{v:+.2e}")),
            r.seconds_per_step
        );
        let mut csv = String::from("t,K\n");
        for (t, k) in &r.history {
            csv += &format!("{t},{k}\n");
        }
        std::fs::write(out.join(format!("cylinder_wi{wi}_h{h}.csv")), csv)?;
        let mut csv = String::from("xi,x,y,tau_xx\n");
        for v in &r.tau_xx {
            csv += &format!("{},{},{},{}\n", v[0], v[1], v[2], v[3]);
        }
        std::fs::write(out.join(format!("cylinder_tau_xx_wi{wi}_h{h}.csv")), csv)?;
        last = r.k;
    }
    println!("K = {last:.4}");
    println!("verdict: {}", if ok { "PASS" } else { "FAIL" });
    Ok(if ok {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}

/// Cut-cell quadrature with `level` quadtree levels and the parabolic interface.
fn cut_options(level: u32) -> crate::xfem::CutOptions {
    crate::xfem::CutOptions {
        level,
        ..Default::default()
    }
}

/// `xpflow run CASE`: one case (the `[base]` of a sweep file, as its own TOML or JSON file) through
/// the same engine as a sweep: results in `results/<stem>.db`, trajectories also in
/// `results/<stem>.csv`.
fn run_case(path: &std::path::Path) -> anyhow::Result<ExitCode> {
    use crate::config::SweepSpec;
    use crate::store::{query::QueryKind, Format, Store};
    use crate::sweep::{default_runner, expand, run_sweep, SweepOptions};
    let text =
        std::fs::read_to_string(path).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    let is_json = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("json"));
    let base: serde_json::Value = if is_json {
        match serde_json::from_str(&text) {
            Ok(v) => v,
            Err(e) => {
                eprintln!("error: {}: JSON: {e}", path.display());
                return Ok(ExitCode::from(2));
            }
        }
    } else {
        match toml::from_str::<toml::Table>(&text) {
            Ok(t) => serde_json::to_value(t)?,
            Err(e) => {
                eprintln!("error: {}: TOML: {e}", path.display());
                return Ok(ExitCode::from(2));
            }
        }
    };
    let name = path
        .file_stem()
        .map_or("case".into(), |s| s.to_string_lossy().into_owned());
    let sweep_json = serde_json::json!({ "name": name, "base": base });
    let spec = match SweepSpec::from_str(&sweep_json.to_string(), true, path)
        .and_then(|s| expand(&s).map(|c| (s, c)))
    {
        Ok(v) => v,
        Err(e) => {
            eprintln!("error: {e}");
            return Ok(ExitCode::from(2));
        }
    };
    let (spec, cases) = spec;
    let db = std::path::Path::new("results").join(format!("{name}.db"));
    let mut opts = SweepOptions::new(db.clone());
    opts.progress = crate::sweep::progress::ProgressMode::detect(false);
    let runner = default_runner();
    let summary = match run_sweep(&spec, &cases, runner.as_ref(), &opts) {
        Ok(s) => s,
        Err(e @ crate::sweep::engine::SweepError::Unsupported { .. }) => {
            eprintln!("error: {}: {e}; nothing was run", path.display());
            return Ok(ExitCode::from(2));
        }
        Err(e) => return Err(e.into()),
    };
    let store = Store::open(&db)?;
    let table = store.query(&QueryKind::Trajectory(cases[0].id.clone()), None, &[])?;
    let csv = std::path::Path::new("results").join(format!("{name}.csv"));
    std::fs::write(&csv, table.render(Format::Csv))?;
    let outcome = store.query(&QueryKind::Cases, None, &[])?;
    print!("{}", outcome.render(Format::Table));
    println!(
        "results: {} (trajectories also in {})",
        db.display(),
        csv.display()
    );
    Ok(if summary.failed > 0 {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    })
}

/// Entry point used by `main.rs`: parse, run, map errors to exit code 1 with a message.
pub fn main_with_args() -> ExitCode {
    let cli = Cli::parse();
    match run(cli) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("xpflow: error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
