"""The one integrand every method shares: texel struct, integrand families, mirror limit.

Conventions (SPEC section 2): w_i = (sqrt(1 - mu^2), 0, mu) in the local frame (n = +z); mode
"reflect" gives (E, 0) with Fresnel ``ftype`` (p0, p1), "dielectric" (R, T) with the exact
dielectric Fresnel of relative IOR eta, "dfg" (A, B), the split-sum weights (1 - (1 - c)^5) and
(1 - c)^5 with F = 1. Every G is formed as G / mu from mu Lambda(mu) (finite at grazing mu = 0).

Written over the micro-normal m (Walter et al. 2007, "Microfacet Models for Refraction through
Rough Surfaces", eqs. 14 and 17: the Jacobians of the half-vector maps cancel against the BSDF's
denominators), the table integrals are int terms(m) (i.m) D(m) dw_m with

    terms(m) = (F(i.m) G(i, o_r) / mu,  (1 - F(i.m)) G(i, o_t) / mu)

(o_r = reflect(i, m) above the surface, o_t = refract(i, m) below it). :func:`terms` is that core,
times a Jacobian factor ``jac``; the methods reach it through two thin wrappers:

* :func:`integrand_phi` (adaptive): at (theta_m, phi_m), jac = (i.m) / cos(theta_m), for the
  measure D cos dw_m;
* :func:`m_terms` (D cos and VNDF methods): at a micro-normal vector, jac = 1 (x * 1.0 == x, so
  the fixed methods' values are those of a separate integrand to the last bit).

:func:`o_terms` is the same integral over the outgoing direction o (f |cos theta_o|, hemisphere
grid and cosine-sampled Monte Carlo).
"""

from __future__ import annotations

import math
from typing import Any

import warp as wp

from ..model.distribution import D, dcos_tan_of_v, lambda_cos
from ..model.fresnel import (
    FRESNEL_CONDUCTOR,
    FRESNEL_DIELECTRIC,
    FRESNEL_SCHLICK,
    fresnel,
    fresnel_dielectric,
    fresnel_dielectric_refract,
)
from ..model.shadowing import smith_G_over_cos_i_equal, smith_G_over_cos_i_to

MODES = {"reflect": 0, "dielectric": 1, "dfg": 2}
"""Integrand families: name -> the ``mode`` selector of the kernels."""

MODE_REFLECT = wp.constant(MODES["reflect"])  # channel 0: int F G D (i.m)/mu     (albedo)
MODE_DIELECTRIC = wp.constant(MODES["dielectric"])  # channels R, T (exact dielectric Fresnel, eta per texel)
MODE_DFG = wp.constant(MODES["dfg"])  # channels A, B: split-sum weights (1 - (1-c)^5), (1-c)^5, F = 1

PI64 = wp.constant(wp.float64(math.pi))
TWO_PI64 = wp.constant(wp.float64(2.0 * math.pi))
HALF_PI64 = wp.constant(wp.float64(0.5 * math.pi))
# The error reported for the alpha = 0 closed forms: their float64 rounding, 64 eps absolute
# (~1.4e-14; every value is in [0, 1]). Measured: the CPU and an H200 differ by up to 5 ulps of 1
# there; an mpmath check (tests/integrate/test_integrate_mirror.py) finds at most a few eps. The
# cancellations are small in absolute terms: g - c in the dielectric Fresnel cancels where
# F = O((eta - 1)^2), and 1 - F adds half an ulp.
MIRROR_ROUNDING = 64.0 * 2.0**-52
MIRROR_ROUNDING64 = wp.constant(wp.float64(MIRROR_ROUNDING))
vec24d = wp.types.vector(length=24, dtype=wp.float64)


def mode_id(mode: str) -> int:
    """The kernel selector of integrand family ``mode`` (ValueError naming the choices)."""
    try:
        return MODES[mode]
    except KeyError:
        raise ValueError(f"unknown mode {mode!r}; one of {', '.join(MODES)}") from None


@wp.struct
class TexelParams:
    """One texel: incidence, material, integrand family (what the integrand needs besides the
    integration variables)."""

    mode: wp.int32
    dist: wp.int32
    shadowing: wp.int32
    ftype: wp.int32
    fp0: wp.float64
    fp1: wp.float64
    mu: wp.float64
    sin_i: wp.float64
    alpha: wp.float64
    eta: wp.float64
    li: wp.float64  # mu * Lambda(mu)
    err_model: wp.int32  # adaptive only; 0: |K15 - G7|, 1: QUADPACK rescaling
    err_model_inner: wp.int32  # adaptive only: the inner phi level's error model
    err_safety: wp.float64  # adaptive only: err_model 2's safety factor
    err_power: wp.float64  # adaptive only: err_model 2's power of the decay ratio
    inner_first: wp.int32  # adaptive only: the inner two-stage rule's first estimate (0: off; 5, 3)
    first_share: wp.float64  # adaptive only: the share of an interval's tolerance the first stage may use
    first_safety: wp.float64  # adaptive only: the factor on the first stage's |G7 - I5| (make_texel: 1)
    inner_map: wp.int32  # adaptive only: the inner pieces' map
    second_safety: wp.float64  # adaptive only: the inner second stage's factor on |G7 - I9| (0: off)
    first_tail: wp.float64  # adaptive only: the inner first stage's factor on its tail floor (0: off)
    second_tail: wp.float64  # adaptive only: the inner second stage's factor on its tail floor (0: off)
    normal_map: wp.float64  # adaptive only: map phi = 0 where o_r = n is this close (Beckmann; 0: off)
    normal_split: wp.float64  # adaptive only: start the first inner piece in halves where o_r = n is this close (Beckmann; 0: off)
    bound_share: wp.float64  # adaptive only: share of the tolerance for D-tail mass bounds (< 0: no bounds)


@wp.func
def make_texel(mode: wp.int32, dist: wp.int32, shadowing: wp.int32, ftype: wp.int32, fp0: wp.float64,
               fp1: wp.float64, mu_in: wp.float64, alpha: wp.float64, eta: wp.float64):
    """The texel struct; mu is clamped to [0, 1] (a caller's mu = 1 + 1 ulp is normal incidence)."""
    zero = wp.float64(0.0)
    one = wp.float64(1.0)
    p = TexelParams()
    mu = wp.clamp(mu_in, zero, one)
    p.mode = mode
    p.dist = dist
    p.shadowing = shadowing
    p.ftype = ftype
    p.fp0 = fp0
    p.fp1 = fp1
    p.mu = mu
    p.sin_i = wp.sqrt(wp.max(zero, one - mu * mu))
    p.alpha = alpha
    p.eta = eta
    p.li = lambda_cos(mu, alpha, dist)
    p.first_safety = one
    return p


@wp.func
def mirror(p: TexelParams):
    """alpha = 0: D is a Dirac delta at n (mirror reflection / straight refraction, G = 1)."""
    one = wp.float64(1.0)
    if p.mode == MODE_DFG:
        w = one - p.mu
        w5 = w * w * w * w * w
        return wp.vec2d(one - w5, w5)
    if p.mode == MODE_DIELECTRIC:
        f = fresnel_dielectric(p.mu, p.eta)
        return wp.vec2d(f, one - f)
    return wp.vec2d(fresnel(p.mu, p.ftype, p.fp0, p.fp1), wp.float64(0.0))


@wp.func
def store(value: wp.array2d(dtype=wp.float64), error: wp.array2d(dtype=wp.float64), i: wp.int32,
          v: wp.vec2d, e: wp.vec2d):
    """Write one texel's (value, error) pair of channels."""
    value[i, 0] = v[0]
    value[i, 1] = v[1]
    error[i, 0] = e[0]
    error[i, 1] = e[1]


@wp.func
def begin_texel(tid: wp.int32, idx: wp.array(dtype=wp.int32), mu_a: wp.array(dtype=wp.float64),
                alpha_a: wp.array(dtype=wp.float64), eta_a: wp.array(dtype=wp.float64), mode: wp.int32,
                dist: wp.int32, shadowing: wp.int32, ftype: wp.int32, fp0: wp.float64, fp1: wp.float64,
                value: wp.array2d(dtype=wp.float64), error: wp.array2d(dtype=wp.float64)):
    """The preamble of every texel kernel (``tid`` = ``wp.tid()``): (texel index, its struct, done).

    done is True for alpha <= 0, whose mirror limit (a closed form; its error: the rounding
    bound ``MIRROR_ROUNDING``) has then been stored.
    """
    i = idx[tid]
    p = make_texel(mode, dist, shadowing, ftype, fp0, fp1, mu_a[i], alpha_a[i], eta_a[i])
    zero = wp.float64(0.0)
    done = False
    if p.alpha <= zero:
        # a Dirac delta: the closed form, nothing to integrate
        store(value, error, i, mirror(p), wp.vec2d(MIRROR_ROUNDING64, MIRROR_ROUNDING64))
        done = True
    return i, p, done


@wp.func
def terms(p: TexelParams, c: wp.float64, cm: wp.float64, jac: wp.float64):
    """(F G / mu, (1 - F) G_t / mu) times ``jac`` at a micro-normal with i.m = c > 0, cos theta_m = cm.

    Channel 0 is reflection (E, R, or A), channel 1 transmission T (dielectric) or B (dfg); every
    chi+ condition on the outgoing directions is applied here, the caller checks c > 0.
    """
    zero = wp.float64(0.0)
    one = wp.float64(1.0)
    out = wp.vec2d(zero, zero)
    f_d = zero
    d = zero
    refracts = False
    if p.mode == MODE_DIELECTRIC:
        # one Fresnel for both channels, sharing its root and division with the refraction
        f_d, d, refracts = fresnel_dielectric_refract(c, p.eta)
    zo = wp.float64(2.0) * c * cm - p.mu
    if zo > zero:
        g = smith_G_over_cos_i_to(p.mu, p.li, zo, p.alpha, p.dist, p.shadowing) * jac
        if p.mode == MODE_DFG:
            w = one - c
            w5 = w * w * w * w * w
            out = wp.vec2d(g * (one - w5), g * w5)
        elif p.mode == MODE_DIELECTRIC:
            out = wp.vec2d(f_d * g, zero)
        else:
            out = wp.vec2d(fresnel(c, p.ftype, p.fp0, p.fp1) * g, zero)
    if refracts:
        # not totally reflected: o_t = (d / eta) m - i / eta, d = eta (c / eta - sqrt(k2)) in a
        # rationalized form whose sign is exact near eta = 1 (it is 0 at eta = 1)
        # (times 1 / eta: one division per texel where the nodes' code is unrolled, not one each)
        zt = (d * cm - p.mu) * (wp.float64(1.0) / p.eta)
        g = zero
        if zt < zero:
            g = smith_G_over_cos_i_to(p.mu, p.li, -zt, p.alpha, p.dist, p.shadowing) * jac
        elif d == zero and p.mu == zero:
            # eta = 1 at grazing: o_t = -i exactly; G / mu by its mu -> 0+ limit
            g = smith_G_over_cos_i_equal(p.mu, p.li, p.shadowing) * jac
        out = wp.vec2d(out[0], (one - f_d) * g)
    return out


# Taylor coefficients (-1)^k / (2k)! and (-1)^k / (2k + 1)!, k = 1 .. 8: on |y| <= pi/4 the first
# left-out terms are below 2.1e-18 (cos) and 8.1e-20 (sin)
_COS_C = [(-1.0) ** k / math.factorial(2 * k) for k in range(1, 9)]
_SIN_C = [(-1.0) ** k / math.factorial(2 * k + 1) for k in range(1, 9)]
_vec8d = wp.types.vector(length=8, dtype=wp.float64)
COS_C = wp.constant(_vec8d(*_COS_C))
SIN_C = wp.constant(_vec8d(*_SIN_C))
PIO2_HI = wp.constant(wp.float64(1.5707963267948966))  # pi/2 = PIO2_HI + PIO2_LO to ~1e-33
PIO2_LO = wp.constant(wp.float64(6.123233995736766e-17))
PI_HI = wp.constant(wp.float64(3.141592653589793))  # pi = PI_HI + PI_LO
PI_LO = wp.constant(wp.float64(1.2246467991473532e-16))


@wp.func
def _estrin8(z: wp.float64, c: Any):
    # c[0] + c[1] z + ... + c[7] z^7 by Estrin's scheme: a dependency chain of 3 multiply-adds
    # and two squarings instead of Horner's 7
    z2 = z * z
    z4 = z2 * z2
    lo = (c[0] + c[1] * z) + (c[2] + c[3] * z) * z2
    hi = (c[4] + c[5] * z) + (c[6] + c[7] * z) * z2
    return lo + hi * z4


@wp.func
def cos_0_pi(x: wp.float64):
    """cos(x) for x in [-pi/4, 5 pi/4], within 1 ulp of libm's cos (tested; ~1.1e-16 absolute).

    The inner phi nodes of the adaptive method all lie in [0, pi]: the general libm cos (its
    range reduction for any x) was ~17% of the kernel's time (issue 14, fifth round). Reduced
    to |y| <= pi/4 by cos x = sin(pi/2 - x) and -cos(pi - x), with pi/2 and pi in two parts
    (pi/2 - x and pi - x are exact in float64 where they are used: Sterbenz), then Taylor
    polynomials of degree 16 / 17, evaluated by Estrin's scheme (issue 14, ninth round: a
    shorter chain of dependent operations than Horner's; a branch-free form that evaluates both
    polynomials and selects measured slower).
    """
    one = wp.float64(1.0)
    if x <= wp.float64(0.7853981633974483):
        return one + x * x * _estrin8(x * x, COS_C)
    if x <= wp.float64(2.356194490192345):
        y = (PIO2_HI - x) + PIO2_LO
        return y + y * (y * y * _estrin8(y * y, SIN_C))
    y = (PI_HI - x) + PI_LO
    return -(one + y * y * _estrin8(y * y, COS_C))


# asin(y) = y + y z R(z), z = y^2: R on z in [0, 1/4] by a polynomial of degree 11 (the Chebyshev
# interpolant of R at 12 nodes, from mpmath at 50 digits; |x| <= 1/2 uses it at z = x^2, the
# rest at z = (1 - |x|) / 2 through acos(x) = 2 asin(sqrt(z)))
_ASIN_R = [0.1666666666666665, 0.07500000000020764, 0.044642857103423646, 0.03038194736709848,
           0.02237204763174451, 0.017355259955786323, 0.013929652902326633, 0.011875494382636922,
           0.0078029494773533175, 0.01603551434914882, -0.010749050339697808, 0.028169218060881414]
ASIN_R_LO = wp.constant(_vec8d(*_ASIN_R[:8]))
ASIN_R_HI = wp.constant(wp.types.vector(length=4, dtype=wp.float64)(*_ASIN_R[8:]))


@wp.func
def acos_poly(x: wp.float64):
    """acos(x) for x in [-1, 1], within 1 ulp of the exact value (tested against mpmath).

    The inner level's cuts need one acos each, per outer node: libm's acos was ~7% of a
    loose-tolerance table's time (issue 14, tenth round). fdlibm's reduction (|x| <= 1/2:
    pi/2 - asin(x); beyond: 2 asin(sqrt((1 - |x|) / 2)), and pi minus that for x < 0) with one
    polynomial for (asin(y) - y) / y^3 in z = y^2 <= 1/4 (``_ASIN_R``), by Estrin's scheme.
    Outside [-1, 1] (and nan) the value is nan, as acos's.
    """
    one = wp.float64(1.0)
    half = wp.float64(0.5)
    ax = wp.abs(x)
    if ax > one or x != x:
        # outside acos's domain (nan stays nan)
        return wp.float64(wp.nan)
    z = ax * ax
    y = ax
    big = ax > half
    if big:
        z = (one - ax) * half
        y = wp.sqrt(z)
    z2 = z * z
    z4 = z2 * z2
    hi = (ASIN_R_HI[0] + ASIN_R_HI[1] * z) + (ASIN_R_HI[2] + ASIN_R_HI[3] * z) * z2
    r = y + y * (z * (_estrin8(z, ASIN_R_LO) + hi * (z4 * z4)))
    pos = (PIO2_HI - r) + PIO2_LO  # acos(|x|)
    if big:
        pos = r + r
    if x < wp.float64(0.0):
        return (PI_HI - pos) + PI_LO
    return pos


@wp.func
def integrand_cos(p: TexelParams, cm: wp.float64, sm: wp.float64, tm: wp.float64, cp: wp.float64):
    """:func:`integrand_phi` at the azimuth whose cosine is ``cp`` (the inner rule forms the
    cosines of its nodes first, apart from the integrand's own chain of operations)."""
    c = p.sin_i * sm * cp + p.mu * cm
    if c > wp.float64(0.0):
        # (i.m) / cos(theta_m), written without the division
        return terms(p, c, cm, p.sin_i * tm * cp + p.mu)
    # chi+(i.m): i sees the back of the micro-facet; or c is nan, at a node rounded onto v = 1
    # (tan theta_m = inf, sin = inf * 0), where D cos has no mass: 0, as the forms before the
    # fused Fresnel gave there through their nan comparisons
    return wp.vec2d(wp.float64(0.0), wp.float64(0.0))


@wp.func
def integrand_phi(p: TexelParams, cm: wp.float64, sm: wp.float64, tm: wp.float64, phi: wp.float64):
    """F G D (i.m) / (mu D cos theta_m) for reflection (x) and transmission (y) at (theta_m, phi).

    ``cm``, ``sm``, ``tm`` are cos, sin and tan of theta_m; the measure is D cos dw_m.
    """
    return integrand_cos(p, cm, sm, tm, cos_0_pi(phi))


@wp.func
def _tail_tan(p: TexelParams, ta: wp.float64, ma: wp.float64):
    """int_{t_a}^inf t (-dm) <= t_a m_a + int_{t_a}^inf min(m_a, alpha^2 / t^2) dt (m_a > 0)."""
    # beyond t* = alpha / sqrt(m_a) the bound alpha^2 / t^2 is the smaller one
    ts = wp.max(ta, p.alpha / wp.sqrt(ma))
    return ta * ma + ma * (ts - ta) + p.alpha * p.alpha / ts


@wp.func
def mass_bound(p: TexelParams, va: wp.float64, vb: wp.float64):
    """A rigorous upper bound of int_va^vb 2 (1 - v) int_0^pi g dphi dv, each channel, for the
    integrand g of :func:`integrand_phi` (the adaptive method's outer integrand); -1 where none
    is known (alpha <= 0, mu + mu Lambda(mu) = 0, a Fresnel outside the catalog's domain).

    In u = 1 - (1 - v)^2 (the D cos CDF, du = 2 (1 - v) dv) the piece's mass is
    (1 - va)^2 - (1 - vb)^2. Each channel of g is F G (i.m) / (mu cos theta_m) with F (or 1 - F,
    or a split-sum weight) <= 1, G / mu <= G1(i) / mu = 1 / (mu + mu Lambda(mu)) (both Smith
    forms, also for the transmitted G) and (i.m) / cos theta_m <= mu + sin(theta_i) tan(theta_m),
    so the integral is at most pi (mu mass + sin(theta_i) int tan(theta_m) du) / (mu + mu Lambda).
    tan is increasing in v: int tan du <= mass tan(theta_b) (vb < 1). At the horizon (vb = 1,
    dielectric mode, where tan -> inf) the tail form instead: with m(t) = 1 - u the D cos mass
    beyond tan = t, int_{t_a}^inf t (-dm) = t_a m(t_a) + int_{t_a}^inf m dt (by parts; t m -> 0),
    and m(t) <= min(m(t_a), alpha^2 / t^2): GGX m = alpha^2 / (alpha^2 + t^2), Beckmann
    m = exp(-t^2 / alpha^2) <= alpha^2 / t^2 (x e^-x < 1), checked for every registered
    distribution by tests/integrate/test_integrate_adaptive_bound.py; also split once at the
    mass m_w = (m_a t_a / (2 alpha))^2, tan <= t_w before it, the tail form after it (tight
    for Beckmann's fast tail). The smallest of these forms is used."""
    zero = wp.float64(0.0)
    one = wp.float64(1.0)
    den = p.mu + p.li
    if p.alpha <= zero or den <= zero or p.bound_share < zero:
        # a mirror, or G / mu unbounded: no bound
        return wp.float64(-1.0)
    if p.mode == MODE_REFLECT:
        # F <= 1 needs Schlick's f0 in [0, 1] and a conductor's eta, k >= 0 (the spec's domain)
        if p.ftype == FRESNEL_SCHLICK and (p.fp0 < zero or p.fp0 > one):
            return wp.float64(-1.0)
        if p.ftype == FRESNEL_CONDUCTOR and (p.fp0 < zero or p.fp1 < zero):
            return wp.float64(-1.0)
    wa = one - va
    wb = wp.max(zero, one - vb)
    ma = wa * wa
    mass = wp.max(zero, ma - wb * wb)
    tan_int = wp.float64(-1.0)
    if vb < one:
        tan_int = mass * dcos_tan_of_v(vb, p.alpha, p.dist)
    if va > zero and ma > zero:
        ta = dcos_tan_of_v(va, p.alpha, p.dist)
        if ta > zero:
            tail = _tail_tan(p, ta, ma)
            # or tan <= t_w up to the mass m_w = (m_a t_a / (2 alpha))^2 and the tail form beyond
            # (near the form's optimum for a fast tail such as Beckmann's)
            x = ma * ta / (wp.float64(2.0) * p.alpha)
            mw = x * x
            if mw < ma:
                tw = dcos_tan_of_v(one - wp.sqrt(mw), p.alpha, p.dist)
                if tw > ta and wp.isfinite(tw):
                    tail = wp.min(tail, (ma - mw) * tw + _tail_tan(p, tw, mw))
            if tan_int < zero or tail < tan_int:
                tan_int = tail
    if tan_int < zero or not wp.isfinite(tan_int):
        # vb = 1 from va = 0: no finite bound of this form
        return wp.float64(-1.0)
    # (1 + 1e-12): the rounding of the few operations above
    return PI64 * (p.mu * mass + p.sin_i * tan_int) / den * wp.float64(1.0 + 1.0e-12)


@wp.func
def m_terms(p: TexelParams, m: wp.vec3d):
    """:func:`terms` at the micro-normal m (jac = 1); zero when i or n sees the back of m.

    Only m.x and m.z are read (isotropic, w_i in the xz-plane). The table integrals are
    int m_terms (i.m) D(m) dw_m.
    """
    c = p.sin_i * m[0] + p.mu * m[2]
    if c <= wp.float64(0.0) or m[2] <= wp.float64(0.0):
        # i sees the back of the micro-facet
        return wp.vec2d(wp.float64(0.0), wp.float64(0.0))
    return terms(p, c, m[2], wp.float64(1.0))


@wp.func
def o_terms(p: TexelParams, o: wp.vec3d):
    """f |cos theta_o| at outgoing direction o: reflection (o.z > 0) in channel 0 (A and B
    for dfg), transmission (o.z < 0, dielectric only) in channel 1. G / mu form throughout."""
    zero = wp.float64(0.0)
    one = wp.float64(1.0)
    out = wp.vec2d(zero, zero)
    wi = wp.vec3d(p.sin_i, zero, p.mu)
    if o[2] > zero:
        h = wi + o
        hl = wp.length(h)
        if hl <= zero:
            # o = -i: no half-vector
            return out
        h = h / hl
        c = wp.dot(wi, h)
        if c <= zero:
            # chi+: back-facing micro-facet
            return out
        zo = o[2]
        g = smith_G_over_cos_i_to(p.mu, p.li, zo, p.alpha, p.dist, p.shadowing)
        v = g * D(h[2], p.alpha, p.dist) * wp.float64(0.25)
        if p.mode == MODE_DFG:
            w = one - c
            w5 = w * w * w * w * w
            return wp.vec2d(v * (one - w5), v * w5)
        if p.mode == MODE_DIELECTRIC:
            return wp.vec2d(v * fresnel_dielectric(c, p.eta), zero)
        return wp.vec2d(v * fresnel(c, p.ftype, p.fp0, p.fp1), zero)
    if o[2] < zero and p.mode == MODE_DIELECTRIC:
        h = -(wi + p.eta * o)
        hl = wp.length(h)
        if hl <= zero:
            # eta = 1 and o = -i: the delta of smooth transmission, zero measure here
            return out
        h = h / hl
        if h[2] < zero:
            h = -h
        ci = wp.dot(wi, h)
        co = wp.dot(o, h)
        if ci <= zero or co >= zero:
            # chi+: both directions must see the same side of the micro-facet
            return out
        den = ci + p.eta * co
        if den == zero:
            # half-vector singularity (eta = 1 limit)
            return out
        azo = -o[2]
        g = smith_G_over_cos_i_to(p.mu, p.li, azo, p.alpha, p.dist, p.shadowing)
        t = ci * (-co) * p.eta * p.eta * (one - fresnel_dielectric(ci, p.eta)) * g * D(h[2], p.alpha, p.dist)
        return wp.vec2d(zero, t / (den * den))
    return out


# the thresholds of the adaptive method's breakpoints (total internal reflection, transmission)


@wp.func
def phi_of_c(cb: wp.float64, p: TexelParams, cm: wp.float64, sm: wp.float64):
    """The phi in [0, pi] where i.m = sin_i sin(theta_m) cos(phi) + mu cos(theta_m) equals ``cb``."""
    x = (cb - p.mu * cm) / (p.sin_i * sm)
    return acos_poly(wp.clamp(x, wp.float64(-1.0), wp.float64(1.0)))


# a conductor Fresnel with k below this gets the dielectric's critical-angle cuts (at eta < 1) and
# knee cuts (eta just above 1): as k -> 0 it becomes the dielectric Fresnel, kink included, a
# transition ~k wide that no rule resolves (k = 0, eta 0.5: up to 70x under its error at 1e-8 and
# 1e5 evaluations per texel; k >= 1: smooth, honest and no dearer without cuts)
CONDUCTOR_KINK_K = wp.constant(wp.float64(1.0))


@wp.func
def tir_eta(p: TexelParams):
    """The relative IOR whose critical angle kinks the integrand (eta < 1), or 2 (none): the
    dielectric mode's eta, or a reflection's dielectric Fresnel eta (p0), or a conductor's eta
    (p0) when its k (p1) is below ``CONDUCTOR_KINK_K``."""
    if p.mode == MODE_DIELECTRIC and p.eta > wp.float64(0.0):
        return p.eta
    if p.mode == MODE_REFLECT and p.fp0 > wp.float64(0.0):
        if p.ftype == FRESNEL_DIELECTRIC or (p.ftype == FRESNEL_CONDUCTOR and p.fp1 < CONDUCTOR_KINK_K):
            return p.fp0
    return wp.float64(2.0)


# eta^2 - 1 below which the Fresnel knee gets cuts of its own (knee < 0.032, eta < 1.0005)
KNEE_MAX_K2 = wp.constant(wp.float64(1.0e-3))


@wp.func
def fresnel_knee(p: TexelParams):
    """i.m = sqrt(eta^2 - 1) for a dielectric Fresnel (:func:`tir_eta`'s eta) just above 1, or -1.

    Below it F rises from ~((eta - 1) / 2)^2 to 1 at grazing i.m: the eta > 1 image of the
    critical angle, a knee ~sqrt(eta^2 - 1) wide. Near eta = 1 it is narrower than any rule's
    nodes and sits in the v map's tail (a texel at eta = 1 + 1e-6, mu = 1, alpha = 2 was 17x
    dishonest at 5e-7 without the cuts); from eta^2 - 1 = ``KNEE_MAX_K2`` on, the rules resolve
    it (honest at 1 + 1e-4 .. 1.3 on a scan without the cuts, which cost 30-40% more evaluations
    there). Issue 14, ninth round's review."""
    eta = tir_eta(p)
    k2 = (eta - wp.float64(1.0)) * (eta + wp.float64(1.0))
    if k2 > wp.float64(0.0) and k2 < KNEE_MAX_K2:
        return wp.sqrt(k2)
    return wp.float64(-1.0)


@wp.func
def transmission_floor(p: TexelParams, cm: wp.float64):
    """Lowest i.m with transmission (eta < 1): the horizon root c_t if valid, else c_TIR."""
    e2 = wp.float64(1.0) - p.eta * p.eta
    if p.mu <= wp.float64(0.0):
        # grazing from inside: nothing is transmitted
        return wp.float64(2.0)
    c_t = p.mu / (wp.float64(2.0) * cm) + e2 * cm / (wp.float64(2.0) * p.mu)
    if c_t * cm >= p.mu:
        return c_t
    return wp.sqrt(e2)


@wp.func
def _t_gap(p: TexelParams, theta_i: wp.float64, theta: wp.float64, which: wp.int32):
    # c_max (which = 0) or c_min (which = 1) minus the transmission floor at theta_m = theta
    cm = wp.cos(theta)
    c = wp.cos(theta_i - theta)
    if which == 1:
        c = wp.cos(theta_i + theta)
    return c - transmission_floor(p, cm)


@wp.func
def transmission_breaks(p: TexelParams, theta_i: wp.float64, cands: vec24d, ncand: wp.int32):
    """Append theta_m where c_max or c_min crosses the transmission floor (at most 2 each), and
    where the floor itself switches from the horizon root c_t to c_TIR (a kink of the outer
    integrand: c_t cos theta_m = mu, i.e. cos theta_m = mu / sqrt(1 - eta^2))."""
    n = ncand
    steps = int(64)
    for which in range(2):
        found = int(0)
        ta = wp.float64(1.0e-9)
        ga = _t_gap(p, theta_i, ta, which)
        for k in range(steps):
            tb = HALF_PI64 * wp.float64(k + 1) / wp.float64(steps) - wp.float64(1.0e-9)
            gb = _t_gap(p, theta_i, tb, which)
            if (ga > wp.float64(0.0)) != (gb > wp.float64(0.0)) and found < 2 and n < 24:
                lo = ta
                hi = tb
                glo = ga
                for _it in range(60):
                    mid = wp.float64(0.5) * (lo + hi)
                    if mid <= lo or mid >= hi:
                        # lo and hi are adjacent doubles: no later step changes them
                        break
                    gm = _t_gap(p, theta_i, mid, which)
                    if (gm > wp.float64(0.0)) == (glo > wp.float64(0.0)):
                        lo = mid
                        glo = gm
                    else:
                        hi = mid
                cands[n] = wp.float64(0.5) * (lo + hi)
                n += 1
                found += 1
            ta = tb
            ga = gb
    # eta < 1 here (dielectric mode only), so e > 0; mu < e keeps the cosine below 1
    e = wp.sqrt(wp.max(wp.float64(1.0) - p.eta * p.eta, wp.float64(0.0)))
    if p.mu < e and n < 24:
        cands[n] = wp.acos(p.mu / e)
        n += 1
    return cands, n
