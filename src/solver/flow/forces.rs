//! Hydrodynamic force and torque on each particle: the reaction of the rigid-body condition
//! (the weak condition's rigid rows, or the integral of the multipliers; consistent with the
//! discrete momentum balance) and the stress integral −∫ σ(u_h, p_h)·n ds over the particle
//! boundary.

use super::dofs::{element_dofs, MAX_EL_DOFS};
use super::Stokes;
use crate::fem::element::{physical_gradients, q1, q2, q2_map};
use crate::solver::multiplier::RigidCondition;
use crate::solver::rigid::{weak_rigid_kernel, CutElement, ElementCut};

impl Stokes {
    /// Force and torque on each particle: from the rigid rows of the weak condition (reaction)
    /// and from the stress integral over the boundary quadrature.
    pub(super) fn particle_forces(&self) -> (Vec<[f64; 3]>, Vec<[f64; 3]>) {
        let lay = self.layout;
        let np = lay.n_particles;
        let (mut reaction, mut stress) = (vec![[0.0; 3]; np], vec![[0.0; 3]; np]);
        if np == 0 {
            return (reaction, stress);
        }
        let weak = self.params.rigid_condition == RigidCondition::Weak;
        if !weak {
            reaction = self.multiplier_forces();
        }
        let nd = 22 + if lay.with_g { 16 } else { 0 };
        let mut dofs = Vec::with_capacity(MAX_EL_DOFS);
        let mut ke = vec![0.0; (nd + 3) * (nd + 3)];
        let mut dn = [[0.0; 2]; 9];
        for (e, cut) in self.cuts.iter().enumerate() {
            let ElementCut::Cut(cut) = cut else { continue };
            element_dofs(&self.mesh, &lay, e, &mut dofs);
            let xe = &self.mesh.element_coords[e];
            let ue: Vec<[f64; 2]> = self.mesh.elements[e]
                .iter()
                .map(|&k| [self.sol[lay.u(k, 0)], self.sol[lay.u(k, 1)]])
                .collect();
            let pe: Vec<f64> = self.mesh.element_vertices[e]
                .iter()
                .map(|&v| self.sol[lay.p(v)])
                .collect();
            for pc in &cut.particles {
                let i = pc.particle;
                // reaction: −(rigid rows of the weak-condition kernel) · x
                ke.iter_mut().for_each(|v| *v = 0.0);
                if weak {
                    let ce = CutElement::of(xe, cut, pc);
                    weak_rigid_kernel(
                        &mut ke,
                        nd + 3,
                        nd,
                        &ce,
                        pc.center,
                        self.params.eta,
                        self.params.kappa,
                        self.params.rigid_form,
                    );
                    for c in 0..3 {
                        let row = &ke[(nd + c) * (nd + 3)..(nd + c + 1) * (nd + 3)];
                        let mut r: f64 = (0..nd).map(|a| row[a] * self.sol[dofs[a]]).sum();
                        r += (0..3)
                            .map(|d| row[nd + d] * self.sol[lay.rigid(i, d)])
                            .sum::<f64>();
                        reaction[i][c] -= r;
                    }
                }
                // stress integral: force on the particle = −∫ σ(u_h, p_h)·n_fluid ds
                for bp in &pc.points {
                    let (_, jac, det) = q2_map(xe, bp.xi);
                    let dref = q2(bp.xi).1;
                    physical_gradients(&jac, det, &dref, &mut dn);
                    let psi = q1(bp.xi).0;
                    let mut l = [[0.0; 2]; 2];
                    for k in 0..9 {
                        for a in 0..2 {
                            for b in 0..2 {
                                l[a][b] += dn[k][b] * ue[k][a];
                            }
                        }
                    }
                    let p: f64 = (0..4).map(|m| psi[m] * pe[m]).sum();
                    let eta = self.params.eta;
                    let sig = [
                        [-p + 2.0 * eta * l[0][0], eta * (l[0][1] + l[1][0])],
                        [eta * (l[0][1] + l[1][0]), -p + 2.0 * eta * l[1][1]],
                    ];
                    let t = [
                        -(sig[0][0] * bp.n[0] + sig[0][1] * bp.n[1]),
                        -(sig[1][0] * bp.n[0] + sig[1][1] * bp.n[1]),
                    ];
                    let r = [bp.x[0] - pc.center[0], bp.x[1] - pc.center[1]];
                    stress[i][0] += bp.w * t[0];
                    stress[i][1] += bp.w * t[1];
                    stress[i][2] += bp.w * (r[0] * t[1] - r[1] * t[0]);
                }
            }
        }
        // the films' correction acts on the rigid rows too: part of the condition's force
        if !self.films.is_empty() {
            let rigid: Vec<[f64; 3]> = (0..np)
                .map(|i| [0, 1, 2].map(|c| self.sol[lay.rigid(i, c)]))
                .collect();
            for film in &self.films {
                let f = film.force_on_first(&rigid);
                for c in 0..2 {
                    reaction[film.first][c] += f[c];
                    if let Some(j) = film.second {
                        reaction[j][c] -= f[c];
                    }
                }
            }
        }
        (reaction, stress)
    }
}
