"""``ktx2``: a Khronos KTX 2.0 texture, written from the KTX 2.0 specification.

What engines load (Vulkan, WebGPU, Bevy, Godot, glTF viewers). One mip level, no
supercompression, one face, no array layers; a 1-D, 2-D or 3-D texture as the table has 1, 2
or 3 axes (layout: :mod:`bsdf_tab.io.texture`). The value channels are its components in
channel order; the storage encoding (:mod:`bsdf_tab.io.storage`, default ``float16``) and the
number of channels choose the Vulkan format:

==========  ==================  =====================  =========================
encoding    1 channel           2 channels             3-4 channels
==========  ==================  =====================  =========================
float16     R16_SFLOAT          R16G16_SFLOAT          R16G16B16A16_SFLOAT
float32     R32_SFLOAT          R32G32_SFLOAT          R32G32B32A32_SFLOAT
unorm16     R16_UNORM           R16G16_UNORM           R16G16B16A16_UNORM
unorm8      R8_UNORM            R8G8_UNORM             R8G8B8A8_UNORM
unorm10     A2B10G10R10_UNORM_PACK32 (R, G, B = channels 0-2, unused ones 0, A = 1)
==========  ==================  =====================  =========================

(3 channels: A = 1.) The data format descriptor is one Khronos basic descriptor block
(Khronos Data Format 1.3: colour model RGBSDA, primaries BT.709, transfer function LINEAR,
one sample per component with its bit offset and length, FLOAT | SIGNED qualifiers and
sampleLower / sampleUpper -1.0f / 1.0f for floats, 0 / 2^bits - 1 for UNORM). The key/value
data holds ``KTXorientation`` (``r``, ``rd``, ``rdi``), ``KTXwriter``, and the JSON strings
``bsdf_tab_axes``, ``bsdf_tab_channels``, ``bsdf_tab_lookup`` (the lookup convention),
``bsdf_tab_meta`` (with ``storage``: per channel the integration and storage errors),
``bsdf_tab_spec`` and ``bsdf_tab_version``, NUL-terminated, sorted by key.
"""

from __future__ import annotations

import math
import struct
from pathlib import Path
from typing import Callable

import numpy as np

from .atomic import write_bytes
from .base import Format, build, value_channels
from .storage import as_encoded, encode, get_encoding, requested_encoding, storage_report
from .texture import image_dims, metadata_strings, parts_from_metadata, table_from_texels, texel_array

__all__ = ["FORMAT", "IDENTIFIER", "VK_FORMATS", "ktx2_bytes", "ktx2_from_bytes", "read_ktx2", "vk_format", "write_ktx2"]

#: The 12-byte file identifier of KTX 2.0.
IDENTIFIER = b"\xabKTX 20\xbb\r\n\x1a\n"

# Khronos Data Format 1.3 constants
_KHR_DF_VERSION_1_3 = 2
_MODEL_RGBSDA = 1
_PRIMARIES_BT709 = 1
_TRANSFER_LINEAR = 1
_QUAL_FLOAT = 0x80
_QUAL_SIGNED = 0x40
_CHANNEL_ID = {"R": 0, "G": 1, "B": 2, "A": 15}
_FLOAT_M1 = 0xBF800000  # -1.0f
_FLOAT_P1 = 0x3F800000  # 1.0f

#: Vulkan format name -> (VkFormat value, components, bits per component, kind); PACK32 apart.
VK_FORMATS: dict[str, tuple[int, str, int, str]] = {
    "R16_SFLOAT": (76, "R", 16, "float"),
    "R16G16_SFLOAT": (83, "RG", 16, "float"),
    "R16G16B16A16_SFLOAT": (97, "RGBA", 16, "float"),
    "R32_SFLOAT": (100, "R", 32, "float"),
    "R32G32_SFLOAT": (103, "RG", 32, "float"),
    "R32G32B32A32_SFLOAT": (109, "RGBA", 32, "float"),
    "R16_UNORM": (70, "R", 16, "unorm"),
    "R16G16_UNORM": (77, "RG", 16, "unorm"),
    "R16G16B16A16_UNORM": (91, "RGBA", 16, "unorm"),
    "R8_UNORM": (9, "R", 8, "unorm"),
    "R8G8_UNORM": (16, "RG", 8, "unorm"),
    "R8G8B8A8_UNORM": (37, "RGBA", 8, "unorm"),
    "A2B10G10R10_UNORM_PACK32": (64, "RGBA", 10, "pack32"),
}
_BY_VALUE = {v[0]: k for k, v in VK_FORMATS.items()}
#: (kind, bits) -> the format names for 1, 2 and 3-4 channels
_BY_ENCODING = {
    ("float", 16): ("R16_SFLOAT", "R16G16_SFLOAT", "R16G16B16A16_SFLOAT"),
    ("float", 32): ("R32_SFLOAT", "R32G32_SFLOAT", "R32G32B32A32_SFLOAT"),
    ("unorm", 16): ("R16_UNORM", "R16G16_UNORM", "R16G16B16A16_UNORM"),
    ("unorm", 8): ("R8_UNORM", "R8G8_UNORM", "R8G8B8A8_UNORM"),
}


def vk_format(encoding: str, n_channels: int) -> str:
    """The Vulkan format name that stores ``n_channels`` channels as ``encoding``.

    Raises
    ------
    ValueError
        For more than 4 channels, or more than 3 in ``unorm10``.
    """
    if not 1 <= n_channels <= 4:
        raise ValueError(f"a KTX2 texture holds 1 to 4 channels, not {n_channels}")
    enc = get_encoding(encoding)
    if enc.name == "unorm10":
        if n_channels > 3:
            raise ValueError("unorm10 (A2B10G10R10_UNORM_PACK32) holds at most 3 channels (A has 2 bits)")
        return "A2B10G10R10_UNORM_PACK32"
    return _BY_ENCODING[(enc.kind, enc.bits)][min(n_channels, 3) - 1]


def _texel_bytes(name: str) -> int:
    _, comps, bits, kind = VK_FORMATS[name]
    return 4 if kind == "pack32" else len(comps) * bits // 8


def _samples(name: str) -> list[tuple[int, int, int, int, int]]:
    """(bit offset, bit length, channel type byte, lower, upper) per sample, per the DFD spec."""
    _, comps, bits, kind = VK_FORMATS[name]
    if kind == "pack32":
        return [(0, 10, _CHANNEL_ID["R"], 0, 1023), (10, 10, _CHANNEL_ID["G"], 0, 1023),
                (20, 10, _CHANNEL_ID["B"], 0, 1023), (30, 2, _CHANNEL_ID["A"], 0, 3)]
    out = []
    for k, c in enumerate(comps):
        if kind == "float":
            out.append((k * bits, bits, _CHANNEL_ID[c] | _QUAL_FLOAT | _QUAL_SIGNED, _FLOAT_M1, _FLOAT_P1))
        else:
            out.append((k * bits, bits, _CHANNEL_ID[c], 0, (1 << bits) - 1))
    return out


def dfd_bytes(name: str) -> bytes:
    """The data format descriptor of ``name``: dfdTotalSize, then one basic descriptor block."""
    samples = _samples(name)
    block_size = 24 + 16 * len(samples)
    words = [
        0,  # vendorId 0 (Khronos, 17 bits) | descriptorType 0 (basic, 15 bits)
        _KHR_DF_VERSION_1_3 | (block_size << 16),
        _MODEL_RGBSDA | (_PRIMARIES_BT709 << 8) | (_TRANSFER_LINEAR << 16) | (0 << 24),  # flags: straight alpha
        0,  # texelBlockDimension0..3 = 1 - 1
        _texel_bytes(name),  # bytesPlane0; bytesPlane1..3 = 0
        0,  # bytesPlane4..7
    ]
    for offset, length, channel_type, lower, upper in samples:
        words += [offset | ((length - 1) << 16) | (channel_type << 24), 0, lower, upper]
    body = struct.pack(f"<{len(words)}I", *words)
    return struct.pack("<I", 4 + len(body)) + body


def _kv_bytes(pairs: dict[str, bytes]) -> bytes:
    out = bytearray()
    for key in sorted(pairs, key=lambda k: k.encode("utf-8")):
        entry = key.encode("utf-8") + b"\0" + pairs[key]
        out += struct.pack("<I", len(entry)) + entry
        out += b"\0" * (-len(entry) % 4)
    return bytes(out)


def _pixel_data(texels: np.ndarray, name: str, encoding: str) -> bytes:
    _, comps, bits, kind = VK_FORMATS[name]
    n = texels.shape[-1]
    if kind == "pack32":
        codes = get_encoding("unorm10").codes(texels)
        r = codes[..., 0]
        g = codes[..., 1] if n > 1 else 0 * r
        b = codes[..., 2] if n > 2 else 0 * r
        packed = (r | (g << 10) | (b << 20) | (np.uint32(3) << 30)).astype("<u4")
        return packed.tobytes()
    full = np.zeros(texels.shape[:-1] + (len(comps),), dtype=np.float64)
    full[..., :n] = texels
    if n < len(comps):
        full[..., n:] = 1.0  # alpha of a 3-channel texture
    if kind == "float":
        return full.astype("<f4" if bits == 32 else "<f2").tobytes()
    codes = get_encoding(encoding).codes(full)
    return codes.astype("<u2" if bits == 16 else "u1").tobytes()


def _encoded(table, encoding: str | None):
    encoding = encoding or requested_encoding(table, "ktx2")
    names = value_channels(table.channels)
    name = vk_format(encoding, len(names))
    return encoding, name


def ktx2_bytes(table, encoding: str | None = None) -> bytes:
    """The bytes of the KTX2 file of ``table`` (``encoding`` default: ``meta["storage"]`` or float16).

    Raises
    ------
    ValueError
        If the table has no value channel, more than 4, or more than 3 axes, or a float
        encoding cannot hold a value (beyond 65504 for float16: never written as an infinity).
    """
    encoding, name = _encoded(table, encoding)
    width, height, depth = image_dims(table)
    stored = encode(table, encoding)
    pixels = _pixel_data(texel_array(table, stored), name, encoding)
    meta = dict(table.meta)
    meta["storage"] = storage_report(table, encoding, "ktx2")
    meta["storage"]["vk_format"] = "VK_FORMAT_" + name
    strings = metadata_strings(table.axes, value_channels(table.channels), meta)
    version = str(meta.get("version", ""))
    pairs = {k: v.encode("utf-8") + b"\0" for k, v in strings.items()}
    pairs["KTXorientation"] = {1: b"r\0", 2: b"rd\0", 3: b"rdi\0"}[len(table.axes)]
    pairs["KTXwriter"] = f"bsdf-tab {version}".strip().encode("utf-8") + b"\0"
    dfd = dfd_bytes(name)
    kvd = _kv_bytes(pairs)
    vk_value = VK_FORMATS[name][0]
    type_size = 4 if VK_FORMATS[name][3] == "pack32" else VK_FORMATS[name][2] // 8
    dfd_offset = 80 + 24  # identifier + header + index, one level
    kvd_offset = dfd_offset + len(dfd)
    align = math.lcm(_texel_bytes(name), 4)
    data_offset = kvd_offset + len(kvd)
    data_offset += -data_offset % align
    header = struct.pack(
        "<9I", vk_value, type_size, width, height, depth, 0, 1, 1, 0
    )  # layerCount 0, faceCount 1, levelCount 1, supercompression none
    index = struct.pack("<4I2Q", dfd_offset, len(dfd), kvd_offset, len(kvd), 0, 0)
    levels = struct.pack("<3Q", data_offset, len(pixels), len(pixels))
    head = IDENTIFIER + header + index + levels + dfd + kvd
    return head + b"\0" * (data_offset - len(head)) + pixels


def write_ktx2(table, path, encoding: str | None = None) -> list[Path]:
    """Write ``table`` as a KTX2 file atomically; returns ``[path]``."""
    return [write_bytes(path, ktx2_bytes(table, encoding))]


def _write(table, path) -> list[Path]:
    return write_ktx2(table, path)


def _decode(data: bytes, name: str, count: int, n_channels: int) -> np.ndarray:
    _, comps, bits, kind = VK_FORMATS[name]
    if kind == "pack32":
        words = np.frombuffer(data, dtype="<u4", count=count).astype(np.uint32)
        parts = [(words >> s) & 1023 for s in (0, 10, 20)]
        return np.stack(parts[:n_channels], axis=-1).astype(np.float64) / 1023.0
    if kind == "float":
        arr = np.frombuffer(data, dtype="<f4" if bits == 32 else "<f2", count=count * len(comps))
        return arr.reshape(count, len(comps))[:, :n_channels].astype(np.float64)
    arr = np.frombuffer(data, dtype="<u2" if bits == 16 else "u1", count=count * len(comps))
    return arr.reshape(count, len(comps))[:, :n_channels].astype(np.float64) / ((1 << bits) - 1)


def ktx2_from_bytes(data: bytes, factory: Callable | None = None, *, source: str = "ktx2 data"):
    """The table held by the bytes of a KTX2 file bsdf-tab wrote.

    Value channels are the decoded components (float64); each ``X_err`` is the stored bound
    from the metadata (see :func:`bsdf_tab.io.texture.table_from_texels`).

    Raises
    ------
    ValueError
        If the data is not a KTX2 file, uses a format or feature bsdf-tab does not write, or
        has no bsdf-tab metadata.
    """
    if data[:12] != IDENTIFIER or len(data) < 104:
        raise ValueError(f"{source}: not a KTX 2.0 file")
    vk_value, _, width, height, depth, layers, faces, levels, scheme = struct.unpack_from("<9I", data, 12)
    _, _, kvd_offset, kvd_length, _, _ = struct.unpack_from("<4I2Q", data, 48)
    if vk_value not in _BY_VALUE or layers > 1 or faces != 1 or levels != 1 or scheme != 0:
        raise ValueError(f"{source}: a KTX2 texture bsdf-tab does not read (VkFormat {vk_value}, "
                         f"{layers} layers, {faces} faces, {levels} levels, supercompression {scheme})")
    name = _BY_VALUE[vk_value]
    offset, length, _ = struct.unpack_from("<3Q", data, 80)
    pairs, pos, end = {}, kvd_offset, kvd_offset + kvd_length
    while pos < end:
        (size,) = struct.unpack_from("<I", data, pos)
        entry = data[pos + 4: pos + 4 + size]
        key, _, value = entry.partition(b"\0")
        pairs[key.decode("utf-8")] = value.rstrip(b"\0").decode("utf-8", "replace")
        pos += 4 + size + (-size % 4)
    axes, names, meta = parts_from_metadata(pairs, source)
    count = max(width, 1) * max(height, 1) * max(depth, 1)
    texels = _decode(data[offset: offset + length], name, count, len(names))
    channels, meta = table_from_texels(texels, axes, names, meta)
    return build(axes, channels, meta, factory)


def read_ktx2(path, factory: Callable | None = None):
    """Read a KTX2 file bsdf-tab wrote (see :func:`ktx2_from_bytes`)."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no such file: {path}")
    return ktx2_from_bytes(path.read_bytes(), factory, source=str(path))


def _as_stored(table, factory: Callable | None = None):
    return as_encoded(table, requested_encoding(table, "ktx2"), "ktx2", factory)


FORMAT = Format(
    name="ktx2",
    suffixes=(".ktx2",),
    description="KTX 2.0 GPU texture (R16G16_SFLOAT, R16G16_UNORM, A2B10G10R10, ...), linear, lookup in key/value data",
    write=_write,
    media_type="image/ktx2",
    to_bytes=ktx2_bytes,
    read=read_ktx2,
    from_bytes=ktx2_from_bytes,
    as_stored=_as_stored,
)
