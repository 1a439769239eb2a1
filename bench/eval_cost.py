"""Where the time per integrand evaluation goes: the integrand alone against inside the inner
phi integrals (the adaptive method's fixed work per inner integral: cuts, pieces, end maps, rules).

Run: ``python bench/eval_cost.py [--texels 2048] [--device cpu]``. Prints a table and writes
``bench/out/eval_cost.json``. For random texels (mu, alpha uniform in [0.05, 1]; Fresnel
dielectric 1.5 for reflection) and 64 micro-normal angles theta_m each, one kernel calls the
method's :func:`~bsdf_tab.integrate.inner.inner_integral` (the shipped inner settings: two-stage
G7 first with ``FIRST_SAFETY``, then G7 with ``SECOND_SAFETY`` |G7 - I9|, the decay-ratio estimate, the ends mapped as the method maps them
at that tolerance) and counts its evaluations; a
second kernel evaluates the integrand the same number of times at the same theta_m, on a uniform
phi grid over the support (where i.m exceeds the reflection horizon's, or 0 for transmission),
with no quadrature around it. Times are one launch each, on one core (``workers`` do not apply:
a single launch), after a warm-up; the difference per evaluation is the inner level's own work.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np
import warp as wp

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bsdf_tab.integrate.adaptive import FIRST_SAFETY, SECOND_SAFETY  # noqa: E402
from bsdf_tab.integrate.inner import inner_integral  # noqa: E402
from bsdf_tab.integrate.integrand import integrand_phi, make_texel  # noqa: E402
from bench.common import device_arg  # noqa: E402

wp.set_module_options({"enable_backward": False})
NT = 64  # theta_m per texel


@wp.func
def _texel(mu: wp.float64, alpha: wp.float64, mode: wp.int32, dist: wp.int32, inner_map: wp.int32):
    p = make_texel(mode, dist, 1, 2, wp.float64(1.5), wp.float64(0.0), mu, alpha, wp.float64(1.5))
    p.err_model = 1
    p.err_model_inner = 2
    p.err_safety = wp.float64(1.0)
    p.err_power = wp.float64(3.0)
    p.bound_share = wp.float64(0.0)
    p.inner_first = 5
    p.first_share = wp.float64(1.0)
    p.first_safety = wp.float64(FIRST_SAFETY)
    p.second_safety = wp.float64(SECOND_SAFETY)
    p.inner_map = inner_map
    return p


@wp.func
def _theta(k: wp.int32):
    t = wp.float64(0.02) + wp.float64(1.5) * wp.float64(k) / wp.float64(NT)
    return wp.cos(t), wp.sin(t), wp.tan(t)


@wp.kernel
def inner_kernel(mu_a: wp.array(dtype=wp.float64), alpha_a: wp.array(dtype=wp.float64), mode: wp.int32,
                 dist: wp.int32, inner_map: wp.int32, tol: wp.float64, out: wp.array(dtype=wp.float64), evals: wp.array(dtype=wp.int32)):
    i = wp.tid()
    p = _texel(mu_a[i], alpha_a[i], mode, dist, inner_map)
    acc = wp.float64(0.0)
    ev = int(0)
    for k in range(NT):
        cm, sm, tm = _theta(k)
        r, e, used, used_ref = inner_integral(p, cm, sm, tm, tol, 200)
        acc += r[0] + r[1]
        ev += used
    out[i] = acc
    evals[i] = ev


@wp.kernel
def integrand_kernel(mu_a: wp.array(dtype=wp.float64), alpha_a: wp.array(dtype=wp.float64), mode: wp.int32,
                     dist: wp.int32, inner_map: wp.int32, evals: wp.array(dtype=wp.int32), out: wp.array(dtype=wp.float64)):
    i = wp.tid()
    p = _texel(mu_a[i], alpha_a[i], mode, dist, inner_map)
    acc = wp.float64(0.0)
    per = evals[i] // wp.int32(NT) + 1
    for k in range(NT):
        cm, sm, tm = _theta(k)
        ss = p.sin_i * sm
        c_floor = wp.where(mode == 1, wp.float64(0.0), p.mu / (wp.float64(2.0) * cm))
        phi_hi = wp.float64(3.141592653589793)
        if ss > wp.float64(0.0):
            phi_hi = wp.acos(wp.clamp((c_floor - p.mu * cm) / ss, wp.float64(-1.0), wp.float64(1.0)))
        for j in range(per):
            f = integrand_phi(p, cm, sm, tm, phi_hi * (wp.float64(j) + wp.float64(0.5)) / wp.float64(per))
            acc += f[0] + f[1]
    out[i] = acc


def main(argv=None, prog=None) -> int:
    parser = argparse.ArgumentParser(prog=prog, description=__doc__.splitlines()[0])
    parser.add_argument("--texels", type=int, default=2048)
    parser.add_argument("--device", default="cpu")
    parser.add_argument("--out", default=str(Path(__file__).resolve().parent / "out" / "eval_cost.json"))
    args = parser.parse_args(argv)
    if args.texels < 1:
        parser.error("--texels must be >= 1")
    dev = device_arg(parser, args.device)
    rng = np.random.default_rng(1)
    mu = wp.array(rng.uniform(0.05, 1.0, args.texels), dtype=wp.float64, device=dev)
    alpha = wp.array(rng.uniform(0.05, 1.0, args.texels), dtype=wp.float64, device=dev)
    out = wp.zeros(args.texels, dtype=wp.float64, device=dev)
    evals = wp.zeros(args.texels, dtype=wp.int32, device=dev)
    rows = []
    print(f"{'case':<18} {'tol':>7} {'evals/inner':>11} {'inner ns/eval':>13} {'integrand ns/eval':>17} {'inner share':>11}")
    for mode, dist, label in ((0, 0, "reflect GGX"), (0, 1, "reflect Beckmann"), (1, 0, "dielectric GGX")):
        for tol in (1e-3, 1e-7):
            inner_map = 2 if tol >= 1e-3 else 1  # the shipped rule (integrate_texels: inner_map=None)
            times = {}
            for name, kernel, inputs in (("inner", inner_kernel, [mu, alpha, mode, dist, inner_map, tol, out, evals]),
                                         ("integrand", integrand_kernel, [mu, alpha, mode, dist, inner_map, evals, out])):
                wp.launch(kernel, dim=min(8, args.texels), inputs=inputs, device=dev)  # compile, warm
                if name == "inner":
                    wp.launch(kernel, dim=args.texels, inputs=inputs, device=dev)  # the counts for both
                    wp.synchronize_device(dev)
                t0 = time.perf_counter()
                wp.launch(kernel, dim=args.texels, inputs=inputs, device=dev)
                wp.synchronize_device(dev)
                times[name] = time.perf_counter() - t0
            total = int(evals.numpy().sum())
            row = {"case": label, "tol": tol, "evals_per_inner_integral": total / (args.texels * NT),
                   "inner_ns_per_eval": 1e9 * times["inner"] / total,
                   "integrand_ns_per_eval": 1e9 * times["integrand"] / total}
            row["inner_work_share"] = 1.0 - row["integrand_ns_per_eval"] / row["inner_ns_per_eval"]
            rows.append(row)
            print(f"{label:<18} {tol:>7g} {row['evals_per_inner_integral']:>11.1f} {row['inner_ns_per_eval']:>13.1f} "
                  f"{row['integrand_ns_per_eval']:>17.1f} {row['inner_work_share']:>11.0%}", flush=True)
    os.makedirs(os.path.dirname(args.out), exist_ok=True)
    with open(args.out, "w") as fh:
        json.dump({"device": dev.alias, "texels": args.texels, "rows": rows}, fh, indent=2)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
