"""Radial (migration) velocity in circular Couette flow vs time (thesis 3.5): `migration_vr`.

One panel per combination of R2/R1, β, Wi, α, ε, mesh and Δt; one curve per initial position r0*. The
radial velocity is made dimensionless as dr*/dt* = V_r/((R2 − R1) ω̄), V_r = (xU + yV)/r, from the stored
U, V — or from central differences of r*(t*) when the stored velocities are missing or zero while the
particle moves (the legend says which). Positive: away from the inner cylinder.

Inputs: cases (geometry = 'couette') ⋈ outcomes; samples (t, x, y, u, v of particle 0).
Usage: python plotting/migration_vr.py DB [OUT_DIR]
"""

from __future__ import annotations

import numpy as np

import figlib as fl
from migration_r import couette_families

NAME = "migration_vr"
#: Smallest y range: a particle at rest shows round-off (1e-15) as zero, not as noise.
MIN_SPAN = 1e-3
TITLE = "Migration in circular Couette flow: radial velocity dr*/dt* vs t*"


def radial_velocity(c: fl.Case, tr: fl.Track):
    u, v, source = fl.velocities(c, tr)
    t = tr.t * c.rate
    if source.startswith("stored"):
        r = np.hypot(tr.x, tr.y)
        return t, (tr.x * u + tr.y * v) / r / c.velocity_scale, source
    # Differentiate r* itself: differences of x, y of a particle going round have a spurious radial part.
    return t, np.gradient(c.r_star(tr.x, tr.y), t), "dr*/dt* from finite differences of r*"


def main(f: fl.Figures) -> None:
    cases = [c for c in f.cases("couette") if f.samples(c)]
    if not cases:
        n = len(f.cases("couette"))
        msg = ("no Couette cases in the database (run e.g. sweeps/couette_r0.toml)" if n == 0 else
               f"none of the {n} Couette cases has samples yet (pending or failed)")
        f.empty(NAME, TITLE, msg)
        return
    fams = couette_families(cases, "r0", 1)
    common, rest = fl.split_common([p for p, _ in fams])
    common.pop("r0", None)
    sources = set()
    for page, items in fl.pages(list(zip(rest, fams)), NAME, f.log):
        fig, axes = fl.panel_grid(len(items))
        for ax, (panel_params, (_, cs)) in zip(axes, items):
            for c in cs:
                tr = f.samples(c)[0] if 0 in f.samples(c) else None
                if tr is None or len(tr.t) < 2:
                    continue
                t, vr, source = radial_velocity(c, tr)
                sources.add(source)
                ax.plot(t, vr, lw=1.3, ls=fl.LINESTYLES[cs.index(c) % len(fl.LINESTYLES)], label=f"r0* = {fl.fmt(c.r0)} ({fl.kind_text(c)})")
            ax.axhline(0.0, color="0.5", lw=0.8)
            ax.set_xlabel("t* = t ω̄")
            ax.set_ylabel("dr*/dt* = V_r / ((R2 − R1) ω̄)")
            panel_params.pop("r0", None)
            ax.set_title(fl.describe(panel_params) or "all cases", fontsize=9)
            ax.legend(fontsize=7, loc="best")
            ax.grid(alpha=0.3)
            fl.min_span(ax, MIN_SPAN)
        fig.suptitle(f"{TITLE}\n{fl.describe(common)}  [{'; '.join(sorted(sources))}]", fontsize=11)
        f.save(fig, page)


if __name__ == "__main__":
    import make_figures

    make_figures.run_one(main)
