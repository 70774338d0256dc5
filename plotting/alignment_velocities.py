"""Velocities of the top-left particle vs time in confined shear flow (thesis Figs. 5.15, 5.22):
`alignment_velocities`.

One row per set-up (model, Wi, α, β, H, a, L, N, mesh, Δt), four set-ups per page, families with most
initial layouts first; columns U* = U/(Hγ̇), V* = V/(Hγ̇) and ω* = ω/γ̇ (clockwise positive) against
t* = tγ̇, one curve per initial layout (l_x, l_y). U, V are the stored velocities, or central differences of
the positions when the stored ones are missing or zero while the particle moves (the title says which).

Inputs: cases (geometry = 'confined_shear') ⋈ outcomes; samples (t, x, y, u, v, omega of particle 0).
Usage: python plotting/alignment_velocities.py DB [OUT_DIR]
"""

from __future__ import annotations

import matplotlib.pyplot as plt

import figlib as fl

NAME = "alignment_velocities"
TITLE = "Velocities of the top-left particle in confined shear flow"
#: Set-ups (rows) per page.
ROWS_PER_PAGE = 4


def main(f: fl.Figures) -> None:
    all_shear = f.cases("confined_shear")
    cases = [c for c in all_shear if 0 in f.samples(c) and len(f.samples(c)[0].t) >= 2]
    if not cases:
        msg = ("no confined-shear cases in the database (run e.g. sweeps/table5_2.toml)" if not all_shear else
               f"none of the {len(all_shear)} confined-shear cases has two or more samples yet")
        f.empty(NAME, TITLE, msg)
        return
    if len(cases) < len(all_shear):
        f.log(f"{NAME}: {len(all_shear) - len(cases)} of {len(all_shear)} confined-shear cases have fewer than "
              "two samples (pending or failed) and are not drawn")
    groups = sorted(fl.shear_groups(cases), key=lambda g: -len(g[1]))
    common, rest = fl.split_common([p for p, _ in groups])
    for page, items in fl.pages(list(zip(rest, groups)), NAME, f.log, per=ROWS_PER_PAGE):
        fig, axes = plt.subplots(len(items), 3, figsize=(15, 2.9 * len(items) + 1.0), squeeze=False,
                                 layout="constrained")
        sources = set()
        for row, (panel_params, (_, cs)) in zip(axes, items):
            for i, c in enumerate(cs):
                tr = f.samples(c)[0]
                u, v, source = fl.velocities(c, tr)
                sources.add(source)
                t = tr.t * c.rate
                label = f"{c.layout_text()} ({fl.kind_text(c)})"
                kw = dict(color=f"C{i % 10}", lw=1.2)
                row[0].plot(t, u / c.velocity_scale, label=label, **kw)
                row[1].plot(t, v / c.velocity_scale, **kw)
                row[2].plot(t, tr.omega / c.rate, **kw)
            for ax, q in zip(row, ("U* = U/(Hγ̇)", "V* = V/(Hγ̇)", "ω* = ω/γ̇ (clockwise +)")):
                ax.set_ylabel(q)
                ax.set_xlabel("t* = tγ̇")
                ax.axhline(0.0, color="0.5", lw=0.7)
                ax.grid(alpha=0.3)
            row[0].set_title(fl.describe(panel_params) or "all cases", fontsize=9, loc="left")
            row[2].legend(*row[0].get_legend_handles_labels(), fontsize=6.5, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0)
        fig.suptitle(f"{TITLE}\n{fl.describe(common)}  [{'; '.join(sorted(sources))}]", fontsize=11)
        f.save(fig, page)


if __name__ == "__main__":
    import make_figures

    make_figures.run_one(main)
