"""Writing a table too large to hold: blocks of texels in, an ``exr`` or ``npz`` file out.

:func:`write_blocks` takes the axes, the channel names, the metadata and an iterator of
blocks ``(start, values)`` and writes the file the in-memory writer writes for the same table:

- ``exr``: the header of :func:`bsdf_tab.io.exr.header_attributes` and the layout of
  :mod:`bsdf_tab.io.exr`, scanline by scanline; byte for byte the file of
  :func:`~bsdf_tab.io.exr.write_exr` for the same table (float32 channels);
- ``npz``: the members of :mod:`bsdf_tab.io.npz` in its order, each channel member streamed
  (float64 by default); ``numpy.load`` reads the same arrays as from
  :func:`~bsdf_tab.io.npz.npz_bytes`.

Both formats need the metadata before (EXR header) or beside (npz) the values, and hold the
channels apart (npz) or interleaved by scanline (EXR), while blocks arrive texel-major with
all channels. So the values go first to a raw scratch file next to the output (channel-major,
in the output's dtype) with plain writes, and the output is then written from it in chunks
of a few MiB: resident memory stays at about one block, disk needs about twice the output's
uncompressed size. The output is written atomically (:mod:`bsdf_tab.io.atomic`); the scratch
file is removed whatever happens.
"""

from __future__ import annotations

import math
import zipfile
from pathlib import Path
from typing import Callable, Iterable, Mapping

import numpy as np
import OpenEXR

from .atomic import atomic_path, temp_path
from .base import ERR_SUFFIX, FormatError, TableParts, check_folder, value_channels
from .exr import COMPRESSION, header_attributes, image_shape, write_exr
from .npz import head_members, tail_members
from .registry import format_for
from .storage import FORMAT_STORAGE, bytes_per_texel, get_encoding

__all__ = ["STREAM_FORMATS", "StreamedTable", "can_stream", "write_blocks", "write_stream"]

#: The formats :func:`write_blocks` writes.
STREAM_FORMATS = ("exr", "npz")
#: Bytes per chunk read back from the scratch file.
CHUNK_BYTES = 1 << 19


class _Scratch:
    """Channel-major ``(n_channels, n_texels)`` values in a raw file, by flat texel ranges."""

    def __init__(self, fh, n_channels: int, n_texels: int, dtype) -> None:
        self.fh = fh
        self.n_channels = n_channels
        self.n_texels = n_texels
        self.dtype = np.dtype(dtype)
        self.plane_bytes = n_texels * self.dtype.itemsize

    def write(self, start: int, values: np.ndarray) -> None:
        size = self.dtype.itemsize
        for c in range(self.n_channels):
            self.fh.seek(c * self.plane_bytes + start * size)
            self.fh.write(np.ascontiguousarray(values[c], dtype=self.dtype).tobytes())

    def read(self, c: int, start: int, end: int) -> np.ndarray:
        size = self.dtype.itemsize
        self.fh.seek(c * self.plane_bytes + start * size)
        return np.frombuffer(self.fh.read((end - start) * size), dtype=self.dtype)


def can_stream(fmt: str) -> bool:
    """Whether :func:`write_blocks` writes format ``fmt`` (a format name or a file name)."""
    return format_for(fmt).name in STREAM_FORMATS


def _stream_format(path: Path, fmt: str | None) -> str:
    name = format_for(fmt if fmt is not None else path).name
    if name not in STREAM_FORMATS:
        raise FormatError("format", f"{name} cannot be written block by block; streaming writes "
                                    f"{' or '.join(STREAM_FORMATS)}")
    return name


def _check_block(start, values, channels: list[str], n_texels: int, index: int) -> tuple[int, np.ndarray | list]:
    n_channels = len(channels)
    if isinstance(values, Mapping):
        missing = [c for c in channels if c not in values]
        if missing:
            raise ValueError(f"block {index}: no values for channel(s) {', '.join(missing)}")
        flat = [np.asarray(values[c]).reshape(-1) for c in channels]
        sizes = {v.size for v in flat}
        if len(sizes) != 1:
            raise ValueError(f"block {index}: the channels have different sizes {sorted(sizes)}")
        count = sizes.pop()
    else:
        arr = np.asarray(values)
        if arr.ndim < 1 or arr.shape[0] != n_channels:
            raise ValueError(f"block {index}: values of shape {arr.shape}; the first axis must be the "
                             f"{n_channels} channels")
        flat = arr.reshape(n_channels, -1)
        count = flat.shape[1]
    start = int(start)
    if start < 0 or start + count > n_texels:
        raise ValueError(f"block {index}: texels {start}..{start + count - 1} are outside the "
                         f"table's {n_texels} texels")
    return start, flat


def _check_coverage(spans: list[tuple[int, int]], n_texels: int) -> None:
    end = 0
    for start, stop in sorted(spans):
        if start < end:
            raise ValueError(f"blocks overlap at texel {start}")
        if start > end:
            raise ValueError(f"no block gave texels {end}..{start - 1}")
        end = stop
    if end < n_texels:
        raise ValueError(f"no block gave texels {end}..{n_texels - 1} (of {n_texels})")


def _write_exr(out: Path, store: _Scratch, axes: dict, channels: list[str], meta: dict) -> None:
    shape = tuple(len(a) for a in axes.values())
    height, width = image_shape(shape)
    attributes = header_attributes(axes, channels, meta)
    if not hasattr(OpenEXR, "OutputFile"):  # pragma: no cover - OpenEXR without the scanline writer
        values = {name: store.read(c, 0, store.n_texels).reshape(shape) for c, name in enumerate(channels)}
        write_exr(TableParts(axes, values, meta), out)
        return
    import Imath  # the legacy API's attribute types, shipped with OpenEXR

    header = OpenEXR.Header(width, height)  # increasing y, windows as OpenEXR.File writes them
    header["compression"] = Imath.Compression(getattr(Imath.Compression, COMPRESSION.name))
    proto = header["channels"]["R"]  # a FLOAT channel description
    header["channels"] = {name: proto for name in channels}
    header["type"] = b"scanlineimage"
    for key, value in attributes.items():
        header[key] = value.encode("utf-8")
    rows = max(1, CHUNK_BYTES // (width * 4 * len(channels)))
    with atomic_path(out) as tmp:
        exr = OpenEXR.OutputFile(str(tmp), header)
        try:
            for r0 in range(0, height, rows):
                r1 = min(height, r0 + rows)
                exr.writePixels(
                    {name: store.read(c, r0 * width, r1 * width).tobytes() for c, name in enumerate(channels)},
                    r1 - r0,
                )
        finally:
            exr.close()


def _write_npz(out: Path, store: _Scratch, axes: dict, channels: list[str], meta: dict) -> None:
    shape = tuple(len(a) for a in axes.values())
    step = max(1, CHUNK_BYTES // store.dtype.itemsize)
    with atomic_path(out) as tmp:
        with zipfile.ZipFile(tmp, "w", compression=zipfile.ZIP_DEFLATED, allowZip64=True) as zf:

            def member(name: str, arr: np.ndarray) -> None:
                with zf.open(name + ".npy", "w", force_zip64=True) as fh:
                    np.lib.format.write_array(fh, arr, allow_pickle=False)

            for name, arr in head_members(axes).items():
                member(name, arr)
            for c, name in enumerate(channels):
                with zf.open(f"channel/{name}.npy", "w", force_zip64=True) as fh:
                    header = {"descr": np.lib.format.dtype_to_descr(store.dtype), "fortran_order": False,
                              "shape": shape}
                    np.lib.format.write_array_header_1_0(fh, header)
                    for t0 in range(0, store.n_texels, step):
                        fh.write(store.read(c, t0, min(store.n_texels, t0 + step)).tobytes())
            for name, arr in tail_members(channels, meta).items():
                member(name, arr)


def write_blocks(
    path,
    axes: dict,
    channels: Iterable[str],
    blocks: Iterable[tuple[int, np.ndarray]],
    meta: dict | Callable[[], dict],
    *,
    fmt: str | None = None,
    dtype=np.float64,
) -> dict:
    """Write a table given as blocks of texels to ``path`` (``exr`` or ``npz``), atomically.

    Parameters
    ----------
    path : str or os.PathLike
        Destination; its folder must exist. The format is its ending (``.exr``, ``.npz``)
        unless ``fmt`` is given.
    axes : dict
        Axis name -> 1-D values, in axis order (the table's shape is their lengths).
    channels : iterable of str
        Channel names, in the order of the values' first axis.
    blocks : iterable of (int, array)
        ``(start, values)``: ``start`` is the flat (row-major over the axes) index of the
        block's first texel; ``values`` is an array with the channels first and the block's
        texels after, in any shape that flattens to them (``(n_channels, nb, n1, n2)`` for
        ``nb`` whole axis-0 slices starting at slice ``i0``: ``start = i0 * n1 * n2``), or a
        mapping channel name -> array of the block's texels. Blocks may come in any order but
        must cover every texel exactly once.
    meta : dict or callable
        The table's metadata, or a function of no arguments that returns it, called once after
        the last block (for metadata that depends on the values, such as ``max_error``).
    fmt : {"exr", "npz"}, optional
        The format (default: from the ending of ``path``).
    dtype : numpy dtype
        The npz channel dtype (default float64); EXR channels are always float32.

    Returns
    -------
    dict
        The metadata written.

    Raises
    ------
    FormatError
        If the format is unknown or cannot be streamed (only ``exr`` and ``npz`` can).
    FileNotFoundError
        If the destination folder does not exist.
    ValueError
        If a block has the wrong number of channels or falls outside the table, or the
        blocks overlap or leave texels out. Nothing is written then.

    Examples
    --------
    >>> def blocks():                                        # doctest: +SKIP
    ...     for i0 in range(n0):
    ...         yield i0 * n1 * n2, compute_slice(i0)        # shape (4, n1, n2)
    >>> write_blocks("big.exr", axes, ["f_r", "f_t", "f_r_err", "f_t_err"], blocks(),
    ...              lambda: {"spec": spec, "max_error": max_seen})     # doctest: +SKIP
    """
    path = Path(path)
    fmt = _stream_format(path, fmt)
    folder = check_folder(path)
    axes = {str(n): np.asarray(a, dtype=np.float64) for n, a in axes.items()}
    if not axes:
        raise ValueError("a table needs at least one axis")
    channels = [str(c) for c in channels]
    if not channels:
        raise ValueError(f"cannot write a table without channels to {fmt}")
    n_texels = math.prod(len(a) for a in axes.values())
    store_dtype = np.float32 if fmt == "exr" else np.dtype(dtype)
    scratch = temp_path(folder / path.name, ".raw")
    try:
        with open(scratch, "w+b") as raw:
            store = _Scratch(raw, len(channels), n_texels, store_dtype)
            spans: list[tuple[int, int]] = []
            for index, (start, values) in enumerate(blocks):
                start, flat = _check_block(start, values, channels, n_texels, index)
                store.write(start, flat)
                spans.append((start, start + len(flat[0])))
            _check_coverage(spans, n_texels)
            meta = dict(meta() if callable(meta) else meta)
            writer = _write_exr if fmt == "exr" else _write_npz
            writer(path, store, axes, channels, meta)
    finally:
        try:
            scratch.unlink()
        except FileNotFoundError:
            pass
    return meta


class StreamedTable:
    """What a streaming write wrote: axes, channel names and metadata (no channel data).

    Has the ``axes``, ``meta``, ``shape``, ``kind`` and ``max_error()`` of a table, for the
    one-line summaries a caller prints.
    """

    def __init__(self, axes: dict, meta: dict, channel_names: Iterable[str]) -> None:
        self.axes = axes
        self.meta = meta
        self.channel_names = list(channel_names)

    @property
    def kind(self) -> str | None:
        """The table kind from ``meta["spec"]["table"]``, or None."""
        spec = self.meta.get("spec")
        return spec.get("table") if isinstance(spec, dict) else None

    @property
    def shape(self) -> tuple[int, ...]:
        return tuple(len(a) for a in self.axes.values())

    def max_error(self) -> dict[str, float]:
        """``meta["max_error"]`` (value channel -> largest error estimate)."""
        return dict(self.meta.get("max_error") or {})

    def __repr__(self) -> str:
        axes = " x ".join(f"{n}[{len(a)}]" for n, a in self.axes.items())
        return f"StreamedTable({self.kind or 'table'}: {axes}; channels {', '.join(self.channel_names)})"


def write_stream(stream, path, fmt: str | None = None) -> StreamedTable:
    """Write a stream of axis-0 slabs (such as ``bsdf_tab.api.iter_blocks``'s) with :func:`write_blocks`.

    Parameters
    ----------
    stream : iterable
        Has ``axes`` (dict), ``channel_names`` (list), iterates ``(start, end, channels)``
        with ``channels`` a mapping name -> values of the axis-0 slices ``start:end``, and
        ``meta()`` gives the metadata once every block was produced.
    path : str or os.PathLike
        Destination (``.exr`` or ``.npz``).
    fmt : str, optional
        ``exr`` or ``npz`` (default: from the ending of ``path``).

    Returns
    -------
    StreamedTable
        The axes, channel names and metadata written.
    """
    axes = stream.axes
    names = list(stream.channel_names)
    per_slice = math.prod(len(a) for a in list(axes.values())[1:])
    name = _stream_format(Path(path), fmt)
    meter = _StorageMeter(names, FORMAT_STORAGE[name][0], name)

    def blocks():
        for start, _end, channels in stream:
            meter.add(channels)
            yield start * per_slice, channels

    def meta() -> dict:
        out = dict(stream.meta() if callable(stream.meta) else stream.meta)
        out.setdefault("storage", meter.report())
        return out

    meta = write_blocks(path, axes, names, blocks(), meta, fmt=name)
    return StreamedTable(dict(axes), meta, names)


class _StorageMeter:
    """:func:`bsdf_tab.io.storage.storage_report` of a table seen block by block (same keys)."""

    def __init__(self, names: list[str], encoding: str, fmt: str) -> None:
        self.encoding, self.fmt = encoding, fmt
        self.enc = None if encoding == "float64" else get_encoding(encoding)
        self.values = value_channels(names)
        self.has_err = {n: n + ERR_SUFFIX in names for n in self.values}
        self.acc = {n: {"integration_error": None, "storage_error": 0.0, "clamp_error": 0.0, "total_error": 0.0,
                        "min": None, "max": None} for n in self.values}

    def add(self, channels: Mapping) -> None:
        for n in self.values:
            x = np.asarray(channels[n], dtype=np.float64)
            if not x.size:
                continue
            c = self.acc[n]
            finite = np.isfinite(x)
            if self.enc is None:
                stored = np.zeros_like(x)
            else:
                with np.errstate(invalid="ignore"):
                    stored = np.where(finite, np.abs(self.enc.quantize(x) - x), np.inf)
            total = stored
            if self.has_err[n]:
                err = np.asarray(channels[n + ERR_SUFFIX], dtype=np.float64)
                e = float(np.max(err))
                c["integration_error"] = e if c["integration_error"] is None else max(c["integration_error"], e)
                total = stored + err
            c["storage_error"] = max(c["storage_error"], float(np.max(stored)))
            c["total_error"] = max(c["total_error"], float(np.max(total)))
            if finite.any():
                lo, hi = float(np.min(x[finite])), float(np.max(x[finite]))
                c["min"] = lo if c["min"] is None else min(c["min"], lo)
                c["max"] = hi if c["max"] is None else max(c["max"], hi)

    def report(self) -> dict:
        totals = [c["total_error"] for c in self.acc.values()]
        return {
            "encoding": self.encoding,
            "format": self.fmt,
            "bytes_per_texel": bytes_per_texel(self.encoding, len(self.values)),
            "channels": {n: dict(c) for n, c in self.acc.items()},
            "max_total_error": max(totals) if totals else 0.0,
        }
