//! From particle positions to per-element integration data for the flow and stress solvers:
//! classification (fluid / cut / inside), fluid-part quadrature and particle-boundary quadrature
//! of every element (thesis §2.3.2, §5.3.2), using the `xfem` geometry.

use crate::mesh::Mesh;
use crate::solver::rigid::{
    BoundaryPoint, CutQuadrature as CutData, ElementCut, Particle, ParticleCut,
};
use crate::xfem::{
    CellLocation, Circle, CircleUnion, CutOptions, CutQuadrature, InterfaceOptions, InterfacePoint,
    InterfaceQuadrature, Q2Element, XfemError,
};

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

/// Classifies every element of `mesh` against the particles and builds the fluid-part and
/// boundary quadrature of the cut ones.
pub fn compute_cuts(
    mesh: &Mesh,
    particles: &[Particle],
    period_x: Option<f64>,
    opts: CutOptions,
) -> Result<Vec<ElementCut>, CutError> {
    if particles.is_empty() {
        return Ok(vec![ElementCut::Fluid; mesh.n_elements()]);
    }
    let ls = level_set(particles, period_x)?;
    let mut cq = CutQuadrature::new(opts)?;
    let mut iq = InterfaceQuadrature::new(InterfaceOptions::default())?;
    let mut pts: Vec<InterfacePoint> = Vec::new();
    let mut out = Vec::with_capacity(mesh.n_elements());
    for e in 0..mesh.n_elements() {
        let map = Q2Element {
            nodes: mesh.element_coords[e],
        };
        out.push(match cq.classify(&map, &ls) {
            CellLocation::Fluid => ElementCut::Fluid,
            CellLocation::Particle => ElementCut::Inside,
            CellLocation::Cut(cell) => {
                pts.clear();
                iq.points_into(&map, &ls, &mut pts)?;
                let vol = cell
                    .rule
                    .points
                    .iter()
                    .copied()
                    .zip(cell.rule.weights.iter().copied())
                    .collect();
                ElementCut::Cut(CutData {
                    vol,
                    particles: group_by_image(&pts),
                })
            }
        });
    }
    Ok(out)
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
