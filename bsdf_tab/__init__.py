"""bsdf-tab: microfacet BSDF lookup tables computed with NVIDIA Warp kernels.

Public API: :func:`tabulate`, :class:`Table`, :func:`read_exr`, :func:`normalize_spec`,
:func:`spec_hash`, :class:`SpecError`. The Warp device functions live in :mod:`bsdf_tab.model`.
"""

__version__ = "0.1.0"

from .errors import SpecError  # noqa: E402
from .spec import normalize_spec, spec_hash, resolve_axes  # noqa: E402
from .table import Table  # noqa: E402
from .exr import read_exr, write_exr  # noqa: E402
from .api import tabulate  # noqa: E402

__all__ = [
    "__version__",
    "SpecError",
    "Table",
    "normalize_spec",
    "read_exr",
    "resolve_axes",
    "spec_hash",
    "tabulate",
    "write_exr",
]
