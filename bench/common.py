"""What the accuracy sweep and the Mitsuba peer share: the checkout's folders, the test cases,
the independent reference at a set of texels, one run of one integration method, the pooling
of rows into one point per (method, effort) and the Pareto front of such points.

Both :mod:`bench.accuracy_sweep` and :mod:`bench.mitsuba_run` import this module; it imports
neither (no cycle). It runs from a source checkout: the reference lives in
``tests/reference/microfacet_ref.py``, which is not part of the installed package.
"""

from __future__ import annotations

import hashlib
import json
import math
import sys
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

REPO_ROOT = Path(__file__).resolve().parents[1]
DEFAULT_OUT = REPO_ROOT / "bench" / "out"
ANCHORS = REPO_ROOT.parent / "shared" / "anchors"


@dataclass(frozen=True)
class Case:
    """One benchmark case: a table mode, a distribution and a shadowing (spec names), an eta."""

    name: str
    mode: str  # "reflect" (albedo, F = 1) or "dielectric"
    dist: str  # a spec ``distribution`` name
    shadowing: str  # a spec ``shadowing`` name
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


# ------------------------------------------------------------------------------ model selectors


def _selector(registry_name: str, fallback_suffix: str, name: str) -> int:
    """The integer selector the integrators take for a spec name: from the model's registry
    (``bsdf_tab.model.DISTRIBUTIONS`` / ``SHADOWINGS``, entries an int or an object with an
    ``id``) when it has one, else the exported constant (``bsdf_tab.model.GGX``, ...)."""
    import bsdf_tab.model as model

    registry = getattr(model, registry_name, None)
    if isinstance(registry, dict) and name in registry:
        entry = registry[name]
        return int(getattr(entry, "id", entry))
    value = getattr(model, name.upper(), None)
    if value is None:
        raise ValueError(f"unknown {fallback_suffix} {name!r}")
    return int(value)


def distribution_id(name: str) -> int:
    """Selector of the distribution ``name`` (``"ggx"``, ``"beckmann"``, ...)."""
    return _selector("DISTRIBUTIONS", "distribution", name)


def shadowing_id(name: str) -> int:
    """Selector of the shadowing ``name`` (``"separable"``, ``"correlated"``)."""
    return _selector("SHADOWINGS", "shadowing", name)


# ------------------------------------------------------------------------------ reference


def reference_module():
    """``tests/reference/microfacet_ref`` of this checkout (RuntimeError when absent)."""
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


def reference_values(case: Case, mu, alpha, eta=None, cache_dir: Path | None = None):
    """(values, errors), each (N, 2), of the reference at the texels (mu[k], alpha[k][, eta[k]]).

    Each value is the reference's method B (composite Gauss-Legendre at two resolutions, its
    bound the difference); alpha = 0 is the closed-form mirror value. Cached under
    ``cache_dir`` (``reference_<hash>.npz``) when given.
    """
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
    ref = reference_module()
    values = np.zeros((mu.size, 2))
    errors = np.zeros((mu.size, 2))
    for k in range(mu.size):
        m, a, e = float(mu[k]), float(alpha[k]), float(eta[k])
        if case.mode == "reflect":
            r = ref.albedo(m, a, case.dist, case.shadowing, methods="B")
            values[k, 0], errors[k, 0] = r.value, r.err
        else:
            r, t = ref.dielectric(m, a, e, case.dist, case.shadowing, methods="B")
            values[k] = r.value, t.value
            errors[k] = r.err, t.err
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        np.savez(path, values=values, errors=errors)
    return values, errors


# ------------------------------------------------------------------------------ methods


def run_method(method: str, effort, case: Case, mu, alpha, eta, workers=None, device=None):
    """Run one integration method (:func:`bsdf_tab.integrate.get_method`) on the texels at one
    effort (``adaptive``: its tolerance). Returns (values, errors, evaluations per texel).

    The integrator is called directly rather than through :func:`bsdf_tab.tabulate`, whose
    tables are stored as float32: the sweep measures errors down to 1e-10.
    """
    from bsdf_tab.integrate import get_method
    from bsdf_tab.model import FRESNEL_ONE

    fn = get_method(method)
    kw = dict(dist=distribution_id(case.dist), shadowing=shadowing_id(case.shadowing), ftype=int(FRESNEL_ONE),
              device=device, workers=workers)
    if method == "adaptive":
        v, e, cost = fn(case.mode, mu, alpha, eta, tol=float(effort), return_cost=True, **kw)
        return v, e, float(np.mean(cost))
    v, e = fn(case.mode, mu, alpha, eta, effort=int(effort), **kw)
    evals = float(effort)
    if method == "grid":
        evals *= 1.25 * (2 if case.mode == "dielectric" else 1)  # + the half-resolution grid
    elif method == "vndf_gl":
        from bsdf_tab.integrate.vndf_gl import order

        evals = 1.25 * order(int(effort)) ** 2
    elif method == "mc_cosine" and case.mode == "dielectric":
        evals *= 2
    return v, e, evals


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


def pareto(points):
    """Indices of the points (time, error) not dominated by a faster-or-equal, more accurate one."""
    order = sorted(range(len(points)), key=lambda k: (points[k][0], points[k][1]))
    front, best = [], math.inf
    for k in order:
        if points[k][1] < best:
            front.append(k)
            best = points[k][1]
    return front


def parse_variants(texts) -> list[dict]:
    """``--variant KEY=VALUE[,KEY=VALUE]`` options -> integrate_texels keyword dicts (ints, floats,
    or booleans for ``true`` / ``false``).

    Raises ValueError naming the bad text (the scripts print it as one line and exit 2).
    """
    variants = []
    for text in texts:
        d = {}
        for kv in text.split(","):
            k, sep, val = kv.partition("=")
            if not sep or not k:
                raise ValueError(f"--variant: expected KEY=VALUE, got {kv!r}")
            if val.lower() in ("true", "false"):
                d[k] = val.lower() == "true"
            else:
                d[k] = int(val) if val.lstrip("-").isdigit() else float(val)
        variants.append(d)
    return variants


def device_arg(parser, name):
    """The Warp device of a script's ``--device`` option (None: Warp's default), or the parser's one
    line naming the option and exit 2 (an unknown or unavailable device)."""
    from bsdf_tab.integrate.runtime import resolve_device

    try:
        return resolve_device(name)
    except ValueError as exc:
        parser.error(f"--device: {exc}")


def stop_process(proc) -> None:
    """Stop a child process we started (a server): SIGTERM, then SIGKILL after 10 s."""
    import subprocess

    proc.terminate()
    try:
        proc.wait(10)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()
