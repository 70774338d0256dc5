"""Makes every figure and table from xpflow results databases.

    python plotting/make_figures.py [DB ...] [--out results/figures] [--only SCRIPT ...]

Without DB arguments it uses every results/*.db. The outputs of database `NAME.db` go to `OUT/NAME/`
(PNG + PDF per figure, Markdown tables under `tables/`, and `index.md` listing the files and what is
missing). A figure without data is not written: the log and the index say what is missing. Exit code 0 when every script ran, 1 when a script
failed (the others still run; the traceback is printed), 2 for a missing or non-xpflow database.
`make figures [DB=results/demo.db]` runs this with the Python of `.venv/` (see docs/figures.md).
"""

from __future__ import annotations

import argparse
import concurrent.futures
import contextlib
import glob
import importlib
import io
import os
import sys
import time
import traceback

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import figlib  # noqa: E402

#: The figure scripts, in the order they run (module names in plotting/).
SCRIPTS = [
    "migration_r",
    "migration_vr",
    "single_particle",
    "alignment_trajectories",
    "alignment_velocities",
    "alignment_steady",
    "string_gaps",
    "regime_map",
    "string_tables",
    "mesh_convergence",
    "extrusion",
    "field_snapshots",
    "film_zoom",
]


def run_database(db: str, out_root: str, scripts: list[str]) -> int:
    """Runs the scripts on one database; returns the number of scripts that failed."""
    name = os.path.splitext(os.path.basename(db))[0]
    out = os.path.join(out_root, name)
    print(f"{db} -> {out}/", flush=True)
    try:
        f = figlib.Figures(db, out)
    except figlib.NotADatabase as e:
        print(f"  {e}", file=sys.stderr)
        return -1
    if f.missing_schema:
        print(f"  {db} is not an xpflow results database (missing tables: {', '.join(f.missing_schema)})",
              file=sys.stderr)
        return -1
    failed = 0
    for s in scripts:
        start = time.perf_counter()
        print(f" {s}", flush=True)
        try:
            importlib.import_module(s).main(f)
        except Exception:  # a broken script must not stop the others; reported and counted
            failed += 1
            f.notes.append(f"{s} FAILED (see the log)")
            traceback.print_exc()
        print(f"  ({time.perf_counter() - start:.1f} s)", flush=True)
    write_index(f)
    return failed


def write_index(f: figlib.Figures) -> None:
    lines = [f"# Figures from {f.db}", "", f"{f.summary()}", "", "## Files", ""]
    lines += [f"- `{os.path.relpath(p, f.out)}`" for p in f.written]
    lines += ["", "## Missing or left out", ""]
    lines += [f"- {n}" for n in f.notes] or ["- nothing"]
    with open(os.path.join(f.out, "index.md"), "w", encoding="utf-8") as fh:
        fh.write("\n".join(lines) + "\n")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("db", nargs="*", help="results databases (default: results/*.db)")
    ap.add_argument("--out", default="results/figures", help="output root (default results/figures)")
    ap.add_argument("--only", action="append", choices=SCRIPTS, help="run only this script (repeatable)")
    args = ap.parse_args(argv)
    dbs = args.db or sorted(glob.glob("results/*.db"))
    if not dbs:
        print("no results databases given and none in results/*.db: nothing to plot "
              "(run a sweep first, e.g. `xpflow sweep sweeps/demo.toml`)")
        return 0
    missing = [d for d in dbs if not os.path.isfile(d)]
    if missing:
        print(f"database not found: {', '.join(missing)}", file=sys.stderr)
        return 2
    scripts = args.only or SCRIPTS
    bad_db = failed = 0
    # one process per database, as many at once as the machine has cores (the databases share
    # nothing; each one's log is printed whole, in the order given)
    workers = min(len(dbs), os.cpu_count() or 1)
    jobs = [(db, args.out, scripts) for db in dbs]
    if workers > 1:
        with concurrent.futures.ProcessPoolExecutor(max_workers=workers) as pool:
            results = pool.map(run_captured, jobs)
            for n, log in results:
                print(log, end="", flush=True)
                bad_db += n < 0
                failed += max(n, 0)
    else:
        for db, out, s in jobs:
            n = run_database(db, out, s)
            bad_db += n < 0
            failed += max(n, 0)
    if failed:
        print(f"{failed} figure script run(s) failed", file=sys.stderr)
        return 1
    return 2 if bad_db else 0


def run_captured(job: tuple[str, str, list[str]]) -> tuple[int, str]:
    """run_database in a worker process, its output captured: (result, log)."""
    db, out, scripts = job
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf), contextlib.redirect_stderr(buf):
        n = run_database(db, out, scripts)
    return n, buf.getvalue()


def run_one(script_main) -> None:
    """Entry point of a single script: `python plotting/SCRIPT.py DB [OUT_DIR]` (default
    results/figures/<db name>/)."""
    if len(sys.argv) not in (2, 3):
        print(f"usage: python {sys.argv[0]} DB [OUT_DIR]", file=sys.stderr)
        sys.exit(2)
    db = sys.argv[1]
    out = sys.argv[2] if len(sys.argv) == 3 else os.path.join(
        "results", "figures", os.path.splitext(os.path.basename(db))[0])
    try:
        f = figlib.Figures(db, out)
    except figlib.NotADatabase as e:
        print(str(e), file=sys.stderr)
        sys.exit(2)
    if f.missing_schema:
        print(f"{db} is not an xpflow results database (missing {', '.join(f.missing_schema)})", file=sys.stderr)
        sys.exit(2)
    script_main(f)


if __name__ == "__main__":
    sys.exit(main())
