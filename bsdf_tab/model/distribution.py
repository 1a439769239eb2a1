"""The registry of microfacet distributions, and one dispatch entry point per operation.

Host side: :data:`DISTRIBUTIONS` maps a distribution's name (the spec's ``distribution``) to its
integer id, the ``wp.int32`` selector every ``@wp.func`` below takes as ``dist``;
:data:`DISTRIBUTION_DESCRIPTIONS` gives a one-line description of each. The ids are the
positions in :data:`_MODULES`, and :data:`GGX` / :data:`BECKMANN` are the same ids as Warp
constants. Other layers (spec, tables, scene, benchmarks) read names and ids from here.

Device side: each operation (:func:`D`, :func:`Lambda`, :func:`lambda_cos`, :func:`sample_vndf`,
the D cos CDF functions, :func:`dlnD_dcos`) dispatches on ``dist`` to the distribution's own
module (``ggx.py``, ``beckmann.py``), which holds everything that distribution knows. The
dispatchers are generated from the registry (a chain of ``@wp.func`` closures, see
:func:`_dispatch`); an unknown id falls back to the first distribution (GGX), as it always has.
:func:`smith_G1` and :func:`pdf_vndf` are written once on top of them.

Adding a distribution: a module like ``ggx.py`` (``NAME``, ``DESCRIPTION`` and the functions
``<name>_D``, ``_lambda``, ``_lambda_cos``, ``_sample_vndf``, ``_dcos_sample_tan``,
``_dcos_tan_of_v``, ``_dcos_v_of_theta``, ``_dlnD_dcos``) and its name in :data:`_NAMES`. The
tests in ``tests/model`` and ``tests/integrate`` are parametrized over :data:`DISTRIBUTIONS`
(the reference in ``tests/reference`` needs the new D and Lambda too).
"""

import importlib
from typing import Any

import warp as wp

# the registry: one module per distribution, named here; a distribution's id is its position
# (ids never leave the process: specs, tables and hashes carry names; keep positions anyway)
_NAMES = ("ggx", "beckmann")
_MODULES = tuple(importlib.import_module(f".{name}", __package__) for name in _NAMES)

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


def _dispatch(op: str, doc: str):
    """``op(x, alpha, dist)``: ``<name>_<op>(x, alpha)`` of the registered distribution with id ``dist``.

    Built from :data:`_MODULES` as a chain of ``@wp.func`` closures, ``if dist == id: return
    f(x, alpha)`` down the registry, ending in the first module's function (the fallback for an
    unknown id, GGX as it has always been). Warp compiles each closure to its own C++ function and
    the compiler inlines the chain: the same code as hand-written branches.
    """
    funcs = [getattr(m, f"{m.NAME}_{op}") for m in _MODULES]
    fallback = funcs[0]

    @wp.func(name=f"dispatch_{op}_0")
    def last(x: Any, alpha: Any, dist: wp.int32):
        return fallback(x, alpha)

    nxt = last
    for i in range(len(funcs) - 1, 0, -1):
        nxt = _branch(op, i, funcs[i], nxt)
    nxt.__doc__ = doc
    return nxt


def _branch(op: str, i: int, f, nxt):
    @wp.func(name=f"dispatch_{op}_{i}")
    def step(x: Any, alpha: Any, dist: wp.int32):
        if dist == i:
            return f(x, alpha)
        return nxt(x, alpha, dist)

    return step


def _dispatch_sample(op: str, doc: str):
    """As :func:`_dispatch` for the samplers ``<name>_<op>(wi, alpha, u1, u2)``."""
    funcs = [getattr(m, f"{m.NAME}_{op}") for m in _MODULES]
    fallback = funcs[0]

    @wp.func(name=f"dispatch_{op}_0")
    def last(wi: Any, alpha: Any, u1: Any, u2: Any, dist: wp.int32):
        return fallback(wi, alpha, u1, u2)

    nxt = last
    for i in range(len(funcs) - 1, 0, -1):
        nxt = _branch_sample(op, i, funcs[i], nxt)
    nxt.__doc__ = doc
    return nxt


def _branch_sample(op: str, i: int, f, nxt):
    @wp.func(name=f"dispatch_{op}_{i}")
    def step(wi: Any, alpha: Any, u1: Any, u2: Any, dist: wp.int32):
        if dist == i:
            return f(wi, alpha, u1, u2)
        return nxt(wi, alpha, u1, u2, dist)

    return step


# ---------------------------------------------------------------- the dispatchers (generated)

D = _dispatch("D", "Microfacet distribution D(m) of micro-normal cosine ``cos_theta_m``: D(cos_theta_m, alpha, dist).")
Lambda = _dispatch("lambda", "Exact Smith Lambda(v) (infinite at grazing for alpha > 0): Lambda(cos_theta_v, alpha, dist).")
lambda_cos = _dispatch(
    "lambda_cos",
    "|cos theta_v| * Lambda(v): finite at grazing, used to form G without 0 * inf: lambda_cos(cos_theta_v, alpha, dist).",
)
sample_vndf = _dispatch_sample(
    "sample_vndf",
    "Visible-normal sample for ``wi`` (wi.z > 0) from two uniform numbers in [0, 1): sample_vndf(wi, alpha, u1, u2, dist).",
)
dcos_sample_tan = _dispatch(
    "dcos_sample_tan",
    "tan(theta_m) at the value ``u`` in [0, 1) of the CDF of D(m) cos(theta_m) in theta_m: dcos_sample_tan(u, alpha, dist).\n\n"
    "With phi_m uniform in [0, 2 pi) this samples micro-normals with density D(m) cos(theta_m).",
)
dcos_tan_of_v = _dispatch(
    "dcos_tan_of_v",
    "tan(theta_m) at v in [0, 1), where u = 1 - (1 - v)^2 is the D cos CDF: dcos_tan_of_v(v, alpha, dist).\n\n"
    "The adaptive integrator's outer variable: D cos dw_m = 2 (1 - v) dv dphi / (2 pi), and the "
    "(1 - u)^(-1/2) growth of tan(theta_m) at grazing is removed.",
)
dcos_v_of_theta = _dispatch(
    "dcos_v_of_theta",
    "Inverse of :func:`dcos_tan_of_v`: v at theta_m in [0, pi/2] (1 at and beyond pi/2): dcos_v_of_theta(theta, alpha, dist).",
)
dlnD_dcos = _dispatch(
    "dlnD_dcos",
    "Bound on |d ln D / d cos theta_m| (how much a relative error in cos theta_m grows in D): "
    "dlnD_dcos(cos_theta_m, alpha, dist).",
)


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


