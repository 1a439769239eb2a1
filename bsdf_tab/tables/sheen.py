"""``sheen_albedo``: E(mu, alpha) of the Charlie sheen BRDF; ``sheen_albedo_avg``: 2 int E mu dmu.

The BRDF is f = D(h) V(mu_i, mu_o) (F = 1; the sheen colour multiplies it) with the Charlie D
of Estevez and Kulla 2017, "Production Friendly Microfacet Sheen BRDF", and the visibility V
chosen by the spec's ``sheen_shadowing`` key (declared in these kinds' ``keys``; the older
spelling ``parametrization`` is still accepted and normalized to it; the axes are (mu, alpha),
alpha = sheenRoughness^2, or a ``roughness`` axis = sheenRoughness):

- ``fitted`` (default): the paper's fitted Lambda, correlated, V clamped to [0, 1] as the
  glTF Sample Viewer's ``V_Sheen`` (:func:`bsdf_tab.model.charlie.charlie_V_fitted`);
- ``exact``: the exact Smith Lambda of D, correlated (``charlie_V_exact``): E(mu = 0) = 1;
- ``ashikhmin``: Filament's ``V_Neubelt`` = 1 / (4 (mu_i + mu_o - mu_i mu_o)).

Integrator (its own kernel: the general integrators need a D cos CDF map Charlie does not
have). Over the half vector h (Walter et al. 2007 eq. 14): E = int D(h) V mu_o 4 (i.h) dw_h
over the h with mu_o = 2 (i.h) cos(theta_h) - mu > 0. With theta_i = acos(mu) that set is,
in closed form, all phi_h for theta_h < theta_1 = (pi/2 - theta_i) / 2, the phi_h with
cos(phi_h) > kappa = -mu cos(2 theta_h) / (sin(theta_i) sin(2 theta_h)) for theta_1 <= theta_h
< theta_* = (pi/2 + theta_i) / 2, and none above. Composite Gauss-Kronrod 7-15 in theta_h on
[0, theta_1] (2 panels) and on [theta_1, theta_*] in panels graded geometrically toward
theta_* at the scale min(sqrt(alpha), alpha tan(theta_*)) / 16 (where D's horizon peak and
its exponential tail sit), with quadratic substitutions on the panels touching theta_1 and
theta_* (the phi range opens like a square root there); in phi_h 3 G7-K15 panels on
[0, phi_max], the last one quadratically graded toward phi_max. The error of a texel is
sum |K15 - G7| over the outer panels (inner values from K15) plus the K15-weighted inner
|K15 - G7| plus 1e-14 |E| for rounding. ``sheen_albedo_avg`` integrates E(w^2) 4 w^3 over
w = sqrt(mu) by G7-K15 on 4 panels (errors: |K15 - G7| plus the weighted texel errors).
float64 throughout.
"""

from __future__ import annotations

import math

import numpy as np
import warp as wp

from ..axes import alpha_values
from ..integrate.quadrature import GK_WG, GK_WK, GK_X
from ..model.charlie import (
    charlie_D,
    charlie_V_ashikhmin,
    charlie_V_exact,
    charlie_V_fitted,
    charlie_alpha,
    charlie_projected_area_table,
)
from ._common import Context
from .kinds import SHEEN_SHADOWINGS

# no kernel of this module is differentiated: no adjoint code (a third of the compile time)
wp.set_module_options({"enable_backward": False})

_MAX_GRADED = 48
_INNER_PANELS = 4
_MAX_INNER = 64
_INNER_PANELS_F = wp.constant(wp.float64(_INNER_PANELS))
_ROUNDING = wp.constant(wp.float64(1.0e-14))

_HALF_PI = wp.constant(wp.float64(0.5 * math.pi))


@wp.func
def _integrand(mu: wp.float64, sin_i: wp.float64, a: wp.float64, th: wp.float64, phi: wp.float64, mode: int,
               table: wp.array2d(dtype=wp.float64), row: int):
    """D(h) V mu_o 4 (i.h) sin(theta_h): the integrand per d theta_h d phi_h (0 outside)."""
    st = wp.sin(th)
    ct = wp.cos(th)
    ih = sin_i * st * wp.cos(phi) + mu * ct
    mo = wp.float64(2.0) * ih * ct - mu
    if mo <= wp.float64(0.0) or ih <= wp.float64(0.0):
        # w_o below the horizon, or a back-facing micro-normal
        return wp.float64(0.0)
    v = wp.float64(0.0)
    if mode == 0:
        v = charlie_V_fitted(mu, mo, a)
    elif mode == 1:
        v = charlie_V_exact(mu, mo, a, table, row)
    else:
        v = charlie_V_ashikhmin(mu, mo)
    return charlie_D(ct, a) * v * mo * wp.float64(4.0) * ih * st


@wp.func
def _phi_max(mu: wp.float64, sin_i: wp.float64, th: wp.float64):
    """Upper end of the admissible phi_h range at theta_h (0: empty, pi: the whole circle)."""
    num = -mu * wp.cos(wp.float64(2.0) * th)
    den = sin_i * wp.sin(wp.float64(2.0) * th)
    if den <= wp.float64(0.0):
        # normal incidence or theta_h = 0: the threshold is +-infinity
        if num <= wp.float64(0.0):
            return wp.float64(3.141592653589793)
        return wp.float64(0.0)
    k = num / den  # den > 0
    if k <= -wp.float64(1.0):
        return wp.float64(3.141592653589793)
    if k >= wp.float64(1.0):
        return wp.float64(0.0)
    return wp.acos(k)


@wp.func
def _inner(mu: wp.float64, sin_i: wp.float64, a: wp.float64, th: wp.float64, mode: int, table: wp.array2d(dtype=wp.float64),
           row: int, gx: wp.array(dtype=wp.float64), gk: wp.array(dtype=wp.float64),
           gg: wp.array(dtype=wp.float64)):
    """(K15 value, error) of 2 int_0^phi_max integrand d phi_h (the factor 2: phi_h -> -phi_h)."""
    pm = _phi_max(mu, sin_i, th)
    val = wp.float64(0.0)
    err = wp.float64(0.0)
    if pm <= wp.float64(0.0):
        return wp.vec2d(val, err)
    # the boundary layer at phi_max: mu_o = 2 (i.h) cos(theta_h) - mu falls to 0 there with slope
    # 2 sin(theta_i) sin(theta_h) cos(theta_h) sin(phi_max); V mu_o changes over mu_o ~ mu, so
    # panels are graded geometrically (ratio 2) from phi_max down from the width mu / slope
    slope = wp.float64(2.0) * sin_i * wp.sin(th) * wp.cos(th) * wp.sin(pm)
    delta = pm / _INNER_PANELS_F
    if slope > wp.float64(0.0) and pm < wp.float64(3.141592653589793):
        # slope > 0: mu / slope is finite
        delta = wp.min(delta, wp.max(mu / slope, wp.float64(1.0e-14) * pm))
    hi = pm
    width = delta
    for p in range(_MAX_INNER):
        lo = wp.max(hi - width, wp.float64(0.0))
        if p == _MAX_INNER - 1:
            lo = wp.float64(0.0)
        rk = wp.float64(0.0)
        rg = wp.float64(0.0)
        for j in range(15):
            s = wp.float64(0.5) * (gx[j] + wp.float64(1.0))
            phi = lo + (hi - lo) * s
            jac = wp.float64(0.5) * (hi - lo)
            if p == 0:
                # the panel at phi_max: phi = hi - w s'^4 with s' = 1 - s (mu_o -> 0 there;
                # the fitted Lambda has x^c terms with c ~ 0.17)
                sp = wp.float64(1.0) - s
                sp2 = sp * sp
                phi = hi - (hi - lo) * sp2 * sp2
                jac = wp.float64(2.0) * (hi - lo) * sp2 * sp
            f = _integrand(mu, sin_i, a, th, phi, mode, table, row) * jac
            rk += gk[j] * f
            rg += gg[j] * f
        val += rk
        err += wp.abs(rk - rg)
        hi = lo
        width = wp.min(width * wp.float64(2.0), pm / _INNER_PANELS_F)
        if hi <= wp.float64(0.0):
            break
    return wp.vec2d(wp.float64(2.0) * val, wp.float64(2.0) * err)


@wp.func
def _panel(mu: wp.float64, sin_i: wp.float64, a: wp.float64, lo: wp.float64, hi: wp.float64, grade: int, mode: int,
           table: wp.array2d(dtype=wp.float64), row: int, gx: wp.array(dtype=wp.float64),
           gk: wp.array(dtype=wp.float64), gg: wp.array(dtype=wp.float64)):
    """(value, error) over theta_h in [lo, hi]; grade 1: quadratic toward lo, 2: toward hi."""
    rk = wp.float64(0.0)
    rg = wp.float64(0.0)
    inner_err = wp.float64(0.0)
    w = hi - lo
    for j in range(15):
        s = wp.float64(0.5) * (gx[j] + wp.float64(1.0))
        th = lo + w * s
        jac = wp.float64(0.5) * w
        if grade == 1:
            th = lo + w * s * s
            jac = w * s
        elif grade == 2:
            sp = wp.float64(1.0) - s
            th = hi - w * sp * sp
            jac = w * sp
        r = _inner(mu, sin_i, a, th, mode, table, row, gx, gk, gg)
        rk += gk[j] * r[0] * jac
        rg += gg[j] * r[0] * jac
        inner_err += gk[j] * r[1] * jac
    return wp.vec2d(rk, wp.abs(rk - rg) + inner_err)


@wp.kernel
def sheen_albedo_kernel(mus: wp.array(dtype=wp.float64), alphas: wp.array(dtype=wp.float64),
                        rows: wp.array(dtype=wp.int32), mode: int, table: wp.array2d(dtype=wp.float64),
                        gx: wp.array(dtype=wp.float64), gk: wp.array(dtype=wp.float64),
                        gg: wp.array(dtype=wp.float64), out: wp.array(dtype=wp.vec2d)):
    """One texel per thread: (E, E_err) of the Charlie sheen BRDF at (mus[t], alphas[t])."""
    t = wp.tid()
    mu = wp.min(wp.max(mus[t], wp.float64(0.0)), wp.float64(1.0))
    a = charlie_alpha(alphas[t])
    row = rows[t]
    sin_i = wp.sqrt(wp.max(wp.float64(0.0), wp.float64(1.0) - mu * mu))  # clamped: mu <= 1
    theta_i = wp.acos(mu)
    t1 = wp.float64(0.5) * (_HALF_PI - theta_i)
    ts = wp.float64(0.5) * (_HALF_PI + theta_i)
    total = wp.vec2d(wp.float64(0.0), wp.float64(0.0))
    if t1 > wp.float64(0.0):
        # the full-circle part: smooth, two plain panels
        total += _panel(mu, sin_i, a, wp.float64(0.0), wp.float64(0.5) * t1, 0, mode, table, row, gx, gk, gg)
        total += _panel(mu, sin_i, a, wp.float64(0.5) * t1, t1, 0, mode, table, row, gx, gk, gg)
    # [theta_1, theta_*]: panels graded geometrically (ratio 2) up from theta_1 at the scale
    # theta_1 (phi_max goes from pi to about pi/2 within a few theta_1 when mu is small) and
    # down from theta_* at the scale g (D's horizon peak and its exponential tail)
    tan_s = wp.float64(1.0e300)
    if wp.cos(ts) > wp.float64(0.0):
        # theta_* < pi/2 unless mu = 0
        tan_s = wp.sin(ts) / wp.cos(ts)
    g = wp.min(wp.sqrt(a), a * tan_s) / wp.float64(16.0)
    mid = wp.float64(0.5) * (t1 + ts)
    lo = t1
    for k in range(_MAX_GRADED):
        hi = wp.min(wp.float64(2.0) * lo, mid)
        if k == 0:
            hi = wp.min(wp.max(wp.float64(2.0) * t1, g), mid)
        if k == _MAX_GRADED - 1:
            hi = mid
        grade = 0
        if k == 0:
            grade = 1
        if hi > lo:
            total += _panel(mu, sin_i, a, lo, hi, grade, mode, table, row, gx, gk, gg)
        lo = hi
        if lo >= mid:
            break
    hi = ts
    width = g
    for k in range(_MAX_GRADED):
        lo = wp.max(hi - width, mid)
        if k == _MAX_GRADED - 1:
            lo = mid
        grade = 0
        if k == 0:
            grade = 2
        if hi > lo:
            total += _panel(mu, sin_i, a, lo, hi, grade, mode, table, row, gx, gk, gg)
        hi = lo
        width = width * wp.float64(2.0)
        if hi <= mid:
            break
    out[t] = wp.vec2d(total[0], total[1] + _ROUNDING * wp.abs(total[0]))


def _gk_arrays(device):
    return tuple(wp.array(np.asarray(x, dtype=np.float64), dtype=wp.float64, device=device) for x in (GK_X, GK_WK, GK_WG))


def sheen_albedo_values(mu, alpha, shadowing: str = "fitted", device=None):
    """(E, E_err) of the Charlie sheen BRDF at the points (mu[k], alpha[k]) (float64 arrays).

    Parameters
    ----------
    mu, alpha : array_like
        Same shape; mu in [0, 1], alpha >= 0 (clamped at ``CHARLIE_ALPHA_MIN``).
    shadowing : {"fitted", "exact", "ashikhmin"}
    device : Warp device, optional
    """
    mu = np.asarray(mu, dtype=np.float64)
    alpha = np.asarray(alpha, dtype=np.float64)
    shape = np.broadcast(mu, alpha).shape
    mu_f = np.broadcast_to(mu, shape).ravel()
    al_f = np.broadcast_to(alpha, shape).ravel()
    uniq, rows = np.unique(al_f, return_inverse=True)
    mode = SHEEN_SHADOWINGS[shadowing]
    if mode == 1:
        table = charlie_projected_area_table(uniq)
    else:
        table = np.zeros((1, 4))  # unused by the fitted and Ashikhmin modes
    n = mu_f.size
    if n == 0:
        return np.zeros(shape), np.zeros(shape)
    out = wp.zeros(n, dtype=wp.vec2d, device=device)
    wp.launch(
        sheen_albedo_kernel, dim=n,
        inputs=[wp.array(mu_f, dtype=wp.float64, device=device), wp.array(al_f, dtype=wp.float64, device=device),
                wp.array(rows.astype(np.int32), dtype=wp.int32, device=device), mode,
                wp.array(table, dtype=wp.float64, device=device), *_gk_arrays(device)],
        outputs=[out], device=device,
    )
    res = out.numpy()
    return res[:, 0].reshape(shape), res[:, 1].reshape(shape)


def sheen_albedo_avg_values(alpha, shadowing: str = "fitted", device=None):
    """(E_avg, E_avg_err) = 2 int_0^1 E(mu) mu dmu per alpha, G7-K15 over w = sqrt(mu) on 4 panels."""
    alpha = np.atleast_1d(np.asarray(alpha, dtype=np.float64))
    ends = np.array([0.0, 0.25, 0.5, 0.75, 1.0])
    half = 0.5 * np.diff(ends)
    w = (0.5 * (ends[:-1] + ends[1:]))[:, None] + half[:, None] * GK_X[None, :]  # (4, 15)
    mu = (w * w).ravel()
    E, err = sheen_albedo_values(mu[None, :], alpha[:, None], shadowing, device)
    E = E.reshape(alpha.size, 4, 15)
    err = err.reshape(alpha.size, 4, 15)
    weight = 4.0 * w**3 * half[:, None]  # (4, 15)
    k15 = np.einsum("pj,j,apj->ap", weight, GK_WK, E)
    g7 = np.einsum("pj,j,apj->ap", weight, GK_WG, E)
    nodes_err = np.einsum("pj,j,apj->a", weight, GK_WK, err)
    return k15.sum(axis=1), np.abs(k15 - g7).sum(axis=1) + nodes_err


def compute(nspec: dict, axes: dict, ctx: Context) -> dict:
    mu = np.asarray(axes["mu"], dtype=np.float64)
    alpha = alpha_values(axes)
    ctx.expect(mu.size * alpha.size)
    E, err = sheen_albedo_values(mu[:, None], alpha[None, :], nspec["sheen_shadowing"], ctx.device)
    ctx.reporter()(mu.size * alpha.size, mu.size * alpha.size)
    return {"E": E, "E_err": err}


def compute_avg(nspec: dict, axes: dict, ctx: Context) -> dict:
    alpha = alpha_values(axes)
    ctx.expect(60 * alpha.size)
    E, err = sheen_albedo_avg_values(alpha, nspec["sheen_shadowing"], ctx.device)
    ctx.reporter()(60 * alpha.size, 60 * alpha.size)
    return {"E_avg": E, "E_avg_err": err}
