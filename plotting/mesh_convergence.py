"""Mesh convergence: the same set-up on several meshes (thesis Figs. 3.18–3.19 and 5.17):
`mesh_convergence` (`_p2`, ...) and `tables/mesh_convergence.md`.

Cases (Couette and confined shear) are grouped by all their parameters except `numerics.mesh`; a numerical
setting (`numerics.*`, `output.*`) that takes one value per mesh within a set-up (e.g. Δt zipped with the
mesh) counts as part of the mesh, is left out of the grouping and is named in the legend. A group is one
set-up including its initial layout; groups with samples on at least two different meshes are drawn, one row
per group (four per page), one curve per mesh (legend: mesh, outcome):
  Couette:        r*(t*) and ω*(t*) of the particle, t* = tω̄, ω* = ω/ω̄ (clockwise positive, as stored);
  confined shear: V*(t*) = V/(Hγ̇), ω*(t*) = ω/γ̇ and y/H of particle 0 (the top-left one), t* = tγ̇;
V are the stored velocities or central differences of the positions (`figlib.velocities`, the title says which).

The table gives, per set-up and pair of consecutive meshes (sorted by element count), the largest difference
over the sample times common to both meshes (equal times; linear interpolation in t when they differ) of r*
(Couette) or y/H (shear) and of ω*, absolute and relative to the finer mesh of the pair (positions: the range
max − min of its values over the common times; ω*: its largest |ω*| there).

Inputs: cases (geometry 'couette' or 'confined_shear', params_json) ⋈ outcomes; samples (t, x, y, v, omega
of particle 0).
Usage: python plotting/mesh_convergence.py DB [OUT_DIR]
"""

from __future__ import annotations

import json

import matplotlib.pyplot as plt
import numpy as np

import figlib as fl
from migration_r import r_star_series, shade_unreachable

NAME = "mesh_convergence"
TABLE = "tables/mesh_convergence.md"
TITLE = "Mesh convergence: the same set-up on several meshes"
#: Set-ups (rows) per page.
ROWS_PER_PAGE = 4
GEOMETRIES = ("couette", "confined_shear")
GEOMETRY_TEXT = {"couette": "Couette", "confined_shear": "confined shear"}
#: Parameters named in a row's title, per geometry (the mesh is the legend).
TITLE_KEYS = {
    "couette": ["model", "ratio", "beta", "wi", "alpha", "eps", "r0", "dt"],
    "confined_shear": ["model", "wi", "alpha", "beta", "h", "a", "l", "n", "dt"],
}
#: Leaves of params_json that the title keys above already name (others that differ between rows are added).
TITLED_LEAVES = ("fluid.model", "fluid.wi", "fluid.alpha", "fluid.beta", "numerics.dt", "particles.radius",
                 "particles.layout.")
#: Sections of params_json whose settings count as part of the mesh when they take one value per mesh.
MESH_TIED_SECTIONS = ("numerics.", "output.")
MESH_LEAF = "numerics.mesh"
MISSING_RUN = "run e.g. sweeps/couette_two_mesh.toml or sweeps/three_particles_mesh.toml"


# ------------------------------------------------------------------------------------------------ grouping
def leaves(d, prefix: str = "") -> dict:
    """params_json flattened to dotted path → hashable value (lists as tuples, floats rounded)."""
    out = {}
    if isinstance(d, dict):
        for k, v in d.items():
            out.update(leaves(v, f"{prefix}{k}."))
        return out
    return {prefix[:-1]: frozen(d)}


def frozen(v):
    if isinstance(v, (list, tuple)):
        return tuple(frozen(x) for x in v)
    if isinstance(v, dict):
        return json.dumps(v, sort_keys=True)
    return fl.rounded(v)


def mesh_of(c: fl.Case) -> tuple:
    m = c.params.get("numerics", {}).get("mesh")
    return tuple(m) if isinstance(m, list) else (c.mesh,)


def elements(c: fl.Case) -> float:
    m = mesh_of(c)
    return float(np.prod(m)) if all(isinstance(v, (int, float)) for v in m) else float("inf")


def leaf_text(c: fl.Case, path: str) -> str:
    """'Δt = 0.01', 'remap = biquadratic', 'early_stop = true' for a leaf of the case's params_json."""
    name = path.split(".")[-1]
    v = leaves(c.params).get(path)
    return f"{fl.SYMBOL.get(name, name)} = {str(v).lower() if isinstance(v, bool) else fl.fmt(v)}"


def mesh_text(c: fl.Case) -> str:
    m = mesh_of(c)
    return "×".join(str(v) for v in m) if len(m) == 2 else str(c.mesh or "?").replace("x", "×")


class Group:
    """One set-up on several meshes: its cases (one per mesh, sorted by element count) and the settings
    that change with the mesh."""

    def __init__(self, geometry: str, cases: list[fl.Case], tied: list[str]):
        self.geometry = geometry
        self.cases = sorted(cases, key=lambda c: (elements(c), c.id))
        #: Mesh-tied settings that differ between the meshes (named in the legend).
        self.varying = [p for p in tied if len({leaves(c.params).get(p) for c in cases}) > 1]

    def drawn(self, f: fl.Figures) -> list[fl.Case]:
        """The cases with ≥ 2 samples of particle 0."""
        return [c for c in self.cases if 0 in f.samples(c) and len(f.samples(c)[0].t) >= 2]

    def title_params(self) -> dict:
        c = self.cases[0]
        p = {k: fl.rounded(getattr(c, k)) for k in TITLE_KEYS[self.geometry]}
        if "numerics.dt" in self.varying:
            p.pop("dt")
        if self.geometry == "confined_shear":
            kind, _ = c.layout()
            p["layout"] = f"{kind} ({c.layout_text()})"
        return p


def split_by_parameters(cases: list[fl.Case], varies=lambda path: False):
    """Splits `cases` into groups that share every parameter but the mesh, the leaves `varies(path)`
    lets vary within a group (the curves of a panel), and the settings tied to the mesh (one value per
    mesh within the group: e.g. Δt zipped with the mesh); yields (cases, tied settings) per group."""
    flat = {c.id: leaves(c.params) for c in cases}

    def other(path: str) -> bool:
        return path != MESH_LEAF and not varies(path)

    def coarse(c):
        return tuple(sorted((k, v) for k, v in flat[c.id].items()
                            if other(k) and not k.startswith(MESH_TIED_SECTIONS)))

    for _, same in fl.group(cases, key=coarse):
        paths = sorted({k for c in same for k in flat[c.id] if other(k) and k.startswith(MESH_TIED_SECTIONS)})
        tied = []
        for p in paths:
            per_mesh: dict = {}
            for c in same:
                per_mesh.setdefault(mesh_of(c), set()).add(flat[c.id].get(p))
            if all(len(v) == 1 for v in per_mesh.values()):
                tied.append(p)
        free = [p for p in paths if p not in tied]
        for _, sub in fl.group(same, key=lambda c: tuple(flat[c.id].get(p) for p in free)):
            yield sub, tied


def mesh_groups(cases: list[fl.Case]) -> list[Group]:
    """Groups by all parameters but the mesh; mesh-tied settings (one value per mesh) are not split on."""
    return [Group(geometry, sub, tied) for geometry in GEOMETRIES
            for sub, tied in split_by_parameters([c for c in cases if c.geometry == geometry])]


def extra_title_leaves(groups: list[Group]) -> list[str]:
    """Leaves (not the mesh, not mesh-tied in every row, not named by the title keys) that differ between
    the drawn rows of one geometry, so that two rows never carry the same title."""
    out = []
    for geometry in GEOMETRIES:
        out += [p for p in differing_leaves([g for g in groups if g.geometry == geometry]) if p not in out]
    return out


def differing_leaves(groups: list[Group]) -> list[str]:
    flats = [leaves(g.cases[0].params) for g in groups]
    paths = sorted({k for fl_ in flats for k in fl_})
    out = []
    for p in paths:
        if p == MESH_LEAF or p.startswith(TITLED_LEAVES) or all(p in g.varying for g in groups):
            continue
        if len({fl_.get(p) for fl_ in flats}) > 1:
            out.append(p)
    return out


# ------------------------------------------------------------------------------------------------- series
def series(f: fl.Figures, c: fl.Case) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Quantity → (t*, values) of particle 0 from the stored samples."""
    tr = f.samples(c)[0]
    t = tr.t * c.rate
    out = {"omega": (t, tr.omega / c.rate)}
    if c.geometry == "couette":
        out["r"] = (t, c.r_star(tr.x, tr.y))
    else:
        h = c.h if c.h else c.geo().get("h", 1.0)
        out["y"] = (t, tr.y / h)
    return out


def common_values(f: fl.Figures, a: fl.Case, b: fl.Case, q: str):
    """(t*, values of a, values of b, how matched) on the sample times common to both, or None.
    Equal times (same steps) are matched directly; otherwise the denser series is interpolated linearly in
    t onto the sparser one's times within the common time range."""
    (ta, va), (tb, vb) = series(f, a)[q], series(f, b)[q]
    dts = [x.dt * x.rate for x in (a, b) if x.dt]
    return fl.match_common(ta, va, tb, vb, 1e-6 * min(dts) if dts else 1e-9)


# ---------------------------------------------------------------------------------------------- the table
QUANTITY = {"r": "r*", "y": "y/H", "omega": "ω*"}


def compare_rows(f: fl.Figures, g: Group) -> list[str]:
    cs = g.drawn(f)
    rows = []
    for coarse, fine in zip(cs, cs[1:]):
        for q in (("r", "omega") if g.geometry == "couette" else ("y", "omega")):
            m = common_values(f, coarse, fine, q)
            pair = f"{mesh_text(coarse)} → {mesh_text(fine)}"
            if m is None:
                rows.append(f"| {pair} | {QUANTITY[q]} | no common sample times | | | | | |")
                continue
            t, vc, vf, how = m
            d = np.abs(vc - vf)
            k = int(np.argmax(d))
            if q == "omega":
                ref, ref_text = float(np.max(np.abs(vf))), "max \\|ω*\\|"
            else:
                ref, ref_text = float(np.max(vf) - np.min(vf)), f"range of {QUANTITY[q]}"
            rel = f"{100 * d[k] / ref:.3g} %" if ref > 0 else "–"
            rows.append(f"| {pair} | {QUANTITY[q]} | {fl.fmt(t[0])}–{fl.fmt(t[-1])} ({len(t)}, {how}) | "
                        f"{d[k]:.4g} | {fl.fmt(t[k])} | {d[-1]:.4g} | {ref_text} = {ref:.4g} | {rel} |")
    return rows


def mesh_line(f: fl.Figures, g: Group, c: fl.Case) -> str:
    tr = f.samples(c).get(0)
    n = 0 if tr is None else len(tr.t)
    data = (f"{n} samples, t* = {fl.fmt(tr.t[0] * c.rate)}–{fl.fmt(tr.t[-1] * c.rate)}" if n
            else "no samples yet")
    tied = "".join(f", {leaf_text(c, p)}" for p in g.varying)
    state = c.status + (f", {fl.kind_text(c)}" if c.kind else "")
    return (f"- {mesh_text(c)} ({fl.fmt(elements(c))} elements{tied}): case {c.id} `{c.hash}`, {state}; {data}"
            + ("" if n >= 2 else " (not compared)"))


def table(f: fl.Figures, groups: list[Group], titles: list[str], message: str | None) -> None:
    lines = ["# Mesh convergence (like thesis Table 3.1, Figs. 3.18–3.19, 5.17)", "",
             f"Generated by plotting/mesh_convergence.py from `{f.db}` ({f.summary()}).", ""]
    if message:
        f.write_text(TABLE, "\n".join(md(ln) for ln in lines + [f"Nothing to compare yet: {message}.", ""]))
        return
    lines += [
        "Per set-up (all parameters equal but the mesh) and pair of consecutive meshes (sorted by element "
        "count), of particle 0: 'max |Δ|' is the largest absolute difference between the two meshes over "
        "their common sample times t* (equal times, or linear interpolation in t onto the sparser series' "
        "times when the sample times differ), 'at t*' where it occurs, '|Δ| at end' the difference at the "
        "last common time. 'relative' is max |Δ| divided by a reference value of the FINER mesh of the pair "
        "over the common times (column 'reference'): for positions (r*, y/H) the range max − min of its "
        "values (how far the particle moved), for ω* its largest |ω*|.",
        "",
        "Couette: r* = (r − R1)/(R2 − R1), ω* = ω/ω̄, t* = tω̄; confined shear: y/H, ω* = ω/γ̇, t* = tγ̇ "
        "(ω clockwise positive, as stored).",
        ""]
    for g, title in zip(groups, titles):
        lines += [f"## {GEOMETRY_TEXT[g.geometry]}: {title}", ""]
        lines += [mesh_line(f, g, c) for c in g.cases]
        lines += ["", "| meshes | quantity | common t* (samples) | max \\|Δ\\| | at t* | \\|Δ\\| at end | "
                      "reference (finer mesh) | relative |",
                  "| --- | --- | --- | ---: | ---: | ---: | --- | ---: |"]
        lines += compare_rows(f, g)
        lines.append("")
    f.write_text(TABLE, "\n".join(md(ln) for ln in lines))


def md(line: str) -> str:
    """Escapes the asterisks of r*, t*, ω* so that Markdown does not read them as emphasis."""
    return line.replace("*", "\\*")


# --------------------------------------------------------------------------------------------- the figure
def plot_row(f: fl.Figures, g: Group, row, sources: set) -> None:
    for i, c in enumerate(g.drawn(f)):
        label = mesh_text(c) + "".join(f", {leaf_text(c, p)}" for p in g.varying)
        label += f" ({fl.kind_text(c)})"
        kw = dict(color=f"C{i % 10}", lw=1.3, ls=fl.LINESTYLES[i % len(fl.LINESTYLES)])
        s = series(f, c)
        if g.geometry == "couette":
            rs = r_star_series(f, c)
            row[0].plot(*rs, label=label, **kw)
            row[1].plot(*s["omega"], **kw)
        else:
            tr = f.samples(c)[0]
            _, v, source = fl.velocities(c, tr)
            sources.add(source)
            row[0].plot(tr.t * c.rate, v / c.velocity_scale, label=label, **kw)
            row[1].plot(*s["omega"], **kw)
            row[2].plot(*s["y"], **kw)
    if g.geometry == "couette":
        shade_unreachable(row[0], g.cases)
        names = ("r* = (r − R1)/(R2 − R1)", "ω* = ω/ω̄ (clockwise +)")
        tname = "t* = t ω̄"
    else:
        names = ("V* = V/(Hγ̇)", "ω* = ω/γ̇ (clockwise +)", "y/H of particle 0")
        tname = "t* = tγ̇"
    for ax, q in zip(row, names):
        ax.set_ylabel(q)
        ax.set_xlabel(tname)
        ax.grid(alpha=0.3)
    if g.geometry == "couette":
        ys = np.concatenate([np.asarray(ln.get_ydata(), dtype=float) for ln in row[0].lines])
        ys = ys[np.isfinite(ys)]
        if len(ys):
            lo, hi = float(ys.min()), float(ys.max())
            pad = max(0.08 * (hi - lo), 0.01)
            row[0].set_ylim(max(lo - pad, 0.0), min(hi + pad, 1.0))
    for ax in row:
        fl.min_span(ax, 1e-3)
    row[0].legend(fontsize=7, loc="best")


def main(f: fl.Figures) -> None:
    all_cases = [c for geo in GEOMETRIES for c in f.cases(geo)]
    if not all_cases:
        msg = f"no Couette or confined-shear cases in the database ({MISSING_RUN})"
        f.empty(NAME, TITLE, msg)
        table(f, [], [], msg)
        return
    groups = mesh_groups(all_cases)
    multi = [g for g in groups if len({mesh_of(c) for c in g.cases}) >= 2]
    drawn = [g for g in multi if len({mesh_of(c) for c in g.drawn(f)}) >= 2]
    if not drawn:
        msg = f"no set-up run on two or more meshes ({len(groups)} set-ups, each on one mesh; {MISSING_RUN})"
        if multi:
            msg = (f"no set-up with samples on two or more meshes yet ({len(multi)} set-up(s) on several meshes, "
                   f"but fewer than two of their cases have samples: pending, running or failed)")
        f.empty(NAME, TITLE, msg)
        table(f, [], [], msg)
        return
    for g in drawn:
        left = [c for c in g.cases if c not in g.drawn(f)]
        if left:
            f.log(f"{NAME}: mesh(es) {', '.join(mesh_text(c) for c in left)} of a {GEOMETRY_TEXT[g.geometry]} "
                  "set-up have fewer than two samples (pending, running or failed) and are not drawn")
    if len(drawn) < len(multi):
        f.log(f"{NAME}: {len(multi) - len(drawn)} set-up(s) on several meshes have samples on fewer than two "
              "of them and are not drawn")
    drawn.sort(key=lambda g: (GEOMETRIES.index(g.geometry), -len(g.drawn(f)), g.cases[0].id))
    extra = extra_title_leaves(drawn)
    params = []
    for g in drawn:
        p = {"geometry": GEOMETRY_TEXT[g.geometry], **g.title_params()}
        p.update({e.split(".")[-1]: leaf_text(g.cases[0], e).split(" = ", 1)[1] for e in extra
                  if e not in g.varying and e in leaves(g.cases[0].params)})
        params.append(p)
    common, rest = fl.split_common(params)
    table(f, drawn, [fl.describe({k: v for k, v in p.items() if k != "geometry"}).replace("\n", " ")
                     for p in params], None)
    for page, items in fl.pages(list(zip(rest, drawn)), NAME, f.log, per=ROWS_PER_PAGE):
        cols = 3 if any(g.geometry == "confined_shear" for _, g in items) else 2
        fig, axes = plt.subplots(len(items), cols, figsize=(5.0 * cols, 3.0 * len(items) + 1.2), squeeze=False,
                                 layout="constrained")
        fig.get_layout_engine().set(rect=(0, 0.025, 1, 0.975))  # room for the footer
        sources: set = set()
        for row, (panel_params, g) in zip(axes, items):
            n = 2 if g.geometry == "couette" else 3
            for ax in row[n:]:
                ax.set_visible(False)
            plot_row(f, g, row[:n], sources)
            head = panel_params.pop("geometry", None)
            text = fl.describe(panel_params)
            row[0].set_title(": ".join(x for x in (head, text) if x) or "the set-up of the title", fontsize=9,
                             loc="left")
        src = f"  [{'; '.join(sorted(sources))}]" if sources else ""
        head = dict(common)
        geo = head.pop("geometry", None)
        fig.suptitle(f"{TITLE}\n{geo + ': ' if geo else ''}{fl.describe(head)}{src}", fontsize=11)
        f.save(fig, page)


if __name__ == "__main__":
    import make_figures

    make_figures.run_one(main)
