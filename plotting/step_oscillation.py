"""How smooth each case's particle rotation is: the table behind the explicit coupling's stable
step (issue 27, sweeps/explicit_coupling_stability.toml, docs/validation.md).

Too large a step with the explicit stress coupling shows as a slow oscillation of the particles'
ω* (a period of about ten steps, growing), not as a blow-up. For every case of a confined-shear
database this fits a quadratic to each particle's ω*(t*) over two windows — the middle and the last
third of the run — and prints the largest residual of the fit in each (a smooth approach to a steady
string is a quadratic to ≈ 1e-4 over ten time units; an oscillation leaves its amplitude) and the
verdict: `oscillates` when the last window's residual exceeds OSCILLATION_TOL, `diverged` / `failed`
as stored.

    python3 plotting/step_oscillation.py results/explicit_coupling_stability.db

Reads the database only (opened read-only); prints a markdown table.
"""

from __future__ import annotations

import json
import sqlite3
import sys

#: A residual of the quadratic fit above this (in ω* = ω/γ̇, about 1 % of the particles' ω*)
#: is an oscillation. Smooth runs stay below 1e-4 (measured on the Δt = 0.02 string).
OSCILLATION_TOL = 1e-3


def quadratic_residual(ts: list[float], ws: list[float]) -> float:
    """Largest |w − q(t)| of the least-squares quadratic q through the points (0 for < 4 points)."""
    n = len(ts)
    if n < 4:
        return 0.0
    t0 = sum(ts) / n
    xs = [t - t0 for t in ts]
    # normal equations of [1, x, x²]
    s = [sum(x**k for x in xs) for k in range(5)]
    b = [sum(w * x**k for x, w in zip(xs, ws)) for k in range(3)]
    a = [[s[0], s[1], s[2]], [s[1], s[2], s[3]], [s[2], s[3], s[4]]]
    coef = solve3(a, b)
    return max(abs(w - (coef[0] + coef[1] * x + coef[2] * x * x)) for x, w in zip(xs, ws))


def solve3(a: list[list[float]], b: list[float]) -> list[float]:
    """Gaussian elimination with partial pivoting for a 3×3 system."""
    m = [row[:] + [rhs] for row, rhs in zip(a, b)]
    for c in range(3):
        p = max(range(c, 3), key=lambda r: abs(m[r][c]))
        m[c], m[p] = m[p], m[c]
        for r in range(c + 1, 3):
            f = m[r][c] / m[c][c]
            for k in range(c, 4):
                m[r][k] -= f * m[c][k]
    x = [0.0, 0.0, 0.0]
    for r in (2, 1, 0):
        x[r] = (m[r][3] - sum(m[r][k] * x[k] for k in range(r + 1, 3))) / m[r][r]
    return x


def interpolate(series: list[tuple[float, float]], t: float) -> float | None:
    """Linear interpolation of (t, value) pairs sorted by t; None outside them."""
    for (t0, v0), (t1, v1) in zip(series, series[1:]):
        if t0 <= t <= t1:
            return v0 if t1 == t0 else v0 + (v1 - v0) * (t - t0) / (t1 - t0)
    return None


def main(db: str) -> None:
    con = sqlite3.connect(f"file:{db}?mode=ro", uri=True)
    rows = con.execute(
        "SELECT c.id, c.params_json, c.status, o.kind FROM cases c "
        "LEFT JOIN outcomes o ON o.case_id = c.id ORDER BY c.id"
    ).fetchall()
    cases = []
    for cid, params, status, kind in rows:
        p = json.loads(params)
        fluid, geo = p["fluid"], p["geometry"]["confined_shear"]
        rate = geo.get("wall_speed", 1.0) / geo["h"]
        series = {}
        for particle, t, w in con.execute(
            "SELECT particle, t, omega FROM samples WHERE case_id = ? ORDER BY particle, step", (cid,)
        ):
            series.setdefault(particle, []).append((t * rate, w / rate))
        cases.append(
            dict(wi=fluid.get("wi", 0.0), beta=fluid.get("beta", 0.0), dt=p["numerics"]["dt"] * rate,
                 lam=fluid.get("wi", 0.0), status=status, kind=kind, series=series)
        )
    print("| Wi | β | Δt* | Δt/λ | outcome | residual, middle third | last third | from the finest Δt, last third | verdict |")
    print("|---|---|---|---|---|---|---|---|---|")
    for c in sorted(cases, key=lambda c: (c["wi"], c["beta"], -c["dt"])):
        if not c["series"]:
            print(f"| {c['wi']:g} | {c['beta']:g} | {c['dt']:g} | – | {c['status']} | – | – | – | not run |")
            continue
        t_end = max(t for s in c["series"].values() for t, _ in s)
        windows = [(t_end / 3, 2 * t_end / 3), (2 * t_end / 3, t_end)]
        res = [0.0, 0.0]
        for s in c["series"].values():
            for i, (lo, hi) in enumerate(windows):
                pts = [(t, w) for t, w in s if lo <= t <= hi]
                res[i] = max(res[i], quadratic_residual([t for t, _ in pts], [w for _, w in pts]))
        finest = min(
            (o for o in cases if (o["wi"], o["beta"]) == (c["wi"], c["beta"]) and o["series"]),
            key=lambda o: o["dt"],
        )
        dev = 0.0
        for particle, s in c["series"].items():
            ref = finest["series"].get(particle, [])
            for t, w in s:
                r = interpolate(ref, t) if t >= windows[1][0] else None
                if r is not None:
                    dev = max(dev, abs(w - r))
        if c["kind"] == "diverged" or c["status"] == "failed":
            verdict = c["kind"] or c["status"]
        elif finest is c:
            verdict = "reference"
        elif dev > OSCILLATION_TOL:
            verdict = "off the finest step"
        else:
            verdict = "follows"
        print(
            f"| {c['wi']:g} | {c['beta']:g} | {c['dt']:g} | {c['dt'] / c['lam']:.3f} | {c['kind'] or c['status']} "
            f"| {res[0]:.1e} | {res[1]:.1e} | {dev:.1e} | {verdict} |"
        )


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit("usage: step_oscillation.py DATABASE")
    main(sys.argv[1])
