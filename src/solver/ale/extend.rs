//! Extension of a vertex field into the particles: the vertices that touch no fluid get values
//! extrapolated from the fluid side, so that the history interpolated near a particle is smooth.

use super::stencil::vertex_at;
use crate::mesh::{Mesh, Shape};

/// Layers of vertices inside particles that [`extend_inside`] fills. A vertex active at the new
/// configuration lies at most √2 h inside a particle (it belongs to a cut element); its
/// pre-image keeps that position relative to the particle (rigid patch), so the element holding
/// it has its vertices at most 2√2 h inside: two layers past the active ones, a third for
/// stretched cells, a fourth for the bicubic stencil (one vertex further out).
pub const EXTENSION_LAYERS: usize = 4;

/// Gives the vertices that touch no fluid element (`known[v] == false`: inside a particle)
/// values extrapolated from the fluid side, layer by layer, up to [`EXTENSION_LAYERS`] deep.
///
/// The history of a step is interpolated at pre-images that can fall in elements inside the
/// particle at tⁿ (a vertex that becomes active as the particle moves maps to the same place
/// relative to the old particle, which may be an inside element). Those vertices hold s = 0
/// (c = I) from the transport solve; interpolating them pollutes the fluid part of the new cut
/// element by an O(1) amount once per activation, an error that does not shrink with Δt. Each
/// new value is the linear extrapolation along a grid line from the two nearest known vertices
/// (mean over the directions that have two), or, without such a pair, the mean of the known
/// edge neighbours.
pub fn extend_inside<T>(mesh: &Mesh, known: &[bool], field: &mut [T])
where
    T: Copy + std::ops::Add<Output = T> + std::ops::Mul<f64, Output = T>,
{
    let (nx, ny) = mesh.dims();
    let cols = if mesh.periodic { nx } else { nx + 1 };
    let at = |i: isize, j: isize| -> Option<usize> {
        if j < 0 || j > ny as isize || (!mesh.periodic && (i < 0 || i >= cols as isize)) {
            return None;
        }
        Some(vertex_at(mesh, i, j as usize))
    };
    let x = |v: usize| mesh.nodes[mesh.node_of_vertex[v]];
    let dist = |a: usize, b: usize| {
        let (p, q) = (x(a), x(b));
        // periodic neighbours across the seam: the shorter way round
        let period = (mesh.periodic && mesh.shape == Shape::Rectangle)
            .then(|| mesh.ax.vertices[nx] - mesh.ax.vertices[0]);
        let dx = crate::periodic::fold(p[0] - q[0], period);
        dx.hypot(p[1] - q[1])
    };
    let mut known = known.to_vec();
    let mut fresh: Vec<(usize, T)> = Vec::new();
    for _ in 0..EXTENSION_LAYERS {
        fresh.clear();
        for j in 0..=ny as isize {
            for i in 0..cols as isize {
                let v = vertex_at(mesh, i, j as usize);
                if known[v] {
                    continue;
                }
                let (mut line, mut n_line) = (None::<T>, 0usize);
                let (mut near, mut n_near) = (None::<T>, 0usize);
                for (di, dj) in [(1, 0), (-1, 0), (0, 1), (0, -1)] {
                    let Some(a) = at(i + di, j + dj).filter(|&a| known[a]) else {
                        continue;
                    };
                    near = Some(near.map_or(field[a], |s| s + field[a]));
                    n_near += 1;
                    let Some(b) = at(i + 2 * di, j + 2 * dj).filter(|&b| known[b]) else {
                        continue;
                    };
                    let w = dist(v, a) / dist(a, b);
                    let e = field[a] * (1.0 + w) + field[b] * (-w);
                    line = Some(line.map_or(e, |s| s + e));
                    n_line += 1;
                }
                match (line, near) {
                    (Some(s), _) => fresh.push((v, s * (1.0 / n_line as f64))),
                    (None, Some(s)) => fresh.push((v, s * (1.0 / n_near as f64))),
                    _ => {}
                }
            }
        }
        if fresh.is_empty() {
            break;
        }
        for &(v, val) in &fresh {
            field[v] = val;
            known[v] = true;
        }
    }
}
