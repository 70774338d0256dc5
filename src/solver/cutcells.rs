//! From particle positions to per-element integration data for the flow and stress solvers, by
//! the [`Discretization`] of the case (`numerics.method`), using the `xfem` geometry:
//!
//! - XFEM (thesis §2.3.2, §5.3.2): classification (fluid / cut / inside), fluid-part quadrature
//!   of the cut elements by the cut rule, elements inside a particle removed;
//! - the fictitious domain method (FDM, thesis §2.3.4): the particle interior is fluid, every
//!   element is integrated whole with the standard rule, nothing is removed, and the elements
//!   the particle circles cross carry their boundary pieces, on which the rigid-body motion is
//!   imposed by the same weak condition ([`crate::solver::rigid`]). The fields (velocity,
//!   pressure, G, the log-conformation and its projections) are then continuous into the
//!   particles, as the thesis describes FDM ("the field variables change continuously from the
//!   fluid domain to the rigid body").
//!
//! Every solver reads only the [`ElementCut`]s, so this is the one place where the two methods
//! differ.

use crate::fem::quadrature::gauss_quad;
use crate::mesh::Mesh;
use crate::solver::rigid::{
    BoundaryPoint, CutQuadrature as CutData, ElementCut, Particle, ParticleCut,
};
use crate::xfem::{
    CellLocation, Circle, CircleUnion, CutCell, CutOptions, CutQuadrature, InterfaceOptions,
    InterfacePoint, InterfaceQuadrature, LevelSet, Q2Element, RefMap, XfemError,
};

/// How the particles enter the discretization (`numerics.method`): the thesis' XFEM and the
/// fictitious domain method it is measured against (§2.3.4, Table 2.4).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Discretization {
    /// XFEM with this cut rule: cut elements integrated over their fluid part, elements inside
    /// particles removed (their dofs fixed at zero).
    Xfem(CutOptions),
    /// The fictitious domain method: the particle interior is fluid, every element integrated
    /// whole by the standard 3×3 Gauss rule, no dof removed.
    FictitiousDomain,
}

impl Default for Discretization {
    /// XFEM with the default cut rule.
    fn default() -> Self {
        Discretization::Xfem(CutOptions::default())
    }
}

impl From<CutOptions> for Discretization {
    /// XFEM with the cut rule `opts`.
    fn from(opts: CutOptions) -> Self {
        Discretization::Xfem(opts)
    }
}

/// Gauss points per direction of the whole-element rule of the fictitious domain method: that of
/// the solvers' uncut elements (the flow's and the transport's 3×3), so that an element crossed
/// by a particle boundary is integrated exactly as one that is not.
const WHOLE_ELEMENT_GAUSS: usize = 3;

/// Errors of the cut-cell computation.
#[derive(Debug, thiserror::Error)]
pub enum CutError {
    /// Invalid particle geometry or quadrature options.
    #[error("cut-cell geometry: {0}")]
    Geometry(#[from] XfemError),
}

/// The level set of the particles (union of circles, periodic in x with `period_x`).
pub fn level_set(particles: &[Particle], period_x: Option<f64>) -> Result<CircleUnion, CutError> {
    let circles = particles
        .iter()
        .map(|p| Circle {
            center: p.center,
            radius: p.radius,
        })
        .collect();
    Ok(CircleUnion::new(circles, period_x)?)
}

/// The integration data of every element of `mesh` for the particles: with
/// [`Discretization::Xfem`] each element is classified and the cut ones get their fluid-part and
/// boundary quadrature; with [`Discretization::FictitiousDomain`] the elements the particle
/// boundaries cross get the whole-element rule and their boundary quadrature, all others are
/// fluid.
pub fn compute_cuts(
    mesh: &Mesh,
    particles: &[Particle],
    period_x: Option<f64>,
    method: impl Into<Discretization>,
) -> Result<Vec<ElementCut>, CutError> {
    if particles.is_empty() {
        return Ok(vec![ElementCut::Fluid; mesh.n_elements()]);
    }
    let ls = level_set(particles, period_x)?;
    match method.into() {
        Discretization::Xfem(opts) => xfem_cuts(mesh, &ls, opts),
        Discretization::FictitiousDomain => fictitious_domain_cuts(mesh, &ls),
    }
}

/// [`compute_cuts`] for particles in a fluid bounded also by the zero level of `bound` (a free
/// surface, [`crate::solver::free_surface::SurfaceLevelSet`]; `None`: [`compute_cuts`]): the fluid
/// is where both level sets are positive, cut elements get the fluid-part quadrature of that
/// intersection and the particle boundary pieces that lie in it; the surface has no boundary
/// terms (traction-free). XFEM only: the fictitious domain method's particles keep their
/// interior, which a surface cannot bound.
///
/// # Panics
/// With [`Discretization::FictitiousDomain`] and a `bound` (the case validation refuses it).
pub fn compute_cuts_bounded(
    mesh: &Mesh,
    particles: &[Particle],
    period_x: Option<f64>,
    method: impl Into<Discretization>,
    bound: Option<&dyn LevelSet>,
) -> Result<Vec<ElementCut>, CutError> {
    let method = method.into();
    let Some(bound) = bound else {
        return compute_cuts(mesh, particles, period_x, method);
    };
    let Discretization::Xfem(opts) = method else {
        panic!("a free surface is cut by XFEM only");
    };
    if particles.is_empty() {
        return surface_cuts(mesh, bound, opts);
    }
    let ls = level_set(particles, period_x)?;
    let both = Intersection {
        particles: &ls,
        bound,
    };
    let mut cq = CutQuadrature::new(opts)?;
    let mut iq = InterfaceQuadrature::new(InterfaceOptions::default())?;
    let mut pts: Vec<InterfacePoint> = Vec::new();
    let mut out = Vec::with_capacity(mesh.n_elements());
    for e in 0..mesh.n_elements() {
        let map = Q2Element {
            nodes: mesh.element_coords[e],
        };
        out.push(match cq.classify(&map, &both) {
            CellLocation::Fluid => ElementCut::Fluid,
            CellLocation::Particle => ElementCut::Inside,
            CellLocation::Cut(cell) => {
                pts.clear();
                iq.points_into(&map, &ls, &mut pts)?;
                pts.retain(|p| bound.value(p.x) > 0.0);
                ElementCut::Cut(CutData {
                    vol: fluid_rule(&cell),
                    whole: false,
                    particles: group_by_image(&pts),
                })
            }
        });
    }
    Ok(out)
}

/// The fluid outside the particles and inside a bound: min(φ_particles, φ_bound), 1-Lipschitz
/// when both are.
struct Intersection<'a> {
    particles: &'a CircleUnion,
    bound: &'a dyn LevelSet,
}

impl LevelSet for Intersection<'_> {
    fn value(&self, x: [f64; 2]) -> f64 {
        self.particles.value(x).min(self.bound.value(x))
    }

    fn feature_size(&self, x: [f64; 2], reach: f64) -> f64 {
        self.particles
            .feature_size(x, reach)
            .min(self.bound.feature_size(x, reach))
    }

    fn nearest_particle(&self, x: [f64; 2]) -> Option<usize> {
        self.particles.nearest_particle(x)
    }
}

/// The fictitious domain method's elements: fluid, or whole with the boundary pieces of the
/// circles that cross them (the interface quadrature along the exact arcs, as for XFEM).
fn fictitious_domain_cuts(mesh: &Mesh, ls: &CircleUnion) -> Result<Vec<ElementCut>, CutError> {
    let whole: Vec<([f64; 2], f64)> = {
        let g = gauss_quad(WHOLE_ELEMENT_GAUSS);
        g.points.into_iter().zip(g.weights).collect()
    };
    let mut iq = InterfaceQuadrature::new(InterfaceOptions::default())?;
    let mut pts: Vec<InterfacePoint> = Vec::new();
    let mut out = Vec::with_capacity(mesh.n_elements());
    for e in 0..mesh.n_elements() {
        let map = Q2Element {
            nodes: mesh.element_coords[e],
        };
        // φ is 1-Lipschitz: no boundary within the element's image radius of its centre
        let reach = map.image_radius([-1.0, -1.0], [1.0, 1.0]);
        if ls.value(map.centre()).abs() >= reach {
            out.push(ElementCut::Fluid);
            continue;
        }
        pts.clear();
        iq.points_into(&map, ls, &mut pts)?;
        out.push(if pts.is_empty() {
            ElementCut::Fluid
        } else {
            ElementCut::Cut(CutData {
                vol: whole.clone(),
                whole: true,
                particles: group_by_image(&pts),
            })
        });
    }
    Ok(out)
}

/// XFEM's elements: classified by the cut rule `opts`, the cut ones with their fluid-part and
/// boundary quadrature.
fn xfem_cuts(mesh: &Mesh, ls: &CircleUnion, opts: CutOptions) -> Result<Vec<ElementCut>, CutError> {
    let mut cq = CutQuadrature::new(opts)?;
    let mut iq = InterfaceQuadrature::new(InterfaceOptions::default())?;
    let mut pts: Vec<InterfacePoint> = Vec::new();
    let mut out = Vec::with_capacity(mesh.n_elements());
    for e in 0..mesh.n_elements() {
        let map = Q2Element {
            nodes: mesh.element_coords[e],
        };
        out.push(match cq.classify(&map, ls) {
            CellLocation::Fluid => ElementCut::Fluid,
            CellLocation::Particle => ElementCut::Inside,
            CellLocation::Cut(cell) => {
                pts.clear();
                iq.points_into(&map, ls, &mut pts)?;
                ElementCut::Cut(CutData {
                    vol: fluid_rule(&cell),
                    whole: false,
                    particles: group_by_image(&pts),
                })
            }
        });
    }
    Ok(out)
}

/// The elements of `mesh` for a fluid bounded by the zero level of `ls` without boundary terms
/// (a stress-free surface: the traction condition is natural), by XFEM's cut rule `opts`:
/// fluid, cut (fluid-part quadrature, no particle pieces) or outside the fluid (removed). The
/// free surface of an extrudate (thesis §6.3.2: the level set ζ = H(x, t) − y, the same
/// quadtree and rules as for particles).
pub fn surface_cuts<L: LevelSet + ?Sized>(
    mesh: &Mesh,
    ls: &L,
    opts: CutOptions,
) -> Result<Vec<ElementCut>, CutError> {
    let mut cq = CutQuadrature::new(opts)?;
    Ok((0..mesh.n_elements())
        .map(|e| {
            let map = Q2Element {
                nodes: mesh.element_coords[e],
            };
            match cq.classify(&map, ls) {
                CellLocation::Fluid => ElementCut::Fluid,
                CellLocation::Particle => ElementCut::Inside,
                CellLocation::Cut(cell) => ElementCut::Cut(CutData {
                    vol: fluid_rule(&cell),
                    whole: false,
                    particles: Vec::new(),
                }),
            }
        })
        .collect())
}

/// The fluid-part quadrature of a cut element as (reference point, weight) pairs.
fn fluid_rule(cell: &CutCell) -> Vec<([f64; 2], f64)> {
    cell.rule
        .points
        .iter()
        .copied()
        .zip(cell.rule.weights.iter().copied())
        .collect()
}

/// Groups boundary points by particle and periodic image (centre = x − arm).
fn group_by_image(pts: &[InterfacePoint]) -> Vec<ParticleCut> {
    // Same-image test: centres of different images differ by a period, far above round-off.
    const SAME_IMAGE: f64 = 1e-9;
    let mut groups: Vec<ParticleCut> = Vec::new();
    for p in pts {
        let center = [p.x[0] - p.arm[0], p.x[1] - p.arm[1]];
        let bp = BoundaryPoint {
            xi: p.xi,
            x: p.x,
            w: p.weight,
            n: p.normal,
        };
        match groups.iter_mut().find(|g| {
            g.particle == p.particle
                && (g.center[0] - center[0]).abs() < SAME_IMAGE
                && (g.center[1] - center[1]).abs() < SAME_IMAGE
        }) {
            Some(g) => g.points.push(bp),
            None => groups.push(ParticleCut {
                particle: p.particle,
                center,
                points: vec![bp],
            }),
        }
    }
    groups
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::Axis;
    use crate::solver::rigid::Motion;

    /// The fictitious domain method's elements: nothing removed, the crossed ones whole with
    /// the whole circle on them, the same boundary quadrature as XFEM's where both see it.
    #[test]
    fn the_fictitious_domain_integrates_every_element_whole() {
        // the arcs partition the circle: its length to round-off (interface quadrature)
        const ARC_ROUND_OFF: f64 = 1e-12;
        let mesh = Mesh::rectangle(
            Axis::uniform(-1.0, 1.0, 20),
            Axis::uniform(-1.0, 1.0, 20),
            false,
        );
        let particle = Particle {
            center: [0.013, -0.021],
            radius: 0.37,
            motion: Motion::Free,
        };
        let fdm = compute_cuts(&mesh, &[particle], None, Discretization::FictitiousDomain).unwrap();
        let xfem = compute_cuts(&mesh, &[particle], None, Discretization::default()).unwrap();
        let mut length = 0.0;
        for (f, x) in fdm.iter().zip(&xfem) {
            match (f, x) {
                (ElementCut::Inside, _) => panic!("the fictitious domain removes no element"),
                (ElementCut::Cut(c), _) => {
                    assert!(c.whole && c.vol.len() == WHOLE_ELEMENT_GAUSS.pow(2));
                    length += c.particles[0].points.iter().map(|p| p.w).sum::<f64>();
                }
                (ElementCut::Fluid, _) => {}
            }
            if let (ElementCut::Cut(c), ElementCut::Cut(xc)) = (f, x) {
                assert!(!xc.whole);
                assert_eq!(c.particles, xc.particles, "the same boundary quadrature");
            }
        }
        let circumference = 2.0 * std::f64::consts::PI * particle.radius;
        assert!((length - circumference).abs() < ARC_ROUND_OFF * circumference);
        assert!(xfem.iter().any(|c| matches!(c, ElementCut::Inside)));
    }

    /// A particle poking through a bound y < 1: the fluid is the box below the bound less the
    /// disc's part below it, and the particle's boundary pieces are its arc below the bound.
    #[test]
    fn a_bound_cuts_the_fluid_and_the_particle_boundary() {
        // the cut rule's area error on this mesh (parabolic chords, default level): measured
        // ≤ 1e-6 of the area; the arcs are exact to round-off
        const AREA_TOL: f64 = 1e-5;
        const ARC_TOL: f64 = 1e-10;
        struct Below(f64);
        impl LevelSet for Below {
            fn value(&self, x: [f64; 2]) -> f64 {
                self.0 - x[1]
            }
        }
        let mesh = Mesh::rectangle(
            Axis::uniform(0.0, 1.0, 10),
            Axis::uniform(0.0, 1.5, 15),
            false,
        );
        let (c, r) = ([0.43, 0.95], 0.15);
        let particle = Particle {
            center: c,
            radius: r,
            motion: Motion::Free,
        };
        let bound = Below(1.0);
        let cuts = compute_cuts_bounded(
            &mesh,
            &[particle],
            None,
            Discretization::default(),
            Some(&bound),
        )
        .unwrap();
        let (mut area, mut length) = (0.0, 0.0);
        for (e, cut) in cuts.iter().enumerate() {
            let map = Q2Element {
                nodes: mesh.element_coords[e],
            };
            let det = |xi: [f64; 2]| {
                let j = map.jacobian(xi);
                j[0][0] * j[1][1] - j[0][1] * j[1][0]
            };
            match cut {
                ElementCut::Fluid => area += 0.01,
                ElementCut::Cut(cd) => {
                    area += cd.vol.iter().map(|(xi, w)| w * det(*xi)).sum::<f64>();
                    for pc in &cd.particles {
                        length += pc.points.iter().map(|p| p.w).sum::<f64>();
                        assert!(pc.points.iter().all(|p| p.x[1] < 1.0));
                    }
                }
                ElementCut::Inside => {}
            }
        }
        // the disc's segment above y = 1 (height r − d, d = 1 − c_y) lies outside the fluid already
        let d: f64 = 1.0 - c[1];
        let half = (d / r).acos();
        let segment = r * r * (half - (d / r) * half.sin());
        let disc_below = std::f64::consts::PI * r * r - segment;
        let want = 1.0 - disc_below;
        assert!((area - want).abs() < AREA_TOL, "area {area} against {want}");
        let arc = r * (2.0 * std::f64::consts::PI - 2.0 * half);
        assert!((length - arc).abs() < ARC_TOL, "arc {length} against {arc}");
    }
}
