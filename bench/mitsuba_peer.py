"""Mitsuba 3 as a peer of the accuracy benchmark: the same albedos, estimated by sampling
Mitsuba's own BSDFs (the estimator; the benchmark run that uses it is :mod:`bench.mitsuba_run`).

Mitsuba's ``roughconductor`` (with ``material = "none"``: complex IOR 0 + 1i, a lossless
conductor whose Fresnel factor is exactly 1) gives the albedo E with F = 1; its
``roughdielectric`` gives R and T. Both use Smith's *separable* shadowing G1(i) G1(o), so only
the separable cases of the benchmark can be compared. Mitsuba's ``alpha`` for ``ggx`` and
``beckmann`` is Walter's width, as ours. Each texel's estimate is the mean of the weights that
``BSDF.sample`` returns (visible-normal sampling, Mitsuba's default): the weight is
f cos / pdf, i.e. G1(o) times the Fresnel selection for the dielectric, so an estimate of
R (T) is the mean over all samples of the weights whose outgoing direction lies on the side of
w_i (the other side), the other samples counting as zero.

Convention mapping (checked on texels against ``bsdf_tab.tabulate`` and the independent
reference, see docs/methods.md and tests/bench/test_mitsuba_peer.py):

* w_i = (sqrt(1 - mu^2), 0, mu) in Mitsuba's local shading frame (``si.wi``).
* eta = eta_o / eta_i. eta > 1: ``int_ior = eta``, ``ext_ior = 1`` and w_i above the
  surface. eta < 1: ``int_ior = 1 / eta``, ``ext_ior = 1`` and w_i *below* the surface, i.e.
  light arriving from inside the denser medium; R is then the lower hemisphere.
* T is the energy form (R + T -> 1 as alpha -> 0): the samples are drawn in
  ``TransportMode.Importance``. In ``TransportMode.Radiance`` Mitsuba's transmitted weight
  carries the radiance compression factor 1 / eta^2 (eta in our sense), which would give
  T / eta^2.
* Known model difference: for Beckmann, Mitsuba evaluates G1 with Walter et al.'s rational
  approximation (2007, eq. 27; relative error up to ~0.35%) instead of the exact erfc form. Its
  VNDF sampling is exact, so its estimate converges to the integral of G1_exact(i) D (i.m) / mu
  times G1_approx(o), which lies 0 .. 4e-4 above the exact-Smith albedo (measured and predicted
  in docs/methods.md). GGX's G1 is exact in both.

Error channel (the same definition as our ``mc_vndf``, :mod:`bsdf_tab.integrate.montecarlo`):
4 sigma_hat / sqrt(N) + 7 W / N, with W = 1 (Mitsuba's importance-mode weights are G1(o)
<= 1; the largest weight seen is used if it were larger). The plain standard error
sigma_hat / sqrt(N) is returned too.

Runtime: ``llvm_ad_rgb`` (Dr.Jit's LLVM backend, vectorized over all samples of a batch of
texels; needs a system libLLVM, found through ``DRJIT_LIBLLVM_PATH``, which :func:`setup`
points at a Debian ``libllvm19`` .. ``libllvm15`` when unset). If no LLVM can be loaded,
``scalar_rgb`` is the fallback: one Python call per sample, so only small sample counts are
practical, and its times measure the Python loop rather than Mitsuba.

Nothing here imports Mitsuba at module import time; :func:`setup` does.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

#: system libLLVM files tried, in order, when ``DRJIT_LIBLLVM_PATH`` is unset
LLVM_NAMES = (
    "libLLVM-19.so", "libLLVM.so.19.1", "libLLVM-18.so", "libLLVM.so.18.1", "libLLVM-17.so",
    "libLLVM-16.so", "libLLVM-15.so", "libLLVM.so",
)
LLVM_DIRS = (
    "/usr/lib/x86_64-linux-gnu", "/usr/lib/aarch64-linux-gnu", "/usr/lib64", "/usr/lib", "/usr/local/lib",
    "/usr/lib/llvm-19/lib", "/usr/lib/llvm-18/lib", "/usr/lib/llvm-15/lib",
)
#: variants tried by :func:`setup`, best first
VARIANTS = ("llvm_ad_rgb", "scalar_rgb")
#: lanes (texels x samples) of one vectorized launch
MAX_LANES = 2**22
#: the weight bound W of the error channel (G1 <= 1)
WEIGHT_BOUND = 1.0

_STATE: dict | None = None


def find_libllvm() -> str | None:
    """The first system libLLVM shared library of :data:`LLVM_NAMES` found in :data:`LLVM_DIRS`.

    Returns
    -------
    str or None
        Its path, or None when none exists.
    """
    for name in LLVM_NAMES:
        for folder in LLVM_DIRS:
            path = Path(folder) / name
            if path.is_file():
                return str(path)
    return None


def prepare_llvm_env() -> str | None:
    """Point ``DRJIT_LIBLLVM_PATH`` at a system libLLVM when it is unset.

    Dr.Jit reads the variable when it is first imported, so this must run before anything
    imports ``drjit`` or ``mitsuba``. An existing value is left alone.

    Returns
    -------
    str or None
        The value in effect afterwards (None when unset and no library was found).
    """
    current = os.environ.get("DRJIT_LIBLLVM_PATH")
    if current:
        return current
    found = find_libllvm()
    if found is not None:
        os.environ["DRJIT_LIBLLVM_PATH"] = found
    return found


def setup(variant: str | None = None) -> dict:
    """Import Mitsuba and set a variant (the first of :data:`VARIANTS` that works).

    Parameters
    ----------
    variant : str, optional
        Force one variant (e.g. ``"scalar_rgb"``); default: try :data:`VARIANTS` in order.

    Returns
    -------
    dict
        ``available`` (bool), ``variant``, ``vectorized`` (bool), ``libllvm`` (the
        ``DRJIT_LIBLLVM_PATH`` in effect), ``mitsuba_version``, ``drjit_version``, ``threads``
        and ``note`` (why it is unavailable, or which variant runs). Never raises: every
        failure is reported in ``note``.
    """
    global _STATE
    if _STATE is not None and _STATE.get("available") and variant in (None, _STATE.get("variant")):
        return dict(_STATE)
    libllvm = prepare_llvm_env()
    status = {"available": False, "variant": None, "vectorized": False, "libllvm": libllvm,
              "mitsuba_version": None, "drjit_version": None, "threads": None, "note": ""}
    try:
        import mitsuba as mi
    except Exception as exc:  # noqa: BLE001 - any import failure means: skip
        status["note"] = f"skipped: import mitsuba failed ({type(exc).__name__}: {exc})"
        _STATE = status
        return dict(status)
    status["mitsuba_version"] = getattr(mi, "__version__", None)
    try:
        import drjit as dr

        status["drjit_version"] = getattr(dr, "__version__", None)
    except Exception:  # noqa: BLE001 - mitsuba imported, so drjit is there; version is cosmetic
        dr = None
    failures = []
    for name in ([variant] if variant else VARIANTS):
        if name not in mi.variants():
            failures.append(f"{name}: not in this build")
            continue
        try:
            mi.set_variant(name)
            if not name.startswith("scalar"):
                # the LLVM backend fails here (not at set_variant) when libLLVM is missing
                total = np.asarray(dr.sum(mi.Float([1.0, 2.0])), dtype=np.float64).ravel()
                if total.size != 1 or total[0] != 3.0:
                    raise RuntimeError("probe computation gave a wrong result")
        except Exception as exc:  # noqa: BLE001 - try the next variant
            failures.append(f"{name}: {type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''}")
            continue
        status.update(available=True, variant=name, vectorized=not name.startswith("scalar"))
        if dr is not None and status["vectorized"]:
            try:
                status["threads"] = int(dr.thread_count())
            except Exception:  # noqa: BLE001 - informational only
                status["threads"] = None
        how = ("vectorized over samples (Dr.Jit LLVM backend)" if status["vectorized"]
               else "scalar fallback: one Python call per sample, times measure the Python loop")
        status["note"] = f"mitsuba {status['mitsuba_version']} {name}: {how}"
        if failures:
            status["note"] += f" (not usable: {'; '.join(failures)})"
        _STATE = status
        return dict(status)
    status["note"] = "skipped: no Mitsuba variant could be set (" + "; ".join(failures) + ")"
    if libllvm is None:
        status["note"] += "; no libLLVM found (apt-get install libllvm19, or set DRJIT_LIBLLVM_PATH)"
    _STATE = status
    return dict(status)


@dataclass
class PeerEstimate:
    """Mitsuba's estimate at N texels.

    Attributes
    ----------
    values : numpy.ndarray
        (N, 2): (E, 0) for ``reflect``, (R, T) for ``dielectric``.
    errors : numpy.ndarray
        (N, 2): the error channel 4 sigma_hat / sqrt(n) + 7 W / n (as our ``mc_vndf``).
    stderr : numpy.ndarray
        (N, 2): the standard error sigma_hat / sqrt(n).
    wmax : numpy.ndarray
        (N,): the largest weight seen per texel (the bound W is max(1, wmax)).
    n_samples : int
        Samples per texel.
    """

    values: np.ndarray
    errors: np.ndarray
    stderr: np.ndarray
    wmax: np.ndarray
    n_samples: int


def _ior(mode: str, eta: float) -> tuple[float, bool]:
    """(int_ior with ext_ior = 1, w_i below the surface) for our eta = eta_o / eta_i."""
    if mode == "reflect":
        return 1.0, False
    if eta > 1.0:
        return float(eta), False
    return float(1.0 / eta), True


def _bsdf_dict(mode: str, dist: str, alpha: float, int_ior: float) -> dict:
    if mode == "reflect":
        return {"type": "roughconductor", "distribution": dist, "alpha": float(alpha), "material": "none"}
    return {"type": "roughdielectric", "distribution": dist, "alpha": float(alpha),
            "int_ior": float(int_ior), "ext_ior": 1.0}


def _check_inputs(mode, dist, mu, alpha, eta, n_samples):
    if mode not in ("reflect", "dielectric"):
        raise ValueError(f"mode must be 'reflect' or 'dielectric', got {mode!r}")
    if dist not in ("ggx", "beckmann"):
        raise ValueError(f"dist must be 'ggx' or 'beckmann', got {dist!r}")
    mu = np.ascontiguousarray(mu, dtype=np.float64).ravel()
    alpha = np.ascontiguousarray(alpha, dtype=np.float64).ravel()
    if eta is None:
        if mode == "dielectric":
            raise ValueError("a dielectric estimate needs eta")
        eta = np.ones(mu.size)
    eta = np.ascontiguousarray(np.broadcast_to(np.asarray(eta, dtype=np.float64), mu.shape)).ravel()
    if alpha.size != mu.size:
        raise ValueError("mu and alpha must have the same number of texels")
    if not (np.isfinite(mu).all() and np.isfinite(alpha).all() and np.isfinite(eta).all()):
        raise ValueError("mu, alpha and eta must be finite")
    if ((mu <= 0.0) | (mu > 1.0)).any():
        raise ValueError("mu must lie in (0, 1]: Mitsuba samples nothing at grazing mu = 0")
    if (alpha <= 0.0).any():
        raise ValueError("alpha must be > 0 (Mitsuba's rough BSDFs have no mirror limit)")
    if mode == "dielectric" and ((eta <= 0.0) | (eta == 1.0)).any():
        raise ValueError("eta must be > 0 and != 1 (Mitsuba rejects equal interior and exterior IORs)")
    n_samples = int(n_samples)
    if n_samples < 2:
        raise ValueError(f"n_samples must be >= 2, got {n_samples}")
    return mu, alpha, eta, n_samples


def _finish(s, q, wmax, n):
    """Mean, error channel and standard error from per-texel sums (float64)."""
    mean = s / n
    var = np.maximum(0.0, (q - n * mean * mean) / max(n - 1, 1))
    se = np.sqrt(var / n)
    bound = np.maximum(WEIGHT_BOUND, wmax)[:, None]
    return mean, 4.0 * se + 7.0 * bound / n, se


def estimate(mode: str, dist: str, mu, alpha, eta=None, *, n_samples: int, seed: int = 0,
             max_lanes: int = MAX_LANES, transport: str = "importance") -> PeerEstimate:
    """Albedo (``reflect``, F = 1) or (R, T) (``dielectric``) of Mitsuba's BSDF at each texel.

    Parameters
    ----------
    mode : {"reflect", "dielectric"}
        ``roughconductor`` with a perfect mirror material, or ``roughdielectric``.
    dist : {"ggx", "beckmann"}
        Microfacet distribution (Mitsuba's shadowing is separable).
    mu, alpha : array_like
        Cosine of incidence in (0, 1] and Walter width > 0, one per texel.
    eta : array_like or float, optional
        eta_o / eta_i per texel (``dielectric`` only; > 0 and != 1).
    n_samples : int
        Samples per texel (>= 2).
    seed : int
        Seed of Mitsuba's ``independent`` sampler (the estimate is deterministic for a seed).
    max_lanes : int
        Largest number of samples evaluated in one vectorized launch.
    transport : {"importance", "radiance"}
        Mitsuba's transport mode. ``"importance"`` (default) gives the energy form of T;
        ``"radiance"`` gives Mitsuba's radiance-mode weights, whose T is T / eta^2 (for
        checking the mapping only).

    Returns
    -------
    PeerEstimate

    Raises
    ------
    RuntimeError
        If no Mitsuba variant can be set (see :func:`setup`).
    ValueError
        For inputs Mitsuba cannot represent (mu <= 0, alpha <= 0, eta = 1, ...).
    """
    mu, alpha, eta, n = _check_inputs(mode, dist, mu, alpha, eta, n_samples)
    if transport not in ("importance", "radiance"):
        raise ValueError(f"transport must be 'importance' or 'radiance', got {transport!r}")
    state = setup() if _STATE is None or not _STATE.get("available") else _STATE
    if not state["available"]:
        raise RuntimeError(state["note"])
    s = np.zeros((mu.size, 2))
    q = np.zeros((mu.size, 2))
    wmax = np.zeros(mu.size)
    if mu.size == 0:
        return PeerEstimate(s, q.copy(), q.copy(), wmax, n)
    run = _run_vectorized if state["vectorized"] else _run_scalar
    # one BSDF per (interior IOR, side), its alpha updated per group of texels
    keys = [(_ior(mode, float(e)), float(a)) for e, a in zip(eta, alpha)]
    groups: dict = {}
    for k, key in enumerate(keys):
        groups.setdefault(key, []).append(k)
    run(mode, dist, mu, groups, n, int(seed), int(max_lanes), s, q, wmax, transport)
    mean, err, se = _finish(s, q, wmax, n)
    return PeerEstimate(mean, err, se, wmax, n)


def _launch_seed(seed: int, launch: int) -> int:
    """A distinct 32-bit sampler seed per launch (Mitsuba's seed is a uint32)."""
    return (int(seed) * 1_000_003 + int(launch)) & 0xFFFFFFFF


def _bsdf_cache(mode, dist):
    """BSDF objects per interior IOR, with a setter for alpha (Mitsuba keeps alpha opaque, so
    changing it does not recompile the kernels)."""
    import mitsuba as mi

    objects: dict = {}

    def get(int_ior: float, alpha: float):
        if int_ior not in objects:
            bsdf = mi.load_dict(_bsdf_dict(mode, dist, alpha, int_ior))
            params = mi.traverse(bsdf)
            key = next((k for k in params.keys() if k == "alpha.value" or k == "alpha"), None)
            if key is None:
                raise RuntimeError(f"no alpha parameter in {type(bsdf).__name__}: {list(params.keys())}")
            objects[int_ior] = (bsdf, params, key)
        bsdf, params, key = objects[int_ior]
        params[key] = float(alpha)
        params.update()
        return bsdf

    return get


def _context(transport: str):
    import mitsuba as mi

    tm = mi.TransportMode.Importance if transport == "importance" else mi.TransportMode.Radiance
    return mi.BSDFContext(tm)


#: set to False to force the NumPy reduction (Dr.Jit < 1.0 has no block reductions)
USE_BLOCK_REDUCE = True


def _block_reduce_available(dr) -> bool:
    return USE_BLOCK_REDUCE and hasattr(dr, "block_sum") and hasattr(dr, "block_reduce")


def _reduce_drjit(dr, mi, weight, same_side, nb, two):
    """Per-texel sums (float64) of the weights and their squares on w_i's side (and the other
    side when ``two``), and the largest weight, for blocks of ``nb`` consecutive lanes."""
    w = mi.Float64(weight)
    wr = dr.select(same_side, w, 0.0)
    sums = [dr.block_sum(wr, nb), dr.block_sum(wr * wr, nb), dr.block_reduce(dr.ReduceOp.Max, w, nb)]
    if two:
        wt = dr.select(same_side, 0.0, w)
        sums += [dr.block_sum(wt, nb), dr.block_sum(wt * wt, nb)]
    dr.eval(*sums)
    return [np.asarray(a, dtype=np.float64) for a in sums]


def _reduce_numpy(weight, same_side, nb, two):
    """The same as :func:`_reduce_drjit`, on the host."""
    w = np.asarray(weight, dtype=np.float64).reshape(-1, nb)
    side = np.asarray(same_side, dtype=bool).reshape(-1, nb)
    wr = np.where(side, w, 0.0)
    out = [wr.sum(axis=1), (wr * wr).sum(axis=1), w.max(axis=1)]
    if two:
        wt = np.where(side, 0.0, w)
        out += [wt.sum(axis=1), (wt * wt).sum(axis=1)]
    return out


def _run_vectorized(mode, dist, mu, groups, n, seed, max_lanes, s, q, wmax, transport):
    import drjit as dr
    import mitsuba as mi

    get = _bsdf_cache(mode, dist)
    sampler = mi.load_dict({"type": "independent", "sample_count": 1})
    ctx = _context(transport)
    per_launch = max(2, min(n, int(max_lanes)))
    launch = 0
    for ((int_ior, below), alpha), texels in groups.items():
        bsdf = get(int_ior, alpha)
        texels = np.asarray(texels)
        done = 0
        while done < n:
            nb = min(per_launch, n - done)  # samples per texel in this launch
            chunk = max(1, int(max_lanes) // nb)
            for c0 in range(0, texels.size, chunk):
                sel = texels[c0:c0 + chunk]
                lanes = sel.size * nb
                sampler.seed(_launch_seed(seed, launch), lanes)
                launch += 1
                idx = dr.arange(mi.UInt32, lanes) // nb
                # (a size-1 source would become a literal: another kernel, compiled in the timing)
                src = np.concatenate([mu[sel], mu[sel][:1]]) if sel.size == 1 else mu[sel]
                m = dr.gather(mi.Float, mi.Float(src.astype(np.float32)), idx)
                z = -m if below else m
                si = dr.zeros(mi.SurfaceInteraction3f, lanes)
                si.wi = mi.Vector3f(dr.safe_sqrt(1.0 - m * m), 0.0, z)
                si.sh_frame = mi.Frame3f(mi.Vector3f(0.0, 0.0, 1.0))
                bs, weight = bsdf.sample(ctx, si, sampler.next_1d(), sampler.next_2d())
                if _block_reduce_available(dr):
                    out = _reduce_drjit(dr, mi, weight.x, bs.wo.z * z > 0.0, nb, mode == "dielectric")
                else:
                    out = _reduce_numpy(weight.x, bs.wo.z * z > 0.0, nb, mode == "dielectric")
                s[sel, 0] += out[0]
                q[sel, 0] += out[1]
                wmax[sel] = np.maximum(wmax[sel], out[2])
                if mode == "dielectric":
                    s[sel, 1] += out[3]
                    q[sel, 1] += out[4]
            done += nb


def _run_scalar(mode, dist, mu, groups, n, seed, max_lanes, s, q, wmax, transport):
    import mitsuba as mi

    get = _bsdf_cache(mode, dist)
    sampler = mi.load_dict({"type": "independent", "sample_count": 1})
    ctx = _context(transport)
    launch = 0
    for ((int_ior, below), alpha), texels in groups.items():
        bsdf = get(int_ior, alpha)
        for k in texels:
            sampler.seed(_launch_seed(seed, launch))
            launch += 1
            m = float(mu[k])
            z = -m if below else m
            si = mi.SurfaceInteraction3f()
            si.wi = mi.Vector3f(math.sqrt(max(0.0, 1.0 - m * m)), 0.0, z)
            si.sh_frame = mi.Frame3f(mi.Vector3f(0.0, 0.0, 1.0))
            for _ in range(n):
                bs, weight = bsdf.sample(ctx, si, sampler.next_1d(), sampler.next_2d())
                w = float(weight[0])
                c = 0 if bs.wo[2] * z > 0.0 else 1
                if mode == "reflect" and c == 1:
                    w = 0.0  # a failed sample (weight 0)
                    c = 0
                s[k, c] += w
                q[k, c] += w * w
                wmax[k] = max(wmax[k], w)
