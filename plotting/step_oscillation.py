"""How far each case's particle rotation is from the finest step's: the table behind the
explicit coupling's step (issue 27, sweeps/explicit_coupling_stability.toml, docs/validation.md).

Too large a step with the explicit stress coupling shows as a slow oscillation of the particles'
ω* (a period of about ten steps), or as a different trajectory near contact, not as a blow-up. For
each (Wi, β) of a confined-shear database the case with the smallest Δt is the reference; every
other case prints the largest |ω* − ω*_ref| over the middle and over the last third of the run (ref
interpolated at the case's times). Cut-cell jumps of ω* on a coarse mesh appear at the same places
in every run and show up here only as far as the runs' timing differs.

    python3 plotting/step_oscillation.py results/explicit_coupling_stability.db

Reads the database only (opened read-only); prints a markdown table.
"""

from __future__ import annotations

import json
import sqlite3
import sys

#: A deviation from the finest step's ω* above this (ω* = ω/γ̇; about 1 % of the particles'
#: ω*) over the last third of the run: the step is off the finest one's trajectory.
OSCILLATION_TOL = 1e-3


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
    print("| Wi | β | Δt* | Δt/λ | outcome | from the finest Δt, middle third | last third | verdict |")
    print("|---|---|---|---|---|---|---|---|")
    for c in sorted(cases, key=lambda c: (c["wi"], c["beta"], -c["dt"])):
        if not c["series"]:
            print(f"| {c['wi']:g} | {c['beta']:g} | {c['dt']:g} | – | {c['status']} | – | – | not run |")
            continue
        t_end = max(t for s in c["series"].values() for t, _ in s)
        windows = [(t_end / 3, 2 * t_end / 3), (2 * t_end / 3, t_end)]
        finest = min(
            (o for o in cases if (o["wi"], o["beta"]) == (c["wi"], c["beta"]) and o["series"]),
            key=lambda o: o["dt"],
        )
        dev = [0.0, 0.0]
        for particle, s in c["series"].items():
            ref = finest["series"].get(particle, [])
            for t, w in s:
                for i, (lo, hi) in enumerate(windows):
                    r = interpolate(ref, t) if lo <= t <= hi else None
                    if r is not None:
                        dev[i] = max(dev[i], abs(w - r))
        if c["kind"] == "diverged" or c["status"] == "failed":
            verdict = c["kind"] or c["status"]
        elif finest is c:
            verdict = "reference"
        elif dev[1] > OSCILLATION_TOL:
            verdict = "off the finest step"
        else:
            verdict = "follows"
        print(
            f"| {c['wi']:g} | {c['beta']:g} | {c['dt']:g} | {c['dt'] / c['lam']:.3f} | {c['kind'] or c['status']} "
            f"| {dev[0]:.1e} | {dev[1]:.1e} | {verdict} |"
        )


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit("usage: step_oscillation.py DATABASE")
    main(sys.argv[1])
