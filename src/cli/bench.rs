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
        sweep,
        case,
        db,
    } = command
    else {
        unreachable!("bench is called with the bench command")
    };
    match name {
        BenchName::Moving => {
            use crate::bench::MovingPath;
            use crate::fem::substructure::Factorization;
            use crate::solver::ale::AleExtent;
            let study = match (sweep, case) {
                (Some(file), Some(id)) => match StudyCase::load(&file, &id, db.as_deref()) {
                    Ok(s) => Some(s),
                    Err(e) => {
                        eprintln!("error: {e}");
                        return Ok(ExitCode::from(2));
                    }
                },
                _ => None,
            };
            // a study's case on its own ALE extent unless `--ale` says otherwise
            let own = study
                .as_ref()
                .map_or(AleExtent::Whole, |s| s.spec.numerics.ale_extent);
            let extents: &[AleExtent] = match ale {
                Some(AleArg::Both) => &[AleExtent::Ring, AleExtent::Whole],
                Some(AleArg::Ring) => &[AleExtent::Ring],
                Some(AleArg::Whole) => &[AleExtent::Whole],
                None => std::slice::from_ref(&own),
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
            let mut closing = Vec::new();
            let mut print = |runs: Vec<crate::bench::MovingBench>| {
                for b in &runs {
                    println!("{}", b.to_row());
                }
                if let [new, old] = runs.as_slice() {
                    println!("{}", crate::bench::ratio_row(new, old));
                    closing.push(crate::bench::step_line(new, old));
                }
            };
            if let Some(study) = study {
                if let Some(from) = &study.from {
                    println!("{from}");
                }
                println!("{}", crate::bench::MovingBench::HEADER);
                let on_path = |p| Ok(crate::bench::on_path(study.spec.clone(), p));
                let source = crate::bench::MovingSource {
                    label: study.label.clone(),
                    case: &on_path,
                    state: study.state.as_deref(),
                };
                print(crate::bench::moving(&source, 3, repeats.max(1), paths)?);
            } else {
                println!("{}", crate::bench::MovingBench::HEADER);
                for m in mesh.split(',') {
                    let (nx, ny) = parse_mesh(m)?;
                    for &n in &particles {
                        let cut = Some((cut_level, interface.into()));
                        let case = |p| crate::bench::moving_case(nx, ny, n, with_g, follow, cut, p);
                        let source = crate::bench::MovingSource::standard(nx, ny, follow, &case);
                        print(crate::bench::moving(&source, 3, repeats.max(1), paths)?);
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

/// A study's case for the moving benchmark (`--sweep FILE --case ID [--db DB]`).
struct StudyCase {
    /// The case as the sweep expands it.
    spec: crate::config::CaseSpec,
    /// The mesh column of the table: the case's label and id.
    label: String,
    /// The saved state every path continues from, if `--db` has one.
    state: Option<String>,
    /// Where the paths start, when from a saved state.
    from: Option<String>,
}

impl StudyCase {
    /// The case `id` of sweep file `file` and, with `db`, its saved state there.
    ///
    /// # Errors
    /// The reason (file, case), when the sweep file is invalid, `id` selects no single case or
    /// `db` holds no saved state of it.
    fn load(
        file: &std::path::Path,
        id: &str,
        db: Option<&std::path::Path>,
    ) -> Result<Self, String> {
        let spec = crate::config::SweepSpec::from_file(file).map_err(|e| e.to_string())?;
        let cases = crate::sweep::expand(&spec).map_err(|e| e.to_string())?;
        let only = super::sweep_cmds::select_cases(&cases, &[id.to_string()])
            .map_err(|e| format!("{}: {e}", file.display()))?;
        // (one id given: `select_cases` names exactly one case or refuses)
        let only = only.unwrap_or_default();
        let c = cases
            .into_iter()
            .find(|c| only.contains(&c.id))
            .expect("select_cases matched one case");
        let (state, from) = match db {
            None => (None, None),
            Some(db) => {
                let (step, t, state) = crate::sweep::engine::saved_runner_state(db, &c.id)
                    .ok_or_else(|| {
                        format!(
                            "{}: case {} has no saved state (a sweep with --state-every saves one)",
                            db.display(),
                            c.id
                        )
                    })?;
                let from = format!(
                    "from the saved state of case {} at step {step} (t = {t:.4})",
                    c.id
                );
                (Some(state), Some(from))
            }
        };
        Ok(StudyCase {
            label: format!("{} ({})", c.label, &c.id[..8.min(c.id.len())]),
            spec: c.spec,
            state,
            from,
        })
    }
}
