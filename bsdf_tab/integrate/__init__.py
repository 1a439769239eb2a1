"""Integration methods: one module per method, each a Warp kernel plus a thin host launcher.

Every method has the signature of :func:`bsdf_tab.integrate.adaptive.integrate_texels`
(``mode, mu, alpha, eta, *, dist, shadowing, ftype, fp0, fp1, tol, device, workers, progress``,
plus optional ``effort``) and returns ``(values, errors)`` of shape (N, 2). :data:`METHODS`
maps the spec's ``method`` name to it.
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
