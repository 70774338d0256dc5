"""Contours of tr τ with the particles and the mesh from the HDF5 field snapshots (thesis Figs. 5.19, 5.21):
`field_snapshots` (one page per case with snapshots: `field_snapshots`, `field_snapshots_p2`, ...).

Each page shows up to four snapshots of one case, evenly spread over its recorded times, stacked: filled
contours of tr τ (one colour scale per page), the mesh (Q1 vertices of the elements, thin lines), the
particles as circles of radius a at their sampled positions (nearest sample in time) and the zero level set
(dashed) when the file has one. Skipped, with a message, when the database records no snapshot or the
HDF5 file cannot be found (looked for at the recorded path, next to the database, in
`<db dir>/<sweep name>/` and in `<db dir>/<db name>/`, for a database renamed with its directory).

Inputs: snapshots (case_id, step, t, file) ⋈ cases; HDF5 groups /step_<n> with coords, quads, tr_tau,
level_set (src/store/snapshot.rs); samples (x, y) for the particle positions.
Usage: python plotting/field_snapshots.py DB [OUT_DIR]
"""

from __future__ import annotations

import os

import matplotlib.pyplot as plt
import matplotlib.tri as mtri
import numpy as np
from matplotlib.collections import PolyCollection
from matplotlib.patches import Circle

import figlib as fl

NAME = "field_snapshots"
#: Snapshots drawn per case.
PER_CASE = 4
#: Cases drawn (one page each); the rest are listed in the log.
MAX_CASES = 12
#: Meshes with more elements are drawn without element edges (they would be a grey fill).
MAX_MESH_EDGES = 40_000
FIELD = "tr_tau"


def resolve(f: fl.Figures, c: fl.Case, recorded: str) -> str | None:
    db_dir = os.path.dirname(os.path.abspath(f.db))
    base = os.path.basename(recorded)
    candidates = [recorded, os.path.join(db_dir, recorded), os.path.join(db_dir, base)]
    candidates += [os.path.join(db_dir, s.strip(), base) for s in c.sweeps.split(",") if s.strip()]
    # a database renamed together with its directory (results/NAME.db, results/NAME/)
    candidates.append(os.path.join(db_dir, os.path.splitext(os.path.basename(f.db))[0], base))
    return next((p for p in candidates if os.path.isfile(p)), None)


def particle_positions(f: fl.Figures, c: fl.Case, t: float) -> list[tuple[float, float]]:
    out = []
    for tr in f.samples(c).values():
        if len(tr.t) == 0:
            continue
        i = int(np.argmin(np.abs(tr.t - t)))
        if np.isfinite(tr.x[i]) and np.isfinite(tr.y[i]):
            out.append((tr.x[i], tr.y[i]))
    if not out and f.samples(c) == {}:
        out = c.initial_positions()
    return out


def read_snapshot(h5, group: str):
    g = h5[group]
    coords = np.asarray(g["coords"][()], dtype=float)
    quads = np.asarray(g["quads"][()], dtype=np.int64)
    names = [k for k in g.keys() if k not in ("coords", "quads")]
    field = FIELD if FIELD in g else next((k for k in names if g[k].ndim == 1 and k != "level_set"), None)
    values = np.asarray(g[field][()], dtype=float) if field else None
    level = np.asarray(g["level_set"][()], dtype=float) if "level_set" in g else None
    t = float(g.attrs["time"]) if "time" in g.attrs else float("nan")
    return coords, quads, field, values, level, t


def open_snapshots(f: fl.Figures, path: str, name: str):
    """The snapshot file at `path` and its step groups in order, or None (logged under `name`)."""
    import h5py

    # a running sweep holds the file open for writing: read without HDF5's file lock (figures of
    # a sweep in progress; a snapshot being written at that moment may fail to read)
    try:
        h5 = h5py.File(path, "r", locking=False)
    except OSError as e:
        f.log(f"{name}: {path} cannot be read now ({e}); skipped")
        return None
    return h5, sorted(k for k in h5.keys() if k.startswith("step_"))


def draw_case(f: fl.Figures, c: fl.Case, path: str, page: str) -> bool:
    opened = open_snapshots(f, path, NAME)
    if opened is None:
        return False
    h5, groups = opened
    with h5:
        if not groups:
            f.log(f"{NAME}: {path} has no step_* groups")
            return False
        pick = [groups[i] for i in sorted({round(x) for x in np.linspace(0, len(groups) - 1, min(PER_CASE, len(groups)))})]
        snaps = [read_snapshot(h5, g) for g in pick]
    fields = {s[2] for s in snaps}
    # Colour range from fluid nodes only (level set > 0) and the 1st-99th percentiles: nodes of
    # cut elements with tiny fluid parts can carry large pressure values that would flatten the
    # rest of the picture.
    fluid_vals = [s[3][s[4] > 0] if s[4] is not None else s[3] for s in snaps if s[3] is not None]
    vals = np.concatenate(fluid_vals) if fluid_vals else None
    if vals is not None and vals.size and np.isfinite(vals).any():
        lo_p, hi_p = np.nanpercentile(vals, [1.0, 99.0])
        vals = np.array([lo_p, hi_p])
    span = np.ptp(snaps[0][0], axis=0)
    aspect = span[1] / span[0] if span[0] > 0 else 1.0
    width = 10.0
    fig, axes = plt.subplots(len(snaps), 1, figsize=(width, max(1.6, width * aspect) * len(snaps) + 1.2),
                             squeeze=False, layout="constrained")
    levels = None
    if vals is not None and np.isfinite(vals).any():
        lo, hi = np.nanmin(vals), np.nanmax(vals)
        levels = np.linspace(lo, hi if hi > lo else lo + 1.0, 21)
    mappable = None
    for ax, (coords, quads, field, values, level, t), group in zip(axes[:, 0], snaps, pick):
        tris = np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]])
        tri = mtri.Triangulation(coords[:, 0], coords[:, 1], tris)
        if values is not None and levels is not None:
            mappable = ax.tricontourf(tri, values, levels=levels, cmap="viridis", extend="both")
        if len(quads) <= MAX_MESH_EDGES:
            ax.add_collection(PolyCollection(coords[quads], facecolors="none", edgecolors="0.15", linewidths=0.4,
                                             alpha=0.6, zorder=3))
        if level is not None and np.nanmin(level) < 0 < np.nanmax(level):
            ax.tricontour(tri, level, levels=[0.0], colors="white", linestyles="--", linewidths=0.9)
        for x, y in particle_positions(f, c, t):
            ax.add_patch(Circle((x, y), c.a or 0.0, fc="white", ec="black", lw=1.0, zorder=5))
        ax.set_aspect("equal")
        ax.set_xlim(coords[:, 0].min(), coords[:, 0].max())
        ax.set_ylim(coords[:, 1].min(), coords[:, 1].max())
        ax.set_title(f"t* = {t * c.rate:.4g}  ({group}, {len(quads)} elements)", fontsize=9)
        ax.set_xlabel("x")
        ax.set_ylabel("y")
    if mappable is not None:
        fig.colorbar(mappable, ax=axes[:, 0].tolist(), label=" / ".join(sorted(str(x) for x in fields)),
                     shrink=0.9)
    params = fl.describe({"wi": c.wi, "alpha": c.alpha, "beta": c.beta, "h": c.h, "a": c.a, "n": c.n,
                          "delta": c.delta, "eps": c.eps, "r0": c.r0})
    what = "tr τ" if fields == {FIELD} else f"{', '.join(str(x) for x in fields)} (no tr_tau in the file)"
    fig.suptitle(f"Contours of {what} with particles and mesh — {c.geometry.replace('_', ' ')}, "
                 f"{c.layout_text()}\n{params} ({fl.kind_text(c)}; case {c.hash})", fontsize=10)
    f.save(fig, page)
    return True


def main(f: fl.Figures) -> None:
    rows = f.con.execute("SELECT case_id, MIN(file) FROM snapshots GROUP BY case_id ORDER BY case_id").fetchall()
    if not rows:
        f.log(f"{NAME}: skipped: no field snapshots in the database (set output.snapshot_every in the sweep file)")
        return
    by_id = {c.id: c for c in f.cases()}
    drawn = 0
    for case_id, recorded in rows:
        c = by_id.get(case_id)
        if c is None:
            continue
        if drawn >= MAX_CASES:
            f.log(f"{NAME}: only the first {MAX_CASES} of {len(rows)} cases with snapshots are drawn")
            break
        path = resolve(f, c, recorded)
        if path is None:
            f.log(f"{NAME}: snapshot file of case {c.hash} not found ({recorded}); skipped")
            continue
        if draw_case(f, c, path, NAME if drawn == 0 else f"{NAME}_p{drawn + 1}"):
            drawn += 1
    if drawn == 0:
        f.log(f"{NAME}: skipped: none of the {len(rows)} snapshot files could be read")


if __name__ == "__main__":
    import make_figures

    make_figures.run_one(main)
