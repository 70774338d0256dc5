//! Weak rigid-body condition on a particle boundary (thesis Eqs. 5.21–5.24), element by element.
//!
//! For a cut element and one particle i with centre X, jump g(v, V, χ) = v − V − χ × (x − X)
//! (2D: χ × r = χ (−r_y, r_x)), the element contributes
//!
//! ```text
//!   −(g(v,V,χ), σ(u,p)·n)_Γ                       consistency (open-boundary term, Eq. 5.21)
//!   −(σ(v,q)·n, g(u,U,ω))_Γ                       adjoint consistency (symmetric variant only)
//!   + κ L(g(v,V,χ), g(u,U,ω))                     stabilization, Eq. 5.24
//!   L(a, b) = M⁻¹_{km} (a n, φ_k)_Γ : (φ_m, n b + b n)_Γ
//! ```
//!
//! with σ = −pI + 2η D, n the outward normal of the fluid, φ_k the discontinuous Q2 basis of the
//! eliminated field E on this element and M_{km} = (φ_k, φ_m) over the element's fluid part.
//! The L term is symmetric positive semi-definite. The thesis uses the non-symmetric form
//! (consistency term only) with κ = η0; the symmetric variant adds the adjoint term so that the
//! whole flow system stays symmetric for the LBLᵀ solver. Rigid unknowns (U_x, U_y, ω) enter
//! through g, which makes the particle force- and torque-free when they are free unknowns.
//!
//! ## The fictitious domain method: a two-sided boundary
//!
//! With the fictitious domain method (FDM, `numerics.method = "fdm"`, thesis §2.3.4) the particle
//! interior is fluid and Γ runs through elements integrated whole ([`CutElement::whole`]). The
//! consistency terms come from integrating the momentum balance by parts over the fluid on one
//! side of Γ; with fluid on both sides they read −(g(v), ⟦σ⟧·n)_Γ with ⟦σ⟧ the jump of the
//! stress across Γ, and the discrete fields of an element integrated whole are one polynomial
//! there: no jump, the terms vanish (so do the polymer ones, `solver::polymer_terms`). Keeping
//! the one-sided terms is inconsistent: measured on the confined cylinder (h = 0.05R) they drive
//! the stress integral negative (K = −103) and the force of the condition 17 % low
//! (docs/validation.md, issue 23). What remains is the stabilization κL(g, g): a penalty on the
//! jump, whose consistency error (the slip g it leaves) is O(h/κ) — with κ = η0 the drag is
//! again 17 % low at h = 0.05R — so FDM uses κ = [`FICTITIOUS_DOMAIN_PENALTY`] · η0.
//!
//! ## The force of the condition (K_L)
//!
//! The thesis reads the drag of both methods also from the Lagrange multipliers λ that impose
//! the rigid motion: F_L = ∫_Γ λ ds (Eq. 2.57), the traction the constraint needs. Here the
//! condition is weak and has no multiplier unknowns; its multiplier is implied, and F_L is the
//! reaction of the rigid rows (test functions V, χ): the force and torque the condition exerts
//! on the particle, −(rigid rows of this kernel)·x (`solver::flow::forces`), zero for a free
//! particle and the holding force of a prescribed one. With XFEM that is the traction integral
//! −∫σ(u_h,p_h)·n ds (n into the particle) plus the stabilization's force −κL(e, g(u_h)); the
//! polymer traction enters the rigid rows through the polymer consistency term and is added by
//! the caller (`ViscoelasticFlow::particle_forces`). With FDM it is the penalty's force alone,
//! which carries the whole jump of the traction across Γ — the outer traction minus the
//! interior fluid's, whose integral is the force on the interior (zero in Stokes flow without
//! body force, −f·|P| with one: the reaction then includes the body force on the interior).
//! The thesis' own condition, with multiplier unknowns on a ring and F_L = ∫λ ds itself, is the
//! alternative `numerics.rigid_condition = "multiplier"` ([`crate::solver::multiplier`]).

use nalgebra::{SMatrix, SVector};

use crate::fem::element::{physical_gradients, q1, q2, q2_map};

/// How a particle moves.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Motion {
    /// Force- and torque-free: (U, ω) are unknowns.
    Free,
    /// Prescribed translational and angular velocity (a fixed body when zero).
    Prescribed {
        /// Translational velocity.
        u: [f64; 2],
        /// Angular velocity (counter-clockwise positive).
        omega: f64,
    },
}

/// A rigid circular particle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Particle {
    /// Centre.
    pub center: [f64; 2],
    /// Radius.
    pub radius: f64,
    /// Motion.
    pub motion: Motion,
}

/// The boundary of one particle inside one cut element.
#[derive(Debug, Clone, PartialEq)]
pub struct ParticleCut {
    /// Particle index.
    pub particle: usize,
    /// Centre of the particle image that cuts this element (differs from the particle centre
    /// by a period when the particle crosses a periodic boundary).
    pub center: [f64; 2],
    /// Boundary quadrature points.
    pub points: Vec<BoundaryPoint>,
}

/// Volume and boundary quadrature of an element crossed by particle boundaries.
#[derive(Debug, Clone, PartialEq)]
pub struct CutQuadrature {
    /// Volume quadrature: reference points and reference weights (× det J gives physical). XFEM:
    /// the fluid part; fictitious domain (`whole`): the whole element's standard rule.
    pub vol: Vec<([f64; 2], f64)>,
    /// Whether `vol` covers the whole element: the fictitious domain method (thesis §2.3.4),
    /// whose particle interior is fluid, so that nothing is cut off (no ghost penalty, every
    /// node a fluid node) and the boundary is two-sided (see [`weak_rigid_kernel`]). False for
    /// XFEM's cut cells.
    pub whole: bool,
    /// Boundary pieces, one per particle cutting the element.
    pub particles: Vec<ParticleCut>,
}

/// Where an element lies relative to the particles.
#[derive(Debug, Clone, PartialEq)]
pub enum ElementCut {
    /// Entirely in the fluid (with the fictitious domain method also: entirely inside a
    /// particle, whose interior is fluid there).
    Fluid,
    /// Entirely inside particles (or a discarded sliver): no contribution (XFEM only).
    Inside,
    /// Crossed by one or more particle boundaries: XFEM's cut cell, or with the fictitious
    /// domain method the whole element with the boundary pieces in it
    /// ([`CutQuadrature::whole`]).
    Cut(CutQuadrature),
}

/// Whether `cuts` are those of the fictitious domain method (its crossed elements are integrated
/// whole; XFEM's never are).
pub fn fictitious_domain(cuts: &[ElementCut]) -> bool {
    cuts.iter()
        .any(|c| matches!(c, ElementCut::Cut(q) if q.whole))
}

/// A quadrature point on a particle boundary inside one element.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BoundaryPoint {
    /// Reference coordinates in the element.
    pub xi: [f64; 2],
    /// Physical point.
    pub x: [f64; 2],
    /// Weight (physical arc length).
    pub w: f64,
    /// Outward unit normal of the fluid (pointing into the particle).
    pub n: [f64; 2],
}

/// Which form of the weak condition to assemble.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WeakForm {
    /// Thesis form (non-symmetric matrix).
    Thesis,
    /// With the adjoint consistency term (symmetric matrix).
    Symmetric,
}

/// Geometry of one cut element for the kernel.
#[derive(Debug, Clone, Copy)]
pub struct CutElement<'a> {
    /// Physical coordinates of the element's Q2 nodes.
    pub xe: &'a [[f64; 2]; 9],
    /// Volume quadrature (fluid part, or the whole element): reference points and weights.
    pub vol: &'a [([f64; 2], f64)],
    /// Boundary quadrature of this particle inside the element.
    pub bnd: &'a [BoundaryPoint],
    /// The element is integrated whole (fictitious domain, [`CutQuadrature::whole`]): Γ is
    /// two-sided, no consistency terms, penalty κ · [`FICTITIOUS_DOMAIN_PENALTY`].
    pub whole: bool,
}

impl<'a> CutElement<'a> {
    /// The kernel's view of the boundary piece `piece` of the crossed element `cut` with nodes
    /// `xe`.
    pub fn of(xe: &'a [[f64; 2]; 9], cut: &'a CutQuadrature, piece: &'a ParticleCut) -> Self {
        CutElement {
            xe,
            vol: &cut.vol,
            bnd: &piece.points,
            whole: cut.whole,
        }
    }
}

/// The fictitious domain method's penalty: κ = this × η0 (the XFEM κ times this). Chosen by
/// measurement of K_L on the Newtonian confined cylinder against the boundary-fitted 132.358
/// (docs/validation.md, issue 23): a finite penalty leaves a slip that makes K_L low (O(h/κ):
/// with κ = η0 −17 % at h = 0.05R; with 10³ −0.07 % at 0.05R, −0.04 % at 0.015R), and a very
/// large one locks (it asks the 27 moments of g per element to vanish, more than a continuous
/// Q2 velocity can meet: with 10⁶ +1.1 % at 0.2R, +0.4 % at 0.05R; with 10⁴ +0.08 % at 0.05R).
/// With 3·10³ K_L is within 0.03 % from h = 0.05R to 0.015R (−0.5 % at 0.2R).
pub const FICTITIOUS_DOMAIN_PENALTY: f64 = 3e3;

/// Adds the weak rigid-body terms to the local matrix `ke` (row-major, `nd` × `nd`) whose local
/// dofs are: 18 velocity (node-major, component-minor), 4 pressure, …, and the particle's rigid
/// unknowns (U_x, U_y, ω) at `off_rigid..off_rigid + 3`.
#[allow(clippy::too_many_arguments)]
pub fn weak_rigid_kernel(
    ke: &mut [f64],
    nd: usize,
    off_rigid: usize,
    cut: &CutElement<'_>,
    center: [f64; 2],
    eta: f64,
    kappa: f64,
    form: WeakForm,
) {
    let kappa = if cut.whole {
        kappa * FICTITIOUS_DOMAIN_PENALTY
    } else {
        kappa
    };
    // Local mass matrix of the discontinuous Q2 space on the fluid part.
    let mut m = SMatrix::<f64, 9, 9>::zeros();
    for &(xi, w) in cut.vol {
        let det = q2_map(cut.xe, xi).2;
        let n2 = q2(xi).0;
        for k in 0..9 {
            for l in 0..9 {
                m[(k, l)] += w * det * n2[k] * n2[l];
            }
        }
    }
    let Some(chol) = m.cholesky() else {
        // A fluid part too small to carry E: the element was not discarded by the sliver rule
        // but its mass matrix is numerically singular; skip the stabilization (consistency
        // terms below still apply). A whole element's mass matrix is never singular.
        return consistency_terms(ke, nd, off_rigid, cut, center, eta, form);
    };
    // A[α][k][ij] = Σ_q w φ_k j_α,i n_j for the 21 jump dofs (18 velocity + 3 rigid).
    let mut a = [[[0.0f64; 4]; 9]; 21];
    for bp in cut.bnd {
        let phi = q2(bp.xi).0;
        let r = [bp.x[0] - center[0], bp.x[1] - center[1]];
        for k in 0..9 {
            let wk = bp.w * phi[k];
            for nd_a in 0..9 {
                for c in 0..2 {
                    for j in 0..2 {
                        a[2 * nd_a + c][k][2 * c + j] += wk * phi[nd_a] * bp.n[j];
                    }
                }
            }
            for j in 0..2 {
                a[18][k][j] -= wk * bp.n[j]; // U_x: j = −e_x
                a[19][k][2 + j] -= wk * bp.n[j]; // U_y: j = −e_y
                a[20][k][j] += wk * r[1] * bp.n[j]; // ω: j = −(−r_y, r_x)
                a[20][k][2 + j] -= wk * r[0] * bp.n[j];
            }
        }
    }
    let local = |alpha: usize| local_jump_dof(alpha, off_rigid);
    // Y_β = M⁻¹ (A_β + A_βᵀ), column per ij component.
    for beta in 0..21 {
        let mut y = [[0.0f64; 4]; 9];
        for ij in 0..4 {
            let ji = 2 * (ij % 2) + ij / 2;
            let rhs = SVector::<f64, 9>::from_fn(|k, _| a[beta][k][ij] + a[beta][k][ji]);
            let sol = chol.solve(&rhs);
            for k in 0..9 {
                y[k][ij] = sol[k];
            }
        }
        for alpha in 0..21 {
            let mut l = 0.0;
            for k in 0..9 {
                for ij in 0..4 {
                    l += a[alpha][k][ij] * y[k][ij];
                }
            }
            ke[local(alpha) * nd + local(beta)] += kappa * l;
        }
    }
    consistency_terms(ke, nd, off_rigid, cut, center, eta, form);
}

/// Local matrix index of jump dof `alpha` (0..18 velocity, 18..21 the rigid unknowns stored at
/// `off_rigid..off_rigid + 3`).
#[inline]
pub fn local_jump_dof(alpha: usize, off_rigid: usize) -> usize {
    if alpha < 18 {
        alpha
    } else {
        off_rigid + alpha - 18
    }
}

/// Jump vectors g of the 21 jump dofs at a boundary point: velocity dof (a, c) → N_a e_c,
/// U_x → −e_x, U_y → −e_y, ω → −(−r_y, r_x), with r = x − X and `phi` the Q2 values there.
pub fn jump_vectors(phi: &[f64; 9], r: [f64; 2]) -> [[f64; 2]; 21] {
    let mut jv = [[0.0f64; 2]; 21];
    for a in 0..9 {
        jv[2 * a] = [phi[a], 0.0];
        jv[2 * a + 1] = [0.0, phi[a]];
    }
    jv[18] = [-1.0, 0.0];
    jv[19] = [0.0, -1.0];
    jv[20] = [r[1], -r[0]];
    jv
}

/// −(g(v), σ(u,p)·n)_Γ and, for the symmetric form, −(σ(v,q)·n, g(u))_Γ; nothing on the
/// two-sided boundary of an element integrated whole (the stress has no jump there).
#[allow(clippy::too_many_arguments)]
fn consistency_terms(
    ke: &mut [f64],
    nd: usize,
    off_rigid: usize,
    cut: &CutElement<'_>,
    center: [f64; 2],
    eta: f64,
    form: WeakForm,
) {
    if cut.whole {
        return;
    }
    let mut dn = [[0.0; 2]; 9];
    for bp in cut.bnd {
        let (_, jac, det) = q2_map(cut.xe, bp.xi);
        let (phi, dref) = q2(bp.xi);
        physical_gradients(&jac, det, &dref, &mut dn);
        let psi = q1(bp.xi).0;
        let r = [bp.x[0] - center[0], bp.x[1] - center[1]];
        let n = bp.n;
        let jv = jump_vectors(&phi, r);
        // tractions σ(β)·n of the 22 stress dofs (velocity, pressure)
        let mut tv = [[0.0f64; 2]; 22];
        for b in 0..9 {
            let gn = dn[b][0] * n[0] + dn[b][1] * n[1];
            for d in 0..2 {
                // 2η D(N_b e_d)·n, component i: η (δ_id ∇N_b·n + ∂_i N_b n_d)
                let mut t = [eta * dn[b][0] * n[d], eta * dn[b][1] * n[d]];
                t[d] += eta * gn;
                tv[2 * b + d] = t;
            }
        }
        for m in 0..4 {
            tv[18 + m] = [-psi[m] * n[0], -psi[m] * n[1]];
        }
        let local = |alpha: usize| local_jump_dof(alpha, off_rigid);
        for alpha in 0..21 {
            for beta in 0..22 {
                let v = -bp.w * (jv[alpha][0] * tv[beta][0] + jv[alpha][1] * tv[beta][1]);
                ke[local(alpha) * nd + beta] += v;
                if form == WeakForm::Symmetric {
                    ke[beta * nd + local(alpha)] += v;
                }
            }
        }
    }
}
