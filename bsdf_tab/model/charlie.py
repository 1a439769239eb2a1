"""Charlie sheen: the distribution, its sampling, and three shadowing / visibility choices.

Estevez and Kulla 2017, "Production Friendly Microfacet Sheen BRDF" (Sony Pictures
Imageworks): an inverted-Gaussian-like distribution of fibres whose normals lie near the
surface plane,

    D(m) = (2 + 1/alpha) sin(theta_m)^(1/alpha) / (2 pi),    int D(m) cos(theta_m) dw_m = 1,

with ``alpha`` the sheen alpha (glTF ``KHR_materials_sheen`` and Filament: alpha =
sheenRoughness^2). alpha is clamped below at :data:`CHARLIE_ALPHA_MIN` (a sheen roughness of
3.2e-4): at alpha = 0 the distribution is a Dirac ring on the horizon, no density.

Shadowing (the spec key ``sheen_shadowing`` of the sheen tables, :mod:`bsdf_tab.tables.sheen`):

- ``fitted``: the paper's fitted Lambda, exp(L(cos)) for cos < 1/2 and exp(2 L(1/2) -
  L(1 - cos)) above, L(x) = a / (1 + b x^c) + d x + e with (a, b, c, d, e) interpolated in
  (1 - alpha)^2 between the paper's alpha = 0 and alpha = 1 fits (glTF Sample Viewer
  ``lambdaSheen``), height-correlated G = 1 / (1 + Lambda_i + Lambda_o), and the Sample
  Viewer's clamp of the visibility V = G / (4 mu_i mu_o) to [0, 1] (without it E diverges as
  mu -> 0: mu Lambda_fit(mu) -> 0, the fit does not grow like 1 / mu).
- ``exact``: the Smith Lambda of D itself, Lambda(w) = P(w) / cos(theta) - 1 with the
  projected area P(w) = int max(0, w.m) D(m) dw_m (Heitz 2014, "Understanding the
  Masking-Shadowing Function in Microfacet-Based BRDFs", eq. 18: no closed form for Charlie).
  P is tabulated once per alpha by :func:`charlie_projected_area_table` (host, float64) and
  interpolated by :func:`charlie_projected_area` (4-point Lagrange on a sinh-graded theta grid
  of :data:`CHARLIE_TABLE_NODES` nodes; relative error of P = cos (1 + Lambda), hence of G,
  below 2e-8 for alpha >= 1e-4 and below 1e-7 down to alpha = 1e-7, checked against SciPy in
  ``tests/sheen``). Height-correlated G.
- ``ashikhmin``: the visibility V = 1 / (4 (mu_i + mu_o - mu_i mu_o)) of Neubelt and Pettineo
  2013, "Crafting a Next-Gen Material Pipeline for The Order: 1886" (after Ashikhmin and
  Premoze 2007, "Distribution-based BRDFs"), which Filament's cloth model uses
  (``V_Neubelt``).

Charlie is deliberately **not** in the distribution registry of
:mod:`bsdf_tab.model.distribution`: the general integrators need a closed-form D cos CDF map
per distribution; the sheen tables have their own integrator. Everything here is generic over
float32 / float64 (``wp.vec3f`` / ``wp.vec3d``) except the host table builder.
"""

from typing import Any
import math

import numpy as np
import warp as wp

CHARLIE_ALPHA_MIN = 1.0e-7
"""Smallest alpha the Charlie functions use (smaller values are clamped to it)."""

CHARLIE_TABLE_NODES = 513
"""theta nodes of one row of the projected-area table of the exact Lambda."""

_TWO_PI = 6.283185307179586
_HALF_PI = 1.5707963267948966

# Estevez and Kulla 2017, Table 1: the fit at alpha = 0 (index 0) and alpha = 1 (index 1)
_FIT0 = (25.3245, 3.32435, 0.16801, -1.27393, -4.85967)
_FIT1 = (21.5473, 3.82987, 0.19823, -1.97760, -4.32054)
_A1, _B1, _C1, _D1, _E1 = _FIT1
_DA, _DB, _DC, _DD, _DE = (f0 - f1 for f0, f1 in zip(_FIT0, _FIT1))


@wp.func
def charlie_alpha(alpha: Any):
    """alpha clamped to [CHARLIE_ALPHA_MIN, inf)."""
    return wp.max(alpha, type(alpha)(CHARLIE_ALPHA_MIN))


@wp.func
def charlie_D(cos_theta_m: Any, alpha: Any):
    """D(m) = (2 + 1/alpha) sin^(1/alpha)(theta_m) / (2 pi) for cos_theta_m > 0, else 0."""
    zero = type(alpha)(0.0)
    if cos_theta_m <= zero:
        # back-facing micro-normals carry no area
        return zero
    a = charlie_alpha(alpha)
    inv = type(alpha)(1.0) / a  # a >= CHARLIE_ALPHA_MIN > 0
    s2 = wp.max(zero, type(alpha)(1.0) - cos_theta_m * cos_theta_m)
    if s2 <= zero:
        # sin^(1/alpha) at theta_m = 0 is 0 (1/alpha > 0)
        return zero
    # log of s2 > 0 is finite
    return (type(alpha)(2.0) + inv) * wp.exp(type(alpha)(0.5) * inv * wp.log(s2)) / type(alpha)(_TWO_PI)


@wp.func
def charlie_pdf(cos_theta_m: Any, alpha: Any):
    """Density of :func:`charlie_sample` per solid angle of m: D(m) cos(theta_m)."""
    return charlie_D(cos_theta_m, alpha) * wp.max(cos_theta_m, type(alpha)(0.0))


@wp.func
def charlie_sample(alpha: Any, u1: Any, u2: Any):
    """A micro-normal m with density D(m) cos(theta_m) from (u1, u2) in [0, 1)^2.

    The CDF of D cos in s = sin(theta_m) is s^(2 + 1/alpha), so s = u1^(alpha / (1 + 2 alpha)),
    phi = 2 pi u2. Returns a ``wp.vec3`` of the type of ``alpha``.
    """
    zero = type(alpha)(0.0)
    one = type(alpha)(1.0)
    a = charlie_alpha(alpha)
    s = zero
    if u1 > zero:
        # u1 = 0 is the pole s = 0 (log(0) avoided)
        s = wp.min(one, wp.exp(a / (one + type(alpha)(2.0) * a) * wp.log(u1)))
    c = wp.sqrt(wp.max(zero, one - s * s))  # clamped: s <= 1
    phi = type(alpha)(_TWO_PI) * u2
    return wp.vector(s * wp.cos(phi), s * wp.sin(phi), c)


@wp.func
def _fit_L(x: Any, alpha: Any):
    """L(x) = a / (1 + b x^c) + d x + e, coefficients interpolated in t = (1 - alpha)^2."""
    one = type(alpha)(1.0)
    a1 = wp.min(charlie_alpha(alpha), one)
    t = (one - a1) * (one - a1)
    ca = type(alpha)(_A1) + t * type(alpha)(_DA)
    cb = type(alpha)(_B1) + t * type(alpha)(_DB)
    cc = type(alpha)(_C1) + t * type(alpha)(_DC)
    cd = type(alpha)(_D1) + t * type(alpha)(_DD)
    ce = type(alpha)(_E1) + t * type(alpha)(_DE)
    xc = type(alpha)(0.0)
    if x > type(alpha)(0.0):
        # x^c with c > 0 is 0 at x = 0 (log(0) avoided)
        xc = wp.exp(cc * wp.log(x))
    # 1 + b x^c >= 1
    return ca / (one + cb * xc) + cd * x + ce


@wp.func
def charlie_lambda_fitted(cos_theta: Any, alpha: Any):
    """Estevez-Kulla fitted Lambda: exp(L(cos)) for cos < 1/2, exp(2 L(1/2) - L(1 - cos)) above."""
    half = type(alpha)(0.5)
    c = wp.min(wp.abs(cos_theta), type(alpha)(1.0))
    if c < half:
        return wp.exp(_fit_L(c, alpha))
    return wp.exp(type(alpha)(2.0) * _fit_L(half, alpha) - _fit_L(type(alpha)(1.0) - c, alpha))


@wp.func
def charlie_V_fitted(mu_i: Any, mu_o: Any, alpha: Any):
    """glTF Sample Viewer ``V_Sheen``: clamp(1 / ((1 + Lambda_i + Lambda_o) 4 mu_i mu_o), 0, 1)."""
    one = type(alpha)(1.0)
    den = (one + charlie_lambda_fitted(mu_i, alpha) + charlie_lambda_fitted(mu_o, alpha)) * type(alpha)(4.0) * mu_i * mu_o
    if den <= one:
        # the clamp at 1 (also the grazing limit mu_i mu_o = 0: no division by 0)
        return one
    return one / den


@wp.func
def charlie_V_ashikhmin(mu_i: Any, mu_o: Any):
    """Neubelt visibility (Filament ``V_Neubelt``): 1 / (4 (mu_i + mu_o - mu_i mu_o))."""
    den = type(mu_i)(4.0) * (mu_i + mu_o - mu_i * mu_o)
    if den <= type(mu_i)(0.0):
        # both directions grazing: the formula's limit is unbounded; no energy reaches there
        return type(mu_i)(0.0)
    return type(mu_i)(1.0) / den


@wp.func
def _asinh(x: Any):
    """asinh(x) = log(x + sqrt(x^2 + 1)) for x >= 0 (no cancellation there)."""
    return wp.log(x + wp.sqrt(x * x + type(x)(1.0)))


@wp.func
def charlie_projected_area(cos_theta: Any, alpha: Any, table: wp.array2d(dtype=wp.float64), row: wp.int32):
    """P(w) = int max(0, w.m) D(m) dw_m = cos(theta) (1 + Lambda(w)), from row ``row`` of ``table``.

    ``table`` is :func:`charlie_projected_area_table` for an alpha list; ``row`` the index of
    ``alpha`` in it (the grid of the row depends on alpha). 4-point Lagrange interpolation in
    t = asinh(theta / s) / asinh((pi/2) / s), s = sqrt(alpha), on uniform t nodes.
    """
    zero = type(alpha)(0.0)
    one = type(alpha)(1.0)
    n = table.shape[1]
    s = wp.sqrt(charlie_alpha(alpha))  # > 0
    amax = _asinh(type(alpha)(_HALF_PI) / s)  # > 0 since s > 0
    c = wp.min(wp.max(wp.abs(cos_theta), zero), one)
    theta = wp.acos(c)
    x = _asinh(theta / s) / amax * type(alpha)(n - 1)
    j = wp.min(wp.max(int(x), 1), n - 3)
    f = x - type(alpha)(j)
    fm = type(alpha)(table[row, j - 1])
    f0 = type(alpha)(table[row, j])
    f1 = type(alpha)(table[row, j + 1])
    f2 = type(alpha)(table[row, j + 2])
    two = type(alpha)(2.0)
    six = type(alpha)(6.0)
    return (-f * (f - one) * (f - two) / six * fm + (f + one) * (f - one) * (f - two) / two * f0
            - (f + one) * f * (f - two) / two * f1 + (f + one) * f * (f - one) / six * f2)


@wp.func
def charlie_lambda_cos_exact(cos_theta: Any, alpha: Any, table: wp.array2d(dtype=wp.float64), row: wp.int32):
    """|cos| Lambda(w) = P(w) - |cos| of the exact Smith Lambda (finite at grazing: P(pi/2))."""
    c = wp.abs(cos_theta)
    return wp.max(charlie_projected_area(c, alpha, table, row) - c, type(alpha)(0.0))


@wp.func
def charlie_lambda_exact(cos_theta: Any, alpha: Any, table: wp.array2d(dtype=wp.float64), row: wp.int32):
    """Exact Smith Lambda(w) = P(w) / |cos| - 1 (+inf at grazing)."""
    c = wp.abs(cos_theta)
    if c <= type(alpha)(0.0):
        # grazing: P(pi/2) > 0 over a zero projected area
        return type(alpha)(wp.inf)
    return charlie_lambda_cos_exact(c, alpha, table, row) / c


@wp.func
def charlie_V_exact(mu_i: Any, mu_o: Any, alpha: Any, table: wp.array2d(dtype=wp.float64), row: wp.int32):
    """G / (4 mu_i mu_o) with correlated exact G: 1 / (4 (mu_i mu_o + mu_o L_i + mu_i L_o)), L = |cos| Lambda."""
    li = charlie_lambda_cos_exact(mu_i, alpha, table, row)
    lo = charlie_lambda_cos_exact(mu_o, alpha, table, row)
    den = type(alpha)(4.0) * (mu_i * mu_o + mu_o * li + mu_i * lo)
    if den <= type(alpha)(0.0):
        # both directions grazing: no energy reaches there
        return type(alpha)(0.0)
    return type(alpha)(1.0) / den


# --------------------------------------------------------------------------- host side

_GL_X, _GL_W = np.polynomial.legendre.leggauss(32)


def charlie_table_thetas(alpha: float, nodes: int = CHARLIE_TABLE_NODES) -> np.ndarray:
    """The theta nodes of one table row: s sinh(t asinh((pi/2) / s)), t uniform, s = sqrt(alpha)."""
    s = math.sqrt(max(float(alpha), CHARLIE_ALPHA_MIN))
    t = np.linspace(0.0, 1.0, nodes)
    theta = s * np.sinh(t * math.asinh(0.5 * math.pi / s))
    theta[-1] = 0.5 * math.pi
    return theta


def charlie_projected_area_host(theta: np.ndarray, alpha: float) -> np.ndarray:
    """P(theta) = int max(0, w.m) D(m) dw_m by float64 quadrature (NumPy), w at polar angle theta.

    Over the elevation y = pi/2 - theta_m of m the azimuth integral is closed-form:
    int_0^2pi max(0, A cos p + B) dp = 2 (A sin p0 + B p0), A = sin(theta) cos(y),
    B = cos(theta) sin(y), p0 = arccos(-B / A) (pi when B >= A). The y integral is 32-point
    Gauss-Legendre on panels graded geometrically toward the horizon at the scale sqrt(alpha)
    (where D lives), split at the kink y = theta with a quadratic substitution on both sides
    (the integrand has a (B - A)^(3/2) term there).
    """
    theta = np.atleast_1d(np.asarray(theta, dtype=np.float64))
    a = max(float(alpha), CHARLIE_ALPHA_MIN)
    n = 1.0 / a
    cn = (2.0 + n) / (2.0 * math.pi)
    grade = []
    k = math.sqrt(a) / 16.0
    while k < 0.5 * math.pi:
        grade.append(k)
        k *= 2.0
    fixed = np.array([0.0] + grade + [0.5 * math.pi])
    th = np.clip(theta, 0.0, 0.5 * math.pi)
    br = np.sort(np.concatenate([np.repeat(fixed[None, :], th.size, 0), th[:, None]], axis=1), axis=1)
    lo, hi = br[:, :-1], br[:, 1:]  # (T, K)
    s = 0.5 * (_GL_X + 1.0)
    width = hi - lo
    kink_hi = np.isclose(hi, th[:, None], rtol=0, atol=0)
    kink_lo = np.isclose(lo, th[:, None], rtol=0, atol=0) & ~kink_hi
    S = s[None, None, :]
    y = lo[..., None] + width[..., None] * S
    J = np.repeat(width[..., None], s.size, axis=2)
    y = np.where(kink_hi[..., None], hi[..., None] - width[..., None] * S * S, y)
    J = np.where(kink_hi[..., None] | kink_lo[..., None], 2.0 * width[..., None] * S, J)
    y = np.where(kink_lo[..., None], lo[..., None] + width[..., None] * S * S, y)
    w = 0.5 * _GL_W[None, None, :] * J
    st = np.sin(th)[:, None, None]
    ct = np.cos(th)[:, None, None]
    A = st * np.cos(y)
    B = ct * np.sin(y)
    with np.errstate(divide="ignore", invalid="ignore"):
        # A = 0 (normal incidence or y = pi/2): B >= A, the whole circle
        r = np.where(A > 0.0, -B / np.where(A > 0.0, A, 1.0), -2.0)
    p0 = np.where(r <= -1.0, math.pi, np.arccos(np.clip(r, -1.0, 1.0)))
    I = 2.0 * (A * np.sin(p0) + B * p0)
    cy = np.cos(y)
    with np.errstate(divide="ignore"):
        # cos(y) = 0 only at y = pi/2 (the pole, never a Gauss node): D = 0 there
        Dm = cn * np.exp(n * np.log(np.where(cy > 0.0, cy, 1e-300)))
    return np.sum(w * Dm * cy * I, axis=(1, 2))


def charlie_projected_area_table(alphas, nodes: int = CHARLIE_TABLE_NODES) -> np.ndarray:
    """Rows of P on :func:`charlie_table_thetas` for each alpha: the ``table`` argument of the
    exact-Lambda functions, float64 of shape (len(alphas), nodes)."""
    alphas = np.atleast_1d(np.asarray(alphas, dtype=np.float64))
    out = np.empty((alphas.size, nodes))
    for k, a in enumerate(alphas):
        out[k] = charlie_projected_area_host(charlie_table_thetas(a, nodes), a)
    return out


__all__ = [
    "CHARLIE_ALPHA_MIN",
    "CHARLIE_TABLE_NODES",
    "charlie_alpha",
    "charlie_D",
    "charlie_pdf",
    "charlie_sample",
    "charlie_lambda_fitted",
    "charlie_V_fitted",
    "charlie_V_ashikhmin",
    "charlie_projected_area",
    "charlie_lambda_cos_exact",
    "charlie_lambda_exact",
    "charlie_V_exact",
    "charlie_table_thetas",
    "charlie_projected_area_host",
    "charlie_projected_area_table",
]
