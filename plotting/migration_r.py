"""Particle migration in circular Couette flow (thesis 3.5, Figs. 3.20ff.): r*(t*) families.

Four figures, one per family parameter: `migration_r_by_r0` (curves differ in the initial position r0*),
`migration_r_by_wi`, `migration_r_by_alpha` and `migration_r_by_eps`. One panel per combination of the other
parameters (R2/R1, β, Wi, α, ε, r0*, mesh, Δt; the ε family's mesh, refined with ε, is in each curve's
label instead); a family needs at least two values of its parameter (r0*: one is enough). Shaded: radial positions a particle cannot reach, r* < a/(R2 − R1) or
r* > 1 − a/(R2 − R1).

Inputs: cases (geometry = 'couette') ⋈ outcomes; samples (x, y of particle 0).
Usage: python plotting/migration_r.py DB [OUT_DIR]
"""

from __future__ import annotations

import numpy as np

import figlib as fl

#: Parameters that define a Couette case (panel keys).
KEYS = ["ratio", "beta", "wi", "alpha", "eps", "r0", "mesh", "step", "settings"]
#: Parameters a family may change with its own (the ε family refines the mesh with ε to keep a/h):
#: left out of the panel keys and given in each curve's label instead.
ALONG = {"eps": ["mesh"]}
#: Caption of the shading, in every suptitle.
SHADING = "grey: unreachable, r* < a/(R2 − R1) or r* > 1 − a/(R2 − R1)"
#: Family parameter → (file suffix, words for titles).
FAMILIES = {
    "r0": ("r0", "initial positions r0*"),
    "wi": ("wi", "Weissenberg numbers Wi"),
    "alpha": ("alpha", "mobilities α"),
    "eps": ("eps", "confinements ε = 2a/(R2 − R1)"),
}


def key_of(c: fl.Case, names) -> dict:
    return {n: fl.rounded(getattr(c, n)) for n in names}


def couette_families(cases, var: str, min_values: int):
    """[(panel parameters, cases sorted by var)] for the groups with ≥ min_values values of var."""
    others = [k for k in KEYS if k != var and k not in ALONG.get(var, [])]
    groups = fl.group(cases, key=lambda c: tuple(key_of(c, others).items()),
                      sort=lambda k: tuple(fl.sort_key(v) for _, v in k))
    out = []
    for k, cs in groups:
        if len({fl.rounded(getattr(c, var)) for c in cs}) >= min_values:
            out.append((dict(k), sorted(cs, key=lambda c: fl.sort_key(getattr(c, var)))))
    return out


def shade_unreachable(ax, cases) -> None:
    """Grey bands r* < a/(R2 − R1) and r* > 1 − a/(R2 − R1), one pair per distinct particle size."""
    for u in sorted({round(c.unreachable, 12) for c in cases if c.unreachable is not None}):
        kw = dict(color="0.6", alpha=0.25, lw=0)
        ax.axhspan(0.0, u, **kw)
        ax.axhspan(1.0 - u, 1.0, **kw)


def r_star_series(f: fl.Figures, c: fl.Case):
    """(t*, r*) of particle 0 starting with the initial position at t* = 0, or None without samples."""
    tr = f.samples(c).get(0)
    if tr is None or len(tr.t) == 0:
        return None
    p0 = c.initial_positions()
    t = np.concatenate([[0.0], tr.t]) * c.rate
    x = np.concatenate([[p0[0][0]] if p0 else [np.nan], tr.x])
    y = np.concatenate([[p0[0][1]] if p0 else [np.nan], tr.y])
    return t, c.r_star(x, y)


def plot_family(f: fl.Figures, var: str) -> None:
    suffix, words = FAMILIES[var]
    name = f"migration_r_by_{suffix}"
    title = f"Migration in circular Couette flow: r*(t*) for several {words}"
    cases = f.cases("couette")
    if not cases:
        f.empty(name, title, "no Couette cases in the database (run e.g. sweeps/couette_r0.toml)")
        return
    with_samples = [c for c in cases if f.samples(c)]
    if len(with_samples) < len(cases):
        f.log(f"{name}: {len(cases) - len(with_samples)} of {len(cases)} Couette cases have no samples "
              "(pending or failed) and are not drawn")
    if not with_samples:
        f.empty(name, title, f"none of the {len(cases)} Couette cases has samples yet (pending or failed)")
        return
    fams = couette_families(with_samples, var, 1 if var == "r0" else 2)
    if not fams:
        vals = sorted({fl.fmt(getattr(c, var)) for c in with_samples})
        f.empty(name, title, f"no Couette cases that differ only in {fl.SYMBOL[var]} "
                f"({len(with_samples)} cases with samples, {fl.SYMBOL[var]} ∈ {{{', '.join(vals)}}})")
        return
    common, rest = fl.split_common([{k: v for k, v in p.items()} for p, _ in fams])
    common.pop(var, None)
    for page, items in fl.pages(list(zip(rest, fams)), name, f.log):
        fig, axes = fl.panel_grid(len(items))
        for ax, (panel_params, (_, cs)) in zip(axes, items):
            shade_unreachable(ax, cs)
            for i, c in enumerate(cs):
                s = r_star_series(f, c)
                if s is None:
                    continue
                along = "".join(f", {k} {fl.fmt(getattr(c, k))}" for k in ALONG.get(var, []))
                line, = ax.plot(*s, lw=1.4, ls=fl.LINESTYLES[i % len(fl.LINESTYLES)],
                                label=f"{fl.SYMBOL[var]} = {fl.fmt(getattr(c, var))}{along} ({fl.kind_text(c)})")
                ax.plot(s[0][0], s[1][0], "o", color=line.get_color(), ms=4)
            ax.set_ylim(0.0, 1.0)
            ax.set_xlabel("t* = t ω̄")
            ax.set_ylabel("r* = (r − R1)/(R2 − R1)")
            panel_params.pop(var, None)
            ax.set_title(fl.describe(panel_params) or "all cases", fontsize=9)
            ax.legend(fontsize=7, loc="best")
            ax.grid(alpha=0.3)
        fig.suptitle(f"{title}\n{fl.describe(common)}; ● r0* at t* = 0; {SHADING}", fontsize=11)
        f.save(fig, page)


def main(f: fl.Figures) -> None:
    for var in FAMILIES:
        plot_family(f, var)


if __name__ == "__main__":
    import make_figures

    make_figures.run_one(main)
