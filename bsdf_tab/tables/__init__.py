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

Adding a table kind: a module here with its ``KINDS``, and its name in :data:`_MODULES`. A kind
whose module defines Warp kernels of its own declares its entry in :mod:`.kinds` instead, with
:class:`~.kinds.Deferred` functions: its module is imported when a table of it is first computed,
so a command that never computes one (``bsdf-tab plan``) does not define those kernels.
"""

from __future__ import annotations

from . import albedo, dfg, dielectric, kinds, multiscatter
from ._common import Context

#: The kinds' declarations, in catalog order (``kinds.*_KINDS``: entries of the modules loaded on first use).
_MODULES = (albedo.KINDS, dielectric.KINDS, dfg.KINDS, kinds.BSDF_KINDS, multiscatter.KINDS, kinds.LTC_KINDS,
            kinds.SHEEN_KINDS, kinds.ANISO_KINDS)

#: Kind name -> its entry (with the functions).
KINDS: dict[str, dict] = {name: info for declared in _MODULES for name, info in declared.items()}

_FUNCTIONS = ("compute", "blocks")

#: Kind name -> its entry without the functions: what the spec, the service catalog and docs read.
CATALOG: dict[str, dict] = {
    name: {k: v for k, v in info.items() if k not in _FUNCTIONS} for name, info in KINDS.items()
}

__all__ = ["CATALOG", "KINDS", "Context"]
