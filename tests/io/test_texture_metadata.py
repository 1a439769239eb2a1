"""Texture writers: no infinity from a float encoding, shader-usable lookup metadata that matches
each file's own layout, linear colour signalling in PNG, and what ``info`` / ``bake`` say.

Truths come from outside the code under test:

- the range of float16 / float32 from ``numpy.finfo``; the stored bits decoded with numpy from
  the byte layouts of the KTX 2.0 specification (header, index, level index, key/value data:
  parsed here with ``struct``) and of Microsoft's DDS reference (148-byte DX10 header);
- PNG chunks parsed here with ``struct`` / ``zlib`` (PNG specification), pixels and text read by
  OpenImageIO;
- the lookup formulas are evaluated with plain Python ``eval`` (no numpy names available) and
  the texel they land on is looked up in the decoded image: it must hold the node's value.
"""

from __future__ import annotations

import json
import math
import struct
import zlib

import numpy as np
import pytest

import bsdf_tab.api
import bsdf_tab.io as bio
from bsdf_tab import cli
from bsdf_tab.table import Table

HALF_MAX = float(np.finfo(np.float16).max)  # 65504


def table_of(shape, names=("A", "B"), axis_names=("ior", "mu", "roughness"), seed=3, unequal=None) -> Table:
    """Values in (0, 1), error channels 3e-7; axes with twelfths (no short decimal repr) and
    optionally one axis of unequal steps."""
    rng = np.random.default_rng(seed)
    axis_names = axis_names[-len(shape):]
    axes = {}
    for k, (n, s) in enumerate(zip(axis_names, shape)):
        values = (np.arange(s) + 1.0) / (s + 1.0) if s > 1 else np.array([0.5])  # 1/(s+1) ... s/(s+1)
        if unequal == k:
            values = values**2
        axes[n] = values
    channels = {c: rng.random(shape) for c in names}
    channels.update({c + "_err": np.full(shape, 3e-7) for c in names})
    meta = {"spec": {"table": "dfg"}, "version": "0.test",
            "method": {"name": "adaptive", "precision": "float64 (stored as float32)"}}
    return Table(axes, channels, meta)


# --------------------------------------------------------------------------- independent parsers


def ktx2_parts(data: bytes):
    """(vkFormat, (width, height, depth), key/value dict of str, level bytes) per the KTX 2.0 spec."""
    assert data[:12] == b"\xabKTX 20\xbb\r\n\x1a\n"
    vk, _type_size, width, height, depth = struct.unpack_from("<5I", data, 12)
    _dfd_off, _dfd_len, kvd_off, kvd_len = struct.unpack_from("<4I", data, 48)
    level_off, level_len, _ = struct.unpack_from("<3Q", data, 80)
    kv, pos = {}, kvd_off
    while pos < kvd_off + kvd_len:
        (size,) = struct.unpack_from("<I", data, pos)
        key, _, value = data[pos + 4:pos + 4 + size].partition(b"\0")
        assert value.endswith(b"\0")  # NUL-terminated values
        kv[key.decode()] = value[:-1].decode()
        pos += 4 + size + (-size % 4)
    return vk, (width, height, depth), kv, data[level_off:level_off + level_len]


def png_chunks(data: bytes) -> list[tuple[bytes, bytes]]:
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    out, pos = [], 8
    while pos < len(data):
        (length,) = struct.unpack_from(">I", data, pos)
        kind, body = data[pos + 4:pos + 8], data[pos + 8:pos + 8 + length]
        (crc,) = struct.unpack_from(">I", data, pos + 8 + length)
        assert crc == zlib.crc32(kind + body) & 0xFFFFFFFF
        out.append((kind, body))
        pos += 12 + length
    return out


def png_text(data: bytes) -> dict[str, str]:
    text = {}
    for kind, body in png_chunks(data):
        if kind == b"tEXt":
            key, _, value = body.partition(b"\0")
            text[key.decode("latin-1")] = value.decode("latin-1")
    return text


def png_codes(path, bits: int) -> np.ndarray:
    oiio = pytest.importorskip("OpenImageIO", reason="openimageio (pip install openimageio) is not installed")
    inp = oiio.ImageInput.open(str(path))
    assert inp is not None, oiio.geterror()
    codes = inp.read_image(oiio.UINT16 if bits == 16 else oiio.UINT8)
    inp.close()
    return np.asarray(codes)


# --------------------------------------------------------------------------- 1. float16 range


def huge_table(value: float) -> Table:
    table = table_of((3, 4))
    table.channels["B"][1, 2] = value
    return table


@pytest.mark.parametrize("fmt", ["ktx2", "dds"])
def test_float16_textures_refuse_values_beyond_the_half_range(tmp_path, fmt):
    table = huge_table(7.0e4)
    with np.errstate(over="ignore"):
        assert np.isinf(np.float16(7.0e4))  # what the file would hold
    with pytest.raises(ValueError) as exc:
        bio.to_bytes(table, fmt)
    message = str(exc.value)
    assert "\n" not in message
    for fragment in ("channel B", "float16 range", "70000", "--precision float32"):
        assert fragment in message, message
    with pytest.raises(ValueError, match="float16 range"):
        bio.as_stored(table, fmt)
    # nothing written, an existing file kept
    path = tmp_path / f"lut.{fmt}"
    path.write_bytes(b"old")
    with pytest.raises(ValueError, match="float16 range"):
        bio.write(table, path)
    assert path.read_bytes() == b"old" and [p.name for p in tmp_path.iterdir()] == [path.name]


def test_half_exr_names_the_largest_value():
    with pytest.raises(ValueError) as exc:
        bio.to_bytes(huge_table(-1.25e6), "half-exr")
    assert "channel B" in str(exc.value) and "1.25e+06" in str(exc.value) and "exr" in str(exc.value)


@pytest.mark.parametrize("fmt", ["ktx2", "dds"])
def test_float16_keeps_the_largest_half_and_float32_stores_beyond(fmt):
    edge = huge_table(HALF_MAX)  # exactly representable: stored as is
    data = bio.to_bytes(edge, fmt)
    level = ktx2_parts(data)[3] if fmt == "ktx2" else data[148:]
    halves = np.frombuffer(level, dtype="<f2")
    assert np.isfinite(halves).all() and halves.max() == HALF_MAX
    big = huge_table(7.0e4)
    big.meta["storage"] = {"encoding": "float32"}
    data = bio.to_bytes(big, fmt)
    level = ktx2_parts(data)[3] if fmt == "ktx2" else data[148:]
    floats = np.frombuffer(level, dtype="<f4")
    assert np.isfinite(floats).all() and floats.max() == np.float32(7.0e4)


def test_unorm_textures_clamp_and_report_instead(tmp_path):
    table = huge_table(7.0e4)
    table.meta["storage"] = {"encoding": "unorm16"}
    for fmt in ("ktx2", "dds", "png"):
        assert bio.to_bytes(table, fmt)  # a clamp is measured and reported, never an infinity
    report = bio.as_stored(table, "png").meta["storage"]["channels"]["B"]
    assert report["clamp_error"] == 7.0e4 - 1.0


@pytest.fixture
def bsdf_spec(tmp_path):
    path = tmp_path / "bsdf3.json"  # the audit's table: f_r reaches 5.4e5 at alpha 0.001
    path.write_text(json.dumps({"table": "bsdf", "alpha": 0.001, "fresnel": {"type": "one"},
                                "parametrization": "half_diff",
                                "axes": {"theta_h": {"size": 4}, "theta_d": {"size": 4}, "phi_d": {"size": 4}}}))
    return path


def run(capsys, *argv):
    code = cli.main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


@pytest.mark.parametrize("ending", [".ktx2", ".dds", ".half.exr"])
def test_bake_refuses_a_float16_file_with_one_line(tmp_path, capsys, bsdf_spec, ending):
    out_path = tmp_path / f"x{ending}"
    code, out, err = run(capsys, "bake", bsdf_spec, "-o", out_path, "-q")
    lines = [line for line in err.strip().splitlines() if "Warp" not in line]
    assert code == 2 and len(lines) == 1, err
    assert "channel f_r" in lines[0] and "float16 range" in lines[0] and "inf" not in out
    assert not out_path.exists()
    if ending != ".half.exr":
        code, out, err = run(capsys, "bake", bsdf_spec, "-o", out_path, "-q", "--precision", "float32")
        assert code == 0, err
        assert "inf" not in out and out_path.exists()


# --------------------------------------------------------------------------- 2-3. lookup metadata


def rhs(coordinate: str) -> str:
    """The expression of ``t = EXPR`` or ``t = EXPR, k the fractional index ...``."""
    expr = coordinate.split(" = ", 1)[1]
    return expr.split(", k ", 1)[0]


def evaluate(coordinate: str, env: dict) -> float:
    return float(eval(rhs(coordinate), {"__builtins__": {}}, dict(env)))  # plain Python only


def written(fmt: str, table: Table, tmp_path):
    """(lookup dict, every metadata string, image (depth, height, width, comps) as float64 stored
    values) of the file ``fmt`` writes, read back independently."""
    path = tmp_path / f"lut.{fmt}"
    bio.write(table, path)
    data = path.read_bytes()
    if fmt == "ktx2":
        vk, (w, h, d), kv, level = ktx2_parts(data)
        assert vk == 103  # R32G32_SFLOAT: the values exactly (float32)
        image = np.frombuffer(level, dtype="<f4").astype(np.float64).reshape(max(d, 1), max(h, 1), w, 2)
        strings = kv
        dims = (w, h, d)
    else:
        strings = png_text(data)
        codes = png_codes(path, 16).astype(np.float64) / 65535
        image = codes.reshape((1,) + codes.shape)
        dims = (image.shape[2], image.shape[1], 0)  # a PNG is one 2-D image
    return json.loads(strings["bsdf_tab_lookup"]), strings, image, dims


def expected(table: Table, fmt: str, c: str) -> np.ndarray:
    x = table.channels[c]
    return x.astype(np.float32).astype(np.float64) if fmt == "ktx2" else np.round(np.clip(x, 0, 1) * 65535) / 65535


@pytest.mark.parametrize("fmt", ["ktx2", "png"])
@pytest.mark.parametrize("shape,unequal", [((11,), None), ((11, 5), None), ((4, 11, 5), None), ((4, 11, 5), 1),
                                           ((3, 6, 7), 0), ((1, 5, 3), None), ((4, 1, 3), None)])
def test_lookup_formula_lands_on_the_node_texel(tmp_path, fmt, shape, unequal):
    table = table_of(shape, unequal=unequal)
    if fmt == "ktx2":
        table.meta["storage"] = {"encoding": "float32"}
    lookup, strings, image, dims = written(fmt, table, tmp_path)
    for key, value in strings.items():
        assert "np." not in value and "float64(" not in value, (key, value)
    depth, height, width = image.shape[:3]
    names = list(table.axes)
    entries = {e["name"]: e for e in lookup["axes"]}
    assert [e["name"] for e in lookup["axes"]] == names
    stacked = fmt == "png" and len(shape) == 3
    layout = lookup["layout"]
    assert (layout["width"], layout["height"], layout["depth"]) == dims  # the file's own image
    assert layout["kind"] == ("stacked slices" if stacked else {1: "1d", 2: "2d", 3: "volume"}[len(shape)])
    if stacked:
        assert height == shape[0] * shape[1] and depth == 1
    for node in np.ndindex(*shape):
        env = {n: float(table.axes[n][i]) for n, i in zip(names, node)}
        env["k"] = None
        coords = {}
        for n, i in zip(names, node):
            e = entries[n]
            local = dict(env)
            if e["mapping"] == "unequal steps":
                local["k"] = float(i)  # the fractional index of a node is its index
            if stacked:
                local[f"i_{names[0]}"] = node[0]
            coords[e["texture_axis"]] = evaluate(e["coordinate"], local)
        if stacked:
            assert coords["slice"] == pytest.approx(node[0], abs=1e-9)
        # the coordinate is a texel centre, and that texel holds this node
        x = coords["u"] * width
        y = coords.get("v", 0.5 / height) * height
        z = coords.get("w", 0.5 / depth) * depth
        for t in (x, y, z):
            assert t - math.floor(t) == pytest.approx(0.5, abs=1e-9)
        texel = image[math.floor(z), math.floor(y), math.floor(x)]
        for ci, c in enumerate(["A", "B"]):
            assert texel[ci] == expected(table, fmt, c)[node], (node, c)


def test_png_stacked_rows_never_leave_their_slice(tmp_path):
    """At the ends of axis 1 the v of slice i is the centre of its first / last row: bilinear
    filtering there gives the neighbouring slice's row weight 0."""
    table = table_of((3, 5, 4))
    lookup = written("png", table, tmp_path)[0]
    e1 = lookup["axes"][1]
    n0, n1 = 3, 5
    for i0 in range(n0):
        for a1, row in ((table.axes["mu"][0], i0 * n1), (table.axes["mu"][-1], i0 * n1 + n1 - 1)):
            v = evaluate(e1["coordinate"], {"mu": float(a1), "i_ior": i0})
            assert v * n0 * n1 == pytest.approx(row + 0.5, abs=1e-9)
    assert "slice" in lookup["layout"]["filtering"] and "row" in lookup["layout"]["texel"]
    assert lookup["axes"][0]["texture_axis"] == "slice"


def test_ktx2_lookup_is_shader_syntax():
    """Every number in the formulas is a decimal literal with a point or exponent (GLSL's
    ``7 / 8`` would be integer division)."""
    import re

    table = table_of((4, 7, 8))
    _, _, kv, _ = ktx2_parts(bio.to_bytes(table, "ktx2"))
    for e in json.loads(kv["bsdf_tab_lookup"])["axes"]:
        expr = rhs(e["coordinate"])
        for literal in re.findall(r"(?<![\w.])\d[\d.e+-]*", expr):
            assert "." in literal or "e" in literal, (literal, expr)


# --------------------------------------------------------------------------- 4a. PNG colour chunks


@pytest.mark.parametrize("n", [1, 2, 4])
def test_png_declares_linear_samples(tmp_path, n):
    table = table_of((3, 4), names=("A", "B", "C", "D")[:n])
    path = tmp_path / "lut.png"
    bio.write(table, path)
    chunks = png_chunks(path.read_bytes())
    kinds = [k for k, _ in chunks]
    assert b"sRGB" not in kinds and b"iCCP" not in kinds
    body = dict(chunks)
    assert struct.unpack(">I", body[b"gAMA"])[0] == 100000  # gamma 1.0
    assert body[b"cICP"] == bytes([1, 8, 0, 1])  # BT.709, H.273 transfer 8 = linear, RGB, full range
    assert kinds.index(b"gAMA") < kinds.index(b"IDAT") and kinds.index(b"cICP") < kinds.index(b"IDAT")
    oiio = pytest.importorskip("OpenImageIO", reason="openimageio (pip install openimageio) is not installed")
    inp = oiio.ImageInput.open(str(path))
    colour_space = str(inp.spec().getattribute("oiio:ColorSpace") or "")
    inp.close()
    assert "srgb" not in colour_space.lower()


def test_doctor_reads_our_png_as_linear(tmp_path):
    readers = pytest.importorskip("bsdf_tab.doctor.readers")
    path = tmp_path / "lut.png"
    bio.write(table_of((3, 4)), path)
    assert readers.read_png(path.read_bytes()).transfer == "linear"


# --------------------------------------------------------------------------- 4b-c. info and bake words


def test_info_of_a_float16_ktx2_says_what_is_stored(tmp_path, capsys):
    table = table_of((3, 4))
    path = tmp_path / "lut.ktx2"
    bio.write(table, path)
    code, out, err = run(capsys, "info", path)
    assert code == 0, err
    assert "stored as float32" not in out and "precision: float64 (stored as float16, ktx2)" in out
    channels = next(line for line in out.splitlines() if line.startswith("channels:"))
    assert channels.startswith("channels: A, B;") and "not stored" in channels and "A_err" in channels
    exr = tmp_path / "lut.exr"
    bio.write(table, exr)
    code, out, err = run(capsys, "info", exr)
    assert "channels: A, B, A_err, B_err" in out and "not stored" not in out


def test_streamed_exr_bake_reports_its_storage(tmp_path, capsys, bsdf_spec):
    spec = json.loads(bsdf_spec.read_text())
    spec["alpha"] = 0.3
    bsdf_spec.write_text(json.dumps(spec))
    assert bsdf_tab.api.streams(spec)  # the bake goes through the streaming writer
    out_path = tmp_path / "x.exr"
    code, out, err = run(capsys, "bake", bsdf_spec, "-o", out_path, "-q")
    assert code == 0, err
    stored = Table.read(out_path)
    x = np.asarray(stored.channels["f_r"], dtype=np.float64)
    report = stored.meta["storage"]
    assert report["encoding"] == "float32" and report["format"] == "exr"
    # the file holds float32 values: their rounding is below half a float32 ulp of each
    assert report["channels"]["f_r"]["storage_error"] <= float(np.max(np.spacing(np.float32(x)))) / 2
    assert f"storage float32 adds f_r {report['channels']['f_r']['storage_error']:.2g}" in out


def test_a_header_named_after_a_digit_gets_no_reserved_identifier(tmp_path):
    """C reserves names starting with an underscore and a capital or a second underscore: a
    table file named ``3d-lut.h`` gets ``lut_3d_lut`` identifiers (the lookup code uses the same)."""
    import re

    import bsdf_tab
    from bsdf_tab.io.c_header import c_prefix, header_text

    table = bsdf_tab.tabulate({"table": "albedo_avg", "axes": {"alpha": [0.2, 0.5]}, "tolerance": 1e-3})
    text = header_text(table, "3d-lut")
    names = set(re.findall(r"(?:#define|static const (?:float|double))\s+([A-Za-z_][A-Za-z0-9_]*)", text))
    names.discard("BSDF_TAB_LUT_3D_LUT_H")  # the include guard
    assert names and all(n.lower().startswith("lut_3d_lut") for n in names), names
    assert not any(n.startswith("_") for n in names)
    assert c_prefix("_x") == "lut_x" and c_prefix("dfg") == "dfg" and c_prefix("9") == "lut_9"


@pytest.mark.parametrize("suffix", [".png", ".ktx2", ".dds"])
def test_a_four_axis_table_is_refused_by_every_texture(tmp_path, suffix):
    """A final review's find: PNG reached a KeyError (an internal error) where KTX2 and DDS refuse."""
    import bsdf_tab

    table = bsdf_tab.tabulate({"table": "albedo_aniso", "axes": {"mu": [0.5, 1.0], "phi_v": [0.0], "alpha": [0.3],
                                                                 "anisotropy": [0.0]}})
    from bsdf_tab.io import write

    with pytest.raises(ValueError, match="1 to 3 axes, this one has 4"):
        write(table, tmp_path / f"t{suffix}")
    assert not any(tmp_path.iterdir())
