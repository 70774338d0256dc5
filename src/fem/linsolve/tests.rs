//! Tests of the direct solvers.
use super::probe::PROBE_ITERATIONS;
use super::*;
use crate::fem::sparse::PatternBuilder;

/// A small symmetric saddle-point matrix [[A, Bᵀ], [B, 0]] with A = tridiag(−1, 4, −1).
fn saddle(scale: f64) -> SparseMatrix {
    let n = 6;
    let mut pb = PatternBuilder::new(n + 2);
    for i in 0..n - 1 {
        pb.add_group(&[i, i + 1]);
    }
    pb.add_coupling(&[n], &[0, 1, 2]);
    pb.add_coupling(&[n + 1], &[3, 4, 5]);
    let mut a = pb.build();
    for i in 0..n {
        a.add(i, i, 4.0 * scale);
        if i + 1 < n {
            a.add(i, i + 1, -scale);
            a.add(i + 1, i, -scale);
        }
    }
    for (p, cols) in [(n, [0, 1, 2]), (n + 1, [3, 4, 5])] {
        for c in cols {
            a.add(p, c, 1.0);
            a.add(c, p, 1.0);
        }
    }
    a
}

/// [`saddle`] with its velocity block scaled by `sym` and made non-symmetric: `skew` added
/// above the velocity diagonal and subtracted below it (the symmetric part is the scaled
/// `saddle`).
fn skewed_saddle(skew: f64, sym: f64) -> SparseMatrix {
    let mut a = saddle(1.0);
    for j in 0..6usize {
        for i in j.saturating_sub(1)..(j + 2).min(6) {
            let p = a.position(i, j);
            a.values[p] *= sym;
        }
    }
    for i in 0..5 {
        a.add(i, i + 1, skew);
        a.add(i + 1, i, -skew);
    }
    a
}

#[test]
fn a_non_symmetric_system_is_solved_through_its_symmetric_part_or_by_lu() {
    // residual tolerance: round-off on an 8×8 well-conditioned system
    const TOL: f64 = 1e-13;
    let order: Vec<usize> = (0..8).collect();
    let b: Vec<f64> = (0..8).map(|i| (i as f64).cos() + 0.5).collect();
    let reference = |a: &SparseMatrix| {
        let mut lu = DirectSolver::analyze(a, SolverKind::Lu).unwrap();
        lu.factor(a).unwrap();
        let mut x = b.clone();
        lu.solve_in_place(&mut x).unwrap();
        x
    };
    // a positive-definite symmetric part: GMRES converges, no LU
    let a = skewed_saddle(0.8, 1.0);
    let mut s = DirectSolver::analyze_with_order(&a, SolverKind::Lu, &order).unwrap();
    s.factor(&a).unwrap();
    let mut x = vec![0.0; 8];
    assert!(s.solve_checked(&a, &b, &mut x, TOL).unwrap() < TOL);
    assert!((1..=8).contains(&s.last_polish_iterations()));
    assert_eq!(s.lu_fallbacks(), 0);
    let x_lu = reference(&a);
    for (u, v) in x.iter().zip(&x_lu) {
        assert!((u - v).abs() < 1e-12, "{u} vs {v}");
    }
    // a skew velocity block: the symmetric part [[0, Bᵀ], [B, 0]] is singular, the solver
    // factors A by LU
    let a = skewed_saddle(1.0, 0.0);
    let mut s = DirectSolver::analyze_with_order(&a, SolverKind::Lu, &order).unwrap();
    s.factor(&a).unwrap();
    assert!(s.solve_checked(&a, &b, &mut x, TOL).unwrap() < TOL);
    assert_eq!(s.lu_fallbacks(), 1);
    let x_lu = reference(&a);
    for (u, v) in x.iter().zip(&x_lu) {
        assert!((u - v).abs() < 1e-10, "{u} vs {v}");
    }
}

/// The symmetric part is factored without pivots where that works; when its factor
/// preconditions poorly (a leading velocity pivot of 4e-16: the unpivoted LDLᵀ's entries grow by
/// 1e16 and carry no digit), GMRES misses, the symmetric part is refactored with pivots (and
/// stays pivoted for the pattern) and the solve meets the tolerance without falling back to LU.
#[test]
fn the_symmetric_part_is_factored_without_pivots_and_repivoted_when_it_preconditions_poorly() {
    // residual tolerance: round-off on an 8×8 system
    const TOL: f64 = 1e-12;
    let order: Vec<usize> = (0..8).collect();
    let b: Vec<f64> = (0..8).map(|i| (i as f64).cos() + 0.5).collect();
    let a = skewed_saddle(0.8, 1.0);
    let mut s = DirectSolver::analyze_with_order(&a, SolverKind::Lu, &order).unwrap();
    s.factor(&a).unwrap();
    let Backend::SymmetricPart(sp) = &s.backend else {
        panic!("the symmetric part preconditions")
    };
    assert!(sp.is_unpivoted());
    let mut x = vec![0.0; 8];
    assert!(s.solve_checked(&a, &b, &mut x, TOL).unwrap() < TOL);
    assert_eq!((s.pivoted_refactors(), s.lu_fallbacks()), (0, 0));
    // the leading velocity pivot 4 → 4e-16
    let mut a = skewed_saddle(0.8, 1.0);
    let p = a.position(0, 0);
    a.values[p] = 4e-16;
    let mut s = DirectSolver::analyze_with_order(&a, SolverKind::Lu, &order).unwrap();
    s.factor(&a).unwrap();
    let res = s.solve_checked(&a, &b, &mut x, TOL).unwrap();
    assert!(res < TOL, "{res}");
    assert_eq!((s.pivoted_refactors(), s.lu_fallbacks()), (1, 0));
    // from then on the pattern's symmetric part is factored with pivots at once
    s.factor(&a).unwrap();
    let Backend::SymmetricPart(sp) = &s.backend else {
        panic!("still the symmetric part")
    };
    assert!(!sp.is_unpivoted());
    assert!(s.solve_checked(&a, &b, &mut x, TOL).unwrap() < TOL);
    assert_eq!((s.pivoted_refactors(), s.lu_fallbacks()), (1, 0));
}

#[test]
fn lblt_and_lu_solve_saddle_point_and_refactor() {
    // residual tolerance: round-off on an 8×8 well-conditioned system
    const TOL: f64 = 1e-13;
    for kind in [SolverKind::Lblt, SolverKind::Lu] {
        let a = saddle(1.0);
        let mut s = DirectSolver::analyze(&a, kind).unwrap();
        let b: Vec<f64> = (0..8).map(|i| (i as f64).sin() + 1.0).collect();
        let mut x = vec![0.0; 8];
        s.factor(&a).unwrap();
        assert!(s.solve_checked(&a, &b, &mut x, TOL).unwrap() < TOL);
        // refactor with new values, same pattern
        let a2 = saddle(3.0);
        s.factor(&a2).unwrap();
        assert!(
            s.solve_checked(&a2, &b, &mut x, TOL).unwrap() < TOL,
            "{kind:?}"
        );
    }
}

/// A strongly non-symmetric system (GMRES on the symmetric part needs more than
/// [`PROBE_ITERATIONS`]) times one LU against it and keeps whichever is cheaper; whichever it
/// keeps, every later solve still meets the tolerance and matches faer's LU.
#[test]
fn a_slow_symmetric_part_is_timed_against_an_lu_and_either_way_solves() {
    // residual tolerance: round-off on a 40×40 well-conditioned system
    const TOL: f64 = 1e-12;
    // tridiag(−1 − k, 4, −1 + k) with k = 1 on 40 unknowns: symmetric part tridiag(−1, 4, −1)
    // (k = 2 and more: GMRES misses the tolerance in 30 iterations and the solver takes the LU)
    let n = 40;
    let a = slow_tridiagonal(n);
    let order: Vec<usize> = (0..n).collect();
    let b: Vec<f64> = (0..n).map(|i| (i as f64).cos() + 0.5).collect();
    let mut lu = DirectSolver::analyze(&a, SolverKind::Lu).unwrap();
    lu.factor(&a).unwrap();
    let mut x_lu = b.clone();
    lu.solve_in_place(&mut x_lu).unwrap();
    let mut s = DirectSolver::analyze_with_order(&a, SolverKind::Lu, &order).unwrap();
    let mut x = vec![0.0; n];
    for round in 0..3 {
        s.factor(&a).unwrap();
        assert!(s.solve_checked(&a, &b, &mut x, TOL).unwrap() < TOL);
        if round == 0 {
            assert!(
                s.last_polish_iterations() > PROBE_ITERATIONS,
                "the test needs a slow preconditioner: {} iterations, {} fallbacks, {:?}",
                s.last_polish_iterations(),
                s.lu_fallbacks(),
                s.kind()
            );
        }
        for (u, v) in x.iter().zip(&x_lu) {
            assert!((u - v).abs() < 1e-10, "round {round}: {u} vs {v}");
        }
    }
    assert!(matches!(s.probe, Probe::Decided));
    assert!(s.lu_fallbacks() <= 1);
}

/// The slow system of the probe tests on `n` unknowns: tridiag(−2, 4, 0).
fn slow_tridiagonal(n: usize) -> SparseMatrix {
    let mut pb = PatternBuilder::new(n);
    for i in 0..n - 1 {
        pb.add_group(&[i, i + 1]);
    }
    let mut a = pb.build();
    for i in 0..n {
        a.add(i, i, 4.0);
        if i + 1 < n {
            a.add(i + 1, i, -2.0);
        }
    }
    a
}

/// Above [`PROBE_MAX_UNKNOWNS`] a slow symmetric part is not timed against an LU (whose
/// reservation alone outweighs what it could save there), and the solves still meet the
/// tolerance.
#[test]
fn a_large_system_is_never_timed_against_an_lu() {
    // residual tolerance: round-off on a well-conditioned system
    const TOL: f64 = 1e-12;
    let n = PROBE_MAX_UNKNOWNS + 1;
    let a = slow_tridiagonal(n);
    let order: Vec<usize> = (0..n).collect();
    let b: Vec<f64> = (0..n).map(|i| (i as f64).cos() + 0.5).collect();
    let mut s = DirectSolver::analyze_with_order(&a, SolverKind::Lu, &order).unwrap();
    let mut x = vec![0.0; n];
    for _ in 0..3 {
        s.factor(&a).unwrap();
        assert!(s.solve_checked(&a, &b, &mut x, TOL).unwrap() < TOL);
        assert!(s.last_polish_iterations() > PROBE_ITERATIONS);
        // decided from the start: no LU is ever pending
        assert!(matches!(s.backend, Backend::SymmetricPart(_)));
        assert_eq!(s.probe_verdict(), Some(ProbeVerdict::SymmetricPart));
    }
    assert_eq!(s.lu_fallbacks(), 0);
}

/// A verdict handed to the solver of a rebuilt pattern is kept: no second probe, and an LU
/// verdict factors by LU from the first solve.
#[test]
fn a_probe_verdict_outlives_its_solver() {
    const TOL: f64 = 1e-12;
    let n = 40;
    let a = slow_tridiagonal(n);
    let order: Vec<usize> = (0..n).collect();
    let b: Vec<f64> = (0..n).map(|i| (i as f64).sin() + 1.0).collect();
    for verdict in [ProbeVerdict::SymmetricPart, ProbeVerdict::Lu] {
        let mut s = DirectSolver::analyze_with_order(&a, SolverKind::Lu, &order).unwrap();
        assert_eq!(s.probe_verdict(), None, "a new solver watches");
        s.settle(verdict, &a).unwrap();
        let mut x = vec![0.0; n];
        for _ in 0..3 {
            s.factor(&a).unwrap();
            assert!(s.solve_checked(&a, &b, &mut x, TOL).unwrap() < TOL);
            assert!(matches!(s.probe, Probe::Decided));
        }
        let lu = matches!(s.backend, Backend::Lu { .. });
        assert_eq!(lu, verdict == ProbeVerdict::Lu, "{verdict:?}");
    }
}

/// [`Pivoting::WhenNeeded`] factors without pivots where every pivot is nonzero (velocities
/// before their pressures) and solves as the pivoted factor does; with a pressure first (a zero
/// pivot) it falls back to the pivoted factor and still solves.
#[test]
fn an_unpivoted_factor_is_used_where_it_exists() {
    // residual tolerance: round-off on an 8×8 well-conditioned system
    const TOL: f64 = 1e-13;
    let a = saddle(1.0);
    let b: Vec<f64> = (0..8).map(|i| (0.7 * i as f64).cos()).collect();
    let mut pivoted =
        DirectSolver::analyze_with_order(&a, SolverKind::Lblt, &[0, 1, 2, 6, 3, 4, 5, 7]).unwrap();
    pivoted.factor(&a).unwrap();
    let mut y = vec![0.0; 8];
    assert!(pivoted.solve_checked(&a, &b, &mut y, TOL).unwrap() < TOL);
    assert!(!pivoted.is_unpivoted());
    for (order, unpivoted) in [
        ([0, 1, 2, 6, 3, 4, 5, 7], true),
        ([6, 0, 1, 2, 7, 3, 4, 5], false),
    ] {
        let mut s = DirectSolver::analyze_with_order(&a, SolverKind::Lblt, &order).unwrap();
        s.set_pivoting(Pivoting::WhenNeeded);
        s.factor(&a).unwrap();
        assert_eq!(s.is_unpivoted(), unpivoted, "order {order:?}");
        let mut x = vec![0.0; 8];
        assert!(s.solve_checked(&a, &b, &mut x, TOL).unwrap() < TOL);
        let diff = x
            .iter()
            .zip(&y)
            .map(|(p, q)| (p - q).abs())
            .fold(0.0, f64::max);
        assert!(diff < 1e-13, "order {order:?}: {diff:.2e}");
        s.factor_pivoted(&a).unwrap();
        assert!(!s.is_unpivoted());
    }
}

/// An identity elimination order is given to faer as such (no permutation, the matrix factored
/// as stored), for a matrix stored whole or by its lower triangle alone (as the band matrix M
/// stores its dense interface block): both solve as the permuted factorization does.
#[test]
fn an_identity_order_factors_the_matrix_as_stored() {
    // residual tolerance: round-off on an 8×8 well-conditioned system
    const TOL: f64 = 1e-13;
    let a = saddle(1.0);
    // the order that eliminates each pressure after its velocities, made the numbering
    let order = [0, 1, 2, 6, 3, 4, 5, 7];
    let permuted = |lower_only: bool| {
        let (mut col_ptr, mut row_idx, mut values) = (vec![0], Vec::new(), Vec::new());
        for &j in &order {
            for (new_i, &i) in order.iter().enumerate() {
                let first = if lower_only { col_ptr.len() - 1 } else { 0 };
                if new_i >= first && a.column(j).0.contains(&i) {
                    row_idx.push(new_i);
                    values.push(a.values[a.position(i, j)]);
                }
            }
            col_ptr.push(row_idx.len());
        }
        let mut p = SparseMatrix::from_pattern(8, col_ptr, row_idx);
        p.values = values;
        p
    };
    let b: Vec<f64> = (0..8).map(|i| (0.7 * i as f64).cos()).collect();
    let mut want = b.clone();
    let mut s = DirectSolver::analyze_with_order(&a, SolverKind::Lblt, &order).unwrap();
    s.factor(&a).unwrap();
    s.solve_in_place(&mut want).unwrap();
    let identity: Vec<usize> = (0..8).collect();
    for lower_only in [false, true] {
        let p = permuted(lower_only);
        for pivoting in [Pivoting::WhenNeeded, Pivoting::Always] {
            let mut s = DirectSolver::analyze_with_order(&p, SolverKind::Lblt, &identity).unwrap();
            s.set_pivoting(pivoting);
            s.factor(&p).unwrap();
            assert_eq!(s.is_unpivoted(), pivoting == Pivoting::WhenNeeded);
            let mut x: Vec<f64> = order.iter().map(|&d| b[d]).collect();
            s.solve_in_place(&mut x).unwrap();
            for (k, &d) in order.iter().enumerate() {
                assert!(
                    (x[k] - want[d]).abs() < TOL,
                    "{lower_only} {pivoting:?}: {k}"
                );
            }
        }
    }
}
