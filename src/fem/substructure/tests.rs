//! The band solver against the whole factorization.

use super::*;
use crate::fem::sparse::PatternBuilder;

/// A Stokes-like saddle-point matrix on a 1D chain: velocities 0..n (tridiagonal, SPD), a
/// pressure per three velocities.
fn chain(n: usize, band_scale: f64, band: std::ops::Range<usize>) -> SparseMatrix {
    let np = n / 3;
    let mut pb = PatternBuilder::new(n + np);
    for i in 0..n - 1 {
        pb.add_group(&[i, i + 1]);
    }
    for p in 0..np {
        pb.add_coupling(&[n + p], &[3 * p, 3 * p + 1, 3 * p + 2]);
    }
    let mut a = pb.build();
    for i in 0..n - 1 {
        // the band's elements change between matrices
        let s = if band.contains(&i) && band.contains(&(i + 1)) {
            band_scale
        } else {
            1.0 + 0.01 * i as f64
        };
        for (r, c, v) in [(i, i, s), (i + 1, i + 1, s), (i, i + 1, -s), (i + 1, i, -s)] {
            a.add(r, c, v);
        }
    }
    a.add(0, 0, 1.0);
    for p in 0..np {
        for c in [3 * p, 3 * p + 1, 3 * p + 2] {
            a.add(n + p, c, 1.0);
            a.add(c, n + p, 1.0);
        }
    }
    a
}

/// The band solver's solution of `a x = b` is the whole factorization's (by AMD).
fn assert_solves_as_whole(sub: &mut Substructured, a: &SparseMatrix, b: &[f64], what: &str) {
    let whole = DirectSolver::analyze(a, SolverKind::Lblt).unwrap();
    assert_solves_as(sub, whole, a, b, what);
}

/// The band solver's solution of `a x = b` is that of `whole`, a solver for all of `a`.
fn assert_solves_as(
    sub: &mut Substructured,
    mut whole: DirectSolver,
    a: &SparseMatrix,
    b: &[f64],
    what: &str,
) {
    // relative residual accepted (the flow solver's)
    const TOL: f64 = 1e-10;
    let nd = a.n();
    assert!(sub.fits(a), "{what}: only the band changed");
    sub.factor(a).unwrap();
    let mut x = vec![0.0; nd];
    let res = sub.solve_checked(a, b, &mut x, TOL).unwrap();
    assert!(res <= TOL, "{what}: residual {res:.2e}");
    whole.factor(a).unwrap();
    let mut y = vec![0.0; nd];
    whole.solve_checked(a, b, &mut y, TOL).unwrap();
    let err = x
        .iter()
        .zip(&y)
        .map(|(p, q)| (p - q).abs())
        .fold(0.0, f64::max);
    let size = y.iter().map(|v| v.abs()).fold(0.0, f64::max);
    assert!(
        err <= 1e-8 * size,
        "{what}: solutions differ by {err:.2e} of {size:.2e}"
    );
    assert_eq!(
        sub.last_polish_iterations(),
        0,
        "{what}: exact up to round-off"
    );
}

/// The chain's band: the velocities 27..48 and their pressures (Γ = velocities 27 and 47).
fn chain_band(n: usize, nd: usize) -> Vec<bool> {
    (0..nd)
        .map(|d| {
            if d < n {
                (27..48).contains(&d)
            } else {
                (9..16).contains(&(d - n))
            }
        })
        .collect()
}

/// The chain's node blocks: one per velocity, in their order, and each pressure after the
/// middle velocity of its three.
fn chain_blocks(n: usize, nd: usize) -> DofBlocks {
    DofBlocks {
        block: (0..nd)
            .map(|d| if d < n { d } else { 3 * (d - n) + 1 } as u32)
            .collect(),
        class: (0..nd).map(|d| u8::from(d >= n)).collect(),
        order: Some((0..n as u32).collect()),
    }
}

/// The chain of 90 velocities whose elements 30..45 change, and its band solver.
fn chain_split() -> (usize, std::ops::Range<usize>, usize, Substructured) {
    let (n, range) = (90, 30..45);
    let a0 = chain(n, 2.0, range.clone());
    let nd = a0.n();
    let sub = Substructured::new(&a0, &chain_band(n, nd), &chain_blocks(n, nd), 1e-10).unwrap();
    (n, range, nd, sub)
}

#[test]
fn substructured_solves_match_the_whole_factorization() {
    let (n, range, nd, mut sub) = chain_split();
    assert!(sub.split().interface > 0 && sub.split().interior > 0);
    let b: Vec<f64> = (0..nd).map(|i| (0.3 * i as f64).cos()).collect();
    for scale in [2.0, 1e-4, 50.0] {
        let a = chain(n, scale, range.clone());
        assert!(sub.factor(&a).unwrap(), "a new band");
        assert!(!sub.factor(&a).unwrap(), "the same band");
        assert_solves_as_whole(&mut sub, &a, &b, &format!("band scale {scale}"));
    }
    assert_eq!(sub.pivoted_refactors(), 0, "M factored without pivots");
    // a change outside the band is noticed
    let mut far = chain(n, 2.0, range);
    far.add(3, 3, 1.0);
    assert!(!sub.fits(&far));
}

/// Γ's own entries may change with the band (S is linear in A_ΓΓ): the solution follows
/// them, and back to the placement's values M is again S₀'s.
#[test]
fn the_interface_block_may_change() {
    let (n, range, nd, mut sub) = chain_split();
    assert_eq!(sub.split().interface, 2, "Γ = velocities 27 and 47");
    let b: Vec<f64> = (0..nd).map(|i| (0.7 * i as f64).sin()).collect();
    for (d27, d47) in [(0.0, 0.0), (0.5, -0.25), (3.0, 1e-3), (0.0, 0.0)] {
        let mut a = chain(n, 7.0, range.clone());
        a.add(27, 27, d27);
        a.add(47, 47, d47);
        assert_solves_as_whole(&mut sub, &a, &b, &format!("Γ diagonal + ({d27}, {d47})"));
    }
    let mut a = chain(n, 2.0, range);
    sub.factor(&a).unwrap();
    let with_s0 = sub.m.values.clone();
    a.add(47, 47, 0.5);
    assert!(sub.factor(&a).unwrap(), "a change in Γ × Γ refactors");
    assert_ne!(sub.m.values, with_s0);
    a.add(47, 47, -0.5);
    sub.factor(&a).unwrap();
    assert_eq!(sub.m.values, with_s0, "S₀ again, bitwise");
}

/// A chain of `sites` unknowns u (SPD, tridiagonal) where the sites `pairs` also carry a
/// multiplier-like unknown p with the 2×2 block [[ε, 1], [1, 0]] on (u, p), and their u's are
/// coupled by 0.1: well conditioned for any ε, but without pivots u's pivot is ε and p's −1/ε.
fn pivot_chain(sites: usize, band: std::ops::Range<usize>, eps: f64) -> (SparseMatrix, DofBlocks) {
    let nd = sites + band.len();
    let p = |k: usize| sites + k - band.start;
    let mut pb = PatternBuilder::new(nd);
    for k in 0..sites - 1 {
        pb.add_group(&[k, k + 1]);
    }
    for k in band.clone() {
        pb.add_group(&[k, p(k)]);
    }
    let mut a = pb.build();
    for k in 0..sites {
        if band.contains(&k) {
            a.add(k, k, eps);
            a.add(k, p(k), 1.0);
            a.add(p(k), k, 1.0);
        } else {
            a.add(k, k, 3.0);
        }
        if k + 1 < sites {
            let c = if band.contains(&k) && band.contains(&(k + 1)) {
                0.1
            } else {
                -1.0
            };
            a.add(k, k + 1, c);
            a.add(k + 1, k, c);
        }
    }
    let blocks = DofBlocks {
        block: (0..nd)
            .map(|d| if d < sites { d } else { d - sites + band.start } as u32)
            .collect(),
        class: (0..nd).map(|d| u8::from(d >= sites)).collect(),
        order: Some((0..sites as u32).collect()),
    };
    (a, blocks)
}

/// A band whose unpivoted factor exists but is useless (pivots ε = 1e-14 and −1/ε) is
/// refactored with pivoting and then solves as the whole matrix does; with ε = 0.5 it is not.
#[test]
fn an_inaccurate_unpivoted_band_is_refactored_with_pivoting() {
    let (sites, band) = (40, 12..28);
    // the pairs inside the band, whose first and last sites are its interface
    let pairs = band.start + 1..band.end - 1;
    for (eps, refactors) in [(0.5, 0), (1e-14, 1)] {
        let (a, blocks) = pivot_chain(sites, pairs.clone(), eps);
        let nd = a.n();
        let in_band: Vec<bool> = (0..nd).map(|d| d >= sites || band.contains(&d)).collect();
        let mut sub = Substructured::new(&a, &in_band, &blocks, 1e-10).unwrap();
        let b: Vec<f64> = (0..nd).map(|i| (0.3 * i as f64).cos()).collect();
        let whole = DirectSolver::analyze_blocked(&a, SolverKind::Lblt, &blocks).unwrap();
        assert_solves_as(&mut sub, whole, &a, &b, &format!("eps {eps}"));
        assert_eq!(sub.pivoted_refactors(), refactors, "eps {eps}");
    }
}

/// A whole matrix's unpivoted factor, kept where it solves and replaced by the pivoted one
/// where its growth spoiled it: by the placement's check of K, and by a checked solve.
#[test]
fn a_useless_unpivoted_factor_fails_its_check() {
    const TOL: f64 = 1e-10;
    for (eps, refactored) in [(0.5, false), (1e-14, true)] {
        let (a, blocks) = pivot_chain(40, 13..27, eps);
        let mut s = DirectSolver::analyze_blocked(&a, SolverKind::Lblt, &blocks).unwrap();
        s.set_pivoting(Pivoting::WhenNeeded);
        s.factor(&a).unwrap();
        assert!(s.is_unpivoted(), "eps {eps}: no zero pivot");
        assert_eq!(s.check_unpivoted(&a, TOL).unwrap(), refactored, "eps {eps}");
        assert_eq!(s.is_unpivoted(), !refactored, "eps {eps}");
        assert_eq!(s.pivoted_refactors(), usize::from(refactored), "eps {eps}");
        // the next factorization tries without pivots again; the checked solve refactors
        s.factor(&a).unwrap();
        let b: Vec<f64> = (0..a.n()).map(|i| (0.3 * i as f64).cos()).collect();
        let mut x = vec![0.0; a.n()];
        assert!(s.solve_checked(&a, &b, &mut x, TOL).unwrap() <= TOL);
        assert_eq!(
            s.pivoted_refactors(),
            2 * usize::from(refactored),
            "eps {eps}"
        );
        assert_eq!(s.last_polish_iterations(), 0, "eps {eps}");
    }
}

/// Makes `dofs` identity rows and columns of `a`, keeping their entries in the pattern as zeros
/// (as the flow matrix does for the dofs inside a particle).
fn make_identity(a: &mut SparseMatrix, dofs: &[usize]) {
    let is = |d: usize| dofs.contains(&d);
    for j in 0..a.n() {
        let (rows, range) = a.column(j);
        let rows = rows.to_vec();
        for (i, p) in rows.into_iter().zip(range) {
            if is(i) || is(j) {
                a.values[p] = if i == j { 1.0 } else { 0.0 };
            }
        }
    }
}

/// Inert dofs (identity rows whose couplings the pattern stores as zeros, like those deep
/// inside a particle) leave M's pattern: the band solver still solves as the whole
/// factorization does, and a coupling of theirs that becomes non-zero no longer fits.
#[test]
fn inert_couplings_leave_m_and_are_checked() {
    let (n, range) = (90, 30..45);
    // velocities 33..39 and the two pressures of theirs, inside the band interior
    let identity: Vec<usize> = (33..39).chain([n + 11, n + 12]).collect();
    let matrix = |scale: f64| {
        let mut a = chain(n, scale, range.clone());
        make_identity(&mut a, &identity);
        a
    };
    let a0 = matrix(2.0);
    let nd = a0.n();
    let (band, blocks) = (chain_band(n, nd), chain_blocks(n, nd));
    let gamma = Substructured::interface(&a0, &band);
    let inert: Vec<bool> = (0..nd).map(|d| identity.contains(&d)).collect();
    let mut sub =
        Substructured::with_interface(&a0, &band, &gamma, &inert, &blocks, 1e-10).unwrap();
    let plain = Substructured::new(&a0, &band, &blocks, 1e-10).unwrap();
    // the chain's seven links 32–33 … 38–39 and the two pressures' three velocities each, both
    // ways
    assert_eq!(sub.inert_entries(), 2 * (7 + 2 * 3));
    assert_eq!(sub.m.nnz() + sub.inert_entries(), plain.m.nnz());
    let b: Vec<f64> = (0..nd).map(|i| (0.3 * i as f64).cos()).collect();
    for scale in [2.0, 1e-4, 50.0] {
        let a = matrix(scale);
        assert_solves_as_whole(&mut sub, &a, &b, &format!("inert, band scale {scale}"));
    }
    let mut coupled = matrix(2.0);
    coupled.add(35, 36, -0.5);
    coupled.add(36, 35, -0.5);
    assert!(!sub.fits(&coupled), "an inert coupling became non-zero");
    // a dof called inert whose couplings are not zero keeps them
    let mut loose = inert.clone();
    loose[20 + 20] = true;
    let kept = Substructured::with_interface(&a0, &band, &gamma, &loose, &blocks, 1e-10).unwrap();
    assert_eq!(kept.inert_entries(), sub.inert_entries());
}
