"""LTC matrices: the fit's parameters, the lobe density, the storage form, the L1 fit metric.

Heitz, Dupuy, Hill, Neubelt 2016, "Real-Time Polygonal-Light Shading with Linearly Transformed
Cosines": a lobe D(L) is the clamped cosine D_o(w) = max(0, w_z) / pi transformed by a matrix M,

    D(L) = D_o(Minv L / |Minv L|) |det Minv| / |Minv L|^3
         = max(0, (Minv L)_z) |det Minv| / (pi |Minv L|^4),

which integrates to 1 over the sphere for every invertible M and is invariant to the scale of
M. For an isotropic BRDF with V in the xz plane, M = R_y(beta) [[m11, 0, q m11], [0, m22, 0],
[0, 0, 1]] (beta the lobe's tilt, m11 and m22 its widths, q its skew): four parameters, the
whole family of such matrices up to scale (the public code fixes beta to the BRDF's mean
direction and fits the other three).

Storage form (the public code's ``packTab`` and three.js's ``ltc_1`` texture): Minv divided by
its middle entry Minv_11, and its four free entries (Minv_00, Minv_20, Minv_02, Minv_22); in
GLSL ``mat3(vec3(x, 0, y), vec3(0, 1, 0), vec3(z, 0, w))`` (columns). ``M`` below is the
inverse of that normalized Minv (so M_11 = 1 too).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["clipped_l1_metric", "density", "density_entries", "entries_from_params", "params_from_entries", "from_storage",
           "l1_metric", "minv_from_params", "params_dim", "storage", "upper_mass", "upper_mass_entries"]

params_dim = 4
_TINY = 1e-300


def minv_from_params(p):
    """Minv (..., 3, 3) of parameters p = (beta, ln m11, ln m22, q), shape (..., 4)."""
    p = np.asarray(p, dtype=np.float64)
    beta, m11, m22, q = p[..., 0], np.exp(p[..., 1]), np.exp(p[..., 2]), p[..., 3]
    c, s = np.cos(beta), np.sin(beta)
    # A^-1 = [[1/m11, 0, -q], [0, 1/m22, 0], [0, 0, 1]], R^T = [[c, 0, -s], [0, 1, 0], [s, 0, c]]
    out = np.zeros(p.shape[:-1] + (3, 3))
    out[..., 0, 0] = c / m11 - q * s
    out[..., 0, 2] = -s / m11 - q * c
    out[..., 1, 1] = 1.0 / m22
    out[..., 2, 0] = s
    out[..., 2, 2] = c
    return out


def density(minv, L):
    """LTC lobe D(L) for matrices ``minv`` (..., 3, 3) at directions L (..., K, 3)."""
    minv = np.asarray(minv, dtype=np.float64)
    l = np.einsum("...ij,...kj->...ki", minv, np.asarray(L, dtype=np.float64))
    det = np.abs(np.linalg.det(minv))[..., None]
    n2 = np.sum(l * l, axis=-1)
    # |Minv L| > 0 for invertible Minv and unit L
    return np.maximum(l[..., 2], 0.0) * det / (math.pi * np.maximum(n2 * n2, _TINY))


def entries_from_params(p):
    """Stored entries (x, y, z, w) = (Minv_00, Minv_20, Minv_02, Minv_22) / Minv_11 of parameters p."""
    p = np.asarray(p, dtype=np.float64)
    beta, m11, m22, q = p[..., 0], np.exp(p[..., 1]), np.exp(p[..., 2]), p[..., 3]
    c, s = np.cos(beta), np.sin(beta)
    return np.stack([m22 * (c / m11 - q * s), m22 * s, m22 * (-s / m11 - q * c), m22 * c], axis=-1)


def params_from_entries(e):
    """Inverse of :func:`entries_from_params` (m11 from |1/m11|: a flipped lobe is not a fit)."""
    e = np.asarray(e, dtype=np.float64)
    x, y, z, w = e[..., 0], e[..., 1], e[..., 2], e[..., 3]
    m22 = np.hypot(y, w)
    beta = np.arctan2(y, w)
    c, s = np.cos(beta), np.sin(beta)
    xs, zs = x / np.maximum(m22, _TINY), z / np.maximum(m22, _TINY)  # m22 > 0 for invertible Minv
    inv_m11 = np.abs(c * xs - s * zs)
    q = -s * xs - c * zs
    return np.stack([beta, -np.log(np.maximum(inv_m11, _TINY)), np.log(np.maximum(m22, _TINY)), q], axis=-1)


def density_entries(e, L):
    """D(L) for stored entries e (B, 4) at L (B, K, 3): the fit's fast path."""
    x, y, z, w = (e[:, i:i + 1] for i in range(4))
    lx = x * L[..., 0] + z * L[..., 2]
    lz = y * L[..., 0] + w * L[..., 2]
    n2 = lx * lx + L[..., 1] ** 2 + lz * lz  # > 0 for invertible Minv and |L| = 1
    return np.maximum(lz, 0.0) * np.abs(x * w - y * z) / (math.pi * n2 * n2)


def l1_metric(d_ltc, f, w, E):
    """int |D_ltc - f_r cos / E| dL over the sphere, from the lobe's quadrature nodes.

    Both lobes integrate to 1, so int |a - b| = 2 int max(b - a, 0): only the true lobe's
    support is needed, and the nodes of :func:`bsdf_tab.ltc.lobe.lobe_nodes` (weights w of the
    measure f_r cos dL) give 2 sum_k (w_k / E) max(1 - E D_ltc(L_k) / f_k, 0). In [0, 2].
    """
    E = np.asarray(E, dtype=np.float64)[..., None]
    # f > 0 wherever w > 0; E > 0 for alpha > 0 (callers pass the lobe's own mass)
    ratio = np.where(f > 0.0, E * d_ltc / np.where(f > 0.0, f, 1.0), 1.0)
    return 2.0 * np.sum(w * np.maximum(1.0 - ratio, 0.0), axis=-1) / np.maximum(E[..., 0], _TINY)


def upper_mass(minv):
    """int over the upper hemisphere of the LTC lobe of ``minv`` (..., 3, 3): its mass above the horizon.

    L = M w maps {L_z > 0} onto the half-space n.w > 0 with n = M^T e_z / |M^T e_z| (M's row 2), and
    the clamped cosine over a half-space with unit normal n has the mass (1 + n_z) / 2 (half of
    int |w_z| / pi = 2 over the sphere plus int w_z / pi = n_z over the half-space).
    """
    m = np.linalg.inv(np.asarray(minv, dtype=np.float64))
    r = m[..., 2, :]
    return 0.5 * (1.0 + r[..., 2] / np.maximum(np.linalg.norm(r, axis=-1), _TINY))  # row of an invertible M != 0


def upper_mass_entries(e):
    """:func:`upper_mass` of stored entries e (..., 4): M's row 2 is (-y, 0, x) / det."""
    e = np.asarray(e, dtype=np.float64)
    x, y, z, w = e[..., 0], e[..., 1], e[..., 2], e[..., 3]
    sgn = np.where(x * w - y * z < 0.0, -1.0, 1.0)
    return 0.5 * (1.0 + sgn * x / np.maximum(np.hypot(x, y), _TINY))  # (x, y) = 0 only for a singular Minv


def clipped_l1_metric(d_ltc, f, w, E, amp, m_up):
    """int over the upper hemisphere of |amp D_ltc - f_r cos / E| dL (amp: the relative amplitude).

    The shading error of a light P above the horizon with the estimate E amp int_P D_ltc is
    E abs(int_P (amp D_ltc - T)) <= E times this. With int_up amp D = amp m_up and int T = 1:
    = amp m_up - 1 + 2 int max(T - amp D, 0), the last term on the true lobe's nodes. For
    amp = 1 / m_up (the horizon-mass amplitude) it is the L1 distance between the clipped,
    renormalized LTC lobe and T.
    """
    E = np.asarray(E, dtype=np.float64)[..., None]
    amp = np.asarray(amp, dtype=np.float64)
    ratio = np.where(f > 0.0, amp[..., None] * E * d_ltc / np.where(f > 0.0, f, 1.0), 1.0)  # f > 0 where w > 0
    under = 2.0 * np.sum(w * np.maximum(1.0 - ratio, 0.0), axis=-1) / np.maximum(E[..., 0], _TINY)
    return np.maximum(amp * np.asarray(m_up, dtype=np.float64) - 1.0 + under, 0.0)


def storage(minv):
    """(Minv_00, Minv_20, Minv_02, Minv_22) of Minv / Minv_11, and M = (Minv / Minv_11)^-1 likewise."""
    minv = np.asarray(minv, dtype=np.float64)
    n = minv / minv[..., 1:2, 1:2]  # Minv_11 = 1 / m22 > 0
    m = np.linalg.inv(n)
    pick = lambda a: np.stack([a[..., 0, 0], a[..., 2, 0], a[..., 0, 2], a[..., 2, 2]], axis=-1)  # noqa: E731
    return pick(n), pick(m)


def from_storage(x, y, z, w):
    """The 3x3 Minv of the stored entries (x, y, z, w) = (Minv_00, Minv_20, Minv_02, Minv_22)."""
    x = np.asarray(x, dtype=np.float64)
    out = np.zeros(x.shape + (3, 3))
    out[..., 0, 0], out[..., 2, 0], out[..., 0, 2], out[..., 2, 2] = x, y, z, w
    out[..., 1, 1] = 1.0
    return out
