//! Each particle's reach: the elements coupled to its rigid-body unknowns in the flow matrix's
//! pattern, so that the pattern, its symbolic factorization and the band's placement outlive the
//! particle's moves; and the band around a free surface.
//!
//! A reach is a disc of the particle's radius plus [`RIGID_REACH`] element sizes around its
//! centre, stretched along the particle's drift across the mesh (in element indices, so that a
//! mesh that follows its particle sees none): where a particle moved fast through the mesh
//! while the last pattern lasted (a particle orbiting in a Couette cell's frame, one carried
//! through a die, particles approaching from rest), the next reach extends ahead of it by what
//! it travels in [`LASTING_STEPS`] steps at that rate (at most [`MAX_AHEAD_RADII`] radii), so
//! that a pattern and its placement last about that many steps instead of the two elements' worth
//! of travel a disc allows. A slow particle (a string) keeps its disc. A reach stretched for a
//! drift that has since slowed down is renewed ([`Reach::outlived`]).

use crate::fem::element::q2_map;
use crate::mesh::dilate;
use crate::mesh::{bounding_box, Mesh, Shape};
use crate::periodic::{fold, nearest_image};
use crate::solver::rigid::{ElementCut, Particle};

/// How far beyond its boundary, in sizes of the element concerned, a particle's rigid-body
/// unknowns are coupled in the matrix pattern. A particle can move about this far (beyond its
/// drift's stretch) before an element it cuts lies outside the coupled set and the pattern and
/// its symbolic factorization must be rebuilt; the unused couplings store zeros.
const RIGID_REACH: f64 = 2.0;

/// Steps a pattern is to last: a reach extends ahead of its particle by the particle's drift
/// over the last pattern's life, per step, times this. A placement of the band costs 10–40
/// steps of M's factorization (90×480 Couette cell, one particle: 1.6 s against 0.018 s;
/// a/16, three particles: ≈ 4 s against 0.22 s), while a reach stretched by s element sizes
/// grows M's Γ by about 10 s dofs: lasting 16 steps, a placement costs at most about as much
/// per step as M.
const LASTING_STEPS: f64 = 16.0;

/// Longest stretch of a reach ahead of its particle, in radii: beyond it the band grows more
/// than the placements it saves (its area by about (2 + 2·RIGID_REACH·h/a) radii² per radius of
/// stretch).
const MAX_AHEAD_RADII: f64 = 1.0;

/// How far beyond the elements a free surface cuts (cut elements without particle pieces) the
/// pattern couples the ghost-penalty patches and the matrix is assembled every step, in elements:
/// the surface can move about this far before the pattern is rebuilt.
const SURFACE_REACH: usize = 2;

/// Where the flow matrix may change while a pattern lasts: each particle's reach (the elements
/// coupled to its rigid-body unknowns) and the band around a free surface. Elements outside it
/// are fluid and assembled from the cached base; the ghost-penalty patches of faces next to it
/// are in the pattern.
#[derive(Debug, Clone)]
pub(super) struct Reach {
    /// Per particle, the elements coupled to its rigid-body unknowns.
    pub particles: Vec<Vec<bool>>,
    /// The elements within [`SURFACE_REACH`] of an element cut by a free surface.
    pub surface: Vec<bool>,
    /// Per particle, how far ahead of the centre the reach is stretched (zero: a disc).
    pub ahead: Vec<[f64; 2]>,
    /// Where the particles' centres lay across the mesh ([`across`]) when the reach was made,
    /// or when [`Reach::outlived`] last looked at their drift: the start of the window the drift
    /// is measured over (empty: forgotten).
    start: Vec<Option<[f64; 2]>>,
    /// Particle moves ([`Reach::moved`]) in the drift's window.
    age: usize,
}

impl Reach {
    /// Whether element `e` may be cut while the pattern lasts.
    pub fn contains(&self, e: usize) -> bool {
        self.surface[e] || self.particles.iter().any(|r| r[e])
    }

    /// Whether every cut element lies in the reach of what cuts it.
    pub fn covers(&self, cuts: &[ElementCut]) -> bool {
        cuts.iter().enumerate().all(|(e, c)| match c {
            ElementCut::Cut(c) if c.particles.is_empty() => self.surface[e],
            ElementCut::Cut(c) => c.particles.iter().all(|pc| self.particles[pc.particle][e]),
            _ => true,
        })
    }

    /// Whether the pattern couples the two elements of the face between `e` and `o` for the
    /// ghost penalty: faces next to an element in the reach (only those can be cut while the
    /// pattern lasts). The pattern and the nested-dissection ordering must agree on this.
    pub fn patched_face(&self, e: usize, o: usize) -> bool {
        self.contains(e) || self.contains(o)
    }

    /// Counts one move of the particles (a time step) in the reach's age.
    pub fn moved(&mut self) {
        self.age += 1;
    }

    /// Forgets where the particles were: the next move is a jump (a state restored into the
    /// solver), not a drift, and the reach renewed for it is not stretched.
    pub fn forget(&mut self) {
        self.start.clear();
        self.age = 0;
    }

    /// Whether the reach was stretched for a drift that has slowed down: every
    /// 4 × [`LASTING_STEPS`] moves, whether the drift over them would make a stretch of more
    /// than a quarter radius less than half as long. Renewing the reach (a new pattern and
    /// placement) shrinks the band that M factors every step. Starts the next window.
    pub fn outlived(&mut self, mesh: &Mesh, particles: &[Particle]) -> bool {
        if (self.age as f64) < 4.0 * LASTING_STEPS || self.start.len() != particles.len() {
            return false;
        }
        let now = self.drifts(mesh, particles);
        let slowed = particles.iter().enumerate().any(|(i, p)| {
            let (was, will) = (norm(self.ahead[i]), norm(now[i]));
            was > 0.25 * p.radius && will < 0.5 * was
        });
        if !slowed {
            self.start = starts(mesh, particles);
            self.age = 0;
        }
        slowed
    }

    /// The reach for `particles` cut as `cuts`, stretched along each particle's drift over
    /// this reach's window (since it was made, or over the last 4 × [`LASTING_STEPS`] moves;
    /// [`reach_for`]).
    pub fn renewed(&self, mesh: &Mesh, particles: &[Particle], cuts: &[ElementCut]) -> Reach {
        let ahead = if self.start.len() == particles.len() {
            self.drifts(mesh, particles)
        } else {
            vec![[0.0; 2]; particles.len()]
        };
        reach_for(mesh, particles, cuts, ahead)
    }

    /// Per particle, its displacement across the mesh over the window (in element indices, taken
    /// to a length by the element map at its centre now), per move, times [`LASTING_STEPS`], at
    /// most [`MAX_AHEAD_RADII`] radii long; zero where it was or is outside the mesh.
    fn drifts(&self, mesh: &Mesh, particles: &[Particle]) -> Vec<[f64; 2]> {
        let per_move = LASTING_STEPS / self.age.max(1) as f64;
        let period = mesh.periodic.then_some(mesh.dims().0 as f64);
        particles
            .iter()
            .zip(&self.start)
            .map(|(p, then)| {
                let (Some(then), Some((now, to_length))) = (then, across(mesh, p.center)) else {
                    return [0.0; 2];
                };
                let d = [fold(now[0] - then[0], period), now[1] - then[1]];
                let j = to_length;
                let d = [
                    per_move * (j[0][0] * d[0] + j[0][1] * d[1]),
                    per_move * (j[1][0] * d[0] + j[1][1] * d[1]),
                ];
                let (len, max) = (norm(d), MAX_AHEAD_RADII * p.radius);
                if len > max {
                    [d[0] * max / len, d[1] * max / len]
                } else {
                    d
                }
            })
            .collect()
    }

    /// Whether element `e`, inside a particle now, stays inside it wherever the particle goes
    /// along its stretch: all nine nodes also in the disc moved by [`Reach::ahead`] (the disc
    /// is convex). An element outside every stretched particle's disc stays as it is.
    pub fn stays_inside(&self, mesh: &Mesh, particles: &[Particle], e: usize) -> bool {
        let xe = &mesh.element_coords[e];
        let (lo, hi) = bounding_box(xe);
        let mid = [0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1])];
        particles.iter().zip(&self.ahead).all(|(p, a)| {
            let c = nearest_image(p.center, mid[0], period_of(mesh));
            if *a == [0.0; 2] || (mid[0] - c[0]).hypot(mid[1] - c[1]) > p.radius {
                return true;
            }
            let moved = [c[0] + a[0], c[1] + a[1]];
            xe.iter()
                .all(|x| (x[0] - moved[0]).hypot(x[1] - moved[1]) <= p.radius)
        })
    }
}

/// Where `c` lies across the mesh, in element indices, (e_x + (ξ_x + 1)/2, e_y + (ξ_y + 1)/2),
/// and the map from those indices to lengths there (the element map's Jacobian times two);
/// `None` outside the mesh.
fn across(mesh: &Mesh, c: [f64; 2]) -> Option<([f64; 2], [[f64; 2]; 2])> {
    let (e, xi) = mesh.locate(c)?;
    let nx = mesh.dims().0;
    let at = [
        (e % nx) as f64 + 0.5 * (xi[0] + 1.0),
        (e / nx) as f64 + 0.5 * (xi[1] + 1.0),
    ];
    let (_, j, _) = q2_map(&mesh.element_coords[e], xi);
    Some((at, j.map(|row| row.map(|v| 2.0 * v))))
}

/// Where each particle lies across the mesh ([`across`]).
fn starts(mesh: &Mesh, particles: &[Particle]) -> Vec<Option<[f64; 2]>> {
    particles
        .iter()
        .map(|p| across(mesh, p.center).map(|(at, _)| at))
        .collect()
}

fn norm(v: [f64; 2]) -> f64 {
    v[0].hypot(v[1])
}

/// The x-period of a periodic rectangle.
fn period_of(mesh: &Mesh) -> Option<f64> {
    (mesh.periodic && mesh.shape == Shape::Rectangle)
        .then(|| mesh.ax.vertices[mesh.ax.len()] - mesh.ax.vertices[0])
}

/// Distance from the point `q` to the segment from `a` to `b`.
fn to_segment(q: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    let (d, w) = ([b[0] - a[0], b[1] - a[1]], [q[0] - a[0], q[1] - a[1]]);
    let dd = d[0] * d[0] + d[1] * d[1];
    let s = if dd > 0.0 {
        ((w[0] * d[0] + w[1] * d[1]) / dd).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (w[0] - s * d[0]).hypot(w[1] - s * d[1])
}

/// Per particle, the elements whose velocity and pressure the pattern couples to its rigid-body
/// unknowns: bounding box within the radius plus [`RIGID_REACH`] element sizes of the segment
/// from the centre to the centre moved by `ahead` (nearest periodic image on a periodic
/// rectangle). The distance of a box to the segment is taken as the smaller of its endpoints' to
/// the box and the box corners' to the segment: exact unless they cross, and then at most half
/// the box's diagonal, within the reach anyway.
fn rigid_reach(mesh: &Mesh, particles: &[Particle], ahead: &[[f64; 2]]) -> Vec<Vec<bool>> {
    let period = period_of(mesh);
    particles
        .iter()
        .zip(ahead)
        .map(|(p, a)| {
            mesh.element_coords
                .iter()
                .map(|xe| {
                    let (lo, hi) = bounding_box(xe);
                    let size = (hi[0] - lo[0]).max(hi[1] - lo[1]);
                    let c = nearest_image(p.center, 0.5 * (lo[0] + hi[0]), period);
                    let end = [c[0] + a[0], c[1] + a[1]];
                    let to_box = |q: [f64; 2]| {
                        let b = [q[0].clamp(lo[0], hi[0]), q[1].clamp(lo[1], hi[1])];
                        (b[0] - q[0]).hypot(b[1] - q[1])
                    };
                    let mut dist = to_box(c).min(to_box(end));
                    if *a != [0.0; 2] {
                        for corner in [lo, [hi[0], lo[1]], hi, [lo[0], hi[1]]] {
                            dist = dist.min(to_segment(corner, c, end));
                        }
                    }
                    dist <= p.radius + RIGID_REACH * size
                })
                .collect()
        })
        .collect()
}

/// The [`Reach`] of the particles and surface cuts: [`rigid_reach`] of the particles stretched
/// by `ahead`, or every element for every particle if that does not cover `cuts` (cuts not of
/// these positions: a caller's choice); the elements `cuts` has cut by a free surface, widened by
/// [`SURFACE_REACH`].
pub(super) fn reach_for(
    mesh: &Mesh,
    particles: &[Particle],
    cuts: &[ElementCut],
    ahead: Vec<[f64; 2]>,
) -> Reach {
    let surface_cut: Vec<bool> = cuts
        .iter()
        .map(|c| matches!(c, ElementCut::Cut(c) if c.particles.is_empty()))
        .collect();
    let surface = dilate(&surface_cut, mesh.dims(), mesh.periodic, SURFACE_REACH);
    let reach = Reach {
        particles: rigid_reach(mesh, particles, &ahead),
        surface,
        ahead,
        start: starts(mesh, particles),
        age: 0,
    };
    if reach.covers(cuts) {
        reach
    } else {
        Reach {
            particles: vec![vec![true; mesh.n_elements()]; particles.len()],
            ..reach
        }
    }
}
