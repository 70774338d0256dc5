"""A rigid particle migrating in the extrusion flow out of a planar die into a free-surface extrudate (thesis
§6.5.3, Fig. 6.8): `extrusion_trajectories`, `extrusion_separation`, `extrusion_velocity` (`_p2`, ...) and
`tables/extrusion.md`.

Cases: geometry 'extrusion', one particle. The die is −L_w ≤ x ≤ 0 with its wall at y = H0, the extrudate
0 ≤ x ≤ L_fs with a free surface, y = 0 the symmetry line; U = Q/H0, t* = tU/H0, U* = U/U, ω* = ωH0/U
(clockwise positive, as stored), Wi = λU/H0. Cases are grouped into set-ups by all of `params_json` except
the curve parameters (Wi, the radius a and the start X0: one colour per combination in a set-up) and the
mesh; a `numerics.*`/`output.*` setting that takes one value per mesh within a set-up (e.g. Δt zipped with
the mesh) counts as part of the mesh, as in mesh_convergence.py, and is named in the legend. The meshes of a
set-up share the panels: the finest solid, coarser ones dotted, dash-dotted, ... (dashed is the particle's
top in the trajectories) in the colour of the curve.

- `extrusion_trajectories`: one panel per set-up (PANELS_PER_PAGE per page): the centre path y(x) (● start;
  at the end the outcome's marker, ○ for a run not done), the top of the path y + a thin dashed, the
  undisturbed steady surface H̄(x) grey (solid for the finest mesh, else in the mesh's line style; labelled
  with Wi when the panel has several), the die wall y = H0 for x ≤ 0 thick black and the symmetry line y = 0.
  The y axis is stretched against x (the paths move by tenths of H0 over L_w + L_fs).
- `extrusion_separation`: s = Y + a − H̄(X) (thesis Eq. 6.65) against the particle's x, panels as above; s = 0
  (the particle's top on the undisturbed surface) and the die exit x = 0 as thin lines. s are the stored
  samples; a case without them (an older run) gets s from its H̄ when one is known (the title says so).
- `extrusion_velocity`: one row per set-up (ROWS_PER_PAGE per page): U*_x, U*_y and ω* against t*; ◆ where
  the centre passes the die exit. U are the stored velocities or central differences of the positions
  (`figlib.velocities`, the title says which).

H̄ is `final_json.undisturbed_surface` (x, h on the surface's nodes from x = 0 to L_fs, swell = max H̄/H0).
A run not done has no outcome yet: it is drawn as far as its samples go, with the H̄ of a finished case of the
same fluid, geometry and mesh when there is one (else no surface).

The table lists per set-up and case: Wi, α, a, X0, mesh, Δt, status and outcome, the swell of H̄, s at the
first and last sample, x and t* at the end, and, for each mesh but the finest, the largest |ΔU*_x| against the
next finer mesh over their common sample times (equal times, else linear interpolation in t), absolute and
relative to the largest |U*_x| of the finer mesh there.

Inputs: cases (geometry 'extrusion', params_json) ⋈ outcomes (kind, final_json.undisturbed_surface,
separation); samples (t, x, y, u, v, omega, separation of particle 0).
Usage: python plotting/extrusion.py DB [OUT_DIR]
"""

from __future__ import annotations

import json
import textwrap

import matplotlib.pyplot as plt
import matplotlib.transforms as mtransforms
import numpy as np
from matplotlib.lines import Line2D

import figlib as fl
import mesh_convergence as mc

TRAJECTORIES = "extrusion_trajectories"
SEPARATION = "extrusion_separation"
VELOCITY = "extrusion_velocity"
TABLE = "tables/extrusion.md"
TITLES = {
    TRAJECTORIES: "A particle in extrusion flow: centre path y(x) and the undisturbed surface H̄ (thesis §6.5.3)",
    SEPARATION: "A particle in extrusion flow: separation s = Y + a − H̄(X) from the undisturbed surface "
                "(thesis Eq. 6.65)",
    VELOCITY: "A particle in extrusion flow: U*_x, U*_y and ω* against t* (thesis Fig. 6.8)",
}
#: Panels per page of the trajectory and separation figures (one set-up each).
PANELS_PER_PAGE = 4
#: Set-ups (rows of three panels) per page of the velocity figure.
ROWS_PER_PAGE = 3
#: Leaves of params_json that tell the curves of a set-up apart (one colour per combination), with the start.
CURVE_LEAVES = ("fluid.wi", "particles.radius")
START_PREFIX = "particles.layout."
#: Geometry leaves the titles name as H0, L_w, L_fs, Q (others that differ between set-ups are added).
GEOMETRY_TITLED = {"h0": "H0", "die_length": "L_w", "extrudate_length": "L_fs", "flow_rate": "Q"}
#: Line styles of the meshes, finest first; no dashes: dashed is the particle's top in the trajectories.
MESH_STYLES = ["-", ":", "-.", (0, (6, 2, 1, 2, 1, 2))]
#: Longest legend line (characters) before it wraps.
LEGEND_WIDTH = 45
MISSING_RUN = "run sweeps/extrusion_mesh.toml or sweeps/extrusion_particle.toml"


# ------------------------------------------------------------------------------------------------ grouping
def is_curve(path: str) -> bool:
    return path in CURVE_LEAVES or path.startswith(START_PREFIX)


def start_of(c: fl.Case) -> tuple:
    p = c.initial_positions()
    return tuple(fl.rounded(float(v)) for v in p[0]) if p else (None, None)


def curve_key(c: fl.Case) -> tuple:
    return fl.rounded(c.wi), fl.rounded(c.a), start_of(c)


# the mesh height above the symmetry line in units of H0 when `geometry.extrusion.height` is not given
# (src/config/case.rs, DEFAULT_EXTRUSION_HEIGHT)
DEFAULT_HEIGHT = 2.0


def geo_value(c: fl.Case, k: str) -> float:
    return float(c.geo().get(k, 1.0 if k in ("h0", "flow_rate") else 0.0))


class SetUp:
    """One set-up: its cases over curves (Wi, a, X0) and meshes, the meshes (coarse → fine), the curve keys
    and the mesh-tied settings that differ between the meshes."""

    def __init__(self, cases: list[fl.Case], tied: list[str]):
        self.cases = sorted(cases, key=lambda c: (fl.sort_key(c.wi), fl.sort_key(c.a),
                                                  tuple(map(fl.sort_key, start_of(c))), mc.elements(c), c.id))
        self.meshes = list({mc.mesh_of(c): c for c in sorted(cases, key=mc.elements)})
        self.curves = list(dict.fromkeys(curve_key(c) for c in self.cases))
        self.varying = [p for p in tied if len({mc.leaves(c.params).get(p) for c in cases}) > 1]

    def colour(self, c: fl.Case) -> str:
        return f"C{self.curves.index(curve_key(c)) % 10}"

    def style(self, c: fl.Case):
        return MESH_STYLES[(len(self.meshes) - 1 - self.meshes.index(mc.mesh_of(c))) % len(MESH_STYLES)]

    def mesh_label(self, mesh: tuple) -> str:
        c = next(c for c in self.cases if mc.mesh_of(c) == mesh)
        return mc.mesh_text(c) + "".join(f", {mc.leaf_text(c, p)}" for p in self.varying)

    def title_params(self) -> dict:
        c = self.cases[0]
        p = {"model": c.model, "alpha": fl.rounded(c.alpha), "beta": fl.rounded(c.beta)}
        p.update({name: fl.rounded(geo_value(c, k)) for k, name in GEOMETRY_TITLED.items()})
        if "numerics.dt" not in self.varying:
            p["dt"] = fl.rounded(c.dt)
        return p


def setups(cases: list[fl.Case]) -> list[SetUp]:
    """Groups by all parameters but the curve parameters and the mesh; settings tied to the mesh do not
    split (mesh_convergence.split_by_parameters)."""
    return [SetUp(sub, tied) for sub, tied in mc.split_by_parameters(cases, is_curve)]


def curve_names(groups: list[SetUp]) -> list[str]:
    """The curve parameters ('wi', 'a', 'start') that take more than one value among the cases drawn."""
    cs = [c for g in groups for c in g.cases]
    return [n for i, n in enumerate(("wi", "a", "start")) if len({curve_key(c)[i] for c in cs}) > 1]


def curve_params(c: fl.Case, names) -> dict:
    out = {"wi": fl.rounded(c.wi), "a": fl.rounded(c.a), "X0": "({}, {})".format(*map(fl.fmt, start_of(c)))}
    return {k: v for k, v in out.items() if (k if k != "X0" else "start") in names}


def panel_titles(groups: list[SetUp], names: list[str]) -> list[dict]:
    """Title parameters per set-up: the set-up's, the curve parameters common to all cases, and the leaves
    (not the curve, not the mesh) that tell set-ups apart."""
    extra = [p for p in mc.differing_leaves(groups) if not is_curve(p) and p != "numerics.remap"
             and p.split(".")[-1] not in GEOMETRY_TITLED]
    common = [n for n in ("wi", "a", "start") if n not in names]
    out = []
    for g in groups:
        c = g.cases[0]
        p = {**curve_params(c, common), **g.title_params()}
        p.update({e.split(".")[-1]: mc.leaf_text(c, e).split(" = ", 1)[1] for e in extra
                  if e not in g.varying and e in mc.leaves(c.params)})
        out.append(p)
    return out


# ------------------------------------------------------------------------------------ undisturbed surface
def own_surface(c: fl.Case):
    """(x, H̄, swell) from the case's final_json, or None."""
    us = c.final.get("undisturbed_surface") or {}
    x, h = np.asarray(us.get("x", []), dtype=float), np.asarray(us.get("h", []), dtype=float)
    if len(x) < 2 or len(x) != len(h):
        return None
    swell = us.get("swell")
    return x, h, float(swell) if swell is not None else float(np.max(h)) / geo_value(c, "h0")


class Surfaces:
    """H̄ per case: its own, else that of a finished case with the same fluid, geometry and mesh."""

    def __init__(self, cases: list[fl.Case]):
        self.by_key: dict = {}
        for c in cases:
            s = own_surface(c)
            if s is not None:
                self.by_key.setdefault(self.key(c), (s, c))

    @staticmethod
    def key(c: fl.Case) -> str:
        return json.dumps([c.params.get("fluid"), c.params.get("geometry"), mc.mesh_of(c)], sort_keys=True)

    def of(self, c: fl.Case):
        """((x, H̄, swell), donor case or None when it is the case's own) or None."""
        s = own_surface(c)
        if s is not None:
            return s, None
        return self.by_key.get(self.key(c))


def h_bar(c: fl.Case, surface, x: np.ndarray) -> np.ndarray:
    """H̄(x): H0 in the die (x ≤ 0), the surface interpolated beyond."""
    xs, hs, _ = surface
    return np.where(x <= 0, geo_value(c, "h0"), np.interp(x, xs, hs))


# ------------------------------------------------------------------------------------------------- series
class Series:
    """Particle 0 of one case from its samples with finite t, x, y: t*, x, y, U*_x, U*_y, ω* and s."""

    def __init__(self, f: fl.Figures, c: fl.Case, surfaces: Surfaces):
        tr = f.samples(c).get(0)
        self.source, self.s_computed = None, False
        if tr is not None:
            keep = np.isfinite(tr.t) & np.isfinite(tr.x) & np.isfinite(tr.y)
            # a diverged run's last samples can leave the fluid (x ≈ 1e24): drawn up to the first that does
            h0 = geo_value(c, "h0")
            top = c.geo().get("height") or DEFAULT_HEIGHT * h0
            outside = ~((tr.x >= -geo_value(c, "die_length")) & (tr.x <= geo_value(c, "extrudate_length"))
                        & (tr.y >= 0) & (tr.y <= top) & ((tr.x >= 0) | (tr.y <= h0)))
            left = np.nonzero(outside & keep)[0]
            if len(left):
                keep &= np.arange(len(keep)) < left[0]
            sep = tr.separation if tr.separation is not None else np.full(len(tr.t), np.nan)
            tr = fl.Track(*(getattr(tr, k)[keep] for k in ("t", "x", "y", "u", "v", "omega", "theta")), sep[keep])
        if tr is None or len(tr.t) == 0:
            self.t = self.x = self.y = self.u = self.v = self.omega = self.s = np.array([])
            return
        u, v, self.source = fl.velocities(c, tr)
        self.t, self.x, self.y = tr.t * c.rate, tr.x, tr.y
        self.u, self.v, self.omega = u / c.velocity_scale, v / c.velocity_scale, tr.omega / c.rate
        self.s = tr.separation
        surface = surfaces.of(c)
        if not np.isfinite(self.s).any() and surface is not None and c.a is not None:
            self.s, self.s_computed = self.y + c.a - h_bar(c, surface[0], self.x), True

    def __len__(self) -> int:
        return len(self.t)

    def exit_index(self) -> int | None:
        """The first sample with the centre at or past the die exit x = 0 (None if it never gets there)."""
        i = np.nonzero(self.x >= 0)[0]
        return int(i[0]) if len(i) else None


def finite_first_last(v: np.ndarray):
    ok = np.isfinite(v)
    return (float(v[ok][0]), float(v[ok][-1])) if ok.any() else (float("nan"), float("nan"))


# ---------------------------------------------------------------------------------------------- drawing
def end_marker(ax, g: SetUp, c: fl.Case, x, y) -> None:
    """The outcome's marker at the end of a finished run, ○ at the end of a run not done."""
    if c.status != "done" or not c.kind:
        ax.plot(x, y, "o", mfc="none", mec=g.colour(c), ms=6, zorder=6)
    else:
        ax.plot(x, y, fl.KIND_STYLE.get(c.kind, fl.KIND_STYLE[None])[0], color=g.colour(c), ms=7, zorder=6)


def legend(ax, f: fl.Figures, g: SetUp, names: list[str], surfaces: Surfaces, extra: list) -> None:
    """Colours (curves), line styles (meshes), markers (outcomes) and the figure's own lines, outside right."""
    drawn = [c for c in g.cases if len(Series(f, c, surfaces)) >= 2]
    handles = []
    if names:
        handles += [Line2D([], [], color=g.colour(c), lw=2, label=fl.describe(curve_params(c, names)))
                    for c in dict((curve_key(c), c) for c in drawn).values()]
    meshes = [m for m in g.meshes if any(mc.mesh_of(c) == m for c in drawn)]
    handles += [Line2D([], [], color="0.2", ls=g.style(next(c for c in drawn if mc.mesh_of(c) == m)),
                       label=f"mesh {g.mesh_label(m)}") for m in reversed(meshes)]
    left = [c for c in g.cases if c not in drawn]
    if left:
        # per mesh: 'no samples yet: 210×48: Wi = 0.1; Wi = 0.2', wrapped (a long line squeezes the panel)
        text = "; ".join(f"{mc.mesh_text(cs[0])}" + (": " + ", ".join(fl.describe(curve_params(c, names)) for c in cs)
                                                   if names else "")
                         for _, cs in fl.group(left, key=mc.mesh_of))
        handles.append(Line2D([], [], ls="none", label=textwrap.fill(f"no samples yet: {text}", LEGEND_WIDTH)))
    for kind in dict.fromkeys(c.kind for c in drawn if c.status == "done" and c.kind):
        m, _, text = fl.KIND_STYLE.get(kind, fl.KIND_STYLE[None])
        handles.append(Line2D([], [], ls="none", marker=m, color="0.3", label=f"end: {text}"))
    if any(c.status != "done" or not c.kind for c in drawn):
        handles.append(Line2D([], [], ls="none", marker="o", mfc="none", mec="0.3", label="end of a run not done"))
    ax.legend(handles=handles + extra, fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0)


def draw_trajectories(ax, f: fl.Figures, g: SetUp, names, surfaces: Surfaces) -> None:
    c0 = g.cases[0]
    h0, lw, lfs = (geo_value(c0, k) for k in ("h0", "die_length", "extrudate_length"))
    tops = [h0]
    # H̄ once per fluid and mesh, grey in the mesh's line style; labelled with Wi when Wi differs in the panel
    shown: dict = {}
    for c in g.cases:
        s = surfaces.of(c)
        if s is not None:
            shown.setdefault(Surfaces.key(c), (s[0], c))
    several = len({fl.rounded(c.wi) for _, c in shown.values()}) > 1
    for (xs, hs, _), c in shown.values():
        ax.plot(xs, hs, color="0.55", lw=1.2, ls=g.style(c))
        tops.append(float(np.max(hs)))
        if several:
            k = int(0.8 * (len(xs) - 1))
            ax.annotate(f"Wi = {fl.fmt(c.wi)}", (xs[k], hs[k]), xytext=(0, 2), textcoords="offset points",
                        fontsize=7, color="0.4", ha="center", va="bottom")
    for c in g.cases:
        s = Series(f, c, surfaces)
        if len(s) < 2:
            continue
        col = g.colour(c)
        ax.plot(s.x, s.y, color=col, ls=g.style(c), lw=1.4 if g.style(c) == "-" else 1.1)
        if c.a:
            ax.plot(s.x, s.y + c.a, color=col, ls="--", lw=0.8)
            tops.append(float(np.max(s.y + c.a)))
        ax.plot(s.x[0], s.y[0], "o", color=col, ms=4, zorder=5)
        end_marker(ax, g, c, s.x[-1], s.y[-1])
    ax.plot([-lw, 0.0], [h0, h0], color="black", lw=3, solid_capstyle="butt")
    ax.axhline(0.0, color="0.4", lw=0.8, ls=(0, (8, 3, 1, 3)))
    ax.set_xlim(-lw, lfs)
    top = max(tops)
    ax.set_ylim(-0.03 * top, 1.08 * top)
    ax.set_xlabel("x")
    ax.set_ylabel("y")
    ax.grid(alpha=0.3)
    no_surface = list(dict.fromkeys(mc.mesh_text(c) for c in g.cases
                                    if surfaces.of(c) is None and len(Series(f, c, surfaces)) >= 2))
    extra = [Line2D([], [], color="0.55", lw=1.2, label="undisturbed surface H̄(x) (the mesh's style)")] if shown else []
    if no_surface:
        extra.append(Line2D([], [], ls="none", label=f"no H̄ known for {', '.join(no_surface)}"))
    extra += [Line2D([], [], color="black", lw=3, label="die wall y = H0"),
             Line2D([], [], color="0.4", lw=0.8, ls=(0, (8, 3, 1, 3)), label="symmetry line y = 0"),
             Line2D([], [], color="0.3", lw=0.8, ls="--", label="top of the path y + a"),
             Line2D([], [], ls="none", marker="o", color="0.3", ms=4, label="start")]
    legend(ax, f, g, names, surfaces, extra)


def region_labels(ax) -> None:
    """'die' and 'extrudate' at the top of the axes, either side of x = 0."""
    tr = mtransforms.blended_transform_factory(ax.transData, ax.transAxes)
    ax.text(-0.05, 0.97, "die ", transform=tr, ha="right", va="top", fontsize=7, color="0.35")
    ax.text(0.05, 0.97, " extrudate", transform=tr, ha="left", va="top", fontsize=7, color="0.35")


def draw_separation(ax, f: fl.Figures, g: SetUp, names, surfaces: Surfaces) -> bool:
    """Returns whether some s were computed from H̄ (not stored)."""
    computed = False
    c0 = g.cases[0]
    for c in g.cases:
        s = Series(f, c, surfaces)
        ok = np.isfinite(s.s)
        if ok.sum() < 2:
            continue
        computed |= s.s_computed
        col = g.colour(c)
        ax.plot(s.x[ok], s.s[ok], color=col, ls=g.style(c), lw=1.4 if g.style(c) == "-" else 1.1)
        ax.plot(s.x[ok][0], s.s[ok][0], "o", color=col, ms=4, zorder=5)
        end_marker(ax, g, c, s.x[ok][-1], s.s[ok][-1])
    ax.axhline(0.0, color="0.3", lw=0.8)
    ax.axvline(0.0, color="0.3", lw=0.8)
    ax.set_xlim(-geo_value(c0, "die_length"), geo_value(c0, "extrudate_length"))
    region_labels(ax)
    ax.set_xlabel("x (particle centre)")
    ax.set_ylabel("s = Y + a − H̄(X)")
    ax.grid(alpha=0.3)
    fl.min_span(ax, 0.05)
    extra = [Line2D([], [], color="0.3", lw=0.8, label="s = 0: top on H̄; x = 0: die exit"),
             Line2D([], [], ls="none", marker="o", color="0.3", ms=4, label="start")]
    legend(ax, f, g, names, surfaces, extra)
    return computed


def draw_velocity_row(row, f: fl.Figures, g: SetUp, names, surfaces: Surfaces, sources: set) -> None:
    for c in g.cases:
        s = Series(f, c, surfaces)
        if len(s) < 2:
            continue
        sources.add(s.source)
        kw = dict(color=g.colour(c), ls=g.style(c), lw=1.3 if g.style(c) == "-" else 1.0)
        i = s.exit_index()
        for ax, q in zip(row, (s.u, s.v, s.omega)):
            ax.plot(s.t, q, **kw)
            if i is not None and i > 0:
                ax.plot(s.t[i], q[i], "D", color=g.colour(c), ms=4, zorder=5)
            end_marker(ax, g, c, s.t[-1], q[-1])
    for ax, q in zip(row, ("U*_x = U_x/U", "U*_y = U_y/U", "ω* = ωH0/U (clockwise +)")):
        ax.set_ylabel(q)
        ax.set_xlabel("t* = tU/H0")
        ax.grid(alpha=0.3)
        fl.min_span(ax, 0.02)
    row[1].axhline(0.0, color="0.5", lw=0.7)
    row[2].axhline(0.0, color="0.5", lw=0.7)
    legend(row[2], f, g, names, surfaces,
           [Line2D([], [], ls="none", marker="D", color="0.3", ms=4, label="centre at the die exit x = 0")])


# ---------------------------------------------------------------------------------------------- the table
def state(c: fl.Case) -> str:
    return c.status + (f", {fl.kind_text(c)}" if c.kind else "")


def swell_text(c: fl.Case, surfaces: Surfaces) -> str:
    s = surfaces.of(c)
    if s is None:
        return "–"
    return f"{s[0][2]:.4f}" + (f" (case {s[1].id})" if s[1] is not None else "")


def compare(f: fl.Figures, c: fl.Case, finer: fl.Case, surfaces: Surfaces) -> list[str]:
    """[finer mesh, common t* (samples, how), max |ΔU*_x|, relative] against the next finer mesh."""
    a, b = Series(f, c, surfaces), Series(f, finer, surfaces)
    dts = [x.dt * x.rate for x in (c, finer) if x.dt]
    # sample times closer than a millionth of a step are the same time
    m = fl.match_common(a.t, a.u, b.t, b.u, 1e-6 * min(dts) if dts else 1e-9)
    if m is None:
        return [mc.mesh_text(finer), "no common sample times", "", ""]
    t, ua, ub, how = m
    d = float(np.max(np.abs(ua - ub)))
    ref = float(np.max(np.abs(ub)))
    rel = f"{100 * d / ref:.3g} %" if ref > 0 else "–"
    return [mc.mesh_text(finer), f"{fl.fmt(t[0])}–{fl.fmt(t[-1])} ({len(t)}, {how})", f"{d:.3e}", rel]


def table_rows(f: fl.Figures, g: SetUp, surfaces: Surfaces) -> list[str]:
    rows = []
    for key in g.curves:
        cs = [c for c in g.cases if curve_key(c) == key]  # coarse → fine
        drawn = [c for c in cs if len(Series(f, c, surfaces)) >= 2]
        for c in cs:
            s = Series(f, c, surfaces)
            head = (f"| {fl.fmt(c.wi)} | {fl.fmt(c.alpha)} | {fl.fmt(c.a)} | ({', '.join(map(fl.fmt, start_of(c)))})"
                    f" | {mc.mesh_text(c)} | {fl.fmt(c.dt)} | {c.id} | {state(c)} | {len(s)} | "
                    f"{swell_text(c, surfaces)} |")
            if len(s) == 0:
                rows.append(head + " no samples yet |" + " |" * 7)
                continue
            s0, s1 = finite_first_last(s.s)
            fin = c.final.get("separation") or []
            # (unless the final state left the fluid: a diverged run, drawn to its last sample inside)
            if fin and fin[0] is not None and abs(float(fin[0])) <= geo_value(c, "h0"):
                s1 = float(fin[0])
            mark = " (from H̄)" if s.s_computed else ""
            cells = [f"{s0:+.4f}{mark}" if np.isfinite(s0) else "–", f"{s1:+.4f}{mark}" if np.isfinite(s1) else "–",
                     f"{s.x[-1]:.4g}", fl.fmt(s.t[-1])]
            finer = drawn[drawn.index(c) + 1] if c in drawn and c is not drawn[-1] else None
            cells += ["–", "", "", ""] if finer is None else compare(f, c, finer, surfaces)
            rows.append(head + " " + " | ".join(cells) + " |")
    return rows


def table(f: fl.Figures, groups: list[SetUp], titles: list[str], surfaces: Surfaces | None,
          message: str | None) -> None:
    lines = ["# A particle in extrusion flow (thesis §6.5.3, Fig. 6.8)", "",
             f"Generated by plotting/extrusion.py from `{f.db}` ({f.summary()}).", ""]
    if message:
        f.write_text(TABLE, "\n".join(mc.md(ln) for ln in lines + [f"Nothing to show yet: {message}.", ""]))
        return
    lines += [
        "Per set-up, curve (Wi, a, start X0) and mesh, of the particle: U = Q/H0, t* = tU/H0, U*_x = U_x/U. "
        "'swell' is max H̄/H0 of the undisturbed steady surface H̄ the case computed (or, for a run without an "
        "outcome yet, of the finished case named, with the same fluid, geometry and mesh). s = Y + a − H̄(X) "
        "(thesis Eq. 6.65: s < 0 with the particle's top below H̄; H̄ = H0 in the die) at the first sample and "
        "at the end (the outcome's, else the last sample; '(from H̄)': computed from the positions and H̄, "
        "the run stored none). 'x', 't*' are those of the last sample (unfinished runs: as far as they go). "
        "For each mesh but the finest, the last columns compare it with the next finer mesh of the same curve: "
        "the largest |ΔU*_x| over their common sample times (equal times, or linear interpolation in t onto "
        "the sparser series' times) and that divided by the largest |U*_x| of the finer mesh there.",
        ""]
    for g, title in zip(groups, titles):
        lines += [f"## {title}", "",
                  "| Wi | α | a | X0 | mesh | Δt | case | status | samples | swell | s first | s end | x end | "
                  "t* end | vs finer mesh | common t* (samples) | max \\|ΔU*_x\\| | relative |",
                  "| ---: | ---: | ---: | --- | --- | ---: | ---: | --- | ---: | --- | ---: | ---: | ---: | ---: | "
                  "--- | --- | ---: | ---: |"]
        lines += table_rows(f, g, surfaces)
        lines.append("")
    f.write_text(TABLE, "\n".join(mc.md(ln) for ln in lines))


# --------------------------------------------------------------------------------------------- the figures
def panel_figures(f: fl.Figures, name: str, items, names, surfaces: Surfaces, draw, note: str) -> None:
    common, rest = fl.split_common([p for p, _ in items])
    for page, chunk in fl.pages(list(zip(rest, [g for _, g in items])), name, f.log, per=PANELS_PER_PAGE):
        fig, axes = fl.panel_grid(len(chunk), width=11.0, height=3.6, max_cols=1)
        fig.get_layout_engine().set(rect=(0, 0.025, 1, 0.975))  # room for the footer
        computed = False
        for ax, (panel_params, g) in zip(axes, chunk):
            computed |= bool(draw(ax, f, g, names, surfaces))
            ax.set_title(fl.describe(panel_params) or "the set-up of the title", fontsize=9, loc="left")
        extra = "; s computed from H̄ (not stored) for some cases" if computed else ""
        fig.suptitle(f"{TITLES[name]}\n{fl.describe(common)}\n{note}{extra}", fontsize=10)
        f.save(fig, page)


def main(f: fl.Figures) -> None:
    cases = [c for c in f.cases("extrusion") if len(c.initial_positions()) == 1]
    if not cases:
        msg = f"no extrusion case with one particle in the database ({MISSING_RUN})"
        for name, title in TITLES.items():
            f.empty(name, title, msg)
        table(f, [], [], None, msg)
        return
    surfaces = Surfaces(f.cases("extrusion"))
    groups = setups(cases)
    groups.sort(key=lambda g: (-len(g.curves), -len(g.meshes), g.cases[0].id))
    names = curve_names(groups)
    params = panel_titles(groups, names)
    table(f, groups, [fl.describe(p).replace("\n", " ") for p in params], surfaces, None)
    with_samples = [c for c in cases if len(Series(f, c, surfaces)) >= 2]
    if not with_samples:
        msg = (f"none of the {len(cases)} extrusion cases has two or more samples yet (pending, running or "
               "failed)")
        for name, title in TITLES.items():
            f.empty(name, title, msg)
        return
    if len(with_samples) < len(cases):
        f.log(f"extrusion: {len(cases) - len(with_samples)} of {len(cases)} extrusion cases have fewer than two "
              "samples (pending or failed) and are not drawn")
    items = [(p, g) for p, g in zip(params, groups) if any(c in with_samples for c in g.cases)]
    scaled = "U = Q/H0"
    panel_figures(f, TRAJECTORIES, items, names, surfaces, draw_trajectories,
                  "y exaggerated against x; ● start, marker at the end: the outcome")
    with_s = [(p, g) for p, g in items if any(np.isfinite(Series(f, c, surfaces).s).sum() >= 2 for c in g.cases)]
    if with_s:
        if len(with_s) < len(items):
            f.log(f"{SEPARATION}: {len(items) - len(with_s)} set-up(s) have neither stored separations nor a known "
                  "H̄ and are not drawn")
        panel_figures(f, SEPARATION, with_s, names, surfaces, draw_separation,
                      "s < 0: the particle's top below the undisturbed steady surface H̄ (H̄ = H0 in the die)")
    else:
        f.empty(SEPARATION, TITLES[SEPARATION], "no case has stored separations or a known undisturbed surface "
                "H̄ to compute them from (runs older than samples.separation; re-run them)")
    common, rest = fl.split_common([p for p, _ in items])
    for page, chunk in fl.pages(list(zip(rest, [g for _, g in items])), VELOCITY, f.log, per=ROWS_PER_PAGE):
        fig, axes = plt.subplots(len(chunk), 3, figsize=(15, 3.4 * len(chunk) + 1.3), squeeze=False,
                                 layout="constrained")
        fig.get_layout_engine().set(rect=(0, 0.025, 1, 0.975))  # room for the footer
        sources: set = set()
        for row, (panel_params, g) in zip(axes, chunk):
            draw_velocity_row(row, f, g, names, surfaces, sources)
            row[0].set_title(fl.describe(panel_params) or "the set-up of the title", fontsize=9, loc="left")
        src = f"  [{'; '.join(sorted(sources))}]" if sources else ""
        fig.suptitle(f"{TITLES[VELOCITY]}\n{fl.describe(common)}; {scaled}{src}", fontsize=10)
        f.save(fig, page)


if __name__ == "__main__":
    import make_figures

    make_figures.run_one(main)
