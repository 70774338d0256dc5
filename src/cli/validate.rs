//! `xpflow validate`: runs a validation study of `crate::validate` and prints its table and
//! verdict (the thresholds live with the studies).

use std::process::ExitCode;

use super::args::Study;
use crate::fem::linsolve::SolverKind;
use crate::validate::stokes::{
    circular_couette, plane_couette_max_error, stokes_mms, Domain, PLANE_COUETTE_ROUND_OFF,
};

pub(super) fn validate(
    study: Study,
    levels: usize,
    solver: SolverKind,
) -> anyhow::Result<ExitCode> {
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
            for with_g in [false, true] {
                let e = plane_couette_max_error(with_g)?;
                let pass = e < PLANE_COUETTE_ROUND_OFF;
                println!(
                    "plane Couette ({}): max nodal error {e:.3e} (≤ {PLANE_COUETTE_ROUND_OFF:e}: {})\n",
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

pub(super) fn validate_particles(
    study: Study,
    levels: usize,
    hs: &[f64],
    out: &std::path::Path,
    cut: crate::xfem::CutOptions,
) -> anyhow::Result<ExitCode> {
    use crate::solver::rigid::WeakForm;
    use crate::validate::xstokes::{
        couette_free_particle, cylinder_exact, FREE_PARTICLE_REFERENCE, FREE_PARTICLE_TOL,
    };
    let mut ok = true;
    match study {
        Study::XfemStokes => {
            use crate::solver::multiplier::RigidCondition;
            for (condition, form) in [
                (RigidCondition::Weak, WeakForm::Symmetric),
                (RigidCondition::Weak, WeakForm::Thesis),
                (RigidCondition::Multiplier, WeakForm::Symmetric),
            ] {
                let s = cylinder_exact(levels, condition, form, cut)?;
                println!("{}", s.to_markdown());
                ok &= s.passed();
            }
        }
        Study::FreeParticle => {
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
                        ok &= d.abs() < FREE_PARTICLE_TOL;
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
                    CylinderStress::Thesis { coupled_g: true },
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
        Study::VariableSteps => {
            use crate::validate::moving::{CylinderStress, Frame};
            use crate::validate::variable_steps::variable_step_convergence;
            let h = hs.first().copied().unwrap_or(0.25);
            let remap = crate::simulate::settings::ale_remap(Default::default());
            let s = variable_step_convergence(
                h,
                &[0.04, 0.02, 0.01, 0.005],
                0.0025,
                cut,
                remap,
                Frame::Channel,
                CylinderStress::Thesis { coupled_g: true },
            )?;
            println!(
                "channel frame, history remap {remap:?}\n{}",
                s.to_markdown()
            );
            ok &= s.passed();
        }
        Study::ExplicitCoupling | Study::SemiImplicitCoupling => {
            use crate::solver::ale::Remap;
            use crate::validate::moving::{
                translating_cylinder_convergence, CylinderStress, Frame, MIN_TIME_RATE,
            };
            let explicit = study == Study::ExplicitCoupling;
            let h = hs.first().copied().unwrap_or(0.25);
            let (fluid, labels) = if explicit {
                ("η_s = 0.1, explicit coupling", ["lagged Gⁿ", "coupled G"])
            } else {
                (
                    "η_s = 0, semi-implicit coupling",
                    [
                        "lagged Gⁿ (semi_implicit, auto at β = 0)",
                        "coupled G (semi_implicit_coupled_g)",
                    ],
                )
            };
            for (coupled_g, g) in [false, true].into_iter().zip(labels) {
                let stress = if explicit {
                    CylinderStress::Explicit { coupled_g }
                } else {
                    CylinderStress::Thesis { coupled_g }
                };
                let s = translating_cylinder_convergence(
                    h,
                    &[0.02, 0.01, 0.005],
                    0.0025,
                    cut,
                    Remap::Bilinear,
                    Frame::Cylinder,
                    stress,
                )?;
                println!("cylinder frame, {fluid}, {g}\n{}", s.to_markdown());
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
        Study::NearContact => ok &= near_contact(hs, cut)?,
        Study::FilmPolymer => ok &= film_polymer(hs, cut)?,
        Study::StokesMms
        | Study::Couette
        | Study::Cylinder
        | Study::ExtrudateSwell
        | Study::CouetteWallMode => {
            unreachable!("handled by validate, cylinder, extrudate and couette_wall_mode")
        }
    }
    Ok(verdict(ok))
}

/// Prints a study's `verdict: PASS` / `FAIL` line and returns its exit code.
pub(super) fn verdict(ok: bool) -> ExitCode {
    println!("verdict: {}", if ok { "PASS" } else { "FAIL" });
    if ok {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    }
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

/// `xpflow validate couette-wall-mode`: the growth rate of the seeded wall mode per coupling and
/// step on `mesh` (θ × r; default the family's, docs/validation.md "The explicit coupling's wall
/// mode"). At the study's own set-up (Wi = 1, Δt = 0.08, the family's mesh) the rates have a
/// verdict; elsewhere they are the answer to "is the explicit coupling stable here?" and the
/// command succeeds whatever they are.
pub(super) fn couette_wall_mode(
    wi: f64,
    dt: f64,
    mesh: Option<[usize; 2]>,
) -> anyhow::Result<ExitCode> {
    use crate::validate::couette_wall_mode::{
        wall_mode_study, FIT_FROM, GROWING, MESH, STUDY_DT, STUDY_WI, T_END,
    };
    let mesh = mesh.unwrap_or(MESH);
    println!(
        "undisturbed Couette flow, Wi = {wi}, {}x{} (θ × r), m = 9 seeded at the inner cylinder: \
         |c9| of tr c on the first vertex ring",
        mesh[0], mesh[1]
    );
    let (runs, passed) = wall_mode_study(wi, dt, mesh, &mut |coupling, step, t, a| {
        println!("{coupling:?} dt = {step}: t* = {t:.2} |c9| = {a:.3e}");
    })?;
    println!(
        "\n| coupling | Δt | growth of \\|c9\\| per t* over {FIT_FROM}–{T_END} |\n|---|---|---|"
    );
    for r in &runs {
        println!("| {:?} | {} | {:+.3} |", r.coupling, r.dt, r.growth_rate());
    }
    if wi == STUDY_WI && dt == STUDY_DT && mesh == MESH {
        return Ok(verdict(passed));
    }
    let explicit = runs[0].growth_rate();
    let state = if explicit > GROWING {
        "grows: the explicit coupling is unstable here"
    } else if explicit > 0.0 {
        "grows slowly (below the study's threshold): at the edge of stability"
    } else {
        "decays: the explicit coupling is stable here"
    };
    println!("\nexplicit coupling at Δt = {dt}: the wall mode {state} ({explicit:+.3} per t*)");
    Ok(ExitCode::SUCCESS)
}

/// Element sizes of `xpflow validate` without `--h` (none for the translating-cylinder studies,
/// which have their own default): for `cylinder` the Newtonian study's sequence, or
/// for Wi > 0 the coarsest mesh that meets the tolerance in about a minute (measured:
/// Wi = 0.3 h = 0.1 +6.7e-4 of the 0.1 %; Wi = 0.6 h = 0.1 +2.3e-3 misses the 0.2 %, h = 0.07
/// see docs/validation.md).
pub(super) fn default_meshes(study: Study, wi: f64) -> Vec<f64> {
    if matches!(
        study,
        Study::TranslatingCylinder
            | Study::ExplicitCoupling
            | Study::SemiImplicitCoupling
            | Study::VariableSteps
    ) {
        // each has its own default element size (`hs.first()` or it)
        Vec::new()
    } else if study == Study::NearContact {
        vec![0.2, 0.1, 0.05]
    } else if study == Study::FilmPolymer {
        vec![0.2, 0.1, 0.05, 0.025, 0.0125]
    } else if study == Study::ExtrudateSwell {
        vec![0.1, 0.05, 0.025]
    } else if wi == 0.0 {
        vec![0.1, 0.05, 0.03]
    } else if wi <= 0.45 {
        vec![0.1]
    } else {
        vec![0.07]
    }
}

/// `xpflow validate near-contact`: the force table per configuration and element size, the
/// anisotropic meshes of the strings, and the verdict of `validate::near_contact::check`.
fn near_contact(hs: &[f64], cut: crate::xfem::CutOptions) -> anyhow::Result<bool> {
    use crate::validate::near_contact::{check, contact_force, FilmMesh, Pair};
    const GAPS: [f64; 6] = [0.5, 0.2, 0.1, 0.05, 0.02, 0.01];
    let header = "| h across/a | h along/a | gap/a | gap/h | offset | F | F_lub | F/F_lub | corrected F/F_lub |\n|---|---|---|---|---|---|---|---|---|";
    let row = |f: &crate::validate::near_contact::ContactForce| {
        println!(
            "| {} | {} | {} | {:.2} | {} | {:.4e} | {:.4e} | {:.4} | {:.4} |",
            f.mesh.across,
            f.mesh.along,
            f.gap,
            f.elements(),
            f.offset,
            f.force,
            f.asymptote,
            f.ratio(),
            f.corrected_ratio()
        )
    };
    let mut failures = Vec::new();
    for pair in [Pair::Cylinders, Pair::Wall, Pair::CoRotating] {
        let motion = if pair == Pair::CoRotating {
            "ω = 1 each; F the tangential force"
        } else {
            "V = 1"
        };
        println!(
            "\n{} (a = 1, η = 1, {motion}; F_lub = asymptote)\n{header}",
            pair.name()
        );
        let offsets: &[f64] = match pair {
            Pair::Cylinders | Pair::CoRotating => &[0.0, 0.5],
            Pair::Wall => &[0.0],
        };
        let mut rows = Vec::new();
        for &h in hs {
            for gap in GAPS {
                for &offset in offsets {
                    let f = contact_force(pair, gap, FilmMesh::uniform(h), offset, cut)?;
                    row(&f);
                    rows.push(f);
                }
            }
        }
        failures.extend(check(pair, &rows));
    }
    println!("\nThe strings' meshes: finer along the channel than across it (cylinder-cylinder)\n{header}");
    for (across, along) in [
        (0.125, 0.2),
        (0.0833, 0.2),
        (0.0833, 0.0833),
        (0.0625, 0.0625),
    ] {
        for gap in [0.12, 0.08, 0.05] {
            row(&contact_force(
                Pair::Cylinders,
                gap,
                FilmMesh { across, along },
                0.5,
                cut,
            )?);
        }
    }
    for f in &failures {
        println!("FAIL {f}");
    }
    Ok(failures.is_empty())
}

/// `xpflow validate film-polymer`: the steady forces of two co-rotating cylinders in a Giesekus
/// fluid per gap and element size, and the verdict of `validate::film_polymer::check`.
fn film_polymer(hs: &[f64], cut: crate::xfem::CutOptions) -> anyhow::Result<bool> {
    use crate::validate::film_polymer::{
        check, film_forces, film_forces_refined, FilmForces, ALONG, ALPHA, BETA, FILM_BASE,
        FILM_ELEMENTS, GAPS, LAMBDA, MAX_ELEMENTS, RESOLVED_ELEMENTS,
    };
    println!(
        "co-rotating cylinders in a Giesekus fluid (a = 1, ω = 1, λ = {LAMBDA}, α = {ALPHA}, β = {BETA}), \
         steady: forces on the left one\n\
         | gap/a | h/a across | h/a along | gap/h | local Wi 2λωa/g | normal (apart) | tangential | torque | s |\n\
         |---|---|---|---|---|---|---|---|---|"
    );
    let print = |f: &FilmForces| {
        println!(
            "| {} | {} | {} | {:.2} | {:.1} | {:.4} | {:.4} | {:.4} | {:.0} |",
            f.gap,
            f.h,
            f.along,
            f.elements(),
            2.0 * LAMBDA / f.gap,
            f.normal,
            f.tangential,
            f.torque,
            f.seconds
        )
    };
    let mut rows = Vec::new();
    for gap in GAPS {
        for &h in hs.iter().filter(|&&h| gap / h <= MAX_ELEMENTS + 1e-9) {
            let f = film_forces(gap, h, h, LAMBDA, cut)?;
            print(&f);
            rows.push(f);
        }
    }
    // the thin film resolved across (the finest mesh, if it has the elements), coarser along it
    let thin = GAPS.iter().copied().fold(f64::INFINITY, f64::min);
    if let Some(h) = hs
        .iter()
        .copied()
        .filter(|h| thin / h >= RESOLVED_ELEMENTS - 1e-9)
        .reduce(f64::min)
    {
        println!("the thin film resolved across it, coarser along it:");
        for along in ALONG.into_iter().filter(|&along| along > h) {
            let f = film_forces(thin, h, along, LAMBDA, cut)?;
            print(&f);
            rows.push(f);
        }
    }
    // the thin film on the coarsest mesh with its columns refined at the film only (what a
    // following mesh with `films` gives a string)
    println!("the thin film on h/a = {FILM_BASE}, the columns refined at the film (`films`):");
    for elements in FILM_ELEMENTS {
        let f = film_forces_refined(thin, FILM_BASE, elements, LAMBDA, cut)?;
        print(&f);
        rows.push(f);
    }
    let failures = check(&rows);
    for f in &failures {
        println!("FAIL {f}");
    }
    Ok(failures.is_empty())
}
