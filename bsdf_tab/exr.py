"""Compatibility shim: the float32 EXR format now lives in :mod:`bsdf_tab.io.exr`.

Kept only for modules and tests not yet switched to :mod:`bsdf_tab.io`; delete it once
nothing imports ``bsdf_tab.exr``. The readers here return a :class:`~bsdf_tab.table.Table`
as before.
"""

from __future__ import annotations

from .io.exr import ATTR_PREFIX, exr_bytes, layout_description
from .io.exr import read_exr_bytes as _read_exr_bytes_parts
from .table import Table, read_exr, write_exr

__all__ = ["write_exr", "read_exr", "exr_bytes", "read_exr_bytes", "layout_description", "ATTR_PREFIX"]


def read_exr_bytes(data: bytes) -> Table:
    """Read a table from the bytes of an EXR file (see :func:`bsdf_tab.io.exr.read_exr`)."""
    return _read_exr_bytes_parts(data, Table)
