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

Only ``adaptive`` is imported with the package; the other methods' modules load when
:func:`get_method` (or :data:`METHODS`) first hands out one of their functions.

Distribution knowledge (D, Lambda, the D cos CDF and its inverse, sampling) comes from
:mod:`bsdf_tab.model` only.
"""

import importlib
from collections.abc import MutableMapping

from .adaptive import integrate_texels

#: Method name -> the module (of this package) whose ``METHODS`` registers it. The fixed-effort
#: methods are imported on first use: a command that integrates with ``adaptive`` only (``plan``,
#: ``bake`` of the default method) never defines their kernels (12-19 ms of imports on the 2-core machine).
_LAZY_METHODS = {
    "grid": "grid",  # midpoint rule over the outgoing hemisphere
    "mc_cosine": "montecarlo",
    "mc_dcos": "montecarlo",
    "mc_vndf": "montecarlo",
    "qmc_vndf": "montecarlo",
    "vndf_gl": "vndf_gl",  # Gauss-Legendre over the VNDF sample square
}


class _Methods(MutableMapping):
    """The method registry: every name is known up front (the spec validates against it), a
    method's module is imported when its function is first looked up. Assignment replaces an
    entry (benchmarks wrap ``adaptive`` to count evaluations)."""

    def __init__(self, loaded: dict, lazy: dict):
        self._loaded = dict(loaded)
        self._lazy = dict(lazy)

    def __getitem__(self, name: str):
        if name not in self._loaded:
            module = self._lazy[name]  # KeyError: not a method
            for key, fn in importlib.import_module(f".{module}", __name__).METHODS.items():
                self._loaded.setdefault(key, fn)  # an entry assigned before stays
        return self._loaded[name]

    def __setitem__(self, name: str, fn) -> None:
        self._loaded[name] = fn

    def __delitem__(self, name: str) -> None:
        if name not in self:
            raise KeyError(name)
        self._loaded.pop(name, None)
        self._lazy.pop(name, None)

    def __iter__(self):
        return iter(dict.fromkeys([*self._loaded, *self._lazy]))

    def __len__(self) -> int:
        return len(self._loaded.keys() | self._lazy.keys())

    def __contains__(self, name) -> bool:
        return name in self._loaded or name in self._lazy

    def __repr__(self) -> str:
        return f"METHODS({sorted(self)})"


METHODS: MutableMapping = _Methods({"adaptive": integrate_texels}, _LAZY_METHODS)


def get_method(name: str):
    """The texel integrator registered under ``name`` (a spec's ``method``)."""
    try:
        return METHODS[name]
    except KeyError:
        raise ValueError(f"unknown method {name!r}; one of {', '.join(sorted(METHODS))}") from None


__all__ = ["METHODS", "get_method", "integrate_texels"]
