"""bsdf-tab: microfacet BSDF lookup tables computed with NVIDIA Warp kernels.

Public API: :func:`tabulate` and :func:`iter_blocks` (the only ways to compute a table),
:class:`Table`, :func:`read_exr` / :func:`write_exr`, :func:`normalize_spec`, :func:`spec_hash`,
:func:`resolve_axes`, :class:`SpecError`. The Warp device functions live in
:mod:`bsdf_tab.model`, the file formats in :mod:`bsdf_tab.io`, the engine presets in
:mod:`bsdf_tab.presets`, the scene planner in :mod:`bsdf_tab.scene`.
"""

from .version import __version__
from .errors import SpecError
from .spec import normalize_spec, spec_hash, resolve_axes
from .table import Table, read_exr, write_exr
from .api import iter_blocks, tabulate

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
