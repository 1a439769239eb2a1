"""Fresnel reflectance, unpolarized.

``FRESNEL_ONE`` (F = 1), ``FRESNEL_SCHLICK`` (f0 + (1 - f0)(1 - c)^5, Schlick 1994),
``FRESNEL_DIELECTRIC`` (exact, Walter et al. 2007 eq. 22, total internal reflection gives 1),
``FRESNEL_CONDUCTOR`` (exact for a complex IOR eta + i k, e.g. Born and Wolf; as in pbrt).
The generic :func:`fresnel` takes two parameters p0, p1: (f0, -) for Schlick, (eta, -) for
dielectric, (eta, k) for conductor.
"""

from typing import Any

import warp as wp

FRESNELS = {"one": 0, "schlick": 1, "dielectric": 2, "conductor": 3}
"""name (the spec's ``fresnel.type``) -> integer id, the ``ftype`` selector of :func:`fresnel`."""

FRESNEL_ONE = wp.constant(FRESNELS["one"])
FRESNEL_SCHLICK = wp.constant(FRESNELS["schlick"])
FRESNEL_DIELECTRIC = wp.constant(FRESNELS["dielectric"])
FRESNEL_CONDUCTOR = wp.constant(FRESNELS["conductor"])


@wp.func
def fresnel_schlick(cos_i: Any, f0: Any):
    c = wp.min(wp.abs(cos_i), type(f0)(1.0))
    m = type(f0)(1.0) - c
    m2 = m * m
    return f0 + (type(f0)(1.0) - f0) * m2 * m2 * m


@wp.func
def fresnel_dielectric(cos_i: Any, eta: Any):
    """Exact unpolarized Fresnel for relative IOR ``eta`` = eta_t / eta_i (Walter eq. 22)."""
    zero = type(eta)(0.0)
    one = type(eta)(1.0)
    if eta == one:
        # no interface: nothing is reflected, also at grazing where g = c = 0
        return zero
    c = wp.min(wp.abs(cos_i), one)
    g2 = (eta - one) * (eta + one) + c * c  # no cancellation near eta = 1
    if g2 <= zero:
        # total internal reflection (g2 = 0 is the critical angle, where F = 1 too)
        return one
    g = wp.sqrt(g2)
    a = (g - c) / (g + c)
    num = c * (g + c) - one
    den = c * (g - c) + one
    # den >= 1 - c^2 >= 0, and den = 0 needs c = 1 and g = 0, excluded above
    b = num / den
    return type(eta)(0.5) * a * a * (one + b * b)


@wp.func
def fresnel_dielectric_refract(cos_i: Any, eta: Any):
    """(F, d, refracts): the exact dielectric Fresnel and the refraction through the same facet.

    ``cos_i`` = i.m > 0, ``eta`` = eta_t / eta_i. With c = min(cos_i, 1), e = (eta - 1)(eta + 1)
    and g = sqrt(e + c^2) (Walter et al. 2007 eq. 22) the division q = 1 / (g + c) serves
    both (issue 14), and b's own division does not wait for it:

    * F = a^2 (1 + b^2) / 2 with a = (g - c) / (g + c) = e q^2 and b = (c (g + c) - 1) / (c e q + 1)
      = (c (g + c) - 1)(g + c) / (g + c eta^2):
      :func:`fresnel_dielectric`'s value without its cancellation in g - c near eta = 1;
    * the refracted direction o_t = d' m - i / eta (Walter eq. 40) has
      d' = c / eta - sqrt(k2) = -e q / eta (sqrt(k2) = g / eta); returned as d = -e q = eta d'.

    ``refracts`` is False under total internal reflection (g^2 <= 0: F = 1, d = 0).
    """
    zero = type(eta)(0.0)
    one = type(eta)(1.0)
    c = wp.min(wp.abs(cos_i), one)
    e = (eta - one) * (eta + one)  # no cancellation near eta = 1
    if e == zero:
        # no interface: nothing reflected, o_t = -i (none at c = 0, as refract_k2 = 0 there)
        return zero, zero, c > zero
    g2 = e + c * c
    if g2 <= zero:
        # total internal reflection (g2 = 0 is the critical angle, where F = 1 too)
        return one, zero, False
    g = wp.sqrt(g2)
    # g + c > 0: g2 > 0 here
    q = one / (g + c)
    a = e * q * q
    # b's denominator c e q + 1 = c (g - c) + 1 times g + c is g + c eta^2 (1 + e = eta^2): a sum
    # of positive terms, so b = (c (g + c) - 1)(g + c) / (g + c eta^2) divides apart from q (the
    # two divisions run side by side instead of one after the other; issue 14, ninth round)
    b = (c * (g + c) - one) * (g + c) / (g + c * (eta * eta))
    return type(eta)(0.5) * a * a * (one + b * b), -e * q, True


@wp.func
def fresnel_conductor(cos_i: Any, eta: Any, k: Any):
    """Exact unpolarized Fresnel for a conductor of complex relative IOR eta + i k."""
    zero = type(eta)(0.0)
    one = type(eta)(1.0)
    c = wp.min(wp.abs(cos_i), one)
    c2 = c * c
    s2 = one - c2
    t0 = eta * eta - k * k - s2
    a2b2 = wp.sqrt(t0 * t0 + type(eta)(4.0) * eta * eta * k * k)
    a = wp.sqrt(wp.max(zero, type(eta)(0.5) * (a2b2 + t0)))
    rs_num = a2b2 + c2 - type(eta)(2.0) * a * c
    rs_den = a2b2 + c2 + type(eta)(2.0) * a * c
    if rs_den <= zero:
        # eta = k = 0 at grazing: a degenerate conductor reflects everything
        return one
    rs = rs_num / rs_den
    t1 = c2 * a2b2 + s2 * s2
    t2 = type(eta)(2.0) * a * c * s2
    rp_den = t1 + t2
    rp = rs
    if rp_den > zero:
        rp = rs * (t1 - t2) / rp_den
    return type(eta)(0.5) * (rs + rp)


@wp.func
def fresnel(cos_i: Any, ftype: wp.int32, p0: Any, p1: Any):
    """Fresnel of type ``ftype`` at incidence cosine ``cos_i`` (see module docstring)."""
    if ftype == FRESNEL_SCHLICK:
        return fresnel_schlick(cos_i, p0)
    if ftype == FRESNEL_DIELECTRIC:
        return fresnel_dielectric(cos_i, p0)
    if ftype == FRESNEL_CONDUCTOR:
        return fresnel_conductor(cos_i, p0, p1)
    return type(p0)(1.0)
