//! Element kernels of the flow's weak form (thesis Eqs. 2.13, 2.14, 2.16), per quadrature point:
//!
//! ```text
//!   (2η D(u), D(v)) + θ (L(u) − G, L(v)) − (∇·v, p) = (f, v)
//!   −(q, ∇·u) = 0,   −θ (H, L(u) − G) = 0
//! ```

use super::dofs::MAX_EL_DOFS;
use crate::fem::element::{physical_gradients, q1, q2, q2_map};
use crate::fem::quadrature::QuadRule;

/// Per Gauss point: Q2 values and reference gradients, Q1 values.
pub(super) type ShapeTable = (([f64; 9], [[f64; 2]; 9]), [f64; 4]);

pub(super) fn shape_table(rule: &QuadRule) -> Vec<ShapeTable> {
    rule.points.iter().map(|&xi| (q2(xi), q1(xi).0)).collect()
}

/// The Stokes matrix (viscous, DEVSS-G and pressure terms) of the element with nodes `xe` as
/// fully fluid, into `ke` (`nd`×`nd`, local order of
/// [`element_dofs`](super::dofs::element_dofs) without rigid-body slots).
pub(super) fn fluid_element_matrix(
    xe: &[[f64; 2]; 9],
    rule: &QuadRule,
    tab: &[ShapeTable],
    eta: f64,
    theta: f64,
    with_g: bool,
    ke: &mut [f64],
) {
    let nd = 22 + if with_g { 16 } else { 0 };
    let mut fe = [0.0; MAX_EL_DOFS];
    let mut dn = [[0.0; 2]; 9];
    ke.iter_mut().for_each(|v| *v = 0.0);
    for (q, ((n2, dref), psi)) in tab.iter().enumerate() {
        let (_, jac, det) = q2_map(xe, rule.points[q]);
        physical_gradients(&jac, det, dref, &mut dn);
        let w = rule.weights[q] * det;
        stokes_kernel(
            ke,
            &mut fe[..nd],
            nd,
            w,
            eta,
            theta,
            n2,
            &dn,
            psi,
            [0.0; 2],
            with_g,
        );
    }
}

/// Adds one quadrature point's contribution (weight `w` = Gauss weight × det J) to the local
/// matrix `ke` (row-major, `nd`×`nd`, local order as in
/// [`element_dofs`](super::dofs::element_dofs)) and vector `fe`.
#[allow(clippy::too_many_arguments)]
#[inline]
pub(super) fn stokes_kernel(
    ke: &mut [f64],
    fe: &mut [f64],
    nd: usize,
    w: f64,
    eta: f64,
    theta: f64,
    n2: &[f64; 9],
    dn: &[[f64; 2]; 9],
    psi: &[f64; 4],
    force: [f64; 2],
    with_g: bool,
) {
    for a in 0..9 {
        for c in 0..2 {
            let row = 2 * a + c;
            fe[row] += w * n2[a] * force[c];
            for b in 0..9 {
                let gg = dn[a][0] * dn[b][0] + dn[a][1] * dn[b][1];
                for d in 0..2 {
                    // 2η D(v):D(u) = η [δ_cd ∇N_a·∇N_b + ∂_d N_a ∂_c N_b]; θ δ_cd ∇N_a·∇N_b
                    let mut v = eta * dn[a][d] * dn[b][c];
                    if c == d {
                        v += (eta + theta) * gg;
                    }
                    ke[row * nd + 2 * b + d] += w * v;
                }
            }
            for m in 0..4 {
                // −(∇·v, p) and its transpose −(q, ∇·u)
                let v = -w * psi[m] * dn[a][c];
                ke[row * nd + 18 + m] += v;
                ke[(18 + m) * nd + row] += v;
                if with_g {
                    for j in 0..2 {
                        // −θ (G, L(v)): v = N_a e_c, L(v)_{cj} = ∂_j N_a; and the transpose
                        let gcol = 22 + 4 * m + 2 * c + j;
                        let v = -w * theta * psi[m] * dn[a][j];
                        ke[row * nd + gcol] += v;
                        ke[gcol * nd + row] += v;
                    }
                }
            }
        }
    }
    if with_g {
        for l in 0..4 {
            for m in 0..4 {
                let v = w * theta * psi[l] * psi[m];
                for ij in 0..4 {
                    ke[(22 + 4 * l + ij) * nd + 22 + 4 * m + ij] += v;
                }
            }
        }
    }
}
