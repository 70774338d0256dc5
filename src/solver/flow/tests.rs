//! Unit tests of the flow solver: moved particles and moved meshes against solvers built anew.

use super::*;
use crate::mesh::{Axis, Side};
use crate::solver::cutcells::compute_cuts;
use crate::solver::rigid::Motion;
use crate::xfem::CutOptions;

/// Same matrix entries assembled in the same order: only the factorization's round-off
/// differs (when the pattern is rebuilt the ordering may differ).
const SAME_SYSTEM_TOL: f64 = 1e-10;

fn channel() -> Mesh {
    Mesh::rectangle(
        Axis::uniform(-1.0, 1.0, 16),
        Axis::uniform(-0.5, 0.5, 8),
        true,
    )
}

/// The period of a periodic channel.
fn period(mesh: &Mesh) -> f64 {
    mesh.ax.vertices[mesh.ax.len()] - mesh.ax.vertices[0]
}

fn solve_at(st: &mut Stokes) -> StokesSolution {
    st.solve(&|_| [0.0, 0.0]).unwrap()
}

fn fresh(mesh: &Mesh, center: [f64; 2]) -> Stokes {
    let p = vec![Particle {
        center,
        radius: 0.2,
        motion: Motion::Free,
    }];
    let cuts = compute_cuts(mesh, &p, Some(period(mesh)), CutOptions::default()).unwrap();
    let mut st = Stokes::with_particles(
        mesh.clone(),
        StokesParams::new(1.0, 0.0, SolverKind::Lblt),
        p,
        cuts,
    );
    st.set_velocity(Side::Bottom, |_| [-0.5, 0.0]);
    st.set_velocity(Side::Top, |_| [0.5, 0.0]);
    st.pin_pressure();
    st
}

fn moved(st: &mut Stokes, center: [f64; 2]) {
    let p = vec![Particle {
        center,
        radius: 0.2,
        motion: Motion::Free,
    }];
    let cuts = compute_cuts(&st.mesh, &p, Some(period(&st.mesh)), CutOptions::default()).unwrap();
    st.set_particles(p, cuts);
}

fn max_diff(a: &StokesSolution, b: &StokesSolution) -> f64 {
    let du =
        a.u.iter()
            .zip(&b.u)
            .map(|(x, y)| (x[0] - y[0]).abs().max((x[1] - y[1]).abs()));
    let dr = a
        .rigid
        .iter()
        .zip(&b.rigid)
        .flat_map(|(x, y)| (0..3).map(move |c| (x[c] - y[c]).abs()));
    du.chain(dr).fold(0.0, f64::max)
}

/// A Stokes whose mesh moved and one built on the moved mesh assemble the same element
/// matrices, summed in another order (cached base or every step) and factored in another
/// elimination order (the fresh pattern's reach is taken from the new coordinates): they
/// differ by the round-off of a direct solve, relative to the solution's scale.
const FRESH_BUILD_TOL: f64 = 1e-10;

/// The channel of the moving-mesh tests, 32×16: wide enough that the moving-element mask
/// (the changed columns and rows widened by [`MOVING_MARGIN`]) leaves elements in the base.
fn long_channel() -> Mesh {
    periodic_channel(32, 16)
}

/// The periodic channel [−2, 2] × [−½, ½] with `nx` × `ny` elements.
fn periodic_channel(nx: usize, ny: usize) -> Mesh {
    Mesh::rectangle(
        Axis::uniform(-2.0, 2.0, nx),
        Axis::uniform(-0.5, 0.5, ny),
        true,
    )
}

/// `axis` with the vertices `lo..=hi` moved toward `c` by the factor `s` (a local grading).
fn squeezed(axis: &Axis, lo: usize, hi: usize, c: f64, s: f64) -> Axis {
    let mut vertices = axis.vertices.clone();
    vertices[lo..=hi]
        .iter_mut()
        .for_each(|x| *x = c + s * (*x - c));
    Axis { vertices }
}

/// `mesh` graded around the test particle: columns 13..=18 and rows 6..=9 move, elements of
/// the fluid base among them.
fn graded_around_the_particle(mesh: &Mesh) -> Mesh {
    mesh.with_axes(
        squeezed(&mesh.ax, 14, 18, 0.0, 0.8),
        squeezed(&mesh.ay, 7, 9, 0.1, 0.8),
    )
}

/// Largest difference of velocity, pressure and rigid velocities relative to the largest of
/// them in `b`.
fn rel_diff(a: &StokesSolution, b: &StokesSolution) -> f64 {
    let dp = a.p.iter().zip(&b.p).map(|(x, y)| (x - y).abs());
    let scale = (b.u.iter().flatten().chain(&b.p))
        .chain(b.rigid.iter().flatten())
        .fold(0.0, |m: f64, v| m.max(v.abs()));
    dp.fold(max_diff(a, b), f64::max) / scale
}

#[test]
fn a_moved_mesh_solves_like_a_stokes_built_on_it() {
    let mesh = long_channel();
    let c = [0.013, 0.101];
    let mut st = fresh(&mesh, c);
    // builds the fluid base on the uniform mesh
    let before = solve_at(&mut st);
    let graded = graded_around_the_particle(&mesh);
    st.set_mesh(graded.clone());
    moved(&mut st, c);
    let a = solve_at(&mut st);
    assert_eq!((st.pattern_rebuilds, st.base_rebuilds), (0, 1));
    let b = solve_at(&mut fresh(&graded, c));
    let d = rel_diff(&a, &b);
    eprintln!("moved mesh vs fresh: {d:.2e}");
    assert!(d < FRESH_BUILD_TOL, "{d}");
    // not vacuous: the nodes moved in the shear flow
    assert!(max_diff(&a, &before) > 1e-3, "{}", max_diff(&a, &before));
}

#[test]
fn moves_inside_the_mask_keep_the_fluid_base() {
    let mesh = long_channel();
    let c = [0.013, 0.101];
    let mut st = fresh(&mesh, c);
    let _ = solve_at(&mut st);
    let graded = graded_around_the_particle(&mesh);
    st.set_mesh(graded);
    moved(&mut st, c);
    let _ = solve_at(&mut st);
    assert_eq!(st.base_rebuilds, 1);
    // the grading travels on with the particle: columns 13..=19 and rows 6..=10 change,
    // inside the mask (columns 9..=22, rows 2..=13)
    let c2 = [0.05, 0.11];
    let next = mesh.with_axes(
        squeezed(&mesh.ax, 15, 19, 0.05, 0.7),
        squeezed(&mesh.ay, 7, 10, 0.11, 0.8),
    );
    st.set_mesh(next.clone());
    moved(&mut st, c2);
    let a = solve_at(&mut st);
    assert_eq!((st.pattern_rebuilds, st.base_rebuilds), (0, 1));
    let d = rel_diff(&a, &solve_at(&mut fresh(&next, c2)));
    eprintln!("second move vs fresh: {d:.2e}");
    assert!(d < FRESH_BUILD_TOL, "{d}");
    // back to the uniform axes
    st.set_mesh(mesh.clone());
    moved(&mut st, c);
    let a = solve_at(&mut st);
    assert_eq!((st.pattern_rebuilds, st.base_rebuilds), (0, 1));
    let d = rel_diff(&a, &solve_at(&mut fresh(&mesh, c)));
    eprintln!("moved back vs fresh: {d:.2e}");
    assert!(d < FRESH_BUILD_TOL, "{d}");
    // columns moved outside the mask (across the periodic seam) grow it: one more rebuild
    let far = mesh.with_axes(squeezed(&mesh.ax, 1, 3, 0.0, 0.9), mesh.ay.clone());
    st.set_mesh(far.clone());
    moved(&mut st, c);
    let a = solve_at(&mut st);
    assert_eq!((st.pattern_rebuilds, st.base_rebuilds), (0, 2));
    let d = rel_diff(&a, &solve_at(&mut fresh(&far, c)));
    eprintln!("far columns vs fresh: {d:.2e}");
    assert!(d < FRESH_BUILD_TOL, "{d}");
}

#[test]
fn a_moved_annulus_re_evaluates_the_wall_velocities() {
    // circular Couette flow: inner cylinder turning at ω = 1, outer at rest
    let couette = |mesh: &Mesh| {
        let params = StokesParams::new(1.0, 0.0, SolverKind::Lblt);
        let mut st = Stokes::new(mesh.clone(), params);
        st.set_velocity(Side::Bottom, |x| [-x[1], x[0]]);
        st.set_velocity(Side::Top, |_| [0.0, 0.0]);
        st.pin_pressure();
        st
    };
    let n = 24;
    let mesh = Mesh::annulus(n, Axis::uniform(1.0, 2.0, 4));
    let mut st = couette(&mesh);
    let before = solve_at(&mut st);
    // a non-uniform θ axis with the same span: the wall nodes slide along the circles
    let tau = 2.0 * std::f64::consts::PI;
    let mut vertices: Vec<f64> = (0..=n)
        .map(|i| {
            let s = i as f64 / n as f64;
            tau * s + 0.3 * (tau * s).sin()
        })
        .collect();
    vertices[n] = mesh.ax.vertices[n];
    let theta = Axis { vertices };
    let moved_mesh = mesh.with_axes(theta, mesh.ay.clone());
    st.set_mesh(moved_mesh.clone());
    let a = solve_at(&mut st);
    let d = rel_diff(&a, &solve_at(&mut couette(&moved_mesh)));
    eprintln!("moved annulus vs fresh: {d:.2e}");
    assert!(d < FRESH_BUILD_TOL, "{d}");
    // not vacuous: the wall nodes moved, and with them their velocities
    let k = moved_mesh.side_nodes(Side::Bottom)[3];
    assert!((a.u[k][0] - before.u[k][0]).abs() > 1e-2);
    assert_eq!(a.u[k], [-moved_mesh.nodes[k][1], moved_mesh.nodes[k][0]]);
}

#[test]
fn moving_a_particle_equals_building_anew_and_reuses_the_pattern() {
    let mesh = channel();
    let mut st = fresh(&mesh, [0.013, 0.101]);
    let _ = solve_at(&mut st);
    // a small move keeps every element's kind: same pattern, same symbolic analysis
    moved(&mut st, [0.0135, 0.1012]);
    let a = solve_at(&mut st);
    assert_eq!(st.pattern_rebuilds, 0);
    let b = solve_at(&mut fresh(&mesh, [0.0135, 0.1012]));
    assert!(max_diff(&a, &b) < SAME_SYSTEM_TOL, "{}", max_diff(&a, &b));
    // a long move across the seam changes the cut elements: the pattern is rebuilt
    moved(&mut st, [0.95, -0.1]);
    let a = solve_at(&mut st);
    assert_eq!(st.pattern_rebuilds, 1);
    let b = solve_at(&mut fresh(&mesh, [0.95, -0.1]));
    assert!(max_diff(&a, &b) < SAME_SYSTEM_TOL, "{}", max_diff(&a, &b));
    // wall velocities survive the move
    let top = mesh.side_nodes(Side::Top)[3];
    assert_eq!(a.u[top], [0.5, 0.0]);
}

/// A band solve against a whole factorization of the same matrix: both meet the residual
/// [`RESIDUAL_TOL`]; their solutions differ by the conditioning of the cut system times that
/// (measured: ≤ 3e-12 here).
const BAND_VS_WHOLE_TOL: f64 = 1e-9;

/// [`fresh`] with a small particle on a long channel, factored as `factorization` says.
fn fresh_small(mesh: &Mesh, center: [f64; 2], factorization: FlowFactorization) -> Stokes {
    let p = vec![Particle {
        center,
        radius: 0.1,
        motion: Motion::Free,
    }];
    let cuts = compute_cuts(mesh, &p, Some(period(mesh)), CutOptions::default()).unwrap();
    sheared(mesh, p, cuts, factorization)
}

/// Stokes flow between walls sliding at ∓½ around `particles`, factored as `factorization` says.
fn sheared(
    mesh: &Mesh,
    particles: Vec<Particle>,
    cuts: Vec<ElementCut>,
    factorization: FlowFactorization,
) -> Stokes {
    let mut params = StokesParams::new(1.0, 0.0, SolverKind::Lblt);
    params.factorization = factorization;
    let mut st = Stokes::with_particles(mesh.clone(), params, particles, cuts);
    st.set_velocity(Side::Bottom, |_| [-0.5, 0.0]);
    st.set_velocity(Side::Top, |_| [0.5, 0.0]);
    st.pin_pressure();
    st
}

fn moved_small(st: &mut Stokes, center: [f64; 2]) {
    let p = vec![Particle {
        center,
        radius: 0.1,
        motion: Motion::Free,
    }];
    let cuts = compute_cuts(&st.mesh, &p, Some(period(&st.mesh)), CutOptions::default()).unwrap();
    st.set_particles(p, cuts);
}

#[test]
fn the_band_solver_solves_as_the_whole_factorization() {
    // 64×16 elements of h = 1/16: the band around the particle is about 13 % of the channel
    let mesh = periodic_channel(64, 16);
    let c = [0.013, 0.051];
    let mut band = fresh_small(&mesh, c, FlowFactorization::Band);
    let mut whole = fresh_small(&mesh, c, FlowFactorization::Whole);
    // moves of a fraction of an element keep the pattern and the band's placement; 0.3 (five
    // elements) leaves the reach: new pattern, new placement
    for (dx, placements) in [(0.0, 1), (0.004, 1), (0.011, 1), (0.03, 1), (0.3, 2)] {
        let x = [c[0] + dx, c[1] - 0.3 * dx];
        moved_small(&mut band, x);
        moved_small(&mut whole, x);
        let (a, b) = (solve_at(&mut band), solve_at(&mut whole));
        let d = rel_diff(&a, &b);
        eprintln!("band vs whole at dx = {dx}: {d:.2e}");
        assert!(d <= BAND_VS_WHOLE_TOL, "dx = {dx}: {d:.2e}");
        assert_eq!(band.placements, placements, "dx = {dx}");
        assert!(band.timings.placement > 0.0 || dx != 0.3);
    }
    assert_eq!(band.band_fallbacks, 0);
    assert_eq!(whole.placements, 0);
    assert_eq!(band.refactorizations, whole.refactorizations);
}

/// Six particles of radius 0.1 along the channel at x = −1.75, −1.15, …, 1.25, moved by `dx`.
fn row_of_particles(mesh: &Mesh, dx: f64) -> (Vec<Particle>, Vec<ElementCut>) {
    let p: Vec<Particle> = (0..6)
        .map(|i| Particle {
            center: [-1.75 + 0.6 * i as f64 + dx, 0.03 * (i % 2) as f64],
            radius: 0.1,
            motion: Motion::Free,
        })
        .collect();
    let cuts = compute_cuts(mesh, &p, Some(period(mesh)), CutOptions::default()).unwrap();
    (p, cuts)
}

#[test]
fn a_band_whose_interface_is_too_large_gives_way_to_the_whole_matrix() {
    // 96×24, n ≈ 21 200 dofs: the limit is 7.5 √n ≈ 1090 interface dofs; one particle's band
    // boundary has 280, six have 1590
    let mesh = periodic_channel(96, 24);
    let setup = |factorization| {
        let (p, cuts) = row_of_particles(&mesh, 0.0);
        sheared(&mesh, p, cuts, factorization)
    };
    let (mut band, mut whole) = (
        setup(FlowFactorization::Band),
        setup(FlowFactorization::Whole),
    );
    // a move within the reach keeps the pattern: the decision is not made again
    for dx in [0.0, 0.005] {
        for st in [&mut band, &mut whole] {
            let (p, cuts) = row_of_particles(&mesh, dx);
            st.set_particles(p, cuts);
        }
        let d = rel_diff(&solve_at(&mut band), &solve_at(&mut whole));
        assert!(d <= BAND_VS_WHOLE_TOL, "dx = {dx}: {d:.2e}");
    }
    assert_eq!((band.placements, band.band_declines), (0, 1));
    assert_eq!(band.pattern_rebuilds, 0);
    // one particle's band is placed as before
    let mut one = fresh_small(&mesh, [0.013, 0.051], FlowFactorization::Band);
    solve_at(&mut one);
    assert_eq!((one.placements, one.band_declines), (1, 0));
}

#[test]
fn the_reach_stretches_along_a_drift_and_shrinks_when_the_drift_stops() {
    // 64×16 elements of h = 1/16, a particle of 3.2 elements' radius drifting by 0.4 elements
    // per move: a disc reach (two elements beyond the radius) is outgrown every 5–7 moves
    let mesh = periodic_channel(64, 16);
    let at = |x: f64| {
        let p = vec![Particle {
            center: [x, 0.05],
            radius: 0.2,
            motion: Motion::Free,
        }];
        let cuts = compute_cuts(&mesh, &p, Some(period(&mesh)), CutOptions::default()).unwrap();
        (p, cuts)
    };
    let (p, cuts) = at(-1.0);
    let mut band = sheared(&mesh, p, cuts, FlowFactorization::Band);
    solve_at(&mut band);
    let mut x = -1.0;
    for k in 1..=48 {
        x += 0.025;
        let (p, cuts) = at(x);
        band.set_particles(p, cuts);
        let a = solve_at(&mut band);
        if k % 12 == 0 {
            let (p, cuts) = at(x);
            let b = solve_at(&mut sheared(&mesh, p, cuts, FlowFactorization::Whole));
            let d = rel_diff(&a, &b);
            assert!(d <= BAND_VS_WHOLE_TOL, "move {k}: {d:.2e}");
        }
    }
    // the first pattern is a disc; from the second on the reach reaches one radius ahead, so a
    // pattern lasts 13–16 moves
    let drifting = band.pattern_rebuilds;
    eprintln!(
        "48 moves: {drifting} pattern rebuilds, {} placements, ahead {:?}",
        band.placements, band.reach.ahead
    );
    assert!((3..=4).contains(&drifting), "{drifting} rebuilds");
    let ahead = band.reach.ahead[0];
    assert!(
        (ahead[0] - 0.2).abs() < 1e-12 && ahead[1].abs() < 1e-12,
        "{ahead:?}"
    );
    // no placement beyond the patterns': the stretch's elements are not taken as inert
    assert_eq!(band.placements, drifting + 1);
    // the particle stops: within 2 × 4 × 16 moves the stretched reach is renewed (twice if the
    // first window still held a quarter radius of the drift), and then kept
    let still = |band: &mut Stokes| {
        for _ in 0..130 {
            let (p, cuts) = at(x);
            band.set_particles(p, cuts);
        }
    };
    still(&mut band);
    let renewed = band.pattern_rebuilds - drifting;
    assert!((1..=2).contains(&renewed), "{renewed} renewals");
    assert_eq!(band.reach.ahead[0], [0.0; 2]);
    still(&mut band);
    assert_eq!(band.pattern_rebuilds, drifting + renewed);
    let a = solve_at(&mut band);
    let (p, cuts) = at(x);
    let b = solve_at(&mut sheared(&mesh, p, cuts, FlowFactorization::Whole));
    assert!(rel_diff(&a, &b) <= BAND_VS_WHOLE_TOL);
    // a particle placed (a restored state) jumps: no drift, no stretch
    for _ in 0..3 {
        let (p, cuts) = at(x);
        band.set_particles(p, cuts);
    }
    let (p, cuts) = at(x + 0.5);
    band.place_particles(p, cuts);
    assert_eq!(band.pattern_rebuilds, drifting + renewed + 1);
    assert_eq!(band.reach.ahead[0], [0.0; 2]);
}

/// A reach's drift is the particle's motion across the mesh: a particle carried along with a
/// mesh that follows it (the mesh translated by as much) has none, one on a fixed mesh has its
/// own (0.025 per move here, 16 moves' worth, capped at its radius).
#[test]
fn a_reach_measures_the_drift_across_the_mesh() {
    use super::reach::reach_for;
    let shifted = |s: f64| {
        Mesh::rectangle(
            Axis::uniform(-2.0 + s, 2.0 + s, 64),
            Axis::uniform(-0.5, 0.5, 16),
            true,
        )
    };
    let at = |mesh: &Mesh, x: f64| {
        let p = vec![Particle {
            center: [x, 0.05],
            radius: 0.2,
            motion: Motion::Free,
        }];
        let cuts = compute_cuts(mesh, &p, Some(period(mesh)), CutOptions::default()).unwrap();
        (p, cuts)
    };
    let (mesh0, moved) = (shifted(0.0), shifted(0.1));
    let (p, cuts) = at(&mesh0, -1.0);
    let mut reach = reach_for(&mesh0, &p, &cuts, vec![[0.0; 2]]);
    (0..4).for_each(|_| reach.moved());
    // carried with the mesh: no drift
    let (p, cuts) = at(&moved, -0.9);
    let followed = reach.renewed(&moved, &p, &cuts);
    assert!(followed.ahead[0][0].abs() < 1e-12, "{:?}", followed.ahead);
    // on the fixed mesh: 0.1 in 4 moves → 0.4 ahead, capped at the radius
    let (p, cuts) = at(&mesh0, -0.9);
    let drifted = reach.renewed(&mesh0, &p, &cuts);
    assert!(
        (drifted.ahead[0][0] - 0.2).abs() < 1e-12,
        "{:?}",
        drifted.ahead
    );
    assert!(drifted.ahead[0][1].abs() < 1e-12, "{:?}", drifted.ahead);
}
