"""Reading and writing tables: one registry of formats, one atomic write, one streaming writer.

Formats
-------
Every format has one name, used alike by the Python API, the CLI (``--format``), engine
presets and the HTTP service (``format=``), and one meaning under that name:

- ``exr`` (``.exr``, ``image/x-exr``): float32 EXR, spec / axes / meta as JSON header
  attributes; exact float32 round trip.
- ``half-exr`` (``.half.exr``, ``image/x-exr``): the same layout with HALF channels; the
  rounding is measured and added to the error channels.
- ``npz`` (``.npz``, ``application/x-npz``): axes, channels, meta; lossless (the service's
  master).
- ``npy`` (``.npy``, ``application/x-npy``): ONE structured array shaped by the axes, a
  float64 field per channel; no axes, no meta (write-only).
- ``npy-channels`` (``.meta.json``, no media type: several files): one float32 ``.npy`` per
  channel, one float64 ``.npy`` per axis, and the sidecar ``S.meta.json`` that names the set.
- ``json`` (``.json``, ``application/json``): axes, shape, channels (``null`` for
  non-finite values), meta; strict, compact.
- ``h`` (``.h``, ``text/x-c``): a C99 / C++ header of static arrays (write-only).
- ``ktx2`` (``.ktx2``, ``image/ktx2``): a KTX 2.0 GPU texture (R16G16_SFLOAT, R32G32_SFLOAT,
  R16G16_UNORM, R8G8_UNORM, A2B10G10R10_UNORM_PACK32, ...), linear, with a data format
  descriptor and the axes, lookup convention and meta in its key/value data; read back as stored.
- ``dds`` (``.dds``, ``image/vnd-ms.dds``): DirectDraw Surface with the DX10 header, the same
  encodings (write-only: no room for metadata).
- ``png`` (``.png``, ``image/png``): 16-bit (or 8-bit) PNG, linear data, metadata in ``tEXt``;
  read back as stored.

The texture formats store value channels in one encoding (:mod:`~bsdf_tab.io.storage`:
float32, float16, unorm16, unorm10, unorm8; ``meta["storage"]["encoding"]`` chooses, else the
format's default) and record in ``meta["storage"]`` the error that storage adds per channel,
next to the integration error.

A file name's format is its longest matching ending (``lut.half.exr`` is ``half-exr``;
``S.meta.json`` is ``npy-channels``, any other ``.json`` is ``json``), case-insensitively.

``npy`` means one ``.npy`` file holding a structured array whose fields are the channels,
everywhere (it was so in the service; the CLI and presets used the name for per-channel
files). The per-channel layout, the way engines ship their tables (Cycles: one array per
quantity), is ``npy-channels``; its set of files is named by its sidecar ``S.meta.json``.
``npy`` and ``h`` are write-only: they hold no axes or metadata to read back.

Python
------
>>> import bsdf_tab.io as bio
>>> bio.write(table, "lut.half.exr")              # doctest: +SKIP   (format from the name)
>>> bio.write(table, "luts/cycles", fmt="npy-channels")               # doctest: +SKIP
>>> data = bio.to_bytes(table, "npy")             # doctest: +SKIP
>>> parts = bio.read("lut.exr")                   # doctest: +SKIP   (axes, channels, meta)
>>> table = bio.read("lut.exr", factory=bsdf_tab.Table)               # doctest: +SKIP
>>> bio.format_for("lut.half.exr").name
'half-exr'

``bsdf_tab.Table`` has the same as methods: ``table.write(path, fmt=None)``,
``Table.read(path, fmt=None)``, ``table.to_bytes(fmt)``, ``Table.from_bytes(data, fmt)``.

Tables too large to hold go through :func:`write_blocks` (axes, channel names, blocks
``(start texel, values)``, metadata or a function giving it after the last block) or
:func:`write_stream` (a stream of axis-0 slabs such as ``bsdf_tab.api.iter_blocks``'s): the
same file as the in-memory writer, for ``exr`` and ``npz`` (:func:`can_stream`).

Adding a format: a module here with a ``FORMAT = Format(...)`` record, and one line in
:data:`~bsdf_tab.io.registry.FORMATS`; the CLI and the service read names, endings and media
types from the registry.

An unknown name or ending raises :class:`FormatError` (a :class:`~bsdf_tab.errors.SpecError`)
naming it and what is known.

Layering
--------
This package never imports :mod:`bsdf_tab.table`: writers take any object with ``axes``,
``channels`` and ``meta``; readers return :class:`TableParts` or what ``factory`` builds.
``bsdf_tab.table`` imports this package for ``Table.write_exr`` and friends.

Modules: :mod:`~bsdf_tab.io.base` (the table-like protocol, :class:`Format`, JSON helpers),
:mod:`~bsdf_tab.io.atomic`, one module per format (:mod:`~bsdf_tab.io.exr`,
:mod:`~bsdf_tab.io.half_exr`, :mod:`~bsdf_tab.io.npz`, :mod:`~bsdf_tab.io.npy`,
:mod:`~bsdf_tab.io.npy_channels`, :mod:`~bsdf_tab.io.json`, :mod:`~bsdf_tab.io.c_header`,
:mod:`~bsdf_tab.io.ktx2`, :mod:`~bsdf_tab.io.dds`, :mod:`~bsdf_tab.io.png`; their shared texture
layout :mod:`~bsdf_tab.io.texture`; the encodings and measured storage errors
:mod:`~bsdf_tab.io.storage`),
:mod:`~bsdf_tab.io.registry`, and :mod:`~bsdf_tab.io.stream` (tables too large to hold).
"""

from .atomic import atomic_open, atomic_path, write_bytes, write_text
from .base import ERR_SUFFIX, Format, FormatError, TableParts, json_default
from .registry import (
    ENDINGS,
    FILE_FORMATS,
    FORMATS,
    accept_types,
    as_stored,
    format_for,
    format_for_media,
    endings,
    from_bytes,
    get_format,
    media_types,
    names,
    output_path,
    read,
    to_bytes,
    write,
)
from .stream import STREAM_FORMATS, StreamedTable, can_stream, write_blocks, write_stream

__all__ = [
    "ENDINGS",
    "ERR_SUFFIX",
    "FILE_FORMATS",
    "FORMATS",
    "Format",
    "FormatError",
    "STREAM_FORMATS",
    "StreamedTable",
    "TableParts",
    "accept_types",
    "as_stored",
    "atomic_open",
    "atomic_path",
    "can_stream",
    "endings",
    "format_for",
    "format_for_media",
    "from_bytes",
    "get_format",
    "json_default",
    "media_types",
    "names",
    "output_path",
    "read",
    "to_bytes",
    "write",
    "write_blocks",
    "write_bytes",
    "write_stream",
    "write_text",
]
