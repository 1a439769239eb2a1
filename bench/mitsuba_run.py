"""The Mitsuba 3 peer's part of the accuracy benchmark: Mitsuba's estimates
(:mod:`bench.mitsuba_peer`) on the sweep's texels for the cases it can represent (separable
shadowing), judged by the same reference, with our ``adaptive``, ``mc_vndf`` and ``qmc_vndf``
timed on the same texels in the same run, and the ratios between the two.

Imports :mod:`bench.common` (cases, reference, method runs) and :mod:`bench.mitsuba_peer`;
:mod:`bench.accuracy_sweep` calls :func:`peer_run` at run time.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from bench.common import CASES, Case, aggregate, reference_values, run_method
from bench.mitsuba_peer import PeerEstimate, estimate, setup

#: samples per texel of the benchmark (full sweep / ``--quick``)
EFFORTS_FULL = [2**10, 2**12, 2**14, 2**16, 2**18, 2**20]
EFFORTS_QUICK = [2**10, 2**13]
#: the scalar fallback calls Python once per sample: it gets at most this many per texel
SCALAR_MAX_EFFORT = 2**12


#: our methods run on Mitsuba's cases in the same run, with their efforts (full / quick)
SAME_CASE_EFFORTS_FULL = {
    "adaptive": [1e-4, 1e-6],
    "mc_vndf": [2**10, 2**12, 2**14, 2**16, 2**18],
    "qmc_vndf": [2**10, 2**12, 2**14, 2**16, 2**18],
}
SAME_CASE_EFFORTS_QUICK = {"adaptive": [1e-4, 1e-6], "mc_vndf": [2**10, 2**13], "qmc_vndf": [2**10, 2**13]}


def peer_cases():
    """The benchmark cases Mitsuba can represent: separable shadowing, F = 1 albedo (GGX and
    Beckmann) and GGX dielectric at eta = 1.5, 1/1.5 and 1.01 (the dielectric cases of the main
    sweep, with separable instead of correlated shadowing)."""
    albedo = [c for c in CASES if c.mode == "reflect" and c.shadowing == "separable"]
    return albedo + [
        Case("dielectric GGX separable eta=1.5", "dielectric", "ggx", "separable", 1.5),
        Case("dielectric GGX separable eta=1/1.5 (TIR)", "dielectric", "ggx", "separable", 1.0 / 1.5),
        Case("dielectric GGX separable eta=1.01", "dielectric", "ggx", "separable", 1.01),
    ]


def texel_stats(nch: int, est: PeerEstimate, rv: np.ndarray, re: np.ndarray) -> dict:
    """Error and error-channel statistics of one estimate against the reference.

    Parameters
    ----------
    nch : int
        Channels compared (1: E, 2: R and T).
    est : PeerEstimate
    rv, re : numpy.ndarray
        (N, 2) reference values and their error bounds.

    Returns
    -------
    dict
        ``max_abs_err``, ``mean_abs_err``, ``honesty`` (fraction of texel-channels with
        |err| <= error channel + reference bound: our MC definition), ``n_dishonest``,
        ``within_3se`` and ``within_5se`` (|err| <= k standard errors + reference bound),
        ``median_z`` (median signed error in standard errors over channels with se > 0: a
        bias shifts it away from 0; the mean is useless here because texels whose error is a
        rare event no sample hit have se ~ 0), ``max_abs_z``, ``median_stderr``.
    """
    v, e, se = est.values[:, :nch], est.errors[:, :nch], est.stderr[:, :nch]
    diff = v - rv[:, :nch]
    err = np.abs(diff)
    bound = re[:, :nch]
    honest = err <= e + bound
    pos = se > 0
    z = diff[pos] / se[pos]
    return {
        "max_abs_err": float(err.max()),
        "mean_abs_err": float(err.mean()),
        "honesty": float(honest.mean()),
        "n_dishonest": int((~honest).sum()),
        "within_3se": float((err <= 3.0 * se + bound).mean()),
        "within_5se": float((err <= 5.0 * se + bound).mean()),
        "median_z": float(np.median(z)) if z.size else 0.0,
        "max_abs_z": float(np.abs(z).max()) if z.size else 0.0,
        "median_stderr": float(np.median(se)),
        "median_reported_err": float(np.median(e)),
    }


def _pool(rows: list[dict], key: str) -> list[dict]:
    """Per-effort totals over cases of ``rows`` (time per 1000 texels, worst / mean error,
    texel-weighted fractions)."""
    out = []
    for effort in dict.fromkeys(r[key] for r in rows):
        sel = [r for r in rows if r[key] == effort]
        n = sum(r["n_texels"] for r in sel)
        w = [r["n_texels"] for r in sel]
        out.append({
            key: effort,
            "time_s": float(sum(r["time_s"] for r in sel)),
            "time_per_1k_texels_s": 1000.0 * sum(r["time_s"] for r in sel) / n,
            "n_texels": n,
            "max_abs_err": max(r["max_abs_err"] for r in sel),
            "mean_abs_err": float(np.mean([r["mean_abs_err"] for r in sel])),
            "honesty": float(np.average([r["honesty"] for r in sel], weights=w)),
            "n_dishonest": int(sum(r["n_dishonest"] for r in sel)),
            **{k: float(np.average([r[k] for r in sel], weights=w)) for k in ("within_3se", "within_5se")
               if all(k in r for r in sel)},
        })
    return out


def peer_run(quick: bool, mu, alpha, *, cache_dir: Path | None = None, workers=None, device=None,
             log=print, efforts=None, same_case_efforts=None, variant: str | None = None) -> dict:
    """Mitsuba's estimates on the benchmark grid, plus our methods on the same cases, timed in
    the same run.

    Parameters
    ----------
    quick : bool
        Use :data:`EFFORTS_QUICK` / :data:`SAME_CASE_EFFORTS_QUICK`.
    mu, alpha : array_like
        The texels (flattened grid) of the sweep.
    cache_dir : Path, optional
        Where the reference values are cached.
    workers, device
        For our methods (as in the sweep).
    log : callable
        One line per step.
    efforts : list of int, optional
        Samples per texel for Mitsuba (default per ``quick``; the scalar fallback keeps those
        <= :data:`SCALAR_MAX_EFFORT`).
    same_case_efforts : dict, optional
        Method -> efforts of our methods on these cases (default per ``quick``; ``{}`` skips).
    variant : str, optional
        Force a Mitsuba variant.

    Returns
    -------
    dict
        The :func:`setup` status (``available``, ``note``, ...) and, when it ran: ``cases``,
        ``efforts``, ``rows`` (per case and effort: time, errors, honesty, within_3se, median_z,
        ...), ``summary`` (per effort, pooled over cases), ``summary_ggx`` (without the
        Beckmann case, whose G1 differs), ``warmup_s`` (kernel compilation, not in the times),
        ``same_cases`` (``rows`` and ``summary`` of our methods on the same texels) and
        ``comparison`` (ratios at matched sample counts and matched error).
    """
    status = setup(variant)
    if not status["available"]:
        return {**status, "ran": False}
    mu = np.asarray(mu, dtype=np.float64).ravel()
    alpha = np.asarray(alpha, dtype=np.float64).ravel()
    efforts = list(efforts or (EFFORTS_QUICK if quick else EFFORTS_FULL))
    if not status["vectorized"]:
        capped = [e for e in efforts if e <= SCALAR_MAX_EFFORT] or [SCALAR_MAX_EFFORT]
        if capped != efforts:
            log(f"mitsuba: scalar fallback, efforts capped at {SCALAR_MAX_EFFORT} samples per texel")
        efforts = capped
    cases = peer_cases()
    refs = {c.name: reference_values(c, mu, alpha, cache_dir=cache_dir) for c in cases}
    t0 = time.perf_counter()
    warm_mu, warm_alpha = np.array([0.5, 0.9]), np.full(2, float(np.median(alpha)))
    for case in cases:  # compile every kernel (one per block size) outside the timings
        for n in efforts:
            estimate(case.mode, case.dist, warm_mu, warm_alpha, case.eta, n_samples=n, seed=12345)
    warmup = time.perf_counter() - t0
    rows = []
    for n in efforts:
        for k, case in enumerate(cases):
            start = time.perf_counter()
            est = estimate(case.mode, case.dist, mu, alpha, case.eta, n_samples=n, seed=1000 * k + 1)
            dt = time.perf_counter() - start
            rv, re = refs[case.name]
            stats = texel_stats(len(case.channels), est, rv, re)
            rows.append({"samples_per_texel": n, "case": case.name, "time_s": dt, "n_texels": int(mu.size),
                         "max_weight": float(est.wmax.max()), **stats})
        pooled = _pool([r for r in rows if r["samples_per_texel"] == n], "samples_per_texel")[0]
        log(f"  mitsuba {n:>8d} spp  time {pooled['time_s']:7.3f} s  max err {pooled['max_abs_err']:.2e}  "
            f"mean {pooled['mean_abs_err']:.2e}  honest {pooled['honesty']:.4f}  within 3se {pooled['within_3se']:.4f}")
    out = {**status, "ran": True, "cases": [c.name for c in cases], "efforts": efforts,
           "n_texels_per_case": int(mu.size), "warmup_s": warmup, "rows": rows, "summary": _pool(rows, "samples_per_texel"),
           "summary_ggx": _pool([r for r in rows if "Beckmann" not in r["case"]], "samples_per_texel")}
    same = same_case_efforts if same_case_efforts is not None else (
        SAME_CASE_EFFORTS_QUICK if quick else SAME_CASE_EFFORTS_FULL)
    srows = []
    for method, ladder in same.items():
        for case in cases:  # warm-up
            run_method(method, ladder[0], case, mu[:2], alpha[:2], np.full(2, case.eta or 1.0), workers, device)
        for effort in ladder:
            for case in cases:
                eta = np.full(mu.size, case.eta or 1.0)
                start = time.perf_counter()
                v, e, evals = run_method(method, effort, case, mu, alpha, eta, workers, device)
                dt = time.perf_counter() - start
                rv, re = refs[case.name]
                nch = len(case.channels)
                err = np.abs(v[:, :nch] - rv[:, :nch])
                honest = err <= e[:, :nch] + re[:, :nch]
                srows.append({"method": method, "effort": effort, "case": case.name, "time_s": dt,
                              "n_texels": int(mu.size), "evals_per_texel": evals, "invalid_values": False,
                              "max_abs_err": float(err.max()), "mean_abs_err": float(err.mean()),
                              "honesty": float(honest.mean()), "n_dishonest": int((~honest).sum())})
            sel = [r for r in srows if r["method"] == method and r["effort"] == effort]
            log(f"  same cases {method:>9} {effort:<8g} time {sum(r['time_s'] for r in sel):7.3f} s  max err "
                f"{max(r['max_abs_err'] for r in sel):.2e}  mean {np.mean([r['mean_abs_err'] for r in sel]):.2e}")
    out["same_cases"] = {"efforts": same, "rows": srows, "summary": aggregate(srows) if srows else []}
    out["comparison"] = compare(out)
    return out


def compare(result: dict) -> dict:
    """Ratios between Mitsuba and our methods measured in one :func:`peer_run`.

    ``per_sample``: at each sample count both ran, our time / Mitsuba's time and our mean / max
    error over Mitsuba's. ``adaptive``: our adaptive method at each tolerance against the
    fastest Mitsuba point that is at least as accurate (max error), or Mitsuba's most accurate
    point when none is.
    """
    msum = {s["samples_per_texel"]: s for s in result.get("summary", [])}
    ours = result.get("same_cases", {}).get("summary", [])
    per_sample = []
    for s in ours:
        if s["method"] in ("mc_vndf", "qmc_vndf") and int(s["effort"]) in msum:
            m = msum[int(s["effort"])]
            per_sample.append({
                "method": s["method"], "samples_per_texel": int(s["effort"]),
                "time_ratio_ours_over_mitsuba": s["time_per_1k_texels_s"] / m["time_per_1k_texels_s"],
                "mean_err_ratio_ours_over_mitsuba": s["mean_abs_err"] / max(m["mean_abs_err"], 1e-300),
                "max_err_ratio_ours_over_mitsuba": s["max_abs_err"] / max(m["max_abs_err"], 1e-300),
            })
    adaptive = []
    pts = sorted(msum.values(), key=lambda s: s["time_per_1k_texels_s"])
    for s in ours:
        if s["method"] != "adaptive" or not pts:
            continue
        good = [m for m in pts if m["max_abs_err"] <= s["max_abs_err"]]
        m = good[0] if good else min(pts, key=lambda p: p["max_abs_err"])
        adaptive.append({
            "tolerance": s["effort"], "adaptive_time_per_1k_s": s["time_per_1k_texels_s"],
            "adaptive_max_err": s["max_abs_err"], "adaptive_mean_err": s["mean_abs_err"],
            "mitsuba_samples_per_texel": m["samples_per_texel"], "mitsuba_time_per_1k_s": m["time_per_1k_texels_s"],
            "mitsuba_max_err": m["max_abs_err"], "mitsuba_mean_err": m["mean_abs_err"],
            "mitsuba_reaches_it": bool(good),
            "time_ratio_mitsuba_over_adaptive": m["time_per_1k_texels_s"] / s["time_per_1k_texels_s"],
            "max_err_ratio_mitsuba_over_adaptive": m["max_abs_err"] / max(s["max_abs_err"], 1e-300),
        })
    return {"per_sample": per_sample, "adaptive": adaptive}
