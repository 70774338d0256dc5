"""The polymer stress τ_xx along the cylinder surface and the wake centreline (thesis Figs. 2.16,
2.20): XFEM against the fictitious domain method (FDM) on the same mesh, issue 23.

    python3 plotting/cylinder_tau_xx.py DIR [--out DIR]

DIR holds the CSVs `xpflow validate cylinder --wi W --h H [--method fdm] --out DIR` writes:
`cylinder_tau_xx_wi<W>_h<H>.csv` (XFEM) and `cylinder_tau_xx_fdm_wi<W>_h<H>.csv` (FDM), columns
ξ, x, y, τ_xx/(η0 U/R). ξ runs along the upper half of the surface from the front stagnation
point (ξ = 0) to the rear one (ξ = π), then along the wake y = 0 (ξ = π + x − x_c − R). One
figure per (Wi, h) with both methods (`cylinder_tau_xx_wi<W>_h<H>.png/.pdf` in --out, default
DIR) and a table on stdout: per method the surface maximum (its ξ), the rear stagnation value,
the wake maximum, and the largest jump between neighbouring surface samples (a measure of the
oscillation the thesis reports for FDM).
"""

from __future__ import annotations

import argparse
import csv
import glob
import math
import os
import re

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

PATTERN = re.compile(r"cylinder_tau_xx(_fdm)?_wi([0-9.]+)_h([0-9.]+)\.csv$")


def read(path: str) -> list[tuple[float, float]]:
    """(ξ, τ_xx) rows of one CSV."""
    with open(path, newline="") as f:
        return [(float(r["xi"]), float(r["tau_xx"])) for r in csv.DictReader(f)]


def summary(rows: list[tuple[float, float]]) -> dict[str, float]:
    """Surface maximum and where, rear stagnation value, wake maximum, largest surface jump."""
    surface = [r for r in rows if r[0] <= math.pi + 1e-12]
    wake = [r for r in rows if r[0] > math.pi + 1e-12]
    peak = max(surface, key=lambda r: r[1])
    jumps = [abs(b[1] - a[1]) for a, b in zip(surface, surface[1:])]
    return {
        "surface max": peak[1],
        "at ξ": peak[0],
        "rear (ξ = π)": surface[-1][1],
        "wake max": max(r[1] for r in wake) if wake else float("nan"),
        "largest surface jump": max(jumps) if jumps else float("nan"),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dir")
    ap.add_argument("--out")
    args = ap.parse_args()
    out = args.out or args.dir
    os.makedirs(out, exist_ok=True)
    runs: dict[tuple[str, str], dict[str, str]] = {}
    for path in sorted(glob.glob(os.path.join(args.dir, "cylinder_tau_xx*.csv"))):
        m = PATTERN.search(os.path.basename(path))
        if m:
            runs.setdefault((m.group(2), m.group(3)), {})["FDM" if m.group(1) else "XFEM"] = path
    if not runs:
        raise SystemExit(f"{args.dir}: no cylinder_tau_xx*.csv (run xpflow validate cylinder --wi W --out DIR)")
    print("| Wi | h/R | method | " + " | ".join(summary([(0.0, 0.0), (4.0, 0.0)])) + " |")
    print("|---" * 8 + "|")
    for (wi, h), methods in sorted(runs.items()):
        fig, ax = plt.subplots(figsize=(8, 4.5))
        for name, style in (("XFEM", "-"), ("FDM", "--")):
            if name not in methods:
                continue
            rows = read(methods[name])
            ax.plot([r[0] for r in rows], [r[1] for r in rows], style, label=name)
            s = summary(rows)
            print(f"| {wi} | {h} | {name} | " + " | ".join(f"{v:.4g}" for v in s.values()) + " |")
        ax.axvline(math.pi, color="grey", lw=0.8, ls=":")
        ax.text(math.pi, ax.get_ylim()[1], " rear stagnation point → wake", va="top", fontsize=8)
        ax.set_xlabel("ξ (surface from the front stagnation point, then the wake centreline)")
        ax.set_ylabel("τ_xx / (η0 U / R)")
        ax.set_title(f"Oldroyd-B past the confined cylinder, Wi = {wi}, h = {h} R (thesis Fig. 2.20)")
        ax.legend()
        fig.tight_layout()
        for ext in ("png", "pdf"):
            fig.savefig(os.path.join(out, f"cylinder_tau_xx_wi{wi}_h{h}.{ext}"), dpi=150)
        plt.close(fig)


if __name__ == "__main__":
    main()
