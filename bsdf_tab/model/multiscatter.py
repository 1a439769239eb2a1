"""Kulla-Conty multiple-scattering energy compensation (Kulla and Conty 2017, "Revisiting
Physically Based Shading at Imageworks", SIGGRAPH course).

The single-scattering microfacet BRDF with F = 1 reflects E(mu) <= 1 of the energy arriving at
mu = cos(theta_i) (the ``albedo`` table); the missing 1 - E(mu) is what multiple scattering
between micro-facets would add. The compensation lobe

    f_ms(mu_i, mu_o) = (1 - E(mu_i)) (1 - E(mu_o)) / (pi (1 - E_avg)),
    E_avg = 2 int_0^1 E(mu) mu dmu,

is diffuse-like, reciprocal, and integrates to int f_ms cos(theta_o) dw_o = 1 - E(mu_i), so
E + f_ms restores a white furnace (energy 1). For a coloured conductor the lobe is scaled by

    F_ms = F_avg^2 E_avg / (1 - F_avg (1 - E_avg)),    F_avg = 2 int_0^1 F(mu) mu dmu

(the average energy that survives the k-th bounce is F_avg^k, summed as a geometric series).
Evaluate F_ms per colour channel (per wavelength's eta, k).

All functions are ``@wp.func``, generic over wp.float32 / wp.float64. E and E_avg come from the
``albedo`` / ``albedo_avg`` tables or the ``kulla_conty`` table, whose channel
C = (1 - E) / sqrt(pi (1 - E_avg)) gives f_ms(mu_i, mu_o) = C(mu_i) C(mu_o) directly.
:func:`lerp_grid_1d` / :func:`lerp_grid_2d` interpolate such tables on their index grid.
"""

from typing import Any

import numpy as np
import warp as wp

from .fresnel import FRESNEL_CONDUCTOR, FRESNEL_DIELECTRIC, FRESNEL_ONE, FRESNEL_SCHLICK, fresnel

_vec16d = wp.types.vector(length=16, dtype=wp.float64)
# Gauss-Legendre 16 on [0, 1]: nodes and weights
_gl_x, _gl_w = np.polynomial.legendre.leggauss(16)
_GL16_X = wp.constant(_vec16d(*(0.5 * (_gl_x + 1.0)).tolist()))
_GL16_W = wp.constant(_vec16d(*(0.5 * _gl_w).tolist()))
_INV_PI = 0.31830988618379067


@wp.func
def kc_f_ms(e_i: Any, e_o: Any, e_avg: Any):
    """The compensation lobe (1 - E(mu_i)) (1 - E(mu_o)) / (pi (1 - E_avg)) (F = 1)."""
    zero = type(e_avg)(0.0)
    one = type(e_avg)(1.0)
    den = one - e_avg
    if den <= zero:
        # E_avg = 1 (alpha = 0): nothing is lost, no compensation
        return zero
    return (one - e_i) * (one - e_o) * type(e_avg)(_INV_PI) / den


@wp.func
def kc_F_ms(f_avg: Any, e_avg: Any):
    """Fresnel factor of the lobe: F_avg^2 E_avg / (1 - F_avg (1 - E_avg))."""
    one = type(e_avg)(1.0)
    den = one - f_avg * (one - e_avg)
    if den <= type(e_avg)(0.0):
        # F_avg = 1 and E_avg = 0: a degenerate material; the series limit is 1
        return one
    return f_avg * f_avg * e_avg / den


@wp.func
def kc_lobe(e_i: Any, e_o: Any, e_avg: Any, f_avg: Any):
    """The coloured compensation lobe F_ms f_ms (one colour channel)."""
    return kc_F_ms(f_avg, e_avg) * kc_f_ms(e_i, e_o, e_avg)


@wp.func
def kc_C(e: Any, e_avg: Any):
    """The per-direction factor C(mu) = (1 - E(mu)) / sqrt(pi (1 - E_avg)); f_ms = C_i C_o."""
    zero = type(e_avg)(0.0)
    one = type(e_avg)(1.0)
    den = one - e_avg
    if den <= zero:
        # alpha = 0: no compensation
        return zero
    return (one - e) / wp.sqrt(type(e_avg)(wp.pi) * den)


@wp.func
def _avg_piece(a: Any, b: Any, ftype: wp.int32, p0: Any, p1: Any):
    """2 int_a^b F(mu) mu dmu with mu = a + (b - a) t^2 (smooths sqrt behaviour at mu = a)."""
    acc = type(p0)(0.0)
    w = b - a
    for j in range(16):
        t = type(p0)(_GL16_X[j])
        mu = a + w * t * t
        acc += type(p0)(_GL16_W[j]) * fresnel(mu, ftype, p0, p1) * mu * type(p0)(2.0) * w * t
    return type(p0)(2.0) * acc


@wp.func
def fresnel_avg(ftype: wp.int32, p0: Any, p1: Any):
    """F_avg = 2 int_0^1 F(mu) mu dmu of a Fresnel type (same parameters as :func:`fresnel`).

    Closed forms for ``one`` (1) and ``schlick`` ((20 f0 + 1) / 21); Gauss-Legendre 16 after
    mu = a + (b - a) t^2 for conductors and dielectrics, split at the critical angle
    mu_c = sqrt(1 - eta^2) of a dielectric with eta < 1 (F = 1 below it: mu_c^2 exactly).
    Relative accuracy ~1e-7 or better (float64).
    """
    zero = type(p0)(0.0)
    one = type(p0)(1.0)
    if ftype == FRESNEL_ONE:
        return one
    if ftype == FRESNEL_SCHLICK:
        return (type(p0)(20.0) * p0 + one) / type(p0)(21.0)
    if ftype == FRESNEL_DIELECTRIC and p0 < one:
        mu_c = wp.sqrt(one - p0 * p0)
        return mu_c * mu_c + _avg_piece(mu_c, one, ftype, p0, p1)
    return _avg_piece(zero, one, ftype, p0, p1)


@wp.func
def lerp_grid_1d(values: wp.array(dtype=Any), t: Any):
    """Linear interpolation of ``values`` at the continuous index t (clamped to the grid)."""
    n = values.shape[0]
    if n < 2:
        # a single node: constant
        return values[0]
    tc = wp.clamp(t, type(t)(0.0), type(t)(n - 1))
    i = wp.min(int(tc), n - 2)
    f = tc - type(t)(i)
    return values[i] * (type(t)(1.0) - f) + values[i + 1] * f


@wp.func
def lerp_grid_2d(values: wp.array2d(dtype=Any), t0: Any, t1: Any):
    """Bilinear interpolation of ``values[i0, i1]`` at continuous indices (t0, t1), clamped."""
    n0 = values.shape[0]
    n1 = values.shape[1]
    one = type(t0)(1.0)
    a = wp.clamp(t0, type(t0)(0.0), type(t0)(n0 - 1))
    b = wp.clamp(t1, type(t1)(0.0), type(t1)(n1 - 1))
    i = wp.max(0, wp.min(int(a), n0 - 2))
    j = wp.max(0, wp.min(int(b), n1 - 2))
    fa = a - type(t0)(i)
    fb = b - type(t1)(j)
    if n0 < 2:
        i = 0
        fa = type(t0)(0.0)
    if n1 < 2:
        j = 0
        fb = type(t1)(0.0)
    i1 = wp.min(i + 1, n0 - 1)
    j1 = wp.min(j + 1, n1 - 1)
    return (values[i, j] * (one - fa) + values[i1, j] * fa) * (one - fb) + (
        values[i, j1] * (one - fa) + values[i1, j1] * fa
    ) * fb


__all__ = [
    "kc_f_ms",
    "kc_F_ms",
    "kc_lobe",
    "kc_C",
    "fresnel_avg",
    "lerp_grid_1d",
    "lerp_grid_2d",
]
