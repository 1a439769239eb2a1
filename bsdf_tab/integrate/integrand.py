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

import warp as wp

from ..model.distribution import D, lambda_cos
from ..model.fresnel import fresnel, fresnel_dielectric
from ..model.frame import refract_k2
from ..model.shadowing import smith_G_over_cos_i_equal, smith_G_over_cos_i_from_lambda

MODES = {"reflect": 0, "dielectric": 1, "dfg": 2}
"""Integrand families: name -> the ``mode`` selector of the kernels."""

MODE_REFLECT = wp.constant(MODES["reflect"])  # channel 0: int F G D (i.m)/mu     (albedo)
MODE_DIELECTRIC = wp.constant(MODES["dielectric"])  # channels R, T (exact dielectric Fresnel, eta per texel)
MODE_DFG = wp.constant(MODES["dfg"])  # channels A, B: split-sum weights (1 - (1-c)^5), (1-c)^5, F = 1

PI64 = wp.constant(wp.float64(math.pi))
TWO_PI64 = wp.constant(wp.float64(2.0 * math.pi))


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

    done is True for alpha <= 0, whose exact mirror limit (error 0) has then been stored.
    """
    i = idx[tid]
    p = make_texel(mode, dist, shadowing, ftype, fp0, fp1, mu_a[i], alpha_a[i], eta_a[i])
    zero = wp.float64(0.0)
    done = False
    if p.alpha <= zero:
        # a Dirac delta: the closed form, nothing to integrate
        store(value, error, i, mirror(p), wp.vec2d(zero, zero))
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
    zo = wp.float64(2.0) * c * cm - p.mu
    if zo > zero:
        lo = lambda_cos(zo, p.alpha, p.dist)
        g = smith_G_over_cos_i_from_lambda(p.mu, p.li, zo, lo, p.shadowing) * jac
        if p.mode == MODE_DFG:
            w = one - c
            w5 = w * w * w * w * w
            out = wp.vec2d(g * (one - w5), g * w5)
        elif p.mode == MODE_DIELECTRIC:
            out = wp.vec2d(fresnel_dielectric(c, p.eta) * g, zero)
        else:
            out = wp.vec2d(fresnel(c, p.ftype, p.fp0, p.fp1) * g, zero)
    if p.mode == MODE_DIELECTRIC:
        k2 = refract_k2(c, p.eta)
        if k2 > zero:
            # not totally reflected: o_t = (c/eta - sqrt(k2)) m - i/eta, with c/eta - sqrt(k2)
            # rationalized so that its sign is exact near eta = 1 (it is 0 at eta = 1)
            d = (one - p.eta) * (one + p.eta) / (p.eta * p.eta) / (c / p.eta + wp.sqrt(k2))
            zt = d * cm - p.mu / p.eta
            g = zero
            if zt < zero:
                azt = -zt
                lt = lambda_cos(azt, p.alpha, p.dist)
                g = smith_G_over_cos_i_from_lambda(p.mu, p.li, azt, lt, p.shadowing) * jac
            elif d == zero and p.mu == zero:
                # eta = 1 at grazing: o_t = -i exactly; G / mu by its mu -> 0+ limit
                g = smith_G_over_cos_i_equal(p.mu, p.li, p.shadowing) * jac
            out = wp.vec2d(out[0], (one - fresnel_dielectric(c, p.eta)) * g)
    return out


@wp.func
def integrand_phi(p: TexelParams, cm: wp.float64, sm: wp.float64, tm: wp.float64, phi: wp.float64):
    """F G D (i.m) / (mu D cos theta_m) for reflection (x) and transmission (y) at (theta_m, phi).

    ``cm``, ``sm``, ``tm`` are cos, sin and tan of theta_m; the measure is D cos dw_m.
    """
    cp = wp.cos(phi)
    c = p.sin_i * sm * cp + p.mu * cm
    if c <= wp.float64(0.0):
        # chi+(i.m): i sees the back of the micro-facet
        return wp.vec2d(wp.float64(0.0), wp.float64(0.0))
    # (i.m) / cos(theta_m), written without the division
    return terms(p, c, cm, p.sin_i * tm * cp + p.mu)


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
        g = smith_G_over_cos_i_from_lambda(p.mu, p.li, zo, lambda_cos(zo, p.alpha, p.dist), p.shadowing)
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
        g = smith_G_over_cos_i_from_lambda(p.mu, p.li, azo, lambda_cos(azo, p.alpha, p.dist), p.shadowing)
        t = ci * (-co) * p.eta * p.eta * (one - fresnel_dielectric(ci, p.eta)) * g * D(h[2], p.alpha, p.dist)
        return wp.vec2d(zero, t / (den * den))
    return out
