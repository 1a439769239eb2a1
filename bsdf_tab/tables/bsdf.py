"""``bsdf``: point values of one material's BSDF on an angular grid (no integration).

Parametrizations (``spec["parametrization"]``), all angles in radians, isotropic material:

``angles``: axes (theta_i, theta_o, phi_d).
    w_i = (sin theta_i, 0, cos theta_i); phi_d = phi_o - phi_i is the azimuth of w_o.
    ``f_r`` at w_o = (sin theta_o cos phi_d, sin theta_o sin phi_d, cos theta_o) (upper side);
    ``f_t`` at the lower-side direction w_o = (sin theta_o cos phi_d, sin theta_o sin phi_d,
    -cos theta_o): theta_o of a transmitted direction is measured from -n. phi_d = 0 is the
    side of w_i (back-scattering); the mirror direction is (theta_o, phi_d) = (theta_i, pi) and
    the straight-through direction o = -i is also (theta_i, pi) in ``f_t``.
``half_diff``: axes (theta_h, theta_d, phi_d), Rusinkiewicz 1998 with phi_h = 0 (isotropy).
    h = (sin theta_h, 0, cos theta_h); d = (sin theta_d cos phi_d, sin theta_d sin phi_d,
    cos theta_d) is w_i in the frame of h: w_i = R_y(theta_h) d, ``f_r`` at w_o = 2 (w_i.h) h - w_i.
    ``f_t`` at w_o = refract(w_i, h, eta): h is the generalized half-vector -(i + eta o)/|.|
    (Walter eq. 16) oriented to +n; 0 under total internal reflection. Reciprocity makes
    f(theta_h, theta_d, phi_d) = f(theta_h, theta_d, phi_d + pi) (for ``f_r``), so phi_d in
    [0, pi) suffices: the default axes are the MERL layout 90 x 90 x 180, theta_h = (i/90)^2 pi/2
    (square spacing, nodes "left"), theta_d = i pi/180, phi_d = i pi/180.

Channels ``f_r``, ``f_t`` (``f_t`` = 0 unless the Fresnel type is ``dielectric``; eta is the
Fresnel eta = eta_o / eta_i) and error channels ``f_r_err``, ``f_t_err``.

Error bound. The values are point evaluations in float64 (Warp kernel, the model's ``brdf`` /
``btdf``): no discretization error, only rounding. The error channel is a first-order rounding
bound, |f| * eps * (64 + K), eps = 2^-52, where 64 covers the arithmetic of F, G, D and the
divisions, and K the conditioning of the half-vector: the rounded h has |delta cos theta_h| <=
8 eps (reflection) or 8 eps (1 + eta) / |i + eta o| (transmission), amplified by
|d ln D / d cos theta_h| (the model's ``dlnD_dcos``: GGX 4/c + 4/(c (alpha^2 c^2 + 1 - c^2)),
Beckmann 4/c + 2/(c^3 alpha^2)),
by the Fresnel slope 1/g near the critical angle (dielectric, g = sqrt(eta^2 - 1 + c^2)), and
for transmission by 2x the relative error of the denominator (i.h) + eta (o.h) (= |i + eta o|)
and by the cancellation in 1 - F near total internal reflection ((16 + amp/g) / (1 - F)).
Stored EXR channels are float32 (relative rounding 2^-24 on top).

Memory: :func:`blocks` computes blocks of axis-0 slices; ``bsdf_tab.api.iter_blocks`` hands
them to a streaming writer of :mod:`bsdf_tab.io`, so a full-size grid needs memory for one block
only.
"""

from __future__ import annotations

import numpy as np
import warp as wp

from ..integrate.runtime import default_workers, run_chunks
from ..model import FRESNEL_DIELECTRIC, brdf, btdf, dlnD_dcos, fresnel_dielectric
from ._common import Context, integrator_params

__all__ = ["CHANNELS", "EPS_REL", "KINDS", "blocks", "compute", "material_alpha"]

CHANNELS = ("f_r", "f_t", "f_r_err", "f_t_err")
PARAM_ANGLES = wp.constant(0)
PARAM_HALF_DIFF = wp.constant(1)
_PARAM = {"angles": 0, "half_diff": 1}
#: Base relative rounding allowance of one point evaluation (in units of eps = 2^-52).
EPS_REL = 64.0
_EPS = 2.0**-52
#: Texels per kernel block (the streaming memory bound is ~ 4 channels x 8 bytes x this).
BLOCK_TEXELS = 1 << 20


@wp.func
def _fresnel_slope(ci: wp.float64, ftype: wp.int32, eta: wp.float64):
    """~|d ln F / d cos| of the dielectric Fresnel near the critical angle (1/g), else 0."""
    if ftype != FRESNEL_DIELECTRIC:
        return wp.float64(0.0)
    g2 = eta * eta - wp.float64(1.0) + ci * ci
    return wp.float64(1.0) / wp.sqrt(wp.max(wp.abs(g2), wp.float64(1.0e-16)))


@wp.func
def _directions(param: wp.int32, a0: wp.float64, a1: wp.float64, a2: wp.float64, eta: wp.float64):
    """(w_i, w_o reflected, w_o transmitted, ok_t) of one grid point (see the module docstring)."""
    zero = wp.float64(0.0)
    one = wp.float64(1.0)
    c2 = wp.cos(a2)
    s2 = wp.sin(a2)
    if param == PARAM_HALF_DIFF:
        ch = wp.cos(a0)
        sh = wp.sin(a0)
        sd = wp.sin(a1)
        cd = wp.cos(a1)
        dx = sd * c2
        dy = sd * s2
        h = wp.vec3d(sh, zero, ch)
        wi = wp.vec3d(ch * dx + sh * cd, dy, -sh * dx + ch * cd)
        wr = wp.float64(2.0) * cd * h - wi
        # refraction through h (Walter eq. 40), eta = eta_o / eta_i
        k2 = one - (one - cd * cd) / (eta * eta)
        wt = wp.vec3d(zero, zero, zero)
        ok = k2 >= zero
        if ok:
            wt = (cd / eta - wp.sqrt(k2)) * h - wi / eta
        return wi, wr, wt, ok
    si = wp.sin(a0)
    ci = wp.cos(a0)
    so = wp.sin(a1)
    co = wp.cos(a1)
    wi = wp.vec3d(si, zero, ci)
    wr = wp.vec3d(so * c2, so * s2, co)
    wt = wp.vec3d(so * c2, so * s2, -co)
    return wi, wr, wt, True


@wp.kernel
def _bsdf_block_kernel(
    idx: wp.array(dtype=wp.int32),
    ax0: wp.array(dtype=wp.float64),
    ax1: wp.array(dtype=wp.float64),
    ax2: wp.array(dtype=wp.float64),
    param: wp.int32,
    alpha: wp.float64,
    dist: wp.int32,
    shadowing: wp.int32,
    ftype: wp.int32,
    p0: wp.float64,
    p1: wp.float64,
    out: wp.array2d(dtype=wp.float64),
):
    k = idx[wp.tid()]
    n1 = ax1.shape[0]
    n2 = ax2.shape[0]
    i0 = k // (n1 * n2)
    r = k - i0 * n1 * n2
    i1 = r // n2
    i2 = r - i1 * n2
    one = wp.float64(1.0)
    eps = wp.float64(_EPS)
    wi, wr, wt, ok_t = _directions(param, ax0[i0], ax1[i1], ax2[i2], p0)

    fr = brdf(wi, wr, alpha, dist, shadowing, ftype, p0, p1)
    er = wp.float64(0.0)
    if fr != wp.float64(0.0):
        h = wp.normalize(wi + wr)
        kappa = dlnD_dcos(h[2], alpha, dist) + _fresnel_slope(wp.dot(wi, h), ftype, p0)
        er = wp.abs(fr) * eps * (wp.float64(EPS_REL) + wp.float64(8.0) * kappa)

    ft = wp.float64(0.0)
    et = wp.float64(0.0)
    if ftype == FRESNEL_DIELECTRIC and ok_t:
        ft = btdf(wi, wt, alpha, dist, shadowing, p0)
        if ft != wp.float64(0.0):
            v = wi + p0 * wt
            hl = wp.length(v)
            h = -v / hl
            if h[2] < wp.float64(0.0):
                h = -h
            amp = wp.float64(8.0) * (one + p0) / hl
            ci = wp.dot(wi, h)
            slope = _fresnel_slope(ci, ftype, p0)
            kappa = dlnD_dcos(h[2], alpha, dist) + slope + wp.float64(2.0)
            # 1 - F cancels near total internal reflection: abs. error of F over 1 - F
            tr = one - fresnel_dielectric(ci, p0)
            cancel = (wp.float64(16.0) + amp * slope) / wp.max(tr, wp.float64(1.0e-300))
            et = wp.abs(ft) * eps * (wp.float64(EPS_REL) + amp * kappa + cancel)
    out[0, k] = fr
    out[1, k] = ft
    out[2, k] = er
    out[3, k] = et


def material_alpha(nspec: dict) -> float:
    """The material's alpha of a normalized ``bsdf`` spec (``roughness**2`` if given so)."""
    if "roughness" in nspec:
        return float(nspec["roughness"]) ** 2
    return float(nspec["alpha"])


def blocks(nspec: dict, axes: dict, ctx: Context, block_texels: int = BLOCK_TEXELS):
    """Yield (i0_start, i0_end, channels) over blocks of whole axis-0 slices.

    ``channels`` maps each of :data:`CHANNELS` to a float64 array shaped
    (i0_end - i0_start, n1, n2); a block holds about ``block_texels`` texels (at least one slice).
    """
    names = list(axes)
    ax = [np.ascontiguousarray(axes[n], dtype=np.float64) for n in names]
    n0, n1, n2 = (len(a) for a in ax)
    per_slice = n1 * n2
    step = max(1, block_texels // per_slice)
    params = integrator_params(nspec)
    dev = ctx.device
    d_ax1 = wp.array(ax[1], dtype=wp.float64, device=dev)
    d_ax2 = wp.array(ax[2], dtype=wp.float64, device=dev)
    alpha = material_alpha(nspec)
    ctx.expect(n0 * per_slice)
    for start in range(0, n0, step):
        end = min(n0, start + step)
        n = (end - start) * per_slice
        d_ax0 = wp.array(ax[0][start:end], dtype=wp.float64, device=dev)
        d_out = wp.zeros((4, n), dtype=wp.float64, device=dev)

        def launch(idx):
            wp.launch(
                _bsdf_block_kernel,
                dim=idx.shape[0],
                inputs=[
                    idx, d_ax0, d_ax1, d_ax2, _PARAM[nspec["parametrization"]], alpha,
                    params["dist"], params["shadowing"], params["ftype"], params["fp0"], params["fp1"], d_out,
                ],
                device=dev,
            )

        chunk = None if dev.is_cuda else max(4096, -(-n // (4 * (ctx.workers or default_workers()))))
        run_chunks(n, launch, dev, workers=ctx.workers, chunk=chunk, progress=ctx.reporter())
        values = d_out.numpy().reshape(4, end - start, n1, n2)
        yield start, end, {name: values[c] for c, name in enumerate(CHANNELS)}


def compute(nspec: dict, axes: dict, ctx: Context) -> dict:
    """The whole table in memory: {f_r, f_t, f_r_err, f_t_err}, each shaped by the axes."""
    shape = tuple(len(a) for a in axes.values())
    out = {name: np.empty(shape, dtype=np.float64) for name in CHANNELS}
    for start, end, channels in blocks(nspec, axes, ctx):
        for name in CHANNELS:
            out[name][start:end] = channels[name]
    return out


KINDS = {
    "bsdf": {
        # axes of the default parametrization; see "parametrizations"
        "axes": ("theta_i", "theta_o", "phi_d"),
        "channels": ("f_r", "f_t"),
        "fresnel": "any",
        "methods": ("point",),
        "params": ("alpha", "roughness", "parametrization"),
        "parametrizations": {
            "angles": ("theta_i", "theta_o", "phi_d"),
            "half_diff": ("theta_h", "theta_d", "phi_d"),
        },
        "description": "BSDF values f_r (reflection) and f_t (transmission, dielectric Fresnel) of one "
        "material on an angular grid: plain angles or Rusinkiewicz half/difference angles (MERL layout)",
        "compute": compute,
        "blocks": blocks,
    },
}
