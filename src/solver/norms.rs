//! Error norms of finite element fields against exact solutions (for convergence studies).

use crate::fem::element::{physical_gradients, q1, q2, q2_map};
use crate::fem::quadrature::gauss_quad;
use crate::mesh::Mesh;

/// Exact solution of a flow problem: velocity, its gradient L_{ij} = ∂u_i/∂x_j, pressure.
pub trait ExactFlow {
    /// Velocity at x.
    fn u(&self, x: [f64; 2]) -> [f64; 2];
    /// Velocity gradient at x, `[[∂u/∂x, ∂u/∂y], [∂v/∂x, ∂v/∂y]]`.
    fn grad_u(&self, x: [f64; 2]) -> [[f64; 2]; 2];
    /// Pressure at x (any constant level: errors are measured after removing means).
    fn p(&self, x: [f64; 2]) -> f64;
}

/// Errors of a discrete flow field.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlowErrors {
    /// ‖u − u_h‖_{L2}.
    pub u_l2: f64,
    /// |u − u_h|_{H1}.
    pub u_h1: f64,
    /// ‖(p − p̄) − (p_h − p̄_h)‖_{L2}.
    pub p_l2: f64,
    /// ‖L(u) − G_h‖_{L2} when G is present.
    pub g_l2: Option<f64>,
}

/// Computes [`FlowErrors`] with a 5×5 Gauss rule (exact to degree 9 on affine elements).
pub fn flow_errors(
    mesh: &Mesh,
    u: &[[f64; 2]],
    p: &[f64],
    g: Option<&[[f64; 4]]>,
    exact: &dyn ExactFlow,
) -> FlowErrors {
    let rule = gauss_quad(5);
    let mut dn = [[0.0; 2]; 9];
    // pressure means first
    let (mut pe_int, mut ph_int, mut area) = (0.0, 0.0, 0.0);
    for e in 0..mesh.n_elements() {
        for (xi, w) in rule.points.iter().zip(&rule.weights) {
            let (x, _, det) = q2_map(&mesh.element_coords[e], *xi);
            let psi = q1(*xi).0;
            let ph: f64 = (0..4)
                .map(|k| psi[k] * p[mesh.element_vertices[e][k]])
                .sum();
            pe_int += w * det * exact.p(x);
            ph_int += w * det * ph;
            area += w * det;
        }
    }
    let (pe_mean, ph_mean) = (pe_int / area, ph_int / area);
    let (mut eu, mut eh1, mut ep, mut eg) = (0.0, 0.0, 0.0, 0.0);
    for e in 0..mesh.n_elements() {
        let nodes = &mesh.elements[e];
        let verts = &mesh.element_vertices[e];
        for (xi, w) in rule.points.iter().zip(&rule.weights) {
            let (x, jac, det) = q2_map(&mesh.element_coords[e], *xi);
            let (n2, dref) = q2(*xi);
            physical_gradients(&jac, det, &dref, &mut dn);
            let psi = q1(*xi).0;
            let mut uh = [0.0; 2];
            let mut lh = [[0.0; 2]; 2];
            for k in 0..9 {
                for c in 0..2 {
                    uh[c] += n2[k] * u[nodes[k]][c];
                    for d in 0..2 {
                        lh[c][d] += dn[k][d] * u[nodes[k]][c];
                    }
                }
            }
            let ue = exact.u(x);
            let le = exact.grad_u(x);
            let wd = w * det;
            eu += wd * ((ue[0] - uh[0]).powi(2) + (ue[1] - uh[1]).powi(2));
            for c in 0..2 {
                for d in 0..2 {
                    eh1 += wd * (le[c][d] - lh[c][d]).powi(2);
                }
            }
            let ph: f64 = (0..4).map(|k| psi[k] * p[verts[k]]).sum();
            ep += wd * ((exact.p(x) - pe_mean) - (ph - ph_mean)).powi(2);
            if let Some(g) = g {
                for ij in 0..4 {
                    let gh: f64 = (0..4).map(|k| psi[k] * g[verts[k]][ij]).sum();
                    eg += wd * (le[ij / 2][ij % 2] - gh).powi(2);
                }
            }
        }
    }
    FlowErrors {
        u_l2: eu.sqrt(),
        u_h1: eh1.sqrt(),
        p_l2: ep.sqrt(),
        g_l2: g.map(|_| eg.sqrt()),
    }
}

/// Least-squares slope of log(err) against log(h) (the convergence rate).
pub fn fitted_rate(h: &[f64], err: &[f64]) -> f64 {
    let n = h.len() as f64;
    let lx: Vec<f64> = h.iter().map(|v| v.ln()).collect();
    let ly: Vec<f64> = err.iter().map(|v| v.ln()).collect();
    let mx = lx.iter().sum::<f64>() / n;
    let my = ly.iter().sum::<f64>() / n;
    let sxy: f64 = lx.iter().zip(&ly).map(|(x, y)| (x - mx) * (y - my)).sum();
    let sxx: f64 = lx.iter().map(|x| (x - mx).powi(2)).sum();
    sxy / sxx
}

#[cfg(test)]
mod tests {
    #[test]
    fn fitted_rate_recovers_power_law() {
        let h = [0.1, 0.05, 0.025, 0.0125];
        let e: Vec<f64> = h.iter().map(|x: &f64| 3.0 * x.powi(3)).collect();
        assert!((super::fitted_rate(&h, &e) - 3.0).abs() < 1e-12);
    }
}
