"""Uniform grid over the outgoing hemisphere: the midpoint rule in (cos theta_o, phi_o).

The cells are equal in solid angle (dw = d(cos theta) dphi); phi covers [0, pi] and is doubled
(the integrand is even in phi for w_i in the xz-plane). ``effort`` N is the number of nodes per
hemisphere: n_z = ~sqrt(N / 2) rings of n_phi = 2 n_z cells (both even). Transmission uses the
same grid mirrored into the lower hemisphere, with the rings split at |z_o| = mu / eta (where the
half-vector is horizontal and f_t jumps to zero for GGX).

Error channel: 3 |Q(n) - Q(n/2)| (the rule again on the grid of half the resolution in both
directions; the midpoint rule is O(h^2), so this is ~3x the error of the fine grid when the
integrand is smooth; the factor 3 covers the kinks at the horizon and the critical angle),
floored at 1 / (coarse cells), and 1 when the grid cannot resolve the lobe: twice the coarse cell size at the
mirror (or refraction) direction exceeds the lobe width (~2 alpha in reflection, alpha
|eta - 1| / eta in transmission). Near-mirror alpha, normal incidence (the (z, phi) grid is
coarse at the pole), grazing incidence (the reflected lobe is a thin layer above the horizon;
G / mu varies on the scale |z_o| ~ mu) and eta near 1 are therefore flagged, not silently wrong.
"""

from __future__ import annotations

import math

import numpy as np
import warp as wp

from .fixed import finalize, launch_texels
from .integrand import PI64, TexelParams, begin_texel, o_terms, store

# no kernel of this module is differentiated: no adjoint code (a third of the compile time)
wp.set_module_options({"enable_backward": False})

DEFAULT_EFFORT = 65536
SAFETY = 3.0  # times |Q(n) - Q(n/2)|
LOBE_CELLS = 2.0  # the lobe must span this many coarse cells


def grid_shape(effort: int) -> tuple[int, int]:
    """(n_z, n_phi) of the fine grid for ``effort`` nodes per hemisphere."""
    nz = max(2, 2 * int(round(math.sqrt(effort / 2.0) / 2.0)))
    return nz, 2 * nz


@wp.func
def _rings(p: TexelParams, z0: wp.float64, z1: wp.float64, nz: wp.int32, nphi: wp.int32, lower: wp.int32):
    # midpoint rule over |z| in [z0, z1] (nz rings) and phi in [0, pi] (nphi cells), doubled
    zero = wp.float64(0.0)
    one = wp.float64(1.0)
    dz = (z1 - z0) / wp.float64(nz)
    dphi = PI64 / wp.float64(nphi)
    acc = wp.vec2d(zero, zero)
    for a in range(nz):
        z = z0 + (wp.float64(a) + wp.float64(0.5)) * dz
        r = wp.sqrt(wp.max(zero, one - z * z))
        if lower == 1:
            z = -z
        for b in range(nphi):
            phi = (wp.float64(b) + wp.float64(0.5)) * dphi
            acc += o_terms(p, wp.vec3d(r * wp.cos(phi), r * wp.sin(phi), z))
    return acc * (wp.float64(2.0) * dz * dphi)


@wp.func
def _midpoint(p: TexelParams, nz: wp.int32, nphi: wp.int32, lower: wp.int32):
    zero = wp.float64(0.0)
    one = wp.float64(1.0)
    zc = zero
    if lower == 1 and p.eta > zero:
        zc = p.mu / p.eta
    if zc > zero and zc < one and nz >= 2:
        # transmission: the half-vector is horizontal at |z_o| = mu / eta, where GGX's D is
        # finite and f_t jumps to 0 (chi+): the rings must not straddle that circle
        n1 = wp.clamp(int(wp.round(zc * wp.float64(nz))), 1, nz - 1)
        return _rings(p, zero, zc, n1, nphi, lower) + _rings(p, zc, one, nz - n1, nphi, lower)
    return _rings(p, zero, one, nz, nphi, lower)


@wp.kernel
def grid_kernel(idx: wp.array(dtype=wp.int32), mu_a: wp.array(dtype=wp.float64),
                alpha_a: wp.array(dtype=wp.float64), eta_a: wp.array(dtype=wp.float64), mode: wp.int32,
                dist: wp.int32, shadowing: wp.int32, ftype: wp.int32, fp0: wp.float64, fp1: wp.float64,
                effort: wp.int32, seed: wp.int32, value: wp.array2d(dtype=wp.float64),
                error: wp.array2d(dtype=wp.float64)):
    i, p, done = begin_texel(wp.tid(), idx, mu_a, alpha_a, eta_a, mode, dist, shadowing, ftype, fp0, fp1, value, error)
    if done:
        # alpha = 0: the mirror limit is stored
        return
    zero = wp.float64(0.0)
    nz = effort  # effort carries n_z here (n_phi = 2 n_z)
    fine = _midpoint(p, nz, 2 * nz, 0)
    coarse = _midpoint(p, nz / 2, nz, 0)
    if mode == 1:
        ft = _midpoint(p, nz, 2 * nz, 1)
        ct = _midpoint(p, nz / 2, nz, 1)
        fine = wp.vec2d(fine[0], ft[1])
        coarse = wp.vec2d(coarse[0], ct[1])
    d = fine - coarse
    # a feature narrower than a coarse cell is invisible to both grids: floor at one cell's share
    floor = wp.float64(4.0) / wp.float64(2 * nz * nz)
    e0 = wp.max(floor, wp.float64(SAFETY) * wp.abs(d[0]))
    e1 = wp.max(floor, wp.float64(SAFETY) * wp.abs(d[1]))
    store(value, error, i, fine, wp.vec2d(e0, e1))


def _cell_size(nz: int, sin_theta: np.ndarray) -> np.ndarray:
    """Largest angular extent of the (z, phi) cell at a direction of polar sine ``sin_theta``."""
    dz = 1.0 / nz
    with np.errstate(divide="ignore"):
        h_theta = np.minimum(np.where(sin_theta > 0, dz / sin_theta, np.inf), math.sqrt(2.0 * dz))
    h_phi = sin_theta * math.pi / (2 * nz)
    return np.maximum(h_theta, h_phi)


def integrate_texels(mode, mu, alpha, eta=None, *, dist=0, shadowing=1, ftype=0, fp0=0.0, fp1=0.0, tol=None,
                     device=None, workers=None, progress=None, effort=None):
    """Midpoint rule on a uniform (cos theta_o, phi_o) grid; ``effort`` = nodes per hemisphere
    (default 65536). Signature of :func:`bsdf_tab.integrate.adaptive.integrate_texels`; ``tol``
    is ignored (fixed effort). Returns (values, errors), each (N, 2)."""
    effort = int(DEFAULT_EFFORT if effort is None else effort)
    if effort < 8:
        raise ValueError(f"grid: effort (nodes per hemisphere) must be >= 8, got {effort}")
    nz, _nphi = grid_shape(effort)
    values, errors, mu, alpha, eta = launch_texels(
        grid_kernel, mode, mu, alpha, eta, dist=dist, shadowing=shadowing, ftype=ftype, fp0=fp0, fp1=fp1,
        effort=nz, seed=0, device=device, workers=workers, progress=progress,
    )
    if values.size:
        # resolution guard at the lobe centres, judged on the coarse grid of the pair
        sin_i = np.sqrt(np.clip(1.0 - mu * mu, 0.0, 1.0))
        blind_r = LOBE_CELLS * _cell_size(nz // 2, sin_i) > 2.0 * alpha
        # grazing: the reflected lobe is squeezed into a layer of height ~2 alpha max(mu, 2 alpha)
        # above the horizon, which the rings in z must resolve too
        blind_r |= LOBE_CELLS * 2.0 / nz > 2.0 * alpha * np.maximum(mu, 2.0 * alpha)
        # grazing incidence: G / mu varies on the scale |z_o| ~ mu next to the horizon (both
        # hemispheres), which the coarse rings must resolve
        grazing = (LOBE_CELLS * 2.0 / nz > mu) & (alpha > 0)
        errors[grazing] = 1.0
        if mode == "dfg":
            errors[blind_r] = 1.0
        else:
            errors[blind_r, 0] = 1.0
        if mode == "dielectric":
            sin_t = np.clip(sin_i / eta, 0.0, 1.0)
            w_t = alpha * np.abs(eta - 1.0) / np.maximum(eta, 1.0)
            errors[LOBE_CELLS * _cell_size(nz // 2, sin_t) > w_t, 1] = 1.0
    return finalize(mode, values, errors, alpha)


METHODS = {"grid": integrate_texels}
