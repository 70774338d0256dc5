//! How many elements the narrowest gap has across it: between two particles, or a particle and a
//! wall (issue 25). A film resolved by fewer elements than [`crate::observe::outcome`] asks for
//! makes an outcome suspect (`docs/validation.md`, "Near-contact forces").
//!
//! The count along the line of closest approach is measured in the mesh's element index space:
//! from one surface point P to the other Q it is |Δs_x| + |Δs_y|, with s the continuous element
//! index of each axis ([`super::Axis::index_coordinate`]; (θ, r) on an annulus). For a gap across
//! one axis this is the gap over the element size there; for an oblique gap it counts the element
//! layers of both directions the segment crosses.

use super::{Mesh, Shape};

/// What the narrowest gap lies between.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Between {
    /// Particles `i` and `j` (i < j).
    Particles(usize, usize),
    /// Particle `i` and the wall on the mesh's bottom side (y = y₀, or r = R₁).
    BottomWall(usize),
    /// Particle `i` and the wall on the mesh's top side (y = y₁, or r = R₂).
    TopWall(usize),
}

/// The narrowest gap of a configuration, in elements.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NarrowestGap {
    /// Elements across the gap (0 for touching or overlapping surfaces).
    pub elements: f64,
    /// The gap itself (surface to surface; ≤ 0 for touching or overlapping surfaces).
    pub gap: f64,
    /// Where it is.
    pub between: Between,
}

/// Elements between two physical points (close to each other: shorter than half the period).
pub fn elements_between(mesh: &Mesh, p: [f64; 2], q: [f64; 2]) -> f64 {
    let (n_x, _) = mesh.dims();
    let index = |x: [f64; 2]| {
        let mut a = mesh.axis_coordinates(x);
        if mesh.periodic {
            let (lo, hi) = (mesh.ax.vertices[0], mesh.ax.vertices[n_x]);
            a[0] = lo + (a[0] - lo).rem_euclid(hi - lo);
        }
        [
            mesh.ax.index_coordinate(a[0]),
            mesh.ay.index_coordinate(a[1]),
        ]
    };
    let (sp, sq) = (index(p), index(q));
    // the short way round the period (of n_x elements)
    let dx = crate::periodic::fold(sq[0] - sp[0], mesh.periodic.then_some(n_x as f64));
    dx.abs() + (sq[1] - sp[1]).abs()
}

/// One gap of a configuration: between two particles or a particle and a wall.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Gap {
    /// Elements across the gap (0 for touching or overlapping surfaces).
    pub elements: f64,
    /// The gap itself (surface to surface; ≤ 0 for touching or overlapping surfaces).
    pub gap: f64,
    /// Where it is.
    pub between: Between,
    /// Unit vector across the gap, from the (first) particle's centre towards the other particle
    /// or the wall (Cartesian, also on an annulus).
    pub normal: [f64; 2],
}

/// Every gap of the particles of radii `radii` at `centres`: each pair (periodic images on a
/// periodic mesh: the short way round) and each particle with the walls on the mesh's bottom and
/// top sides (y₀ and y₁, or R₁ and R₂ on an annulus).
pub fn gaps(mesh: &Mesh, centres: &[[f64; 2]], radii: &[f64]) -> Vec<Gap> {
    debug_assert_eq!(centres.len(), radii.len());
    let (n_x, n_y) = mesh.dims();
    let period = match (mesh.periodic, mesh.shape) {
        (true, Shape::Rectangle) => Some(mesh.ax.vertices[n_x] - mesh.ax.vertices[0]),
        _ => None,
    };
    let mut all = Vec::with_capacity(centres.len() * (centres.len() + 3) / 2);
    for (i, (&c, &a)) in centres.iter().zip(radii).enumerate() {
        for (j, (&d, &b)) in centres.iter().zip(radii).enumerate().skip(i + 1) {
            let dx = crate::periodic::fold(d[0] - c[0], period);
            let dist = dx.hypot(d[1] - c[1]);
            let normal = if dist > 0.0 {
                [dx / dist, (d[1] - c[1]) / dist]
            } else {
                [1.0, 0.0]
            };
            let gap = dist - a - b;
            let elements = if gap > 0.0 {
                let p = [c[0] + a * normal[0], c[1] + a * normal[1]];
                let q = [c[0] + (dist - b) * normal[0], c[1] + (dist - b) * normal[1]];
                elements_between(mesh, p, q)
            } else {
                0.0
            };
            all.push(Gap {
                elements,
                gap,
                between: Between::Particles(i, j),
                normal,
            });
        }
        // the walls: the closest point of the particle to each side, in the axes' coordinates
        let [_, r] = mesh.axis_coordinates(c);
        let (lo, hi) = (mesh.ay.vertices[0], mesh.ay.vertices[n_y]);
        let s_near = mesh.ay.index_coordinate(r - a);
        let s_far = mesh.ay.index_coordinate(r + a);
        // outwards: +y on a rectangle, radial on an annulus
        let out = match mesh.shape {
            Shape::Rectangle => [0.0, 1.0],
            _ => {
                let rc = c[0].hypot(c[1]);
                [c[0] / rc, c[1] / rc]
            }
        };
        all.push(Gap {
            elements: s_near.max(0.0),
            gap: r - a - lo,
            between: Between::BottomWall(i),
            normal: [-out[0], -out[1]],
        });
        all.push(Gap {
            elements: (n_y as f64 - s_far).max(0.0),
            gap: hi - r - a,
            between: Between::TopWall(i),
            normal: out,
        });
    }
    all
}

/// The narrowest gap between the particles of radius `radius` at `centres` and between each
/// particle and the walls, in elements ([`gaps`]). `None` without particles.
pub fn narrowest_gap(mesh: &Mesh, centres: &[[f64; 2]], radius: f64) -> Option<NarrowestGap> {
    let radii = vec![radius; centres.len()];
    gaps(mesh, centres, &radii)
        .into_iter()
        // the first of equals, in the order pairs then walls per particle
        .fold(None, |best: Option<Gap>, g| match best {
            Some(b) if b.elements <= g.elements => Some(b),
            _ => Some(g),
        })
        .map(|g| NarrowestGap {
            elements: g.elements,
            gap: g.gap,
            between: g.between,
        })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::Axis;

    /// Index coordinates are ratios of decimal lengths: round-off only.
    const EXACT: f64 = 1e-12;

    #[test]
    fn a_gap_across_columns_counts_columns() {
        // columns of 0.1 on [−1, 1], rows of 0.25 on [−1, 1]
        let mesh = Mesh::rectangle(
            Axis::uniform(-1.0, 1.0, 20),
            Axis::uniform(-1.0, 1.0, 8),
            false,
        );
        let g = narrowest_gap(&mesh, &[[-0.23, 0.0], [0.23, 0.0]], 0.2).expect("two particles");
        assert_eq!(g.between, Between::Particles(0, 1));
        assert!(
            (g.gap - 0.06).abs() < EXACT && (g.elements - 0.6).abs() < EXACT,
            "{g:?}"
        );
        // a particle near the top wall: 0.05 from it, rows of 0.25
        let g = narrowest_gap(&mesh, &[[0.0, 0.75]], 0.2).expect("one particle");
        assert_eq!(g.between, Between::TopWall(0));
        assert!(
            (g.gap - 0.05).abs() < EXACT && (g.elements - 0.2).abs() < EXACT,
            "{g:?}"
        );
    }

    #[test]
    fn an_oblique_gap_counts_both_directions_and_the_period_is_the_short_way() {
        let mesh = Mesh::rectangle(
            Axis::uniform(0.0, 4.0, 40),
            Axis::uniform(-1.0, 1.0, 20),
            true,
        );
        // centres 0.3 apart along (0.6, 0.8), radius 0.1: gap 0.1 = (0.06, 0.08) → 0.6 + 0.8
        let (c, d) = ([3.95, 0.0], [3.95 + 0.18, 0.24]);
        let g = narrowest_gap(&mesh, &[c, [d[0] - 4.0, d[1]]], 0.1).expect("two particles");
        assert!(
            (g.gap - 0.1).abs() < EXACT && (g.elements - 1.4).abs() < 1e-9,
            "{g:?}"
        );
        // overlapping particles have no element between them
        let g = narrowest_gap(&mesh, &[[1.0, 0.0], [1.15, 0.0]], 0.1).expect("two particles");
        assert!(g.gap < 0.0 && g.elements == 0.0);
    }

    #[test]
    fn on_an_annulus_the_wall_gaps_are_radial() {
        // r from 1 to 2 in 10 rows of 0.1: a particle of radius 0.2 at r = 1.25 is 0.05 from
        // the inner cylinder, half a row
        let mesh = Mesh::annulus(64, Axis::uniform(1.0, 2.0, 10));
        let g = narrowest_gap(&mesh, &[[0.0, -1.25]], 0.2).expect("one particle");
        assert_eq!(g.between, Between::BottomWall(0));
        assert!(
            (g.gap - 0.05).abs() < EXACT && (g.elements - 0.5).abs() < EXACT,
            "{g:?}"
        );
    }
}
