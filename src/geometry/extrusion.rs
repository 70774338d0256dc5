//! Extrusion flow (thesis §6.2, Fig. 6.1; §6.5.1): a planar die of half-height H0 over
//! −L_w ≤ x ≤ 0 (wall y = H0, symmetry line y = 0), fed at x = −L_w by the fully developed
//! profile of flow rate Q per half-width, and an extrudate over 0 ≤ x ≤ L_fs whose upper boundary
//! is a free surface y = H(x, t) (`crate::solver::free_surface`), traction-free at the outflow
//! x = L_fs. The mesh covers [−L_w, L_fs] × [0, top] with grid lines on x = 0 and y = H0; the
//! fluid is what lies below the die wall and the surface.
//!
//! Scales (§6.5.1): the mean velocity U = Q/H0, the rate U/H0 (Wi = λU/H0; for a UCM fluid the
//! Deborah number of §6.4 is De = λγ̇_w = 3 Wi).

use super::confinement::{Boundary, Confinement};
use crate::mesh::{Axis, Mesh, Side};
use crate::particles::{find_contact, Contact};

/// A particle ends its run when its leading edge comes within this many radii of the outflow
/// x = L_fs: the traction-free outflow condition assumes the flow there is undisturbed, and a
/// particle closer than a diameter would feel the boundary (§6.5 reports trajectories up to where
/// the flow is fully developed again).
pub const OUTFLOW_CLEARANCE: f64 = 2.0;

/// Half-width of the uniformly refined square around the die-exit corner (0, H0) of a mesh
/// refined there ([`Extrusion::die_exit_axes`]; `numerics.die_exit.band`): a multiple of every
/// element size the swell study uses (0.1, 0.05, 0.025, 0.0125).
pub const EXIT_BAND: f64 = 0.2;
/// Growth of the element size away from the refined square ([`Extrusion::die_exit_axes`];
/// `numerics.die_exit.growth`): slow enough that the surface downstream, where the swell peaks,
/// keeps elements of ≤ 0.2 on [−2, 3] × [0, 2].
pub const EXIT_GROWTH: f64 = 1.05;

/// The extrusion set-up.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Extrusion {
    /// Die half-height H0.
    pub h0: f64,
    /// Die length L_w (the die is −L_w ≤ x ≤ 0).
    pub die_length: f64,
    /// Extrudate length L_fs (the outflow is at x = L_fs).
    pub extrudate_length: f64,
    /// Flow rate Q per half-width (mean velocity Q/H0).
    pub flow_rate: f64,
    /// Height of the mesh above the symmetry line (room for the swell).
    pub top: f64,
}

impl Extrusion {
    /// Mean velocity U = Q/H0 in the die.
    pub fn mean_velocity(&self) -> f64 {
        self.flow_rate / self.h0
    }

    /// The fully developed die velocity u_x(y) = (3/2)U(1 − (y/H0)²) for 0 ≤ y ≤ H0 (0 above).
    pub fn inflow_velocity(&self, y: f64) -> f64 {
        if y <= self.h0 {
            let r = y / self.h0;
            1.5 * self.mean_velocity() * (1.0 - r * r)
        } else {
            0.0
        }
    }

    /// The die's shear rate γ̇(y) = du_x/dy = −3U y/H0² (−γ̇_w at the wall).
    pub fn die_shear_rate(&self, y: f64) -> f64 {
        -3.0 * self.mean_velocity() * y / (self.h0 * self.h0)
    }

    /// The axes of `nx` uniform elements along [−L_w, L_fs] and `ny` along [0, top].
    pub fn uniform_axes(&self, nx: usize, ny: usize) -> (Axis, Axis) {
        (
            Axis::uniform(-self.die_length, self.extrudate_length, nx),
            Axis::uniform(0.0, self.top, ny),
        )
    }

    /// The mesh of [`uniform_axes`](Self::uniform_axes).
    pub fn mesh(&self, nx: usize, ny: usize) -> Mesh {
        let (ax, ay) = self.uniform_axes(nx, ny);
        Mesh::rectangle(ax, ay, false)
    }

    /// The axes of a mesh refined around the die-exit corner (0, H0), where the stress is
    /// singular (the thesis' meshes M1–M4 are refined there, §6.4): element size `h` in the
    /// square |x| ≤ `band`, |y − H0| ≤ `band`, growing by `growth` per element away from it up
    /// to the size `coarsest` (infinite: no bound) ([`Axis::banded_capped`]). The die exit and
    /// the die wall are grid lines when `band`/`h` is a whole number
    /// ([`has_grid_lines`](Self::has_grid_lines)).
    ///
    /// # Panics
    /// Unless the square lies in the mesh (`band` ≤ L_w, L_fs, H0 and top − H0), h > 0,
    /// growth ≥ 1 and coarsest ≥ h (the case's validation checks these first).
    pub fn die_exit_axes(&self, h: f64, band: f64, growth: f64, coarsest: f64) -> (Axis, Axis) {
        let (l, top, h0) = (self.die_length, self.top, self.h0);
        (
            Axis::banded_capped(-l, self.extrudate_length, -band, band, h, growth, coarsest),
            Axis::banded_capped(0.0, top, h0 - band, h0 + band, h, growth, coarsest),
        )
    }

    /// Whether axes put grid lines on the die exit x = 0 and the die wall y = H0.
    pub fn has_grid_lines(&self, ax: &Axis, ay: &Axis) -> bool {
        let on = |vertices: &[f64], at: f64| {
            vertices
                .iter()
                .any(|&v| (v - at).abs() < 1e-9 * self.h0.max(1.0))
        };
        on(&ax.vertices, 0.0) && on(&ay.vertices, self.h0)
    }

    /// Whether the mesh with `nx` × `ny` uniform elements has grid lines on the die exit x = 0
    /// and the die wall y = H0 (the wall is a line of nodes where no-slip is imposed).
    pub fn fits(&self, nx: usize, ny: usize) -> bool {
        let on_grid = |length: f64, n: usize, at: f64| {
            let k = at / (length / n as f64);
            (k - k.round()).abs() < 1e-9
        };
        on_grid(self.die_length + self.extrudate_length, nx, self.die_length)
            && on_grid(self.top, ny, self.h0)
    }

    /// The gap of a particle (centre `x`, radius `a`) to the die wall {y = H0, x ≤ 0}: to the
    /// wall above it in the die, to the die-exit corner (0, H0) downstream.
    pub fn die_wall_gap(&self, x: [f64; 2], a: f64) -> f64 {
        let distance = if x[0] <= 0.0 {
            self.h0 - x[1]
        } else {
            x[0].hypot(self.h0 - x[1])
        };
        distance - a
    }
}

impl Confinement for Extrusion {
    fn period(&self) -> Option<f64> {
        None
    }

    /// The inflow profile on the left side (the die's other boundaries are set by
    /// [`Boundary::Extrusion`]).
    ///
    /// # Panics
    /// For another side: the extrusion has no wall on the mesh's other sides.
    fn wall_velocity(&self, side: Side, x: [f64; 2]) -> [f64; 2] {
        match side {
            Side::Left => [self.inflow_velocity(x[1]), 0.0],
            _ => panic!("an extrusion has no wall on the mesh's {side:?} side"),
        }
    }

    /// Particles touching each other, the die wall or the symmetry line (a particle meeting its
    /// mirror image), or reaching the outflow ([`OUTFLOW_CLEARANCE`]). Contact with the free
    /// surface is the stepper's to find: the surface moves.
    fn contact(&self, x: &[[f64; 2]], radius: &[f64], min_gap: f64) -> Option<Contact> {
        for (i, (c, &a)) in x.iter().zip(radius).enumerate() {
            let gap = self.die_wall_gap(*c, a).min(c[1] - a);
            if gap < min_gap {
                return Some(Contact::Wall { i, gap });
            }
            if c[0] + (1.0 + OUTFLOW_CLEARANCE) * a >= self.extrudate_length {
                return Some(Contact::Outflow { i });
            }
        }
        find_contact(x, radius, None, None, min_gap)
    }

    fn shear_rate(&self) -> f64 {
        self.mean_velocity() / self.h0
    }

    fn boundary(&self) -> Boundary {
        Boundary::Extrusion(*self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The §6.5.1 set-up: Q = 1 through the half-die, the profile's flow rate and wall shear
    /// rate, the mesh's grid lines and the contacts.
    #[test]
    fn the_die_profile_carries_the_flow_rate_and_the_contacts_are_where_they_should_be() {
        // a 2-point Gauss rule per element integrates the quadratic profile exactly: round-off
        const TOL: f64 = 1e-13;
        let e = Extrusion {
            h0: 1.0,
            die_length: 3.0,
            extrudate_length: 4.0,
            flow_rate: 1.0,
            top: 2.0,
        };
        let q: f64 = (0..10)
            .map(|k| {
                let (lo, hi) = (0.1 * k as f64, 0.1 * (k + 1) as f64);
                let g = 0.5 / 3f64.sqrt() * (hi - lo);
                let mid = 0.5 * (lo + hi);
                0.5 * (hi - lo) * (e.inflow_velocity(mid - g) + e.inflow_velocity(mid + g))
            })
            .sum();
        assert!((q - 1.0).abs() < TOL, "flow rate {q}");
        assert!((e.die_shear_rate(1.0) + 3.0).abs() < TOL, "γ̇_w = 3 U/H0");
        assert!(e.fits(280, 80) && !e.fits(275, 80) && !e.fits(280, 75));
        let mesh = e.mesh(70, 20);
        assert_eq!(mesh.n_elements(), 1400);
        let a = [0.1];
        assert!(e.contact(&[[-2.3, 0.8]], &a, 0.0).is_none());
        assert!(matches!(
            e.contact(&[[-1.0, 0.95]], &a, 0.0),
            Some(Contact::Wall { i: 0, .. })
        ));
        // downstream of the exit the surface is free: only the corner counts
        assert!(e.contact(&[[0.5, 0.95]], &a, 0.0).is_none());
        assert!(matches!(
            e.contact(&[[0.05, 1.02]], &a, 0.0),
            Some(Contact::Wall { .. })
        ));
        assert!(matches!(
            e.contact(&[[3.71, 0.8]], &a, 0.0),
            Some(Contact::Outflow { i: 0 })
        ));
        assert!(matches!(
            e.contact(&[[-1.0, 0.05]], &a, 0.0),
            Some(Contact::Wall { .. })
        ));
    }
}
