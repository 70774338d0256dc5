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

/// Fluid-part and boundary quadrature of a cut element.
#[derive(Debug, Clone, PartialEq)]
pub struct CutQuadrature {
    /// Fluid-part quadrature: reference points and reference weights (× det J gives physical).
    pub vol: Vec<([f64; 2], f64)>,
    /// Boundary pieces, one per particle cutting the element.
    pub particles: Vec<ParticleCut>,
}

/// Where an element lies relative to the particles.
#[derive(Debug, Clone, PartialEq)]
pub enum ElementCut {
    /// Entirely in the fluid.
    Fluid,
    /// Entirely inside particles (or a discarded sliver): no contribution.
    Inside,
    /// Cut by one or more particle boundaries.
    Cut(CutQuadrature),
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
    /// Fluid-part volume quadrature: reference points and reference weights.
    pub vol: &'a [([f64; 2], f64)],
    /// Boundary quadrature of this particle inside the element.
    pub bnd: &'a [BoundaryPoint],
}

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
        // terms below still apply).
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

/// −(g(v), σ(u,p)·n)_Γ and, for the symmetric form, −(σ(v,q)·n, g(u))_Γ.
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
