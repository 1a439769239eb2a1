"""The doctor's readers: every container against the values we stored (truth: the table, rounded
as the storage rounds), files from bsdf-tab's writers and from independent ones (Pillow, OpenEXR),
KTX2 zstd supercompression rebuilt here from the KTX 2.0 specification."""

from __future__ import annotations

import struct

import numpy as np
import pytest

from bsdf_tab.doctor import check_lut_bytes, read_lut_bytes
from bsdf_tab.errors import SpecError

from conftest import image_of


def _zstd_ktx2(data: bytes) -> bytes:
    """The same KTX2 with level 0 zstd-supercompressed (KTX 2.0 section 3.1 / 3.9: scheme 2 in the
    header, byteLength the compressed size, uncompressedByteLength unchanged)."""
    zstandard = pytest.importorskip("zstandard")
    levels = struct.unpack_from("<I", data, 12 + 28)[0]
    assert levels == 1
    offset, length, raw_len = struct.unpack_from("<3Q", data, 80)
    packed = zstandard.ZstdCompressor(level=19).compress(data[offset:offset + length])
    out = bytearray(data[:offset]) + packed
    struct.pack_into("<I", out, 12 + 32, 2)  # supercompressionScheme = Zstandard
    struct.pack_into("<3Q", out, 80, offset, len(packed), raw_len)
    return bytes(out)


def test_ktx2_float16_and_zstd(ours):
    from bsdf_tab.io.ktx2 import ktx2_bytes

    plain = ktx2_bytes(ours, "float16")
    truth = image_of(ours).astype(np.float16).astype(np.float64)
    img = read_lut_bytes(plain, "dfg.ktx2")
    assert img.storage == "float16" and img.transfer == "linear" and img.channels == ["R", "G"]
    np.testing.assert_array_equal(img.data, truth)
    packed = _zstd_ktx2(plain)
    assert len(packed) < len(plain)
    np.testing.assert_array_equal(read_lut_bytes(packed, "dfg.ktx2").data, truth)
    r = check_lut_bytes(packed, "dfg.ktx2").to_dict()
    assert (r["table"], r["shadowing"]) == ("dfg", "correlated") and r["channels"] == {"R": "A", "G": "B"}
    assert r["findings"] == ["stored as float16: rounding up to 2.4e-4 for values in [0.5, 1)"]


@pytest.mark.parametrize("encoding,tol", [("unorm16", 0.5 / 65535), ("unorm8", 0.5 / 255), ("float32", 0.0)])
def test_dds(ours, encoding, tol):
    from bsdf_tab.io.dds import dds_bytes

    img = read_lut_bytes(dds_bytes(ours, encoding), "dfg.dds")
    assert img.storage == encoding
    got = img.data[:, :, :2]
    assert np.abs(got - image_of(ours)).max() <= tol + 1e-7


def test_png_16_bit_from_our_writer_and_8_bit_from_pillow(ours, tmp_path):
    from PIL import Image

    from bsdf_tab.io.png import png_bytes

    img = read_lut_bytes(png_bytes(ours, "unorm16"), "dfg.png")
    assert img.storage == "unorm16" and "axes" in img.claims
    np.testing.assert_allclose(img.data[:, :, :2], np.round(image_of(ours) * 65535) / 65535, atol=1e-12)
    # Pillow chooses the scanline filters itself (sub / up / average / paeth)
    rgb = np.clip(np.round(np.dstack([image_of(ours), np.linspace(0, 1, ours.shape[1])[None, :].repeat(ours.shape[0], 0)]) * 255), 0, 255).astype(np.uint8)
    path = tmp_path / "pillow.png"
    Image.fromarray(rgb, "RGB").save(path, optimize=True)
    img8 = read_lut_bytes(path.read_bytes(), "pillow.png")
    assert img8.storage == "unorm8" and img8.channels == ["R", "G", "B"]
    np.testing.assert_array_equal(np.round(img8.data * 255).astype(np.uint8), rgb)


def test_foreign_exr_without_claims(ours, tmp_path):
    import OpenEXR

    path = tmp_path / "foreign.exr"
    pixels = {"R": ours.channels["A"].astype(np.float32), "G": ours.channels["B"].astype(np.float32)}
    with OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}, pixels) as f:
        f.write(str(path))
    img = read_lut_bytes(path.read_bytes(), "foreign.exr")
    assert img.channels == ["G", "R"] or img.channels == ["R", "G"]
    assert img.claims == {}
    r = check_lut_bytes(path.read_bytes(), "foreign.exr").to_dict()
    assert r["channels"] == {"R": "A", "G": "B"} and r["table"] == "dfg"


def test_c_and_js_arrays(ours):
    values = image_of(ours).astype(np.float32)
    body = ",\n".join(", ".join(f"{v:.9g}f" for v in row) for row in values.reshape(ours.shape[0], -1))
    c = (f"/* DFG LUT [{ours.shape[0]}][{ours.shape[1]}][2] */\n"
         f"static const float dfg_lut[{ours.shape[0]}][{ours.shape[1]}][2] = {{\n{body}\n}};\n").encode()
    img = read_lut_bytes(c, "dfg.h", shape=(*ours.shape, 2))
    np.testing.assert_array_equal(img.data.astype(np.float32), values)  # 9 digits round-trip float32
    halves = image_of(ours).astype(np.float16).view(np.uint16).ravel()
    js = ("// three.js style: RG16F texels as half-float bit patterns\n"
          "const DATA = new Uint16Array( [ " + ", ".join(f"0x{h:04x}" for h in halves) + " ] );\nexport { DATA };\n").encode()
    img = read_lut_bytes(js, "DFGLUTData.js", shape=(*ours.shape, 2), array_values="half")
    np.testing.assert_array_equal(img.data, image_of(ours).astype(np.float16).astype(np.float64))
    with pytest.raises(SpecError, match="^shape: an array file needs its shape"):
        read_lut_bytes(c, "dfg.h")
    with pytest.raises(SpecError, match="^shape: the array file holds"):
        read_lut_bytes(c, "dfg.h", shape=(64, 64, 2))
    with pytest.raises(SpecError, match="^lut: "):
        read_lut_bytes(b"\x00\x01\x02garbage\xff", "x.bin")


def test_one_array_of_a_file_with_several(ours):
    """A source file that initializes several arrays (as Blender's eevee_lut.cc): ``array_name`` picks one."""
    values = image_of(ours).astype(np.float32)
    body = ", ".join(f"{v:.9g}f" for v in values.ravel())
    src = ("const float first[4] = {1.0f, 2.0f, 3.0f, 4.0f};\n"
           f"const float dfg_lut[{ours.shape[0]}][{ours.shape[1]}][2] = {{{body}}};\n"
           "const float last[2] = {5.0f, 6.0f};\n").encode()
    img = read_lut_bytes(src, "luts.cc", shape=(*ours.shape, 2), array_name="dfg_lut")
    np.testing.assert_array_equal(img.data.astype(np.float32), values)
    first = read_lut_bytes(src, "luts.cc", shape=(4,), array_name="first")
    np.testing.assert_array_equal(first.data[:, 0], [1, 2, 3, 4])
    with pytest.raises(SpecError, match="^array_name: no array named 'missing'"):
        read_lut_bytes(src, "luts.cc", shape=(4,), array_name="missing")
