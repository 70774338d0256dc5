//! The rigid-body condition by Lagrange multipliers on a ring (thesis §2.3.3, §3.3.2; Eq. 2.31):
//! the alternative to the weak condition of [`crate::solver::rigid`] that the thesis used in
//! Chapters 2–4 and compares its methods by (`numerics.rigid_condition = "multiplier"`).
//!
//! Each particle's boundary is a ring of `N` line elements of equal angle, with a P1 multiplier
//! λ (two components) at each of its `N` nodes θ_j = 2πj/N (fixed in the lab frame) and, like the
//! thesis' P2 ring elements, the exact circle as geometry. The weak form adds to the momentum
//! balance and the rigid rows, and as new rows, the symmetric pair
//!
//! ```text
//!   (v − V − χ × (x − X), λ)_Γ          in the momentum balance (v) and the rigid rows (V, χ)
//!   (μ, u − U − ω × (x − X))_Γ = 0      the constraint (Eq. 2.31), one row per multiplier dof
//! ```
//!
//! so that λ is the traction the fluid exerts on the particle, σ·n with n out of the particle,
//! and the force and torque on it are ∫_Γ λ ds and ∫_Γ (x − X) × λ ds (thesis Eq. 2.57: K_L).
//! Nothing else is imposed on Γ: no consistency or stabilization term, no polymer boundary term
//! (the multiplier carries the whole traction).
//!
//! The ring's element size is that of the fluid elements the circle cuts ([`RING_SPACING`] × the
//! mean √area of the cut elements, at least [`MIN_RING_NODES`] nodes), the thesis' choice
//! (its Fig. 2.12: h_λ/h ≈ 1 is optimal; much finer rings violate the inf-sup condition). The
//! thesis integrates each ring element by 20 midpoint subintervals; here the integrals are taken
//! on the same boundary quadrature as the weak condition — Gauss points along the exact arcs of
//! the circle inside each fluid element, the "exact" integration the thesis mentions — so that
//! each element's couplings are local to it. A ring node inside an arc piece puts a kink in the
//! integrand there, which the Gauss rule does not integrate exactly; the discrete constraint is
//! still consistent (the exact solution satisfies it for any test function) and the force is read
//! with the same quadrature as the rows it balances.

use std::f64::consts::PI;

/// Ring element size over the size of the fluid elements the circle cuts (thesis: ≈ 1).
pub const RING_SPACING: f64 = 1.0;

/// Fewest ring nodes of a particle (a particle inside a few elements still gets a polygon that
/// can carry a force and a torque).
pub const MIN_RING_NODES: usize = 8;

/// How a particle's rigid-body motion is imposed on its boundary (`numerics.rigid_condition`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum RigidCondition {
    /// The weak condition of [`crate::solver::rigid`] (thesis Ch. 5): no extra unknowns.
    #[default]
    Weak,
    /// Lagrange multipliers on a ring (thesis Chs. 2–4): two unknowns per ring node.
    Multiplier,
}

impl RigidCondition {
    /// Whether this is the default, [`RigidCondition::Weak`].
    pub fn is_weak(&self) -> bool {
        *self == RigidCondition::Weak
    }
}

/// The multiplier ring of one particle: its node count and the index of its first node among
/// all particles' ring nodes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Ring {
    /// Number of ring nodes (= ring elements).
    pub nodes: usize,
    /// Global index of node 0.
    pub first: usize,
}

impl Ring {
    /// Rings for particles of radii `radii` with fluid element sizes `h` at their boundaries,
    /// numbered one after the other.
    pub fn for_particles(radii: &[f64], h: &[f64]) -> Vec<Ring> {
        let mut first = 0;
        radii
            .iter()
            .zip(h)
            .map(|(&a, &h)| {
                let nodes =
                    ((2.0 * PI * a / (RING_SPACING * h)).round() as usize).max(MIN_RING_NODES);
                let ring = Ring { nodes, first };
                first += nodes;
                ring
            })
            .collect()
    }

    /// The two ring nodes (global indices) whose P1 functions are nonzero at the boundary point
    /// with arm `r` = x − X, and their values.
    pub fn basis_at(&self, r: [f64; 2]) -> [(usize, f64); 2] {
        let theta = r[1].atan2(r[0]).rem_euclid(2.0 * PI);
        let t = theta * self.nodes as f64 / (2.0 * PI);
        let j = (t.floor() as usize).min(self.nodes - 1);
        let s = (t - j as f64).clamp(0.0, 1.0);
        let next = (j + 1) % self.nodes;
        [(self.first + j, 1.0 - s), (self.first + next, s)]
    }

    /// The node before and after global node `k` on this ring.
    pub fn neighbours(&self, k: usize) -> [usize; 2] {
        let j = k - self.first;
        [
            self.first + (j + self.nodes - 1) % self.nodes,
            self.first + (j + 1) % self.nodes,
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The P1 functions are a partition of unity on the ring and interpolate linear functions
    /// of the angle between nodes; a ring has about 2πa/h nodes.
    #[test]
    fn ring_functions_partition_unity_and_interpolate_the_angle() {
        let rings = Ring::for_particles(&[0.1, 0.5], &[0.0125, 0.05]);
        assert_eq!(
            rings[0],
            Ring {
                nodes: 50,
                first: 0
            }
        );
        assert_eq!(
            rings[1],
            Ring {
                nodes: 63,
                first: 50
            }
        );
        let ring = rings[1];
        for q in 0..997 {
            let theta = 2.0 * PI * q as f64 / 997.0;
            let r = [0.5 * theta.cos(), 0.5 * theta.sin()];
            let b = ring.basis_at(r);
            assert!((b[0].1 + b[1].1 - 1.0).abs() < 1e-14);
            assert!(b
                .iter()
                .all(|&(k, v)| (50..113).contains(&k) && (0.0..=1.0).contains(&v)));
            // the node angles weighted by the basis give back the angle (away from the wrap)
            let angle = |k: usize| 2.0 * PI * (k - ring.first) as f64 / ring.nodes as f64;
            if b[1].0 > b[0].0 {
                let back = b[0].1 * angle(b[0].0) + b[1].1 * angle(b[1].0);
                assert!((back - theta).abs() < 1e-12, "{back} vs {theta}");
            }
        }
        assert_eq!(ring.neighbours(50), [112, 51]);
        // a particle much smaller than the elements still gets the minimum ring
        assert_eq!(
            Ring::for_particles(&[0.01], &[0.1])[0].nodes,
            MIN_RING_NODES
        );
    }
}
