//! Command-line interface: thin wrappers over the library (`main.rs` only calls [`main_with_args`]).
//! Arguments in [`args`]; one file per command family.

pub mod args;
mod bench;
pub mod cluster;
mod cylinder;
mod estimate;
pub mod export;
mod extrudate;
pub mod query_cmds;
mod run;
mod search_cmds;
pub mod status_cmds;
pub mod sweep_cmds;
mod tries_cmds;
mod validate;

use std::process::ExitCode;

use clap::Parser;

pub use args::{BenchName, Cli, Command, InterfaceArg, SolverArg, Study};

/// Runs the CLI on already-parsed arguments.
///
/// # Errors
/// What the command reports; usage errors of case and sweep files are exit code 2 instead.
pub fn run(cli: Cli) -> anyhow::Result<ExitCode> {
    match cli.command {
        Command::Run { case, resolved } => run::run_case(&case, resolved),
        Command::Sweep(args) => sweep_cmds::run_sweep(&args),
        Command::Query(args) => query_cmds::run_query(&args),
        Command::Status(args) => status_cmds::run_status(&args),
        Command::RunCase(args) => cluster::run_case(&args),
        Command::Merge(args) => cluster::merge(&args),
        Command::Export(args) => export::run_export(&args),
        Command::Validate {
            study,
            levels,
            solver,
            wi,
            h,
            de,
            graded,
            out,
            dt,
            t_max,
            cut_level,
            interface,
            method,
            rigid_condition,
            elements,
            center_x,
        } => match study {
            _ if elements.is_some() && study != Study::CouetteWallMode => {
                anyhow::bail!("--elements applies to `xpflow validate couette-wall-mode` only")
            }
            _ if center_x.is_some() && study != Study::Cylinder => {
                anyhow::bail!("--center-x applies to `xpflow validate cylinder` only")
            }
            _ if method != args::MethodArg::Xfem && study != Study::Cylinder => {
                anyhow::bail!("--method fdm applies to `xpflow validate cylinder` only")
            }
            _ if rigid_condition != args::RigidConditionArg::Weak && study != Study::Cylinder => {
                anyhow::bail!(
                    "--rigid-condition applies to `xpflow validate cylinder` only \
                     (`xfem-stokes` runs both conditions)"
                )
            }
            Study::StokesMms | Study::Couette => validate::validate(study, levels, solver.into()),
            Study::CouetteWallMode => {
                use crate::validate::couette_wall_mode::{STUDY_DT, STUDY_WI};
                let mesh = elements
                    .as_deref()
                    .map(args::parse_mesh)
                    .transpose()?
                    .map(|(n_theta, n_r)| [n_theta, n_r]);
                validate::couette_wall_mode(
                    if wi == 0.0 { STUDY_WI } else { wi },
                    dt.unwrap_or(STUDY_DT),
                    mesh,
                )
            }
            Study::ExtrudateSwell => extrudate::validate_extrudate_swell(
                &h.unwrap_or_else(|| validate::default_meshes(study, wi)),
                &de,
                graded,
                dt,
                t_max.unwrap_or(crate::validate::extrudate::SWELL_T_MAX),
                &out,
            ),
            Study::Cylinder => cylinder::validate_cylinder(
                wi,
                &h.unwrap_or_else(|| validate::default_meshes(study, wi)),
                &center_x
                    .unwrap_or_else(|| vec![crate::geometry::CylinderChannel::BENCHMARK.center_x]),
                dt.unwrap_or(0.01),
                t_max.unwrap_or(20.0),
                &out,
                args::discretization(method, cut_level, interface)?,
                rigid_condition.into(),
            ),
            _ => validate::validate_particles(
                study,
                levels,
                &h.unwrap_or_else(|| validate::default_meshes(study, wi)),
                &out,
                args::cut_options(cut_level, interface),
            ),
        },
        bench @ Command::Bench { .. } => bench::bench(bench),
    }
}

/// Entry point used by `main.rs`: parse, run, map errors to exit code 1 with a message.
pub fn main_with_args() -> ExitCode {
    let cli = Cli::parse();
    match run(cli) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("xpflow: error: {}", message(&e));
            ExitCode::FAILURE
        }
    }
}

/// The error and its causes on one line, each cause once: errors that already show their source
/// in their own text (`database X: file is not a database`) are not repeated by the chain.
fn message(e: &anyhow::Error) -> String {
    let mut text = String::new();
    for cause in e.chain() {
        let s = cause.to_string();
        if !text.contains(&s) {
            if !text.is_empty() {
                text += ": ";
            }
            text += &s;
        }
    }
    text
}
