"""``png``: a 16-bit (or 8-bit) PNG, what glTF viewers load, written from the PNG specification.

Value channels in channel order as the colour components: 1 channel -> greyscale (colour type
0), 2 or 3 -> RGB (type 2; with 2 channels B = 0, so ``.rg`` reads them whatever the loader
expands), 4 -> RGBA (type 6). Bit depth 16 (``unorm16``, the default: code
``round(clamp(x, 0, 1) * 65535)``, big-endian) or 8 (``unorm8``, ``--precision unorm8``). The
image layout is EXR's (:mod:`bsdf_tab.io.texture`; 3-D tables stack the axis-0 slices
vertically), the top row first: row 0 = axis 0, index 0, at texture coordinate v = 0.5 / height
when uploaded without a vertical flip.

The samples are data, to be read as linear values (load with colour-space conversion off), and
the file says so: a ``cICP`` chunk (PNG 3rd edition: colour primaries 1 = BT.709, transfer
characteristics 8 = linear, matrix 0 = RGB/identity, full range) and, for readers that predate
it, ``gAMA`` = 100000 (gamma 1.0, linear); no ``sRGB`` or ``iCCP`` chunk, so nothing applies
the sRGB curve. ``tEXt`` chunks carry the metadata of
:func:`bsdf_tab.io.texture.metadata_strings` (``bsdf_tab_axes``, ``bsdf_tab_lookup``,
``bsdf_tab_meta`` with ``storage``, ...), so :func:`read_png` gives the table back.
"""

from __future__ import annotations

import struct
import zlib
from pathlib import Path
from typing import Callable

import numpy as np

from .atomic import write_bytes
from .base import Format, build, shape_of, value_channels
from .exr import image_shape
from .storage import as_encoded, encode, get_encoding, requested_encoding, storage_report
from .texture import image_dims, metadata_strings, parts_from_metadata, table_from_texels, texel_array

__all__ = ["CICP_LINEAR", "FORMAT", "GAMA_LINEAR", "SIGNATURE", "png_bytes", "png_from_bytes", "read_png", "write_png"]

#: The 8-byte PNG signature.
SIGNATURE = b"\x89PNG\r\n\x1a\n"
#: ``cICP`` body: BT.709 primaries, linear transfer (H.273 TransferCharacteristics 8), RGB, full range.
CICP_LINEAR = bytes([1, 8, 0, 1])
#: ``gAMA`` body value: image gamma 1.0 times 100000 (linear samples).
GAMA_LINEAR = 100000
_COLOUR_TYPE = {1: 0, 2: 2, 3: 2, 4: 6}
_SAMPLES = {0: 1, 2: 3, 6: 4}


def _chunk(kind: bytes, data: bytes) -> bytes:
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)


def png_bytes(table, encoding: str | None = None) -> bytes:
    """The bytes of the PNG file of ``table`` (``unorm16`` unless ``encoding`` / ``meta["storage"]``
    says ``unorm8``).

    Raises
    ------
    ValueError
        If the table has no value channel, more than 4, more than 3 axes, or an encoding other
        than unorm16 / unorm8.
    """
    image_dims(table)  # 1 to 3 axes, as every texture (a 4-axis table reached a KeyError)
    encoding = encoding or requested_encoding(table, "png")
    if encoding not in ("unorm16", "unorm8"):
        raise ValueError(f"png stores unorm16 or unorm8, not {encoding}")
    enc = get_encoding(encoding)
    names = value_channels(table.channels)
    texels = texel_array(table, encode(table, encoding))
    colour = _COLOUR_TYPE[len(names)]
    samples = _SAMPLES[colour]
    height, width = image_shape(shape_of(table))
    full = np.zeros(texels.shape[:-1] + (samples,), dtype=np.float64)
    full[..., : len(names)] = texels
    codes = enc.codes(full).reshape(height, width * samples)
    rows = codes.astype(">u2" if enc.bits == 16 else "u1")
    raw = b"".join(b"\0" + rows[r].tobytes() for r in range(height))  # filter type 0 per row
    meta = dict(table.meta)
    meta["storage"] = storage_report(table, encoding, "png")
    text = b"".join(_chunk(b"tEXt", k.encode("latin-1") + b"\0" + v.encode("latin-1", "backslashreplace"))
                    for k, v in metadata_strings(table.axes, names, meta, "stacked").items())
    ihdr = struct.pack(">IIBBBBB", width, height, enc.bits, colour, 0, 0, 0)
    colour_chunks = _chunk(b"cICP", CICP_LINEAR) + _chunk(b"gAMA", struct.pack(">I", GAMA_LINEAR))
    return (SIGNATURE + _chunk(b"IHDR", ihdr) + colour_chunks + text + _chunk(b"IDAT", zlib.compress(raw, 9))
            + _chunk(b"IEND", b""))


def write_png(table, path, encoding: str | None = None) -> list[Path]:
    """Write ``table`` as a PNG file atomically; returns ``[path]``."""
    return [write_bytes(path, png_bytes(table, encoding))]


def _write(table, path) -> list[Path]:
    return write_png(table, path)


def _unfilter(raw: bytes, height: int, stride: int, bpp: int) -> np.ndarray:
    lines = np.frombuffer(raw, dtype=np.uint8, count=height * (stride + 1)).reshape(height, stride + 1)
    if not lines[:, 0].any():  # filter type 0 on every row (what bsdf-tab writes)
        return lines[:, 1:].copy()
    out = np.zeros((height, stride), dtype=np.uint8)
    prev = np.zeros(stride, dtype=np.int32)
    pos = 0
    for r in range(height):
        ftype = raw[pos]
        line = np.frombuffer(raw, dtype=np.uint8, count=stride, offset=pos + 1).astype(np.int32)
        pos += 1 + stride
        cur = np.zeros(stride, dtype=np.int32)
        for i in range(stride):
            a = cur[i - bpp] if i >= bpp else 0
            b = prev[i]
            c = prev[i - bpp] if i >= bpp else 0
            if ftype == 0:
                pred = 0
            elif ftype == 1:
                pred = a
            elif ftype == 2:
                pred = b
            elif ftype == 3:
                pred = (a + b) // 2
            else:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                pred = a if pa <= pb and pa <= pc else (b if pb <= pc else c)
            cur[i] = (line[i] + pred) & 0xFF
        out[r] = cur
        prev = cur
    return out


def png_from_bytes(data: bytes, factory: Callable | None = None, *, source: str = "png data"):
    """The table held by the bytes of a PNG file bsdf-tab wrote (non-interlaced, its tEXt metadata).

    Raises
    ------
    ValueError
        If the data is not a PNG or has no bsdf-tab metadata.
    """
    if data[:8] != SIGNATURE:
        raise ValueError(f"{source}: not a PNG file")
    pos, idat, text, ihdr = 8, b"", {}, None
    while pos + 8 <= len(data):
        (length,) = struct.unpack_from(">I", data, pos)
        kind = data[pos + 4: pos + 8]
        body = data[pos + 8: pos + 8 + length]
        pos += 12 + length
        if kind == b"IHDR":
            ihdr = struct.unpack(">IIBBBBB", body)
        elif kind == b"IDAT":
            idat += body
        elif kind == b"tEXt":
            key, _, value = body.partition(b"\0")
            text[key.decode("latin-1")] = value.decode("latin-1")
        elif kind == b"IEND":
            break
    if ihdr is None:
        raise ValueError(f"{source}: PNG without IHDR")
    width, height, bits, colour, _, _, interlace = ihdr
    if colour not in _SAMPLES or bits not in (8, 16) or interlace:
        raise ValueError(f"{source}: a PNG bsdf-tab does not read (colour type {colour}, {bits} bits)")
    axes, names, meta = parts_from_metadata(text, source)
    samples = _SAMPLES[colour]
    bpp = samples * bits // 8
    rows = _unfilter(zlib.decompress(idat), height, width * bpp, bpp)
    codes = rows.view(">u2") if bits == 16 else rows
    values = codes.astype(np.float64).reshape(-1, samples)[:, : len(names)] / ((1 << bits) - 1)
    channels, meta = table_from_texels(values, axes, names, meta)
    return build(axes, channels, meta, factory)


def read_png(path, factory: Callable | None = None):
    """Read a PNG file bsdf-tab wrote (see :func:`png_from_bytes`)."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no such file: {path}")
    return png_from_bytes(path.read_bytes(), factory, source=str(path))


def _as_stored(table, factory: Callable | None = None):
    return as_encoded(table, requested_encoding(table, "png"), "png", factory)


FORMAT = Format(
    name="png",
    suffixes=(".png",),
    description="PNG, 16-bit (or 8-bit) UNORM, linear data, metadata in tEXt chunks",
    write=_write,
    media_type="image/png",
    to_bytes=png_bytes,
    read=read_png,
    from_bytes=png_from_bytes,
    as_stored=_as_stored,
)
