"""Two checkouts side by side: the core tables and the example scene plan, timed interleaved.

    python bench/versions.py /path/to/old-checkout .            # e.g. a `git worktree` of a tag
    python bench/versions.py OLD NEW --reps 5 --out bench/out/versions.json

Each repetition runs, for each checkout in turn, one fresh process that loads the kernels on
small tables and then times every core case once (wall and CPU seconds, the table's largest
error estimate), then ``bsdf-tab plan examples/scene.json --tol 1e-3`` end to end as a user
runs it (start-up included). Medians over the repetitions are printed as a table, with the
wall-time ratio old / new; interleaving makes both checkouts see the same load, so the ratio is
the figure to quote, not the seconds. Both checkouts must have ``bsdf_tab`` at their root.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

#: The issue-14 goal cases: (label, spec).
CASES = {
    "albedo GGX 32^2, tol 5e-7": {"table": "albedo", "tolerance": 5e-7,
                                  "axes": {"mu": {"size": 32}, "alpha": {"size": 32}}},
    "albedo GGX 32^2, tol 1e-3": {"table": "albedo", "tolerance": 1e-3,
                                  "axes": {"mu": {"size": 32}, "alpha": {"size": 32}}},
    "albedo Beckmann 32^2, tol 5e-7": {"table": "albedo", "distribution": "beckmann", "tolerance": 5e-7,
                                       "axes": {"mu": {"size": 32}, "alpha": {"size": 32}}},
    "dielectric 16^3 eta in [1/4, 1/1.01], tol 5e-7": {
        "table": "dielectric", "tolerance": 5e-7,
        "axes": {"mu": {"size": 16}, "alpha": {"size": 16}, "eta": {"size": 16, "range": [0.25, 1 / 1.01]}}},
    "dielectric 16^3 eta in [1.01, 4], tol 5e-7": {
        "table": "dielectric", "tolerance": 5e-7,
        "axes": {"mu": {"size": 16}, "alpha": {"size": 16}, "eta": {"size": 16, "range": [1.01, 4.0]}}},
}
PLAN = "plan examples/scene.json --tol 1e-3"

# the child: runs with cwd = a checkout, imports that checkout's bsdf_tab
_CHILD = r"""
import json, sys, time
sys.path.insert(0, ".")
import numpy as np
from bsdf_tab import api
cases = json.loads(sys.argv[1])
api.tabulate({"table": "albedo", "tolerance": 1e-3, "axes": {"mu": {"size": 4}, "alpha": {"size": 4}}})
api.tabulate({"table": "dielectric", "tolerance": 1e-3,
              "axes": {"mu": {"size": 3}, "alpha": {"size": 3}, "eta": {"size": 3, "range": [0.5, 2.0]}}})
out = {}
for name, spec in cases.items():
    t0, c0 = time.perf_counter(), time.process_time()
    table = api.tabulate(spec)
    errs = [float(np.max(np.asarray(v))) for k, v in table.channels.items() if k.endswith("_err")]
    out[name] = {"wall": time.perf_counter() - t0, "cpu": time.process_time() - c0, "max_error": max(errs)}
print("RESULT " + json.dumps(out))
"""
_PLAN = ("import sys; sys.path.insert(0, '.'); from bsdf_tab.cli import main; "
         f"sys.exit(main({PLAN.split() + ['-q']!r}))")


def _run_checkout(root: Path) -> dict:
    p = subprocess.run([sys.executable, "-c", _CHILD, json.dumps(CASES)], cwd=root, capture_output=True, text=True)
    if p.returncode:
        raise SystemExit(f"{root}: the core cases failed:\n{p.stderr[-2000:]}")
    line = next(ln for ln in p.stdout.splitlines() if ln.startswith("RESULT "))
    res = json.loads(line[len("RESULT "):])
    t0 = time.perf_counter()
    q = subprocess.run([sys.executable, "-c", _PLAN], cwd=root, capture_output=True, text=True)
    if q.returncode:
        raise SystemExit(f"{root}: `bsdf-tab {PLAN}` failed:\n{q.stderr[-2000:]}")
    res[f"bsdf-tab {PLAN} (end to end)"] = {"wall": time.perf_counter() - t0, "cpu": None, "max_error": None}
    return res


def main(argv=None, prog=None) -> int:
    ap = argparse.ArgumentParser(prog=prog, description=__doc__.splitlines()[0])
    ap.add_argument("old", type=Path, help="the checkout to compare against (a worktree of an older commit)")
    ap.add_argument("new", type=Path, help="the checkout under test")
    ap.add_argument("--reps", type=int, default=3, help="interleaved repetitions (default 3)")
    ap.add_argument("--out", type=Path, default=Path(__file__).resolve().parent / "out" / "versions.json")
    args = ap.parse_args(argv)
    if args.reps < 1:
        ap.error("--reps must be >= 1")
    roots = {"old": args.old.resolve(), "new": args.new.resolve()}
    for label, root in roots.items():
        if not (root / "bsdf_tab" / "__init__.py").is_file():
            ap.error(f"{label}: {root} is not a bsdf-tab checkout")
    runs = {label: [] for label in roots}
    for rep in range(args.reps):  # bounded
        for label, root in roots.items():
            runs[label].append(_run_checkout(root))
        print(f"repetition {rep + 1}/{args.reps} done", file=sys.stderr, flush=True)
    summary = {}
    for label, rs in runs.items():
        summary[label] = {"root": str(roots[label]), "cases": {}}
        for name in rs[0]:
            walls = [r[name]["wall"] for r in rs]
            cpus = [r[name]["cpu"] for r in rs if r[name]["cpu"] is not None]
            summary[label]["cases"][name] = {"wall_median": statistics.median(walls), "walls": walls,
                                             "cpu_median": statistics.median(cpus) if cpus else None,
                                             "max_error": rs[0][name]["max_error"]}
    summary["load_average"] = os.getloadavg()
    print("| case | old wall (cpu) s | new wall (cpu) s | old / new |")
    print("|---|---|---|---|")
    for name, old in summary["old"]["cases"].items():
        new = summary["new"]["cases"][name]

        def fmt(c):
            return f"{c['wall_median']:.3f}" + (f" ({c['cpu_median']:.3f})" if c["cpu_median"] is not None else "")

        print(f"| {name} | {fmt(old)} | {fmt(new)} | {old['wall_median'] / new['wall_median']:.2f} |")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(summary, indent=1))
    print(f"load average after: {summary['load_average'][0]:.2f}; JSON: {args.out}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
