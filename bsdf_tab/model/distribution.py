"""The registry of microfacet distributions, and one dispatch entry point per operation.

Host side: :data:`DISTRIBUTIONS` maps a distribution's name (the spec's ``distribution``) to its
integer id, the ``wp.int32`` selector every ``@wp.func`` below takes as ``dist``;
:data:`DISTRIBUTION_DESCRIPTIONS` gives a one-line description of each. The ids are the
positions in :data:`_MODULES`, and :data:`GGX` / :data:`BECKMANN` are the same ids as Warp
constants. Other layers (spec, tables, scene, benchmarks) read names and ids from here.

Device side: each operation dispatches on ``dist`` to the distribution's own module
(``ggx.py``, ``beckmann.py``), which holds everything that distribution knows. An unknown id
falls back to the first distribution (GGX), as it always has.

Adding a distribution: a module like ``ggx.py`` (``NAME``, ``DESCRIPTION`` and the functions
``<name>_D``, ``_lambda``, ``_lambda_cos``, ``_sample_vndf``, ``_dcos_sample_tan``,
``_dcos_tan_of_v``, ``_dcos_v_of_theta``, ``_dlnD_dcos``), its entry in :data:`_MODULES`, and
one ``if dist == ...`` branch per dispatcher below (Warp has no function pointers: the branches
are the device half of the registry; ``tests/model`` checks that every registered id reaches its
own module's functions).
"""

from typing import Any

import warp as wp

from . import beckmann as _beckmann
from . import ggx as _ggx
from .beckmann import (
    beckmann_D,
    beckmann_dcos_sample_tan,
    beckmann_dcos_tan_of_v,
    beckmann_dcos_v_of_theta,
    beckmann_dlnD_dcos,
    beckmann_lambda,
    beckmann_lambda_cos,
    beckmann_sample_vndf,
)
from .ggx import (
    ggx_D,
    ggx_dcos_sample_tan,
    ggx_dcos_tan_of_v,
    ggx_dcos_v_of_theta,
    ggx_dlnD_dcos,
    ggx_lambda,
    ggx_lambda_cos,
    ggx_sample_vndf,
)

# the registry: a distribution's id is its position here (ids are stored in tables' metadata
# and specs' hashes only through their names, but keep existing positions stable anyway)
_MODULES = (_ggx, _beckmann)

DISTRIBUTIONS = {m.NAME: i for i, m in enumerate(_MODULES)}
"""name -> integer id (the ``dist`` selector of every dispatcher)."""

DISTRIBUTION_DESCRIPTIONS = {m.NAME: m.DESCRIPTION for m in _MODULES}
"""name -> one-line description."""

GGX = wp.constant(DISTRIBUTIONS["ggx"])
BECKMANN = wp.constant(DISTRIBUTIONS["beckmann"])


def distribution_id(name: str) -> int:
    """The integer id of the distribution called ``name`` (ValueError naming the choices)."""
    try:
        return DISTRIBUTIONS[name]
    except KeyError:
        raise ValueError(f"unknown distribution {name!r}; one of {', '.join(DISTRIBUTIONS)}") from None


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


@wp.func
def dcos_sample_tan(u: Any, alpha: Any, dist: wp.int32):
    """tan(theta_m) at the value ``u`` in [0, 1) of the CDF of D(m) cos(theta_m) in theta_m.

    With phi_m uniform in [0, 2 pi) this samples micro-normals with density D(m) cos(theta_m).
    """
    if dist == BECKMANN:
        return beckmann_dcos_sample_tan(u, alpha)
    return ggx_dcos_sample_tan(u, alpha)


@wp.func
def dcos_tan_of_v(v: Any, alpha: Any, dist: wp.int32):
    """tan(theta_m) at v in [0, 1), where u = 1 - (1 - v)^2 is the D cos CDF.

    The adaptive integrator's outer variable: D cos dw_m = 2 (1 - v) dv dphi / (2 pi), and the
    (1 - u)^(-1/2) growth of tan(theta_m) at grazing is removed.
    """
    if dist == BECKMANN:
        return beckmann_dcos_tan_of_v(v, alpha)
    return ggx_dcos_tan_of_v(v, alpha)


@wp.func
def dcos_v_of_theta(theta: Any, alpha: Any, dist: wp.int32):
    """Inverse of :func:`dcos_tan_of_v`: v at theta_m in [0, pi/2] (1 at and beyond pi/2)."""
    if dist == BECKMANN:
        return beckmann_dcos_v_of_theta(theta, alpha)
    return ggx_dcos_v_of_theta(theta, alpha)


@wp.func
def dlnD_dcos(cos_theta_m: Any, alpha: Any, dist: wp.int32):
    """Bound on |d ln D / d cos theta_m|: how much a relative error in cos theta_m grows in D."""
    if dist == BECKMANN:
        return beckmann_dlnD_dcos(cos_theta_m, alpha)
    return ggx_dlnD_dcos(cos_theta_m, alpha)
