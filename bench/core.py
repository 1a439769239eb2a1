"""Speed of the core tables at 1e-6 accuracy, against a vectorized NumPy float64 baseline.

Run: ``python bench/core.py`` (add ``--quick`` for a smaller NumPy sweep). Prints a table and
writes ``bench/out/core.json``. Times are wall-clock seconds after the Warp kernels are compiled
(a warm-up call compiles them), on all cores; each figure is the median of three runs. The NumPy
baseline evaluates the same integrand with a fixed composite Gauss-Legendre rule; its node count
is raised until its maximum difference to the adaptive result is below 1e-6 (or the sweep ends),
and the ratio is taken at that node count.

Where the time goes (``--cost``, on by default): each case's texels are integrated again with
the adaptive kernel's counters (``integrate_texels(..., return_cost="detail")``; the same
texels, parameters and values as the table, asserted), and the run reports integrand
evaluations per texel (mean, max, a histogram in powers of two), the time per evaluation (the
table's time over its evaluations, all workers), the split into the outer floor (the initial v
intervals: breakpoints, parts <= pi/16 or pi/8 in theta_m and pieces <= 1/4 in v, pi/4
and 1/2 for rough texels at loose tolerances; a D tail left out under its mass bound costs
nothing) against outer bisections, each divided into inner first rules (7 or 15 evaluations
per phi piece: the two-stage rule) and inner bisections, and the mean cost of the hard texels
(grazing mu < 0.05, near-mirror alpha < 0.02, eta within 5% of 1, eta < 1). Evaluation counts
are deterministic; times move with the machine's load. ``--variant KEY=VALUE`` (repeatable)
also counts the same texels with other integrator keywords (e.g. ``inner_share=0.5``), in the
same run, for before/after comparisons.

On a GPU: ``--device cuda:0`` (the counts run there too; ns/eval is then the GPU's). ``--large``
adds a dielectric 64^3 table (262144 texels, the size a GPU is for). With ``--no-numpy``,
``--save-values FILE.npz`` writes each case's float64 values, reported errors and evaluation
counts, and ``--compare-values FILE.npz`` compares this run's with them: the largest difference,
the share of bit-identical texels, of texels within both runs' reported errors, and of texels with
the same evaluation count (the README's GPU figures: saved on the GPU, compared on the CPU).
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
from bsdf_tab.integrate.runtime import default_workers, resolve_device  # noqa: E402
import numpy_baseline  # noqa: E402
from common import device_arg, parse_variants  # noqa: E402

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
# --large: the table the GPU is for (262144 texels; ~1 min of 2 cores at the spec's tolerance)
LARGE = (
    "dielectric 64^3 eta>1",
    {"table": "dielectric", "axes": {"mu": {"size": 64}, "alpha": {"size": 64}, "eta": {"size": 64}}},
    "dielectric",
)
TARGET = 1e-6


def _time(fn, repeats=3):
    times, out = [], None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), out


def flat_texels(table, mode):
    """A table's texels as flat float64 mu, alpha, eta and its values (texels x channels)."""
    axes = list(table.axes.values())
    grids = np.meshgrid(*axes, indexing="ij")
    mu = grids[0].ravel()
    alpha = grids[1].ravel() ** (2 if "roughness" in table.axes else 1)
    eta = grids[2].ravel() if len(grids) > 2 else np.ones(mu.size)
    names = ["E"] if mode == "reflect" else ["R", "T"]
    values = np.stack([table.channels[n].ravel() for n in names], 1)
    return mu, alpha, eta, values


def integrator_keywords(spec):
    """The adaptive integrator's keywords (distribution, shadowing, Fresnel, tolerance) of a spec."""
    from bsdf_tab.spec import normalize_spec
    from bsdf_tab.tables._common import integrator_params

    kw = integrator_params(normalize_spec(spec))
    return {k: kw[k] for k in ("dist", "shadowing", "ftype", "fp0", "fp1", "tol") if k in kw}


def cost_report(table, spec, mode, t_warp, variants=(), device=None, values=None):
    """Evaluation counts of one case's texels (see the module docstring); ``values``: a dict
    that receives the float64 values and reported errors (for ``--save-values``)."""
    from bsdf_tab.integrate.adaptive import integrate_texels

    mu, alpha, eta, ours = flat_texels(table, mode)
    kw = integrator_keywords(spec)
    v, err, detail = integrate_texels(mode, mu, alpha, eta, return_cost="detail", device=device, **kw)
    if values is not None:
        values.update(v=v, err=err, evals=detail.sum(1))
    same = float(np.max(np.abs(v[:, : ours.shape[1]].astype(np.float32) - ours.astype(np.float32))))
    cost = detail.sum(1)
    total = float(cost.sum())
    hist = np.bincount(np.floor(np.log2(np.maximum(cost, 1))).astype(int))
    groups = {
        "grazing mu<0.05": mu < 0.05,
        "near-mirror alpha<0.02": (alpha > 0) & (alpha < 0.02),
        "eta within 5% of 1": np.abs(eta - 1.0) < 0.05 if mode == "dielectric" else np.zeros(mu.size, bool),
        "eta<1": eta < 1.0,
        "other": (mu >= 0.05) & ((alpha >= 0.02) | (alpha == 0)),
    }
    out = {
        "tol": kw.get("tol"),
        "evals_mean": float(cost.mean()),
        "evals_max": int(cost.max()),
        "evals_total": total,
        "histogram_log2": {f"{2**k}-{2**(k + 1) - 1}": int(c) for k, c in enumerate(hist) if c},
        "ns_per_eval": 1e9 * t_warp / max(total, 1.0),
        "split": dict(zip(
            ("outer_floor.inner_first", "outer_floor.inner_bisect", "outer_bisect.inner_first",
             "outer_bisect.inner_bisect"), (float(x) for x in detail.sum(0) / max(total, 1.0)))),
        "groups_mean": {g: float(cost[m].mean()) for g, m in groups.items() if m.any()},
        "max_diff_to_table_float32": same,
        "variants": {},
    }
    for var in variants:
        vkw = dict(kw)
        vkw.update(var)
        t0 = time.perf_counter()
        vv, ee, dd = integrate_texels(mode, mu, alpha, eta, return_cost="detail", device=device, **vkw)
        tv = time.perf_counter() - t0
        c2 = dd.sum(1)
        out["variants"][json.dumps(var)] = {
            "evals_mean": float(c2.mean()), "evals_max": int(c2.max()), "time_s": tv,
            "max_diff_to_default": float(np.max(np.abs(vv - v))), "max_reported_error": float(ee.max()),
        }
    return out


def _print_cost(name, c):
    split = " ".join(f"{k}={v:.0%}" for k, v in c["split"].items())
    print(f"  {name}: evals/texel mean {c['evals_mean']:.0f} max {c['evals_max']}, "
          f"{c['ns_per_eval']:.0f} ns/eval; {split}")
    print("    histogram: " + ", ".join(f"{k}: {v}" for k, v in c["histogram_log2"].items()))
    print("    groups: " + ", ".join(f"{k} {v:.0f}" for k, v in c["groups_mean"].items()))
    for k, v in c["variants"].items():
        print(f"    variant {k}: mean {v['evals_mean']:.0f} max {v['evals_max']} ({v['evals_mean'] / c['evals_mean']:.2f}x), "
              f"{v['time_s']:.2f} s, max |diff| {v['max_diff_to_default']:.1e}, max err {v['max_reported_error']:.1e}")


def compare_values(name, values, reference) -> dict:
    """This run's float64 values against another run's (``--compare-values``: e.g. the GPU's
    against the CPU's): the largest difference and whether every difference lies within the two
    reported errors together (each run promises its value within its own error)."""
    v, err = values["v"], values["err"]
    v_ref, err_ref = reference[f"{name}/v"], reference[f"{name}/err"]
    diff = np.abs(v - v_ref)
    evals, evals_ref = values["evals"], reference[f"{name}/evals"]
    return {
        "max_abs_diff": float(diff.max()),
        "texels_bit_identical": float(np.mean(np.all(v == v_ref, axis=1))),
        "within_both_errors": float(np.mean(np.all(diff <= err + err_ref, axis=1))),
        "evals_mean": float(evals.mean()), "evals_mean_reference": float(evals_ref.mean()),
        "texels_same_evals": float(np.mean(evals == evals_ref)),
    }


def run(quick: bool, cost: bool = True, variants=(), tol=None, device=None, numpy_baseline_on=True,
        large: bool = False, save_values=None, reference=None) -> dict:
    t0 = time.perf_counter()
    bsdf_tab.tabulate({"table": "albedo", "axes": {"mu": [0.5], "alpha": [0.5]}}, device=device)  # compile
    print(f"(kernels loaded or compiled in {time.perf_counter() - t0:.1f} s)", flush=True)
    sizes = (8, 16, 32) if quick else (8, 16, 24, 32, 48, 64)
    rows, saved = [], {}
    for name, spec, mode in CASES + ([LARGE] if large else []):
        spec = json.loads(json.dumps(spec))
        if tol is not None:
            spec["tolerance"] = tol
        t_warp, table = _time(lambda: bsdf_tab.tabulate(spec, device=device))
        if not numpy_baseline_on:
            rows.append({"case": name, "texels": int(np.prod([len(a) for a in table.axes.values()])),
                         "warp_time_s": t_warp, "warp_max_error_estimate": max(table.max_error().values())})
            print(f"{name:<24} {rows[-1]['texels']:>6} {t_warp:>8.3f} {rows[-1]['warp_max_error_estimate']:>10.1e}",
                  flush=True)
            if cost:
                values = {}
                rows[-1]["cost"] = cost_report(table, spec, mode, t_warp, variants, device, values)
                _print_cost(name, rows[-1]["cost"])
                saved.update({f"{name}/{k}": a for k, a in values.items()})
                if reference is not None and f"{name}/v" in reference:
                    rows[-1]["compare"] = c = compare_values(name, values, reference)
                    print(f"    against the reference run: max |diff| {c['max_abs_diff']:.1e}, bit-identical "
                          f"{c['texels_bit_identical']:.1%}, within both errors {c['within_both_errors']:.1%}, "
                          f"same evaluation count {c['texels_same_evals']:.1%} (mean {c['evals_mean']:.0f} "
                          f"against {c['evals_mean_reference']:.0f})", flush=True)
            continue
        mu, alpha, eta, ours = flat_texels(table, mode)
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
        if cost:
            rows[-1]["cost"] = cost_report(table, spec, mode, t_warp, variants, device)
            _print_cost(name, rows[-1]["cost"])
    if save_values:
        np.savez_compressed(save_values, **saved)
    dev = resolve_device(device)
    return {
        "machine": {"platform": platform.platform(), "cores": default_workers(), "device": dev.alias,
                    "device_name": dev.name},
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


def main(argv=None, prog=None) -> int:
    parser = argparse.ArgumentParser(prog=prog, description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="smaller NumPy node sweep")
    parser.add_argument("--out", default=str(Path(__file__).resolve().parent / "out" / "core.json"))
    parser.add_argument("--no-cost", action="store_true", help="skip the evaluation counts")
    parser.add_argument("--no-numpy", action="store_true", help="skip the NumPy baseline (counts and times only)")
    parser.add_argument("--tol", type=float, default=None, help="the tables' tolerance (default: the spec's)")
    parser.add_argument("--device", default=None, help="Warp device, e.g. cuda:0 (default: cpu)")
    parser.add_argument("--large", action="store_true", help=f"also the case {LARGE[0]!r}")
    parser.add_argument("--save-values", metavar="NPZ", help="with --no-numpy: write each case's float64 values, "
                        "reported errors and evaluation counts")
    parser.add_argument("--compare-values", metavar="NPZ", help="with --no-numpy: compare each case's values with "
                        "those of an earlier --save-values run (e.g. the GPU's with the CPU's)")
    parser.add_argument("--variant", action="append", default=[], metavar="KEY=VALUE[,KEY=VALUE]",
                        help="also count the texels with these integrate_texels keywords")
    args = parser.parse_args(argv)
    try:
        variants = parse_variants(args.variant)
    except ValueError as exc:
        parser.error(str(exc))
    if (args.save_values or args.compare_values) and (not args.no_numpy or args.no_cost):
        parser.error("--save-values and --compare-values take --no-numpy and the evaluation counts (no --no-cost)")
    device_arg(parser, args.device)
    try:
        reference = dict(np.load(args.compare_values)) if args.compare_values else None
    except (OSError, ValueError) as exc:
        parser.error(f"--compare-values: cannot read {args.compare_values}: {exc}")
    print(f"{'case':<24} {'texels':>6} {'warp s':>8} {'max err':>10} {'numpy s':>9} {'n':>5} {'np diff':>9} {'ratio':>8}")
    result = run(args.quick, cost=not args.no_cost, variants=variants, tol=args.tol, device=args.device,
                 numpy_baseline_on=not args.no_numpy, large=args.large, save_values=args.save_values,
                 reference=reference)
    os.makedirs(os.path.dirname(args.out), exist_ok=True)
    with open(args.out, "w") as fh:
        json.dump(result, fh, indent=2)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
