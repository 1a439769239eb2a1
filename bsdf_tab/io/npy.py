"""``npy``: one ``.npy`` file holding a structured array, one float64 field per channel.

The array is shaped by the axes in axis order (C order); its dtype has one little-endian
float64 field per channel, named after the channel, in the table's channel order::

    arr = numpy.load("lut.npy", allow_pickle=False)
    arr.dtype.names        # ("E", "E_err")
    arr["E"][i_mu, i_alpha]

The file holds the values only: no axes and no metadata (use ``npz``, ``exr`` or ``json``
for those, or ``npy-channels`` for ``.npy`` files with the axes and a JSON sidecar), so it
cannot be read back into a table. The same bytes in the CLI, presets and the service
(``format=npy``).
"""

from __future__ import annotations

import io

import numpy as np

from .atomic import bytes_writer
from .base import Format, shape_of

__all__ = ["FORMAT", "structured_array", "npy_bytes", "write_npy"]


def structured_array(table) -> np.ndarray:
    """The table's channels as one structured array shaped by the axes (float64 fields).

    Raises
    ------
    ValueError
        If the table has no channels (a structured dtype needs a field).
    """
    if not table.channels:
        raise ValueError("cannot write a table without channels to npy")
    dtype = np.dtype([(name, "<f8") for name in table.channels])
    arr = np.empty(shape_of(table), dtype=dtype)
    for name, values in table.channels.items():
        arr[name] = values
    return arr


def npy_bytes(table) -> bytes:
    """The bytes of the ``.npy`` file of :func:`structured_array` (no pickles)."""
    buf = io.BytesIO()
    np.save(buf, structured_array(table), allow_pickle=False)
    return buf.getvalue()


#: atomic write of the structured ``.npy`` file (:mod:`.atomic`); returns ``[path]``
write_npy = bytes_writer(npy_bytes)


FORMAT = Format(
    name="npy",
    suffixes=(".npy",),
    description="one .npy structured array, a float64 field per channel, shaped by the axes (no axes, no meta)",
    write=write_npy,
    media_type="application/x-npy",
    to_bytes=npy_bytes,
)
