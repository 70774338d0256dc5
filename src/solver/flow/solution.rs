//! A Stokes solution in nodal form ([`StokesSolution`]), read out of the solved vector.

use super::Stokes;
use crate::fem::element::{q1, q2_map};
use crate::fem::quadrature::gauss_quad;
use crate::mesh::Mesh;

/// A Stokes solution in nodal form.
#[derive(Debug, Clone)]
pub struct StokesSolution {
    /// Velocity at each Q2 node.
    pub u: Vec<[f64; 2]>,
    /// Pressure at each Q1 vertex (zero mean for enclosed flows).
    pub p: Vec<f64>,
    /// Projected velocity gradient at each Q1 vertex (when θ > 0), `[G_xx, G_xy, G_yx, G_yy]`.
    pub g: Option<Vec<[f64; 4]>>,
    /// Rigid velocities (U_x, U_y, ω) of the particles.
    pub rigid: Vec<[f64; 3]>,
    /// Hydrodynamic force and torque (F_x, F_y, T) on each particle from the reaction of the
    /// rigid-body condition — the weak condition's, or the integral of the multipliers
    /// (consistent with the discrete momentum balance; ≈ 0 for free particles).
    pub reaction: Vec<[f64; 3]>,
    /// The same from the stress integral −∫ σ(u_h, p_h)·n ds over the particle boundary.
    pub stress_force: Vec<[f64; 3]>,
    /// Relative residual of the linear solve.
    pub residual: f64,
}

impl Stokes {
    /// The solution in nodal form from the solved vector (the pressure shifted to zero mean where it was pinned).
    pub(super) fn extract(&self, residual: f64) -> StokesSolution {
        let lay = self.layout;
        let u = (0..lay.n_nodes)
            .map(|k| [self.sol[lay.u(k, 0)], self.sol[lay.u(k, 1)]])
            .collect();
        let mut p: Vec<f64> = (0..lay.n_vertices).map(|v| self.sol[lay.p(v)]).collect();
        if self.pressure_pinned {
            let mean = mean_q1(&self.mesh, &p);
            p.iter_mut().for_each(|v| *v -= mean);
        }
        let g = lay.with_g.then(|| {
            (0..lay.n_vertices)
                .map(|v| [0, 1, 2, 3].map(|ij| self.sol[lay.g(v, ij)]))
                .collect()
        });
        let rigid = (0..lay.n_particles)
            .map(|i| [0, 1, 2].map(|c| self.sol[lay.rigid(i, c)]))
            .collect();
        let (reaction, stress_force) = self.particle_forces();
        StokesSolution {
            u,
            p,
            g,
            rigid,
            reaction,
            stress_force,
            residual,
        }
    }
}

/// Mean of a Q1 field over the mesh.
pub fn mean_q1(mesh: &Mesh, p: &[f64]) -> f64 {
    let rule = gauss_quad(2);
    let (mut int, mut area) = (0.0, 0.0);
    for e in 0..mesh.n_elements() {
        for (xi, w) in rule.points.iter().zip(&rule.weights) {
            let det = q2_map(&mesh.element_coords[e], *xi).2;
            let psi = q1(*xi).0;
            let val: f64 = (0..4)
                .map(|k| psi[k] * p[mesh.element_vertices[e][k]])
                .sum();
            int += w * det * val;
            area += w * det;
        }
    }
    int / area
}
