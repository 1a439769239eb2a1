"""Speed of the core tables at 1e-6 accuracy, against a vectorized NumPy float64 baseline.

Run: ``python bench/core.py`` (add ``--quick`` for a smaller NumPy sweep). Prints a table and
writes ``bench/out/core.json``. Times are wall-clock seconds after the Warp kernels are compiled
(a warm-up call compiles them), on all cores; each figure is the median of three runs. The NumPy
baseline evaluates the same integrand with a fixed composite Gauss-Legendre rule; its node count
is raised until its maximum difference to the adaptive result is below 1e-6 (or the sweep ends),
and the ratio is taken at that node count.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import bsdf_tab  # noqa: E402
from bsdf_tab.integrate.runtime import default_workers  # noqa: E402
import numpy_baseline  # noqa: E402

CASES = [
    ("albedo 32x32 GGX", {"table": "albedo", "distribution": "ggx"}, "reflect"),
    ("albedo 32x32 Beckmann", {"table": "albedo", "distribution": "beckmann"}, "reflect"),
    (
        "dielectric 16^3 eta>1",
        {"table": "dielectric", "axes": {"mu": {"size": 16}, "alpha": {"size": 16}}},
        "dielectric",
    ),
    (
        "dielectric 16^3 eta<1",
        {
            "table": "dielectric",
            "axes": {
                "mu": {"size": 16},
                "alpha": {"size": 16},
                "eta": sorted(1.0 / np.linspace(1.01, 4.0, 16)),
            },
        },
        "dielectric",
    ),
]
TARGET = 1e-6


def _time(fn, repeats=3):
    times, out = [], None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), out


def _flat(table, mode):
    axes = list(table.axes.values())
    grids = np.meshgrid(*axes, indexing="ij")
    mu = grids[0].ravel()
    alpha = grids[1].ravel() ** (2 if "roughness" in table.axes else 1)
    eta = grids[2].ravel() if len(grids) > 2 else np.ones(mu.size)
    names = ["E"] if mode == "reflect" else ["R", "T"]
    values = np.stack([table.channels[n].ravel() for n in names], 1)
    return mu, alpha, eta, values


def run(quick: bool) -> dict:
    bsdf_tab.tabulate({"table": "albedo", "axes": {"mu": [0.5], "alpha": [0.5]}})  # compile
    sizes = (8, 16, 32) if quick else (8, 16, 24, 32, 48, 64)
    rows = []
    for name, spec, mode in CASES:
        spec = json.loads(json.dumps(spec))
        t_warp, table = _time(lambda: bsdf_tab.tabulate(spec))
        mu, alpha, eta, ours = _flat(table, mode)
        keep = alpha > 0  # alpha = 0 texels are closed forms for us; the baseline skips them
        dist = spec.get("distribution", "ggx")
        best = None
        for n in sizes:
            t0 = time.perf_counter()
            base = numpy_baseline.integrate(mode, mu[keep], alpha[keep], eta[keep], n, dist=dist)
            t_np = time.perf_counter() - t0
            err = float(np.max(np.abs(base[:, : ours.shape[1]] - ours[keep])))
            best = {"nodes_per_piece": n, "time_s": t_np, "max_diff": err}
            if err <= TARGET:
                break
        rows.append(
            {
                "case": name,
                "texels": int(mu.size),
                "warp_time_s": t_warp,
                "warp_max_error_estimate": max(table.max_error().values()),
                "numpy": best,
                "numpy_reached_target": best["max_diff"] <= TARGET,
                "ratio_numpy_over_warp": best["time_s"] / t_warp,
            }
        )
        print(_row(rows[-1]), flush=True)
    return {
        "machine": {"platform": platform.platform(), "cores": default_workers()},
        "target": TARGET,
        "rows": rows,
    }


def _row(r):
    np_ = r["numpy"]
    flag = "" if r["numpy_reached_target"] else " (target not reached)"
    return (
        f"{r['case']:<24} {r['texels']:>6} {r['warp_time_s']:>8.2f} {r['warp_max_error_estimate']:>10.1e}"
        f" {np_['time_s']:>9.2f} {np_['nodes_per_piece']:>5} {np_['max_diff']:>9.1e} {r['ratio_numpy_over_warp']:>7.1f}x{flag}"
    )


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="smaller NumPy node sweep")
    parser.add_argument("--out", default=str(Path(__file__).resolve().parent / "out" / "core.json"))
    args = parser.parse_args(argv)
    print(f"{'case':<24} {'texels':>6} {'warp s':>8} {'max err':>10} {'numpy s':>9} {'n':>5} {'np diff':>9} {'ratio':>8}")
    result = run(args.quick)
    os.makedirs(os.path.dirname(args.out), exist_ok=True)
    with open(args.out, "w") as fh:
        json.dump(result, fh, indent=2)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
