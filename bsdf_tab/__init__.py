"""bsdf-tab: microfacet BSDF lookup tables computed with NVIDIA Warp kernels.

Public API: :func:`tabulate` and :func:`iter_blocks` (the only ways to compute a table),
:class:`Table`, :func:`read_exr` / :func:`write_exr`, :func:`normalize_spec`, :func:`spec_hash`,
:func:`resolve_axes`, :class:`SpecError`. The Warp device functions live in
:mod:`bsdf_tab.model`, the file formats in :mod:`bsdf_tab.io`, the engine presets in
:mod:`bsdf_tab.presets`, the scene planner in :mod:`bsdf_tab.scene`.

The re-exports load on first use (PEP 562 module ``__getattr__``): ``import bsdf_tab`` costs
nothing, ``from bsdf_tab import tabulate`` imports :mod:`bsdf_tab.api` (and Warp) then. A
command that needs no table (``bsdf-tab --help``) so never imports Warp.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

from .errors import SpecError
from .version import __version__

if TYPE_CHECKING:  # what the lazy names are, for type checkers and readers
    from .api import iter_blocks, tabulate
    from .spec import normalize_spec, resolve_axes, spec_hash
    from .table import Table, read_exr, write_exr

#: public name -> the module that defines it (imported on first access)
_LAZY = {
    "normalize_spec": "spec",
    "spec_hash": "spec",
    "resolve_axes": "spec",
    "Table": "table",
    "read_exr": "table",
    "write_exr": "table",
    "iter_blocks": "api",
    "tabulate": "api",
}

__all__ = [
    "__version__",
    "SpecError",
    "Table",
    "iter_blocks",
    "normalize_spec",
    "read_exr",
    "resolve_axes",
    "spec_hash",
    "tabulate",
    "write_exr",
]


def __getattr__(name: str):
    """A re-export (imported from its module on first access, then cached here), or a
    submodule not imported yet (``bsdf_tab.api`` after a bare ``import bsdf_tab``)."""
    module = _LAZY.get(name)
    if module is not None:
        value = getattr(importlib.import_module(f".{module}", __name__), name)
        globals()[name] = value
        return value
    if not name.startswith("__"):
        try:
            return importlib.import_module(f".{name}", __name__)
        except ModuleNotFoundError as exc:
            if exc.name != f"{__name__}.{name}":  # the submodule exists but fails inside: say so
                raise
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))
