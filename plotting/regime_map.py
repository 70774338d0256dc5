"""Regime map of particle motion over confinement δ = H/2a and Wi (thesis Fig. 5.26): `regime_map`.

One panel per set-up apart from H and Wi (model, N, α, β, a, L, l_x, l_y); one marker per case at (δ, Wi),
by outcome: pass ▷, repel ×, string ●, jammed ■, wall contact ▲, and the rest (steady, timeout, diverged,
not finished) in their own markers. Cases at the same (δ, Wi) — e.g. different meshes, which follow δ in the
regime sweep — are spread slightly sideways. δ is on a log axis when it spans a factor of 8 or more.

Boundaries: at each δ, two neighbouring Wi (among the cases with an outcome) whose outcome kinds differ bracket
a boundary, drawn as a black bar from the lower to the upper Wi with a tick at its middle — on a grid the bar
is one grid spacing long, after an adaptive search (`[search]` over `fluid.wi`, docs/sweeps.md) at most its
tolerance. `xpflow query boundaries` lists the search's brackets with their values.

Inputs: cases (geometry = 'confined_shear', delta, wi) ⋈ outcomes (kind).
Usage: python plotting/regime_map.py DB [OUT_DIR]
"""

from __future__ import annotations

import numpy as np
from matplotlib.lines import Line2D

import figlib as fl

NAME = "regime_map"
TITLE = "Regime map over confinement δ = H/2a and Wi (confined shear)"
KEYS = ["model", "n", "alpha", "beta", "a", "l", "lx", "ly"]
#: Sideways spread of cases at the same point, as a fraction of the axis (log or linear) span.
SPREAD = 0.012


def main(f: fl.Figures) -> None:
    cases = [c for c in f.cases("confined_shear") if c.delta is not None and c.wi is not None]
    if not cases:
        f.empty(NAME, TITLE, "no confined-shear cases with particles in the database "
                "(run e.g. sweeps/regime_delta_wi.toml)")
        return
    unfinished = [c for c in cases if c.kind is None]
    if unfinished:
        f.log(f"{NAME}: {len(unfinished)} of {len(cases)} cases have no outcome yet (pending, running or failed); "
              "drawn as grey dots")
    # Panels with the most (δ, Wi) points first: the real maps before single-δ sweeps.
    groups = sorted(fl.shear_groups(cases, KEYS),
                    key=lambda g: -len({(fl.rounded(c.delta), fl.rounded(c.wi)) for c in g[1]}))
    common, rest = fl.split_common([p for p, _ in groups])
    for page, items in fl.pages(list(zip(rest, groups)), NAME, f.log, per=6):
        fig, axes = fl.panel_grid(len(items), width=5.6, height=4.2, max_cols=2)
        for ax, (panel_params, (_, cs)) in zip(axes, items):
            deltas = np.array([c.delta for c in cs], dtype=float)
            log_x = deltas.max() / deltas.min() >= 8
            span = (np.log10(deltas.max() / deltas.min()) if log_x else deltas.max() - deltas.min()) or 1.0
            at: dict = {}
            for c in cs:
                at.setdefault((fl.rounded(c.delta), fl.rounded(c.wi)), []).append(c)
            kinds_here = set()
            brackets = boundary_brackets(cs)
            for d, lo, hi in brackets:
                ax.errorbar(d, (lo + hi) / 2, yerr=(hi - lo) / 2, fmt="_", color="black", ms=14, mew=1.5,
                            elinewidth=2.5, capsize=5, zorder=3)
            for (d, wi), here in at.items():
                here.sort(key=lambda c: (str(c.kind), c.id))
                for k, c in enumerate(here):
                    shift = (k - (len(here) - 1) / 2) * SPREAD * span
                    x = d * 10 ** shift if log_x else d + shift
                    marker, colour, _ = fl.KIND_STYLE.get(c.kind, fl.KIND_STYLE[None])
                    filled = marker not in ("x", "+", ".")
                    ax.plot(x, wi, marker, color=colour, ms=9, mew=1.8,
                            mfc=colour if filled else "none", ls="none")
                    kinds_here.add(c.kind)
            if log_x:
                ax.set_xscale("log")
                ticks = sorted(set(deltas))
                ax.set_xticks(ticks)
                ax.set_xticklabels([fl.fmt(t) for t in ticks])
                ax.minorticks_off()
            ax.set_xlabel("confinement δ = H/2a")
            ax.set_ylabel("Wi")
            ax.margins(0.08)
            ax.grid(alpha=0.3)
            handles = [Line2D([], [], marker=fl.KIND_STYLE[k][0], color=fl.KIND_STYLE[k][1], ls="none", ms=8,
                              mew=1.8, label=fl.KIND_STYLE[k][2])
                       for k in fl.KIND_STYLE if k in kinds_here]
            if brackets:
                handles.append(Line2D([], [], marker="_", color="black", ls="none", ms=12, mew=2,
                                      label=f"boundary bracket ({len(brackets)})"))
            ax.legend(handles=handles, fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0)
            ax.set_title(f"{fl.describe(panel_params) or 'all cases'} ({len(cs)} cases)", fontsize=9)
        fig.suptitle(f"{TITLE}\n{fl.describe(common)}", fontsize=11)
        f.save(fig, page)


def boundary_brackets(cases) -> list[tuple[float, float, float]]:
    """(δ, Wi below, Wi above) for each pair of neighbouring Wi at the same δ whose outcome kinds differ
    (cases without an outcome bracket nothing)."""
    by_delta: dict = {}
    for c in cases:
        if c.kind is not None:
            by_delta.setdefault(fl.rounded(c.delta), []).append(c)
    out = []
    for here in by_delta.values():
        # one outcome per Wi: several cases at one (δ, Wi) (meshes) count when they agree
        kinds: dict = {}
        for c in here:
            kinds.setdefault(c.wi, set()).add(c.kind)
        wis = sorted(kinds)
        for lo, hi in zip(wis, wis[1:]):
            if kinds[lo] != kinds[hi]:
                out.append((here[0].delta, lo, hi))
    return out


if __name__ == "__main__":
    import make_figures

    make_figures.run_one(main)
