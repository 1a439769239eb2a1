"""``albedo_aniso``: E(mu, phi_v, alpha, anisotropy) of anisotropic GGX, F = 1.

Parametrization (documented in every table's spec description): alpha_x = alpha / sqrt(1 - 0.9 a),
alpha_y = alpha sqrt(1 - 0.9 a) for anisotropy a in [0, 1] (:func:`bsdf_tab.model.ggx_aniso.aniso_widths`;
alpha_x alpha_y = alpha^2: the ``alpha`` axis is the isotropic collapse sqrt(alpha_x alpha_y),
aspect ratio up to 10); w_i = (sin(theta) cos(phi_v), sin(theta) sin(phi_v), mu) with phi_v
measured from the tangent (the alpha_x direction). Shadowing: the spec's ``shadowing``
(``correlated`` or ``separable``) with the exact anisotropic Smith Lambda.

Integrator (its own kernel). In the stretched slope plane, slopes (alpha_x r cos psi,
alpha_y r sin psi) with u = r^2 / (1 + r^2) = 1 - (1 - v)^2 the D cos CDF, so that
D cos dw_m = (1 - v) dv dpsi / pi and E = int int (G / mu) (i.m / m_z) (1 - v) / pi dv dpsi
(Walter et al. 2007 eq. 14), i.m / m_z = r (A cos psi + B sin psi) + mu, A = i_x alpha_x,
B = i_y alpha_y. For fixed psi, w_o = 2 (i.m) m - i is above the horizon iff
mu (1 - r^2 Q) + 2 r P > 0 (Q = alpha_x^2 cos^2 + alpha_y^2 sin^2, P = A cos + B sin): a quadratic
in r, so r < r_max(psi) = (P + sqrt(P^2 + mu^2 Q)) / (mu Q) in closed form (rationalized for
P < 0). The inner integral over v in [0, v_max(psi)] (G7-K15 panels graded geometrically
toward v_max at the width v_max max(mu, 1e-8) / 4: the boundary layer where mu_o ~ mu; in
y = -log(1 - sqrt(v)), where the terms odd in r are smooth and the pole of r at the horizon
v = 1 is at infinity); the
outer over psi, split where P = 0 (where r_max jumps as mu -> 0) and graded geometrically toward
those points at the scale mu sqrt(Q) / |(A, B)|, no panel wider than a half turn / (4 ceil(aspect))
(before 2026-12-01 the first graded panel could be a quarter turn wide: up to 7e-3 off at high
mu and aspect 10, with an error estimate of 5e-4). Error: sum over outer panels of |K15 - G7|
(inner values from K15) plus the K15-weighted inner |K15 - G7| plus 1e-14 |E|. float64.
"""

from __future__ import annotations

import math

import numpy as np
import warp as wp

from ..axes import alpha_values
from ..integrate.quadrature import GK_WG, GK_WK, GK_X
from ..integrate.runtime import resolve_device, run_chunks
from ..model.ggx_aniso import aniso_widths, ggx_aniso_lambda_cos
from ..model.shadowing import SHADOWINGS
from ._common import Context

# no kernel of this module is differentiated: no adjoint code (a third of the compile time)
wp.set_module_options({"enable_backward": False})

F = wp.float64
_PI = wp.constant(wp.float64(math.pi))
_ROUNDING = wp.constant(wp.float64(1.0e-14))
_MAX_PANELS = 40


@wp.func
def _g_over_mu(mu: wp.float64, li: wp.float64, mo: wp.float64, lo: wp.float64, shadowing: int):
    """G / mu_i from mu and |cos| Lambda of both directions (correlated: 1, separable: 0)."""
    den = F(0.0)
    if shadowing == 1:
        den = mu * mo + mo * li + mu * lo
    else:
        den = (mu + li) * (mo + lo)
    if den <= F(0.0):
        # mu = 0 on a mirror: no finite value; the texel integrand is 0 there
        return F(0.0)
    return mo / den


@wp.func
def _point(wi: wp.vec3d, mu: wp.float64, li: wp.float64, ax: wp.float64, ay: wp.float64, w: wp.float64,
           c: wp.float64, s: wp.float64, shadowing: int):
    """(G / mu) (i.m / m_z) (1 - v) / pi at (v, psi), given w = 1 - v (0 where w_o is below the horizon)."""
    if w <= F(0.0):
        # the horizon itself (v = 1): zero measure
        return F(0.0)
    r = wp.sqrt(wp.max(F(1.0) - w * w, F(0.0))) / w  # v (2 - v) = 1 - w^2
    mx = ax * r * c
    my = ay * r * s
    norm2 = F(1.0) + mx * mx + my * my
    im_n = wi[0] * mx + wi[1] * my + mu  # (i.m) sqrt(norm2) = i.m / m_z
    if im_n <= F(0.0):
        # back-facing micro-normal
        return F(0.0)
    mo_z = F(2.0) * im_n / norm2 - mu
    if mo_z <= F(0.0):
        # w_o below the horizon
        return F(0.0)
    k = F(2.0) * im_n / norm2  # o = k (mx, my, 1) - i
    o = wp.vec3d(k * mx - wi[0], k * my - wi[1], mo_z)
    lo = ggx_aniso_lambda_cos(o, ax, ay)
    return _g_over_mu(mu, li, mo_z, lo, shadowing) * im_n * w / _PI


@wp.func
def _inner(wi: wp.vec3d, mu: wp.float64, li: wp.float64, ax: wp.float64, ay: wp.float64, psi: wp.float64,
           shadowing: int, gx: wp.array(dtype=wp.float64), gk: wp.array(dtype=wp.float64),
           gg: wp.array(dtype=wp.float64)):
    """(value, error) of the v integral over [0, v_max(psi)]."""
    c = wp.cos(psi)
    s = wp.sin(psi)
    q = ax * ax * c * c + ay * ay * s * s
    p = wi[0] * ax * c + wi[1] * ay * s
    vmax = F(1.0)
    if mu > F(0.0) and q > F(0.0):
        disc = wp.sqrt(p * p + mu * mu * q)  # > 0
        rmax = F(0.0)
        if p > F(0.0):
            rmax = (p + disc) / (mu * q)  # mu q > 0
        else:
            rmax = mu / (disc - p)  # disc - p >= disc > 0
        vmax = F(1.0) - F(1.0) / wp.sqrt(F(1.0) + rmax * rmax)
    elif mu <= F(0.0) and p <= F(0.0):
        # grazing view: only the micro-normals tilted towards it reflect upward
        vmax = F(0.0)
    val = F(0.0)
    err = F(0.0)
    if vmax <= F(0.0):
        return wp.vec2d(val, err)
    # over y = -log(1 - t), t = sqrt(v): the terms odd in r are smooth in t, and r has a pole
    # at t = 1 (v = 1, the horizon) that y moves to infinity (y is capped at 40: the integrand
    # decays like e^-y there)
    ymax = F(40.0)
    if vmax < F(1.0):
        ymax = wp.min(ymax, -wp.log(F(1.0) - wp.sqrt(vmax)))  # 1 - sqrt(vmax) > 0
    hi = ymax
    cap = wp.min(F(0.75), ymax / F(3.0))
    width = wp.min(ymax * wp.max(mu, F(1.0e-8)) * F(0.25), cap)
    for k in range(_MAX_PANELS + 64):
        lo = wp.max(hi - width, F(0.0))
        if k == _MAX_PANELS + 63:
            lo = F(0.0)
        h = F(0.5) * (hi - lo)
        rk = F(0.0)
        rg = F(0.0)
        for j in range(15):
            y = lo + h * (gx[j] + F(1.0))
            e = wp.exp(-y)
            t = F(1.0) - e
            f = _point(wi, mu, li, ax, ay, e * (F(2.0) - e), c, s, shadowing) * F(2.0) * t * e * h  # 1 - t^2 = e (2 - e)
            rk += gk[j] * f
            rg += gg[j] * f
        val += rk
        err += wp.abs(rk - rg)
        hi = lo
        width = wp.min(F(2.0) * width, cap)
        if hi <= F(0.0):
            break
    return wp.vec2d(val, err)


@wp.func
def _outer_panel(wi: wp.vec3d, mu: wp.float64, li: wp.float64, ax: wp.float64, ay: wp.float64,
                 lo: wp.float64, hi: wp.float64, shadowing: int, gx: wp.array(dtype=wp.float64),
                 gk: wp.array(dtype=wp.float64), gg: wp.array(dtype=wp.float64)):
    h = F(0.5) * (hi - lo)
    rk = F(0.0)
    rg = F(0.0)
    ie = F(0.0)
    for j in range(15):
        r = _inner(wi, mu, li, ax, ay, lo + h * (gx[j] + F(1.0)), shadowing, gx, gk, gg)
        rk += gk[j] * r[0] * h
        rg += gg[j] * r[0] * h
        ie += gk[j] * r[1] * h
    return wp.vec2d(rk, wp.abs(rk - rg) + ie)


@wp.func
def _graded_half(wi: wp.vec3d, mu: wp.float64, li: wp.float64, ax: wp.float64, ay: wp.float64,
                 a: wp.float64, b: wp.float64, scale: wp.float64, npan: int, shadowing: int,
                 gx: wp.array(dtype=wp.float64), gk: wp.array(dtype=wp.float64), gg: wp.array(dtype=wp.float64)):
    """int over psi in [a, b], panels graded geometrically (ratio 2) toward both ends from ``scale``."""
    mid = F(0.5) * (a + b)
    total = wp.vec2d(F(0.0), F(0.0))
    lo = a
    top = (b - a) / F(npan)  # the widest panel (npan > 0)
    width = wp.min(scale, top)
    for k in range(_MAX_PANELS + 64):
        hi = wp.min(lo + width, mid)
        if k == _MAX_PANELS + 63:
            hi = mid
        total += _outer_panel(wi, mu, li, ax, ay, lo, hi, shadowing, gx, gk, gg)
        lo = hi
        width = wp.min(F(2.0) * width, top)
        if lo >= mid:
            break
    hi = b
    width = wp.min(scale, top)
    for k in range(_MAX_PANELS + 64):
        lo = wp.max(hi - width, mid)
        if k == _MAX_PANELS + 63:
            lo = mid
        total += _outer_panel(wi, mu, li, ax, ay, lo, hi, shadowing, gx, gk, gg)
        hi = lo
        width = wp.min(F(2.0) * width, top)
        if hi <= mid:
            break
    return total


@wp.kernel
def albedo_aniso_kernel(idx: wp.array(dtype=wp.int32), mus: wp.array(dtype=wp.float64),
                        phis: wp.array(dtype=wp.float64),
                        axs: wp.array(dtype=wp.float64), ays: wp.array(dtype=wp.float64), shadowing: int,
                        gx: wp.array(dtype=wp.float64), gk: wp.array(dtype=wp.float64),
                        gg: wp.array(dtype=wp.float64), out: wp.array(dtype=wp.vec2d)):
    """One texel per thread (texel ``idx[tid]``): (E, E_err) of anisotropic GGX at (mu, phi_v, alpha_x, alpha_y)."""
    t = idx[wp.tid()]
    mu = wp.min(wp.max(mus[t], F(0.0)), F(1.0))
    ax = axs[t]
    ay = ays[t]
    si = wp.sqrt(wp.max(F(0.0), F(1.0) - mu * mu))  # clamped: mu <= 1
    wi = wp.vec3d(si * wp.cos(phis[t]), si * wp.sin(phis[t]), mu)
    li = ggx_aniso_lambda_cos(wi, ax, ay)
    A = wi[0] * ax
    B = wi[1] * ay
    R = wp.sqrt(A * A + B * B)
    total = wp.vec2d(F(0.0), F(0.0))
    # panels per quarter turn: 4 x ceil(aspect) (the psi integrand has poles at distance about
    # atanh(alpha_y / alpha_x) from the real axis)
    aspect = F(1.0)
    if wp.min(ax, ay) > F(0.0):
        aspect = wp.min(wp.max(ax, ay) / wp.min(ax, ay), F(16.0))  # min > 0
    npan = 4 * int(wp.ceil(aspect - F(1.0e-9)))
    if R <= F(0.0):
        # normal incidence or a mirror: r_max does not depend on psi's sign structure
        q0 = F(0.0)
        step = F(2.0) * _PI / F(4 * npan)
        for k in range(4 * npan):
            total += _outer_panel(wi, mu, li, ax, ay, q0, q0 + step, shadowing, gx, gk, gg)
            q0 = q0 + step
    else:
        psi0 = wp.atan2(B, A)
        qmax = wp.max(ax * ax, ay * ay)
        scale = wp.min(F(0.25) * _PI, wp.max(mu * wp.sqrt(qmax) / R, F(1.0e-10)) * F(0.25))
        total += _graded_half(wi, mu, li, ax, ay, psi0 - F(0.5) * _PI, psi0 + F(0.5) * _PI, scale, npan, shadowing, gx, gk, gg)
        total += _graded_half(wi, mu, li, ax, ay, psi0 + F(0.5) * _PI, psi0 + F(1.5) * _PI, scale, npan, shadowing, gx, gk, gg)
    out[t] = wp.vec2d(total[0], total[1] + _ROUNDING * wp.abs(total[0]))


def albedo_aniso_values(mu, phi_v, alpha_x, alpha_y, shadowing: str = "correlated", device=None, *,
                        workers: int | None = None, progress=None):
    """(E, E_err) of anisotropic GGX (F = 1) at broadcast points (mu, phi_v, alpha_x, alpha_y), float64.

    Texels run in chunks over ``workers`` threads (:func:`bsdf_tab.integrate.runtime.run_chunks`:
    the values do not depend on the chunking); ``progress(done, total)`` after each chunk, and an
    exception it raises stops the remaining chunks (the service's cancellation).
    """
    arrs = np.broadcast_arrays(*(np.asarray(x, dtype=np.float64) for x in (mu, phi_v, alpha_x, alpha_y)))
    shape = arrs[0].shape
    flat = [np.ascontiguousarray(x).ravel() for x in arrs]
    n = flat[0].size
    if n == 0:
        return np.zeros(shape), np.zeros(shape)
    device = resolve_device(device)
    gkx = [wp.array(np.asarray(x, dtype=np.float64), dtype=wp.float64, device=device) for x in (GK_X, GK_WK, GK_WG)]
    inputs = [wp.array(x, dtype=wp.float64, device=device) for x in flat]
    out = wp.zeros(n, dtype=wp.vec2d, device=device)

    def launch(idx):
        wp.launch(albedo_aniso_kernel, dim=idx.shape[0], inputs=[idx, *inputs, int(SHADOWINGS[shadowing]), *gkx],
                  outputs=[out], device=device)

    run_chunks(n, launch, device, workers=workers, progress=progress)
    res = out.numpy()
    # a mirror (alpha_x = alpha_y = 0) reflects everything: E = F = 1 at every mu, the grazing
    # corner mu = 0 included (its integrand has no finite value there; the limit alpha -> 0 first,
    # as the isotropic kinds define it)
    mirror = (flat[2] == 0.0) & (flat[3] == 0.0)
    res[mirror] = (1.0, 0.0)
    return res[:, 0].reshape(shape), res[:, 1].reshape(shape)


def compute(nspec: dict, axes: dict, ctx: Context) -> dict:
    mu = np.asarray(axes["mu"], dtype=np.float64)
    phi = np.asarray(axes["phi_v"], dtype=np.float64)
    alpha = alpha_values(axes)
    an = np.asarray(axes["anisotropy"], dtype=np.float64)
    M, P, A, N = np.meshgrid(mu, phi, alpha, an, indexing="ij")
    ax, ay = aniso_widths(A, N)
    ctx.expect(M.size)
    E, err = albedo_aniso_values(M, P, ax, ay, nspec["shadowing"], ctx.device, workers=ctx.workers,
                                 progress=ctx.reporter())
    return {"E": E, "E_err": err}
