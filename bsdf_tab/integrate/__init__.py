"""Integration methods: one module per method, each a Warp kernel plus a thin host launcher.

Every method has the signature of :func:`bsdf_tab.integrate.adaptive.integrate_texels`
(``mode, mu, alpha, eta, *, dist, shadowing, ftype, fp0, fp1, tol, device, workers, progress``,
plus optional ``effort``) and returns ``(values, errors)`` of shape (N, 2). :data:`METHODS`
maps the spec's ``method`` name to it.

Modules:

* ``integrand.py``: what every method shares on the device: the texel struct, the integrand
  families (:data:`~bsdf_tab.integrate.integrand.MODES`), the one integrand over micro-normals
  (and over outgoing directions), the mirror limit alpha = 0, the kernel preamble;
* ``quadrature.py``: the Gauss-Kronrod 7-15 constants (host arrays and device constants) and
  the one global-bisection routine;
* ``runtime.py``: the device, worker threads over texel chunks, the host preamble;
* ``adaptive.py`` (default), ``grid.py``, ``montecarlo.py``, ``vndf_gl.py``: the methods;
  ``fixed.py``: the host side the fixed-effort methods share.

Distribution knowledge (D, Lambda, the D cos CDF and its inverse, sampling) comes from
:mod:`bsdf_tab.model` only.
"""

from .adaptive import integrate_texels

from . import grid as _grid, montecarlo as _montecarlo, vndf_gl as _vndf_gl

METHODS = {
    "adaptive": integrate_texels,
    **_grid.METHODS,  # "grid": midpoint rule over the outgoing hemisphere
    **_montecarlo.METHODS,  # "mc_cosine", "mc_dcos", "mc_vndf", "qmc_vndf"
    **_vndf_gl.METHODS,  # "vndf_gl": Gauss-Legendre over the VNDF sample square
}


def get_method(name: str):
    """The texel integrator registered under ``name`` (a spec's ``method``)."""
    try:
        return METHODS[name]
    except KeyError:
        raise ValueError(f"unknown method {name!r}; one of {', '.join(sorted(METHODS))}") from None


__all__ = ["METHODS", "get_method", "integrate_texels"]
