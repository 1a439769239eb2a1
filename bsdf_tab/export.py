"""Compatibility shim: the export formats now live in :mod:`bsdf_tab.io`.

``write_npy`` / ``read_npy`` are the ``npy-channels`` format (:mod:`bsdf_tab.io.npy_channels`;
the name ``npy`` now means one structured ``.npy`` file, :mod:`bsdf_tab.io.npy`), the C header
is :mod:`bsdf_tab.io.c_header` and the half-float EXR :mod:`bsdf_tab.io.half_exr`. Kept only
for modules and tests not yet switched; delete it once nothing imports ``bsdf_tab.export``.
The functions that return tables return :class:`~bsdf_tab.table.Table` as before.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .io.c_header import c_identifier, header_text, write_header
from .io.half_exr import HALF_MAX, half_rounding, to_half, write_half_exr
from .io.npy_channels import read_npy_channels, write_npy_channels
from .table import Table

__all__ = [
    "write_npy",
    "read_npy",
    "write_header",
    "header_text",
    "c_identifier",
    "half_rounding",
    "to_half_table",
    "write_half_exr",
    "HALF_MAX",
]


def write_npy(table, out_dir, stem: str, *, stacked: bool = False, dtype=np.float32) -> list[Path]:
    """The ``npy-channels`` files of ``table`` (see :func:`bsdf_tab.io.npy_channels.write_npy_channels`)."""
    return write_npy_channels(table, out_dir, stem, stacked=stacked, dtype=dtype)


def read_npy(out_dir, stem: str) -> Table:
    """Read a table written by :func:`write_npy` (either layout)."""
    return read_npy_channels(out_dir, stem, Table)


def to_half_table(table) -> tuple[Table, dict[str, float]]:
    """The half table and the max rounding error per channel (see :func:`bsdf_tab.io.half_exr.to_half`)."""
    return to_half(table, Table)
