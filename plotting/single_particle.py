"""One particle in confined shear flow started at different heights (thesis §5.5, Figs. 5.7 and 5.8):
`single_particle` (`_p2`, ...) and `tables/single_particle.md`.

Cases: geometry 'confined_shear' with exactly one particle. A start is the particle's initial position
(`particles.layout.*`, Y0) together with `numerics.frame_velocity`, the frame moving with the fluid at that
height (sweeps/single_particle_migration.toml zips the two): both belong to the start, so they never split
set-ups. Cases are grouped into set-ups by all of `params_json` except the start and the mesh; a
`numerics.*`/`output.*` setting that takes one value per mesh within a set-up (e.g. Δt zipped with the mesh)
counts as part of the mesh, as in mesh_convergence.py, and is named in the legend.

One row per set-up (three per page), two panels: V* = V/(Hγ̇) (migration velocity, y-velocity, positive
upwards) and ω* = ω/γ̇ (clockwise positive, as stored) against t* = tγ̇, γ̇ = U_w/H; one colour per start,
labelled Y0/H = (y0 + H/2)/H (measured from the bottom wall, like the thesis and the sweep file). When a
set-up was run on several meshes they share the panels: the finest solid, coarser ones dashed, dotted, ...
in the colour of the start, so that the mesh check reads at a glance. V are the stored velocities, or
central differences of the positions (`figlib.velocities`, the title says which). Runs not done
(running, pending with samples of an interrupted run, failed) are drawn as far as their finite samples go; a
hollow circle marks where such a curve ends.

The table lists per set-up, start and mesh: the samples, final t*, final y/H (from the bottom wall), the net
migration Δy/H and its direction (towards the wall, towards the centre, or none within NO_MIGRATION_TOL),
the means of V* and ω* over the last LATE_FRACTION of the sampled time, and, for each mesh but the finest,
the largest |ΔV*| and |Δω*| against the next finer mesh over their common sample times (equal times; linear
interpolation in t when they differ).

Inputs: cases (geometry 'confined_shear', n_particles = 1, params_json) ⋈ outcomes; samples (t, y, v, omega
of particle 0).
Usage: python plotting/single_particle.py DB [OUT_DIR]
"""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.lines import Line2D

import figlib as fl
import mesh_convergence as mc

NAME = "single_particle"
TABLE = "tables/single_particle.md"
TITLE = "One particle in confined shear flow, started at different heights (thesis Figs. 5.7, 5.8)"
#: Set-ups (rows) per page.
ROWS_PER_PAGE = 3
#: Leaves of params_json that make up a start: the initial position, and the frame velocity zipped with it.
START_PREFIX = "particles.layout."
START_LEAVES = ("numerics.frame_velocity",)
#: Net migration |Δy|/H below which no direction is claimed: the wiggle of V* alone moves the particle
#: by up to ~1e-3 H about its trend (160×80 and 200×100 runs of sweeps/single_particle_migration.toml),
#: a twelfth of an element of the 160×80 mesh (h = a/4).
NO_MIGRATION_TOL = 1e-3
#: Fraction of the sampled time at the end of a run over which the late means of V* and ω* are taken.
LATE_FRACTION = 0.2
#: Parameters named in the titles (the start is the legend, the mesh the line style).
TITLE_KEYS = ["model", "wi", "alpha", "beta", "h", "a", "l", "dt"]
MISSING_RUN = "run sweeps/single_particle_migration.toml"


# ------------------------------------------------------------------------------------------------ grouping
def is_single(c: fl.Case) -> bool:
    n = c.n if c.n is not None else len(c.initial_positions())
    return n == 1


def is_start(path: str) -> bool:
    return path.startswith(START_PREFIX) or path in START_LEAVES


def y0_of(c: fl.Case) -> float:
    """The start height y0 (centre line at y = 0)."""
    return float(c.initial_positions()[0][1])


def height(c: fl.Case) -> float:
    return float(c.h if c.h else c.geo().get("h", 1.0))


def from_bottom(c: fl.Case, y):
    """y/H measured from the bottom wall: (y + H/2)/H."""
    return (np.asarray(y, dtype=float) + height(c) / 2) / height(c)


class SetUp:
    """One set-up: its cases over starts and meshes, the meshes (coarse → fine), the starts (bottom → top)
    and the mesh-tied settings that differ between the meshes."""

    def __init__(self, cases: list[fl.Case], tied: list[str]):
        self.cases = sorted(cases, key=lambda c: (y0_of(c), mc.elements(c), c.id))
        by_mesh = {mc.mesh_of(c): c for c in sorted(cases, key=mc.elements)}
        self.meshes = list(by_mesh)
        self.starts = sorted({fl.rounded(y0_of(c)) for c in cases})
        #: Mesh-tied settings that differ between the meshes (named in the legend).
        self.varying = [p for p in tied if len({mc.leaves(c.params).get(p) for c in cases}) > 1]

    def colour(self, c: fl.Case) -> str:
        return f"C{self.starts.index(fl.rounded(y0_of(c))) % 10}"

    def style(self, c: fl.Case) -> str:
        """Solid for the finest mesh, then dashed, dotted, dash-dotted towards coarser ones."""
        rank = len(self.meshes) - 1 - self.meshes.index(mc.mesh_of(c))
        return fl.LINESTYLES[rank % len(fl.LINESTYLES)]

    def mesh_label(self, mesh: tuple) -> str:
        c = next(c for c in self.cases if mc.mesh_of(c) == mesh)
        return mc.mesh_text(c) + "".join(f", {mc.leaf_text(c, p)}" for p in self.varying)

    def title_params(self) -> dict:
        c = self.cases[0]
        p = {k: fl.rounded(getattr(c, k)) for k in TITLE_KEYS}
        if "numerics.dt" in self.varying:
            p.pop("dt")
        remap = c.params.get("numerics", {}).get("remap")
        if remap and "numerics.remap" not in self.varying:
            p["remap"] = remap
        return p


def setups(cases: list[fl.Case]) -> list[SetUp]:
    """Groups by all parameters but the start and the mesh; settings tied to the mesh do not split."""
    return [SetUp(sub, tied) for sub, tied in mc.split_by_parameters(cases, is_start)]


def title_texts(f: fl.Figures, groups: list[SetUp]) -> list[dict]:
    """Title parameters per set-up, plus the leaves (not the start, not the mesh) that tell rows apart."""
    extra = [p for p in mc.differing_leaves(groups) if not is_start(p) and p != "numerics.remap"]
    params = []
    for g in groups:
        p = g.title_params()
        p.update({e.split(".")[-1]: mc.leaf_text(g.cases[0], e).split(" = ", 1)[1] for e in extra
                  if e not in g.varying and e in mc.leaves(g.cases[0].params)})
        params.append(p)
    return params


# ------------------------------------------------------------------------------------------------- series
class Series:
    """t*, V*, ω* and y of particle 0 of one case, from the samples with finite t, y and ω (a diverged run
    ends in NaN states)."""

    def __init__(self, f: fl.Figures, c: fl.Case):
        tr = f.samples(c).get(0)
        self.source = None
        if tr is not None:
            keep = np.isfinite(tr.t) & np.isfinite(tr.y) & np.isfinite(tr.omega)
            tr = fl.Track(*(getattr(tr, k)[keep] for k in ("t", "x", "y", "u", "v", "omega", "theta")))
        if tr is None or len(tr.t) == 0:
            self.t = self.v = self.omega = self.y = np.array([])
            return
        _, v, self.source = fl.velocities(c, tr)
        self.t, self.v, self.omega, self.y = tr.t * c.rate, v / c.velocity_scale, tr.omega / c.rate, tr.y

    def __len__(self) -> int:
        return len(self.t)

    def late_mean(self, values: np.ndarray) -> float:
        """Mean over the last LATE_FRACTION of the sampled time."""
        ok = np.isfinite(self.t) & np.isfinite(values)
        if not ok.any():
            return float("nan")
        t, v = self.t[ok], values[ok]
        return float(np.mean(v[t >= t[-1] - LATE_FRACTION * (t[-1] - t[0])]))


def largest_difference(ta, va, tb, vb, tol: float):
    """(max |a − b|, first t, last t, number of times, how matched) over the sample times common to both
    series (`figlib.match_common`), or None."""
    m = fl.match_common(ta, va, tb, vb, tol)
    if m is None:
        return None
    t, a, b, how = m
    return float(np.max(np.abs(a - b))), float(t[0]), float(t[-1]), len(t), how


# ---------------------------------------------------------------------------------------------- the table
def direction(c: fl.Case, dy: float) -> str:
    """'towards wall' / 'towards centre' (also when it crosses the centre line) / 'none', from the net
    displacement Δy; a start on the centre line that moves is 'off centre'."""
    if not np.isfinite(dy):
        return "–"
    if abs(dy) / height(c) < NO_MIGRATION_TOL:
        return "none"
    side = np.sign(y0_of(c))
    if side == 0:
        return "off centre"
    return "towards wall" if dy * side > 0 else "towards centre"


def state(c: fl.Case) -> str:
    return c.status + (f", {fl.kind_text(c)}" if c.kind else "")


def table_rows(f: fl.Figures, g: SetUp) -> list[str]:
    rows = []
    for y0 in g.starts:
        cs = [c for c in g.cases if fl.rounded(y0_of(c)) == y0]  # coarse → fine
        drawn = [c for c in cs if len(Series(f, c)) >= 2]
        for c in cs:
            s = Series(f, c)
            start = f"{from_bottom(c, y0):.4g}"
            head = f"| {start} | {g.mesh_label(mc.mesh_of(c))} | {c.id} | {state(c)} | {len(s)} |"
            if len(s) == 0:
                rows.append(head + " no samples yet |" + " |" * 9)
                continue
            h = height(c)
            dy = float(s.y[-1] - y0_of(c))
            cells = [fl.fmt(s.t[-1]), f"{from_bottom(c, s.y[-1]):.4f}", f"{dy / h:+.2e}", direction(c, dy),
                     f"{s.late_mean(s.v):+.3e}", f"{s.late_mean(s.omega):.4f}"]
            finer = drawn[drawn.index(c) + 1] if c in drawn and c is not drawn[-1] else None
            if finer is None:
                cells += ["–", "", "", ""]
            else:
                sf = Series(f, finer)
                dts = [x.dt * x.rate for x in (c, finer) if x.dt]
                # Sample times closer than a millionth of a step are the same time.
                tol = 1e-6 * min(dts) if dts else 1e-9
                dv = largest_difference(s.t, s.v, sf.t, sf.v, tol)
                dw = largest_difference(s.t, s.omega, sf.t, sf.omega, tol)
                if dv is None or dw is None:
                    cells += [mc.mesh_text(finer), "no common sample times", "", ""]
                else:
                    cells += [mc.mesh_text(finer), f"{fl.fmt(dw[1])}–{fl.fmt(dw[2])} ({dw[3]}, {dw[4]})",
                              f"{dv[0]:.2e}", f"{dw[0]:.2e}"]
            rows.append(head + " " + " | ".join(cells) + " |")
    return rows


def table(f: fl.Figures, groups: list[SetUp], titles: list[str], message: str | None) -> None:
    lines = ["# One particle in confined shear flow by start height (thesis §5.5, Figs. 5.7–5.8)", "",
             f"Generated by plotting/single_particle.py from `{f.db}` ({f.summary()}).", ""]
    if message:
        f.write_text(TABLE, "\n".join(mc.md(ln) for ln in lines + [f"Nothing to show yet: {message}.", ""]))
        return
    lines += [
        "Per set-up, start and mesh, of the particle: Y0/H and y/H are measured from the bottom wall "
        "((y + H/2)/H); t* = tγ̇, V* = V/(Hγ̇), ω* = ω/γ̇ (clockwise positive), γ̇ = U_w/H. 'Δy/H' is the "
        "net migration from the start to the last sample; 'direction' is towards the nearer wall or towards the "
        f"centre line, 'none' when |Δy|/H < {NO_MIGRATION_TOL:g}. 'late V*', 'late ω*' are means over the "
        f"last {100 * LATE_FRACTION:g} % of the sampled time of that case (unfinished runs: of what exists so "
        "far). For each mesh but the finest, the last columns compare it with the next finer mesh of the same start: "
        "the largest |ΔV*| and |Δω*| over their common sample times (equal times, or linear interpolation "
        "in t onto the sparser series' times).",
        ""]
    for g, title in zip(groups, titles):
        lines += [f"## {title}", "",
                  "| Y0/H | mesh | case | status | samples | final t* | final y/H | Δy/H | direction | late V* | "
                  "late ω* | vs finer mesh | common t* (samples) | max \\|ΔV*\\| | max \\|Δω*\\| |",
                  "| ---: | --- | ---: | --- | ---: | ---: | ---: | ---: | --- | ---: | ---: | --- | --- | ---: "
                  "| ---: |"]
        lines += table_rows(f, g)
        lines.append("")
    f.write_text(TABLE, "\n".join(mc.md(ln) for ln in lines))


# --------------------------------------------------------------------------------------------- the figure
def plot_row(f: fl.Figures, g: SetUp, row, sources: set) -> None:
    ax_v, ax_w = row
    unfinished = False
    for c in g.cases:
        s = Series(f, c)
        if len(s) < 2:
            continue
        sources.add(s.source)
        kw = dict(color=g.colour(c), ls=g.style(c), lw=1.2 if g.style(c) == "-" else 1.0)
        ax_v.plot(s.t, s.v, **kw)
        ax_w.plot(s.t, s.omega, **kw)
        if c.status != "done":
            unfinished = True
            for ax, q in ((ax_v, s.v), (ax_w, s.omega)):
                ax.plot(s.t[-1], q[-1], "o", mfc="none", mec=g.colour(c), ms=5)
    for ax, q in ((ax_v, "V* = V/(Hγ̇)"), (ax_w, "ω* = ω/γ̇ (clockwise +)")):
        ax.set_ylabel(q)
        ax.set_xlabel("t* = tγ̇")
        ax.grid(alpha=0.3)
    ax_v.axhline(0.0, color="0.5", lw=0.7)
    ax_v.ticklabel_format(axis="y", style="sci", scilimits=(-2, 2))
    fl.min_span(ax_w, 0.05)
    drawn_starts = [y0 for y0 in g.starts if any(fl.rounded(y0_of(c)) == y0 and len(Series(f, c)) >= 2
                                                 for c in g.cases)]
    c0 = g.cases[0]
    starts = [Line2D([], [], color=f"C{g.starts.index(y0) % 10}", lw=2, label=f"{from_bottom(c0, y0):.3g}")
              for y0 in drawn_starts]
    missing = [f"{from_bottom(c0, y0):.3g}" for y0 in g.starts if y0 not in drawn_starts]
    if missing:
        starts.append(Line2D([], [], ls="none", label=f"no samples yet: {', '.join(missing)}"))
    ax_v.legend(handles=starts, title="Y0/H (from bottom wall)", fontsize=7, title_fontsize=7, loc="upper left",
                bbox_to_anchor=(1.01, 1.0), borderaxespad=0)
    drawn_meshes = [m for m in g.meshes if any(mc.mesh_of(c) == m and len(Series(f, c)) >= 2 for c in g.cases)]
    meshes = [Line2D([], [], color="0.2", ls=g.style(next(c for c in g.cases if mc.mesh_of(c) == m)),
                     label=g.mesh_label(m)) for m in reversed(drawn_meshes)]
    missing = [g.mesh_label(m) for m in reversed(g.meshes) if m not in drawn_meshes]
    if missing:
        meshes.append(Line2D([], [], ls="none", label=f"no samples yet: {', '.join(missing)}"))
    if unfinished:
        meshes.append(Line2D([], [], ls="none", marker="o", mfc="none", mec="0.2", label="end of an unfinished run"))
    ax_w.legend(handles=meshes, title="mesh", fontsize=7, title_fontsize=7, loc="upper left",
                bbox_to_anchor=(1.01, 1.0), borderaxespad=0)


def main(f: fl.Figures) -> None:
    cases = [c for c in f.cases("confined_shear") if is_single(c)]
    if not cases:
        msg = f"no confined-shear case with one particle in the database ({MISSING_RUN})"
        f.empty(NAME, TITLE, msg)
        table(f, [], [], msg)
        return
    groups = setups(cases)
    groups.sort(key=lambda g: (-len(g.starts), -len(g.meshes), g.cases[0].id))
    params = title_texts(f, groups)
    table(f, groups, [fl.describe(p).replace("\n", " ") for p in params], None)
    with_samples = [c for c in cases if len(Series(f, c)) >= 2]
    if not with_samples:
        f.empty(NAME, TITLE, f"none of the {len(cases)} one-particle confined-shear cases has two or more samples "
                "yet (pending, running or failed)")
        return
    if len(with_samples) < len(cases):
        f.log(f"{NAME}: {len(cases) - len(with_samples)} of {len(cases)} one-particle confined-shear cases have "
              "fewer than two samples (pending or failed) and are not drawn")
    items = [(p, g) for p, g in zip(params, groups) if any(c in with_samples for c in g.cases)]
    common, rest = fl.split_common([p for p, _ in items])
    for page, chunk in fl.pages(list(zip(rest, [g for _, g in items])), NAME, f.log, per=ROWS_PER_PAGE):
        fig, axes = plt.subplots(len(chunk), 2, figsize=(13, 3.6 * len(chunk) + 1.2), squeeze=False,
                                 layout="constrained")
        fig.get_layout_engine().set(rect=(0, 0.025, 1, 0.975))  # room for the footer
        sources: set = set()
        for row, (panel_params, g) in zip(axes, chunk):
            plot_row(f, g, row, sources)
            row[0].set_title(fl.describe(panel_params) or "the set-up of the title", fontsize=9, loc="left")
        src = f"  [{'; '.join(sorted(sources))}]" if sources else ""
        fig.suptitle(f"{TITLE}\n{fl.describe(common)}{src}", fontsize=11)
        f.save(fig, page)


if __name__ == "__main__":
    import make_figures

    make_figures.run_one(main)
