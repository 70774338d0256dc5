//! Interpolation of the history (a Q1 vertex field) at the pre-images: the bilinear, biquadratic
//! or bicubic stencil ([`Remap`]) of a point on the structured mesh's vertex lattice.

use crate::fem::element::q1;
use crate::mesh::Mesh;

/// How the history fields are interpolated at the pre-images.
///
/// Each step interpolates the history once more, so the interpolation error accumulates like the
/// numerical diffusion of an upwind scheme: with bilinear weights and a rigid shift by a fraction
/// ξ = |d|/h of an element per step, the error after a time T is ≈ ½|U|hT(1 − ξ)|s″|, whose
/// Δt-dependent part −½U²TΔt|s″| is first order in Δt. A biquadratic 3×3 vertex stencil leaves
/// ≈ (1 − ξ²)|U|h²T|s‴|/6, whose Δt-dependent part is O(Δt²); a bicubic 4×4 stencil one more
/// power of h. Per remap the error is ∝ h^{p+1}, per unit time ∝ h^{p+1}/Δt when a particle
/// crosses a sizeable fraction of an element per step: then a smaller Δt makes it worse
/// (docs/validation.md, single particle §5.5). This type's default is the thesis' bilinear map
/// (the validations name theirs); cases default to bicubic (`config::HistoryRemap`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Remap {
    /// Bilinear on the element holding the pre-image (thesis §5.3.3).
    #[default]
    Bilinear,
    /// Biquadratic Lagrange interpolation on the 3×3 vertices around the nearest vertex (in the
    /// structured mesh's index space; one-sided at walls). Not monotone.
    Quadratic,
    /// Bicubic Lagrange interpolation on the 4×4 vertices around the element holding the
    /// pre-image (index space; one-sided at walls). Not monotone; error O(h⁴) per remap.
    Cubic,
}

/// Most vertices one interpolation of the history uses (the 4×4 bicubic stencil).
pub const STENCIL_LEN: usize = 16;

/// Interpolation of a vertex field at a point: up to [`STENCIL_LEN`] vertices and their weights
/// (the four vertices of the element with bilinear weights, a 3×3 vertex stencil with
/// biquadratic ones, a 4×4 one with bicubic ones; unused entries have weight 0).
pub type StencilWeights = ([usize; STENCIL_LEN], [f64; STENCIL_LEN]);

/// Interpolation weights of a vertex field at the physical point `x` (`None` outside the mesh):
/// a pre-image given by a map of its own (the free surface's vertical stretch).
pub fn stencil_at(mesh: &Mesh, x: [f64; 2], remap: Remap) -> Option<StencilWeights> {
    mesh.locate(x).map(|(e, xi)| stencil(mesh, e, xi, remap))
}

/// Interpolation weights of a vertex field at reference point `xi` of element `e`.
pub(super) fn stencil(mesh: &Mesh, e: usize, xi: [f64; 2], remap: Remap) -> StencilWeights {
    let mut out = ([0; STENCIL_LEN], [0.0; STENCIL_LEN]);
    let nx = mesh.dims().0;
    let (ex, ey) = (e % nx, e / nx);
    let x_axis = AxisStencil::new(&mesh.ax.vertices, ex, xi[0], mesh.periodic);
    let y_axis = AxisStencil::new(&mesh.ay.vertices, ey, xi[1], false);
    match remap {
        Remap::Bilinear => {
            out.0[..4].copy_from_slice(&mesh.element_vertices[e]);
            out.1[..4].copy_from_slice(&q1(xi).0);
            // unused entries repeat a valid vertex with weight 0
            out.0[4..].fill(mesh.element_vertices[e][0]);
        }
        Remap::Quadratic => tensor_stencil(mesh, x_axis.quadratic(), y_axis.quadratic(), &mut out),
        Remap::Cubic => tensor_stencil(mesh, x_axis.cubic(), y_axis.cubic(), &mut out),
    }
    out
}

/// Fills `out` with the N×N tensor stencil of 1-D stencils `(c, w)` along x and y: vertex
/// indices c − 1 … c + N − 2, weights w_a w_b.
fn tensor_stencil<const N: usize>(
    mesh: &Mesh,
    (ci, wi): (isize, [f64; N]),
    (cj, wj): (isize, [f64; N]),
    out: &mut StencilWeights,
) {
    for b in 0..N {
        for a in 0..N {
            let k = N * b + a;
            out.0[k] = vertex_at(mesh, ci + a as isize - 1, (cj + b as isize - 1) as usize);
            out.1[k] = wi[a] * wj[b];
        }
    }
}

/// A point on one axis of the mesh, at reference coordinate `xi` of element `ex`, and the 1-D
/// Lagrange stencils through the vertices around it. The weights use the vertices' coordinates
/// (unwrapped across a periodic seam), so that they are exact for polynomials of their degree on
/// graded axes too: weights in index space were exact only on uniform axes and, on a graded one,
/// put the point where the piecewise-linear inverse of the grading does, an O(h²) error per remap
/// whatever the stencil's order.
struct AxisStencil<'a> {
    vertices: &'a [f64],
    /// Element index along the axis.
    ex: usize,
    /// The point's position in index space (vertex i at i): picks the stencil's vertices.
    p: f64,
    /// The point's coordinate.
    x: f64,
    periodic: bool,
}

impl<'a> AxisStencil<'a> {
    fn new(vertices: &'a [f64], ex: usize, xi: f64, periodic: bool) -> Self {
        let t = 0.5 * (xi + 1.0);
        let x = vertices[ex] + t * (vertices[ex + 1] - vertices[ex]);
        AxisStencil {
            vertices,
            ex,
            p: ex as f64 + t,
            x,
            periodic,
        }
    }

    fn n(&self) -> usize {
        self.vertices.len() - 1
    }

    /// Coordinate of vertex `i` (any integer on a periodic axis, unwrapped by the period).
    fn coordinate(&self, i: isize) -> f64 {
        let n = self.n() as isize;
        let period = self.vertices[self.n()] - self.vertices[0];
        self.vertices[i.rem_euclid(n) as usize] + i.div_euclid(n) as f64 * period
    }

    /// Lagrange weights at the point of the N vertices first, first + 1, …
    fn weights<const N: usize>(&self, first: isize) -> [f64; N] {
        let z: [f64; N] = std::array::from_fn(|a| self.coordinate(first + a as isize));
        std::array::from_fn(|a| {
            (0..N)
                .filter(|&b| b != a)
                .map(|b| (self.x - z[b]) / (z[a] - z[b]))
                .product()
        })
    }

    /// Centre vertex index and quadratic weights (at centre − 1, centre, centre + 1); the stencil
    /// is shifted inward at the ends of a non-periodic axis.
    fn quadratic(&self) -> (isize, [f64; 3]) {
        let mut c = self.p.round() as isize;
        if !self.periodic && self.n() >= 2 {
            c = c.clamp(1, self.n() as isize - 1);
        }
        (c, self.weights(c - 1))
    }

    /// Base vertex index and cubic weights (at base − 1, base, base + 1, base + 2); the stencil is
    /// shifted inward at the ends of a non-periodic axis.
    fn cubic(&self) -> (isize, [f64; 4]) {
        let mut c = self.ex as isize;
        if !self.periodic && self.n() >= 3 {
            c = c.clamp(1, self.n() as isize - 2);
        }
        (c, self.weights(c - 1))
    }
}

/// Q1 vertex id at logical vertex position (i, j) (i wrapped on a periodic axis).
pub(super) fn vertex_at(mesh: &Mesh, i: isize, j: usize) -> usize {
    let (nx, ny) = mesh.dims();
    let i = if mesh.periodic {
        i.rem_euclid(nx as isize) as usize
    } else {
        i as usize
    };
    let (ex, ey) = (i.min(nx - 1), j.min(ny - 1));
    mesh.element_vertices[ey * nx + ex][(i - ex) + 2 * (j - ey)]
}
