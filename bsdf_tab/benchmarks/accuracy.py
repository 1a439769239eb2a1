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

Reference: ``tests/reference/microfacet_ref.py`` (independent float64 code, composite
Gauss-Legendre product rule on alpha-graded panels split at every kink, at two resolutions; its
bound is the difference, ~1e-10). It lives in the source tree, not in the installed package:
run from a checkout. Reference values are cached under the output folder.

Peers: Mitsuba 3 (:mod:`bsdf_tab.benchmarks.mitsuba_peer`, imported only here, at run time):
when ``import mitsuba`` works and a variant can be set, it estimates the separable-shadowing
cases by sampling its ``roughconductor`` / ``roughdielectric`` at 2^10 .. 2^20 samples per
texel, and our ``adaptive``, ``mc_vndf`` and ``qmc_vndf`` run on the same texels in the same
run; otherwise it is skipped and the reason recorded (``--no-mitsuba`` skips it). And the
shipped tables in ``../shared/anchors`` (relative to the repository root; skipped when
absent): Cycles ``ggx_E`` (correlated, 2^23 samples per cell) and ``ggx_glass_E`` (eta > 1),
OpenPBR ``ideal_metal_energy_complement`` (separable), each judged at its own axes.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import platform
import sys
import time
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Callable

import numpy as np

REPO_ROOT = Path(__file__).resolve().parents[2]
DEFAULT_OUT = REPO_ROOT / "bench" / "out"
ANCHORS = REPO_ROOT.parent / "shared" / "anchors"

_DIST = {"ggx": 0, "beckmann": 1}
_SHAD = {"separable": 0, "correlated": 1}


@dataclass(frozen=True)
class Case:
    name: str
    mode: str  # "reflect" (albedo, F = 1) or "dielectric"
    dist: str
    shadowing: str
    eta: float | None = None

    @property
    def channels(self) -> tuple[str, ...]:
        return ("E",) if self.mode == "reflect" else ("R", "T")


CASES = [
    Case("albedo GGX separable", "reflect", "ggx", "separable"),
    Case("albedo GGX correlated", "reflect", "ggx", "correlated"),
    Case("albedo Beckmann separable", "reflect", "beckmann", "separable"),
    Case("albedo Beckmann correlated", "reflect", "beckmann", "correlated"),
    Case("dielectric GGX eta=1.5", "dielectric", "ggx", "correlated", 1.5),
    Case("dielectric GGX eta=1/1.5 (TIR)", "dielectric", "ggx", "correlated", 1.0 / 1.5),
    Case("dielectric GGX eta=1.01", "dielectric", "ggx", "correlated", 1.01),
]

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
COLORS = {
    "adaptive": "black", "grid": "tab:brown", "mc_cosine": "tab:red", "mc_dcos": "tab:orange",
    "mc_vndf": "tab:blue", "qmc_vndf": "tab:green", "vndf_gl": "tab:purple",
}


# ------------------------------------------------------------------------------ reference


def _reference_module():
    try:
        from tests.reference import microfacet_ref
    except ImportError:
        if str(REPO_ROOT) not in sys.path:
            sys.path.insert(0, str(REPO_ROOT))
        try:
            from tests.reference import microfacet_ref
        except ImportError as exc:
            raise RuntimeError(
                "the independent reference (tests/reference/microfacet_ref.py) is not importable: "
                "run the accuracy benchmark from a source checkout"
            ) from exc
    return microfacet_ref


def _ref_texel(ref, kind, mu, alpha, dist, shad, eta=None, fres=("one",)):
    """Value and error bound of one reference integral (its method B: composite
    Gauss-Legendre at two resolutions). alpha = 0: the closed-form mirror value."""
    if alpha == 0.0:
        if kind == "R":
            return float(ref.fresnel(mu, fres)) if mu > 0 else 0.0, 0.0
        f = float(ref.F_dielectric(mu, eta)) if mu > 0 else 0.0
        return (1.0 - f if mu > 0 else 0.0), 0.0
    tex = ref._Texel(kind, mu, alpha, dist, shad, fres=fres, eta=eta)
    v, e = ref.method_b(tex)
    return float(v), float(e) + 1e-15


def reference_values(case: Case, mu, alpha, eta=None, cache_dir: Path | None = None):
    """(values, errors), each (N, 2), of the reference at the texels (mu[k], alpha[k][, eta[k]])."""
    mu = np.asarray(mu, dtype=np.float64)
    alpha = np.asarray(alpha, dtype=np.float64)
    eta = np.full(mu.shape, case.eta if case.eta is not None else 1.0) if eta is None else np.asarray(eta, float)
    key = hashlib.sha256(
        json.dumps([asdict(case), mu.tolist(), alpha.tolist(), eta.tolist(), "method_b/v1"]).encode()
    ).hexdigest()[:16]
    path = cache_dir / f"reference_{key}.npz" if cache_dir else None
    if path is not None and path.exists():
        with np.load(path) as z:
            return z["values"], z["errors"]
    ref = _reference_module()
    values = np.zeros((mu.size, 2))
    errors = np.zeros((mu.size, 2))
    for k in range(mu.size):
        m, a, e = float(mu[k]), float(alpha[k]), float(eta[k])
        if case.mode == "reflect":
            values[k, 0], errors[k, 0] = _ref_texel(ref, "R", m, a, case.dist, case.shadowing)
        else:
            values[k, 0], errors[k, 0] = _ref_texel(ref, "R", m, a, case.dist, case.shadowing,
                                                    fres=("dielectric", e))
            values[k, 1], errors[k, 1] = _ref_texel(ref, "T", m, a, case.dist, case.shadowing, eta=e)
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        np.savez(path, values=values, errors=errors)
    return values, errors


# ------------------------------------------------------------------------------ methods


def _call(method: str, effort, case: Case, mu, alpha, eta, workers=None, device=None):
    """Run one method; returns (values, errors, evaluations per texel)."""
    from ..integrate import METHODS

    fn = METHODS[method]
    kw = dict(dist=_DIST[case.dist], shadowing=_SHAD[case.shadowing], ftype=0, device=device, workers=workers)
    if method == "adaptive":
        v, e, cost = fn(case.mode, mu, alpha, eta, tol=float(effort), return_cost=True, **kw)
        return v, e, float(np.mean(cost))
    v, e = fn(case.mode, mu, alpha, eta, effort=int(effort), **kw)
    evals = float(effort)
    if method == "grid":
        evals *= 1.25 * (2 if case.mode == "dielectric" else 1)  # + the half-resolution grid
    elif method == "vndf_gl":
        from ..integrate.vndf_gl import order

        evals = 1.25 * order(int(effort)) ** 2
    elif method == "mc_cosine" and case.mode == "dielectric":
        evals *= 2
    return v, e, evals


def _stats(case: Case, v, e, rv, re):
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


def pareto(points):
    """Indices of the points (time, error) not dominated by a faster-or-equal, more accurate one."""
    order = sorted(range(len(points)), key=lambda k: (points[k][0], points[k][1]))
    front, best = [], math.inf
    for k in order:
        if points[k][1] < best:
            front.append(k)
            best = points[k][1]
    return front


# ------------------------------------------------------------------------------ peers


def mitsuba_peer(result: dict, cache_dir: Path | None, workers=None, device=None, enabled: bool = True,
                 log: Callable[[str], None] = print) -> dict:
    """Run the Mitsuba 3 peer on the sweep's texels (:func:`bsdf_tab.benchmarks.mitsuba_peer.peer_run`),
    with those of our ``adaptive``, ``mc_vndf`` and ``qmc_vndf`` that the sweep ran on the same cases.

    Returns its result, or ``{"available": False, "ran": False, "note": why}`` when it is
    disabled, Mitsuba does not import, or no variant can be set. A failure inside the peer run
    is reported the same way (``ran`` False) rather than losing the sweep.
    """
    if not enabled:
        return {"available": False, "ran": False, "note": "skipped: disabled (--no-mitsuba)"}
    from . import mitsuba_peer as peer

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
    from ..integrate import METHODS

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
        # warm-up: compile / load the kernels outside the timings
        for case in cases:
            _call(method, efforts[method][0], case, mu[:2], alpha[:2], np.full(2, case.eta or 1.0), workers, device)
        for effort in efforts[method]:
            for case in cases:
                eta = np.full(mu.size, case.eta or 1.0)
                start = time.perf_counter()
                v, e, evals = _call(method, effort, case, mu, alpha, eta, workers, device)
                dt = time.perf_counter() - start
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


def aggregate(rows: list[dict]) -> list[dict]:
    """One point per (method, effort): time per 1000 texels over all cases, worst / mean error,
    honesty pooled over all texel-channels."""
    out = []
    keys = []
    for r in rows:
        if (r["method"], r["effort"]) not in keys:
            keys.append((r["method"], r["effort"]))
    for method, effort in keys:
        sel = [r for r in rows if r["method"] == method and r["effort"] == effort]
        n = sum(r["n_texels"] for r in sel)
        out.append({
            "method": method, "effort": effort, "label": f"{method}@{effort:g}",
            "time_per_1k_texels_s": 1000.0 * sum(r["time_s"] for r in sel) / n,
            "evals_per_texel": float(np.mean([r["evals_per_texel"] for r in sel])),
            "max_abs_err": max(r["max_abs_err"] for r in sel),
            "mean_abs_err": float(np.mean([r["mean_abs_err"] for r in sel])),
            "honesty": float(np.average([r["honesty"] for r in sel], weights=[r["n_texels"] for r in sel])),
            "n_dishonest": int(sum(r["n_dishonest"] for r in sel)),
            "invalid_values": any(r["invalid_values"] for r in sel),
        })
    return out


# ------------------------------------------------------------------------------ figures


def chart(result: dict, path: Path, peers: list[dict] | None = None, mitsuba: dict | None = None) -> None:
    """Three panels: max error and mean error against time per 1000 texels (log-log, one curve
    per method, Pareto front dashed), and mean error against samples per texel with the peer
    tables as points. When the Mitsuba peer ran (``mitsuba["ran"]``), its points are a magenta
    diamond curve on all three panels, and our methods on the same (separable) cases are thin
    dotted curves in their colours; the Pareto front is the main sweep's only."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    summary = result["summary"]
    floor = 1e-12
    fig, axes = plt.subplots(1, 3, figsize=(22, 6.2))
    for ax, key, title in ((axes[0], "max_abs_err", "worst texel"), (axes[1], "mean_abs_err", "mean over texels")):
        for method in dict.fromkeys(s["method"] for s in summary):
            pts = [s for s in summary if s["method"] == method]
            x = [s["time_per_1k_texels_s"] for s in pts]
            y = [max(s[key], floor) for s in pts]
            ax.plot(x, y, "o-", color=COLORS.get(method), label=method, ms=5)
            for s, xx, yy in zip(pts, x, y):
                if s["honesty"] < 0.999:
                    ax.plot(xx, yy, "x", color="red", ms=11, mew=2)
        front = pareto([(s["time_per_1k_texels_s"], s[key]) for s in summary])
        fx = [summary[k]["time_per_1k_texels_s"] for k in front]
        fy = [max(summary[k][key], floor) for k in front]
        ax.step(fx, fy, where="post", ls="--", color="gray", lw=1.2, label="Pareto front")
        ax.plot(fx, fy, "o", mfc="none", mec="gray", ms=12)
        if mitsuba and mitsuba.get("ran"):
            _mitsuba_curves(ax, mitsuba, "time_per_1k_texels_s", key, floor)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("wall time per 1000 texels [s]")
        ax.set_ylabel(f"absolute error vs reference ({title})")
        ax.set_title(f"error vs time: {title}")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].plot([], [], "x", color="red", ms=9, mew=2, label="honesty < 99.9%")
    axes[0].legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.11), ncol=3)
    ax = axes[2]
    for method in dict.fromkeys(s["method"] for s in summary):
        pts = [s for s in summary if s["method"] == method]
        ax.plot([s["evals_per_texel"] for s in pts], [max(s["mean_abs_err"], floor) for s in pts], "o-",
                color=COLORS.get(method), label=method, ms=5)
    if mitsuba and mitsuba.get("ran"):
        _mitsuba_curves(ax, mitsuba, "samples_per_texel", "mean_abs_err", floor)
    xmax = max(s["evals_per_texel"] for s in summary)
    for k, p in enumerate(peers or []):
        x = p["samples_per_texel"] or xmax * 4
        ax.plot(x, max(p["mean_abs_err"], floor), marker="*", ms=16,
                color=f"C{k + 6}", ls="none",
                label=f"{p['name']} (mean {p['mean_abs_err']:.1e}, max {p['max_abs_err']:.1e})"
                + ("" if p["samples_per_texel"] else " [samples unknown]"))
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("integrand evaluations (samples) per texel")
    ax.set_ylabel("mean absolute error vs reference")
    ax.set_title("error vs samples, peer tables as stars")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    sub = "quick" if result.get("quick") else "full"
    fig.suptitle(f"bsdf-tab accuracy vs speed ({sub} sweep: {len(result['cases'])} cases x "
                 f"{len(result['axes']['mu']) * len(result['axes']['alpha'])} texels)", fontsize=12)
    fig.tight_layout()
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)


def _mitsuba_curves(ax, mitsuba: dict, xkey: str, ykey: str, floor: float) -> None:
    """Mitsuba's points (magenta diamonds) and our methods on the same cases (dotted)."""
    ncases = len(mitsuba.get("cases", []))
    pts = mitsuba["summary"]
    x = [s[xkey] for s in pts]
    y = [max(s[ykey], floor) for s in pts]
    ax.plot(x, y, "D-", color="magenta", ms=6, lw=1.6,
            label=f"Mitsuba 3 {mitsuba.get('variant')} ({ncases} separable cases)")
    for s, xx, yy in zip(pts, x, y):
        if s["honesty"] < 0.999:
            ax.plot(xx, yy, "x", color="red", ms=11, mew=2)
    same = mitsuba.get("same_cases", {}).get("summary", [])
    for method in dict.fromkeys(s["method"] for s in same):
        sel = [s for s in same if s["method"] == method]
        sx = [s["evals_per_texel"] if xkey == "samples_per_texel" else s[xkey] for s in sel]
        ax.plot(sx, [max(s[ykey], floor) for s in sel], ".:", color=COLORS.get(method), lw=1.0, ms=4,
                label=f"{method}, Mitsuba's cases")


def heatmaps(result: dict, path: Path) -> None:
    """Rows: methods (at their highest effort); columns: cases. Colour: log10 of the worst
    channel's absolute error over (mu, alpha); texels whose error channel lied are boxed red."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    maps, hmaps = result["_maps"], result["_honest_maps"]
    methods = list(maps)
    cases = [c["name"] for c in result["cases"]]
    mu, alpha = result["axes"]["mu"], result["axes"]["alpha"]
    fig, axes = plt.subplots(len(methods), len(cases), figsize=(2.6 * len(cases) + 1.5, 2.3 * len(methods) + 0.8),
                             squeeze=False)
    im = None
    for r, method in enumerate(methods):
        for c, case in enumerate(cases):
            ax = axes[r][c]
            err = np.log10(np.maximum(np.array(maps[method][case]), 1e-12))
            im = ax.imshow(err.T, origin="lower", cmap="viridis", vmin=-12, vmax=0, aspect="auto")
            bad = ~np.array(hmaps[method][case])
            for j, i in zip(*np.nonzero(bad)):
                ax.add_patch(plt.Rectangle((j - 0.5, i - 0.5), 1, 1, fill=False, ec="red", lw=1.5))
            ax.set_xticks(range(len(mu)))
            ax.set_xticklabels([f"{m:g}" for m in mu], rotation=90, fontsize=6)
            ax.set_yticks(range(len(alpha)))
            ax.set_yticklabels([f"{a:g}" for a in alpha], fontsize=6)
            if r == 0:
                ax.set_title(case, fontsize=8)
            if c == 0:
                eff = result["efforts"][method][-1]
                ax.set_ylabel(f"{method}@{eff:g}\nalpha", fontsize=8)
            if r == len(methods) - 1:
                ax.set_xlabel("mu", fontsize=7)
    fig.colorbar(im, ax=axes, shrink=0.6, label="log10 |error| (worst channel); red box: error channel too small")
    fig.suptitle("Where each method fails: error over (mu, alpha) at its highest effort", fontsize=12)
    fig.savefig(path, dpi=90)
    plt.close(fig)


# ------------------------------------------------------------------------------ entry point


def run(quick: bool = False, out_dir: Path | str = DEFAULT_OUT, methods=None, workers=None, device=None,
        anchors_dir: Path | str | None = None, log: Callable[[str], None] = print, mitsuba: bool = True) -> dict:
    """The whole benchmark: sweep, peers, JSON and PNGs under ``out_dir``. Returns the summary.
    ``mitsuba=False`` skips the Mitsuba 3 peer (recorded as skipped)."""
    import warp as wp

    wp.config.quiet = True
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


def configure_parser(parser) -> None:
    parser.add_argument("--quick", action="store_true", help="small grid and effort ladder (about a minute)")
    parser.add_argument("-o", "--out", default=str(DEFAULT_OUT), help="output folder (default: bench/out)")
    parser.add_argument("--methods", default=None, help="comma-separated subset of methods")
    parser.add_argument("--workers", type=int, default=None, help="worker threads (default: all cores)")
    parser.add_argument("--device", default=None, help="Warp device (default: CUDA if present, else cpu)")
    parser.add_argument("--anchors", default=None, help="peer tables folder (default: ../shared/anchors)")
    parser.add_argument("--no-mitsuba", action="store_true",
                        help="skip the Mitsuba 3 peer (it runs when mitsuba imports and a variant can be set)")


def main_from_args(args) -> int:
    """Validate the options (ValueError: one line naming the option), then :func:`run`."""
    from ..integrate import METHODS

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
        anchors_dir=args.anchors, mitsuba=not getattr(args, "no_mitsuba", False))
    return 0
