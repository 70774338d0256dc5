//! The squeeze force a film between two particles (or a particle and a wall) loses when the mesh
//! does not resolve it, added back as a resistance between their rigid-body unknowns (issue 25).
//!
//! # What the mesh misses
//! A film of thickness g between surfaces approaching at relative normal speed W carries the
//! lubrication force (Reynolds' equation at leading order in g/a; `validate::near_contact` has the
//! derivation)
//!
//! ```text
//!   F_lub = 3√2 π η W (a*/g)^{3/2},   a* = a_i a_j / (a_i + a_j)  (a* = a for a plane wall)
//! ```
//!
//! The discrete flow carries a fraction φ(x) of it, with x the number of elements across the film
//! ([`crate::mesh::resolution::gaps`]). `xpflow validate near-contact` measured φ on uniform
//! meshes of h = 0.2a, 0.1a, 0.05a (docs/validation.md, "Near-contact forces"; φ = F_h over the
//! converged force at the same gap). Between two cylinders (the film on a vertex line and
//! mid-element): 0.997 at one element, 0.95–0.98 at half an element, 0.74–0.85 at a fifth,
//! 0.39–0.47 at a tenth and 0.18–0.19 at a twentieth. Against a wall (a grid line: only the
//! particle's side of the film is cut) more: 0.98–0.99 at half, 0.86–0.90 at a fifth, 0.58–0.62
//! at a tenth, 0.33 at a twentieth. The rational
//!
//! ```text
//!   φ(x) = x² / (x² + c),   c = PAIR_FILM_FIT = 0.012 between particles,
//!                           c = WALL_FILM_FIT = 0.006 against a wall,
//! ```
//!
//! fits those values within ±0.09 (pairs) and ±0.05 (walls): the measured fraction at one x
//! itself scatters by up to 0.11 between meshes and offsets (at a fifth of an element: 0.74 on
//! h = 0.1a, 0.85 on h = 0.05a, whose film is wider in elements), which a function of x alone
//! cannot remove. So a corrected film force is within ≈ 10 % of the resolved one at any x, where
//! the mesh alone loses up to 82 % (measured with the correction: docs/validation.md).
//!
//! # The correction
//! Below [`RESOLVED_ELEMENTS`] across, each film adds the resistance
//!
//! ```text
//!   R = 3√2 π η0 (a*/g)^{3/2} · (c/(x² + c) − c/(1 + c)),   (x < 1)
//! ```
//!
//! i.e. the missing fraction 1 − φ(x), shifted to vanish at one element (a resolved film, whose
//! force the mesh carries within 1 %, is left alone: cases whose films stay resolved are
//! unchanged to round-off — the matrix pattern couples the particles' translations, which can
//! reorder the factorization). It acts on the relative normal velocity W = (U_i − U_j)·n (n from i to
//! j; a wall's normal velocity is zero): the force on i is −R W n, on j +R W n. It enters the
//! flow matrix as R n nᵀ on the translational rows of i and j (−R n nᵀ between them), so that it
//! is as implicit as the film it stands for — an explicit force of this size would overshoot
//! whenever R exceeds the mesh's own resistance. It is symmetric positive semi-definite, like the
//! rest of the rigid rows.
//!
//! # What it leaves out
//! - The film's viscosity is the zero-shear η0 = η_s + η_p: the polymer of a slowly squeezed
//!   film in its Newtonian limit (the flow matrix of the explicit coupling has η_s + θ = η0 too).
//!   A shear-thinning or elastic film is not modelled.
//! - Only the squeeze (normal) mode: the tangential and rotational resistances of a film grow like
//!   log(a/g), which a mesh of a few elements across the particle carries far better.
//! - Walls: the channel's plane walls (confined shear); the Couette cylinders and the extrusion's
//!   die wall have none (a particle–cylinder film has another a*).

use crate::mesh::resolution::{gaps, Between};
use crate::mesh::Mesh;

use super::rigid::Particle;

/// The constant c of the resolved fraction φ(x) = x²/(x² + c) of a film x elements across between
/// two particles (fitted to docs/validation.md's near-contact table, module doc).
pub const PAIR_FILM_FIT: f64 = 0.012;

/// The same for a film between a particle and a wall on a grid line (module doc).
pub const WALL_FILM_FIT: f64 = 0.006;

/// A film at least this many elements across is resolved: no correction (its force is within
/// 1 % of the finest mesh's, docs/validation.md "Near-contact forces").
pub const RESOLVED_ELEMENTS: f64 = 1.0;

/// Smallest gap the resistance is evaluated at, in units of a*: overlapping or touching
/// surfaces (a failing step) get the resistance of this gap instead of an infinite one
/// (3√2π (1e3)^{3/2} ≈ 4.2e5 η0: a film that stiff stops the approach within a step).
pub const MIN_GAP: f64 = 1e-3;

/// The correction of a case: the film's viscosity and which walls it acts on.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lubrication {
    /// Viscosity of the film, η0.
    pub viscosity: f64,
    /// Whether the mesh's bottom and top sides are plane walls the particles lubricate against
    /// (the confined-shear channel).
    pub walls: bool,
}

/// The fraction of the squeeze force a film `elements` across misses with the fit constant `c`
/// ([`PAIR_FILM_FIT`], [`WALL_FILM_FIT`]), less what it misses at [`RESOLVED_ELEMENTS`]; zero from
/// there on.
pub fn missing_fraction(elements: f64, c: f64) -> f64 {
    if elements >= RESOLVED_ELEMENTS {
        return 0.0;
    }
    let x = elements.max(0.0);
    c / (x * x + c) - c / (RESOLVED_ELEMENTS * RESOLVED_ELEMENTS + c)
}

/// The lubrication resistance F_lub / W of a film of `gap` between surfaces of effective radius
/// `reduced_radius` (a* = a_i a_j/(a_i + a_j), a for a plane wall), viscosity `viscosity`.
pub fn film_resistance(viscosity: f64, reduced_radius: f64, gap: f64) -> f64 {
    let g = gap.max(MIN_GAP * reduced_radius);
    3.0 * std::f64::consts::SQRT_2
        * std::f64::consts::PI
        * viscosity
        * (reduced_radius / g).powf(1.5)
}

/// One film the mesh does not resolve.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Film {
    /// The particle on the near side.
    pub first: usize,
    /// The particle on the far side, `None` for a wall.
    pub second: Option<usize>,
    /// Unit normal from `first` towards `second` (or the wall).
    pub normal: [f64; 2],
    /// Added resistance R (force per relative normal speed).
    pub resistance: f64,
}

impl Film {
    /// The correction's force on `first` at rigid velocities `rigid` ([U_x, U_y, ω] per
    /// particle); the force on `second` is its opposite.
    pub fn force_on_first(&self, rigid: &[[f64; 3]]) -> [f64; 2] {
        let u = rigid[self.first];
        let v = self.second.map_or([0.0; 3], |j| rigid[j]);
        let w = (u[0] - v[0]) * self.normal[0] + (u[1] - v[1]) * self.normal[1];
        [
            -self.resistance * w * self.normal[0],
            -self.resistance * w * self.normal[1],
        ]
    }
}

/// The films of `particles` on `mesh` with fewer than [`RESOLVED_ELEMENTS`] across, and their
/// added resistance under `lubrication`.
pub fn films(mesh: &Mesh, particles: &[Particle], lubrication: &Lubrication) -> Vec<Film> {
    let centres: Vec<[f64; 2]> = particles.iter().map(|p| p.center).collect();
    let radii: Vec<f64> = particles.iter().map(|p| p.radius).collect();
    gaps(mesh, &centres, &radii)
        .into_iter()
        .filter_map(|g| {
            let (first, second, reduced, fit) = match g.between {
                Between::Particles(i, j) => {
                    let (a, b) = (radii[i], radii[j]);
                    (i, Some(j), a * b / (a + b), PAIR_FILM_FIT)
                }
                Between::BottomWall(i) | Between::TopWall(i) if lubrication.walls => {
                    (i, None, radii[i], WALL_FILM_FIT)
                }
                _ => return None,
            };
            let fraction = missing_fraction(g.elements, fit);
            if fraction <= 0.0 {
                return None;
            }
            Some(Film {
                first,
                second,
                normal: g.normal,
                resistance: film_resistance(lubrication.viscosity, reduced, g.gap) * fraction,
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::Axis;
    use crate::solver::rigid::Motion;

    /// Round-off of a few operations.
    const EXACT: f64 = 1e-12;

    /// The scatter of the measured fraction at one x between meshes and offsets (module doc),
    /// which the fit of x alone leaves: pairs, walls.
    const FIT_SCATTER: [f64; 2] = [0.09, 0.05];

    /// The fit reproduces the measured fractions it was fitted to within [`FIT_SCATTER`], and
    /// the correction vanishes continuously at one element.
    #[test]
    fn the_missing_fraction_matches_the_measured_one_and_vanishes_when_resolved() {
        // (elements across, measured φ on h = 0.2a, 0.1a, 0.05a and both offsets),
        // docs/validation.md "Near-contact forces", F over the converged F at the same gap
        let measured = [
            (0.05, 0.175),
            (0.05, 0.190),
            (0.1, 0.387),
            (0.1, 0.410),
            (0.1, 0.425),
            (0.1, 0.466),
            (0.2, 0.744),
            (0.2, 0.783),
            (0.2, 0.805),
            (0.2, 0.852),
            (0.25, 0.779),
            (0.25, 0.798),
            (0.4, 0.968),
            (0.4, 0.978),
            (0.5, 0.950),
            (0.5, 0.958),
            (0.5, 0.973),
            (0.5, 0.980),
        ];
        // the wall's (h = 0.2a, 0.1a, 0.05a)
        let wall = [
            (0.05, 0.325),
            (0.1, 0.580),
            (0.1, 0.624),
            (0.2, 0.863),
            (0.2, 0.904),
            (0.25, 0.885),
            (0.4, 0.981),
            (0.5, 0.981),
            (0.5, 0.991),
        ];
        for (set, c, scatter) in [
            (&measured[..], PAIR_FILM_FIT, FIT_SCATTER[0]),
            (&wall[..], WALL_FILM_FIT, FIT_SCATTER[1]),
        ] {
            for &(x, phi) in set {
                let fit = x * x / (x * x + c);
                assert!(
                    (fit - phi).abs() <= scatter,
                    "c = {c}, x = {x}: fit {fit}, measured {phi}"
                );
            }
        }
        let c = PAIR_FILM_FIT;
        assert_eq!(missing_fraction(1.0, c), 0.0);
        assert_eq!(missing_fraction(3.0, c), 0.0);
        assert!(missing_fraction(1.0 - 1e-9, c) < 1e-9);
        assert!(missing_fraction(0.1, c) > missing_fraction(0.2, c));
    }

    /// Two particles 0.02 apart across columns of 0.1 (0.2 elements) and one 0.01 from the top
    /// wall of rows 0.25 (0.04 elements): their films, normals and resistances; nothing between
    /// particles further apart than an element.
    #[test]
    fn films_are_the_unresolved_gaps_with_their_normals() {
        let mesh = Mesh::rectangle(
            Axis::uniform(-1.0, 1.0, 20),
            Axis::uniform(-1.0, 1.0, 8),
            false,
        );
        let free = |center| Particle {
            center,
            radius: 0.2,
            motion: Motion::Free,
        };
        let particles = [free([-0.21, 0.0]), free([0.21, 0.0]), free([0.5, 0.79])];
        let lub = Lubrication {
            viscosity: 2.0,
            walls: true,
        };
        let films = films(&mesh, &particles, &lub);
        assert_eq!(films.len(), 2, "{films:?}");
        let pair = films[0];
        assert_eq!((pair.first, pair.second), (0, Some(1)));
        assert!((pair.normal[0] - 1.0).abs() < EXACT && pair.normal[1].abs() < EXACT);
        let expected = film_resistance(2.0, 0.1, 0.02) * missing_fraction(0.2, PAIR_FILM_FIT);
        assert!((pair.resistance - expected).abs() < EXACT * expected);
        let wall = films[1];
        assert_eq!((wall.first, wall.second), (2, None));
        assert!((wall.normal[1] - 1.0).abs() < EXACT);
        // approaching at W = 2: the force pushes the first particle back
        let f = pair.force_on_first(&[[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0], [0.0; 3]]);
        assert!((f[0] + 2.0 * pair.resistance).abs() < EXACT * pair.resistance);
        // without walls only the pair
        let no_walls = Lubrication {
            walls: false,
            ..lub
        };
        assert_eq!(super::films(&mesh, &particles, &no_walls).len(), 1);
    }
}
