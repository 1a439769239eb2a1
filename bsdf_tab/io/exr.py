"""``exr``: float32 OpenEXR, the table's own file format (exact round trip of float32 values).

Layout
------
Every table channel (``E``, ``E_err``, ``R``, ``T``, ...) is one FLOAT (32-bit) EXR channel
of the same name. A table of shape ``(n0, n1, ..., nk)`` is flattened row-major over all axes
but the last, and the last axis runs along the image width:

- 1-D ``(n,)``: height 1, width n; ``pixel[0, j] = channel[j]``.
- 2-D ``(n0, n1)``: height n0, width n1; ``pixel[i, j] = channel[i, j]``.
- 3-D ``(n0, n1, n2)``: the n0 slices stacked vertically: height n0*n1, width n2;
  ``pixel[i0*n1 + i1, j] = channel[i0, i1, j]``.

Row 0 is the top scanline of the image (the first row of the data window). Scanline image,
ZIP compression.

Header attributes (:func:`header_attributes`; all strings, so that any EXR reader can show
them and no value is rounded to 32 bits):

- ``bsdf_tab_spec``: JSON of the normalized spec.
- ``bsdf_tab_axes``: JSON ``[[name, [values...]], ...]`` in axis order, floats written with
  ``repr`` (exact float64).
- ``bsdf_tab_channels``: JSON list of the channel names in table order (EXR itself sorts
  channels by name).
- ``bsdf_tab_layout``: the layout above, in words, for this table's axes.
- ``bsdf_tab_meta``: JSON of the whole ``meta``.
- ``bsdf_tab_version``: the bsdf-tab version that wrote the file (``meta["version"]`` if set).

The streaming writer (:mod:`bsdf_tab.io.stream`) writes the same header and layout scanline
by scanline: for the same table its file is byte for byte the file :func:`write_exr` writes.
"""

from __future__ import annotations

import json
import math
import struct
import tempfile
from pathlib import Path
from typing import Callable

import numpy as np
import OpenEXR

from ..version import __version__
from .atomic import atomic_path
from .base import Format, FormatError, build, json_default, shape_of

__all__ = [
    "ATTR_PREFIX",
    "EXR_MAGIC",
    "FORMAT",
    "header_attributes",
    "image_shape",
    "layout_description",
    "write_image",
    "write_exr",
    "exr_bytes",
    "read_exr",
    "read_exr_bytes",
    "read_channels",
    "check_exr_file",
    "exr_damage",
]

ATTR_PREFIX = "bsdf_tab_"
#: The first four bytes of every OpenEXR file.
EXR_MAGIC = b"\x76\x2f\x31\x01"
#: The non-bsdf-tab header entries of every file written (OpenEXR 3 ``File`` header keys).
COMPRESSION = OpenEXR.ZIP_COMPRESSION
STORAGE = OpenEXR.scanlineimage


def image_shape(shape: tuple[int, ...]) -> tuple[int, int]:
    """(height, width) of the image that stores a table of ``shape``."""
    return math.prod(shape[:-1]), shape[-1]


def _idx(names: list[str]) -> str:
    return "channel[" + ", ".join(f"i_{n}" for n in names[:-1]) + ", j]"


def layout_description(axes: dict, sample: str = "float32") -> str:
    """The pixel layout of a table with ``axes``, in words (``bsdf_tab_layout``).

    Parameters
    ----------
    axes : dict
        Axis name -> values, in axis order.
    sample : str
        The pixel type in words (``"float32"``, ``"float16 (HALF)"``).
    """
    names = list(axes)
    sizes = [len(a) for a in axes.values()]
    height, width = image_shape(tuple(sizes))
    columns = f"column j = index of {names[-1]} ({sizes[-1]})"
    if len(names) == 1:
        return f"{sample}, height 1, width {width}: row 0, {columns}"
    if len(names) == 2:
        rows = f"row i = index of {names[0]} ({sizes[0]})"
        return f"{sample}, height {height}, width {width}: {rows}, {columns}; pixel[i, j] = {_idx(names)}"
    strides = [math.prod(sizes[k + 1 : -1]) for k in range(len(sizes) - 1)]
    terms = " + ".join(f"i_{n}*{s}" if s > 1 else f"i_{n}" for n, s in zip(names[:-1], strides))
    return (
        f"{sample}, height {height}, width {width}: {names[0]} slices stacked vertically, "
        f"row = {terms}, {columns}; pixel[row, j] = {_idx(names)}"
    )


def header_attributes(axes: dict, channel_names, meta: dict, *, sample: str = "float32") -> dict[str, str]:
    """The ``bsdf_tab_*`` header attributes of a table (the one header of every EXR writer).

    Parameters
    ----------
    axes : dict
        Axis name -> 1-D values, in axis order.
    channel_names : iterable of str
        The channel names in table order.
    meta : dict
        The table's metadata (``meta["spec"]`` becomes ``bsdf_tab_spec``).
    sample : str
        The pixel type in words, for ``bsdf_tab_layout``.

    Returns
    -------
    dict[str, str]
        Attribute name -> string value (see the module doc).
    """
    spec = meta.get("spec", {})
    axes_json = [[name, [float(x) for x in values]] for name, values in axes.items()]
    return {
        ATTR_PREFIX + "spec": json.dumps(spec, default=json_default),
        ATTR_PREFIX + "axes": json.dumps(axes_json),
        ATTR_PREFIX + "channels": json.dumps(list(channel_names)),
        ATTR_PREFIX + "layout": layout_description(axes, sample),
        ATTR_PREFIX + "meta": json.dumps(meta, default=json_default),
        ATTR_PREFIX + "version": str(meta.get("version") or __version__),
    }


def write_image(path, attributes: dict[str, str], pixels: dict[str, np.ndarray]) -> Path:
    """Write an EXR image atomically: ``attributes`` in the header, ``pixels`` as channels.

    Parameters
    ----------
    path : str or os.PathLike
        Destination; its folder must exist.
    attributes : dict[str, str]
        Extra header attributes (string values).
    pixels : dict[str, numpy.ndarray]
        Channel name -> 2-D (height, width) float32 (FLOAT) or float16 (HALF) array.

    Raises
    ------
    FileNotFoundError
        If the destination folder does not exist.
    OSError
        If OpenEXR cannot write the file.
    """
    path = Path(path)
    header = {"compression": COMPRESSION, "type": STORAGE, **attributes}
    with atomic_path(path) as tmp:
        try:
            with OpenEXR.File(header, pixels) as exr:
                exr.write(str(tmp))
        except RuntimeError as exc:
            raise OSError(f"cannot write {path}: {exc}") from None
    return path


def _check_channels(table) -> None:
    if not table.channels:
        raise ValueError("cannot write a table without channels to EXR")


def write_exr(table, path) -> list[Path]:
    """Write ``table`` to the OpenEXR file ``path`` (atomically; see the module doc).

    Parameters
    ----------
    table : table-like
        ``axes``, ``channels`` (stored as float32) and ``meta``.
    path : str or os.PathLike
        Destination file. Its folder must exist.

    Returns
    -------
    list of Path
        ``[path]``.

    Raises
    ------
    FileNotFoundError
        If the destination folder does not exist.
    ValueError
        If the table has no channels.
    OSError
        If OpenEXR cannot write the file.
    """
    _check_channels(table)
    height, width = image_shape(shape_of(table))
    pixels = {
        name: np.ascontiguousarray(values, dtype=np.float32).reshape(height, width)
        for name, values in table.channels.items()
    }
    return [write_image(path, header_attributes(table.axes, table.channels, table.meta), pixels)]


def exr_bytes(table) -> bytes:
    """The bytes of the EXR file that :func:`write_exr` writes for ``table``."""
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "table.exr"
        write_exr(table, path)
        return path.read_bytes()


# --------------------------------------------------------------------------- reading

#: Scanlines per chunk of each OpenEXR compression (the ``compression`` attribute's value).
_LINES_PER_CHUNK = {0: 1, 1: 1, 2: 1, 3: 16, 4: 32, 5: 16, 6: 32, 7: 32, 8: 32, 9: 256, 10: 256, 11: 32}
#: Version-field flags of files :func:`exr_damage` does not walk (tiled, deep, multi-part).
_NOT_WALKED = 0x200 | 0x800 | 0x1000


def _read_exact(fh, n: int, what: str) -> bytes:
    data = fh.read(n)
    if len(data) != n:
        raise EOFError(what)
    return data


def _header_attrs(fh) -> dict[str, bytes]:
    """The header attributes (name -> raw value) of a single-part file, ``fh`` after the version."""
    attrs = {}
    while True:
        name = _cstring(fh)
        if not name:
            return attrs
        _cstring(fh)  # the attribute's type name
        (size,) = struct.unpack("<i", _read_exact(fh, 4, "header cut short"))
        if size < 0:  # a negative size is no header OpenEXR wrote
            raise EOFError(f"attribute {name!r} has size {size}")
        attrs[name] = _read_exact(fh, size, f"header cut short in attribute {name!r}")


def _cstring(fh, limit: int = 256) -> str:
    out = bytearray()
    while len(out) <= limit:  # names are at most 255 bytes (long-name files)
        c = _read_exact(fh, 1, "header cut short")
        if c == b"\0":
            return out.decode("latin-1")
        out += c
    raise EOFError("header name too long")


def exr_damage(fh, size: int) -> str | None:
    """What is structurally wrong with a scanline OpenEXR file, or None.

    Walks the header, the chunk offset table and every chunk's leader (scanline and packed
    size) without decoding pixels, so a truncated or damaged file is named before OpenEXR reads
    it (its C++ library prints warnings on the process' stdout and stderr for such files).
    Tiled, deep and multi-part files and unknown compressions are not walked (None).

    Parameters
    ----------
    fh : binary file object
        Positioned at the start of the file.
    size : int
        The file's size in bytes.

    Returns
    -------
    str or None
        A short description of the damage (``"chunk 3 of 4 runs past the end of the file"``).
    """
    try:
        if _read_exact(fh, 4, "not an OpenEXR file") != EXR_MAGIC:
            return "not an OpenEXR file"
        (version,) = struct.unpack("<i", _read_exact(fh, 4, "no version field"))
        if version & _NOT_WALKED:
            return None
        attrs = _header_attrs(fh)
        if "dataWindow" not in attrs or "compression" not in attrs:
            return "the header has no dataWindow or compression"
        lines = _LINES_PER_CHUNK.get(attrs["compression"][0])
        if lines is None or len(attrs["dataWindow"]) != 16:
            return None
        _x0, y0, _x1, y1 = struct.unpack("<4i", attrs["dataWindow"])
        chunks = -(-(y1 - y0 + 1) // lines)
        table_end = fh.tell() + 8 * chunks
        offsets = struct.unpack(f"<{chunks}Q", _read_exact(fh, 8 * chunks, "the chunk offset table is cut short"))
    except EOFError as exc:
        return str(exc)
    except (struct.error, IndexError):
        return "malformed header"
    for i, offset in enumerate(offsets):
        if not table_end <= offset <= size - 8:
            return f"chunk {i + 1} of {chunks} starts past the end of the file"
        fh.seek(offset + 4)
        (packed,) = struct.unpack("<i", fh.read(4))
        if packed < 0 or offset + 8 + packed > size:
            return f"chunk {i + 1} of {chunks} runs past the end of the file"
    return None


def check_exr_file(path, name=None) -> None:
    """Raise :class:`~bsdf_tab.io.base.FormatError` naming ``name`` (default ``path``) if the
    OpenEXR file ``path`` is truncated or damaged (:func:`exr_damage`)."""
    path = Path(path)
    with open(path, "rb") as fh:
        damage = exr_damage(fh, path.stat().st_size)
    if damage is not None:
        raise FormatError(None, f"{name or path}: truncated or corrupt OpenEXR file ({damage})")


def read_channels(path, name=None) -> tuple[dict, dict]:
    """(header, channel name -> pixels) of the OpenEXR file ``path``, checked first.

    A damaged file is one :class:`~bsdf_tab.io.base.FormatError` naming ``name`` (the user's
    file; default ``path``) instead of OpenEXR's own messages.
    """
    check_exr_file(path, name)
    try:
        with OpenEXR.File(str(path), separate_channels=True) as exr:
            # copies: the File clears its header and channel dicts on close
            header = dict(exr.header())
            channels = {key: np.array(ch.pixels) for key, ch in exr.channels().items()}
    except (RuntimeError, ValueError) as exc:  # OpenEXR's errors for files it cannot decode
        raise FormatError(None, f"{name or path}: truncated or corrupt OpenEXR file ({' '.join(str(exc).split())})") from None
    return header, channels



def _check_is_exr(path: Path) -> None:
    if not path.exists():
        raise FileNotFoundError(f"no such file: {path}")
    if not path.is_file():
        raise ValueError(f"{path}: not a file")
    with open(path, "rb") as fh:
        if fh.read(4) != EXR_MAGIC:
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
    height, width = image_shape(shape)
    channels = {}
    for name in order:
        if name not in exr_channels:
            raise ValueError(f"{path}: channel {name!r} listed in the header is missing")
        pixels = exr_channels[name]
        if pixels.shape != (height, width):
            raise ValueError(f"{path}: channel {name!r} is {pixels.shape}, the axes need {(height, width)}")
        channels[name] = pixels.astype(np.float32, copy=False).reshape(shape)
    return channels


def read_exr(path, factory: Callable | None = None):
    """Read a table written by :func:`write_exr` (or the half-float writer).

    Parameters
    ----------
    path : str or os.PathLike
        The EXR file.
    factory : callable, optional
        ``factory(axes, channels, meta)`` builds the result (``bsdf_tab.Table``); default
        :class:`~bsdf_tab.io.base.TableParts`.

    Returns
    -------
    TableParts or what ``factory`` returns
        Axes as float64 exactly as written, channels as float32 arrays shaped by the axes
        (HALF channels widened to float32 exactly), meta from the JSON header.

    Raises
    ------
    FileNotFoundError
        If ``path`` does not exist.
    ValueError
        If the file is not an OpenEXR file or not a bsdf-tab table.
    """
    path = Path(path)
    _check_is_exr(path)
    header, exr_channels = read_channels(path)
    axes = _axes_from_header(header, path)
    if not axes:
        raise ValueError(f"{path}: header attribute {ATTR_PREFIX}axes has no axes")
    meta = _json_attr(header, "meta", path)
    if not isinstance(meta, dict):
        raise ValueError(f"{path}: header attribute {ATTR_PREFIX}meta is not a JSON object")
    shape = tuple(len(a) for a in axes.values())
    channels = _channels_from_pixels(exr_channels, header, shape, path)
    return build(axes, channels, meta, factory)


def read_exr_bytes(data: bytes, factory: Callable | None = None):
    """Read a table from the bytes of an EXR file (see :func:`read_exr`)."""
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "table.exr"
        path.write_bytes(data)
        return read_exr(path, factory)


FORMAT = Format(
    name="exr",
    suffixes=(".exr",),
    description="OpenEXR, float32 channels, spec/axes/meta as JSON header attributes",
    write=write_exr,
    media_type="image/x-exr",
    media_aliases=("image/exr", "image/aces"),
    to_bytes=exr_bytes,
    read=read_exr,
    from_bytes=read_exr_bytes,
)
