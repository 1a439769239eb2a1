"""Integration methods: one module per method, each a Warp kernel plus a thin host launcher.

Every method has the signature of :func:`bsdf_tab.integrate.adaptive.integrate_texels`
(``mode, mu, alpha, eta, *, dist, shadowing, ftype, fp0, fp1, tol, device, workers, progress``,
plus optional ``effort``) and returns ``(values, errors)`` of shape (N, 2). :data:`METHODS`
maps the spec's ``method`` name to it.
"""

from .adaptive import integrate_texels

METHODS = {"adaptive": integrate_texels}


def get_method(name: str):
    """The texel integrator registered under ``name`` (a spec's ``method``)."""
    try:
        return METHODS[name]
    except KeyError:
        raise ValueError(f"unknown method {name!r}; one of {', '.join(sorted(METHODS))}") from None


__all__ = ["METHODS", "get_method", "integrate_texels"]
