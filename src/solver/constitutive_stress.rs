//! The polymer stress handed to the flow solve, from the projected conformation `cⁿ` (Eq. 5.28)
//! in the linearized form `τ = A:L(u) + B·u + b` of [`PolymerStress`]:
//!
//! - [`Coupling::Explicit`]: `τ = τ(cⁿ) = G(cⁿ − I)` (Eq. 2.45 with the stress of the last
//!   step), only `b`: the flow matrix stays symmetric (LBLᵀ).
//! - [`Coupling::SemiImplicit`]: the D'Avino–Hulsen stress of Eq. 5.26/5.51,
//!   `τ = GΔt(−(u − u_m)·∇cⁿ + L·cⁿ + cⁿ·Lᵀ) + G h(cⁿ, Δt) − G I`: `A` and `b` from
//!   [`SemiImplicitStress`], `B_ijk = −GΔt ∂_k cⁿ_ij`, and `+GΔt u_m·∇cⁿ` in `b` (LU).
//!   Eq. 5.51 is one Euler step: its O(Δt²) local error divided by the O(GΔt) "viscosity"
//!   through which the stress depends on u leaves an O(Δt) error in u^{n+1} when η_s = 0, and
//!   the run is first order in time (measured on the translating cylinder held at rest,
//!   docs/validation.md). With `c^{n−1}` available the predictor is the BDF2 step of the
//!   transport, linearized about ĉ = 2cⁿ − c^{n−1}:
//!   `c^{n+1} ≈ (4cⁿ − c^{n−1})/3 + (2Δt/3)(L·ĉ + ĉ·Lᵀ − (u − u_m)·∇ĉ + relax(ĉ))`,
//!   local error O(Δt³), i.e. [`SemiImplicitStress`] of ĉ with step 2Δt/3 plus
//!   `−(2G/3)(cⁿ − c^{n−1})`.
//!
//! With a decoupled DEVSS-G (`coupled_g = false` in the flow solver) the term `−θGⁿ` is added to
//! `b` at volume points (not on particle boundaries, where only τ belongs).
//!
//! The lagged terms of the explicit path, `τ(cⁿ)` and `θGⁿ` standing for their values at
//! t^{n+1}, make it first order in time (translating cylinder held at rest, η_s = 0.1,
//! docs/validation.md). Extrapolating them, `τ(2cⁿ − c^{n−1})` and `θ(2Gⁿ − G^{n−1})`, halved
//! the error there but made the explicit coupling unstable without solvent (the β = 0 shear
//! tests diverged), so the default explicit path stays lagged; the semi-implicit one is second
//! order. With `extrapolate` (and `previous`) the explicit stress is `τ(ĉ)` at the BDF2
//! predictor's ĉ = cⁿ + r(cⁿ − c^{n−1}) (`numerics.coupling = "explicit_extrapolated"`, with G
//! solved with the flow; β > 0 only).

use crate::mesh::Mesh;
use crate::rheology::{Giesekus, SemiImplicitStress, Sym2};
use crate::solver::bdf::Bdf2;
use crate::solver::constitutive_projection::{gradient_field_at, sym_at, sym_gradient_at};
use crate::solver::polymer_terms::{PolymerStress, StressLin};

/// How the polymer stress enters the flow solve.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Coupling {
    /// `τ(cⁿ)` as a load (symmetric flow matrix; the fast path).
    Explicit,
    /// Eq. 5.26: implicit in the new velocity (non-symmetric flow matrix, LU); works for `η_s = 0`.
    SemiImplicit,
}

/// [`PolymerStress`] from nodal Q1 fields of the current time level.
#[derive(Debug, Clone, Copy)]
pub struct CouplingStress<'a> {
    /// The mesh the fields live on.
    pub mesh: &'a Mesh,
    /// The polymer.
    pub model: Giesekus,
    /// Projected conformation `cⁿ` at the Q1 vertices.
    pub conformation: &'a [Sym2],
    /// Coupling kind.
    pub coupling: Coupling,
    /// Time step (semi-implicit only).
    pub dt: f64,
    /// The BDF2 coefficients of this step (semi-implicit with `previous` only).
    pub bdf: Bdf2,
    /// Mesh velocity at the Q2 nodes (semi-implicit only; `None` = fixed mesh).
    pub mesh_velocity: Option<&'a [[f64; 2]]>,
    /// Decoupled DEVSS-G: `θ` and the lagged `Gⁿ` at the Q1 vertices.
    pub devss: Option<(f64, &'a [[f64; 4]])>,
    /// Projected `c^{n−1}` on the current configuration: the semi-implicit BDF2 predictor
    /// instead of Eq. 5.51's Euler step, or the explicit stress's extrapolation.
    pub previous: Option<&'a [Sym2]>,
    /// Explicit coupling: the stress at the extrapolated ĉ (with `previous`) instead of cⁿ.
    pub extrapolate: bool,
}

impl PolymerStress for CouplingStress<'_> {
    fn at(&self, e: usize, xi: [f64; 2], _x: [f64; 2], on_boundary: bool) -> StressLin {
        let c = sym_at(self.mesh, self.conformation, e, xi);
        let mut lin = match self.coupling {
            Coupling::Explicit => {
                let c = match self.previous {
                    Some(prev) if self.extrapolate => {
                        let (w1, w0) = self.bdf.extrapolation();
                        w1 * c + w0 * sym_at(self.mesh, prev, e, xi)
                    }
                    _ => c,
                };
                StressLin {
                    b: self.model.stress(c).to_rows(),
                    ..Default::default()
                }
            }
            Coupling::SemiImplicit => {
                let dc = sym_gradient_at(self.mesh, self.conformation, e, xi);
                let (si, dc, mut b) = match self.previous {
                    None => {
                        let si = SemiImplicitStress::new(&self.model, c, self.dt);
                        (si, dc, si.constant)
                    }
                    Some(prev) => {
                        // c^{n+1} = (c₁cⁿ − c₂c^{n−1})/c₀ + (Δt/c₀)(…) at the extrapolated ĉ:
                        // (4cⁿ − c^{n−1})/3 + (2Δt/3)(…) and ĉ = 2cⁿ − c^{n−1} for equal steps
                        let b = self.bdf;
                        let (w1, w0) = b.extrapolation();
                        let cp = sym_at(self.mesh, prev, e, xi);
                        let dcp = sym_gradient_at(self.mesh, prev, e, xi);
                        let hat = w1 * c + w0 * cp;
                        let dhat = [w1 * dc[0] + w0 * dcp[0], w1 * dc[1] + w0 * dcp[1]];
                        let si = SemiImplicitStress::new(&self.model, hat, self.dt / b.c0);
                        let base = (b.c1 / b.c0) * c - (b.c2 / b.c0) * cp;
                        let shift = self.model.modulus() * (base - hat);
                        (si, dhat, si.constant + shift)
                    }
                };
                let mut bu = [[[0.0; 2]; 2]; 2];
                for i in 0..2 {
                    for j in 0..2 {
                        for k in 0..2 {
                            bu[i][j][k] = -si.g_dt * dc[k].get(i, j);
                        }
                    }
                }
                if let Some(um) = self.mesh_velocity {
                    let psi2 = crate::fem::element::q2(xi).0;
                    let nodes = &self.mesh.elements[e];
                    let mut w = [0.0; 2];
                    for a in 0..9 {
                        w[0] += psi2[a] * um[nodes[a]][0];
                        w[1] += psi2[a] * um[nodes[a]][1];
                    }
                    b += si.g_dt * (w[0] * dc[0] + w[1] * dc[1]);
                }
                StressLin {
                    a: Some(si.coefficients),
                    b_u: Some(bu),
                    b: b.to_rows(),
                }
            }
        };
        if let (Some((theta, g)), false) = (self.devss, on_boundary) {
            let gv = gradient_field_at(self.mesh, g, e, xi).to_rows();
            for i in 0..2 {
                for j in 0..2 {
                    lin.b[i][j] -= theta * gv[i][j];
                }
            }
        }
        lin
    }

    fn is_implicit(&self) -> bool {
        self.coupling == Coupling::SemiImplicit
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::Axis;
    use crate::rheology::VelocityGradient;

    /// The same few flops in another order: round-off.
    const ROUND_OFF: f64 = 1e-13;

    #[test]
    fn explicit_and_semi_implicit_stress_at_a_point() {
        let mesh = Mesh::rectangle(
            Axis::uniform(0.0, 1.0, 2),
            Axis::uniform(0.0, 1.0, 2),
            false,
        );
        let model = Giesekus::new(2.0, 3.0, 0.2).unwrap();
        // c varies linearly in x: c = c0 + x dc
        let (c0, dcx) = (Sym2::new(2.0, 0.5, 1.5), Sym2::new(0.4, -0.2, 0.1));
        let c: Vec<Sym2> = mesh
            .node_of_vertex
            .iter()
            .map(|&k| c0 + mesh.nodes[k][0] * dcx)
            .collect();
        let g = vec![[0.1, 0.2, 0.3, 0.4]; mesh.n_vertices()];
        let mut st = CouplingStress {
            mesh: &mesh,
            model,
            conformation: &c,
            coupling: Coupling::Explicit,
            dt: 0.1,
            bdf: Bdf2::with_ratio(1.0),
            mesh_velocity: None,
            devss: Some((0.5, &g)),
            previous: None,
            extrapolate: false,
        };
        let (e, xi) = (0, [0.0, 0.0]);
        let x = crate::fem::element::q2_map(&mesh.element_coords[e], xi).0;
        let cx = c0 + x[0] * dcx;
        let lin = st.at(e, xi, x, false);
        let tau = model.stress(cx).to_rows();
        assert!(lin.a.is_none() && lin.b_u.is_none());
        for i in 0..2 {
            for j in 0..2 {
                let want = tau[i][j] - 0.5 * g[0][2 * i + j];
                assert!((lin.b[i][j] - want).abs() < ROUND_OFF);
            }
        }
        // on a particle boundary only τ
        assert!((st.at(e, xi, x, true).b[0][1] - tau[0][1]).abs() < ROUND_OFF);
        // semi-implicit: τ(u, L) = A:L + B·u + b must equal Eq. 5.26 evaluated directly
        st.coupling = Coupling::SemiImplicit;
        st.devss = None;
        let lin = st.at(e, xi, x, false);
        let (l, u) = (VelocityGradient::new(0.3, -1.0, 0.7, -0.3), [0.8, -0.6]);
        let gdt = model.modulus() * 0.1;
        let direct = gdt * (l.stretch(cx) - (u[0] * dcx))
            + model.modulus()
                * (crate::rheology::relaxed_conformation(&model, cx, 0.1) - Sym2::IDENTITY);
        // τ(u, L) = A:L + B·u + b
        let lr = l.to_rows();
        let affine = |lin: &StressLin, i: usize, j: usize| {
            let (a, bu) = (lin.a.unwrap(), lin.b_u.unwrap());
            let mut t = lin.b[i][j];
            for k in 0..2 {
                t += bu[i][j][k] * u[k];
                for m in 0..2 {
                    t += a[i][j][k][m] * lr[k][m];
                }
            }
            t
        };
        for i in 0..2 {
            for j in 0..2 {
                let t = affine(&lin, i, j);
                assert!((t - direct.get(i, j)).abs() < ROUND_OFF, "{i}{j}: {t}");
            }
        }
        assert!(st.is_implicit());
        // with c^{n−1}: the BDF2 predictor (4cⁿ − c^{n−1})/3 + (2Δt/3)(stretch(ĉ) − u·∇ĉ
        // + relax(ĉ)), ĉ = 2cⁿ − c^{n−1}; c^{n−1} varies linearly too
        let (p0, dpx) = (Sym2::new(1.8, 0.3, 1.4), Sym2::new(0.1, 0.05, -0.2));
        let cp: Vec<Sym2> = mesh
            .node_of_vertex
            .iter()
            .map(|&k| p0 + mesh.nodes[k][0] * dpx)
            .collect();
        st.previous = Some(&cp);
        let lin = st.at(e, xi, x, false);
        let cpx = p0 + x[0] * dpx;
        let (hat, dhat) = (2.0 * cx - cpx, 2.0 * dcx - dpx);
        let g = model.modulus();
        let d2 = 2.0 * 0.1 / 3.0;
        let c_next = (1.0 / 3.0) * (4.0 * cx - cpx)
            + d2 * (l.stretch(hat) - u[0] * dhat + model.relaxation(hat));
        let direct = g * (c_next - Sym2::IDENTITY);
        for i in 0..2 {
            for j in 0..2 {
                let t = affine(&lin, i, j);
                assert!((t - direct.get(i, j)).abs() < ROUND_OFF, "BDF2 {i}{j}: {t}");
            }
        }
        // explicit, extrapolated: τ(cⁿ + r(cⁿ − c^{n−1})) for a step ratio r = 1.5; without
        // `extrapolate` the lagged τ(cⁿ), and without c^{n−1} (the first step) as well
        st.coupling = Coupling::Explicit;
        st.bdf = Bdf2::with_ratio(1.5);
        let lagged = model.stress(cx).to_rows();
        let extrapolated = model.stress(2.5 * cx - 1.5 * cpx).to_rows();
        for (extrapolate, previous, want) in [
            (true, Some(cp.as_slice()), extrapolated),
            (false, Some(cp.as_slice()), lagged),
            (true, None, lagged),
        ] {
            st.extrapolate = extrapolate;
            st.previous = previous;
            let lin = st.at(e, xi, x, false);
            assert!(!st.is_implicit() && lin.a.is_none() && lin.b_u.is_none());
            for i in 0..2 {
                for j in 0..2 {
                    assert!(
                        (lin.b[i][j] - want[i][j]).abs() < ROUND_OFF,
                        "{extrapolate}"
                    );
                }
            }
        }
    }
}
