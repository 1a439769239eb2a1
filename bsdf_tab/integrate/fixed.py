"""Host side of the fixed-effort methods (grid, Monte Carlo, QMC, VNDF Gauss-Legendre).

One launcher for every fixed-effort kernel (:func:`launch_texels`), the o-space resolution guard
(:func:`lobe_width`) and the clamp to the physical range (:func:`finalize`). The device pieces
they share with the adaptive method (texel struct, integrand, mirror limit, the kernel
preamble) live in :mod:`bsdf_tab.integrate.integrand`.
"""

from __future__ import annotations

import numpy as np
import warp as wp

from .integrand import MIRROR_ROUNDING, mode_id
from .runtime import check_workers, chunk_launcher, resolve_device, run_chunks, texel_arrays


def launch_texels(kernel, mode, mu, alpha, eta, *, dist, shadowing, ftype, fp0, fp1, effort, seed,
                  device, workers, progress, extra=()):
    """Run a fixed-effort ``kernel`` over the texels; every such kernel has the signature
    (idx, mu, alpha, eta, mode, dist, shadowing, ftype, fp0, fp1, effort, seed, value, error,
    *extra), ``extra`` being NumPy float64 arrays (e.g. quadrature nodes) copied to the device.
    Returns (values, errors), each (N, 2) float64, plus the float64 inputs."""
    dev = resolve_device(device)
    check_workers(workers)
    mode_sel = mode_id(mode)
    mu, alpha, eta, mu_w, alpha_w, eta_w = texel_arrays(mu, alpha, eta, dev)
    n = mu.size
    if n == 0:
        return np.zeros((0, 2)), np.zeros((0, 2)), mu, alpha, eta
    value = wp.zeros((n, 2), dtype=wp.float64, device=dev)
    error = wp.zeros((n, 2), dtype=wp.float64, device=dev)
    extra_w = [wp.array(np.ascontiguousarray(a, dtype=np.float64), dtype=wp.float64, device=dev) for a in extra]

    launch = chunk_launcher(kernel, [mu_w, alpha_w, eta_w, mode_sel, int(dist), int(shadowing), int(ftype),
                                     float(fp0), float(fp1), int(effort), int(seed), value, error, *extra_w], dev)

    # fixed cost per texel: small chunks only to spread the work over the workers
    run_chunks(n, launch, dev, workers=workers, progress=progress)
    return value.numpy(), error.numpy(), mu, alpha, eta


def lobe_width(mode: str, mu, alpha, eta):
    """Angular width (radians) of the narrowest lobe of the integrand over outgoing directions:
    ~2 alpha for reflection, ~alpha |eta - 1| / eta for transmission (the half-vector map
    compresses by |eta - 1| as eta -> 1). Used to flag what o-space methods cannot resolve."""
    w = 2.0 * np.asarray(alpha, dtype=np.float64)
    if mode == "dielectric":
        eta = np.asarray(eta, dtype=np.float64)
        w_t = np.asarray(alpha) * np.abs(eta - 1.0) / np.maximum(eta, 1.0)
        tir = eta < 1.0
        # transmission exists unless the whole direction is beyond the critical angle; keep it
        w = np.minimum(w, np.where(tir, np.maximum(w_t, 0.0), w_t))
    return w


def finalize(mode, values, errors, alpha):
    """Clamp to the physical range (values in [0, 1], R + T <= 1) and cap errors at 1 (value and
    truth both lie in [0, 1]); a non-finite estimate becomes 0 with error 1. A texel moved by the
    clamp gets the move added to its error, so the error stays an honest bound."""
    bad = ~np.isfinite(values)
    values = np.where(bad, 0.0, values)
    errors = np.where(bad | ~np.isfinite(errors), 1.0, errors)
    clipped = np.clip(values, 0.0, 1.0)
    errors = errors + np.abs(clipped - values)
    values = clipped
    if mode == "dielectric":
        s = values.sum(axis=1)
        over = s > 1.0
        if over.any():
            scaled = values[over] / s[over, None]
            errors[over] += values[over] - scaled
            values[over] = scaled
    if mode == "reflect":
        values[:, 1] = 0.0
        errors[:, 1] = 0.0
    errors = np.clip(errors, 0.0, 1.0)
    mirror = (np.asarray(alpha) <= 0.0)[:, None]
    errors = np.where(mirror, MIRROR_ROUNDING, errors)  # the closed form's rounding
    return values, errors
