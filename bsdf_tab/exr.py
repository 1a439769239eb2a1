"""OpenEXR round trip of a :class:`~bsdf_tab.table.Table`.

Layout
------
Every table channel (``E``, ``E_err``, ``R``, ``T``, ...) is one FLOAT (32-bit)
EXR channel of the same name. A table of shape ``(n0, n1, ..., nk)`` is
flattened row-major over all axes but the last, and the last axis runs along
the image width:

- 1-D ``(n,)``: height 1, width n; ``pixel[0, j] = channel[j]``.
- 2-D ``(n0, n1)``: height n0, width n1; ``pixel[i, j] = channel[i, j]``.
- 3-D ``(n0, n1, n2)``: the n0 slices stacked vertically: height n0*n1,
  width n2; ``pixel[i0*n1 + i1, j] = channel[i0, i1, j]``.

Row 0 is the top scanline of the image (the first row of the data window).

Header attributes (all strings, so that any EXR reader can show them and no
value is rounded to 32 bits):

- ``bsdf_tab_spec``: JSON of the normalized spec.
- ``bsdf_tab_axes``: JSON ``[[name, [values...]], ...]`` in axis order, floats
  written with ``repr`` (exact float64).
- ``bsdf_tab_channels``: JSON list of the channel names in table order (EXR
  itself sorts channels by name).
- ``bsdf_tab_layout``: the layout above, in words, for this table's axes.
- ``bsdf_tab_meta``: JSON of the whole ``Table.meta``.
- ``bsdf_tab_version``: the bsdf-tab version that wrote the file.
"""

from __future__ import annotations

import json
import math
import os
import tempfile
import uuid
from pathlib import Path

import numpy as np
import OpenEXR

from .table import Table, json_default

__all__ = ["write_exr", "read_exr", "exr_bytes", "read_exr_bytes", "layout_description", "ATTR_PREFIX"]

ATTR_PREFIX = "bsdf_tab_"
_EXR_MAGIC = b"\x76\x2f\x31\x01"


def _version(table: Table) -> str:
    version = table.meta.get("version")
    if version:
        return str(version)
    import bsdf_tab  # at call time the package is fully imported

    return str(getattr(bsdf_tab, "__version__", "unknown"))


def _image_shape(shape: tuple[int, ...]) -> tuple[int, int]:
    """(height, width) of the image that stores a table of ``shape``."""
    return math.prod(shape[:-1]), shape[-1]


def layout_description(axes: dict[str, np.ndarray]) -> str:
    """The pixel layout of a table with ``axes``, in words (``bsdf_tab_layout``)."""
    names = list(axes)
    sizes = [len(a) for a in axes.values()]
    height, width = _image_shape(tuple(sizes))
    columns = f"column j = index of {names[-1]} ({sizes[-1]})"
    if len(names) == 1:
        return f"float32, height 1, width {width}: row 0, {columns}"
    if len(names) == 2:
        rows = f"row i = index of {names[0]} ({sizes[0]})"
        return f"float32, height {height}, width {width}: {rows}, {columns}; pixel[i, j] = {_idx(names)}"
    strides = [math.prod(sizes[k + 1 : -1]) for k in range(len(sizes) - 1)]
    terms = " + ".join(f"i_{n}*{s}" if s > 1 else f"i_{n}" for n, s in zip(names[:-1], strides))
    return (
        f"float32, height {height}, width {width}: {names[0]} slices stacked vertically, "
        f"row = {terms}, {columns}; pixel[row, j] = {_idx(names)}"
    )


def _idx(names: list[str]) -> str:
    return "channel[" + ", ".join(f"i_{n}" for n in names[:-1]) + ", j]"


def _header(table: Table) -> dict:
    spec = table.meta.get("spec", {})
    axes = [[name, [float(x) for x in values]] for name, values in table.axes.items()]
    return {
        "compression": OpenEXR.ZIP_COMPRESSION,
        "type": OpenEXR.scanlineimage,
        ATTR_PREFIX + "spec": json.dumps(spec, default=json_default),
        ATTR_PREFIX + "axes": json.dumps(axes),
        ATTR_PREFIX + "channels": json.dumps(list(table.channels)),
        ATTR_PREFIX + "layout": layout_description(table.axes),
        ATTR_PREFIX + "meta": json.dumps(table.meta, default=json_default),
        ATTR_PREFIX + "version": _version(table),
    }


def _pixels(table: Table) -> dict[str, np.ndarray]:
    height, width = _image_shape(table.shape)
    return {
        name: np.ascontiguousarray(values, dtype=np.float32).reshape(height, width)
        for name, values in table.channels.items()
    }


def write_exr(table: Table, path) -> None:
    """Write ``table`` to the OpenEXR file ``path`` (atomically).

    Parameters
    ----------
    table : Table
        The table; its channels are stored as float32.
    path : str or os.PathLike
        Destination file. Its folder must exist.

    Raises
    ------
    FileNotFoundError
        If the destination folder does not exist.
    OSError
        If OpenEXR cannot write the file.
    """
    path = Path(path)
    folder = path.parent if str(path.parent) else Path(".")
    if not folder.is_dir():
        raise FileNotFoundError(f"cannot write {path}: folder {folder} does not exist")
    if not table.channels:
        raise ValueError("cannot write a table without channels to EXR")
    # a fresh name created by OpenEXR itself, so the file gets the usual umask permissions
    tmp = str(folder / f".{path.name}.{os.getpid()}.{uuid.uuid4().hex}.tmp")
    try:
        with OpenEXR.File(_header(table), _pixels(table)) as exr:
            exr.write(tmp)
        os.replace(tmp, path)
    except RuntimeError as exc:
        raise OSError(f"cannot write {path}: {exc}") from None
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def exr_bytes(table: Table) -> bytes:
    """The bytes of the EXR file that :func:`write_exr` writes for ``table``."""
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "table.exr"
        write_exr(table, path)
        return path.read_bytes()


def _check_is_exr(path: Path) -> None:
    if not path.exists():
        raise FileNotFoundError(f"no such file: {path}")
    if not path.is_file():
        raise ValueError(f"{path}: not a file")
    with open(path, "rb") as fh:
        if fh.read(4) != _EXR_MAGIC:
            raise ValueError(f"{path}: not an OpenEXR file")


def _json_attr(header: dict, name: str, path) -> object:
    key = ATTR_PREFIX + name
    if key not in header:
        raise ValueError(f"{path}: not a bsdf-tab table (no {key} header attribute)")
    try:
        return json.loads(header[key])
    except (TypeError, json.JSONDecodeError) as exc:
        raise ValueError(f"{path}: header attribute {key} is not valid JSON: {exc}") from None


def _axes_from_header(header: dict, path) -> dict[str, np.ndarray]:
    raw = _json_attr(header, "axes", path)
    try:
        return {str(name): np.asarray(values, dtype=np.float64) for name, values in raw}
    except (TypeError, ValueError):
        raise ValueError(f"{path}: header attribute {ATTR_PREFIX}axes is malformed") from None


def _channels_from_pixels(exr_channels: dict, header: dict, shape: tuple[int, ...], path) -> dict:
    order = _json_attr(header, "channels", path) if ATTR_PREFIX + "channels" in header else sorted(exr_channels)
    height, width = _image_shape(shape)
    channels = {}
    for name in order:
        if name not in exr_channels:
            raise ValueError(f"{path}: channel {name!r} listed in the header is missing")
        pixels = exr_channels[name]
        if pixels.shape != (height, width):
            raise ValueError(f"{path}: channel {name!r} is {pixels.shape}, the axes need {(height, width)}")
        channels[name] = pixels.astype(np.float32, copy=False).reshape(shape)
    return channels


def read_exr(path) -> Table:
    """Read a table written by :func:`write_exr`.

    Parameters
    ----------
    path : str or os.PathLike
        The EXR file.

    Returns
    -------
    Table
        Axes as float64 exactly as written, channels as float32 arrays shaped
        by the axes, meta from the JSON header.

    Raises
    ------
    FileNotFoundError
        If ``path`` does not exist.
    ValueError
        If the file is not an OpenEXR file or not a bsdf-tab table.
    """
    path = Path(path)
    _check_is_exr(path)
    try:
        with OpenEXR.File(str(path), separate_channels=True) as exr:
            # copies: the File clears its header and channel dicts on close
            header = dict(exr.header())
            exr_channels = {name: np.array(ch.pixels) for name, ch in exr.channels().items()}
    except RuntimeError as exc:
        raise ValueError(f"{path}: cannot read OpenEXR file: {exc}") from None
    axes = _axes_from_header(header, path)
    if not axes:
        raise ValueError(f"{path}: header attribute {ATTR_PREFIX}axes has no axes")
    meta = _json_attr(header, "meta", path)
    if not isinstance(meta, dict):
        raise ValueError(f"{path}: header attribute {ATTR_PREFIX}meta is not a JSON object")
    shape = tuple(len(a) for a in axes.values())
    channels = _channels_from_pixels(exr_channels, header, shape, path)
    return Table(axes, channels, meta)


def read_exr_bytes(data: bytes) -> Table:
    """Read a table from the bytes of an EXR file (see :func:`read_exr`)."""
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "table.exr"
        path.write_bytes(data)
        return read_exr(path)
