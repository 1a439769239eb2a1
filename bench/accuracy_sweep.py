"""Accuracy against speed for every integration method, judged by an independent reference.

For each test case (``albedo``: GGX and Beckmann, separable and correlated shadowing, F = 1;
``dielectric``: GGX correlated, eta = 1.5, 1/1.5 and 1.01) on a (mu, alpha) grid that includes
grazing mu (1e-4) and near-mirror alpha (1e-3), every method of
:data:`bsdf_tab.integrate.METHODS` runs at increasing effort (``adaptive``: decreasing
tolerance). Each run records its wall time and, against the reference, the max / mean absolute
error over texels and channels and the *honesty* of its error channel: the fraction of
texel-channels whose true error |value - ref| is at most the reported error (+ the reference's
own bound). Outputs (:func:`run`): a JSON summary, a log-log chart of error against time (one
curve per method, Pareto front marked, plus error against samples per texel with the peer
tables as points), and per-method heatmaps of the error over (mu, alpha).

Reference: ``tests/reference/microfacet_ref.py`` (through :mod:`bench.common`; independent float64 code, composite
Gauss-Legendre product rule on alpha-graded panels split at every kink, at two resolutions; its
bound is the difference, ~1e-10). It lives in the source tree, not in the installed package:
run from a checkout. Reference values are cached under the output folder.

Peers: Mitsuba 3 (:mod:`bench.mitsuba_run`, imported only here, at run time):
when ``import mitsuba`` works and a variant can be set, it estimates the separable-shadowing
cases by sampling its ``roughconductor`` / ``roughdielectric`` at 2^10 .. 2^20 samples per
texel, and our ``adaptive``, ``mc_vndf`` and ``qmc_vndf`` run on the same texels in the same
run; otherwise it is skipped and the reason recorded (``--no-mitsuba`` skips it). And the
shipped tables in ``../shared/anchors`` (relative to the repository root; skipped when
absent): Cycles ``ggx_E`` (correlated, 2^23 samples per cell) and ``ggx_glass_E`` (eta > 1),
OpenPBR ``ideal_metal_energy_complement`` (separable), each judged at its own axes.

Figures: :mod:`bench.accuracy_figures`. The script ``bench/accuracy.py`` (or ``bsdf-tab bench
accuracy``) runs :func:`main`.
"""

from __future__ import annotations

import argparse
import gc
import json
import os
import platform
import time
from dataclasses import asdict
from pathlib import Path
from typing import Callable

import numpy as np

from bench.common import ANCHORS, CASES, DEFAULT_OUT, Case, aggregate, pareto, reference_values, run_method

MU_FULL = [1e-4, 0.01, 0.05, 0.1, 0.2, 0.3, 0.45, 0.6, 0.75, 0.9, 1.0]
ALPHA_FULL = [1e-3, 0.01, 0.03, 0.06, 0.1, 0.2, 0.35, 0.5, 0.75, 1.0]
MU_QUICK = [1e-4, 0.05, 0.3, 0.7, 1.0]
ALPHA_QUICK = [1e-3, 0.03, 0.2, 0.6]

#: effort ladder per method (adaptive: tolerance)
EFFORTS_FULL = {
    "adaptive": [1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7],
    "grid": [512, 2048, 8192, 32768, 131072],
    "mc_cosine": [256, 1024, 4096, 16384, 65536],
    "mc_dcos": [256, 1024, 4096, 16384, 65536],
    "mc_vndf": [256, 1024, 4096, 16384, 65536],
    "qmc_vndf": [256, 1024, 4096, 16384, 65536],
    "vndf_gl": [64, 256, 1024, 4096, 16384],
}
EFFORTS_QUICK = {
    "adaptive": [1e-3, 1e-5],
    "grid": [512, 4096],
    "mc_cosine": [256, 2048],
    "mc_dcos": [256, 2048],
    "mc_vndf": [256, 2048],
    "qmc_vndf": [256, 2048],
    "vndf_gl": [64, 576],
}


def _stats(case: Case, v, e, rv, re):
    """Error statistics of one run against the reference, and per texel the worst channel's
    error and whether every channel's error estimate held."""
    nch = len(case.channels)
    err = np.abs(v[:, :nch] - rv[:, :nch])
    honest = err <= e[:, :nch] + re[:, :nch]
    return {
        "max_abs_err": float(err.max()),
        "mean_abs_err": float(err.mean()),
        "honesty": float(honest.mean()),
        "n_dishonest": int((~honest).sum()),
        "median_reported_err": float(np.median(e[:, :nch])),
        "max_reported_err": float(e[:, :nch].max()),
    }, err.max(axis=1), honest.all(axis=1)


# ------------------------------------------------------------------------------ peers


def mitsuba_peer(result: dict, cache_dir: Path | None, workers=None, device=None, enabled: bool = True,
                 log: Callable[[str], None] = print) -> dict:
    """Run the Mitsuba 3 peer on the sweep's texels (:func:`bench.mitsuba_run.peer_run`),
    with those of our ``adaptive``, ``mc_vndf`` and ``qmc_vndf`` that the sweep ran on the same cases.

    Returns its result, or ``{"available": False, "ran": False, "note": why}`` when it is
    disabled, Mitsuba does not import, or no variant can be set. A failure inside the peer run
    is reported the same way (``ran`` False) rather than losing the sweep.
    """
    if not enabled:
        return {"available": False, "ran": False, "note": "skipped: disabled (--no-mitsuba)"}
    from bench import mitsuba_run as peer

    mg, ag = np.meshgrid(np.array(result["axes"]["mu"]), np.array(result["axes"]["alpha"]), indexing="ij")
    try:
        ladders = peer.SAME_CASE_EFFORTS_QUICK if result.get("quick") else peer.SAME_CASE_EFFORTS_FULL
        same = {m: e for m, e in ladders.items() if m in result["efforts"]}  # the methods this sweep ran
        return peer.peer_run(bool(result.get("quick")), mg.ravel(), ag.ravel(), cache_dir=cache_dir,
                             workers=workers, device=device, log=log, same_case_efforts=same)
    except Exception as exc:  # noqa: BLE001 - a peer failure must not lose the sweep
        return {"available": True, "ran": False, "note": f"failed: {type(exc).__name__}: {exc}"}


def anchors(quick: bool, cache_dir: Path | None, anchor_dir: Path = ANCHORS) -> list[dict]:
    """Error of the shipped peer tables against the reference, at their own axes."""
    out: list[dict] = []
    if not anchor_dir.is_dir():
        return out
    stride = 3 if quick else 1

    def load(rel):
        p = anchor_dir / rel
        return np.load(p) if p.exists() else None

    cyc_e, mu32, r32 = load("blender_cycles/ggx_E.npy"), load("blender_cycles/axis_mu32.npy"), load(
        "blender_cycles/axis_rough32.npy")
    if cyc_e is not None and mu32 is not None and r32 is not None:
        # [mu, rough]; rough node 0 is Cycles' perfect-mirror convention (E = 1): left out
        jj, ii = np.meshgrid(np.arange(0, 32, stride), np.arange(1, 32, stride), indexing="ij")
        mu, alpha = mu32[jj].ravel(), (r32[ii] ** 2).ravel()
        case = Case("cycles ggx_E", "reflect", "ggx", "correlated")
        rv, re = reference_values(case, mu, alpha, cache_dir=cache_dir)
        err = np.abs(cyc_e[jj, ii].ravel() - rv[:, 0])
        out.append({"name": "Cycles ggx_E", "samples_per_texel": 2**23, "n_texels": int(err.size),
                    "max_abs_err": float(err.max()), "mean_abs_err": float(err.mean()),
                    "note": "correlated G, F = 1, VNDF + Owen-scrambled Sobol, printed with 6 decimals"})
    glass, mu16, r16, ior16 = (load("blender_cycles/ggx_glass_E.npy"), load("blender_cycles/axis_mu16.npy"),
                               load("blender_cycles/axis_rough16.npy"), load("blender_cycles/axis_ior16.npy"))
    if glass is not None and mu16 is not None and r16 is not None and ior16 is not None:
        s = 2 * stride if quick else 1
        kk, jj, ii = np.meshgrid(np.arange(1, 16, s), np.arange(0, 16, s), np.arange(1, 16, s), indexing="ij")
        mu, alpha, eta = mu16[jj].ravel(), (r16[ii] ** 2).ravel(), ior16[kk].ravel()
        case = Case("cycles ggx_glass_E", "dielectric", "ggx", "correlated", 1.5)
        rv, re = reference_values(case, mu, alpha, eta, cache_dir=cache_dir)
        err = np.abs(glass[kk, jj, ii].ravel() - (rv[:, 0] + rv[:, 1]))
        out.append({"name": "Cycles ggx_glass_E (R+T, eta>1)", "samples_per_texel": 2**23,
                    "n_texels": int(err.size), "max_abs_err": float(err.max()), "mean_abs_err": float(err.mean()),
                    "note": "ior node 0 (eta = 1) and rough node 0 (mirror) left out"})
    metal, cos32, rr32 = (load("adobe_openpbr_bsdf/ideal_metal_energy_complement.npy"),
                          load("adobe_openpbr_bsdf/axis_cos32.npy"), load("adobe_openpbr_bsdf/axis_rough32.npy"))
    if metal is not None:
        cos32 = np.arange(32) / 31.0 if cos32 is None else cos32
        rr32 = np.arange(32) / 31.0 if rr32 is None else rr32
        ii, jj = np.meshgrid(np.arange(1, 32, stride), np.arange(0, 32, stride), indexing="ij")
        mu, alpha = cos32[jj].ravel(), (rr32[ii] ** 2).ravel()
        case = Case("openpbr metal", "reflect", "ggx", "separable")
        rv, re = reference_values(case, mu, alpha, cache_dir=cache_dir)
        err = np.abs((1.0 - metal[ii, jj]).ravel() - rv[:, 0])
        out.append({"name": "OpenPBR ideal_metal (1 - E)", "samples_per_texel": None, "n_texels": int(err.size),
                    "max_abs_err": float(err.max()), "mean_abs_err": float(err.mean()),
                    "note": "separable G, F = 1, uint16 UNORM, generator not public (sample count unknown)"})
    return out


# ------------------------------------------------------------------------------ sweep


def sweep(quick: bool = False, methods=None, out_dir: Path = DEFAULT_OUT, workers=None, device=None,
          log: Callable[[str], None] = print, cases=None) -> dict:
    """Run every method at every effort on every case; returns the JSON-able summary and, under
    the key ``_maps``, per-method (case -> (mu x alpha) max-channel error) arrays of the highest
    effort (for the heatmaps)."""
    from bsdf_tab.integrate import METHODS

    efforts = EFFORTS_QUICK if quick else EFFORTS_FULL
    methods = [m for m in (methods or list(efforts)) if m in METHODS]
    mu_axis = np.array(MU_QUICK if quick else MU_FULL)
    alpha_axis = np.array(ALPHA_QUICK if quick else ALPHA_FULL)
    cases = cases or CASES
    mg, ag = np.meshgrid(mu_axis, alpha_axis, indexing="ij")
    mu, alpha = mg.ravel(), ag.ravel()
    cache = out_dir / "cache"
    refs = {}
    t0 = time.perf_counter()
    for case in cases:
        refs[case.name] = reference_values(case, mu, alpha, cache_dir=cache)
    log(f"reference: {len(cases)} cases x {mu.size} texels in {time.perf_counter() - t0:.1f} s; "
        f"max bound {max(float(r[1].max()) for r in refs.values()):.2g}")
    rows, maps, honest_maps = [], {}, {}
    for method in methods:
        # warm-up: compile / load the kernels, and start the worker threads (a few chunks' worth of
        # texels), outside the timings
        for case in cases:
            run_method(method, efforts[method][0], case, mu[:16], alpha[:16], np.full(16, case.eta or 1.0), workers,
                       device)
        for effort in efforts[method]:
            for case in cases:
                eta = np.full(mu.size, case.eta or 1.0)
                # the cyclic collector off while timing (as timeit does): a full collection over the
                # sweep's growing lists took ~50 ms inside one 3 ms table
                gc.disable()
                try:
                    start = time.perf_counter()
                    v, e, evals = run_method(method, effort, case, mu, alpha, eta, workers, device)
                    dt = time.perf_counter() - start
                finally:
                    gc.enable()
                rv, re = refs[case.name]
                stats, texel_err, texel_honest = _stats(case, v, e, rv, re)
                bad = ~np.isfinite(v).all() or (v < 0).any() or (v > 1).any()
                rows.append({"method": method, "effort": effort, "case": case.name, "time_s": dt,
                             "n_texels": int(mu.size), "evals_per_texel": evals, "invalid_values": bool(bad),
                             **stats})
                if effort == efforts[method][-1]:
                    maps.setdefault(method, {})[case.name] = texel_err.reshape(mg.shape).tolist()
                    honest_maps.setdefault(method, {})[case.name] = texel_honest.reshape(mg.shape).tolist()
            agg = [r for r in rows if r["method"] == method and r["effort"] == effort]
            log(f"{method:>9} effort {effort:<8g} time {sum(r['time_s'] for r in agg):7.3f} s  "
                f"max err {max(r['max_abs_err'] for r in agg):.2e}  mean {np.mean([r['mean_abs_err'] for r in agg]):.2e}"
                f"  honest {np.mean([r['honesty'] for r in agg]):.4f}")
    summary = aggregate(rows)
    return {
        "quick": quick,
        "axes": {"mu": mu_axis.tolist(), "alpha": alpha_axis.tolist()},
        "cases": [asdict(c) for c in cases],
        "efforts": {m: efforts[m] for m in methods},
        "rows": rows,
        "summary": summary,
        "pareto_max": [summary[k]["label"] for k in pareto([(s["time_per_1k_texels_s"], s["max_abs_err"])
                                                             for s in summary])],
        "pareto_mean": [summary[k]["label"] for k in pareto([(s["time_per_1k_texels_s"], s["mean_abs_err"])
                                                              for s in summary])],
        "machine": {"platform": platform.platform(), "cpus": os.cpu_count(), "workers": workers},
        "_maps": maps,
        "_honest_maps": honest_maps,
    }


# ------------------------------------------------------------------------------ entry point


def run(quick: bool = False, out_dir: Path | str = DEFAULT_OUT, methods=None, workers=None, device=None,
        anchors_dir: Path | str | None = None, log: Callable[[str], None] = print, mitsuba: bool = True) -> dict:
    """The whole benchmark: sweep, peers, JSON and PNGs under ``out_dir``. Returns the summary.
    ``mitsuba=False`` skips the Mitsuba 3 peer (recorded as skipped)."""
    from bench.accuracy_figures import chart, heatmaps

    _quiet_warp()
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    result = sweep(quick=quick, methods=methods, out_dir=out_dir, workers=workers, device=device, log=log)
    peers = anchors(quick, out_dir / "cache", Path(anchors_dir) if anchors_dir else ANCHORS)
    for p in peers:
        log(f"peer {p['name']}: {p['n_texels']} texels, max err {p['max_abs_err']:.2e}, mean {p['mean_abs_err']:.2e}")
    if not peers:
        log(f"peer tables: none found under {anchors_dir or ANCHORS} (skipped)")
    log("mitsuba: " + ("running the peer" if mitsuba else "disabled"))
    mitsuba_result = mitsuba_peer(result, out_dir / "cache", workers=workers, device=device, enabled=mitsuba, log=log)
    log(f"mitsuba: {mitsuba_result['note']}" + ("" if mitsuba_result.get("ran") else " (not run)"))
    stem = "accuracy_quick" if quick else "accuracy"
    chart(result, out_dir / f"{stem}.png", peers, mitsuba_result)
    heatmaps(result, out_dir / f"{stem}_heatmaps.png")
    public = {k: v for k, v in result.items() if not k.startswith("_")}
    public["heatmaps"] = {m: {"max_abs_err": result["_maps"][m], "honest": result["_honest_maps"][m]}
                          for m in result["_maps"]}
    public["peers"] = {"anchors": peers, "mitsuba": mitsuba_result}
    public["files"] = {"chart": f"{stem}.png", "heatmaps": f"{stem}_heatmaps.png"}
    (out_dir / f"{stem}.json").write_text(json.dumps(public, indent=1), encoding="utf-8")
    log(f"wrote {out_dir / (stem + '.json')}, {stem}.png, {stem}_heatmaps.png")
    return public


def _quiet_warp() -> None:
    try:
        from bsdf_tab.api import quiet_warp
    except ImportError:  # an older bsdf_tab
        import warp

        warp.config.quiet = True
    else:
        quiet_warp()


def configure_parser(parser: argparse.ArgumentParser) -> None:
    """Add the benchmark's options to ``parser``."""
    parser.add_argument("--quick", action="store_true", help="small grid and effort ladder (about a minute)")
    parser.add_argument("-o", "--out", default=str(DEFAULT_OUT), help="output folder (default: bench/out)")
    parser.add_argument("--methods", default=None, help="comma-separated subset of methods")
    parser.add_argument("--workers", type=int, default=None, help="worker threads (default: all cores)")
    parser.add_argument("--device", default=None, help="Warp device (default: CUDA if present, else cpu)")
    parser.add_argument("--anchors", default=None, help="peer tables folder (default: ../shared/anchors)")
    parser.add_argument("--no-mitsuba", action="store_true",
                        help="skip the Mitsuba 3 peer (it runs when mitsuba imports and a variant can be set)")


def build_parser(prog: str | None = None) -> argparse.ArgumentParser:
    """The benchmark's argument parser (``prog``: the name in its usage line)."""
    parser = argparse.ArgumentParser(
        prog=prog, description="Accuracy against speed of every integration method, judged by the independent "
        "reference (needs a source checkout); writes JSON and PNGs (default: bench/out/).")
    configure_parser(parser)
    return parser


def main_from_args(args: argparse.Namespace) -> int:
    """Validate the options (ValueError: one line naming the option), then :func:`run`."""
    from bsdf_tab.integrate import METHODS

    methods = None
    if args.methods is not None:
        methods = [m.strip() for m in args.methods.split(",") if m.strip()]
        unknown = [m for m in methods if m not in METHODS or m not in EFFORTS_FULL]
        if not methods or unknown:
            raise ValueError(f"--methods: unknown method(s) {', '.join(unknown) or repr(args.methods)}; "
                             f"choose from {', '.join(m for m in EFFORTS_FULL if m in METHODS)}")
    if args.workers is not None and args.workers < 1:
        raise ValueError(f"--workers must be >= 1, got {args.workers}")
    run(quick=args.quick, out_dir=args.out, methods=methods, workers=args.workers, device=args.device,
        anchors_dir=args.anchors, mitsuba=not args.no_mitsuba)
    return 0


def main(argv: list[str] | None = None, prog: str | None = None) -> int:
    """Parse ``argv`` (default: ``sys.argv[1:]``) and run. Bad options raise ValueError (one
    line); a missing reference raises RuntimeError; argparse's own errors exit 2."""
    return main_from_args(build_parser(prog).parse_args(argv))
