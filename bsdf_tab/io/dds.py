"""``dds``: a DirectDraw Surface with the DX10 header extension (what Unity and Unreal import).

Written from Microsoft's DDS reference (``DDS_HEADER``, ``DDS_PIXELFORMAT`` with FourCC
``DX10``, ``DDS_HEADER_DXT10``): one mip level, a 1-D, 2-D or volume (3-D) texture as the
table has 1, 2 or 3 axes (layout: :mod:`bsdf_tab.io.texture`, rows top to bottom = axis
index 0 first). Encodings and DXGI formats:

==========  ===================  =====================  =========================
encoding    1 channel            2 channels             3-4 channels
==========  ===================  =====================  =========================
float16     R16_FLOAT (54)       R16G16_FLOAT (34)      R16G16B16A16_FLOAT (10)
float32     R32_FLOAT (41)       R32G32_FLOAT (16)      R32G32B32A32_FLOAT (2)
unorm16     R16_UNORM (56)       R16G16_UNORM (35)      R16G16B16A16_UNORM (11)
unorm8      R8_UNORM (61)        R8G8_UNORM (49)        R8G8B8A8_UNORM (28)
unorm10     R10G10B10A2_UNORM (24): channels 0-2 in R, G, B (unused ones 0), A = 1
==========  ===================  =====================  =========================

DDS has no place for metadata: the file is write-only for bsdf-tab (write a ``ktx2`` or EXR
next to it for the axes and errors); ``as_stored`` gives the stored values and their bound.
DXGI formats are linear (no ``_SRGB`` format is written).
"""

from __future__ import annotations

import struct
from pathlib import Path
from typing import Callable

import numpy as np

from .atomic import write_bytes
from .base import Format, value_channels
from .storage import as_encoded, encode, get_encoding, requested_encoding
from .texture import image_dims, texel_array

__all__ = ["DXGI_FORMATS", "FORMAT", "dds_bytes", "dxgi_format", "write_dds"]

#: (encoding, components) -> (DXGI_FORMAT name, value).
DXGI_FORMATS: dict[tuple[str, int], tuple[str, int]] = {
    ("float16", 1): ("R16_FLOAT", 54), ("float16", 2): ("R16G16_FLOAT", 34), ("float16", 4): ("R16G16B16A16_FLOAT", 10),
    ("float32", 1): ("R32_FLOAT", 41), ("float32", 2): ("R32G32_FLOAT", 16), ("float32", 4): ("R32G32B32A32_FLOAT", 2),
    ("unorm16", 1): ("R16_UNORM", 56), ("unorm16", 2): ("R16G16_UNORM", 35), ("unorm16", 4): ("R16G16B16A16_UNORM", 11),
    ("unorm8", 1): ("R8_UNORM", 61), ("unorm8", 2): ("R8G8_UNORM", 49), ("unorm8", 4): ("R8G8B8A8_UNORM", 28),
    ("unorm10", 4): ("R10G10B10A2_UNORM", 24),
}

_DDSD_CAPS, _DDSD_HEIGHT, _DDSD_WIDTH, _DDSD_PITCH = 0x1, 0x2, 0x4, 0x8
_DDSD_PIXELFORMAT, _DDSD_MIPMAPCOUNT, _DDSD_DEPTH = 0x1000, 0x20000, 0x800000
_DDPF_FOURCC = 0x4
_DDSCAPS_COMPLEX, _DDSCAPS_TEXTURE = 0x8, 0x1000
_DDSCAPS2_VOLUME = 0x200000
_DIMENSION = {1: 2, 2: 3, 3: 4}  # D3D10_RESOURCE_DIMENSION_TEXTURE1D / 2D / 3D


def dxgi_format(encoding: str, n_channels: int) -> tuple[str, int, int]:
    """(DXGI name, value, components) storing ``n_channels`` channels as ``encoding``.

    Raises
    ------
    ValueError
        For more than 4 channels, or more than 3 in ``unorm10``.
    """
    get_encoding(encoding)
    if not 1 <= n_channels <= 4:
        raise ValueError(f"a DDS texture holds 1 to 4 channels, not {n_channels}")
    if encoding == "unorm10":
        if n_channels > 3:
            raise ValueError("unorm10 (R10G10B10A2_UNORM) holds at most 3 channels (A has 2 bits)")
        comps = 4
    else:
        comps = {1: 1, 2: 2, 3: 4, 4: 4}[n_channels]
    name, value = DXGI_FORMATS[(encoding, comps)]
    return name, value, comps


def _pixels(texels: np.ndarray, encoding: str, comps: int) -> tuple[bytes, int]:
    """(bytes, bytes per texel)."""
    n = texels.shape[-1]
    enc = get_encoding(encoding)
    if encoding == "unorm10":
        codes = enc.codes(texels)
        zero = np.zeros(texels.shape[:-1], dtype=np.uint32)
        r, g, b = (codes[..., k] if k < n else zero for k in range(3))
        return (r | (g << 10) | (b << 20) | (np.uint32(3) << 30)).astype("<u4").tobytes(), 4
    full = np.ones(texels.shape[:-1] + (comps,), dtype=np.float64)
    full[..., :n] = texels
    if enc.kind == "float":
        dtype = "<f4" if enc.bits == 32 else "<f2"
        return full.astype(dtype).tobytes(), comps * enc.bits // 8
    dtype = "<u2" if enc.bits == 16 else "u1"
    return enc.codes(full).astype(dtype).tobytes(), comps * enc.bits // 8


def dds_bytes(table, encoding: str | None = None) -> bytes:
    """The bytes of the DDS (DX10) file of ``table`` (``encoding`` default: ``meta["storage"]``
    or float16).

    Raises
    ------
    ValueError
        If the table has no value channel, more than 4, or more than 3 axes, or a float
        encoding cannot hold a value (beyond 65504 for float16: never written as an infinity).
    """
    encoding = encoding or requested_encoding(table, "dds")
    names = value_channels(table.channels)
    _, dxgi, comps = dxgi_format(encoding, len(names))
    width, height, depth = image_dims(table)
    data, texel_bytes = _pixels(texel_array(table, encode(table, encoding)), encoding, comps)
    flags = _DDSD_CAPS | _DDSD_HEIGHT | _DDSD_WIDTH | _DDSD_PITCH | _DDSD_PIXELFORMAT | _DDSD_MIPMAPCOUNT
    caps, caps2 = _DDSCAPS_TEXTURE, 0
    if depth:
        flags |= _DDSD_DEPTH
        caps |= _DDSCAPS_COMPLEX
        caps2 |= _DDSCAPS2_VOLUME
    pixel_format = struct.pack("<II4s5I", 32, _DDPF_FOURCC, b"DX10", 0, 0, 0, 0, 0)
    header = struct.pack(
        "<7I44s32s5I",
        124, flags, max(height, 1), width, width * texel_bytes, depth, 1,
        b"\0" * 44, pixel_format, caps, caps2, 0, 0, 0,
    )
    dx10 = struct.pack("<5I", dxgi, _DIMENSION[len(table.axes)], 0, 1, 0)
    return b"DDS " + header + dx10 + data


def write_dds(table, path, encoding: str | None = None) -> list[Path]:
    """Write ``table`` as a DDS (DX10) file atomically; returns ``[path]``."""
    return [write_bytes(path, dds_bytes(table, encoding))]


def _write(table, path) -> list[Path]:
    return write_dds(table, path)


def _as_stored(table, factory: Callable | None = None):
    return as_encoded(table, requested_encoding(table, "dds"), "dds", factory)


FORMAT = Format(
    name="dds",
    suffixes=(".dds",),
    description="DirectDraw Surface, DX10 header (R16G16_FLOAT, R16G16_UNORM, R10G10B10A2, ...), linear; write-only",
    write=_write,
    media_type="image/vnd-ms.dds",
    to_bytes=dds_bytes,
    as_stored=_as_stored,
)
