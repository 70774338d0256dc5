"""Particle trajectories in confined shear flow for families of initial positions (thesis Figs. 5.10, 5.13,
5.18, 5.20): `alignment_trajectories`.

One panel per set-up (model, Wi, α, β, H, a, L, N, mesh, Δt); one colour per initial layout (l_x, l_y).
Two particles: both trajectories (Figs. 5.10/5.13); three or more: the top-left particle only, as in
Figs. 5.18/5.20 (the others are point-symmetric). Black dots: initial positions; ×: final positions, with the
particle outline (radius a). Trajectories are broken where they cross the periodic boundary x = ±L/2.
The legend gives each layout's outcome. The walls are the panel's top and bottom (y = ±H/2).

Inputs: cases (geometry = 'confined_shear') ⋈ outcomes; samples (x, y).
Usage: python plotting/alignment_trajectories.py DB [OUT_DIR]
"""

from __future__ import annotations

import numpy as np
from matplotlib.patches import Circle

import figlib as fl

NAME = "alignment_trajectories"
TITLE = "Particle trajectories in confined shear flow for several initial positions"


def draw(ax, f: fl.Figures, cases: list[fl.Case]) -> None:
    xs_all = []
    n_particles = max((c.n or 0) for c in cases)
    shown = [0, 1] if n_particles == 2 else [0]
    for i, c in enumerate(cases):
        tracks = f.samples(c)
        colour = f"C{i % 10}"
        init = c.initial_positions()
        for p in shown:
            tr = tracks.get(p)
            if tr is None or len(tr.t) == 0:
                continue
            x = np.concatenate([[init[p][0]], tr.x]) if p < len(init) else tr.x
            y = np.concatenate([[init[p][1]], tr.y]) if p < len(init) else tr.y
            bx, by = fl.break_periodic(x, y, c.l)
            ax.plot(bx, by, color=colour, lw=1.3, ls="-" if p == 0 else "--",
                    label=f"{c.layout_text()} ({fl.kind_text(c)})" if p == 0 else None)
            ax.plot(x[0], y[0], "o", color="black", ms=4, zorder=5)
            fin = np.isfinite(x) & np.isfinite(y)
            if fin.any():
                xf, yf = x[fin][-1], y[fin][-1]
                ax.plot(xf, yf, "x", color=colour, ms=7, mew=1.6, zorder=6)
                if c.a:
                    ax.add_patch(Circle((xf, yf), c.a, fill=False, ec=colour, lw=0.6, alpha=0.6))
            xs_all.append(x[np.isfinite(x)])
    c0 = cases[0]
    if c0.h:
        ax.set_ylim(-c0.h / 2, c0.h / 2)
        for yw in (-c0.h / 2, c0.h / 2):
            ax.axhline(yw, color="black", lw=2)
    if xs_all and c0.l and c0.h:
        # Symmetric about the channel centre (the set-ups are point-symmetric), at least 1.5 H wide.
        half = max(np.abs(np.concatenate(xs_all)).max() + 2 * (c0.a or 0.0), 0.75 * c0.h)
        ax.set_xlim(-min(half, c0.l / 2), min(half, c0.l / 2))
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlabel("x")
    ax.set_ylabel("y")
    ax.grid(alpha=0.3)
    which = "both particles (top-left solid, bottom-right dashed)" if shown == [0, 1] else "top-left particle"
    return which


def main(f: fl.Figures) -> None:
    all_shear = f.cases("confined_shear")
    cases = [c for c in all_shear if f.samples(c)]
    if len(cases) < len(all_shear):
        f.log(f"{NAME}: {len(all_shear) - len(cases)} of {len(all_shear)} confined-shear cases have no samples "
              "(pending or failed) and are not drawn")
    if not cases:
        msg = ("no confined-shear cases in the database (run e.g. sweeps/two_particle_ly.toml or "
               "sweeps/table5_2.toml)" if not all_shear else
               f"none of the {len(all_shear)} confined-shear cases has samples yet")
        f.empty(NAME, TITLE, msg)
        return
    # Families with the most initial layouts first: single-layout set-ups fill the later pages.
    groups = sorted(fl.shear_groups(cases), key=lambda g: -len(g[1]))
    common, rest = fl.split_common([p for p, _ in groups])
    for page, items in fl.pages(list(zip(rest, groups)), NAME, f.log, per=8):
        fig, axes = fl.panel_grid(len(items), width=6.4, height=3.0, max_cols=2)
        for ax, (panel_params, (_, cs)) in zip(axes, items):
            which = draw(ax, f, cs)
            ax.set_title(f"{fl.describe(panel_params) or 'all cases'}: {which}", fontsize=9)
            ax.legend(fontsize=6.5, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0)
        fig.suptitle(f"{TITLE}\n{fl.describe(common)}; ● initial, × final position", fontsize=11)
        f.save(fig, page)


if __name__ == "__main__":
    import make_figures

    make_figures.run_one(main)
