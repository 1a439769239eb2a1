"""The horizon-clipped sphere form factor of the LTC two-texture layout (``ltc_2.w``).

Shading a polygon with an LTC (Heitz et al. 2016, "Real-Time Polygonal-Light Shading with
Linearly Transformed Cosines") can replace the clipped polygon by the spherical cap with the
same vector form factor F (Heitz and Hill, "Real-Time Area Lighting: a Journey from Research
to Production", SIGGRAPH 2016 course): |F| = sin^2(sigma) for a cap of half-angle sigma, and
F_z / |F| = cos(omega), omega the polar angle of the cap's axis. The table holds

    S(z, l) = I(omega, sigma) / (pi l),   z = cos(omega), l = |F| = sin^2(sigma),

with I the cosine-weighted solid angle of the cap above the horizon (Snyder 1996, "Area Light
Sources for Real-Time Graphics", the cap's form factor clipped by the tangent plane):
I = pi sin^2(sigma) cos(omega) for omega <= pi/2 - sigma (no clipping), 0 for omega >=
pi/2 + sigma, and between them, with gamma = asin(cos(sigma) / sin(omega)),

    G = -2 sin(omega) cos(sigma) cos(gamma) + pi/2 - gamma + sin(gamma) cos(gamma),
    H = cos(omega) (cos(gamma) sqrt(sin^2(sigma) - cos^2(gamma)) + sin^2(sigma) asin(cos(gamma) / sin(sigma))),
    I = pi cos(omega) sin^2(sigma) + G - H  (omega < pi/2),   I = G + H  (omega >= pi/2).

The shader multiplies S by |F|: the form factor of the cap. S(z, 0) = max(z, 0) (the limit).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["cap_form_factor", "sphere_term", "sphere_term_at"]


def cap_form_factor(omega, sigma):
    """I(omega, sigma): the cosine-weighted solid angle of a cap above the horizon (float64)."""
    omega = np.asarray(omega, dtype=np.float64)
    sigma = np.asarray(sigma, dtype=np.float64)
    omega, sigma = np.broadcast_arrays(omega, sigma)
    ss = np.sin(sigma)
    s2 = ss * ss
    full = math.pi * np.cos(omega) * s2
    so = np.sin(omega)
    with np.errstate(divide="ignore", invalid="ignore"):  # only the clipped band is used below
        # sin(omega) > cos(sigma) in the clipped band (omega > pi/2 - sigma)
        g = np.arcsin(np.clip(np.cos(sigma) / np.where(so > 0.0, so, 1.0), -1.0, 1.0))
        cg = np.cos(g)
        G = -2.0 * so * np.cos(sigma) * cg + 0.5 * math.pi - g + np.sin(g) * cg
        # sin^2(sigma) >= cos^2(gamma) in the band (clamped against rounding); sin(sigma) > 0 there
        H = np.cos(omega) * (cg * np.sqrt(np.maximum(s2 - cg * cg, 0.0))
                             + s2 * np.arcsin(np.clip(cg / np.where(ss > 0.0, ss, 1.0), -1.0, 1.0)))
    lo = 0.5 * math.pi - sigma
    hi = 0.5 * math.pi + sigma
    return np.where(omega <= lo, full,
                    np.where(omega >= hi, 0.0, np.where(omega < 0.5 * math.pi, full + G - H, G + H)))


def sphere_term(z, length):
    """S(z, l) = I(acos z, asin sqrt l) / (pi l), and max(z, 0) at l = 0."""
    z = np.clip(np.asarray(z, dtype=np.float64), -1.0, 1.0)
    length = np.clip(np.asarray(length, dtype=np.float64), 0.0, 1.0)
    z, length = np.broadcast_arrays(z, length)
    sigma = np.arcsin(np.sqrt(length))
    with np.errstate(divide="ignore", invalid="ignore"):  # l = 0 takes the limit below
        value = cap_form_factor(np.arccos(z), sigma) / (math.pi * np.where(length > 0.0, length, 1.0))
    return np.where(length > 0.0, value, np.maximum(z, 0.0))


def sphere_term_at(mu, roughness):
    """The ``sphere`` channel of an LTC table on the two-texture layout's coordinates.

    The public code's ``ltc_2.w`` shares the texture of the matrix: texture coordinates
    (u, v) = (roughness, sqrt(1 - mu)) hold S(z = 2 u - 1, l = v). Arrays (mu, roughness)
    broadcast; returns S there.
    """
    mu = np.asarray(mu, dtype=np.float64)
    v = np.sqrt(np.clip(1.0 - mu, 0.0, 1.0))  # clip: mu in [0, 1]
    return sphere_term(2.0 * np.asarray(roughness, dtype=np.float64) - 1.0, v)
