"""Anisotropic GGX (Trowbridge-Reitz) with widths (alpha_x, alpha_y) along the tangent x and bitangent y.

- D(m) = 1 / (pi alpha_x alpha_y (m_x^2 / alpha_x^2 + m_y^2 / alpha_y^2 + m_z^2)^2), m_z > 0
  (Walter et al. 2007, "Microfacet Models for Refraction through Rough Surfaces", eq. 33
  with the anisotropic slope distribution of Heitz 2014, "Understanding the
  Masking-Shadowing Function in Microfacet-Based BRDFs", eq. 82); int D cos dw = 1.
- Lambda(w) = (-1 + sqrt(1 + (alpha_x^2 w_x^2 + alpha_y^2 w_y^2) / w_z^2)) / 2 (Heitz 2014,
  eq. 86: the isotropic Lambda with the projected width alpha(phi)); ``ggx_aniso_lambda_cos``
  is |w_z| Lambda in rationalized form, finite at grazing.
- Visible-normal sampling (Heitz 2018, "Sampling the GGX Distribution of Visible Normals"):
  stretch w by (alpha_x, alpha_y, 1), sample the hemisphere projection, unstretch; density
  G1(w) max(0, w.m) D(m) / w_z (``ggx_aniso_pdf_vndf``).

alpha_x = alpha_y = alpha gives the isotropic :mod:`bsdf_tab.model.ggx` functions. Like Charlie,
this module is self-contained (not in the distribution registry): the anisotropic table has
its own integrator (:mod:`bsdf_tab.tables.aniso`). Generic over float32 / float64.
"""

from typing import Any

import warp as wp

_TWO_PI = 6.283185307179586


@wp.func
def ggx_aniso_D(m: Any, ax: Any, ay: Any):
    """D(m) for a unit micro-normal m (0 for m_z <= 0 or a zero width)."""
    zero = type(ax)(0.0)
    if m[2] <= zero or ax <= zero or ay <= zero:
        # back-facing micro-normal, or a Dirac delta (alpha = 0): no finite density
        return zero
    q = m[0] * m[0] / (ax * ax) + m[1] * m[1] / (ay * ay) + m[2] * m[2]  # > 0: m_z > 0
    return type(ax)(1.0) / (type(ax)(wp.pi) * ax * ay * q * q)


@wp.func
def ggx_aniso_lambda_cos(w: Any, ax: Any, ay: Any):
    """|w_z| Lambda(w) = a2s2 / (2 (sqrt(w_z^2 + a2s2) + |w_z|)), a2s2 = alpha_x^2 w_x^2 + alpha_y^2 w_y^2."""
    z = wp.abs(w[2])
    a2s2 = ax * ax * w[0] * w[0] + ay * ay * w[1] * w[1]
    den = type(ax)(2.0) * (wp.sqrt(z * z + a2s2) + z)
    if den <= type(ax)(0.0):
        # zero width at grazing: a mirror has no shadowing
        return type(ax)(0.0)
    return a2s2 / den


@wp.func
def ggx_aniso_lambda(w: Any, ax: Any, ay: Any):
    """Smith Lambda(w) (exact; +inf at grazing unless both widths are 0)."""
    z = wp.abs(w[2])
    lc = ggx_aniso_lambda_cos(w, ax, ay)
    if z <= type(ax)(0.0):
        # grazing: fully shadowed unless the surface is a mirror
        if lc <= type(ax)(0.0):
            return type(ax)(0.0)
        return type(ax)(wp.inf)
    return lc / z


@wp.func
def ggx_aniso_G1(w: Any, m: Any, ax: Any, ay: Any):
    """G1(w, m) = chi+(w.m / w_z) / (1 + Lambda(w)) = |w_z| / (|w_z| + |w_z| Lambda) (0 at grazing)."""
    zero = type(ax)(0.0)
    if wp.dot(w, m) * w[2] <= zero:
        # chi+: a back-facing micro-normal for w
        return zero
    z = wp.abs(w[2])
    den = z + ggx_aniso_lambda_cos(w, ax, ay)
    if den <= zero:
        # grazing direction
        return zero
    return z / den


@wp.func
def ggx_aniso_sample_vndf(wi: Any, ax: Any, ay: Any, u1: Any, u2: Any):
    """A visible micro-normal for ``wi`` (wi_z > 0), density :func:`ggx_aniso_pdf_vndf`."""
    zero = type(ax)(0.0)
    one = type(ax)(1.0)
    if ax <= zero and ay <= zero:
        # mirror: the only micro-normal is the macro normal
        return type(wi)(zero, zero, one)
    vh = wp.normalize(type(wi)(ax * wi[0], ay * wi[1], wi[2]))
    lensq = vh[0] * vh[0] + vh[1] * vh[1]
    t1 = type(wi)(one, zero, zero)
    if lensq > zero:
        # a tangent perpendicular to the stretched view (undefined at normal incidence)
        t1 = type(wi)(-vh[1], vh[0], zero) / wp.sqrt(lensq)
    t2 = wp.cross(vh, t1)
    r = wp.sqrt(u1)
    phi = type(ax)(_TWO_PI) * u2
    p1 = r * wp.cos(phi)
    p2 = r * wp.sin(phi)
    s = type(ax)(0.5) * (one + vh[2])
    p2 = (one - s) * wp.sqrt(wp.max(zero, one - p1 * p1)) + s * p2  # clamped: |p1| <= 1
    nh = p1 * t1 + p2 * t2 + wp.sqrt(wp.max(zero, one - p1 * p1 - p2 * p2)) * vh  # clamped: the disk
    return wp.normalize(type(wi)(ax * nh[0], ay * nh[1], wp.max(zero, nh[2])))


@wp.func
def ggx_aniso_pdf_vndf(wi: Any, m: Any, ax: Any, ay: Any):
    """G1(wi) max(0, wi.m) D(m) / wi_z: the density of :func:`ggx_aniso_sample_vndf` per solid angle."""
    zero = type(ax)(0.0)
    z = wi[2]
    if z <= zero:
        # the sampler is defined for wi above the surface
        return zero
    im = wp.max(wp.dot(wi, m), zero)
    return im * ggx_aniso_D(m, ax, ay) / (z + ggx_aniso_lambda_cos(wi, ax, ay))  # z > 0


def aniso_widths(alpha, anisotropy):
    """(alpha_x, alpha_y) = (alpha / sqrt(1 - 0.9 a), alpha sqrt(1 - 0.9 a)) for a in [0, 1]
    (host; alpha_x alpha_y = alpha^2, so alpha is the isotropic collapse sqrt(alpha_x alpha_y);
    the aspect alpha_x / alpha_y = 1 / (1 - 0.9 a) reaches 10 at a = 1)."""
    import numpy as np

    k = np.sqrt(1.0 - 0.9 * np.asarray(anisotropy, dtype=np.float64))  # >= sqrt(0.1): a <= 1
    alpha = np.asarray(alpha, dtype=np.float64)
    return alpha / k, alpha * k


__all__ = [
    "ggx_aniso_D",
    "ggx_aniso_lambda",
    "ggx_aniso_lambda_cos",
    "ggx_aniso_G1",
    "ggx_aniso_sample_vndf",
    "ggx_aniso_pdf_vndf",
    "aniso_widths",
]
