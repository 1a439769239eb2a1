"""Beckmann microfacet distribution: everything the package knows about it.

D, the exact Smith Lambda (and |cos| Lambda), visible-normal sampling, the CDF of D(m) cos(theta_m)
in theta_m and its inverse (for D cos sampling and the adaptive integrator's outer variable), and
the bound on |d ln D / d cos theta_m| the bsdf table uses to propagate rounding. Registered in
:mod:`bsdf_tab.model.distribution` under :data:`NAME`.

References: Walter et al. 2007 (D, eq. 25; Smith Lambda, eq. 27 without the rational
approximation); Heitz and d'Eon 2014, "Importance Sampling Microfacet-Based BSDFs using the
Distribution of Visible Normals" (visible-slope sampling, solved here by safeguarded Newton).
"""

from typing import Any

import warp as wp

from .frame import expm1_, log1p_

NAME = "beckmann"
DESCRIPTION = "Beckmann, alpha = alpha_b (Walter et al. 2007 eq. 25)"

_HALF_PI = 1.5707963267948966
_INV_SQRT_PI = 0.56418958354775628
_HALF_INV_SQRT_PI = 0.28209479177387814


@wp.func
def beckmann_D(cos_theta_m: Any, alpha: Any):
    """D(m) = exp(-tan^2 / alpha^2) / (pi alpha^2 cos^4), normalized: int D cos dw = 1."""
    zero = type(alpha)(0.0)
    if cos_theta_m <= zero:
        # back-facing micro-normals carry no area
        return zero
    if alpha <= zero:
        # alpha = 0 is a Dirac delta: no finite density
        return zero
    c2 = cos_theta_m * cos_theta_m
    a2 = alpha * alpha
    t2 = wp.max(zero, type(alpha)(1.0) - c2) / c2
    return wp.exp(-t2 / a2) / (type(alpha)(wp.pi) * a2 * c2 * c2)


@wp.func
def beckmann_lambda_cos(cos_theta_v: Any, alpha: Any):
    """|cos| * Lambda(v) with a = 1 / (alpha tan): alpha s (exp(-a^2) / (2 sqrt(pi)) - a erfc(a) / 2).

    Exact Smith Lambda (erf(a) - 1) / 2 + exp(-a^2) / (2 a sqrt(pi)), multiplied by cos so that it
    stays finite at grazing (value alpha / (2 sqrt(pi))).
    """
    zero = type(alpha)(0.0)
    z = wp.abs(cos_theta_v)
    s = wp.sqrt(wp.max(zero, type(alpha)(1.0) - z * z))
    if s * alpha <= zero:
        # normal incidence or mirror: no shadowing
        return zero
    a = z / (alpha * s)
    half = type(alpha)(0.5)
    return alpha * s * half * (type(alpha)(_INV_SQRT_PI) * wp.exp(-a * a) - a * wp.erfc(a))


@wp.func
def beckmann_lambda(cos_theta_v: Any, alpha: Any):
    """Smith Lambda(v) for Beckmann (exact, infinite at grazing)."""
    z = wp.abs(cos_theta_v)
    if z <= type(alpha)(0.0):
        # grazing: fully shadowed unless alpha = 0
        if alpha <= type(alpha)(0.0):
            return type(alpha)(0.0)
        return type(alpha)(wp.inf)
    return beckmann_lambda_cos(cos_theta_v, alpha) / z


@wp.func
def _beckmann_slope_cdf(x: Any, cot: Any, norm: Any):
    # unnormalized CDF of the visible slope marginal (cot - x) exp(-x^2) / sqrt(pi), x <= cot
    half = type(x)(0.5)
    return (cot * half * wp.erfc(-x) + half * type(x)(_INV_SQRT_PI) * wp.exp(-x * x)) / norm


@wp.func
def beckmann_sample_vndf(wi: Any, alpha: Any, u1: Any, u2: Any):
    """Sample a visible micro-normal for ``wi`` (wi.z > 0), density G1 max(0, wi.m) D / wi.z."""
    zero = type(alpha)(0.0)
    one = type(alpha)(1.0)
    if alpha <= zero:
        # mirror: the only micro-normal is the macro normal
        return type(wi)(zero, zero, one)
    # stretch to the alpha = 1 configuration
    ws = wp.normalize(type(wi)(alpha * wi[0], alpha * wi[1], wi[2]))
    sin_s = wp.sqrt(ws[0] * ws[0] + ws[1] * ws[1])
    cos_phi = one
    sin_phi = zero
    if sin_s > zero:
        cos_phi = ws[0] / sin_s
        sin_phi = ws[1] / sin_s
    # keep erfinv away from +-1
    eps = type(alpha)(1.0e-7)
    v2 = wp.clamp(type(alpha)(2.0) * u2 - one, -one + eps, one - eps)
    y = wp.erfinv(v2)
    x = zero
    if sin_s < type(alpha)(1.0e-7):
        # normal incidence: slopes are the plain Gaussian exp(-x^2) / sqrt(pi)
        x = wp.erfinv(wp.clamp(type(alpha)(2.0) * u1 - one, -one + eps, one - eps))
    else:
        cot = ws[2] / sin_s
        norm = cot * type(alpha)(0.5) * wp.erfc(-cot) + type(alpha)(_HALF_INV_SQRT_PI) * wp.exp(-cot * cot)
        lo = type(alpha)(-9.0)
        hi = wp.min(cot, type(alpha)(9.0))
        x = wp.clamp(zero, lo, hi)
        for _it in range(100):
            f = _beckmann_slope_cdf(x, cot, norm) - u1
            if f > zero:
                hi = x
            else:
                lo = x
            df = (cot - x) * type(alpha)(_INV_SQRT_PI) * wp.exp(-x * x) / norm
            xn = x - f / wp.max(df, type(alpha)(1.0e-30))
            if xn <= lo or xn >= hi:
                # Newton left the bracket: bisect instead
                xn = type(alpha)(0.5) * (lo + hi)
            if wp.abs(xn - x) <= type(alpha)(1.0e-12) * (one + wp.abs(x)):
                x = xn
                break
            x = xn
    # rotate back to the azimuth of wi, unstretch, and convert slopes to a normal
    sx = alpha * (cos_phi * x - sin_phi * y)
    sy = alpha * (sin_phi * x + cos_phi * y)
    return wp.normalize(type(wi)(-sx, -sy, one))


@wp.func
def beckmann_dcos_sample_tan(u: Any, alpha: Any):
    """tan(theta_m) where the D cos CDF u = 1 - exp(-tan^2 / alpha^2) takes the value ``u`` in [0, 1).

    Inverse-CDF sampling of D(m) cos(theta_m) (Walter et al. 2007 eq. 28): tan = alpha sqrt(-ln(1 - u)).
    """
    return alpha * wp.sqrt(wp.max(type(u)(0.0), -wp.log(type(u)(1.0) - u)))


@wp.func
def beckmann_dcos_tan_of_v(v: Any, alpha: Any):
    """tan(theta_m) at v in [0, 1), where u = 1 - (1 - v)^2 is the D cos CDF.

    tan^2 = -alpha^2 ln((1 - v)^2), with log1p for small v.
    """
    return alpha * wp.sqrt(wp.max(type(v)(0.0), type(v)(-2.0) * log1p_(-v)))


@wp.func
def beckmann_dcos_v_of_theta(theta: Any, alpha: Any):
    """Inverse of :func:`beckmann_dcos_tan_of_v` for theta_m in [0, pi/2]: v = 1 - exp(-tan^2 / (2 alpha^2))."""
    one = type(theta)(1.0)
    if theta >= type(theta)(_HALF_PI) or alpha <= type(alpha)(0.0):
        # the horizon, or a mirror (all of D at theta_m = 0): the whole CDF
        return one
    c = wp.cos(theta)
    s = wp.sin(theta)
    t = s / c
    return -expm1_(-t * t / (type(theta)(2.0) * alpha * alpha))


@wp.func
def beckmann_dlnD_dcos(c: Any, alpha: Any):
    """Bound on |d ln D / d cos theta_m|: 4 / c + 2 / (c^3 alpha^2).

    The amplification of a relative error in cos theta_m into D (the bsdf table's rounding
    estimate); ``c`` is clamped to 1e-300 so that c = 0 gives a huge bound (or +inf), never nan.
    """
    c = wp.max(c, type(c)(1.0e-300))
    return type(c)(4.0) / c + type(c)(2.0) / (c * c * c * alpha * alpha)
