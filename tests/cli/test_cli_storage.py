"""``bsdf-tab bake --precision / --store-tol / --emit`` and ``bsdf-tab info``'s storage section.

The expected storage errors are numpy's own rounding computed here; the expected choice of
``--precision auto`` is the smallest candidate (bytes per texel) whose measured bound is
within the tolerance, computed here from those numbers.
"""

from __future__ import annotations

import dataclasses
import json
import sys

import numpy as np
import pytest

import bsdf_tab.api
from bsdf_tab import cli
from bsdf_tab.presets import PRESETS
from bsdf_tab.spec import normalize_spec, resolve_axes
from bsdf_tab.table import Table

ERR = 4e-7


def varied_table(spec: dict) -> Table:
    """Deterministic values in (0, 1) for ``spec`` (a dfg table: A, B) with error channels ERR."""
    nspec = normalize_spec(spec)
    axes = resolve_axes(nspec)
    shape = tuple(len(a) for a in axes.values())
    grid = np.add.outer(np.arange(shape[0]) * 0.1371, np.arange(shape[1]) * 0.0613)
    channels = {"A": 0.05 + 0.9 * np.abs(np.sin(grid)), "B": 0.02 + 0.3 * np.abs(np.cos(3 * grid))}
    channels.update({n + "_err": np.full(shape, ERR) for n in ("A", "B")})
    return Table(axes, channels, {"spec": nspec, "method": "adaptive", "version": "9.9.9"})


@pytest.fixture
def fake_api(monkeypatch):
    monkeypatch.setattr(bsdf_tab.api, "tabulate", lambda spec, **kw: varied_table(spec))


@pytest.fixture
def spec(tmp_path):
    path = tmp_path / "dfg.json"
    path.write_text(json.dumps({"table": "dfg", "axes": {"mu": {"size": 6, "nodes": "centers"},
                                                         "roughness": {"size": 5, "nodes": "centers"}}}))
    return path


def run(capsys, *argv):
    code = cli.main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def one_line_error(code, err, *fragments):
    assert code == 2, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("bsdf-tab: error: ") and "Traceback" not in err, err
    for fragment in fragments:
        assert fragment in lines[0], lines[0]


def stored(x, encoding):
    if encoding == "float16":
        return x.astype(np.float16).astype(np.float64)
    if encoding == "float32":
        return x.astype(np.float32).astype(np.float64)
    bits = {"unorm16": 16, "unorm10": 10, "unorm8": 8}[encoding]
    return np.round(np.clip(x, 0, 1) * (2**bits - 1)) / (2**bits - 1)


def test_ktx2_default_float16_reported_in_meta_summary_and_info(tmp_path, capsys, fake_api, spec):
    out_path = tmp_path / "dfg.ktx2"
    code, out, err = run(capsys, "bake", spec, "-o", out_path, "-q")
    assert code == 0, err
    t = varied_table(json.loads(spec.read_text()))
    rounding = {c: np.abs(stored(t.channels[c], "float16") - t.channels[c]).max() for c in "AB"}
    assert "storage float16 adds" in out and f"A {rounding['A']:.2g}" in out
    back = Table.read(out_path)
    report = back.meta["storage"]
    assert report["encoding"] == "float16" and report["vk_format"] == "VK_FORMAT_R16G16_SFLOAT"
    for c in "AB":
        assert report["channels"][c]["storage_error"] == rounding[c]
        assert report["channels"][c]["integration_error"] == pytest.approx(ERR)
    code, out, err = run(capsys, "info", out_path)
    assert code == 0, err
    assert "storage: float16 (ktx2, VK_FORMAT_R16G16_SFLOAT), 4 bytes per texel" in out
    assert f"A: integration {ERR:.3g}, storage {rounding['A']:.3g}, stored {rounding['A'] + ERR:.3g}" in out


def test_exr_bake_reports_float32_rounding(tmp_path, capsys, fake_api, spec):
    code, out, err = run(capsys, "bake", spec, "-o", tmp_path / "dfg.exr", "-q")
    assert code == 0, err
    t = varied_table(json.loads(spec.read_text()))
    meta = Table.read(tmp_path / "dfg.exr").meta["storage"]
    assert meta["encoding"] == "float32" and meta["format"] == "exr"
    assert meta["channels"]["B"]["storage_error"] == np.abs(stored(t.channels["B"], "float32") - t.channels["B"]).max()


@pytest.mark.parametrize("ending,tol", [(".ktx2", 3e-3), (".ktx2", 1e-3), (".ktx2", 2e-5), (".ktx2", 1e-6),
                                        (".dds", 6e-4), (".png", 3e-3), (".png", 1e-5)])
def test_precision_auto_picks_the_smallest_within_tol(tmp_path, capsys, fake_api, spec, ending, tol):
    t = varied_table(json.loads(spec.read_text()))
    choices = {".ktx2": ["unorm8", "unorm10", "float16", "unorm16", "float32"], ".dds": ["unorm8", "unorm10", "float16",
               "unorm16", "float32"], ".png": ["unorm8", "unorm16"]}[ending]
    size = {"unorm8": 2, "unorm10": 4, "float16": 4, "unorm16": 4, "float32": 8}
    bound = {e: max(np.max(np.abs(stored(t.channels[c], e) - t.channels[c]) + ERR) for c in "AB") for e in choices}
    want = min((e for e in choices if bound[e] <= tol), key=lambda e: (size[e], bound[e]))
    out_path = tmp_path / f"dfg{ending}"
    code, out, err = run(capsys, "bake", spec, "-o", out_path, "-q", "--precision", "auto", "--store-tol", tol)
    assert code == 0, err
    assert f"storage {want} adds" in out
    if ending != ".dds":
        assert Table.read(out_path).meta["storage"]["encoding"] == want


def test_tol_means_store_tol_with_precision_auto_outside_a_scene(tmp_path, capsys, fake_api, spec):
    code, out, err = run(capsys, "bake", spec, "-o", tmp_path / "a.ktx2", "-q", "--precision", "auto", "--tol", "1e-6")
    assert code == 0, err
    assert "storage float32 adds" in out


def test_explicit_precision(tmp_path, capsys, fake_api, spec):
    code, out, err = run(capsys, "bake", spec, "-o", tmp_path / "a.ktx2", "-q", "--precision", "unorm10")
    assert code == 0, err
    assert Table.read(tmp_path / "a.ktx2").meta["storage"]["vk_format"] == "VK_FORMAT_A2B10G10R10_UNORM_PACK32"


@pytest.mark.parametrize("extra,fragments", [
    (["-o", "x.ktx2", "--precision", "auto"], ["--precision auto needs --store-tol"]),
    (["-o", "x.ktx2", "--tol", "1e-3"], ["--tol applies to a scene file"]),
    (["-o", "x.ktx2", "--store-tol", "1e-3"], ["--store-tol applies to --precision auto"]),
    (["-o", "x.ktx2", "--precision", "auto", "--store-tol", "0"], ["--store-tol must be > 0"]),
    (["-o", "x.exr", "--precision", "float16"], ["--precision float16", "exr stores float32"]),
    (["-o", "x.exr", "--precision", "auto", "--store-tol", "1"], ["exr stores only float32"]),
    (["-o", "x.png", "--precision", "float16"], ["png stores unorm16, unorm8"]),
    (["-o", "x.ktx2", "--precision", "auto", "--store-tol", "1e-9"], ["no ktx2 storage keeps the table within 1e-09"]),
    (["-o", "x.ktx2", "--emit", "glsl,cobol"], ["--emit: unknown language 'cobol'"]),
])
def test_storage_option_errors_are_one_line(tmp_path, capsys, fake_api, spec, extra, fragments, monkeypatch):
    monkeypatch.chdir(tmp_path)
    code, out, err = run(capsys, "bake", spec, "-q", *extra)
    one_line_error(code, err, *fragments)


def test_precision_without_a_spec_is_an_error(tmp_path, capsys):
    code, out, err = run(capsys, "bake", "-o", tmp_path, "--precision", "float16")
    one_line_error(code, err, "--precision applies to a spec file or --preset")


def test_emit_without_the_lookup_package_is_one_line(tmp_path, capsys, fake_api, spec, monkeypatch):
    monkeypatch.setitem(sys.modules, "bsdf_tab.lookup", None)  # as if the module were absent
    code, out, err = run(capsys, "bake", spec, "-o", tmp_path / "a.exr", "-q", "--emit", "c")
    one_line_error(code, err, "lookup code generation is not available")


def test_emit_writes_lookup_code_beside_the_table(tmp_path, capsys, fake_api, spec):
    pytest.importorskip("bsdf_tab.lookup", reason="lookup code generation (bsdf_tab.lookup) is not in this tree")
    code, out, err = run(capsys, "bake", spec, "-o", tmp_path / "a.exr", "-q", "--emit", "glsl", "--emit", "c")
    assert code == 0, err
    written = [line.split(":")[0] for line in out.splitlines() if line.endswith("lookup code")]
    assert len(written) == 2 and all((tmp_path / p).exists() or __import__("os").path.exists(p) for p in written)


@pytest.mark.parametrize("name", ["a.dds", "missing.ktx2", "a.tga"])
def test_info_errors_are_one_line(tmp_path, capsys, fake_api, spec, name):
    if name == "a.dds":
        assert run(capsys, "bake", spec, "-o", tmp_path / name, "-q")[0] == 0
    code, out, err = run(capsys, "info", tmp_path / name)
    one_line_error(code, err, {"a.dds": "dds files cannot be read back", "missing.ktx2": "no such file",
                               "a.tga": "unknown file name ending"}[name])


def test_preset_bakes_in_its_engine_format_and_storage(tmp_path, capsys, monkeypatch):
    small = lambda: {"roughness": np.array([0.25, 0.75]), "mu": np.array([0.5, 1.0])}  # noqa: E731
    monkeypatch.setitem(PRESETS, "unreal-envbrdf", dataclasses.replace(PRESETS["unreal-envbrdf"], axes=small))
    monkeypatch.setitem(PRESETS, "bevy-dfg", dataclasses.replace(PRESETS["bevy-dfg"], axes=small))
    code, out, err = run(capsys, "bake", "--preset", "unreal-envbrdf", "-o", tmp_path, "-q")
    assert code == 0, err
    data = (tmp_path / "unreal_envbrdf.dds").read_bytes()
    assert data[:4] == b"DDS " and int.from_bytes(data[128:132], "little") == 35  # DXGI_FORMAT_R16G16_UNORM
    assert "storage unorm16 adds" in out
    code, out, err = run(capsys, "bake", "--preset", "bevy-dfg", "-o", tmp_path, "-q", "--precision", "float32")
    assert code == 0, err
    assert Table.read(tmp_path / "bevy_dfg.ktx2").meta["storage"]["vk_format"] == "VK_FORMAT_R32G32_SFLOAT"
    code, out, err = run(capsys, "bake", "--preset", "bevy-dfg", "-o", tmp_path, "-q", "--format", "exr")
    assert code == 0, err and (tmp_path / "bevy_dfg.exr").exists()
