"""The films between neighbouring particles over time (thesis §5.7: strings form as the gaps close):
`string_gaps` (`_p2`, ...).

One panel per confined-shear set-up with two particles or more (model, Wi, α, β, H, a, L, N, mesh, Δt and the
numerical settings, as `alignment_trajectories` groups them); one colour per initial layout, one line style per
pair of neighbours along the chain (particles 0–1 solid, 1–2 dashed, ...: the layout's order, left to right).
The gap is the surface distance over the radius, d/a = (|x_k+1 − x_k| − 2a)/a, the x-distance taken to the
nearest periodic image; a log axis, so that a film of 0.01a and a particle that left (gap ≫ 1) read on one
panel. A string's gaps settle at a film; a string that breaks up has one gap opening (a pair and a single);
a pass or repel ends with the gaps of order L/a. The legend gives each layout's outcome; runs not done are
drawn as far as their samples go and end in ○.

Inputs: cases (geometry = 'confined_shear', n_particles ≥ 2) ⋈ outcomes; samples (t, x, y).
Usage: python plotting/string_gaps.py DB [OUT_DIR]
"""

from __future__ import annotations

import numpy as np
from matplotlib.ticker import NullLocator

import figlib as fl

NAME = "string_gaps"
TITLE = "Gaps between neighbouring particles over time (0–1 solid, 1–2 dashed, 2–3 dotted, ...)"
#: Smallest gap drawn on the log axis (in units of a): an overlap or contact is clipped to it.
FLOOR = 1e-4


def gaps(f: fl.Figures, c: fl.Case) -> tuple[np.ndarray, list[np.ndarray]] | None:
    """(t*, [gap/a of neighbours k, k+1]) at the times all particles were sampled, or None."""
    tracks = f.samples(c)
    n = c.n or len(tracks)
    if n < 2 or any(k not in tracks for k in range(n)) or not c.a:
        return None
    t = tracks[0].t
    if len(t) < 2 or any(len(tracks[k].t) != len(t) for k in range(n)):
        return None
    out = []
    for k in range(n - 1):
        a, b = tracks[k], tracks[k + 1]
        dx = b.x - a.x
        if c.l:
            dx = dx - c.l * np.round(dx / c.l)
        out.append((np.hypot(dx, b.y - a.y) - 2 * c.a) / c.a)
    return t * c.rate, out


def draw(ax, f: fl.Figures, cases: list[fl.Case]) -> bool:
    drawn = False
    for i, c in enumerate(cases):
        g = gaps(f, c)
        if g is None:
            continue
        t, per_pair = g
        colour = f"C{i % 10}"
        for k, d in enumerate(per_pair):
            label = f"{c.layout_text()}: {fl.kind_text(c)}" if k == 0 else None
            ax.plot(t, np.maximum(d, FLOOR), color=colour, lw=1.2, ls=fl.LINESTYLES[k % len(fl.LINESTYLES)],
                    label=label)
            if c.status != "done":
                ax.plot(t[-1], max(d[-1], FLOOR), "o", mfc="none", color=colour, ms=5)
        drawn = True
    ax.set_yscale("log")
    # (a log axis' minor ticks are most of the layout's time on pages of twelve panels)
    ax.yaxis.set_minor_locator(NullLocator())
    ax.set_xlabel("t*")
    ax.set_ylabel("gap / a")
    ax.grid(True, which="major", alpha=0.3)
    return drawn


def main(f: fl.Figures) -> None:
    cases = [c for c in f.cases("confined_shear") if (c.n or 0) >= 2]
    groups = [(p, cs) for p, cs in fl.shear_groups(cases) if any(gaps(f, c) is not None for c in cs)]
    if not groups:
        f.empty(NAME, TITLE, "no confined-shear case with two particles or more has samples "
                "(run e.g. sweeps/beta_robustness.toml or sweeps/table5_2_graded.toml)")
        return
    common, rest = fl.split_common([p for p, _ in groups])
    for name, chunk in fl.pages(list(zip(groups, rest)), NAME, f.log):
        fig, axes = fl.panel_grid(len(chunk))
        for ax, ((_, cs), own) in zip(axes, chunk):
            draw(ax, f, cs)
            ax.set_title(fl.describe(own), fontsize=8)
            ax.legend(fontsize=6, loc="best")
        fig.suptitle(f"{TITLE}\n{fl.describe(common)}", fontsize=10)
        fl.wrap_titles(fig)
        f.save(fig, name)


if __name__ == "__main__":
    import make_figures

    make_figures.run_one(main)
