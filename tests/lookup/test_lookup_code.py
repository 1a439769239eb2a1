"""Generated lookup code against the Python reference lookup and the exact values.

C is compiled with the system C compiler and run; the Warp ``@wp.func`` is called from a test
kernel in-process; GLSL and HLSL go through glslangValidator (skipped when it is absent). The
exact values are ``bsdf_tab.tabulate`` at the random points themselves: the mean interpolation
error is bounded (and a lookup with a wrong node convention is shown to exceed the reference's
error, so the comparison can fail).
"""

from __future__ import annotations

import importlib.util
import shutil
import subprocess
import sys
import zlib

import numpy as np
import pytest

import bsdf_tab
from bsdf_tab.lookup import emit_files, emit_source, lookup, lookup_plan, output_paths
from bsdf_tab.presets.axes import cycles_axis, unit_endpoints

RNG = np.random.default_rng(15)


def _table(kind: str) -> bsdf_tab.Table:
    if kind == "dfg-centers-square":  # Filament-like mu centres, roughness with square spacing
        spec = {"table": "dfg", "axes": {"mu": {"size": 16, "nodes": "centers"},
                                         "roughness": {"size": 12, "spacing": "square"}}}
    elif kind == "albedo-cycles":  # explicit Cycles axes: clamp(i/(n-1), 1e-4, 1), fitted from the values
        spec = {"table": "albedo", "axes": {"mu": list(cycles_axis(16)), "roughness": list(cycles_axis(12))}}
    elif kind == "albedo-unity-sqrt":  # Unity's sqrt(NdotV) = i/(n-1), explicit values
        spec = {"table": "albedo", "axes": {"mu": list(unit_endpoints(14) ** 2), "roughness": list(unit_endpoints(10))}}
    elif kind == "dielectric-3d":  # irregular eta nodes: piecewise linear in eta
        spec = {"table": "dielectric", "axes": {"mu": {"size": 9}, "alpha": {"size": 7, "range": [0.05, 1.0]},
                                                "eta": [1.1, 1.3, 1.8, 2.5]}}
    elif kind == "albedo-avg-1d":
        spec = {"table": "albedo_avg", "axes": {"alpha": {"size": 10, "nodes": "left"}}}
    else:
        raise KeyError(kind)
    spec["tolerance"] = 1e-6
    return bsdf_tab.tabulate(spec)


_TABLES: dict = {}


def table_of(kind: str):
    if kind not in _TABLES:
        _TABLES[kind] = _table(kind)
    return _TABLES[kind]


def _axis_points(table, m, rng=RNG):
    """Per axis, m random values inside the span of the nodes (sorted, distinct)."""
    plan = lookup_plan(table)
    out = []
    for a in plan.axes:
        lo, hi = a.values[0], a.values[-1]
        out.append(np.unique(rng.uniform(lo, hi, m)) if a.size > 1 else np.array([lo]))
    return out


def _points(table, m=None, kind=None):
    """Random points: the grid of per-axis random values (for the exact comparison), then points
    outside the node span (the lookup clamps; compared with the reference only).

    Returns (points per axis, flattened; number of grid points; per-axis values of the grid)."""
    ndim = len(table.axes)
    m = m or {1: 24, 2: 8, 3: 4}[ndim]
    rng = np.random.default_rng(zlib.crc32(kind.encode())) if kind else RNG  # the same points for C and Warp
    axis_pts = _axis_points(table, m, rng)
    grid = [g.ravel() for g in np.meshgrid(*axis_pts, indexing="ij")]
    plan = lookup_plan(table)
    extra = [np.concatenate([[a.values[0] - 0.05, 0.0, a.values[-1] + 0.1], rng.uniform(a.values[0], a.values[-1], 5)])
             for a in plan.axes]
    extra = [np.clip(e, 0.0, None) for e in extra]
    return [np.concatenate([g, e]) for g, e in zip(grid, extra)], grid[0].size, axis_pts


_EXACT: dict = {}


def _exact(table, axis_pts):
    """``tabulate`` on the random per-axis values (the exact values at the grid points, flattened)."""
    key = (id(table), tuple(tuple(p) for p in axis_pts))
    if key not in _EXACT:
        _EXACT[key] = _exact_uncached(table, axis_pts)
    return _EXACT[key]


def _exact_uncached(table, axis_pts):
    spec = dict(table.meta["spec"])
    spec["axes"] = {n: [float(v) for v in u] for n, u in zip(table.axes, axis_pts)}
    spec["tolerance"] = 1e-6
    exact = bsdf_tab.tabulate(spec)
    return {c: exact.channels[c].ravel() for c in table.value_channels}


#: bound on the mean |lookup - exact| over the random points (bilinear on 10-16 nodes)
#: (measured 3.3e-3, 5.2e-3, 2.1e-3, 4.1e-3, 6.0e-4 at the fixed points; the largest single
#: differences, up to 0.09, are next to alpha = 0 at grazing mu, where E is steepest)
INTERP_TOL = {"dfg-centers-square": 0.008, "albedo-cycles": 0.012, "albedo-unity-sqrt": 0.006,
              "dielectric-3d": 0.01, "albedo-avg-1d": 0.002}
KINDS = list(INTERP_TOL)


def test_reference_at_nodes_is_the_table():
    """At the node positions the reference lookup returns the texels (t integral, no interpolation).

    A clamped node keeps its unclamped position (Cycles' node 0 holds mu = 1e-4 at mu = 0)."""
    for kind in ("dfg-centers-square", "albedo-cycles", "albedo-unity-sqrt"):
        t = table_of(kind)
        grid = {n: (unit_endpoints(len(v)) if kind == "albedo-cycles" else v) for n, v in t.axes.items()}
        mu, r = np.meshgrid(grid["mu"], grid["roughness"], indexing="ij")
        got = lookup(t, mu, r)
        for c in t.value_channels:
            np.testing.assert_allclose(got[c], t.channels[c], atol=1e-12, err_msg=kind)


def test_reference_against_exact_and_a_wrong_mapping():
    """The reference is within interpolation error of the exact values; reading the same table with
    a wrong node convention (endpoints for centres) is measurably worse, so the check can fail."""
    t = table_of("dfg-centers-square")
    _, _, axis_pts = _points(t, 14)
    pts = [g.ravel() for g in np.meshgrid(*axis_pts, indexing="ij")]
    exact = _exact(t, axis_pts)
    ref = lookup(t, *pts)
    err = max(np.abs(ref[c] - exact[c]).mean() for c in t.value_channels)
    assert err < INTERP_TOL["dfg-centers-square"]
    plan = lookup_plan(t)
    from dataclasses import replace

    wrong = replace(plan, axes=(replace(plan.axes[0], nodes="endpoints"), plan.axes[1]))
    bad = lookup(t, *pts, plan=wrong)
    mean_ok = np.mean([np.abs(ref[c] - exact[c]).mean() for c in t.value_channels])
    mean_bad = np.mean([np.abs(bad[c] - exact[c]).mean() for c in t.value_channels])
    assert mean_bad > 2 * mean_ok


def test_fitted_axes_name_the_conventions():
    plan = lookup_plan(table_of("albedo-cycles"))
    mu = plan.axes[0]
    assert (mu.kind, mu.spacing, mu.nodes, mu.range, mu.clamp[0]) == ("uniform", "linear", "endpoints", (0.0, 1.0), 1e-4)
    plan = lookup_plan(table_of("albedo-unity-sqrt"))
    assert (plan.axes[0].spacing, plan.axes[0].nodes) == ("square", "endpoints")
    assert lookup_plan(table_of("dielectric-3d")).axes[2].kind == "nodes"


# --------------------------------------------------------------------------- C


C_MAIN = r"""
#include <stdio.h>
#include <stdlib.h>
#include "{header}"
int main(int argc, char **argv) {{
    FILE *f = fopen(argv[1], "rb");
    static float lut[{nch}][{size}];
    for (int c = 0; c < {nch}; ++c) if (fread(lut[c], sizeof(float), {size}, f) != {size}) return 3;
    int n; if (fread(&n, sizeof(int), 1, f) != 1) return 4;
    float *p = malloc(sizeof(float) * n * {ndim});
    if (fread(p, sizeof(float), n * {ndim}, f) != (size_t)(n * {ndim})) return 5;
    fclose(f);
    for (int k = 0; k < n; ++k) {{
        float out[{nch}];
        {prefix}_lookup({luts}, {args}, out);
        for (int c = 0; c < {nch}; ++c) printf("%.9g%c", out[c], c + 1 < {nch} ? ' ' : '\n');
    }}
    return 0;
}}
"""


@pytest.mark.skipif(shutil.which("gcc") is None and shutil.which("cc") is None, reason="no C compiler")
@pytest.mark.parametrize("kind", KINDS)
def test_c_lookup_compiled_and_run(kind, tmp_path):
    t = table_of(kind)
    (header,) = emit_files(t, tmp_path / "lut.exr", ["c"])
    assert header == tmp_path / "lut.lookup.h"
    chans = t.value_channels
    size = int(np.prod(t.shape))
    ndim = len(t.axes)
    src = C_MAIN.format(header=header.name, nch=len(chans), size=size, ndim=ndim, prefix="lut",
                        luts=", ".join(f"lut[{i}]" for i in range(len(chans))),
                        args=", ".join(f"p[k * {ndim} + {a}]" for a in range(ndim)))
    (tmp_path / "main.c").write_text(src)
    cc = shutil.which("gcc") or shutil.which("cc")
    subprocess.run([cc, "-std=c99", "-O2", "-Wall", "-Werror", "-o", str(tmp_path / "main"), str(tmp_path / "main.c"), "-lm"],
                   check=True, capture_output=True, cwd=tmp_path)
    pts, n_grid, axis_pts = _points(t, kind=kind)
    n_pts = pts[0].size
    blob = b"".join(np.ascontiguousarray(t.channels[c], dtype=np.float32).tobytes() for c in chans)
    blob += np.int32(n_pts).tobytes() + np.stack(pts, axis=1).astype(np.float32).tobytes()
    (tmp_path / "in.bin").write_bytes(blob)
    run = subprocess.run([str(tmp_path / "main"), str(tmp_path / "in.bin")], check=True, capture_output=True, text=True)
    got = np.loadtxt(run.stdout.splitlines(), ndmin=2)
    ref = lookup(t, *[p.astype(np.float32).astype(np.float64) for p in pts])
    exact = _exact(t, axis_pts)
    for i, c in enumerate(chans):
        np.testing.assert_allclose(got[:, i], ref[c], atol=3e-6, err_msg=f"{kind} {c}: C vs reference")
        err = np.abs(got[:n_grid, i] - exact[c]).mean()
        assert err < INTERP_TOL[kind], f"{kind} {c}: C vs exact, mean {err}"


# --------------------------------------------------------------------------- Warp


KERNEL = """
import warp as wp
from {module} import {prefix}_lookup

@wp.kernel
def run_lookup({arrays}, pts: wp.array2d(dtype=wp.float32), out: wp.array2d(dtype=wp.float32)):
    k = wp.tid()
    v = {prefix}_lookup({names}, {args})
{stores}
"""


@pytest.mark.parametrize("kind", ["dfg-centers-square", "albedo-cycles", "dielectric-3d", "albedo-avg-1d"])
def test_warp_lookup_in_a_kernel(kind, tmp_path, monkeypatch):
    import warp as wp

    t = table_of(kind)
    prefix = f"lut_{kind.replace('-', '_')}"
    (path,) = emit_files(t, tmp_path / f"{prefix}.exr", ["warp"])
    assert path.name == f"{prefix}_lookup.py"
    chans = t.value_channels
    ndim = len(t.axes)
    arrays = ", ".join(f"a{i}: wp.array{ndim}d(dtype=wp.float32)" for i in range(len(chans)))
    stores = "\n".join(f"    out[k, {i}] = v{'' if len(chans) == 1 else f'[{i}]'}" for i in range(len(chans)))
    (tmp_path / f"{prefix}_kernel.py").write_text(KERNEL.format(
        module=path.stem, prefix=prefix, arrays=arrays, names=", ".join(f"a{i}" for i in range(len(chans))),
        args=", ".join(f"pts[k, {a}]" for a in range(ndim)), stores=stores))
    monkeypatch.syspath_prepend(str(tmp_path))
    spec = importlib.util.spec_from_file_location(f"{prefix}_kernel", tmp_path / f"{prefix}_kernel.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod
    spec.loader.exec_module(mod)
    pts, n_grid, axis_pts = _points(t, kind=kind)
    n_pts = pts[0].size
    out = wp.zeros((n_pts, len(chans)), dtype=wp.float32, device="cpu")
    inputs = [wp.array(np.asarray(t.channels[c], dtype=np.float32), dtype=wp.float32, device="cpu") for c in chans]
    wp.launch(mod.run_lookup, dim=n_pts, device="cpu",
              inputs=[*inputs, wp.array(np.stack(pts, 1).astype(np.float32), dtype=wp.float32, device="cpu"), out])
    got = out.numpy()
    ref = lookup(t, *[p.astype(np.float32).astype(np.float64) for p in pts])
    exact = _exact(t, axis_pts)
    for i, c in enumerate(chans):
        np.testing.assert_allclose(got[:, i], ref[c], atol=3e-6, err_msg=f"{kind} {c}: Warp vs reference")
        err = np.abs(got[:n_grid, i] - exact[c]).mean()
        assert err < INTERP_TOL[kind], f"{kind} {c}: Warp vs exact, mean {err}"


# --------------------------------------------------------------------------- shading languages


GLSL_MAIN = """#version 450
{code}
layout(binding = 0) uniform sampler2D lut;
layout(location = 0) in vec{ndim_in} p;
layout(location = 0) out vec4 color;
void main() {{
    color = vec4({prefix}_lookup(lut, {args}){pad});
}}
"""

HLSL_MAIN = """{code}
Texture2D<float4> lut : register(t0);
float4 main(float4 p : TEXCOORD0) : SV_Target {{
    return float4({prefix}_lookup(lut, {args}){pad});
}}
"""


def _pad(nch: int) -> str:
    return "" if nch == 4 else ", " + ", ".join(["0.0"] * (4 - nch))


@pytest.mark.skipif(shutil.which("glslangValidator") is None, reason="glslangValidator not installed (apt: glslang-tools)")
@pytest.mark.parametrize("kind", ["dfg-centers-square", "albedo-cycles", "dielectric-3d", "albedo-avg-1d"])
@pytest.mark.parametrize("lang", ["glsl", "hlsl"])
def test_shading_language_front_end(kind, lang, tmp_path):
    t = table_of(kind)
    code = emit_source(t, lang, "lut.exr")
    ndim, nch = len(t.axes), len(t.value_channels)
    comps = "xyzw"
    if lang == "glsl":
        src = GLSL_MAIN.format(code=code, ndim_in=max(ndim, 2) if ndim > 1 else 2, prefix="lut",
                               args=", ".join(f"p.{comps[a]}" for a in range(ndim)), pad=_pad(nch))
        path = tmp_path / "test.frag"
        cmd = ["glslangValidator", "-V", str(path), "-o", str(tmp_path / "out.spv")]
    else:
        src = HLSL_MAIN.format(code=code, prefix="lut", args=", ".join(f"p.{comps[a]}" for a in range(ndim)), pad=_pad(nch))
        path = tmp_path / "test.hlsl"
        cmd = ["glslangValidator", "-D", "-V", "-S", "frag", "-e", "main", str(path), "-o", str(tmp_path / "out.spv")]
    path.write_text(src)
    run = subprocess.run(cmd, capture_output=True, text=True)
    assert run.returncode == 0, run.stdout + run.stderr


def test_emit_files_names_and_errors(tmp_path):
    t = table_of("albedo-avg-1d")
    paths = emit_files(t, tmp_path / "ggx_Eavg.half.exr", ["glsl", "hlsl", "wgsl", "c", "warp"])
    assert [p.name for p in paths] == ["ggx_Eavg.lookup.glsl", "ggx_Eavg.lookup.hlsl", "ggx_Eavg.lookup.wgsl",
                                       "ggx_Eavg.lookup.h", "ggx_Eavg_lookup.py"]
    assert paths == output_paths(tmp_path / "ggx_Eavg.half.exr", ["glsl", "hlsl", "wgsl", "c", "warp"])
    assert all("ggx_Eavg_lookup" in p.read_text() for p in paths)
    with pytest.raises(ValueError, match="unknown language 'metal'"):
        emit_files(t, tmp_path / "x.exr", ["glsl", "metal"])
    assert not (tmp_path / "x.lookup.glsl").exists()  # nothing written when one language is bad


WGSL_MAIN = """{code}
@group(0) @binding(0) var lut_texture: texture_2d<f32>;
@fragment
fn main(@location(0) p: vec4<f32>) -> @location(0) vec4<f32> {{
    return vec4<f32>({prefix}_lookup(lut_texture, {args}){pad});
}}
"""


def _wgpu_device():
    """A wgpu device (its shader compiler is naga, WGSL's reference front end), or None."""
    try:
        import wgpu

        adapter = wgpu.gpu.request_adapter_sync(power_preference="low-power")
        return adapter.request_device_sync() if adapter is not None else None
    except Exception:  # noqa: BLE001 - not installed, no adapter (no Vulkan / GL driver): skip
        return None


@pytest.mark.parametrize("kind", ["dfg-centers-square", "albedo-cycles", "dielectric-3d", "albedo-avg-1d"])
def test_wgsl_front_end(kind):
    device = _wgpu_device()
    if device is None:
        pytest.skip("no WGSL validator: the wgpu package (naga) with an adapter is not available")
    t = table_of(kind)
    ndim, nch = len(t.axes), len(t.value_channels)
    src = WGSL_MAIN.format(code=emit_source(t, "wgsl", "lut.exr"), prefix="lut",
                           args=", ".join(f"p.{'xyzw'[a]}" for a in range(ndim)), pad=_pad(nch))
    device.create_shader_module(code=src)  # raises GPUValidationError with naga's message


def test_wgsl_validator_rejects_a_type_error():
    """The validator used above does reject a wrong WGSL function (so its passing means something)."""
    device = _wgpu_device()
    if device is None:
        pytest.skip("no WGSL validator")
    t = table_of("albedo-avg-1d")
    bad = emit_source(t, "wgsl", "lut.exr").replace("let f0: f32", "let f0: i32")
    with pytest.raises(Exception, match="f0|type"):
        device.create_shader_module(code=WGSL_MAIN.format(code=bad, prefix="lut", args="p.x", pad=_pad(1)))
