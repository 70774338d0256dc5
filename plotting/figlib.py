"""Shared helpers of the xpflow figure scripts.

Reads a results database (schema in src/store/schema.rs, documented in docs/sweeps.md) with the standard
sqlite3 module, turns stored quantities into the thesis' dimensionless ones, groups cases into families
(curves that differ in one parameter, drawn in one panel), and saves figures as PNG + PDF. Every figure
function takes a `Figures` context (database, output directory, log) and never raises for missing data: it
prints what is missing and, when nothing can be drawn, writes no figure and lists it as missing in index.md.

Scalings (thesis):
  confined shear (5.6-5.7): γ̇ = U_w/H, t* = tγ̇, U* = U/(Hγ̇), V* = V/(Hγ̇), ω* = ω/γ̇ (clockwise positive).
  Couette (3.5):            t* = tω̄, ω* = ω/ω̄, r* = (r − R1)/(R2 − R1), radial velocity dr*/dt*.
  extrusion (6.5):          U = Q/H0, t* = tU/H0, U* = U/U, ω* = ωH0/U (clockwise positive), Wi = λU/H0.
"""

from __future__ import annotations

import glob
import json
import math
import textwrap
import os
import sqlite3
import urllib.parse
from dataclasses import dataclass, field
from fractions import Fraction

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

#: Panels per page of a multi-panel figure; further groups go to `<name>_p2`, `<name>_p3`, ...
MAX_PANELS = 12
#: Pages per figure; groups beyond MAX_PANELS × MAX_PAGES are left out (and the log says how many).
MAX_PAGES = 5
#: Resolution of the PNG files.
DPI = 150

#: Line styles cycled within a family, so that curves lying on top of each other stay visible.
LINESTYLES = ["-", "--", ":", "-."]
#: Marker, colour and legend text per outcome kind (regime map, legends).
KIND_STYLE = {
    "pass": (">", "tab:blue", "pass"),
    "repel": ("x", "tab:red", "repel"),
    "string": ("o", "tab:green", "string"),
    "jammed": ("s", "black", "jammed"),
    "wall_contact": ("^", "tab:purple", "wall contact"),
    "surface_contact": ("<", "tab:pink", "surface contact"),
    "exited": ("h", "tab:brown", "reached the outflow"),
    "steady": ("D", "tab:olive", "steady"),
    "migrated": ("v", "tab:cyan", "migrated"),
    "timeout": ("P", "tab:gray", "timeout (undecided)"),
    "diverged": ("*", "tab:orange", "diverged"),
    None: (".", "lightgray", "no outcome (pending / failed)"),
}


# ----------------------------------------------------------------------------------------------- formatting
def wrap_titles(fig) -> None:
    """Wraps each line of the figure's suptitle and of the panel titles to the width they have
    (long parameter lists ran off the edges); the constrained layout makes room for the extra
    lines."""
    def wrap(title, inches: float) -> None:
        # characters per line: the width over an average glyph width of ~0.55 em
        width = max(30, int(inches * 72 / (0.55 * title.get_fontsize())))
        lines = title.get_text().split("\n")
        title.set_text("\n".join(textwrap.fill(line, width) for line in lines))

    if getattr(fig, "_suptitle", None) is not None:
        wrap(fig._suptitle, fig.get_figwidth())
    for ax in fig.axes:
        if ax.get_title():
            wrap(ax.title, ax.get_position().width * fig.get_figwidth())



def fmt(v) -> str:
    """A parameter value as the thesis writes it: 1/3, 4/15, 0.01, 2."""
    if v is None:
        return "–"
    if isinstance(v, str):
        return v
    if isinstance(v, dict):
        # a nested setting (numerics.follow = {ratio, reach, ...}): '(ratio 2, reach 12)'
        return "(" + ", ".join(f"{k} {fmt(x)}" for k, x in sorted(v.items())) + ")"
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    v = float(v)
    if not math.isfinite(v):
        return str(v)
    if abs(v - round(v)) < 1e-9:
        return str(int(round(v)))
    fr = Fraction(v).limit_denominator(30)
    if fr.denominator in (3, 6, 7, 9, 11, 12, 13, 15, 30) and abs(float(fr) - v) < 1e-9:
        return f"{fr.numerator}/{fr.denominator}"
    return f"{v:.4g}"


#: Display names of parameters in titles and legends.
SYMBOL = {
    "wi": "Wi", "alpha": "α", "beta": "β", "delta": "δ", "n": "N", "a": "a", "h": "H", "l": "L",
    "lx": "l_x", "ly": "l_y", "r0": "r0*", "eps": "ε", "ratio": "R2/R1", "mesh": "mesh", "dt": "Δt", "step": "Δt",
    "model": "model", "string_length": "N",
}


#: Longest line of a parameter description before it wraps (titles are centred: longer lines are
#: clipped at the figure edges).
DESCRIBE_WIDTH = 80


def describe(params: dict) -> str:
    """'Wi = 1, α = 0.01, ...' for the given (name → value) pairs, skipping None, wrapped to
    DESCRIBE_WIDTH characters per line."""
    parts = [f"{SYMBOL.get(k, k)} = {fmt(v)}" for k, v in params.items() if v is not None]
    lines, cur = [], ""
    for p in parts:
        cand = f"{cur}, {p}" if cur else p
        if cur and len(cand) > DESCRIBE_WIDTH:
            lines.append(cur + ",")
            cur = p
        else:
            cur = cand
    if cur:
        lines.append(cur)
    return "\n".join(lines)


# -------------------------------------------------------------------------------------------------- cases
@dataclass
class Case:
    """One row of `cases` joined with its outcome, plus the geometry from `params_json`."""

    id: int
    hash: str
    label: str
    geometry: str
    status: str
    params: dict
    wi: float | None
    alpha: float | None
    beta: float | None
    delta: float | None
    n: int | None
    a: float | None
    h: float | None
    l: float | None
    lx: float | None
    ly: float | None
    r0: float | None
    eps: float | None
    mesh: str | None
    dt: float | None
    kind: str | None
    string_length: int | None
    t_decided: float | None
    mean_gap: float | None
    final: dict
    error: str | None
    sweeps: str = ""
    _samples: dict | None = field(default=None, repr=False)

    # -- geometry from params_json
    def geo(self) -> dict:
        g = self.params.get("geometry", {})
        return next(iter(g.values()), {}) if isinstance(g, dict) else {}

    @property
    def settings(self) -> str | None:
        """The numerical settings beyond mesh and Δt that tell set-ups apart ('grading_x 3, remap
        bicubic'), or None: cases that differ only in these must not share a panel."""
        n = self.params.get("numerics", {})
        skip = {"mesh", "dt", "t_end", "quadtree_level", "grid_deformation"}
        parts = [f"{k} {self.frame_text() if k == 'frame_velocity' else fmt(v)}" for k, v in sorted(n.items())
                 if k not in skip and not (k == "grading" and v == 1)]
        return ", ".join(parts) or None

    @property
    def step(self):
        """The time step as titles give it: Δt of a fixed step, 'max M (adaptive)' for an
        error-controlled one (whose `dt` column holds only its initial step)."""
        dt = self.params.get("numerics", {}).get("dt")
        if isinstance(dt, dict):
            return f"max {fmt(dt.get('max'))} (adaptive)"
        return self.dt

    def frame_text(self) -> str:
        """numerics.frame_velocity as text: 'of the fluid at the start' when it is the undisturbed shear
        velocity γ̇·y at the first particle's start height (the single-particle sweeps zip the two, so such
        starts share a set-up), else its value."""
        v = self.params.get("numerics", {}).get("frame_velocity", 0.0)
        start = self.initial_positions()
        if self.geometry == "confined_shear" and start and math.isclose(v, self.rate * start[0][1], abs_tol=1e-12):
            return "of the fluid at the start"
        return fmt(v)

    @property
    def model(self) -> str:
        return self.params.get("fluid", {}).get("model", "?")

    @property
    def rate(self) -> float:
        """γ̇ = U_w/H (shear), ω̄ (Couette: the thesis' t* = tω̄) or U/H0 = Q/H0² (extrusion); 1 otherwise."""
        g = self.geo()
        if self.geometry == "confined_shear":
            return g.get("wall_speed", 1.0) / g["h"]
        if self.geometry == "couette":
            return g.get("omega_inner", 1.0)
        if self.geometry == "extrusion":
            return g.get("flow_rate", 1.0) / g.get("h0", 1.0) ** 2
        return 1.0

    @property
    def velocity_scale(self) -> float:
        """Hγ̇ = U_w (shear), (R2 − R1)ω̄ (Couette), U = Q/H0 (extrusion: the mean velocity in the die)."""
        g = self.geo()
        if self.geometry == "confined_shear":
            return g.get("wall_speed", 1.0)
        if self.geometry == "couette":
            return (g["r2"] - g["r1"]) * g.get("omega_inner", 1.0)
        if self.geometry == "extrusion":
            return g.get("flow_rate", 1.0) / g.get("h0", 1.0)
        return 1.0

    @property
    def ratio(self) -> float | None:
        g = self.geo()
        return g["r2"] / g["r1"] if self.geometry == "couette" else None

    def layout(self) -> tuple[str, dict]:
        lay = (self.params.get("particles") or {}).get("layout") or {}
        return next(iter(lay.items()), ("?", {}))

    def layout_text(self) -> str:
        """How the initial positions were given: 'l_x = 0.5, l_y = 0.1' or 'r0* = 1/3'."""
        kind, v = self.layout()
        if kind in ("string", "pair"):
            text = describe({"lx": v.get("lx"), "ly": v.get("ly")})
            if v.get("perturb"):
                dx, dy = v["perturb"]
                text += f", particle {v['n'] // 2} moved by ({fmt(dx)}, {fmt(dy)})"
            return text
        if kind == "couette":
            return describe({"r0": v.get("r0_star")})
        if kind == "explicit":
            return "positions " + ", ".join(f"({fmt(x)}, {fmt(y)})" for x, y in v.get("positions", []))
        return kind

    def initial_positions(self) -> list[tuple[float, float]]:
        """Initial centres, as src/geometry/layout.rs places them."""
        kind, v = self.layout()
        if kind == "string":
            n, c = v["n"], (v["n"] - 1) / 2
            xs = [((k - c) * v["lx"], -(k - c) * v["ly"]) for k in range(n)]
            if v.get("perturb"):
                dx, dy = v["perturb"]
                xs[n // 2] = (xs[n // 2][0] + dx, xs[n // 2][1] + dy)
            return xs
        if kind == "pair":
            return [(-v["lx"], v["ly"]), (v["lx"], -v["ly"])]
        if kind == "explicit":
            return [tuple(p) for p in v["positions"]]
        if kind == "couette":
            g = self.geo()
            r = g["r1"] + v["r0_star"] * (g["r2"] - g["r1"])
            ang = v.get("angle", 0.0)
            return [(r * math.cos(ang), r * math.sin(ang))]
        return []

    def r_star(self, x, y):
        g = self.geo()
        return (np.hypot(x, y) - g["r1"]) / (g["r2"] - g["r1"])

    @property
    def unreachable(self) -> float | None:
        """a/(R2 − R1): r* below this or above 1 minus this is out of a particle's reach (Couette)."""
        if self.geometry != "couette" or self.a is None:
            return None
        g = self.geo()
        return self.a / (g["r2"] - g["r1"])


@dataclass
class Track:
    """Samples of one particle of one case, as float arrays (NULL → NaN), t ascending. `separation` is the
    extrusion's s = Y + a − H̄(X) (all NaN without a free surface or in a database older than that column;
    None in a Track built from the seven others)."""

    t: np.ndarray
    x: np.ndarray
    y: np.ndarray
    u: np.ndarray
    v: np.ndarray
    omega: np.ndarray
    theta: np.ndarray
    separation: np.ndarray | None = None


CASE_SQL = """
SELECT c.id, c.case_hash, c.label, c.geometry, c.status, c.params_json, c.wi, c.alpha, c.beta, c.delta,
       c.n_particles, c.a, c.h, c.l, c.lx, c.ly, c.r0, c.eps, c.mesh, c.dt,
       o.kind, o.string_length, o.t_decided, o.mean_gap, o.final_json, c.error,
       (SELECT group_concat(s.name, ', ') FROM sweep_cases sc JOIN sweeps s ON s.id = sc.sweep_id
         WHERE sc.case_id = c.id) AS sweeps
FROM cases c LEFT JOIN outcomes o ON o.case_id = c.id
ORDER BY c.id
"""

SAMPLE_SQL = """
SELECT particle, t, x, y, u, v, omega, theta, {separation} FROM samples WHERE case_id = ? ORDER BY particle, step
"""


class Figures:
    """Context of one database: connection, cached cases, output directory, log and the files written."""

    def __init__(self, db: str, out: str):
        self.db = db
        self.name = os.path.splitext(os.path.basename(db))[0]
        self.out = out
        self.written: list[str] = []
        self.notes: list[str] = []
        self.con = connect(db)
        self.missing_schema = missing_tables(self.con)
        if not self.missing_schema:
            os.makedirs(out, exist_ok=True)
        self._cases: list[Case] | None = None

    def log(self, msg: str) -> None:
        print(f"  {msg}", flush=True)
        self.notes.append(msg)

    # -- reading
    def cases(self, geometry: str | None = None) -> list[Case]:
        if self._cases is None:
            self._cases = [] if self.missing_schema else [row_to_case(r) for r in self.con.execute(CASE_SQL)]
        return [c for c in self._cases if geometry is None or c.geometry == geometry]

    def samples(self, case: Case) -> dict[int, Track]:
        """particle → Track (empty dict if the case has no samples)."""
        if case._samples is None:
            # samples.separation came with schema version 4 (src/store/schema.rs): NULL in older databases
            cols = {r[1] for r in self.con.execute("PRAGMA table_info(samples)")}
            sql = SAMPLE_SQL.format(separation="separation" if "separation" in cols else "NULL")
            rows = self.con.execute(sql, (case.id,)).fetchall()
            by: dict[int, list] = {}
            for r in rows:
                by.setdefault(r[0], []).append(r[1:])
            tracks = {}
            for p, rs in by.items():
                a = np.array([[np.nan if v is None else v for v in r] for r in rs], dtype=float)
                tracks[p] = Track(*(a[:, i] for i in range(8)))
            case._samples = tracks
        return case._samples

    def summary(self) -> str:
        """'N cases (k done, ...) in sweeps a, b' for figure footers."""
        cs = self.cases()
        by = {}
        for c in cs:
            by[c.status] = by.get(c.status, 0) + 1
        status = ", ".join(f"{v} {k}" for k, v in sorted(by.items()))
        return f"{self.name}.db: {len(cs)} cases" + (f" ({status})" if status else "")

    # -- writing
    def save(self, fig, name: str) -> list[str]:
        """Saves `fig` as <out>/<name>.png and .pdf with a provenance footer; closes it."""
        wrap_titles(fig)
        fig.text(0.005, 0.003, f"xpflow · {self.summary()}", fontsize=6, color="0.45", ha="left", va="bottom")
        paths = []
        for ext in ("png", "pdf"):
            p = os.path.join(self.out, f"{name}.{ext}")
            fig.savefig(p, dpi=DPI)
            paths.append(p)
        plt.close(fig)
        self.written += paths
        print(f"  wrote {paths[0]} (+ .pdf)", flush=True)
        return paths

    def empty(self, name: str, title: str, message: str) -> list[str]:
        """Records that figure `name` has nothing to plot: printed and listed under "Missing or left
        out" in index.md; no file is written (an empty figure looks like a result)."""
        self.log(f"{name} not written ({title}): {message}")
        # a figure of an earlier run into the same directory would contradict the index
        for stale in glob.glob(os.path.join(glob.escape(self.out), f"{glob.escape(name)}.*")) + glob.glob(
                os.path.join(glob.escape(self.out), f"{glob.escape(name)}_p[0-9]*.*")):
            os.remove(stale)
        return []

    def write_text(self, name: str, text: str) -> str:
        p = os.path.join(self.out, name)
        os.makedirs(os.path.dirname(p), exist_ok=True)
        with open(p, "w", encoding="utf-8") as f:
            f.write(text)
        self.written.append(p)
        print(f"  wrote {p}", flush=True)
        return p


class NotADatabase(Exception):
    """The file is not an SQLite database (or cannot be read as one)."""


def connect(db: str) -> sqlite3.Connection:
    """Opens the database read-only, as `xpflow query` does (src/store/open.rs): a reader never writes,
    never creates the -wal/-shm files (immutable when no writer has the database open, i.e. no -wal
    file), and works on a read-only share. Raises NotADatabase for a file that is not SQLite."""
    if not os.path.exists(db):
        raise FileNotFoundError(f"database {db} does not exist")
    mode = "mode=ro" if os.path.exists(db + "-wal") else "mode=ro&immutable=1"
    uri = "file:" + urllib.parse.quote(os.path.abspath(db)) + "?" + mode
    try:
        con = sqlite3.connect(uri, uri=True)
        con.execute("SELECT name FROM sqlite_master LIMIT 1").fetchall()
        return con
    except sqlite3.Error as e:
        raise NotADatabase(f"{db} is not an SQLite database ({e})") from e


def missing_tables(con: sqlite3.Connection) -> list[str]:
    have = {r[0] for r in con.execute("SELECT name FROM sqlite_master WHERE type IN ('table', 'view')")}
    return [t for t in ("cases", "outcomes", "samples", "sweeps", "sweep_cases", "snapshots") if t not in have]


def row_to_case(r) -> Case:
    params = json.loads(r[5]) if r[5] else {}
    final = json.loads(r[24]) if r[24] else {}
    return Case(r[0], r[1], r[2], r[3], r[4], params, *r[6:20], r[20], r[21], r[22], r[23], final, r[25],
                r[26] or "")


# --------------------------------------------------------------------------------------------- trajectories
def break_periodic(x: np.ndarray, y: np.ndarray, period: float | None):
    """Inserts NaN where x jumps across the periodic boundary so a line is not drawn across the domain."""
    if period is None or len(x) < 2:
        return x, y
    jumps = np.where(np.abs(np.diff(x)) > period / 2)[0] + 1
    return np.insert(x, jumps, np.nan), np.insert(y, jumps, np.nan)


def unwrap_x(x: np.ndarray, period: float | None) -> np.ndarray:
    if period is None or len(x) < 2:
        return x
    ok = np.isfinite(x)
    out = x.copy()
    out[ok] = np.unwrap(x[ok], period=period)
    return out


def velocities(case: Case, tr: Track) -> tuple[np.ndarray, np.ndarray, str]:
    """U, V of a particle: the stored ones, or central differences of the positions when the stored ones
    are missing or identically zero while the particle moves (what the fake runner stores)."""
    u, v = tr.u, tr.v
    period = case.l if case.geometry == "confined_shear" else None
    xs = unwrap_x(tr.x, period)
    moved = len(xs) > 1 and np.nanmax(np.abs(np.diff(xs))) + np.nanmax(np.abs(np.diff(tr.y))) > 0
    stored_ok = np.all(np.isfinite(u)) and np.all(np.isfinite(v)) and (np.any(u != 0) or np.any(v != 0) or not moved)
    if stored_ok or len(tr.t) < 2:
        return u, v, "stored U, V"
    return np.gradient(xs, tr.t), np.gradient(tr.y, tr.t), "U, V from finite differences of the positions"


# ------------------------------------------------------------------------------------------------- families
def match_common(ta, va, tb, vb, tol: float):
    """(t, values of a, values of b, how matched) at the sample times common to two series, or None.
    Non-finite samples are dropped; within the common time range the sparser series' times are matched in
    the other one: at equal times (within `tol`) directly, otherwise by linear interpolation in t."""
    ka, kb = np.isfinite(ta) & np.isfinite(va), np.isfinite(tb) & np.isfinite(vb)
    ta, va, tb, vb = ta[ka], va[ka], tb[kb], vb[kb]
    if len(ta) == 0 or len(tb) == 0:
        return None
    lo, hi = max(ta[0], tb[0]), min(ta[-1], tb[-1])
    ina, inb = (ta >= lo - tol) & (ta <= hi + tol), (tb >= lo - tol) & (tb <= hi + tol)
    if not ina.any() or not inb.any():
        return None
    swap = inb.sum() < ina.sum()
    (t1, v1, i1), (t2, v2, i2) = ((tb, vb, inb), (ta, va, ina)) if swap else ((ta, va, ina), (tb, vb, inb))
    t1, v1, t2, v2 = t1[i1], v1[i1], t2[i2], v2[i2]
    # t1 is the sparser series: match its times in t2
    j = np.clip(np.searchsorted(t2, t1), 0, len(t2) - 1)
    jl = np.clip(j - 1, 0, len(t2) - 1)
    near = np.where(np.abs(t2[jl] - t1) < np.abs(t2[j] - t1), jl, j)
    if np.all(np.abs(t2[near] - t1) <= tol):
        w2, how = v2[near], "equal t"
    elif len(t2) >= 2:
        w2, how = np.interp(t1, t2, v2), "interpolated"
    else:
        return None
    return (t1, w2, v1, how) if swap else (t1, v1, w2, how)


def group(cases, key, sort=None):
    """[(key value, [cases])] in first-seen order of keys (or sorted by `sort(key)`)."""
    groups: dict = {}
    for c in cases:
        groups.setdefault(key(c), []).append(c)
    items = list(groups.items())
    if sort:
        items.sort(key=lambda kv: sort(kv[0]))
    return items


def rounded(v):
    """Key-friendly value: floats rounded to 10 significant digits (sweep values like 0.1 + 0.2)."""
    if isinstance(v, float):
        return float(f"{v:.10g}")
    return v


def split_common(keys: list[dict]) -> tuple[dict, list[dict]]:
    """Splits parameter dicts into the part common to all (for the suptitle) and the rest (panel titles)."""
    if not keys:
        return {}, []
    names = list(keys[0].keys())
    common = {k: keys[0][k] for k in names if all(rounded(d.get(k)) == rounded(keys[0][k]) for d in keys)}
    rest = [{k: v for k, v in d.items() if k not in common} for d in keys]
    return common, rest


def sort_key(v):
    """Sorts None last and mixed types stably."""
    return (v is None, v if isinstance(v, (int, float)) else str(v))


def pages(items: list, name: str, fig_log, per: int = MAX_PANELS) -> list[tuple[str, list]]:
    """Splits panel items into pages of `per`: [(file name, items)], logging what is left out."""
    chunks = [items[i:i + per] for i in range(0, len(items), per)]
    if len(chunks) > MAX_PAGES:
        left = sum(len(c) for c in chunks[MAX_PAGES:])
        fig_log(f"{name}: {left} more panels left out (more than {MAX_PAGES} pages of {per} panels)")
        chunks = chunks[:MAX_PAGES]
    return [(name if i == 0 else f"{name}_p{i + 1}", c) for i, c in enumerate(chunks)]


def panel_grid(n: int, width: float = 4.6, height: float = 3.4, max_cols: int = 3):
    cols = min(n, max_cols)
    rows = math.ceil(n / cols)
    fig, axes = plt.subplots(rows, cols, figsize=(width * cols, height * rows + 0.8), squeeze=False,
                             layout="constrained")
    for ax in axes.flat[n:]:
        ax.set_visible(False)
    return fig, list(axes.flat[:n])


def min_span(ax, span: float) -> None:
    """Widens the y range to at least `span` around its centre and turns off the offset notation, so that
    equal values read as equal and not as noise around an offset."""
    lo, hi = ax.get_ylim()
    if hi - lo < span:
        mid = (lo + hi) / 2
        ax.set_ylim(mid - span / 2, mid + span / 2)
    ax.ticklabel_format(axis="y", useOffset=False)


def kind_text(c: Case) -> str:
    return KIND_STYLE.get(c.kind, KIND_STYLE[None])[2] if c.kind else c.status


#: Parameters that define a confined-shear set-up apart from the initial positions (panel keys).
SHEAR_KEYS = ["model", "wi", "alpha", "beta", "h", "a", "l", "n", "mesh", "step", "settings"]


def shear_groups(cases, keys=SHEAR_KEYS):
    """[(parameters, cases)] of confined-shear cases grouped by `keys`, sorted by them; cases within a group
    are sorted by their initial layout (l_x, l_y)."""
    groups = group(cases, key=lambda c: tuple((k, rounded(getattr(c, k))) for k in keys),
                   sort=lambda k: tuple(sort_key(v) for _, v in k))
    return [(dict(k), sorted(cs, key=lambda c: (sort_key(c.lx), sort_key(c.ly), c.id))) for k, cs in groups]
