//! `xpflow bench`: runs a benchmark of `crate::bench` and prints its markdown rows.

use std::process::ExitCode;

use super::args::{cut_options, parse_mesh, AleArg, BenchName, Command, FactorizationArg};

/// Runs the benchmark of a `Command::Bench`.
///
/// # Errors
/// A bad `--mesh`, or the benchmark's own failure.
pub(super) fn bench(command: Command) -> anyhow::Result<ExitCode> {
    let Command::Bench {
        name,
        mesh,
        solver,
        with_g,
        repeats,
        particles,
        h,
        cut_level,
        interface,
        follow,
        factorization,
        ale,
    } = command
    else {
        unreachable!("bench is called with the bench command")
    };
    match name {
        BenchName::Moving => {
            use crate::bench::MovingPath;
            use crate::fem::substructure::Factorization;
            use crate::solver::ale::AleExtent;
            let extents: &[AleExtent] = match ale {
                AleArg::Both => &[AleExtent::Ring, AleExtent::Whole],
                AleArg::Ring => &[AleExtent::Ring],
                AleArg::Whole => &[AleExtent::Whole],
            };
            let path = |factorization, ale| MovingPath { factorization, ale };
            let paths: Vec<MovingPath> = match factorization {
                // the new path against the refactor path as it was (whole ALE too)
                FactorizationArg::Both => {
                    vec![path(Factorization::Band, extents[0]), MovingPath::REFACTOR]
                }
                FactorizationArg::Band => extents
                    .iter()
                    .map(|&a| path(Factorization::Band, a))
                    .collect(),
                FactorizationArg::Whole => extents
                    .iter()
                    .map(|&a| path(Factorization::Whole, a))
                    .collect(),
            };
            let paths = paths.as_slice();
            println!("{}", crate::bench::MovingBench::HEADER);
            let mut closing = Vec::new();
            for m in mesh.split(',') {
                let (nx, ny) = parse_mesh(m)?;
                for &n in &particles {
                    let cut = Some((cut_level, interface.into()));
                    let runs = crate::bench::moving(
                        nx,
                        ny,
                        n,
                        3,
                        repeats.max(1),
                        with_g,
                        follow,
                        cut,
                        paths,
                    )?;
                    for b in &runs {
                        println!("{}", b.to_row());
                    }
                    if let [new, old] = runs.as_slice() {
                        println!("{}", crate::bench::ratio_row(new, old));
                        closing.push(crate::bench::step_line(new, old));
                    }
                }
            }
            for line in closing {
                println!("{line}");
            }
        }
        BenchName::Expand => {
            println!(
                "| grid | cases | expansion (best of {}) | per case |",
                repeats.max(1)
            );
            println!("|---|---|---|---|");
            let mut times = Vec::new();
            for n in [100, 200] {
                let t = crate::bench::expansion(n, repeats)?;
                println!(
                    "| {n}² | {} | {t:.3} s | {:.1} µs |",
                    n * n,
                    1e6 * t / (n * n) as f64
                );
                times.push(t);
            }
            println!(
                "expansion: 200² / 100² = {:.2} (linear: 4; the quadratic search was 31)",
                times[1] / times[0]
            );
        }
        BenchName::Stokes => {
            let (nx, ny) = parse_mesh(&mesh)?;
            let b = crate::bench::stokes(nx, ny, solver.into(), with_g, repeats)?;
            println!("{b}");
        }
        BenchName::Drag => {
            use crate::solver::multiplier::RigidCondition;
            use crate::solver::rigid::WeakForm;
            use crate::validate::xstokes::{cylinder_drag, NEWTONIAN_K};
            println!("| h/R | unknowns | K | rel. error | cut cells | assembly | symbolic | numeric | solve | total |");
            println!("|---|---|---|---|---|---|---|---|---|---|");
            for hh in h {
                let r = cylinder_drag(
                    &crate::geometry::CylinderChannel::BENCHMARK,
                    hh,
                    RigidCondition::Weak,
                    WeakForm::Symmetric,
                    cut_options(cut_level, interface),
                )?;
                let t = r.timings;
                println!(
                    "| {hh} | {} | {:.4} | {:.1e} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.2} s |",
                    r.dofs,
                    r.k_reaction,
                    ((r.k_reaction - NEWTONIAN_K) / NEWTONIAN_K).abs(),
                    r.cut_seconds,
                    t.assembly,
                    t.symbolic,
                    t.numeric,
                    t.solve,
                    r.seconds
                );
            }
        }
    }
    Ok(ExitCode::SUCCESS)
}
