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
    /// Run one case from a case file (TOML) and write its trajectories.
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
    },
    /// Run a performance benchmark.
    Bench {
        /// Which benchmark.
        name: BenchName,
        /// Mesh as NXxNY (elements), e.g. 200x50.
        #[arg(long, default_value = "200x50")]
        mesh: String,
        /// Linear solver.
        #[arg(long, value_enum, default_value_t = SolverArg::Lblt)]
        solver: SolverArg,
        /// Include the DEVSS-G unknowns.
        #[arg(long)]
        with_g: bool,
        /// Repeated solves after the first (median reported).
        #[arg(long, default_value_t = 5)]
        repeats: usize,
    },
}

/// Validation studies.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum Study {
    /// Manufactured solution, periodic channel and annulus, with and without DEVSS-G.
    StokesMms,
    /// Plane and circular Couette flow.
    Couette,
    /// Newtonian / Oldroyd-B drag on the confined cylinder (Ch. 2).
    Cylinder,
}

/// Benchmarks.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum BenchName {
    /// One Stokes (Q2/Q1) solve: assembly, symbolic, numeric, refactor, solve.
    Stokes,
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

fn not_built(what: &str, issue: &str) -> anyhow::Result<ExitCode> {
    eprintln!("xpflow: `{what}` is not built yet ({issue}); nothing was run.");
    Ok(ExitCode::from(3))
}

/// Runs the CLI on already-parsed arguments.
pub fn run(cli: Cli) -> anyhow::Result<ExitCode> {
    match cli.command {
        Command::Run { .. } => not_built("run", "moving-particle solver: issues 3 and 5"),
        Command::Sweep(args) => sweep_cmds::run_sweep(&args),
        Command::Query(args) => sweep_cmds::run_query(&args),
        Command::Status(args) => sweep_cmds::run_status(&args),
        Command::Validate {
            study,
            levels,
            solver,
        } => validate(study, levels, solver.into()),
        Command::Bench {
            name: BenchName::Stokes,
            mesh,
            solver,
            with_g,
            repeats,
        } => {
            let (nx, ny) = parse_mesh(&mesh)?;
            let b = crate::bench::stokes(nx, ny, solver.into(), with_g, repeats)?;
            println!("{b}");
            Ok(ExitCode::SUCCESS)
        }
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
        Study::Cylinder => return not_built("validate cylinder", "XFEM core: issue 3"),
    }
    Ok(if ok {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
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
