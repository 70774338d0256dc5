//! The benchmark of thesis Ch. 2 (§2.5.1): a fixed cylinder of radius R centred in a channel of
//! height H = 4R between walls at rest, periodic in x with L = 30R, the flow driven to a mean
//! velocity U (flow rate Q = U H). K = F_x/(η0 U R); published K = 132.358 (Newtonian, Table 2.3).

use super::Confinement;
use crate::mesh::{Axis, Side};
use crate::particles::{find_contact, Contact};

/// The confined-cylinder channel.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CylinderChannel {
    /// Cylinder radius R.
    pub radius: f64,
    /// Channel height H (walls at y = ±H/2).
    pub height: f64,
    /// Period L (x ∈ [−L/2, L/2]).
    pub length: f64,
    /// x of the cylinder centre (on the centre line).
    pub center_x: f64,
    /// Mean velocity U of the driven flow.
    pub mean_velocity: f64,
}

impl CylinderChannel {
    /// The thesis' set-up in units of R and U: R = 1, H = 4, L = 30, U = 1. The channel is
    /// periodic, so the centre's x is immaterial to the flow; it is off the grid lines of
    /// [`axes`](Self::axes) so that the cylinder is nowhere tangent to an element edge (exact
    /// tangencies make the cut-cell quadtree refine deeply: slow, not wrong).
    pub const BENCHMARK: CylinderChannel = CylinderChannel {
        radius: 1.0,
        height: 4.0,
        length: 30.0,
        center_x: 0.0123,
        mean_velocity: 1.0,
    };

    /// The flow rate Q = U H the flow is driven to.
    pub fn flow_rate(&self) -> f64 {
        self.mean_velocity * self.height
    }

    /// The cylinder's centre.
    pub fn center(&self) -> [f64; 2] {
        [self.center_x, 0.0]
    }

    /// Mesh axes for element size `h` near the cylinder: uniform in the band |x| ≤ 1.6R (the
    /// centre off its grid lines) and over the height (an odd number of elements, so that the
    /// lines where the cylinder touches horizontals, y = ±R, are no grid lines), growing by 15 %
    /// per element outside the band.
    pub fn axes(&self, h: f64) -> (Axis, Axis) {
        let (half_l, half_h) = (0.5 * self.length, 0.5 * self.height);
        let band = 1.6 * self.radius;
        let ny = (self.height / h).round() as usize | 1;
        (
            Axis::banded(-half_l, half_l, -band, band, h, 1.15),
            Axis::uniform(-half_h, half_h, ny),
        )
    }
}

impl Confinement for CylinderChannel {
    fn period(&self) -> Option<f64> {
        Some(self.length)
    }

    /// Walls at rest.
    fn wall_velocity(&self, _side: Side, _x: [f64; 2]) -> [f64; 2] {
        [0.0, 0.0]
    }

    fn contact(&self, x: &[[f64; 2]], radius: &[f64], min_gap: f64) -> Option<Contact> {
        let walls = Some((-0.5 * self.height, 0.5 * self.height));
        find_contact(x, radius, walls, Some(self.length), min_gap)
    }

    /// U/R (Wi = λU/R).
    fn shear_rate(&self) -> f64 {
        self.mean_velocity / self.radius
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The benchmark's axes: 30R by 4R, an odd row count, the band uniform at h.
    #[test]
    fn benchmark_axes_span_the_channel_with_an_odd_row_count() {
        // sums of a few hundred element sizes: round-off only
        const TOL: f64 = 1e-12;
        let c = CylinderChannel::BENCHMARK;
        let (ax, ay) = c.axes(0.1);
        assert!((ax.vertices[0] + 15.0).abs() < TOL && (ax.vertices[ax.len()] - 15.0).abs() < TOL);
        assert!((ay.vertices[0] + 2.0).abs() < TOL && (ay.vertices[ay.len()] - 2.0).abs() < TOL);
        assert_eq!(ay.len() % 2, 1);
        assert!((c.flow_rate() - 4.0).abs() < TOL);
        assert_eq!(c.contact(&[c.center()], &[1.0], 0.0), None);
    }
}
