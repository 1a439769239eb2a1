"""Microfacet BRDF (Walter et al. 2007 eq. 20) and BTDF (eq. 21) evaluation."""

from typing import Any

import warp as wp

from .distribution import D
from .fresnel import fresnel, fresnel_dielectric
from .shadowing import smith_G


@wp.func
def brdf(
    wi: Any, wo: Any, alpha: Any, dist: wp.int32, shadowing: wp.int32, ftype: wp.int32, p0: Any, p1: Any
):
    """f_r(i, o) = F(i.h) G(i, o) D(h) / (4 |i.n| |o.n|), h = normalize(i + o); 0 below the surface."""
    zero = type(alpha)(0.0)
    zi = wi[2]
    zo = wo[2]
    if zi <= zero or zo <= zero:
        # reflection needs both directions above the surface (grazing has zero measure)
        return zero
    h = wi + wo
    hl = wp.length(h)
    if hl <= zero:
        # i = -o cannot happen with both above; guard the normalization anyway
        return zero
    h = h / hl
    c = wp.dot(wi, h)
    if c <= zero:
        # chi+: back-facing micro-facet
        return zero
    g = smith_G(zi, zo, alpha, dist, shadowing)
    return fresnel(c, ftype, p0, p1) * g * D(h[2], alpha, dist) / (type(alpha)(4.0) * zi * zo)


@wp.func
def btdf(wi: Any, wo: Any, alpha: Any, dist: wp.int32, shadowing: wp.int32, eta: Any):
    """f_t(i, o) = |i.h||o.h| / (|i.n||o.n|) eta^2 (1 - F) G D / ((i.h) + eta (o.h))^2.

    ``eta`` = eta_o / eta_i (IOR below over IOR above, eta_i = 1 here);
    h = -normalize(i + eta o) oriented to +n. Zero unless wi is above and wo below the surface.
    At eta = 1 the BTDF is a Dirac delta in o = -i and this returns 0 elsewhere.
    """
    zero = type(alpha)(0.0)
    zi = wi[2]
    zo = wo[2]
    if zi <= zero or zo >= zero:
        # transmission needs wi above and wo below
        return zero
    h = -(wi + eta * wo)
    hl = wp.length(h)
    if hl <= zero:
        # eta = 1 and o = -i: the half-vector is undefined (delta transmission)
        return zero
    h = h / hl
    if h[2] < zero:
        h = -h
    ci = wp.dot(wi, h)
    co = wp.dot(wo, h)
    if ci <= zero or co >= zero:
        # chi+: both directions must see the same side of the micro-facet, on opposite sides
        return zero
    den = ci + eta * co
    if den == zero:
        # half-vector singularity (eta = 1 limit)
        return zero
    g = smith_G(zi, zo, alpha, dist, shadowing)
    f = fresnel_dielectric(ci, eta)
    return (ci * (-co)) / (zi * (-zo)) * eta * eta * (type(alpha)(1.0) - f) * g * D(h[2], alpha, dist) / (den * den)
