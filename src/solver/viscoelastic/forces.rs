//! Forces and torques on the particles, and the polymer stress read from the flow.

use super::ViscoelasticFlow;
use crate::rheology::Sym2;
use crate::solver::constitutive_projection::{fluid_mean, sym_at, velocity_gradient_at};
use crate::solver::multiplier::RigidCondition;
use crate::solver::rigid::{fictitious_domain, ElementCut};

impl ViscoelasticFlow {
    /// Hydrodynamic force and torque on each particle as the rigid-body condition exerts it
    /// (the K_L of thesis Eq. 2.57, see [`crate::solver::rigid`]): the weak-condition reaction of
    /// the last flow solve (solvent stress, pressure and stabilization, consistent with the
    /// discrete momentum balance), with XFEM plus the polymer stress integral −∮ τ·n ds with the
    /// current τ (the polymer consistency term of the rigid rows) and, with flow-rate control,
    /// the mean pressure gradient's traction f·(particle area). With the fictitious domain
    /// method the reaction is the whole force: the condition carries the jump of the total
    /// traction, and the body force on the interior fluid. With multipliers
    /// ([`crate::solver::multiplier`]) the reaction ∫λ ds is the whole traction, polymer
    /// included (plus, with XFEM, the pressure gradient's traction).
    pub fn particle_forces(&self) -> Vec<[f64; 3]> {
        if fictitious_domain(&self.cuts) {
            return self.reaction.clone();
        }
        let mut out = match self.params.rigid_condition {
            RigidCondition::Weak => self.polymer_forces(),
            RigidCondition::Multiplier => vec![[0.0; 3]; self.reaction.len()],
        };
        for (f, r) in out.iter_mut().zip(&self.reaction) {
            (0..3).for_each(|c| f[c] += r[c]);
        }
        self.add_pressure_gradient(&mut out);
        out
    }

    /// Hydrodynamic force and torque on each particle as the integral of the traction of the
    /// discrete fields over its boundary (the K of thesis Eq. 2.55): −∮ σ(u_h, p_h)·n ds of the
    /// last flow solve, the polymer part −∮ τ·n ds with the current τ and, with flow-rate
    /// control, the mean pressure gradient's traction f·(particle area). With XFEM it differs
    /// from [`particle_forces`](Self::particle_forces) by the stabilization's force; with the
    /// fictitious domain method it sees the fields smeared across the boundary (the thesis: about
    /// 60 % of the drag).
    pub fn traction_forces(&self) -> Vec<[f64; 3]> {
        let mut out = self.polymer_forces();
        for (f, r) in out.iter_mut().zip(&self.traction) {
            (0..3).for_each(|c| f[c] += r[c]);
        }
        self.add_pressure_gradient(&mut out);
        out
    }

    /// With flow-rate control, the traction of the mean pressure gradient −f x on each particle:
    /// f·(particle area) along x.
    fn add_pressure_gradient(&self, out: &mut [[f64; 3]]) {
        if self.flow_rate.is_some() {
            for (f, p) in out.iter_mut().zip(self.stokes.particles()) {
                f[0] += self.body_force * std::f64::consts::PI * p.radius * p.radius;
            }
        }
    }

    /// The polymer part of [`traction_forces`](Self::traction_forces): force and torque
    /// ∮ τ·n ds (n out of the particle) with the current projected conformation; its x component
    /// is the K of thesis §5.4.
    pub fn polymer_forces(&self) -> Vec<[f64; 3]> {
        let g = self.fluid.polymer().modulus();
        let mut out = vec![[0.0; 3]; self.reaction.len()];
        for (e, cut) in self.cuts.iter().enumerate() {
            let ElementCut::Cut(cut) = cut else { continue };
            for pc in &cut.particles {
                for bp in &pc.points {
                    let c = sym_at(&self.mesh, &self.conformation, e, bp.xi);
                    let tau = (c - Sym2::IDENTITY) * g;
                    let t = [
                        -(tau.xx * bp.n[0] + tau.xy * bp.n[1]),
                        -(tau.xy * bp.n[0] + tau.yy * bp.n[1]),
                    ];
                    let r = [bp.x[0] - pc.center[0], bp.x[1] - pc.center[1]];
                    let f = &mut out[pc.particle];
                    f[0] += bp.w * t[0];
                    f[1] += bp.w * t[1];
                    f[2] += bp.w * (r[0] * t[1] - r[1] * t[0]);
                }
            }
        }
        out
    }

    /// Polymer stress τ = G(c − I) at a point (rectangle meshes), from the projected conformation.
    pub fn polymer_stress_at(&self, x: [f64; 2]) -> Option<Sym2> {
        let (e, xi) = self.mesh.locate(x)?;
        let c = sym_at(&self.mesh, &self.conformation, e, xi);
        Some((c - Sym2::IDENTITY) * self.fluid.polymer().modulus())
    }

    /// Body force of the last flow solve (flow-rate control), 0 without it.
    pub fn body_force(&self) -> f64 {
        self.body_force
    }

    /// Polymer stress τ = G(c − I) of the projected conformation cⁿ at the Q1 vertices (inside a
    /// particle: of its extension).
    pub fn polymer_stress(&self) -> Vec<Sym2> {
        if !self.params.has_polymer() {
            return Vec::new();
        }
        let polymer = self.fluid.polymer();
        self.conformation
            .iter()
            .map(|&c| polymer.stress(c))
            .collect()
    }

    /// Domain mean of the polymer stress τ = G(c − I) (the mean of Π exp(s) equals that of
    /// exp(s_h): constants are Q1 test functions).
    pub fn mean_polymer_stress(&self) -> Sym2 {
        let cuts = self.projection.cuts();
        let m = fluid_mean(&self.mesh, cuts, |e, xi| {
            let c = crate::solver::constitutive_projection::sym_at(
                &self.mesh,
                &self.conformation,
                e,
                xi,
            );
            [c.xx, c.xy, c.yy]
        });
        self.fluid.polymer().stress(Sym2::new(m[0], m[1], m[2]))
    }

    /// Domain mean of the total extra stress 2η_s D(u) + τ.
    pub fn mean_extra_stress(&self) -> Sym2 {
        let cuts: &[ElementCut] = self.projection.cuts();
        let d = fluid_mean(&self.mesh, cuts, |e, xi| {
            let d = velocity_gradient_at(&self.mesh, &self.velocity, e, xi).rate_of_deformation();
            [d.xx, d.xy, d.yy]
        });
        2.0 * self.fluid.eta_s() * Sym2::new(d[0], d[1], d[2]) + self.mean_polymer_stress()
    }
}
