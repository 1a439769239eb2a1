"""KTX2, DDS and PNG files read back by independent readers, and the storage errors they report.

Truth comes from outside the code under test:

- KTX2: the ``pyktx2`` parser (PyPI) reads the container (identifier, header, index, DFD, key /
  value data, level data). pyktx2 0.3.1 has two bugs that the test corrects from the KTX 2.0
  specification before parsing: its ColorModel enum lacks KHR_DF_MODEL_RGBSDA (1), and its
  key/value padding is ``alignment - pos % 8`` (the spec: pad to 4). Its level check needs
  the texel size, which the test supplies from its own table of Vulkan formats. The DFD words
  are then decoded here from the Khronos Data Format 1.3 layout, and the level data with numpy.
- DDS: the header is decoded here from Microsoft's ``DDS_HEADER`` / ``DDS_HEADER_DXT10``
  layout; OpenImageIO (PyPI ``openimageio``) reads the DXGI formats it supports
  (R10G10B10A2_UNORM, R8G8B8A8_UNORM; 3.2 refuses R16G16_FLOAT, R16G16_UNORM, R8G8_UNORM, ...).
- PNG: OpenImageIO reads the 16- and 8-bit files and their tEXt metadata.
- The stored values and errors: numpy's own float16 / float32 rounding and
  ``round(clip(x, 0, 1) * (2^b - 1))`` computed here.
"""

from __future__ import annotations

import enum
import json
import struct

import numpy as np
import pytest

import bsdf_tab.io as bio
from bsdf_tab.io import storage
from bsdf_tab.table import Table

# Vulkan format -> (VkFormat value, components, bits per component, kind); from the Vulkan spec
VK = {
    "R16G16_SFLOAT": (83, 2, 16, "float"),
    "R32G32_SFLOAT": (103, 2, 32, "float"),
    "R16_SFLOAT": (76, 1, 16, "float"),
    "R32_SFLOAT": (100, 1, 32, "float"),
    "R16G16_UNORM": (77, 2, 16, "unorm"),
    "R8G8_UNORM": (16, 2, 8, "unorm"),
    "A2B10G10R10_UNORM_PACK32": (64, 4, 10, "pack32"),
}
# (VkFormat name, encoding, channels of the table)
CASES = [
    ("R16G16_SFLOAT", "float16", 2),
    ("R32G32_SFLOAT", "float32", 2),
    ("R16_SFLOAT", "float16", 1),
    ("R32_SFLOAT", "float32", 1),
    ("R16G16_UNORM", "unorm16", 2),
    ("R8G8_UNORM", "unorm8", 2),
    ("A2B10G10R10_UNORM_PACK32", "unorm10", 2),
]


def table_of(n_channels: int, shape=(5, 7), seed=0) -> Table:
    rng = np.random.default_rng(seed)
    names = ["A", "B", "C", "D"][:n_channels]
    axes = {n: np.linspace(0.0, 1.0, s) for n, s in zip(["w", "mu", "roughness"][-len(shape):], shape)}
    channels = {n: rng.random(shape) for n in names}
    channels.update({n + "_err": np.full(shape, 3e-7) for n in names})
    return Table(axes, channels, {"spec": {"table": "dfg"}, "version": "0.test"})


def expected_stored(x: np.ndarray, encoding: str) -> np.ndarray:
    """What the file must hold, computed with numpy here."""
    if encoding == "float16":
        return x.astype(np.float16).astype(np.float64)
    if encoding == "float32":
        return x.astype(np.float32).astype(np.float64)
    bits = {"unorm16": 16, "unorm10": 10, "unorm8": 8}[encoding]
    return np.round(np.clip(x, 0, 1) * (2**bits - 1)) / (2**bits - 1)


@pytest.fixture
def pyktx2(monkeypatch):
    parser = pytest.importorskip("pyktx2.parser", reason="pyktx2 (pip install pyktx2) is not installed")
    # the two corrections from the KTX 2.0 / Khronos Data Format specifications (see the module doc)
    members = {m.name: m.value for m in parser.ColorModel}
    members["KHR_DF_MODEL_RGBSDA"] = 1
    monkeypatch.setattr(parser, "ColorModel", enum.Enum("ColorModel", members))
    monkeypatch.setattr(parser.BytesReader, "get_padding_size", lambda self, alignment: -self.pos % alignment)
    return parser


def parse_ktx2(parser, data: bytes, texel_bytes: int):
    parser.get_stride = lambda fmt: texel_bytes  # the level-size check of pyktx2 needs it
    return parser.parse_bytes(data)


def texel_bytes(name: str) -> int:
    _, comps, bits, kind = VK[name]
    return 4 if kind == "pack32" else comps * bits // 8


@pytest.mark.parametrize("name,encoding,n", CASES)
@pytest.mark.parametrize("shape", [(5, 7), (3, 4, 6)])
def test_ktx2_read_by_pyktx2(pyktx2, name, encoding, n, shape):
    table = table_of(n, shape)
    table.meta["storage"] = {"encoding": encoding}
    data = bio.to_bytes(table, "ktx2")
    k = parse_ktx2(pyktx2, data, texel_bytes(name))
    value, comps, bits, kind = VK[name]
    assert k.vkFormat.value == value
    assert k.typeSize == (4 if kind == "pack32" else bits // 8)
    dims = (shape[-1], shape[-2], shape[0] if len(shape) == 3 else 0)
    assert (k.pixelWidth, k.pixelHeight, k.pixelDepth) == dims
    assert (k.layerCount, k.faceCount, k.levelCount, k.supercompressionScheme.value) == (0, 1, 1, 0)
    assert k.levelIndices[0].byteOffset % np.lcm(texel_bytes(name), 4) == 0  # mip level alignment
    assert k.levelIndices[0].byteLength == int(np.prod(shape)) * texel_bytes(name)
    assert k.levelIndices[0].uncompressedByteLength == k.levelIndices[0].byteLength
    # key / value data: orientation, writer, and the metadata (sorted keys, NUL-terminated)
    assert list(k.kv) == sorted(k.kv, key=lambda s: s.encode())
    assert k.kv["KTXorientation"] == (b"rd\0" if len(shape) == 2 else b"rdi\0")
    assert k.kv["KTXwriter"].startswith(b"bsdf-tab")
    axes = json.loads(k.kv["bsdf_tab_axes"].rstrip(b"\0"))
    assert {a: np.asarray(v).tolist() for a, v in axes.items()} == {a: v.tolist() for a, v in table.axes.items()}
    lookup = json.loads(k.kv["bsdf_tab_lookup"].rstrip(b"\0"))
    assert lookup["components"]["R"] == "A" and [a["name"] for a in lookup["axes"]] == list(table.axes)
    meta = json.loads(k.kv["bsdf_tab_meta"].rstrip(b"\0"))
    assert meta["storage"]["encoding"] == encoding and meta["storage"]["vk_format"] == "VK_FORMAT_" + name
    # the level data, decoded with numpy, holds numpy's rounding of the values
    level = data[k.levelIndices[0].byteOffset:][: k.levelIndices[0].byteLength]
    assert b"".join(img.data for img in k.levelImages) == level  # pyktx2 sliced the same bytes
    count = int(np.prod(shape))
    if kind == "pack32":
        words = np.frombuffer(level, dtype="<u4")
        got = np.stack([(words >> (10 * c)) & 1023 for c in range(3)] + [words >> 30], -1) / np.array(
            [1023, 1023, 1023, 3])
        assert (got[:, 3] == 1).all() and (got[:, n:3] == 0).all()
    elif kind == "float":
        got = np.frombuffer(level, dtype="<f2" if bits == 16 else "<f4").reshape(count, comps).astype(np.float64)
    else:
        got = np.frombuffer(level, dtype="<u2" if bits == 16 else "u1").reshape(count, comps) / (2**bits - 1)
    for c, ch in enumerate(["A", "B"][:n]):
        np.testing.assert_array_equal(got[:, c], expected_stored(table.channels[ch].ravel(), encoding))


@pytest.mark.parametrize("name,encoding,n", CASES)
def test_ktx2_dfd_fields_against_the_spec(pyktx2, name, encoding, n):
    table = table_of(n)
    table.meta["storage"] = {"encoding": encoding}
    data = bio.to_bytes(table, "ktx2")
    k = parse_ktx2(pyktx2, data, texel_bytes(name))
    basic, samples = k.dfd
    assert basic.colorModel.value == 1  # KHR_DF_MODEL_RGBSDA
    assert basic.colorPrimaries.value == 1  # BT709
    assert basic.transferFunction.value == 1  # KHR_DF_TRANSFER_LINEAR: no sRGB decode
    assert basic.flags == 0  # straight alpha
    assert (basic.texelBlockDimension0, basic.texelBlockDimension1, basic.texelBlockDimension2,
            basic.texelBlockDimension3) == (0, 0, 0, 0)  # 1 x 1 x 1 x 1 blocks, stored minus one
    assert basic.bytesPlane0 == texel_bytes(name) and basic.bytesPlane1 == 0
    # the descriptor's own words: dfdTotalSize, vendorId / type, version 2 (1.3), block size
    dfd = data[k.dfdByteOffset:k.dfdByteOffset + k.dfdByteLength]
    total, vendor_type, version, block = struct.unpack_from("<IIHH", dfd)
    assert total == k.dfdByteLength == 4 + 24 + 16 * len(samples)
    assert vendor_type == 0 and version == 2 and block == 24 + 16 * len(samples)
    _, comps, bits, kind = VK[name]
    expected = []  # (bitOffset, bitLength - 1, channelType, lower, upper), from the DF spec
    if kind == "pack32":
        for c, (off, length, cid) in enumerate([(0, 10, 0), (10, 10, 1), (20, 10, 2), (30, 2, 15)]):
            expected.append((off, length - 1, cid, 0, 2**length - 1))
    else:
        for c in range(comps):
            cid = [0, 1, 2, 15][c]
            if kind == "float":  # KHR_DF_SAMPLE_DATATYPE_FLOAT | SIGNED; -1.0f / 1.0f
                expected.append((c * bits, bits - 1, cid | 0x80 | 0x40, 0xBF800000, 0x3F800000))
            else:
                expected.append((c * bits, bits - 1, cid, 0, 2**bits - 1))
    got = []
    for s in samples:
        w0, w1, lower, upper = struct.unpack("<4I", s)
        got.append((w0 & 0xFFFF, (w0 >> 16) & 0xFF, w0 >> 24, lower, upper))
        assert w1 == 0  # sample positions 0
    assert got == expected


def test_ktx2_round_trip_and_info_storage(tmp_path):
    table = table_of(2)
    table.meta["storage"] = {"encoding": "unorm16"}
    path = tmp_path / "lut.ktx2"
    bio.write(table, path)
    back = bio.read(path, factory=Table)
    for ch in ("A", "B"):
        np.testing.assert_array_equal(back.channels[ch], expected_stored(table.channels[ch], "unorm16"))
        report = back.meta["storage"]["channels"][ch]
        true_storage = np.abs(expected_stored(table.channels[ch], "unorm16") - table.channels[ch]).max()
        assert report["storage_error"] == pytest.approx(true_storage, rel=1e-12)
        assert report["integration_error"] == pytest.approx(3e-7)
        # the error channel read back bounds the stored value's error
        assert (back.channels[ch + "_err"] >= np.abs(back.channels[ch] - table.channels[ch])).all()


def test_ktx2_rejects_what_it_cannot_hold():
    with pytest.raises(ValueError, match="1 to 4 channels"):
        bio.to_bytes(table_of(4).__class__({"x": [0.0, 1.0]}, {c: [0.1, 0.2] for c in "ABCDE"}), "ktx2")
    t = table_of(4)
    t.meta["storage"] = {"encoding": "unorm10"}
    with pytest.raises(ValueError, match="at most 3"):
        bio.to_bytes(t, "ktx2")
    with pytest.raises(ValueError, match="not a KTX 2.0 file"):
        bio.from_bytes(b"nope" * 30, "ktx2")


# --------------------------------------------------------------------------- DDS

DXGI = {  # (encoding, table channels) -> (DXGI_FORMAT value, components, bytes per texel), Microsoft docs
    ("float16", 2): (34, 2, 4), ("float32", 2): (16, 2, 8), ("float16", 1): (54, 1, 2), ("float32", 1): (41, 1, 4),
    ("unorm16", 2): (35, 2, 4), ("unorm8", 2): (49, 2, 2), ("unorm10", 2): (24, 4, 4), ("unorm8", 4): (28, 4, 4),
}


@pytest.mark.parametrize("encoding,n", sorted(DXGI))
@pytest.mark.parametrize("shape", [(5, 7), (3, 4, 6)])
def test_dds_header_and_data(encoding, n, shape):
    table = table_of(n, shape)
    table.meta["storage"] = {"encoding": encoding}
    data = bio.to_bytes(table, "dds")
    dxgi, comps, tb = DXGI[(encoding, n)]
    assert data[:4] == b"DDS "
    size, flags, height, width, pitch, depth, mips = struct.unpack_from("<7I", data, 4)
    pf_size, pf_flags, fourcc = struct.unpack_from("<II4s", data, 4 + 72)
    caps, caps2 = struct.unpack_from("<2I", data, 4 + 104)
    assert size == 124 and pf_size == 32 and pf_flags == 0x4 and fourcc == b"DX10"
    assert flags & 0x100F == 0x100F and (width, height) == (shape[-1], shape[-2]) and pitch == width * tb
    assert mips == 1 and caps & 0x1000
    fmt, dim, misc, array, misc2 = struct.unpack_from("<5I", data, 128)
    assert fmt == dxgi and array == 1 and misc == 0
    if len(shape) == 3:
        assert dim == 4 and depth == shape[0] and flags & 0x800000 and caps2 & 0x200000 and caps & 0x8
    else:
        assert dim == 3 and depth == 0 and caps2 == 0
    body = data[148:]
    count = int(np.prod(shape))
    assert len(body) == count * tb
    if encoding == "unorm10":
        words = np.frombuffer(body, dtype="<u4")
        got = np.stack([(words >> (10 * c)) & 1023 for c in range(2)], -1) / 1023
        assert ((words >> 30) == 3).all()
    elif encoding.startswith("float"):
        got = np.frombuffer(body, dtype="<f2" if encoding == "float16" else "<f4").reshape(count, comps)
    else:
        bits = 16 if encoding == "unorm16" else 8
        got = np.frombuffer(body, dtype="<u2" if bits == 16 else "u1").reshape(count, comps) / (2**bits - 1)
    for c, ch in enumerate("ABCD"[:n]):
        np.testing.assert_array_equal(np.asarray(got[:, c], np.float64),
                                      expected_stored(table.channels[ch].ravel(), encoding))


@pytest.mark.parametrize("encoding,n", [("unorm10", 2), ("unorm10", 3), ("unorm8", 4), ("unorm8", 3)])
def test_dds_read_by_openimageio(tmp_path, encoding, n):
    oiio = pytest.importorskip("OpenImageIO", reason="openimageio (pip install openimageio) is not installed")
    table = table_of(n)
    table.meta["storage"] = {"encoding": encoding}
    path = tmp_path / "lut.dds"
    bio.write(table, path)
    inp = oiio.ImageInput.open(str(path))
    assert inp is not None, oiio.geterror()
    spec = inp.spec()
    pixels = inp.read_image("float")
    inp.close()
    assert (spec.width, spec.height) == (7, 5) and spec.nchannels == 4
    # OpenImageIO 3.2 converts these DDS formats to 8 bits: within 1/255 of the stored value
    for c, ch in enumerate("ABCD"[:n]):
        np.testing.assert_allclose(pixels[..., c], expected_stored(table.channels[ch], encoding), atol=1 / 255 + 1e-6)


# --------------------------------------------------------------------------- PNG


@pytest.mark.parametrize("encoding,bits", [("unorm16", 16), ("unorm8", 8)])
@pytest.mark.parametrize("n", [1, 2, 3, 4])
def test_png_read_by_openimageio(tmp_path, encoding, bits, n):
    oiio = pytest.importorskip("OpenImageIO", reason="openimageio (pip install openimageio) is not installed")
    table = table_of(n, shape=(3, 4, 5))  # 3-D: slices stacked vertically
    table.meta["storage"] = {"encoding": encoding}
    path = tmp_path / "lut.png"
    bio.write(table, path)
    config = oiio.ImageSpec()
    config.attribute("oiio:UnassociatedAlpha", 1)  # the 4th channel is data, not alpha to premultiply
    inp = oiio.ImageInput.open(str(path), config)
    assert inp is not None, oiio.geterror()
    spec = inp.spec()
    assert (spec.width, spec.height) == (5, 12) and spec.nchannels == {1: 1, 2: 3, 3: 3, 4: 4}[n]
    assert spec.format == (oiio.UINT16 if bits == 16 else oiio.UINT8)
    codes = inp.read_image(oiio.UINT16 if bits == 16 else oiio.UINT8)
    axes = json.loads(spec.getattribute("bsdf_tab_axes"))
    inp.close()
    assert axes["roughness"] == table.axes["roughness"].tolist()
    for c, ch in enumerate("ABCD"[:n]):
        want = np.round(np.clip(table.channels[ch], 0, 1) * (2**bits - 1)).reshape(12, 5)
        np.testing.assert_array_equal(codes[..., c], want)
    if n == 2:
        assert (codes[..., 2] == 0).all()
    back = bio.read(path, factory=Table)
    for ch in "ABCD"[:n]:
        np.testing.assert_array_equal(back.channels[ch], expected_stored(table.channels[ch], encoding))


# --------------------------------------------------------------------------- storage errors


@pytest.mark.parametrize("encoding", ["float16", "float32", "unorm16", "unorm10", "unorm8"])
def test_storage_report_is_numpy_rounding(encoding):
    table = table_of(2)
    table.channels["A"][0, 0], table.channels["B"][1, 1] = -0.02, 1.03  # beyond [0, 1]: the UNORM clamp shows
    report = storage.storage_report(table, encoding, "ktx2")
    for ch in ("A", "B"):
        x = table.channels[ch]
        stored = expected_stored(x, encoding)
        c = report["channels"][ch]
        assert c["storage_error"] == np.abs(stored - x).max()
        assert c["total_error"] == pytest.approx(np.max(np.abs(stored - x) + 3e-7), rel=1e-12)
        assert c["integration_error"] == pytest.approx(3e-7)
        clamp = np.abs(np.clip(x, 0, 1) - x).max() if encoding.startswith("unorm") else 0.0
        assert c["clamp_error"] == pytest.approx(clamp, abs=0)
        if encoding.startswith("unorm"):
            assert c["clamp_error"] > 0.0 and c["storage_error"] >= c["clamp_error"]


def test_auto_picks_the_smallest_within_tol():
    table = table_of(2)
    sizes = {"unorm8": 2, "unorm10": 4, "float16": 4, "unorm16": 4, "float32": 8}  # bytes per texel, 2 channels
    errors = {e: max(np.max(np.abs(expected_stored(table.channels[c], e) - table.channels[c]) + 3e-7)
                     for c in "AB") for e in sizes}
    for tol in (5e-3, 1e-3, 1e-4, 1e-5, 1e-6):
        fits = [e for e in sizes if errors[e] <= tol]
        want = min(fits, key=lambda e: (sizes[e], errors[e]))
        got, report = storage.choose_encoding(table, "ktx2", tol)
        assert got == want and report["bytes_per_texel"] == sizes[want]
    assert storage.choose_encoding(table, "png", 1e-3)[0] == "unorm16"
    with pytest.raises(ValueError, match="no ktx2 storage keeps"):
        storage.choose_encoding(table, "ktx2", 1e-7)
