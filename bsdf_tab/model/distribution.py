"""Distribution dispatch: one entry point per operation, selected by a ``wp.int32`` constant.

Adding a distribution means a module like ``ggx.py`` and one branch per function here.
"""

from typing import Any

import warp as wp

from .beckmann import beckmann_D, beckmann_lambda, beckmann_lambda_cos, beckmann_sample_vndf
from .ggx import ggx_D, ggx_lambda, ggx_lambda_cos, ggx_sample_vndf

GGX = wp.constant(0)
BECKMANN = wp.constant(1)


@wp.func
def D(cos_theta_m: Any, alpha: Any, dist: wp.int32):
    """Microfacet distribution D(m) of micro-normal cosine ``cos_theta_m``."""
    if dist == BECKMANN:
        return beckmann_D(cos_theta_m, alpha)
    return ggx_D(cos_theta_m, alpha)


@wp.func
def Lambda(cos_theta_v: Any, alpha: Any, dist: wp.int32):
    """Exact Smith Lambda(v) (infinite at grazing for alpha > 0)."""
    if dist == BECKMANN:
        return beckmann_lambda(cos_theta_v, alpha)
    return ggx_lambda(cos_theta_v, alpha)


@wp.func
def lambda_cos(cos_theta_v: Any, alpha: Any, dist: wp.int32):
    """|cos theta_v| * Lambda(v): finite at grazing, used to form G without 0 * inf."""
    if dist == BECKMANN:
        return beckmann_lambda_cos(cos_theta_v, alpha)
    return ggx_lambda_cos(cos_theta_v, alpha)


@wp.func
def smith_G1(v: Any, m: Any, alpha: Any, dist: wp.int32):
    """G1(v, m) = chi+((v.m)/(v.n)) / (1 + Lambda(v)) = |z| / (|z| + |z| Lambda)."""
    zero = type(alpha)(0.0)
    z = v[2]
    if wp.dot(v, m) * z <= zero:
        # v sees the back of the micro-facet (or grazes the macro surface)
        return zero
    az = wp.abs(z)
    return az / (az + lambda_cos(z, alpha, dist))


@wp.func
def sample_vndf(wi: Any, alpha: Any, u1: Any, u2: Any, dist: wp.int32):
    """Visible-normal sample for ``wi`` (wi.z > 0) from two uniform numbers in [0, 1)."""
    if dist == BECKMANN:
        return beckmann_sample_vndf(wi, alpha, u1, u2)
    return ggx_sample_vndf(wi, alpha, u1, u2)


@wp.func
def pdf_vndf(wi: Any, m: Any, alpha: Any, dist: wp.int32):
    """Density of :func:`sample_vndf` over solid angle: G1(wi) max(0, wi.m) D(m) / wi.z."""
    zero = type(alpha)(0.0)
    z = wi[2]
    if z <= zero:
        # only defined for directions above the surface
        return zero
    c = wp.dot(wi, m)
    if c <= zero:
        # back-facing micro-normals are invisible
        return zero
    return smith_G1(wi, m, alpha, dist) * c * D(m[2], alpha, dist) / z
