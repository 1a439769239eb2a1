"""Reading a LUT someone has: EXR, KTX2 (zstd too), DDS, 8/16-bit PNG, ``.npy``, C/C++/JS arrays.

Every reader returns a :class:`LutImage`: the values as float64, shaped ``(height, width,
channels)`` with row 0 the file's first row (the top scanline of an image; index 0 of an
array), the file's channel names, and what the file says about storage (``float32``,
``float16``, ``unorm8``, ``unorm10``, ``unorm16``) and transfer (``linear`` or ``srgb``, from a
KTX2 data format descriptor, a ``*_SRGB`` format, or a PNG ``sRGB`` / ``gAMA`` chunk). UNORM
texels are decoded as ``v / (2^bits - 1)``; nothing is sRGB-decoded (the doctor decides).

The container readers follow the specifications: PNG (ISO/IEC 15948: chunks, zlib, the five
scanline filters; no Adam7 interlace), KTX 2.0 (Khronos: header, level index, DFD, key/value
data; zstd supercompression with the ``zstandard`` module), DDS (Microsoft: ``DDS_HEADER``,
``DDS_HEADER_DXT10`` with DXGI formats, and the legacy float FourCCs). A bsdf-tab EXR carries
its axes and metadata, which the doctor takes as the file's claims.
"""

from __future__ import annotations

import json
import struct
import zlib
from pathlib import Path

import numpy as np

from .arrays import ARRAY_VALUES, read_array_text
from .image import LutImage, LutReadError, as_image, srgb_decode, srgb_encode

__all__ = ["LutImage", "LutReadError", "ARRAY_VALUES", "read_lut", "read_lut_bytes", "srgb_decode", "srgb_encode"]



_PNG_SIG = b"\x89PNG\r\n\x1a\n"
_PNG_CHANNELS = {0: ("Y",), 2: ("R", "G", "B"), 4: ("Y", "A"), 6: ("R", "G", "B", "A")}


def _paeth(a, b, c):
    p = a + b - c
    pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
    return a if pa <= pb and pa <= pc else (b if pb <= pc else c)


def _unfilter(raw: bytes, height: int, stride: int, bpp: int) -> np.ndarray:
    out = np.zeros((height, stride), dtype=np.uint8)
    prev = np.zeros(stride, dtype=np.int64)
    pos = 0
    for y in range(height):
        ftype = raw[pos]
        line = np.frombuffer(raw, dtype=np.uint8, count=stride, offset=pos + 1).astype(np.int64)
        pos += stride + 1
        if ftype == 0:
            cur = line
        elif ftype == 2:
            cur = (line + prev) & 0xFF
        else:
            cur = line.copy()
            for x in range(stride):
                a = cur[x - bpp] if x >= bpp else 0
                c = prev[x - bpp] if x >= bpp else 0
                if ftype == 1:
                    cur[x] = (cur[x] + a) & 0xFF
                elif ftype == 3:
                    cur[x] = (cur[x] + ((a + prev[x]) >> 1)) & 0xFF
                elif ftype == 4:
                    cur[x] = (cur[x] + _paeth(a, prev[x], c)) & 0xFF
                else:
                    raise LutReadError(f"PNG: unknown filter type {ftype} in row {y}")
        out[y] = cur
        prev = cur
    return out


def read_png(data: bytes) -> LutImage:
    """An 8- or 16-bit grey / grey+alpha / RGB / RGBA PNG (non-interlaced)."""
    if data[:8] != _PNG_SIG:
        raise LutReadError("not a PNG file (bad signature)")
    pos, idat, ihdr, transfer, text = 8, [], None, None, {}
    while pos + 8 <= len(data):
        length, ctype = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + length]
        pos += 12 + length
        if ctype == b"IHDR":
            ihdr = struct.unpack(">IIBBBBB", body)
        elif ctype == b"IDAT":
            idat.append(body)
        elif ctype in (b"sRGB", b"iCCP"):
            transfer = "srgb"
        elif ctype == b"gAMA" and transfer is None:
            gamma = struct.unpack(">I", body)[0] / 100000.0
            transfer = "linear" if abs(gamma - 1.0) < 1e-3 else "srgb" if abs(gamma - 1 / 2.2) < 0.01 else None
        elif ctype == b"tEXt":
            key, _, value = body.partition(b"\x00")
            key = key.decode("latin-1")
            if key.startswith("bsdf_tab_"):
                try:
                    text[key] = json.loads(value.decode("latin-1"))
                except ValueError:
                    text[key] = value.decode("latin-1")
        elif ctype == b"IEND":
            break
    if ihdr is None:
        raise LutReadError("PNG: no IHDR chunk")
    width, height, depth, color, _, _, interlace = ihdr
    if color not in _PNG_CHANNELS or depth not in (8, 16):
        raise LutReadError(f"PNG: colour type {color} at {depth} bits is not a LUT layout (8/16-bit grey, "
                           "grey+alpha, RGB or RGBA)")
    if interlace:
        raise LutReadError("PNG: Adam7-interlaced files are not read; write the LUT non-interlaced")
    names = _PNG_CHANNELS[color]
    nch, nbytes = len(names), depth // 8
    raw = zlib.decompress(b"".join(idat))
    rows = _unfilter(raw, height, width * nch * nbytes, nch * nbytes)
    if depth == 16:
        values = rows.reshape(height, -1).view(">u2").astype(np.float64) / 65535.0
    else:
        values = rows.astype(np.float64) / 255.0
    claims = _claims_from(text)
    return as_image(_unstack(values.reshape(height, width, nch), claims), "png", names, channels_last=True,
                     storage=f"unorm{depth}", transfer=transfer, claims=claims)


def _unstack(image: np.ndarray, claims: dict) -> np.ndarray:
    """An image (height, width, channels) in bsdf-tab's texture layout (:mod:`bsdf_tab.io.texture`)
    back in the shape of the table its claims give: a 1-D table is one row of ``n`` texels, a 3-D
    table ``(n0, n1, n2)`` its axis-0 slices stacked vertically (row = i0 * n1 + i1). An image
    whose size does not fit the claimed axes is left as it is."""
    sizes = _claimed_sizes(claims)
    height, width, nch = image.shape
    if not sizes:
        return image
    if len(sizes) == 1 and height == 1 and sizes[0] == width:
        return image.reshape(width, nch)
    if len(sizes) == 3 and sizes[0] * sizes[1] == height and sizes[2] == width:
        return image.reshape(sizes[0], sizes[1], sizes[2], nch)
    return image


# ----------------------------------------------------------------------------- KTX2

_KTX2_ID = b"\xabKTX 20\xbb\r\n\x1a\n"
# vkFormat -> (numpy dtype or packing, channel names, storage, srgb)
_VK = {
    9: ("u1", "R", "unorm8", False), 15: ("u1", "R", "unorm8", True),
    16: ("u1", "RG", "unorm8", False), 22: ("u1", "RG", "unorm8", True),
    37: ("u1", "RGBA", "unorm8", False), 43: ("u1", "RGBA", "unorm8", True),
    64: ("a2b10g10r10", "RGBA", "unorm10", False),
    70: ("<u2", "R", "unorm16", False), 77: ("<u2", "RG", "unorm16", False), 91: ("<u2", "RGBA", "unorm16", False),
    76: ("<f2", "R", "float16", False), 83: ("<f2", "RG", "float16", False), 97: ("<f2", "RGBA", "float16", False),
    100: ("<f4", "R", "float32", False), 103: ("<f4", "RG", "float32", False), 106: ("<f4", "RGB", "float32", False),
    109: ("<f4", "RGBA", "float32", False),
}


def _decode_texels(buf: bytes, kind: str, nch: int, storage: str, count: int) -> np.ndarray:
    if kind == "a2b10g10r10":
        w = np.frombuffer(buf, dtype="<u4", count=count)
        r, g, b, a = w & 1023, (w >> 10) & 1023, (w >> 20) & 1023, w >> 30
        return np.stack([r / 1023.0, g / 1023.0, b / 1023.0, a / 3.0], axis=-1)
    v = np.frombuffer(buf, dtype=kind, count=count * nch).astype(np.float64).reshape(count, nch)
    if storage == "unorm8":
        v = v / 255.0
    elif storage == "unorm16":
        v = v / 65535.0
    return v


def _ktx2_kv(data: bytes, offset: int, length: int) -> dict:
    kv, pos, end = {}, offset, offset + length
    while pos + 4 <= end:
        size = struct.unpack_from("<I", data, pos)[0]
        entry = data[pos + 4:pos + 4 + size]
        key, _, value = entry.partition(b"\x00")
        kv[key.decode("utf-8", "replace")] = value.rstrip(b"\x00").decode("utf-8", "replace")
        pos += 4 + size + (-size % 4)
    return kv


def read_ktx2(data: bytes) -> LutImage:
    """A 1-D, 2-D or 3-D KTX2 texture, level 0, in one of the UNORM / SFLOAT formats of a LUT."""
    if data[:12] != _KTX2_ID:
        raise LutReadError("not a KTX2 file (bad identifier)")
    (vk, type_size, width, height, depth, layers, faces, levels, scheme) = struct.unpack_from("<9I", data, 12)
    dfd_off, dfd_len, kvd_off, kvd_len = struct.unpack_from("<4I", data, 48)
    if vk not in _VK:
        raise LutReadError(f"KTX2: vkFormat {vk} is not a LUT format this reader knows (R/RG/RGBA 8- or 16-bit "
                           "UNORM, 16/32-bit SFLOAT, A2B10G10R10_UNORM)")
    if faces != 1 or layers > 1:
        raise LutReadError("KTX2: only a single 1-D, 2-D or 3-D image is identified (no layers or cube faces)")
    level0 = struct.unpack_from("<3Q", data, 80)
    offset, length, _ = level0
    buf = data[offset:offset + length]
    if scheme == 2:
        try:
            import zstandard
        except ImportError:
            raise LutReadError("KTX2: zstd supercompression needs the 'zstandard' module (pip install zstandard)") from None
        buf = zstandard.ZstdDecompressor().decompress(buf, max_output_size=64 << 20)
    elif scheme != 0:
        raise LutReadError(f"KTX2: supercompression scheme {scheme} is not read (0 none, 2 zstd)")
    kind, names, storage, srgb = _VK[vk]
    height, depth = max(height, 1), max(depth, 1)
    texels = _decode_texels(buf, kind, len(names), storage, width * height * depth)
    # pixelHeight 0 (or 1) with pixelDepth 0: a 1-D texture, one texel per node of the one axis
    texels = texels.reshape((depth, height, width, len(names)) if depth > 1 else
                            (width, len(names)) if height == 1 else (height, width, len(names)))
    transfer = "srgb" if srgb else "linear"
    if dfd_len >= 16:
        tf = data[dfd_off + 4 + 10]  # basic descriptor block byte 10: transferFunction (1 linear, 2 sRGB)
        transfer = {1: "linear", 2: "srgb"}.get(tf, transfer)
    kv = _ktx2_kv(data, kvd_off, kvd_len) if kvd_len else {}
    claims = {}
    for key, value in kv.items():
        if key.startswith("bsdf_tab_"):
            try:
                claims[key] = json.loads(value)
            except ValueError:
                claims[key] = value
    return as_image(texels, "ktx2", list(names), channels_last=True, storage=storage, transfer=transfer,
                     claims=_claims_from(claims))


# ----------------------------------------------------------------------------- DDS

# DXGI_FORMAT -> (dtype or packing, channels, storage, srgb)
_DXGI = {
    2: ("<f4", "RGBA", "float32", False), 10: ("<f2", "RGBA", "float16", False),
    11: ("<u2", "RGBA", "unorm16", False), 16: ("<f4", "RG", "float32", False),
    24: ("a2b10g10r10", "RGBA", "unorm10", False), 28: ("u1", "RGBA", "unorm8", False),
    29: ("u1", "RGBA", "unorm8", True), 34: ("<f2", "RG", "float16", False), 35: ("<u2", "RG", "unorm16", False),
    41: ("<f4", "R", "float32", False), 49: ("u1", "RG", "unorm8", False), 54: ("<f2", "R", "float16", False),
    56: ("<u2", "R", "unorm16", False), 61: ("u1", "R", "unorm8", False),
}
# legacy D3DFMT FourCC codes stored as integers
_D3D = {111: 54, 112: 34, 113: 10, 114: 41, 115: 16, 116: 2}


#: D3D10_RESOURCE_DIMENSION of the DX10 header -> the texture's number of axes
_DDS_DIMENSION = {2: 1, 3: 2, 4: 3}
_DDSD_DEPTH, _DDSCAPS2_VOLUME = 0x800000, 0x200000


def read_dds(data: bytes) -> LutImage:
    """A 1-D, 2-D or volume (3-D) DDS texture (DX10 header or a legacy float / 8-bit RGBA header),
    level 0: a 1-D texture is read as (width, channels), a volume as (depth, height, width,
    channels), the slices in file order (bsdf-tab's ``dds`` writer: axis 0 along the depth)."""
    if data[:4] != b"DDS ":
        raise LutReadError("not a DDS file (bad magic)")
    if len(data) < 128:
        raise LutReadError("DDS: truncated header")
    size, flags, height, width, pitch, depth, mips = struct.unpack_from("<7I", data, 4)
    pf_size, pf_flags, fourcc, bits, rmask, gmask, bmask, amask = struct.unpack_from("<II4sIIIII", data, 76)
    caps2 = struct.unpack_from("<I", data, 112)[0]
    offset = 128
    volume = bool(caps2 & _DDSCAPS2_VOLUME) and bool(flags & _DDSD_DEPTH) and depth > 1
    ndim = 3 if volume else 2
    if fourcc == b"DX10":
        dxgi, dim, _, array_size, _ = struct.unpack_from("<5I", data, 128)
        offset += 20
        if dim not in _DDS_DIMENSION or array_size > 1:
            raise LutReadError("DDS: only a single 1-D, 2-D or volume texture is identified (no arrays or cube maps)")
        ndim = _DDS_DIMENSION[dim]
    elif pf_flags & 0x4:  # DDPF_FOURCC
        code = struct.unpack("<I", fourcc)[0]
        if code not in _D3D:
            raise LutReadError(f"DDS: FourCC {fourcc!r} is not a LUT format this reader knows")
        dxgi = _D3D[code]
    elif bits == 32 and rmask == 0xFF and gmask == 0xFF00:
        dxgi = 28
    else:
        raise LutReadError("DDS: pixel format not read (use the DX10 header with a float or UNORM format)")
    if dxgi not in _DXGI:
        raise LutReadError(f"DDS: DXGI format {dxgi} is not a LUT format this reader knows")
    kind, names, storage, srgb = _DXGI[dxgi]
    height, depth = max(height, 1), max(depth, 1)
    shape = {1: (width * height,), 2: (height, width), 3: (depth, height, width)}[ndim]
    count = int(np.prod(shape))
    texel_bytes = 4 if kind == "a2b10g10r10" else len(names) * np.dtype(kind).itemsize
    if len(data) - offset < count * texel_bytes:
        raise LutReadError(f"DDS: truncated pixel data ({len(data) - offset} bytes, "
                           f"{' x '.join(map(str, shape))} texels need {count * texel_bytes})")
    texels = _decode_texels(data[offset:], kind, len(names), storage, count).reshape(*shape, len(names))
    return as_image(texels, "dds", list(names), channels_last=True, storage=storage,
                     transfer="srgb" if srgb else None)


# ----------------------------------------------------------------------------- EXR, npy, arrays


def _claims_from(attrs: dict) -> dict:
    """bsdf-tab's own claims (axes in order with values, spec, meta) from header / KV attributes."""
    claims = {}
    for key, value in attrs.items():
        short = key.split("_", 2)[-1] if key.startswith("bsdf_tab_") else key
        if short in ("axes", "spec", "meta", "channels"):
            claims[short] = value
    return claims


def _claimed_sizes(claims: dict) -> list[int] | None:
    axes = claims.get("axes")
    if isinstance(axes, dict):
        return [len(v) for v in axes.values()] if all(isinstance(v, list) for v in axes.values()) else None
    if isinstance(axes, list) and all(isinstance(a, list) and len(a) == 2 and isinstance(a[1], list) for a in axes):
        return [len(a[1]) for a in axes]
    return None


def read_exr(data: bytes, name: str = "lut.exr") -> LutImage:
    """An EXR image: its channels (bsdf-tab order if it says so), and a bsdf-tab file's claims.

    ``name`` (the user's file) is what an error names, never the temporary copy OpenEXR reads."""
    import tempfile

    from ..io.base import FormatError
    from ..io.exr import read_channels

    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "lut.exr"
        path.write_bytes(data)
        try:
            header, chans = read_channels(path, name)
        except FormatError as exc:  # truncated or damaged: one line naming the user's file
            raise LutReadError(exc.message, None) from None
    attrs = {}
    for key, value in header.items():
        if isinstance(key, str) and key.startswith("bsdf_tab_"):
            try:
                attrs[key] = json.loads(value) if isinstance(value, str) else value
            except ValueError:
                attrs[key] = value
    claims = _claims_from(attrs)
    order = [c for c in claims.get("channels", []) if c in chans] or sorted(chans)
    order = [c for c in order if not c.endswith("_err")]
    storage = "float16" if all(chans[c].dtype == np.float16 for c in order) else "float32"
    stack = np.stack([chans[c].astype(np.float64) for c in order], axis=-1)
    sizes = _claimed_sizes(claims)
    if sizes and int(np.prod(sizes)) == stack.shape[0] * stack.shape[1] and len(sizes) != 2:
        stack = stack.reshape(*sizes, stack.shape[-1])  # bsdf-tab's layout: last axis along the width
    return as_image(stack, "exr", order, storage=storage, transfer="linear", claims=claims)


def _npy_storage(dtype) -> str:
    """What a ``.npy`` array's dtype says about storage: ``unorm8`` / ``unorm16`` for uint8 /
    uint16 (read as UNORM), otherwise the dtype's own name (``float16``, ``float32``,
    ``float64``, ...)."""
    dtype = np.dtype(dtype)
    return {np.dtype(np.uint8): "unorm8", np.dtype(np.uint16): "unorm16"}.get(dtype, dtype.name)


def read_lut_bytes(data: bytes, name: str = "lut", shape=None, array_values: str = "float",
                   array_name: str | None = None) -> LutImage:
    """Read a LUT from its bytes; the format from the magic number, else from the name (arrays).

    Parameters
    ----------
    data : bytes
        The file's contents.
    name : str
        The file name (for ``.npy`` and array files without a magic number).
    shape : tuple of int, optional
        The shape of an array file's numbers (required for C/C++/JS arrays).
    array_values : str
        How an array file's numbers are read (:data:`ARRAY_VALUES`).

    Raises
    ------
    SpecError
        ``param`` ``lut`` (unreadable), ``shape`` or ``array_values``.
    """
    if data[:8] == _PNG_SIG:
        return read_png(data)
    if data[:12] == _KTX2_ID:
        return read_ktx2(data)
    if data[:4] == b"DDS ":
        return read_dds(data)
    if data[:4] == b"\x76\x2f\x31\x01":
        return read_exr(data, name)
    if data[:6] == b"\x93NUMPY":
        import io

        try:
            arr = np.load(io.BytesIO(data), allow_pickle=False)
        except ValueError as exc:
            raise LutReadError(f"cannot read the .npy file: {exc}") from None
        if arr.dtype.names:
            names = [n for n in arr.dtype.names if not n.endswith("_err")]
            dtype = np.result_type(*[arr.dtype.fields[n][0] for n in names]) if names else np.dtype(np.float64)
            arr = np.stack([arr[n] for n in names], axis=-1)
            return as_image(arr, "npy", names, storage=_npy_storage(dtype))
        storage = _npy_storage(arr.dtype)
        if storage == "unorm8":
            arr = arr / 255.0
        elif storage == "unorm16":
            arr = arr / 65535.0
        return as_image(arr, "npy", storage=storage)
    if name.lower().endswith(NPY_CHANNELS_SIDECAR):
        raise LutReadError(f"{name}: an npy-channels sidecar names a set of .npy files beside it, which its bytes alone "
                           "do not hold: check it by its path (bsdf-tab check S.meta.json), or check one of its .npy "
                           "arrays")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        raise LutReadError(f"{name}: not a LUT format the doctor reads (EXR, KTX2, DDS, PNG, .npy, "
                           "or a C/C++/JS array file with --shape)") from None
    return read_array_text(text, shape, array_values, array_name)


#: the sidecar that names a set of ``npy-channels`` files (:mod:`bsdf_tab.io.npy_channels`)
NPY_CHANNELS_SIDECAR = ".meta.json"


def read_npy_channels(path) -> LutImage:
    """A set of ``.npy`` files bsdf-tab's ``npy-channels`` format wrote, named by its sidecar
    ``S.meta.json``, read by :mod:`bsdf_tab.io`'s own reader: the value channels (``*_err``
    left out) in channel order, the axes and metadata as the file's claims, the storage the
    arrays' dtype."""
    from ..io import read as io_read

    p = Path(path)
    try:
        parts = io_read(p, "npy-channels")
    except (OSError, ValueError, KeyError) as exc:  # FormatError is a ValueError
        message = getattr(exc, "message", None) or str(exc)
        raise LutReadError(f"{p.name}: cannot read the npy-channels set ({message})") from None
    names = [n for n in parts.channels if not n.endswith("_err")]
    if not names:
        raise LutReadError(f"{p.name}: the npy-channels set has no value channel")
    arrays = [np.asarray(parts.channels[n]) for n in names]
    if len({a.shape for a in arrays}) != 1:
        raise LutReadError(f"{p.name}: the channels of the npy-channels set differ in shape")
    meta = parts.meta if isinstance(parts.meta, dict) else {}
    claims = {"axes": {n: np.asarray(v, dtype=np.float64).tolist() for n, v in parts.axes.items()}, "channels": names}
    if meta:
        claims["meta"] = meta
        if isinstance(meta.get("spec"), dict):
            claims["spec"] = meta["spec"]
    dtype = np.result_type(*[a.dtype for a in arrays])
    return as_image(np.stack(arrays, axis=-1), "npy-channels", names, channels_last=True,
                     storage=_npy_storage(dtype), claims=claims)


def read_lut(path, shape=None, array_values: str = "float", array_name: str | None = None) -> LutImage:
    """Read the LUT file ``path`` (see :func:`read_lut_bytes`); an ``npy-channels`` sidecar
    ``S.meta.json`` reads its set of files (:func:`read_npy_channels`)."""
    p = Path(path)
    if p.name.lower().endswith(NPY_CHANNELS_SIDECAR):
        return read_npy_channels(p)
    return read_lut_bytes(p.read_bytes(), p.name, shape=shape, array_values=array_values, array_name=array_name)
