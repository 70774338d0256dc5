"""The film between the two closest particles, zoomed, with the mesh (issue 25): `film_zoom`.

One panel per case with field snapshots and at least two particles (up to MAX_CASES, two columns): its
last snapshot around the midpoint of its narrowest gap, ±WINDOW_X radii along the line of centres' x and
±WINDOW_Y across, filled contours of tr τ (one colour scale for the page), the elements of the snapshot
(the Q2 nodes' sub-quads: two per element and direction) and the particles at their sampled positions.
What it is for: whether the film a string's particles hold between them is resolved by the mesh — a fixed
mesh's film is a fraction of an element across, a mesh with `numerics.follow.films` has that many
elements — and what the polymer's stress does in it.

Inputs: as field_snapshots (snapshots ⋈ cases, HDF5 /step_<n> groups, samples for the positions).
Usage: python plotting/film_zoom.py DB [OUT_DIR]
"""

from __future__ import annotations

import matplotlib.pyplot as plt
import matplotlib.tri as mtri
import numpy as np
from matplotlib.collections import PolyCollection
from matplotlib.patches import Circle

import figlib as fl
from field_snapshots import open_snapshots, particle_positions, read_snapshot, resolve

NAME = "film_zoom"
#: Cases drawn (one panel each); the rest are listed in the log.
MAX_CASES = 8
#: Half-widths of the window around the gap's midpoint, in radii (along x, along y).
WINDOW_X = 0.35
WINDOW_Y = 0.5


def narrowest_pair(points: list[tuple[float, float]], a: float, period: float | None):
    """(midpoint, gap) of the closest two particles (nearest periodic image along x), or None."""
    best = None
    for i, p in enumerate(points):
        for q in points[i + 1:]:
            dx = q[0] - p[0]
            if period:
                dx -= period * round(dx / period)
            dy = q[1] - p[1]
            gap = np.hypot(dx, dy) - 2.0 * a
            if best is None or gap < best[1]:
                best = ((p[0] + 0.5 * dx, p[1] + 0.5 * dy), gap)
    return best


def last_snapshot(f: fl.Figures, path: str):
    opened = open_snapshots(f, path, NAME)
    if opened is None:
        return None
    h5, groups = opened
    with h5:
        return read_snapshot(h5, groups[-1]) if groups else None


def main(f: fl.Figures) -> None:
    rows = f.con.execute("SELECT case_id, MIN(file) FROM snapshots GROUP BY case_id ORDER BY case_id").fetchall()
    by_id = {c.id: c for c in f.cases()}
    panels = []
    for case_id, recorded in rows:
        c = by_id.get(case_id)
        if c is None or (c.n or 0) < 2 or not c.a:
            continue
        if len(panels) >= MAX_CASES:
            f.log(f"{NAME}: only the first {MAX_CASES} cases with snapshots are drawn")
            break
        path = resolve(f, c, recorded)
        snap = last_snapshot(f, path) if path else None
        if snap is None:
            f.log(f"{NAME}: no readable snapshot of case {c.hash}; skipped")
            continue
        points = particle_positions(f, c, snap[5])
        period = c.geo().get("l") if c.geometry == "confined_shear" else None
        pair = narrowest_pair(points, c.a, period)
        if pair is not None:
            panels.append((c, snap, points, pair))
    if not panels:
        f.log(f"{NAME}: skipped: no case with field snapshots and two or more particles")
        return
    cols = min(2, len(panels))
    nrows = (len(panels) + cols - 1) // cols
    fig, axes = plt.subplots(nrows, cols, figsize=(4.6 * cols, 6.0 * nrows + 0.8), squeeze=False,
                             layout="constrained")
    inside = []
    for c, (coords, quads, field, values, level, t), points, ((mx, my), gap) in panels:
        near = (np.abs(coords[:, 0] - mx) < WINDOW_X * c.a) & (np.abs(coords[:, 1] - my) < WINDOW_Y * c.a)
        if values is not None:
            fluid = near & (level > 0) if level is not None else near
            inside.append(values[fluid])
    vals = np.concatenate(inside) if inside else np.array([])
    levels = None
    if vals.size and np.isfinite(vals).any():
        lo, hi = np.nanpercentile(vals, [1.0, 99.0])
        levels = np.linspace(lo, hi if hi > lo else lo + 1.0, 21)
    mappable = None
    for ax, (c, (coords, quads, field, values, level, t), points, ((mx, my), gap)) in zip(axes.flat, panels):
        a = c.a
        x0, x1, y0, y1 = mx - WINDOW_X * a, mx + WINDOW_X * a, my - WINDOW_Y * a, my + WINDOW_Y * a
        centre = coords[quads].mean(axis=1)
        keep = (centre[:, 0] > x0 - a) & (centre[:, 0] < x1 + a) & (centre[:, 1] > y0 - a) & (centre[:, 1] < y1 + a)
        q = quads[keep]
        if values is not None and levels is not None and len(q):
            tris = np.concatenate([q[:, [0, 1, 2]], q[:, [0, 2, 3]]])
            tri = mtri.Triangulation(coords[:, 0], coords[:, 1], tris)
            mappable = ax.tricontourf(tri, values, levels=levels, cmap="viridis", extend="both")
        ax.add_collection(PolyCollection(coords[q], facecolors="none", edgecolors="0.1", linewidths=0.3,
                                         alpha=0.7, zorder=3))
        period = c.geo().get("l") if c.geometry == "confined_shear" else None
        for x, y in points:
            if period:
                x -= period * round((x - mx) / period)
            ax.add_patch(Circle((x, y), a, fc="white", ec="black", lw=1.0, zorder=5))
        ax.set_xlim(x0, x1)
        ax.set_ylim(y0, y1)
        ax.set_aspect("equal")
        ax.set_title(f"{c.label}\nt* = {t * c.rate:.4g}, gap {gap / a:.4f}a ({fl.kind_text(c)})", fontsize=8)
        ax.tick_params(labelsize=7)
    for ax in list(axes.flat)[len(panels):]:
        ax.axis("off")
    if mappable is not None:
        fig.colorbar(mappable, ax=axes.ravel().tolist(), label="tr τ", shrink=0.8)
    fig.suptitle("The narrowest film at the last snapshot, with the mesh (sub-quads of the Q2 elements)",
                 fontsize=10)
    f.save(fig, NAME)


if __name__ == "__main__":
    import make_figures

    make_figures.run_one(main)
