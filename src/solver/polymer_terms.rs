//! Polymer-stress terms of the momentum balance, for a stress given in linearized form at each
//! quadrature point (thesis Eqs. 2.13, 5.17, 5.21 with τ from Eq. 5.26 or explicit τⁿ):
//!
//! ```text
//!   τ_ij = A_ijkl L_kl(u) + B_ijk u_k + b_ij,      L_kl = ∂u_k/∂x_l
//!   volume:    + (L(v), τ)                 (the (∇v)ᵀ : τ term)
//!   boundary:  − (g(v, V, χ), τ·n)_Γ       (with the weak rigid-body condition)
//! ```
//!
//! `A` and `B` make the flow matrix non-symmetric (use the LU solver); an explicit stress (only
//! `b`) keeps it symmetric. The caller also uses `b` for an explicit DEVSS-G term −θGⁿ.

/// Linearized stress at one point: τ = A : L(u) + B · u + b.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct StressLin {
    /// A_ijkl (implicit part in the velocity gradient), if any.
    pub a: Option<[[[[f64; 2]; 2]; 2]; 2]>,
    /// B_ijk (implicit part in the velocity, e.g. −GΔt ∂_k cⁿ_ij of Eq. 5.26), if any.
    pub b_u: Option<[[[f64; 2]; 2]; 2]>,
    /// b_ij (explicit part).
    pub b: [[f64; 2]; 2],
}

/// Supplies the linearized polymer stress during assembly.
pub trait PolymerStress: Sync {
    /// The stress at reference point `xi` (physical `x`) of element `e`; `on_boundary` is true
    /// for particle-boundary quadrature points (where only the polymer stress τ belongs, not a
    /// DEVSS-G term).
    fn at(&self, e: usize, xi: [f64; 2], x: [f64; 2], on_boundary: bool) -> StressLin;

    /// Whether any point has implicit parts (A or B): then the flow matrix is non-symmetric.
    fn is_implicit(&self) -> bool;
}

/// Adds + (L(v), τ) at one volume point (weight `w` = Gauss weight × det J) to the velocity
/// rows/columns (local dofs 0..18, node-major) of `ke` (row-major, `nd` wide) and to `fe`.
#[allow(clippy::too_many_arguments)]
pub fn volume_terms(
    ke: &mut [f64],
    fe: &mut [f64],
    nd: usize,
    w: f64,
    n2: &[f64; 9],
    dn: &[[f64; 2]; 9],
    lin: &StressLin,
) {
    for a in 0..9 {
        for c in 0..2 {
            // (L(v), b): v = N_a e_c, L(v)_cj = ∂_j N_a; moved to the right-hand side
            fe[2 * a + c] -= w * (dn[a][0] * lin.b[c][0] + dn[a][1] * lin.b[c][1]);
        }
    }
    if lin.a.is_none() && lin.b_u.is_none() {
        return;
    }
    // τ_cj of each trial function u = N_b e_d, computed once for all 18 test rows
    let tau = trial_stresses(n2, dn, lin);
    for a in 0..9 {
        for c in 0..2 {
            let row = &mut ke[(2 * a + c) * nd..(2 * a + c) * nd + 18];
            for (k, t) in row.iter_mut().zip(&tau) {
                *k += w * (dn[a][0] * t[c][0] + dn[a][1] * t[c][1]);
            }
        }
    }
}

/// The linearized stress's implicit part τ_ij(N_b e_d) for each of the 18 velocity trial
/// functions (index 2b + d), from A : L(u) + B · u.
#[inline]
fn trial_stresses(n2: &[f64; 9], dn: &[[f64; 2]; 9], lin: &StressLin) -> [[[f64; 2]; 2]; 18] {
    let mut tau = [[[0.0; 2]; 2]; 18];
    for b in 0..9 {
        for d in 0..2 {
            let t = &mut tau[2 * b + d];
            for i in 0..2 {
                for j in 0..2 {
                    if let Some(aa) = &lin.a {
                        t[i][j] += aa[i][j][d][0] * dn[b][0] + aa[i][j][d][1] * dn[b][1];
                    }
                    if let Some(bu) = &lin.b_u {
                        t[i][j] += bu[i][j][d] * n2[b];
                    }
                }
            }
        }
    }
    tau
}

/// Adds − (g(v, V, χ), τ·n)_Γ at one boundary point: `jv[α]` are the jump vectors of the 21
/// jump dofs (18 velocity, then U_x, U_y, ω at local `off_rigid..`), `n2`, `dn` the velocity
/// shape functions and gradients at the point, `n` the fluid normal, `w` the arc-length weight.
#[allow(clippy::too_many_arguments)]
pub fn boundary_terms(
    ke: &mut [f64],
    fe: &mut [f64],
    nd: usize,
    off_rigid: usize,
    w: f64,
    jv: &[[f64; 2]; 21],
    n2: &[f64; 9],
    dn: &[[f64; 2]; 9],
    n: [f64; 2],
    lin: &StressLin,
) {
    let local = |alpha: usize| crate::solver::rigid::local_jump_dof(alpha, off_rigid);
    let bn = [
        lin.b[0][0] * n[0] + lin.b[0][1] * n[1],
        lin.b[1][0] * n[0] + lin.b[1][1] * n[1],
    ];
    for alpha in 0..21 {
        // −(g, b·n) moves to the right-hand side with a plus sign
        fe[local(alpha)] += w * (jv[alpha][0] * bn[0] + jv[alpha][1] * bn[1]);
    }
    if lin.a.is_none() && lin.b_u.is_none() {
        return;
    }
    // (τ·n)_i of each trial function u = N_b e_d (its stress as the volume terms take it),
    // computed once for all 21 jump rows
    let tau = trial_stresses(n2, dn, lin);
    let traction: [[f64; 2]; 18] = std::array::from_fn(|k| {
        let t = &tau[k];
        [
            t[0][0] * n[0] + t[0][1] * n[1],
            t[1][0] * n[0] + t[1][1] * n[1],
        ]
    });
    for alpha in 0..21 {
        let row = &mut ke[local(alpha) * nd..local(alpha) * nd + 18];
        for (k, t) in row.iter_mut().zip(&traction) {
            *k -= w * (jv[alpha][0] * t[0] + jv[alpha][1] * t[1]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn explicit_stress_gives_only_a_load() {
        // (L(v), b) for b = [[1, 2], [3, 4]] and one node's gradient (1, 0): row u_x −1, row u_y −3
        let mut ke = vec![0.0; 22 * 22];
        let mut fe = vec![0.0; 22];
        let mut dn = [[0.0; 2]; 9];
        dn[4] = [1.0, 0.0];
        let lin = StressLin {
            b: [[1.0, 2.0], [3.0, 4.0]],
            ..Default::default()
        };
        volume_terms(&mut ke, &mut fe, 22, 1.0, &[0.0; 9], &dn, &lin);
        assert_eq!(fe[8], -1.0);
        assert_eq!(fe[9], -3.0);
        assert!(ke.iter().all(|&v| v == 0.0));
    }

    #[test]
    fn newtonian_as_stress_matches_viscous_term() {
        // τ = 2η D(u) written as A_ijkl = η (δ_ik δ_jl + δ_il δ_jk) gives the 2η D(v):D(u) matrix
        let eta = 0.7;
        let mut a = [[[[0.0; 2]; 2]; 2]; 2];
        for i in 0..2 {
            for j in 0..2 {
                a[i][j][i][j] += eta;
                a[i][j][j][i] += eta;
            }
        }
        let lin = StressLin {
            a: Some(a),
            ..Default::default()
        };
        let mut dn = [[0.0; 2]; 9];
        for (k, g) in dn.iter_mut().enumerate() {
            *g = [(k as f64 * 0.37).sin(), (k as f64 * 0.71).cos()];
        }
        let mut ke = vec![0.0; 22 * 22];
        let mut fe = vec![0.0; 22];
        volume_terms(&mut ke, &mut fe, 22, 1.0, &[0.0; 9], &dn, &lin);
        for a_ in 0..9 {
            for c in 0..2 {
                for b in 0..9 {
                    for d in 0..2 {
                        let gg = dn[a_][0] * dn[b][0] + dn[a_][1] * dn[b][1];
                        let expect =
                            eta * dn[a_][d] * dn[b][c] + if c == d { eta * gg } else { 0.0 };
                        // the same arithmetic in another order: round-off only
                        assert!((ke[(2 * a_ + c) * 22 + 2 * b + d] - expect).abs() < 1e-14);
                    }
                }
            }
        }
    }

    /// A linearization with every implicit entry set, and shape values/gradients, from a
    /// deterministic pseudo-random sequence.
    fn sample() -> (StressLin, [f64; 9], [[f64; 2]; 9]) {
        let mut x = 0.3f64;
        let mut next = || {
            x = (x * 3.7 + 0.13).fract();
            2.0 * x - 1.0
        };
        let mut lin = StressLin {
            a: Some([[[[0.0; 2]; 2]; 2]; 2]),
            b_u: Some([[[0.0; 2]; 2]; 2]),
            b: [[next(), next()], [next(), next()]],
        };
        for v in lin
            .a
            .as_mut()
            .unwrap()
            .iter_mut()
            .flatten()
            .flatten()
            .flatten()
        {
            *v = next();
        }
        for v in lin.b_u.as_mut().unwrap().iter_mut().flatten().flatten() {
            *v = next();
        }
        let n2 = std::array::from_fn(|_| next());
        let dn = std::array::from_fn(|_| [next(), next()]);
        (lin, n2, dn)
    }

    #[test]
    fn volume_terms_equal_their_entrywise_definition_bitwise() {
        // the trial stresses are computed once per trial function; each entry must be the
        // same arithmetic as (L(N_a e_c), τ(N_b e_d)) evaluated on its own
        let (lin, n2, dn) = sample();
        let (aa, bu) = (lin.a.unwrap(), lin.b_u.unwrap());
        let mut ke = vec![0.0; 22 * 22];
        let mut fe = vec![0.0; 22];
        volume_terms(&mut ke, &mut fe, 22, 0.7, &n2, &dn, &lin);
        for a in 0..9 {
            for c in 0..2 {
                for b in 0..9 {
                    for d in 0..2 {
                        let mut v = 0.0;
                        for j in 0..2 {
                            let mut t = 0.0;
                            t += aa[c][j][d][0] * dn[b][0] + aa[c][j][d][1] * dn[b][1];
                            t += bu[c][j][d] * n2[b];
                            v += dn[a][j] * t;
                        }
                        assert_eq!(ke[(2 * a + c) * 22 + 2 * b + d], 0.7 * v);
                    }
                }
            }
        }
        // the pressure columns and rows are untouched
        assert!((0..22).all(|r| (18..22).all(|k| ke[r * 22 + k] == 0.0 && ke[k * 22 + r] == 0.0)));
    }

    #[test]
    fn boundary_terms_equal_their_entrywise_definition_bitwise() {
        let (lin, n2, dn) = sample();
        let (aa, bu) = (lin.a.unwrap(), lin.b_u.unwrap());
        let jv: [[f64; 2]; 21] =
            std::array::from_fn(|k| [(k as f64 * 0.3).sin(), (k as f64 * 0.2).cos()]);
        let n = [0.6, -0.8];
        let (nd, off) = (25, 22);
        let mut ke = vec![0.0; nd * nd];
        let mut fe = vec![0.0; nd];
        boundary_terms(&mut ke, &mut fe, nd, off, 0.4, &jv, &n2, &dn, n, &lin);
        for alpha in 0..21 {
            let row = crate::solver::rigid::local_jump_dof(alpha, off);
            for b in 0..9 {
                for d in 0..2 {
                    // the trial function's stress as the volume terms take it, then τ·n
                    let tau = |i: usize, j: usize| {
                        let mut t = 0.0;
                        t += aa[i][j][d][0] * dn[b][0] + aa[i][j][d][1] * dn[b][1];
                        t += bu[i][j][d] * n2[b];
                        t
                    };
                    let t = [
                        tau(0, 0) * n[0] + tau(0, 1) * n[1],
                        tau(1, 0) * n[0] + tau(1, 1) * n[1],
                    ];
                    let expect = 0.0 - 0.4 * (jv[alpha][0] * t[0] + jv[alpha][1] * t[1]);
                    assert_eq!(ke[row * nd + 2 * b + d], expect);
                }
            }
        }
    }
}
