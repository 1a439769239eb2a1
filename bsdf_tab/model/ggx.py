"""GGX (Trowbridge-Reitz) microfacet distribution: everything the package knows about it.

D, the exact Smith Lambda (and |cos| Lambda), visible-normal sampling, the CDF of D(m) cos(theta_m)
in theta_m and its inverse (for D cos sampling and the adaptive integrator's outer variable), and
the bound on |d ln D / d cos theta_m| the bsdf table uses to propagate rounding. Registered in
:mod:`bsdf_tab.model.distribution` under :data:`NAME`.

References: Walter et al. 2007, "Microfacet Models for Refraction through Rough Surfaces"
(D, eq. 33; Smith Lambda); Heitz 2014, "Understanding the Masking-Shadowing Function in
Microfacet-Based BRDFs" (Lambda); Heitz 2018, "Sampling the GGX Distribution of Visible
Normals" (VNDF sampling).
"""

from typing import Any

import warp as wp

from .ggx_aniso import ggx_aniso_sample_vndf

NAME = "ggx"
DESCRIPTION = "GGX / Trowbridge-Reitz, alpha = alpha_g (Walter et al. 2007 eq. 33)"

_HALF_PI = 1.5707963267948966


@wp.func
def ggx_D(cos_theta_m: Any, alpha: Any):
    """D(m) = alpha^2 / (pi cos^4 (alpha^2 + tan^2)^2), normalized: int D cos dw = 1."""
    zero = type(alpha)(0.0)
    if cos_theta_m <= zero:
        # back-facing micro-normals carry no area
        return zero
    if alpha <= zero:
        # alpha = 0 is a Dirac delta: no finite density
        return zero
    c2 = cos_theta_m * cos_theta_m
    a2 = alpha * alpha
    # cos^2 (alpha^2 + tan^2) = alpha^2 cos^2 + sin^2, finite at grazing
    den = a2 * c2 + wp.max(zero, type(alpha)(1.0) - c2)
    return a2 / (type(alpha)(wp.pi) * den * den)


@wp.func
def ggx_lambda_cos(cos_theta_v: Any, alpha: Any):
    """|cos| * Lambda(v): (sqrt(z^2 + alpha^2 s^2) - z) / 2, finite at grazing (alpha / 2)."""
    zero = type(alpha)(0.0)
    z = wp.abs(cos_theta_v)
    a2s2 = alpha * alpha * wp.max(zero, type(alpha)(1.0) - z * z)
    den = type(alpha)(2.0) * (wp.sqrt(z * z + a2s2) + z)
    if den <= zero:
        # alpha = 0 at grazing: a mirror has no shadowing
        return zero
    # rationalized form, no cancellation for small alpha tan
    return a2s2 / den


@wp.func
def ggx_lambda_root(cos_theta_v: Any, alpha: Any):
    """r = sqrt(z^2 + alpha^2 s^2) = |cos| (1 + 2 Lambda(v)), z = |cos|, s^2 = 1 - z^2.

    The one square root of the GGX Lambda: |cos| Lambda = (r - z) / 2 and |cos| + |cos| Lambda =
    (z + r) / 2, so G can be formed from r with one division and no cancellation (``shadowing``).
    """
    z = wp.abs(cos_theta_v)
    return wp.sqrt(z * z + alpha * alpha * wp.max(type(alpha)(0.0), type(alpha)(1.0) - z * z))


@wp.func
def ggx_lambda(cos_theta_v: Any, alpha: Any):
    """Smith Lambda(v) = (-1 + sqrt(1 + alpha^2 tan^2)) / 2 (exact, infinite at grazing)."""
    z = wp.abs(cos_theta_v)
    if z <= type(alpha)(0.0):
        # grazing: fully shadowed unless alpha = 0
        if alpha <= type(alpha)(0.0):
            return type(alpha)(0.0)
        return type(alpha)(wp.inf)
    return ggx_lambda_cos(cos_theta_v, alpha) / z


@wp.func
def ggx_sample_vndf(wi: Any, alpha: Any, u1: Any, u2: Any):
    """Sample a visible micro-normal for ``wi`` (wi.z > 0), density G1 max(0, wi.m) D / wi.z.

    The isotropic case of :func:`~bsdf_tab.model.ggx_aniso.ggx_aniso_sample_vndf` (Heitz 2018).
    """
    return ggx_aniso_sample_vndf(wi, alpha, alpha, u1, u2)


@wp.func
def ggx_dcos_sample_tan(u: Any, alpha: Any):
    """tan(theta_m) where the D cos CDF u = tan^2 / (alpha^2 + tan^2) takes the value ``u`` in [0, 1).

    Inverse-CDF sampling of D(m) cos(theta_m) (Walter et al. 2007 eq. 35): tan = alpha sqrt(u / (1 - u)).
    """
    return alpha * wp.sqrt(u / (type(u)(1.0) - u))


@wp.func
def ggx_dcos_tan_of_v(v: Any, alpha: Any):
    """tan(theta_m) at v in [0, 1), where u = 1 - (1 - v)^2 is the D cos CDF.

    tan = alpha sqrt(u) / (1 - v) with u = v (2 - v): no cancellation in 1 - u near v = 1.
    """
    w = type(v)(1.0) - v
    return alpha * wp.sqrt(v * (type(v)(2.0) - v)) / w


@wp.func
def ggx_dcos_v_of_theta(theta: Any, alpha: Any):
    """Inverse of :func:`ggx_dcos_tan_of_v` for theta_m in [0, pi/2]: v = 1 - alpha cos / sqrt(alpha^2 cos^2 + sin^2)."""
    one = type(theta)(1.0)
    if theta >= type(theta)(_HALF_PI) or alpha <= type(alpha)(0.0):
        # the horizon, or a mirror (all of D at theta_m = 0): the whole CDF
        return one
    c = wp.cos(theta)
    s = wp.sin(theta)
    return one - alpha * c / wp.sqrt(alpha * alpha * c * c + s * s)


@wp.func
def ggx_dlnD_dcos(c: Any, alpha: Any):
    """Bound on |d ln D / d cos theta_m|: 4 / c + 4 / (c (alpha^2 c^2 + 1 - c^2)).

    The amplification of a relative error in cos theta_m into D (the bsdf table's rounding
    estimate); ``c`` is clamped to 1e-300 so that c = 0 gives a huge bound (or +inf), never nan.
    """
    one = type(c)(1.0)
    c = wp.max(c, type(c)(1.0e-300))
    return type(c)(4.0) / c + type(c)(4.0) / (c * (alpha * alpha * c * c + wp.max(one - c * c, type(c)(0.0))))
