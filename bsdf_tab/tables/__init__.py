"""The table catalog: one module per table kind, each declaring its kinds in ``KINDS``.

A kind's entry: ``axes`` (axis slots in table order; ``"alpha"`` stands for the roughness slot,
``alpha`` or ``roughness``), ``channels`` (value channels; each also gets ``<X>_err``),
``fresnel`` (``"any"``: a fresnel parameter, ``"axis"``: dielectric with eta from the ``eta``
axis, ``"one"``: Fresnel-independent), ``description``, and the functions: ``compute(nspec,
axes, ctx) -> channels`` and, for kinds computed in blocks of axis-0 slices (tables too large to
hold), ``blocks(nspec, axes, ctx, block_texels)``. Optional: ``methods`` (the only methods the
kind accepts), ``params`` (kind-only top-level keys) and ``parametrizations`` (name -> axis
slots), ``chunk_axis`` (the axis a cluster cuts the table along; default 0).
:mod:`bsdf_tab.spec` validates against :data:`CATALOG`; :mod:`bsdf_tab.api` is the only
caller of the functions.

Adding a table kind: a module here with its ``KINDS``, and its name in :data:`_MODULES`.
"""

from __future__ import annotations

from . import albedo, aniso, bsdf, dfg, dielectric, ltc, multiscatter, sheen
from ._common import Context

_MODULES = (albedo, dielectric, dfg, bsdf, multiscatter, ltc, sheen, aniso)

#: Kind name -> its entry (with the functions).
KINDS: dict[str, dict] = {name: info for module in _MODULES for name, info in module.KINDS.items()}

_FUNCTIONS = ("compute", "blocks")

#: Kind name -> its entry without the functions: what the spec, the service catalog and docs read.
CATALOG: dict[str, dict] = {
    name: {k: v for k, v in info.items() if k not in _FUNCTIONS} for name, info in KINDS.items()
}

__all__ = ["CATALOG", "KINDS", "Context"]
