"""Decreasing axes and the texture layouts of the KTX2 / DDS / PNG files.

The expected values are computed here, independently of ``bsdf_tab.lookup``: per axis the
fractional node index is ``np.interp`` of the coordinate (or of its square root, for an axis
uniform in sqrt(x)) over the table's actual node values, sorted increasing (a decreasing axis
is reversed, with its indices), held at the ends; the value is the multilinear corner sum over
the channel arrays. The texture layout is read from the files' own headers and pixel bytes
(parsed with ``struct`` / ``zlib`` here) and the emitted WGSL is run on those pixels through
wgpu (skipped without an adapter). Channel values are random, so a wrong bracket, a wrong
direction or a transposed texel lands far from the reference.
"""

from __future__ import annotations

import shutil
import struct
import subprocess
import zlib

import numpy as np
import pytest

import bsdf_tab
from bsdf_tab.lookup import emit_files, emit_source, fit_axis, lookup
from bsdf_tab.presets.axes import unit_centers, unit_endpoints

CC = shutil.which("gcc") or shutil.which("cc")


def _eevee_like(n):
    """EEVEE's NV = clamp(1 - y^2, 1e-4, 0.9999), y = j/(n-1): decreasing and irregular (written here)."""
    return np.clip(1.0 - (np.arange(n) / (n - 1)) ** 2, 1e-4, 0.9999)


#: name -> (axes: name -> (values, "sqrt" if the axis is uniform in sqrt(x) else "x"), channels)
def _axes_of(kind):
    if kind == "godot-2d":  # roughness decreasing at centres (Godot's rows), mu increasing endpoints
        return {"roughness": (unit_centers(9)[::-1], "x"), "mu": (unit_endpoints(7), "x")}, ("B", "E")
    if kind == "square-irregular-2d":  # mu decreasing uniform in sqrt(mu), roughness decreasing irregular
        return {"mu": (unit_endpoints(8)[::-1] ** 2, "sqrt"), "roughness": (_eevee_like(9), "x")}, ("A", "B")
    if kind == "dec-3d":  # increasing mu, decreasing alpha (endpoints), decreasing irregular eta
        return {"mu": (unit_endpoints(5), "x"), "alpha": (np.linspace(1.0, 0.1, 4), "x"),
                "eta": (np.array([2.5, 1.8, 1.3, 1.1]), "x")}, ("R", "T")
    if kind == "dec-1d":
        return {"alpha": (np.linspace(0.9, 0.1, 6), "x")}, ("E", "F", "G")
    if kind == "inc-3d":  # all increasing (layout checks)
        return {"mu": (unit_endpoints(3), "x"), "alpha": (unit_endpoints(4), "x"),
                "eta": (np.linspace(1.1, 2.0, 5), "x")}, ("R", "T")
    if kind == "inc-1d":
        return {"alpha": (unit_endpoints(7), "x")}, ("E",)
    raise KeyError(kind)


DEC_KINDS = ["godot-2d", "square-irregular-2d", "dec-3d", "dec-1d"]


def make_table(kind, seed=3):
    axes, chans = _axes_of(kind)
    shape = tuple(len(v) for v, _ in axes.values())
    rng = np.random.default_rng(seed)
    channels = {c: rng.uniform(0.05, 0.95, shape) for c in chans}
    return bsdf_tab.Table({n: v for n, (v, _) in axes.items()}, channels, {}), axes


def numpy_reference(axes, channels, pts):
    """Multilinear interpolation over the actual node values (see the module doc)."""
    frac = []
    for (values, space), x in zip(axes.values(), pts):
        v = np.asarray(values, dtype=np.float64)
        n = v.size
        if n == 1:
            frac.append(np.zeros(np.shape(x)))
            continue
        g = np.sqrt if space == "sqrt" else (lambda a: a)
        idx = np.arange(n, dtype=np.float64)
        if v[0] > v[-1]:
            v, idx = v[::-1], idx[::-1]
        held = np.clip(np.asarray(x, dtype=np.float64), v[0], v[-1])  # np.interp holds the ends anyway
        frac.append(np.interp(g(held), g(v), idx))
    out = {}
    for c, arr in channels.items():
        acc = np.zeros(np.shape(pts[0]))
        nd = arr.ndim
        for corner in range(1 << nd):
            w = np.ones(np.shape(pts[0]))
            index = []
            for k in range(nd):
                t = frac[k]
                i0 = np.minimum(np.floor(t).astype(int), max(arr.shape[k] - 2, 0))
                f = t - i0
                bit = (corner >> k) & 1
                index.append(np.minimum(i0 + bit, arr.shape[k] - 1))
                w = w * (f if bit else 1.0 - f)
            acc = acc + w * arr[tuple(index)]
        out[c] = acc
    return out


def sample_points(axes, m=40, seed=7):
    """Random points inside and beyond both ends of every axis, and the nodes themselves."""
    rng = np.random.default_rng(seed)
    pts = []
    for values, _ in axes.values():
        lo, hi = float(np.min(values)), float(np.max(values))
        span = hi - lo
        inside = rng.uniform(lo, hi, m)
        outside = np.array([lo - 0.05 * span, max(lo - 0.3 * span, 0.0), hi + 0.05 * span, hi + 0.3 * span])
        nodes = rng.choice(np.asarray(values), 6)
        pts.append(np.concatenate([inside, outside, nodes]))
    return [rng.permutation(p) for p in pts]


# --------------------------------------------------------------------------- plans and reference


def test_preset_axes_fit_in_their_stored_order():
    """Godot's roughness rows (decreasing centres) are a uniform axis from 1 to 0; EEVEE's NV is a
    decreasing irregular one; both map their nodes to their indices (t = i)."""
    godot = fit_axis("roughness", unit_centers(128)[::-1])
    assert (godot.kind, godot.spacing, godot.nodes, godot.range) == ("uniform", "linear", "centers", (1.0, 0.0))
    assert godot.bounds() == (0.0, 1.0)
    eevee = fit_axis("mu", _eevee_like(64))
    assert eevee.kind == "nodes" and eevee.decreasing
    sq = fit_axis("mu", unit_endpoints(10)[::-1] ** 2)
    assert (sq.kind, sq.spacing, sq.range) == ("uniform", "square", (1.0, 0.0))
    for a, v in ((godot, unit_centers(128)[::-1]), (eevee, _eevee_like(64)), (sq, unit_endpoints(10)[::-1] ** 2)):
        np.testing.assert_allclose(a.coord(v), np.arange(v.size), atol=1e-9)


def test_non_monotonic_axis_is_refused():
    t = bsdf_tab.Table({"alpha": np.array([0.1, 0.5, 0.3])}, {"E": np.zeros(3)}, {})
    with pytest.raises(ValueError, match="neither increasing nor decreasing"):
        emit_source(t, "c", "x.exr")


@pytest.mark.parametrize("kind", DEC_KINDS)
def test_reference_on_decreasing_axes(kind):
    t, axes = make_table(kind)
    pts = sample_points(axes)
    got = lookup(t, *pts)
    want = numpy_reference(axes, t.channels, pts)
    for c in t.value_channels:
        np.testing.assert_allclose(got[c], want[c], atol=1e-12, err_msg=f"{kind} {c}")


def test_godot_preset_subset_reference():
    """The godot-dfg preset itself (a subset of its nodes): the reference reads the stored rows."""
    from bsdf_tab.presets import build_preset

    t = build_preset("godot-dfg", select={"roughness": [0, 20, 50, 90, 127], "mu": [0, 40, 80, 127]})
    axes = {n: (v, "x") for n, v in t.axes.items()}
    assert t.axes["roughness"][0] > t.axes["roughness"][-1]
    pts = sample_points(axes, seed=11)
    got = lookup(t, *pts)
    want = numpy_reference(axes, {c: t.channels[c] for c in t.value_channels}, pts)
    for c in t.value_channels:
        np.testing.assert_allclose(got[c], want[c], atol=1e-12)


# --------------------------------------------------------------------------- C


C_MAIN = r"""
#include <stdio.h>
#include "{header}"
int main(int argc, char **argv) {{
    static float lut[{nch}][{size}];
    float p[{ndim}], out[{nch}];
    (void)argc; (void)argv;
    for (int c = 0; c < {nch}; ++c)
        for (int k = 0; k < {size}; ++k) if (scanf("%f", &lut[c][k]) != 1) return 3;
    while (1) {{
        for (int a = 0; a < {ndim}; ++a) if (scanf("%f", &p[a]) != 1) return 0;
        {prefix}_lookup({luts}, {args}, out);
        for (int c = 0; c < {nch}; ++c) printf("%.9g%c", out[c], c + 1 < {nch} ? ' ' : '\n');
    }}
}}
"""


def run_c(t, tmp_path, pts, table_file="lut.exr"):
    (header,) = emit_files(t, tmp_path / table_file, ["c"])
    prefix = header.read_text().split("_lookup(", 1)[0].rsplit(" ", 1)[-1]
    chans, nd = t.value_channels, len(t.axes)
    size = int(np.prod(t.shape))
    (tmp_path / "main.c").write_text(C_MAIN.format(
        header=header.name, nch=len(chans), size=size, ndim=nd, prefix=prefix,
        luts=", ".join(f"lut[{i}]" for i in range(len(chans))), args=", ".join(f"p[{a}]" for a in range(nd))))
    flags = ["-std=c99", "-O2", "-Wall", "-Wextra", "-Wpedantic", "-Werror"]
    run = subprocess.run([CC, *flags, "-o", str(tmp_path / "main"), str(tmp_path / "main.c"), "-lm"],
                         capture_output=True, text=True, cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    feed = " ".join(repr(float(x)) for c in chans for x in np.asarray(t.channels[c], np.float32).ravel())
    feed += "\n" + "\n".join(" ".join(repr(float(p[k])) for p in pts) for k in range(pts[0].size))
    run = subprocess.run([str(tmp_path / "main")], input=feed, check=True, capture_output=True, text=True)
    return np.loadtxt(run.stdout.splitlines(), ndmin=2)


@pytest.mark.skipif(CC is None, reason="no C compiler")
@pytest.mark.parametrize("kind", DEC_KINDS)
def test_c_on_decreasing_axes(kind, tmp_path):
    t, axes = make_table(kind)
    pts = [p.astype(np.float32).astype(np.float64) for p in sample_points(axes)]
    got = run_c(t, tmp_path, pts)
    chans32 = {c: np.asarray(t.channels[c], np.float32).astype(np.float64) for c in t.value_channels}
    want = numpy_reference(axes, chans32, pts)
    for i, c in enumerate(t.value_channels):
        np.testing.assert_allclose(got[:, i], want[c], atol=5e-6, err_msg=f"{kind} {c}")


@pytest.mark.skipif(CC is None, reason="no C compiler")
def test_c_one_node_axis_and_digit_file_name(tmp_path):
    """A 1-node axis compiles under -Wextra -Werror; '3d-lut' gives identifiers starting with a letter;
    <P>_NUM_VALUE_CHANNELS counts the value channels only."""
    rng = np.random.default_rng(5)
    axes = {"mu": (np.array([0.5]), "x"), "roughness": (np.linspace(1.0, 0.0, 5), "x")}
    chans = {"A": rng.uniform(size=(1, 5)), "B": rng.uniform(size=(1, 5))}
    t = bsdf_tab.Table({n: v for n, (v, _) in axes.items()}, {**chans, "A_err": np.zeros((1, 5)),
                                                                "B_err": np.zeros((1, 5))}, {})
    pts = [np.full(9, 0.3), np.linspace(-0.2, 1.2, 9)]
    got = run_c(t, tmp_path, pts, "3d-lut.h")
    want = numpy_reference(axes, {c: v.astype(np.float32).astype(np.float64) for c, v in chans.items()}, pts)
    for i, c in enumerate("AB"):
        np.testing.assert_allclose(got[:, i], want[c], atol=5e-6)
    text = (tmp_path / "3d-lut.lookup.h").read_text()
    assert "lut_3d_lut_lookup(" in text and "#define LUT_3D_LUT_NUM_VALUE_CHANNELS 2" in text
    code = "\n".join(ln for ln in text.splitlines() if not ln.startswith("//"))
    assert "_3D_LUT" not in code.replace("LUT_3D_LUT", "") and " _3d" not in code


# --------------------------------------------------------------------------- texture files


def read_ktx2_layout(path):
    """(dims (width, height, depth) as in the header, pixels (depth, height, width, comps) float32)."""
    data = path.read_bytes()
    vk, type_size, width, height, depth = struct.unpack_from("<5I", data, 12)
    offset, length, _ = struct.unpack_from("<3Q", data, 80)
    comps = {100: 1, 103: 2, 109: 4}[vk]  # R32, R32G32, R32G32B32A32 _SFLOAT
    pix = np.frombuffer(data, "<f4", count=length // 4, offset=offset)
    return (width, height, depth), pix.reshape(max(depth, 1), max(height, 1), width, comps)


def read_dds_layout(path):
    data = path.read_bytes()
    assert data[:4] == b"DDS " and data[84:88] == b"DX10"
    _, _, height, width, _, depth = struct.unpack_from("<6I", data, 4)
    dxgi, dimension = struct.unpack_from("<2I", data, 128)
    comps = {41: 1, 16: 2, 2: 4}[dxgi]  # R32, R32G32, R32G32B32A32 _FLOAT
    pix = np.frombuffer(data, "<f4", offset=148)
    dims = (width, {2: 0}.get(dimension, height), depth if dimension == 4 else 0)
    return dims, pix.reshape(max(depth, 1), height, width, comps)


def read_png_layout(path):
    data = path.read_bytes()
    pos, idat, ihdr = 8, b"", None
    while pos < len(data):
        (n,) = struct.unpack_from(">I", data, pos)
        kind, body = data[pos + 4:pos + 8], data[pos + 8:pos + 8 + n]
        ihdr = body if kind == b"IHDR" else ihdr
        idat += body if kind == b"IDAT" else b""
        pos += 12 + n
    width, height, bits, colour = struct.unpack_from(">IIBB", ihdr)
    comps = {0: 1, 2: 3, 6: 4}[colour]
    rows = np.frombuffer(zlib.decompress(idat), np.uint8).reshape(height, -1)
    assert not rows[:, 0].any()  # filter type 0
    pix = np.frombuffer(rows[:, 1:].tobytes(), ">u2").astype(np.float32) / 65535.0
    return (width, height, 0), pix.reshape(1, height, width, comps)


WRITERS = {"ktx2": read_ktx2_layout, "dds": read_dds_layout, "png": read_png_layout}


def write_table(t, path, fmt):
    from bsdf_tab.io.dds import write_dds
    from bsdf_tab.io.ktx2 import write_ktx2
    from bsdf_tab.io.png import write_png

    {"ktx2": lambda: write_ktx2(t, path, "float32"), "dds": lambda: write_dds(t, path, "float32"),
     "png": lambda: write_png(t, path, "unorm16")}[fmt]()
    return WRITERS[fmt](path)


LAYOUT_CASES = [(kind, fmt) for kind in ("inc-1d", "dec-1d", "godot-2d", "inc-3d", "dec-3d")
                for fmt in ("ktx2", "dds", "png")]


def _texture_dims(dims):
    width, height, depth = dims
    return 1 if height == 0 else (3 if depth else 2)


@pytest.mark.parametrize("kind,fmt", LAYOUT_CASES)
def test_emitted_texture_type_matches_the_file(kind, fmt, tmp_path):
    """The sampler / texture type of every shading language is the dimension the file declares,
    and the file's texels, addressed as the documented layout says, are the table's nodes."""
    t, axes = make_table(kind)
    path = tmp_path / f"lut.{fmt}"
    dims, pix = write_table(t, path, fmt)
    nd = _texture_dims(dims)
    if fmt == "png":
        assert nd == 2  # PNG: a 2-D image, 3-D slices stacked along y
    else:
        assert nd == len(t.axes)  # KTX2 / DDS: the table's own dimension
    tol = 1e-7 if fmt != "png" else 1e-5
    shape = t.shape
    for k, c in enumerate(t.value_channels):  # documented layout, evaluated on the file's pixels
        if nd == 3:
            got = pix[:, :, :, k]  # [z = axis 0][y = axis 1][x = axis 2]
        elif len(shape) == 3:
            got = pix[0, :, :, k].reshape(shape[0], shape[1], shape[2])  # row = i0 * n1 + i1
        else:
            got = pix[0, :, :, k].reshape(shape)
        np.testing.assert_allclose(got, t.channels[c], atol=tol, err_msg=f"{kind} {fmt} {c}")
    glsl, hlsl, wgsl = (p.read_text() for p in emit_files(t, path, ["glsl", "hlsl", "wgsl"]))
    assert f"sampler{nd}D lut" in glsl and f"Texture{nd}D<float4> lut" in hlsl and f"lut: texture_{nd}d<f32>" in wgsl


# --------------------------------------------------------------------------- shader front ends


GLSL_MAIN = """#version 450
{code}
layout(binding = 0) uniform {sampler} tex;
layout(location = 0) in vec4 p;
layout(location = 0) out vec4 color;
void main() {{
    color = vec4({prefix}_lookup(tex, {args}){pad});
}}
"""

HLSL_MAIN = """{code}
{texture} tex : register(t0);
float4 main(float4 p : TEXCOORD0) : SV_Target {{
    return float4({prefix}_lookup(tex, {args}){pad});
}}
"""


def _pad(nch):
    return "" if nch == 4 else ", " + ", ".join(["0.0"] * (4 - nch))


@pytest.mark.skipif(shutil.which("glslangValidator") is None, reason="glslangValidator not installed")
@pytest.mark.parametrize("kind", DEC_KINDS + ["inc-3d", "inc-1d"])
@pytest.mark.parametrize("fmt", ["ktx2", "png"])
@pytest.mark.parametrize("lang", ["glsl", "hlsl"])
def test_glsl_hlsl_compile_both_layouts(kind, fmt, lang, tmp_path):
    t, _ = make_table(kind)
    code = emit_source(t, lang, f"lut.{fmt}")
    nd = len(t.axes) if fmt == "ktx2" else 2
    nch = len(t.value_channels)
    args = ", ".join(f"p.{'xyzw'[a]}" for a in range(len(t.axes)))
    if lang == "glsl":
        src = GLSL_MAIN.format(code=code, sampler=f"sampler{nd}D", prefix="lut", args=args, pad=_pad(nch))
        path = tmp_path / "test.frag"
        cmd = ["glslangValidator", "-V", str(path), "-o", str(tmp_path / "out.spv")]
    else:
        src = HLSL_MAIN.format(code=code, texture=f"Texture{nd}D<float4>", prefix="lut", args=args, pad=_pad(nch))
        path = tmp_path / "test.hlsl"
        cmd = ["glslangValidator", "-D", "-V", "-S", "frag", "-e", "main", str(path), "-o", str(tmp_path / "out.spv")]
    path.write_text(src)
    run = subprocess.run(cmd, capture_output=True, text=True)
    assert run.returncode == 0, run.stdout + run.stderr
    if shutil.which("dxc") and lang == "hlsl":
        run = subprocess.run(["dxc", "-T", "ps_6_0", "-E", "main", str(path)], capture_output=True, text=True)
        assert run.returncode == 0, run.stdout + run.stderr


def _wgpu_device():
    try:
        import wgpu

        adapter = wgpu.gpu.request_adapter_sync(power_preference="low-power")
        return adapter.request_device_sync() if adapter is not None else None
    except Exception:  # noqa: BLE001 - not installed or no adapter: skip
        return None


WGSL_RUN = """{code}
@group(0) @binding(0) var tex: {texture};
@group(0) @binding(1) var<storage, read> pts: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> outv: array<vec4<f32>>;
@compute @workgroup_size(1)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {{
    let p = pts[gid.x];
    outv[gid.x] = vec4<f32>({prefix}_lookup(tex, {args}){pad});
}}
"""


def run_wgsl(device, code, dims, pix, pts, nch, ndim):
    """Run the emitted WGSL lookup on the file's pixels uploaded as the texture the file declares."""
    import wgpu

    width, height, depth = dims
    tdim = _texture_dims(dims)
    rgba = np.zeros(pix.shape[:3] + (4,), np.float32)
    rgba[..., :pix.shape[3]] = pix
    size = (width, max(height, 1), max(depth, 1))
    tex = device.create_texture(size=size, format=wgpu.TextureFormat.rgba32float, dimension=f"{tdim}d",
                                usage=wgpu.TextureUsage.TEXTURE_BINDING | wgpu.TextureUsage.COPY_DST)
    device.queue.write_texture({"texture": tex}, rgba.tobytes(), {"bytes_per_row": width * 16,
                                                                  "rows_per_image": size[1]}, size)
    n = pts[0].size
    p4 = np.zeros((n, 4), np.float32)
    p4[:, :ndim] = np.stack(pts, 1)
    src = WGSL_RUN.format(code=code, texture=f"texture_{tdim}d<f32>", prefix="lut",
                          args=", ".join(f"p.{'xyzw'[a]}" for a in range(ndim)), pad=_pad(nch))
    module = device.create_shader_module(code=src)
    pbuf = device.create_buffer_with_data(data=p4.tobytes(), usage=wgpu.BufferUsage.STORAGE)
    obuf = device.create_buffer(size=n * 16, usage=wgpu.BufferUsage.STORAGE | wgpu.BufferUsage.COPY_SRC)
    pipe = device.create_compute_pipeline(layout="auto", compute={"module": module, "entry_point": "main"})
    group = device.create_bind_group(layout=pipe.get_bind_group_layout(0), entries=[
        {"binding": 0, "resource": tex.create_view()},
        {"binding": 1, "resource": {"buffer": pbuf, "offset": 0, "size": n * 16}},
        {"binding": 2, "resource": {"buffer": obuf, "offset": 0, "size": n * 16}}])
    enc = device.create_command_encoder()
    cpass = enc.begin_compute_pass()
    cpass.set_pipeline(pipe)
    cpass.set_bind_group(0, group)
    cpass.dispatch_workgroups(n)
    cpass.end()
    device.queue.submit([enc.finish()])
    return np.frombuffer(device.queue.read_buffer(obuf), np.float32).reshape(n, 4)[:, :nch]


# wgpu's OpenGL backend (Mesa llvmpipe, the adapter of CI machines without a GPU) reads 1-D
# textures as zeros, so the 1-D native layout is checked by the header test and the compilers.
RUN_CASES = [(kind, fmt) for kind in ("godot-2d", "square-irregular-2d", "inc-3d", "dec-3d")
             for fmt in ("ktx2", "dds", "png")] + [("dec-1d", "png")]


@pytest.mark.parametrize("kind,fmt", RUN_CASES)
def test_wgsl_runs_on_the_written_file(kind, fmt, tmp_path):
    """The emitted WGSL, run by wgpu on the texels of the written file (uploaded as the texture
    the file's header declares), equals the independent reference, decreasing axes included."""
    device = _wgpu_device()
    if device is None:
        pytest.skip("no wgpu adapter")
    t, axes = make_table(kind)
    path = tmp_path / f"lut.{fmt}"
    dims, pix = write_table(t, path, fmt)
    (wgsl,) = emit_files(t, path, ["wgsl"])
    pts = [p.astype(np.float32).astype(np.float64) for p in sample_points(axes, m=30)]
    got = run_wgsl(device, wgsl.read_text(), dims, pix, pts, len(t.value_channels), len(t.axes))
    stored = {c: np.asarray(t.channels[c], np.float32).astype(np.float64) for c in t.value_channels}
    if fmt == "png":
        stored = {c: np.round(np.clip(v, 0, 1) * 65535) / 65535 for c, v in stored.items()}
    want = numpy_reference(axes, stored, pts)
    for i, c in enumerate(t.value_channels):
        np.testing.assert_allclose(got[:, i], want[c], atol=2e-5, err_msg=f"{kind} {fmt} {c}")


def test_wgsl_run_detects_a_wrong_layout(tmp_path):
    """The run can fail: the same volume with its y and z axes swapped, or read upside down, is
    measurably off the reference."""
    device = _wgpu_device()
    if device is None:
        pytest.skip("no wgpu adapter")
    t, axes = make_table("dec-3d")
    path = tmp_path / "lut.ktx2"
    dims, pix = write_table(t, path, "ktx2")
    code = emit_source(t, "wgsl", str(path))
    pts = [p.astype(np.float32).astype(np.float64) for p in sample_points(axes, m=30)]
    want = numpy_reference(axes, {c: np.asarray(t.channels[c], np.float32) for c in t.value_channels}, pts)
    good = run_wgsl(device, code, dims, pix, pts, 2, 3)
    np.testing.assert_allclose(good[:, 0], want["R"], atol=2e-5)
    swapped = np.ascontiguousarray(pix.transpose(1, 0, 2, 3))
    bad = run_wgsl(device, code, (dims[0], dims[2], dims[1]), swapped, pts, 2, 3)
    assert np.abs(bad[:, 0] - want["R"]).max() > 0.05
    flipped = np.ascontiguousarray(pix[:, ::-1])
    assert np.abs(run_wgsl(device, code, dims, flipped, pts, 2, 3)[:, 0] - want["R"]).max() > 0.05
    fixed = code.replace("const LUT_FLIP_Y: i32 = 0;", "const LUT_FLIP_Y: i32 = 1;")
    np.testing.assert_allclose(run_wgsl(device, fixed, dims, flipped, pts, 2, 3)[:, 0], want["R"], atol=2e-5)
