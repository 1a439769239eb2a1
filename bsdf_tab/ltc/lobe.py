"""The true lobe of an LTC fit, on the host in float64: f_r(V, L) cos(theta_L) / E.

Conventions of Walter et al. 2007, "Microfacet Models for Refraction through Rough Surfaces"
(SPEC section 2): n = +z, V = (sqrt(1 - mu^2), 0, mu), F = 1 (the Fresnel term of an LTC table
is the separate Schlick amplitude). The lobe is parametrized by the micro-normal h, sampled by
its distribution of D(h) cos(theta_h): with u in [0, 1], phi in [0, 2 pi),

    D(h) cos(theta_h) dw_h = du dphi / (2 pi),
    GGX:      tan^2(theta_h) = alpha^2 u / (1 - u),
    Beckmann: tan^2(theta_h) = -alpha^2 ln(1 - u),

and u = 1 - (1 - v)^2 (du = 2 (1 - v) dv), which removes the 1/sqrt(1 - u) of the grazing
integrand. With L = 2 (V.h) h - V the Jacobian dw_L = 4 (V.h) dw_h turns the lobe's measure into

    f_r cos(theta_L) dw_L = (G / mu) (V.h) / cos(theta_h) * D(h) cos(theta_h) dw_h,

whose factor (G / mu)(V.h) / cos(theta_h) is bounded and independent of the scale alpha: a
near-mirror lobe costs no more than a rough one. G / mu is formed from mu Lambda(mu) (finite
at mu = 0), so grazing V is exact, not clamped.
"""

from __future__ import annotations

import math
from typing import Callable, NamedTuple

import numpy as np

def _erfc(x):
    """erfc elementwise: SciPy's when installed (imported here, not at start-up: it costs every
    ``bsdf-tab`` command about a second), else math.erfc per element."""
    try:
        from scipy.special import erfc
    except ImportError:  # SciPy is optional at run time
        return np.frompyfunc(math.erfc, 1, 1)(x)
    return erfc(x)

__all__ = ["ALPHA_FLOOR", "DISTRIBUTIONS", "gauss_legendre", "lambda_cos", "ndf", "lobe_nodes", "lobe_value", "view"]

#: Below this alpha the lobe's shape is fitted at ALPHA_FLOOR (a Dirac lobe has no density).
ALPHA_FLOOR = 1e-6
_TINY = 1e-300


def view(mu):
    """V = (sqrt(1 - mu^2), 0, mu) for an array of mu, shape (..., 3)."""
    mu = np.asarray(mu, dtype=np.float64)
    s = np.sqrt(np.maximum(1.0 - mu * mu, 0.0))  # clamp: 1 - mu^2 may round below 0 at mu = 1
    return np.stack([s, np.zeros_like(mu), mu], axis=-1)


def gauss_legendre(n: int, a: float, b: float, panels: int = 1):
    """Composite Gauss-Legendre nodes and weights on [a, b] with ``panels`` equal panels."""
    x, w = np.polynomial.legendre.leggauss(n)
    edges = np.linspace(a, b, panels + 1)
    half = 0.5 * np.diff(edges)[:, None]
    mid = 0.5 * (edges[:-1] + edges[1:])[:, None]
    return (mid + half * x[None, :]).ravel(), (half * w[None, :]).ravel()


def _ggx_lambda_cos(c, s2, alpha):
    a2s2 = alpha * alpha * s2
    # c + sqrt(..) > 0 unless c = 0 and alpha s = 0 (then the numerator is 0 too)
    return a2s2 / (2.0 * np.maximum(c + np.sqrt(c * c + a2s2), _TINY))


def _beckmann_lambda_cos(c, s2, alpha):
    den = alpha * np.sqrt(s2)
    a = c / np.maximum(den, _TINY)  # den = 0 only at normal incidence (a = inf, Lambda = 0)
    erfc_a = np.asarray(_erfc(a), dtype=np.float64)
    with np.errstate(over="ignore"):  # a = inf at normal incidence: exp(-inf) = 0, as it should
        return -0.5 * c * erfc_a + den * np.exp(-a * a) / (2.0 * math.sqrt(math.pi))


def _ggx_ndf(c2, s2, a2):
    den = a2 * c2 + s2  # > 0 for ch > 0 or alpha > 0
    return a2 / (math.pi * np.maximum(den * den, _TINY))


def _beckmann_ndf(c2, s2, a2):
    t2 = s2 / np.maximum(c2, _TINY)  # ch > 0 where called
    return np.exp(-t2 / a2) / (math.pi * a2 * np.maximum(c2 * c2, _TINY))


class _Distribution(NamedTuple):
    """The host functions of one distribution: a new distribution is one entry of :data:`DISTRIBUTIONS`."""

    lambda_cos: Callable  # (c, 1 - c^2, alpha) -> c Lambda(c)
    ndf: Callable  # (cos^2, sin^2, alpha^2) -> D(h)
    tan2_of_u: Callable  # (u, 1 - u, alpha^2) -> tan^2(theta_h) at the CDF value u of D cos
    v_of_tan2: Callable  # (tan^2(theta_h), alpha) -> v, u = 1 - (1 - v)^2


DISTRIBUTIONS = {
    "ggx": _Distribution(
        _ggx_lambda_cos, _ggx_ndf,
        lambda u, one_m_u, a2: a2 * u / np.maximum(one_m_u, _TINY),  # v < 1 at every node (v2 < 1)
        lambda t2, alpha: 1.0 - alpha / np.sqrt(alpha * alpha + t2)),
    "beckmann": _Distribution(
        _beckmann_lambda_cos, _beckmann_ndf,
        lambda u, one_m_u, a2: -a2 * np.log(np.maximum(one_m_u, _TINY)),
        lambda t2, alpha: 1.0 - np.exp(-t2 / (2.0 * alpha * alpha))),
}


def lambda_cos(dist: str, c, alpha):
    """c Lambda(c) for cos(theta) = c in [0, 1] (exact Smith Lambda; finite at c = 0).

    GGX: c Lambda = alpha^2 (1 - c^2) / (2 (c + sqrt(c^2 + alpha^2 (1 - c^2)))).
    Beckmann, a = c / (alpha sqrt(1 - c^2)): c Lambda = -c erfc(a) / 2
    + alpha sqrt(1 - c^2) exp(-a^2) / (2 sqrt(pi)).
    """
    c = np.asarray(c, dtype=np.float64)
    s2 = np.maximum(1.0 - c * c, 0.0)  # clamp: rounding at c = 1
    return DISTRIBUTIONS[dist].lambda_cos(c, s2, alpha)


def ndf(dist: str, ch, alpha):
    """D(h) for cos(theta_h) = ch > 0 (normalized: int D cos dw = 1)."""
    ch = np.asarray(ch, dtype=np.float64)
    c2 = ch * ch
    return DISTRIBUTIONS[dist].ndf(c2, np.maximum(1.0 - c2, 0.0), alpha * alpha)


def _g_over_mu(dist: str, shadowing: str, mu, lv, lz, alpha):
    """G / mu from mu Lambda(mu) = lv and L_z > 0 (array lz)."""
    ll = lambda_cos(dist, lz, alpha)  # L_z Lambda(L_z)
    lam_l = ll / np.maximum(lz, _TINY)  # L_z > 0 where used (callers mask L_z <= 0)
    if shadowing == "correlated":
        return 1.0 / np.maximum(mu + lv + mu * lam_l, _TINY)  # >= mu Lambda(mu) > 0 for alpha > 0
    g1_l = lz / np.maximum(lz + ll, _TINY)  # G1(L) = 1 / (1 + Lambda(L))
    return g1_l / np.maximum(mu + lv, _TINY)  # mu + mu Lambda(mu) > 0 for alpha > 0


def lobe_value(dist: str, shadowing: str, mu, alpha, L):
    """f_r(V, L) cos(theta_L) (F = 1) at directions L (..., 3); 0 below the horizon.

    ``mu`` and ``alpha`` are scalars or arrays broadcasting against L[..., 0].
    """
    L = np.asarray(L, dtype=np.float64)
    mu = np.broadcast_to(np.asarray(mu, dtype=np.float64), L.shape[:-1])
    alpha = np.broadcast_to(np.maximum(np.asarray(alpha, dtype=np.float64), ALPHA_FLOOR), L.shape[:-1])
    V = view(mu)
    h = L + V
    hn = np.linalg.norm(h, axis=-1)
    h = h / np.maximum(hn, _TINY)[..., None]  # L = -V only below the horizon (masked below)
    lz = L[..., 2]
    vh = np.sum(h * V, axis=-1)
    ok = (lz > 0.0) & (vh > 0.0) & (h[..., 2] > 0.0)
    lv = lambda_cos(dist, mu, alpha)
    gm = _g_over_mu(dist, shadowing, mu, lv, np.where(ok, lz, 1.0), alpha)
    return np.where(ok, gm * ndf(dist, np.where(ok, h[..., 2], 1.0), alpha) / 4.0, 0.0)


def _v_of_theta(dist: str, theta, alpha):
    """v of the micro-normal polar angle theta (inverse of the maps above), in [0, 1]."""
    t2 = np.tan(np.clip(theta, 0.0, 0.5 * math.pi - 1e-15)) ** 2  # clip: tan finite
    return DISTRIBUTIONS[dist].v_of_tan2(t2, alpha)


def lobe_nodes(dist: str, shadowing: str, mu, alpha, nv: int, nphi: int, v_panels: int = 1,
               phi_panels: int = 1):
    """Quadrature of the lobe on the half sphere phi in [0, pi] (the lobe is even in L_y).

    For a micro-normal at polar angle theta_h, L is above the horizon (and V.h > 0) exactly for
    cos(phi) > c_min = (mu / (2 cos theta_h) - mu cos theta_h) / (sin theta_v sin theta_h): all
    phi for theta_h <= pi/4 - theta_v/2, none beyond pi/4 + theta_v/2 (theta_v = acos mu). The v
    range is split at those two angles and phi runs over [0, phi_max(theta_h)] through
    phi = phi_max (1 - cos(pi y)) / 2, so the horizon cut is an end of every rule, not a kink
    inside one (Gauss-Legendre in v and y, ``v_panels`` panels per segment, ``phi_panels`` in y).

    Parameters
    ----------
    dist, shadowing : str
        ``ggx`` / ``beckmann``; ``correlated`` / ``separable``.
    mu, alpha : array_like, shape (B,)
        Texels (alpha floored at :data:`ALPHA_FLOOR`).
    nv, nphi, v_panels, phi_panels : int
        The Gauss-Legendre orders and panel counts.

    Returns
    -------
    L : ndarray (B, K, 3)
        Directions (the L_y >= 0 half; the lobe and every LTC of the fit are even in L_y).
    f : ndarray (B, K)
        f_r cos(theta_L) at L (0 where L is below the horizon).
    w : ndarray (B, K)
        Weights: sum_k w_k g(L_k) ~ int g(L) f_r cos(theta_L) dw_L over the whole sphere for g
        even in L_y (the factor 2 of the symmetry included); sum_k w_k ~ E.
    """
    mu = np.atleast_1d(np.asarray(mu, dtype=np.float64))
    alpha = np.maximum(np.atleast_1d(np.asarray(alpha, dtype=np.float64)), ALPHA_FLOOR)
    B = mu.size
    theta_v = np.arccos(np.clip(mu, 0.0, 1.0))
    v1 = _v_of_theta(dist, 0.25 * math.pi - 0.5 * theta_v, alpha)
    v2 = _v_of_theta(dist, 0.25 * math.pi + 0.5 * theta_v, alpha)
    x, wx = gauss_legendre(nv, 0.0, 1.0, v_panels)
    # v nodes: [0, v1], then [v1, v2] through s(x) = (1 - cos(pi x)) / 2: phi_max has square-root
    # ends at v1 and v2, which s flattens
    sx = 0.5 * (1.0 - np.cos(math.pi * x))
    dsx = 0.5 * math.pi * np.sin(math.pi * x) * wx
    v = np.concatenate([v1[:, None] * x[None, :], v1[:, None] + (v2 - v1)[:, None] * sx[None, :]], axis=1)
    wv = np.concatenate([v1[:, None] * wx[None, :], (v2 - v1)[:, None] * dsx[None, :]], axis=1)
    y, wy = gauss_legendre(nphi, 0.0, 1.0, phi_panels)
    one_m_u = (1.0 - v) ** 2
    u = 1.0 - one_m_u
    a2 = (alpha * alpha)[:, None]
    t2 = DISTRIBUTIONS[dist].tan2_of_u(u, one_m_u, a2)
    ch = 1.0 / np.sqrt(1.0 + t2)  # (B, 2 nv')
    sh = np.sqrt(t2) * ch
    sv = np.sqrt(np.maximum(1.0 - mu * mu, 0.0))[:, None]  # clamp: rounding at mu = 1
    num = mu[:, None] / (2.0 * ch) - mu[:, None] * ch
    den = sv * sh
    with np.errstate(divide="ignore", invalid="ignore"):  # den = 0: all or nothing, by the sign
        c_min = np.where(den > 0.0, num / np.where(den > 0.0, den, 1.0), np.where(num < 0.0, -2.0, 2.0))
    phi_max = np.arccos(np.clip(c_min, -1.0, 1.0))  # (B, nv2)
    phi = phi_max[:, :, None] * (0.5 * (1.0 - np.cos(math.pi * y)))[None, None, :]
    dphi = phi_max[:, :, None] * (0.5 * math.pi * np.sin(math.pi * y) * wy)[None, None, :]
    cp, sp = np.cos(phi), np.sin(phi)
    h = np.stack([sh[:, :, None] * cp, sh[:, :, None] * sp, np.broadcast_to(ch[:, :, None], cp.shape)], axis=-1)
    V = view(mu)[:, None, None, :]
    vh = np.sum(h * V, axis=-1)
    L = 2.0 * vh[..., None] * h - V
    lz = L[..., 2]
    ok = (vh > 0.0) & (lz > 0.0)  # guards rounding at the ends of the phi range
    lv = lambda_cos(dist, mu, alpha)[:, None, None]
    gm = _g_over_mu(dist, shadowing, mu[:, None, None], lv, np.where(ok, lz, 1.0), alpha[:, None, None])
    dens = ndf(dist, ch, alpha[:, None])[:, :, None]  # D(h)
    f = np.where(ok, gm * dens / 4.0, 0.0)
    # measure: du dphi / (2 pi) of D cos, du = 2 (1 - v) dv, times 2 for phi in [pi, 2 pi)
    quad = (2.0 * (1.0 - v) * wv)[:, :, None] * dphi / math.pi
    w = np.where(ok, gm * vh / ch[:, :, None], 0.0) * quad
    return L.reshape(B, -1, 3), f.reshape(B, -1), w.reshape(B, -1)
