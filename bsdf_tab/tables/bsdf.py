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
``btdf``): no discretization error, only rounding. Writing f_r = F(c) R and f_t = (1 - F(c)) T,
the error channel is

    err = |f| eps (64 + K) + R dF (or T dF) + 2^-1074 (2 + 1/q + gain),   eps = 2^-52,

where 64 covers the arithmetic of G, D and the divisions, and K the conditioning of the
half-vector: the rounded h has |delta cos theta_h| <= 8 eps (reflection) or amp eps, amp =
8 (1 + eta) / |i + eta o| (transmission), amplified by |d ln D / d cos theta_h| (the model's
``dlnD_dcos``: GGX 4/c + 4/(c (alpha^2 c^2 + 1 - c^2)), Beckmann 4/c + 2/(c^3 alpha^2)), and for
transmission by 2x the relative error of the denominator (i.h) + eta (o.h) (= |i + eta o|).
dF is an absolute bound on the Fresnel term's own error (``_fresnel_err``): a running error
analysis of the model's operation sequence plus its input error (the same |delta cos|). It
carries the condition numbers the old relative allowance missed: the dielectric's g - c
cancellation as eta -> 1 (relative error ~8 eps cos^2 / |eta^2 - 1|), its square-root slope at the
critical angle (and a computed total internal reflection within rounding of it), the
conductor's r_s numerator as eta + i k -> 1, Schlick's (1 - c)^5 at c = 1. Under 1 - F it is
the cancellation near total internal reflection. The last term is the subnormal floor: a
result below 2^-1022 is rounded to 2^-1075 absolute, not eps relative; q = 4 |i.n||o.n| (or
den^2) is the last division and ``gain`` the growth of a subnormal exp(-tan^2/alpha^2) through
Beckmann's 1/(pi alpha^2 cos^4) and the other factors. The floor also makes a texel that
underflowed to 0 inside the support honest. In ``half_diff``, a refraction test that calls
total internal reflection within the rounding of k2 = 1 - (1 - cos^2 theta_d) / eta^2 (~eps /
eta^2) refracts at the largest k2 that rounding allows, and that f_t is added to its bound (the
exact value lies between 0 and it). Checked against a 40-digit evaluation in
``tests/tables/test_bsdf_honesty.py``.
Stored EXR channels are float32 (relative rounding 2^-24 on top).

Memory: :func:`blocks` computes blocks of axis-0 slices; ``bsdf_tab.api.iter_blocks`` hands
them to a streaming writer of :mod:`bsdf_tab.io`, so a full-size grid needs memory for one block
only.
"""

from __future__ import annotations

import numpy as np
import warp as wp

from ..integrate.runtime import default_workers, run_chunks
from ..model import (
    BECKMANN,
    FRESNEL_CONDUCTOR,
    FRESNEL_DIELECTRIC,
    FRESNEL_SCHLICK,
    D,
    brdf,
    btdf,
    dlnD_dcos,
    fresnel,
    fresnel_dielectric,
    smith_G,
)
from ._common import Context, integrator_params

# no kernel of this module is differentiated: no adjoint code (a third of the compile time)
wp.set_module_options({"enable_backward": False})

__all__ = ["CHANNELS", "EPS_REL", "KINDS", "blocks", "compute", "material_alpha"]

CHANNELS = ("f_r", "f_t", "f_r_err", "f_t_err")
PARAM_ANGLES = wp.constant(0)
PARAM_HALF_DIFF = wp.constant(1)
_PARAM = {"angles": 0, "half_diff": 1}
#: Base relative rounding allowance of one point evaluation (in units of eps = 2^-52).
EPS_REL = 64.0
_EPS = 2.0**-52
#: One subnormal ulp, 2^-1074: the absolute rounding of a result below 2^-1022.
_TINY = 2.0**-1074
#: Texels per kernel block (the streaming memory bound is ~ 4 channels x 8 bytes x this).
BLOCK_TEXELS = 1 << 20


@wp.func
def _sqrt_err(x: wp.float64, ex: wp.float64):
    """Bound on |sqrt(x') - sqrt(x)| for |x' - x| <= ex, x >= 0 (not first order: exact).

    |sqrt(x') - sqrt(x)| = |x' - x| / (sqrt(x') + sqrt(x)) <= min(ex / sqrt(x), sqrt(ex)).
    """
    r = wp.sqrt(wp.max(ex, wp.float64(0.0)))
    sx = wp.sqrt(wp.max(x, wp.float64(0.0)))
    if sx > r:
        # x well away from 0: the linear bound ex / sqrt(x) is the smaller one (sx > r >= 0)
        return ex / sx
    return r


@wp.func
def _fresnel_dielectric_err(ci: wp.float64, dc: wp.float64, eta: wp.float64):
    r"""Absolute error bound of the model's ``fresnel_dielectric(ci, eta)``, ``ci`` known to ``dc``.

    Two parts. Rounding: a running error analysis of the model's own operation sequence
    (g^2 = (eta - 1)(eta + 1) + c^2, g = sqrt(g^2), a = (g - c)/(g + c),
    b = (c (g + c) - 1)/(c (g - c) + 1), F = a^2 (1 + b^2)/2), each step adding eps |result| to the
    propagated bounds. The one that matters is g - c: as eta -> 1, g - c = (eta^2 - 1)/(g + c)
    while the rounding of g is ~eps c, so

    .. math:: \frac{\delta F}{F} \approx \frac{8\,\varepsilon\,c^2}{|\eta^2 - 1|}

    (the condition number of F near eta = 1: 4e6 eps at eta = 1 + 1e-6). Input: the exact
    derivative, which has no such cancellation (d ln a / dc = -2/g),

    .. math:: |\partial F/\partial c| \le |a|\,(1 + b^2)\,\frac{2|a|}{g}
              + a^2 |b| \frac{|n'| + |b|\,|d'|}{\mathrm{den}},\quad
              n' = g + 2c + c^2/g,\; |d'| \le g + 2c + c^2/g,

    with g replaced by max(g, sqrt(2 c dc)) (a factor 2 on the a-term) so that it stays a bound
    at the critical angle g -> 0, where F - 1 ~ -(2/c + 2c/s^2) g is a square-root in c.
    Computed total internal reflection (g^2 <= 0) within the uncertainty of g^2 of the critical
    angle has error <= (2/c + 2c/s^2) 2 sqrt(delta g^2) (capped at 1).
    """
    zero = wp.float64(0.0)
    one = wp.float64(1.0)
    two = wp.float64(2.0)
    eps = wp.float64(_EPS)
    if eta == one:
        # the model returns exactly 0, the exact value for any c
        return zero
    c = wp.min(wp.abs(ci), one)
    d = (eta - one) * (eta + one)
    c2 = c * c
    g2 = d + c2
    # rounding of (eta - 1), (eta + 1), their product, c * c and the sum
    e_g2 = eps * (wp.float64(4.0) * wp.abs(d) + c2 + wp.abs(g2))
    e_tot = e_g2 + two * c * dc + dc * dc
    if g2 <= zero:
        if g2 + e_tot <= zero:
            # certainly total internal reflection: F = 1 exactly
            return zero
        s2 = wp.max(one - c2, wp.float64(1.0e-300))  # > 0: g2 <= 0 needs s2 >= eta^2 - tiny
        k = two / wp.max(c, wp.float64(1.0e-300)) + two * c / s2  # c > 0 guarded
        return wp.min(one, k * two * wp.sqrt(e_tot))  # e_tot >= 0: a sum of bounds
    g = wp.sqrt(g2)  # g2 > 0 in this branch
    gp = g + c  # > 0: g > 0 here
    gm = g - c
    # --- rounding (running error analysis, input c exact)
    e_g = _sqrt_err(g2, e_g2) + eps * g
    e_gm = e_g + eps * wp.abs(gm)
    e_gp = e_g + eps * gp
    a = gm / gp  # gp > 0 (above)
    e_a = (e_gm + wp.abs(a) * e_gp) / gp + eps * wp.abs(a)
    num = c * gp - one
    den = c * gm + one
    # den >= 1 - c^2 + c g > 0 (c = 1 needs g > 0 here); floored anyway
    den = wp.max(den, wp.float64(1.0e-300))
    e_num = c * e_gp + eps * (c * gp + wp.abs(num))
    e_den = c * e_gm + eps * (c * wp.abs(gm) + den)
    b = num / den
    e_b = (e_num + wp.abs(b) * e_den) / den + eps * wp.abs(b)
    aa = a * a
    ob = one + b * b
    e_aa = two * wp.abs(a) * e_a + eps * aa
    e_ob = two * wp.abs(b) * e_b + eps * (b * b + ob)
    f = wp.float64(0.5) * aa * ob
    e_round = wp.float64(0.5) * (ob * e_aa + aa * e_ob) + eps * f
    # --- input: exact derivative in c, g floored at the square-root scale of the perturbation
    ge = wp.max(g, wp.sqrt(two * c * dc))  # c, dc >= 0
    if ge <= zero:
        # c = 0 and dc = 0: the input is exact
        return e_round
    dpr = ge + two * c + c2 / ge  # ge > 0 (above)
    e_a_in = wp.float64(4.0) * wp.abs(a) * dc / ge
    e_b_in = (one + wp.abs(b)) * dpr * dc / den
    e_in = ob * wp.abs(a) * e_a_in + aa * wp.abs(b) * e_b_in
    return e_round + e_in


@wp.func
def _fresnel_conductor_err(ci: wp.float64, dc: wp.float64, eta: wp.float64, k: wp.float64):
    """Absolute error bound of the model's ``fresnel_conductor``: running error analysis.

    The model's sequence (c^2, s^2 = 1 - c^2, t0 = eta^2 - k^2 - s^2, |n^2 - s^2| = sqrt(t0^2 +
    4 eta^2 k^2), a = sqrt((|.| + t0)/2), r_s = (|.| + c^2 - 2ac)/(|.| + c^2 + 2ac), r_p = r_s (t1 -
    t2)/(t1 + t2)), each step's bound propagated with |partial derivatives| and eps |result| added,
    the input error ``dc`` carried as an absolute error of c. The differences |.| + c^2 - 2ac (r_s
    -> 0 as eta + i k -> 1) and t1 - t2 are where the bound grows: their relative error is the
    sum of the magnitudes over the difference, the condition number of F there.
    """
    zero = wp.float64(0.0)
    one = wp.float64(1.0)
    two = wp.float64(2.0)
    half = wp.float64(0.5)
    eps = wp.float64(_EPS)
    c = wp.min(wp.abs(ci), one)
    c2 = c * c
    e_c2 = two * c * dc + eps * c2
    s2 = one - c2
    e_s2 = e_c2 + eps * wp.abs(s2)
    ee = eta * eta
    kk = k * k
    t0 = ee - kk - s2
    e_t0 = eps * (ee + kk + wp.abs(ee - kk) + wp.abs(t0)) + e_s2
    q4 = wp.float64(4.0) * ee * kk
    q = t0 * t0 + q4
    e_q = two * wp.abs(t0) * e_t0 + eps * (t0 * t0 + wp.float64(4.0) * q4 + q)
    r = wp.sqrt(q)  # q >= 0: a sum of squares
    e_r = _sqrt_err(q, e_q) + eps * r
    u = wp.max(zero, half * (r + t0))
    e_u = half * (e_r + e_t0) + eps * (r + wp.abs(t0))
    a = wp.sqrt(u)  # u >= 0 (max above)
    e_a = _sqrt_err(u, e_u) + eps * a
    ac = two * a * c
    e_ac = two * (c * e_a + a * dc) + two * eps * ac
    rs_num = r + c2 - ac
    rs_den = r + c2 + ac
    e_rsn = e_r + e_c2 + e_ac + eps * (r + c2 + ac + wp.abs(rs_num))
    e_rsd = e_r + e_c2 + e_ac + eps * (wp.float64(2.0) * rs_den)
    if rs_den <= zero:
        # the model returns 1 (eta = k = 0 at grazing); no propagation possible, bound by 1
        return one
    rs = rs_num / rs_den  # rs_den > 0 (above)
    e_rs = (e_rsn + wp.abs(rs) * e_rsd) / rs_den + eps * wp.abs(rs)
    t1 = c2 * r + s2 * s2
    e_t1 = r * e_c2 + c2 * e_r + two * wp.abs(s2) * e_s2 + wp.float64(3.0) * eps * (c2 * r + s2 * s2)
    t2 = two * a * c * s2
    e_t2 = two * (c * wp.abs(s2) * e_a + a * wp.abs(s2) * dc + a * c * e_s2) + wp.float64(3.0) * eps * wp.abs(t2)
    rp_den = t1 + t2
    f = half * (rs + rs)
    e_f = e_rs + eps * f
    if rp_den > zero:
        rho = (t1 - t2) / rp_den  # rp_den > 0 (this branch)
        e_rho = (e_t1 + e_t2) * (one + wp.abs(rho)) / rp_den + eps * (wp.abs(t1) + wp.abs(t2) + wp.abs(rho))
        rp = rs * rho
        e_rp = wp.abs(rho) * e_rs + wp.abs(rs) * e_rho + eps * wp.abs(rp)
        f = half * (rs + rp)
        e_f = half * (e_rs + e_rp) + eps * wp.abs(f)
    return e_f


@wp.func
def _fresnel_err(ci: wp.float64, dc: wp.float64, ftype: wp.int32, p0: wp.float64, p1: wp.float64):
    """Absolute error bound of the model's ``fresnel(ci, ftype, p0, p1)`` with ``ci`` known to ``dc``.

    ``one``: 0 (exact). Schlick F = f0 + (1 - f0) m^5, m = 1 - c: 6 roundings of terms of
    magnitude |f0| + |1 - f0| m^5 (m = 1 - c itself is exact for c in [1/2, 1]), and the input
    term |1 - f0| ((m + dc)^5 - m^5), exact for the 5th power (it stays a bound at m = 0, where the
    derivative vanishes). Dielectric and conductor: :func:`_fresnel_dielectric_err`,
    :func:`_fresnel_conductor_err`.
    """
    if ftype == FRESNEL_DIELECTRIC:
        return _fresnel_dielectric_err(ci, dc, p0)
    if ftype == FRESNEL_CONDUCTOR:
        return _fresnel_conductor_err(ci, dc, p0, p1)
    if ftype == FRESNEL_SCHLICK:
        one = wp.float64(1.0)
        m = one - wp.min(wp.abs(ci), one)
        w = wp.abs(one - p0)
        mu = m + dc
        mu2 = mu * mu
        m2 = m * m
        return wp.float64(8.0) * wp.float64(_EPS) * (wp.abs(p0) + w * m2 * m2 * m) + w * (mu2 * mu2 * mu - m2 * m2 * m)
    return wp.float64(0.0)


@wp.func
def _underflow_gain(alpha: wp.float64, ch: wp.float64, rest: wp.float64):
    """How much an absolute error of one subnormal ulp in D's first factor grows into f.

    D = e / (pi alpha^2 c^4) with e = exp(-tan^2/alpha^2) (Beckmann) or a GGX ratio; once e is
    subnormal its absolute error is ~2^-1074, no longer eps |e|, and reaches f multiplied by
    ``rest`` / (pi alpha^2 c^4) (``rest`` = every other factor of f). Capped at 1e300.
    """
    den = wp.float64(3.141592653589793) * alpha * alpha * ch * ch * ch * ch
    if den <= wp.float64(1.0e-300) * rest:
        # the ratio would exceed 1e300 (or alpha = 0 / grazing h, where D is 0 anyway)
        return wp.float64(1.0e300)
    return wp.min(rest / den, wp.float64(1.0e300))  # den > 0 here


@wp.func
def _directions(param: wp.int32, a0: wp.float64, a1: wp.float64, a2: wp.float64, eta: wp.float64):
    """(w_i, w_o reflected, w_o transmitted, ok_t) of one grid point (see the module docstring);
    ok_t: 0 no refraction, 1 refracted, 2 refracted only within the rounding of the test."""
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
        ok = int(0)
        if k2 >= zero:
            ok = int(1)
        # cd is a rounded cosine and 1 - cd^2 loses ~eps / sin^2: a computed total internal
        # reflection within d2 of k2 = 0 may refract exactly, with some k2 in [0, d2]. Refract
        # at k2 = d2 (ok = 2): f_t there bounds the exact value (it grows from 0 with k2), and
        # the kernel adds it to the error instead of a bare 0 with bound 0.
        d2 = wp.float64(8.0 * _EPS) * (one + one / (eta * eta))
        if ok == 0 and k2 > -d2:
            ok = int(2)
            k2 = d2
        if ok > 0:
            wt = (cd / eta - wp.sqrt(k2)) * h - wi / eta
        return wi, wr, wt, ok
    si = wp.sin(a0)
    ci = wp.cos(a0)
    so = wp.sin(a1)
    co = wp.cos(a1)
    wi = wp.vec3d(si, zero, ci)
    wr = wp.vec3d(so * c2, so * s2, co)
    wt = wp.vec3d(so * c2, so * s2, -co)
    return wi, wr, wt, int(1)


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

    zero = wp.float64(0.0)
    tiny = wp.float64(_TINY)
    dc8 = wp.float64(8.0) * eps  # |delta cos| of the rounded half-vector (reflection)
    beck = dist == BECKMANN

    fr = brdf(wi, wr, alpha, dist, shadowing, ftype, p0, p1)
    er = zero
    zi = wi[2]
    zo = wr[2]
    if zi > zero and zo > zero and alpha > zero:
        h = wp.normalize(wi + wr)
        c = wp.dot(wi, h)
        if c > zero:
            # f_r = F(c) R, R = G D / (4 zi zo): F's error enters as R dF
            q = wp.float64(4.0) * zi * zo  # > 0 (zi, zo > 0)
            g = smith_G(zi, zo, alpha, dist, shadowing)
            rest = g * D(h[2], alpha, dist) / q
            ff = fresnel(c, ftype, p0, p1)
            er = rest * _fresnel_err(c, dc8, ftype, p0, p1)
            gain = zero
            if beck:
                gain = _underflow_gain(alpha, h[2], wp.abs(ff) * g / q)
            er += wp.abs(fr) * eps * (wp.float64(EPS_REL) + wp.float64(8.0) * dlnD_dcos(h[2], alpha, dist))
            # subnormal floor: the last operations' absolute rounding, F G D / q, and D's factor
            er += tiny * (wp.float64(2.0) + one / q + gain)

    ft = zero
    et = zero
    if ftype == FRESNEL_DIELECTRIC and ok_t > 0:
        ft = btdf(wi, wt, alpha, dist, shadowing, p0)
        zo = wt[2]
        v = wi + p0 * wt
        hl = wp.length(v)
        if zi > zero and zo < zero and hl > zero and alpha > zero:
            h = -v / hl  # hl > 0 (this branch)
            if h[2] < zero:
                h = -h
            ci = wp.dot(wi, h)
            co = wp.dot(wt, h)
            den = ci + p0 * co
            if ci > zero and co < zero and den != zero:
                # f_t = (1 - F(ci)) T; |delta cos| of h is amp eps
                amp = wp.float64(8.0) * (one + p0) / hl  # hl > 0
                g = smith_G(zi, zo, alpha, dist, shadowing)
                pre = (ci * (-co)) / (zi * (-zo)) * p0 * p0 * g / (den * den)  # zi, zo, den != 0
                rest = pre * D(h[2], alpha, dist)
                ff = fresnel_dielectric(ci, p0)
                et = rest * _fresnel_dielectric_err(ci, amp * eps, p0)
                gain = zero
                if beck:
                    gain = _underflow_gain(alpha, h[2], (one - ff) * pre)
                # D's conditioning through h, and 2x the relative error of den = -|i + eta o|
                kappa = dlnD_dcos(h[2], alpha, dist) + wp.float64(2.0)
                et += wp.abs(ft) * eps * (wp.float64(EPS_REL) + amp * kappa)
                et += tiny * (wp.float64(2.0) + one / (den * den) + gain)
        if ok_t == 2:
            # refraction only within rounding: the exact value lies in [0, ft] (see _directions)
            et += wp.abs(ft)
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
