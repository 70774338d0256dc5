//! Test support for the XFEM module: an exact annulus sector (curved map), uniform rectangle
//! meshes, a smoothly perturbed bilinear mesh, and the leading-order chord error estimates that
//! the area tests compare against.

use std::f64::consts::PI;

use super::ref_map::{BilinearQuad, RectMap, RefMap};
use crate::fem::element::Q2_NODES;

/// The annulus sector r ∈ [r0, r1], θ ∈ [t0, t1] with the exact polar map
/// x = r(ξ) (cos θ(η), sin θ(η)), r and θ affine in ξ and η.
#[derive(Debug, Clone, Copy)]
pub struct AnnulusSector {
    r: [f64; 2],
    theta: [f64; 2],
}

impl AnnulusSector {
    pub fn new(r: [f64; 2], theta: [f64; 2]) -> Self {
        Self { r, theta }
    }

    fn polar(&self, xi: [f64; 2]) -> (f64, f64) {
        (
            self.r[0] + 0.5 * (xi[0] + 1.0) * (self.r[1] - self.r[0]),
            self.theta[0] + 0.5 * (xi[1] + 1.0) * (self.theta[1] - self.theta[0]),
        )
    }

    /// The nine Q2 nodes of the sector (on the exact circles), tensor order.
    pub fn q2_nodes(&self) -> [[f64; 2]; 9] {
        Q2_NODES.map(|p| self.map(p))
    }
}

impl RefMap for AnnulusSector {
    fn map(&self, xi: [f64; 2]) -> [f64; 2] {
        let (r, t) = self.polar(xi);
        [r * t.cos(), r * t.sin()]
    }

    fn jacobian(&self, xi: [f64; 2]) -> [[f64; 2]; 2] {
        let (r, t) = self.polar(xi);
        let dr = 0.5 * (self.r[1] - self.r[0]);
        let dt = 0.5 * (self.theta[1] - self.theta[0]);
        [
            [dr * t.cos(), -r * dt * t.sin()],
            [dr * t.sin(), r * dt * t.cos()],
        ]
    }
}

/// Uniform nx × ny rectangles of [x0, x1] × [y0, y1].
pub fn rect_mesh(x: [f64; 2], y: [f64; 2], nx: usize, ny: usize) -> Vec<RectMap> {
    let mut out = Vec::with_capacity(nx * ny);
    for j in 0..ny {
        for i in 0..nx {
            let xa = x[0] + (x[1] - x[0]) * i as f64 / nx as f64;
            let xb = x[0] + (x[1] - x[0]) * (i + 1) as f64 / nx as f64;
            let ya = y[0] + (y[1] - y[0]) * j as f64 / ny as f64;
            let yb = y[0] + (y[1] - y[0]) * (j + 1) as f64 / ny as f64;
            out.push(RectMap::new([xa, ya], [xb, yb]));
        }
    }
    out
}

/// nx × ny bilinear quadrilaterals of [x0, x1] × [y0, y1] whose interior vertices are moved by a
/// smooth displacement of amplitude `amp` element sizes (boundary vertices stay on the boundary,
/// so the elements still tile the rectangle exactly).
pub fn perturbed_mesh(
    x: [f64; 2],
    y: [f64; 2],
    nx: usize,
    ny: usize,
    amp: f64,
) -> Vec<BilinearQuad> {
    let (hx, hy) = ((x[1] - x[0]) / nx as f64, (y[1] - y[0]) / ny as f64);
    let vertex = |i: usize, j: usize| {
        let (px, py) = (x[0] + hx * i as f64, y[0] + hy * j as f64);
        let interior_x = i > 0 && i < nx;
        let interior_y = j > 0 && j < ny;
        let dx = if interior_x {
            amp * hx * (1.7 * px + 0.3).sin() * (2.3 * py).cos()
        } else {
            0.0
        };
        let dy = if interior_y {
            amp * hy * (1.1 * px).cos() * (2.9 * py + 0.5).sin()
        } else {
            0.0
        };
        [px + dx, py + dy]
    };
    let mut out = Vec::with_capacity(nx * ny);
    for j in 0..ny {
        for i in 0..nx {
            out.push(BilinearQuad {
                corners: [
                    vertex(i, j),
                    vertex(i + 1, j),
                    vertex(i, j + 1),
                    vertex(i + 1, j + 1),
                ],
            });
        }
    }
    out
}

/// Area error bound of straight chords on a circle of radius a: a chord of length s cuts off a
/// circular segment of area ≈ s³/(12a); the chord lengths sum to at most 2πa and are at most
/// `s_max`, so the total is ≤ π s_max²/6 (independent of a).
pub fn linear_chord_error(s_max: f64) -> f64 {
    PI * s_max * s_max / 6.0
}

/// Leading-order area error of parabolic chords on a circle of radius a: with the circle
/// y = x²/(2a) + x⁴/(8a³) + … and the parabola through x = 0, ±s/2, the difference integrates to
/// s⁵/(960 a³) per chord; summed over chords of total length ≤ 2πa and length ≤ `s_max`:
/// ≤ π s_max⁴/(480 a²). (Tangencies to element edges add an O(s³) part where a parabola would
/// fold its triangle and the chord stays straight.)
pub fn quadratic_chord_error(a: f64, s_max: f64) -> f64 {
    PI * s_max.powi(4) / (480.0 * a * a)
}
