"""Shading-frame helpers (macro normal n = +z); names follow the math (pbrt-v4 style)."""

from typing import Any

import warp as wp


@wp.func
def cos_theta(w: Any):
    return w[2]


@wp.func
def sin2_theta(w: Any):
    # clamp: 1 - z^2 can round below zero for |z| = 1
    return wp.max(type(w[2])(0.0), type(w[2])(1.0) - w[2] * w[2])


@wp.func
def tan2_theta(w: Any):
    c2 = w[2] * w[2]
    if c2 <= type(c2)(0.0):
        # grazing direction: tan^2 is infinite
        return type(c2)(wp.inf)
    return sin2_theta(w) / c2


@wp.func
def reflect(w: Any, m: Any):
    """Mirror ``w`` about the micro-normal ``m``: 2 (w.m) m - w."""
    return type(w[0])(2.0) * wp.dot(w, m) * m - w


@wp.func
def refract_k2(c: Any, eta: Any):
    """cos^2 of the refracted angle, 1 - (1 - c^2) / eta^2, as (c^2 + (eta - 1)(eta + 1)) / eta^2.

    Written without the cancellation of ``1 - (1 - c^2)``: at eta = 1 it is c^2 exactly, also for
    grazing c < 1e-8 where the plain form rounds to 0 and loses the transmission.
    """
    return (c * c + (eta - type(eta)(1.0)) * (eta + type(eta)(1.0))) / (eta * eta)


@wp.func
def refract(w: Any, m: Any, eta: Any):
    """Refract ``w`` through the micro-normal ``m`` (Walter eq. 40).

    ``eta`` = eta_o / eta_i, the IOR on the far side over the IOR on the side of ``w``
    (``m`` on the side of ``w``: w.m > 0). Returns (ok, w_t); ok is False under total
    internal reflection, and w_t is then zero.
    """
    one = type(eta)(1.0)
    c = wp.dot(w, m)
    k2 = refract_k2(c, eta)
    if k2 < type(eta)(0.0):
        # total internal reflection: no refracted direction
        return False, w * type(eta)(0.0)
    wt = (c / eta - wp.sqrt(k2)) * m - w / eta
    return True, wt


@wp.func
def expm1_(x: Any):
    """exp(x) - 1 without cancellation for small |x| (Warp has no expm1)."""
    if wp.abs(x) < type(x)(1.0e-5):
        return x + type(x)(0.5) * x * x
    return wp.exp(x) - type(x)(1.0)


@wp.func
def log1p_(x: Any):
    """log(1 + x) accurate for small |x| (Kahan's trick; Warp has no log1p)."""
    u = type(x)(1.0) + x
    if u == type(x)(1.0):
        return x
    return wp.log(u) * x / (u - type(x)(1.0))
