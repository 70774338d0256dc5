"""Steady angular velocities of the particles of a string and the gap between them, by string length
(thesis Figs. 5.23, 5.30, 5.32): `alignment_steady_omega`.

One row per set-up (model, Wi, α, β, H, a, L, mesh, Δt); left: ω* = ω/γ̇ of each particle at the steady
state, particles ordered along the string by x (1 = left end), one series per string length N (a single
particle that reached a steady rotation counts as N = 1); right: gap d* = d/a between neighbours (small
dots: each gap of each case; large marker: `outcomes.mean_gap`) against N. Every string found is drawn, so
the spread over initial positions is visible (the thesis finds none).

Inputs: cases ⋈ outcomes with kind = 'string' (or 'steady' and N = 1) in confined shear; outcomes.final_json
(positions, omega_star, gaps_over_a), outcomes.mean_gap.
Usage: python plotting/alignment_steady.py DB [OUT_DIR]
"""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np

import figlib as fl

NAME = "alignment_steady_omega"
TITLE = "Steady angular velocity of the particles of a string and their gap, by string length"
KEYS = ["model", "wi", "alpha", "beta", "h", "a", "l", "mesh", "step", "settings"]
ROWS_PER_PAGE = 4
#: Smallest y range of a panel (ω* and d* are O(0.1–1); smaller differences are not resolved by a solver).
MIN_SPAN = 0.05


def is_steady_string(c: fl.Case) -> bool:
    return c.kind == "string" or (c.kind == "steady" and c.n == 1)


def main(f: fl.Figures) -> None:
    shear = [c for c in f.cases("confined_shear") if c.status == "done"]
    cases = [c for c in shear if is_steady_string(c) and c.final.get("omega_star")]
    if not cases:
        kinds = sorted({c.kind for c in shear if c.kind})
        msg = ("no finished confined-shear cases in the database (run e.g. sweeps/table5_2.toml)" if not shear
               else f"none of the {len(shear)} finished confined-shear cases formed a string "
               f"(outcomes: {', '.join(kinds)})")
        f.empty(NAME, TITLE, msg)
        return
    groups = fl.shear_groups(cases, KEYS)
    common, rest = fl.split_common([p for p, _ in groups])
    for page, items in fl.pages(list(zip(rest, groups)), NAME, f.log, per=ROWS_PER_PAGE):
        fig, axes = plt.subplots(len(items), 2, figsize=(12, 3.3 * len(items) + 1.0), squeeze=False,
                                 layout="constrained", gridspec_kw=dict(width_ratios=[3, 2]))
        for (ax_w, ax_d), (panel_params, (_, cs)) in zip(axes, items):
            lengths = sorted({len(c.final["omega_star"]) for c in cs})
            for j, n in enumerate(lengths):
                colour = f"C{j % 10}"
                of_n = [c for c in cs if len(c.final["omega_star"]) == n]
                for k, c in enumerate(of_n):
                    pos = np.array(c.final.get("positions") or [[i, 0] for i in range(n)], dtype=float)
                    order = np.argsort(pos[:, 0])
                    w = np.array(c.final["omega_star"], dtype=float)[order]
                    ax_w.plot(np.arange(1, n + 1), w, "o-", color=colour, ms=5, lw=0.8, alpha=0.8,
                              label=f"N = {n} ({len(of_n)} case{'s' if len(of_n) > 1 else ''})" if k == 0 else None)
                    gaps = c.final.get("gaps_over_a") or []
                    ax_d.plot([n] * len(gaps), gaps, ".", color=colour, ms=3, alpha=0.6)
                    if c.mean_gap is not None:
                        ax_d.plot(n, c.mean_gap, "D", color=colour, ms=6, mfc="none")
                mg = [c.mean_gap for c in of_n if c.mean_gap is not None]
                if mg:
                    ax_d.annotate(f"d* = {np.mean(mg):.3g}", (n, np.mean(mg)), textcoords="offset points",
                                  xytext=(6, 4), fontsize=7)
            ax_w.set_xlabel("particle along the string (1 = left end)")
            ax_w.set_ylabel("steady ω* = ω/γ̇")
            ax_w.set_xticks(range(1, max(lengths) + 1))
            ax_w.grid(alpha=0.3)
            ax_w.legend(fontsize=7)
            ax_w.set_title(fl.describe(panel_params) or "all strings", fontsize=9, loc="left")
            ax_d.set_xlabel("string length N")
            ax_d.set_ylabel("gap d* = d/a")
            ax_d.set_xticks(lengths)
            ax_d.set_xlim(min(lengths) - 0.5, max(lengths) + 0.5)
            ax_d.grid(alpha=0.3)
            for ax in (ax_w, ax_d):
                fl.min_span(ax, MIN_SPAN)
        fig.suptitle(f"{TITLE}\n{fl.describe(common)}; ◇ mean gap of a case, · each gap", fontsize=11)
        f.save(fig, page)


if __name__ == "__main__":
    import make_figures

    make_figures.run_one(main)
