"""Tests of the bsdf-tab command line (run in-process through cli.main)."""

import json

import numpy as np
import pytest

import bsdf_tab.api
from bsdf_tab import cli
from bsdf_tab.cli import many as many_command
from bsdf_tab.presets import default_specs
from bsdf_tab import read_exr
from bsdf_tab.errors import SpecError
from bsdf_tab.spec import normalize_spec, resolve_axes, texel_count
from bsdf_tab.table import Table


def hand_table(spec: dict) -> Table:
    """A table with deterministic values for ``spec`` and small error channels."""
    nspec = normalize_spec(spec)
    axes = resolve_axes(nspec)
    shape = tuple(len(a) for a in axes.values())
    kind = nspec["table"]
    names = {"albedo": ["E"], "albedo_avg": ["E_avg"], "dielectric": ["R", "T"], "dfg": ["A", "B"]}[kind]
    channels = {n: np.full(shape, 0.5, dtype=np.float32) for n in names}
    channels.update({n + "_err": np.full(shape, 2.5e-7, dtype=np.float32) for n in names})
    meta = {"spec": nspec, "conventions": {"alpha": "walter"}, "method": "adaptive", "version": "9.9.9"}
    return Table(axes, channels, meta)


@pytest.fixture
def fake_api(monkeypatch):
    """Replace bsdf_tab.api by a fake whose tabulate records its calls."""
    calls = []

    def tabulate(spec, *, device=None, workers=None, progress=False, scheduler=None):
        calls.append({"spec": spec, "device": device, "workers": workers, "progress": progress})
        if callable(progress):
            n = texel_count(spec)
            progress(n // 2, n)
            progress(n, n)
        return hand_table(spec)

    monkeypatch.setattr(bsdf_tab.api, "tabulate", tabulate)
    return calls


def max_error_printed(out: str, channel: str = "E") -> float:
    """The stored max error of ``channel`` on a bake's summary line (``max error E 0.000214; storage ...``)."""
    import re

    return float(re.search(rf"max error (?:[^;]*?){channel} ([0-9.eE+-]+)", out).group(1))


def run(capsys, *argv):
    code = cli.main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def assert_one_line_error(code, err, *fragments):
    assert code == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("bsdf-tab: error: ")
    assert "Traceback" not in err
    for fragment in fragments:
        assert fragment in lines[0]


# --------------------------------------------------------------------------- errors


def test_bad_spec_is_one_line_exit_2(tmp_path, capsys):
    spec = tmp_path / "bad.json"
    spec.write_text(json.dumps({"table": "albedo", "axes": {"mu": [0.5, 0.2]}}))
    code, out, err = run(capsys, "bake", str(spec))
    assert_one_line_error(code, err, "axes.mu", "strictly increasing")
    assert not (tmp_path / "bad.exr").exists()


def test_unknown_table_is_one_line_exit_2(tmp_path, capsys):
    spec = tmp_path / "bad.json"
    spec.write_text(json.dumps({"table": "glass"}))
    code, _, err = run(capsys, "bake", str(spec))
    assert_one_line_error(code, err, "table", "must be one of")


def test_bad_json_is_one_line_exit_2(tmp_path, capsys):
    spec = tmp_path / "broken.json"
    spec.write_text("{not json")
    code, _, err = run(capsys, "bake", str(spec))
    assert_one_line_error(code, err, "invalid JSON")


def test_missing_spec_file(tmp_path, capsys):
    code, _, err = run(capsys, "bake", str(tmp_path / "nope.json"))
    assert_one_line_error(code, err, "not found", "nope.json")


def test_info_on_missing_and_foreign_files(tmp_path, capsys):
    code, _, err = run(capsys, "info", str(tmp_path / "nope.exr"))
    assert_one_line_error(code, err, "nope.exr")
    text = tmp_path / "text.exr"
    text.write_text("not an exr")
    code, _, err = run(capsys, "info", str(text))
    assert_one_line_error(code, err, "not an OpenEXR file")


def test_usage_errors_exit_2(capsys):
    assert cli.main(["bake", "--no-such-option"]) == 2
    assert cli.main([]) == 2
    assert cli.main(["frobnicate"]) == 2
    capsys.readouterr()


def test_library_spec_error_is_one_line(monkeypatch, tmp_path, capsys):
    def tabulate(spec, **kwargs):
        raise SpecError("tolerance", "cannot be reached\non this device")

    monkeypatch.setattr(bsdf_tab.api, "tabulate", tabulate)
    spec = tmp_path / "s.json"
    spec.write_text(json.dumps({"table": "albedo_avg", "axes": {"alpha": [0.5]}}))
    code, _, err = run(capsys, "bake", str(spec))
    assert_one_line_error(code, err, "tolerance: cannot be reached on this device")


@pytest.mark.parametrize("exc", [ValueError("operands could not be broadcast together"),
                                 RuntimeError("kernel exploded")])
def test_library_errors_are_internal_and_debug_shows_them(monkeypatch, tmp_path, capsys, exc):
    """A bare ValueError (NumPy's, a bug's) is not bad input, as a RuntimeError is not: exit 1,
    one line, its traceback with --debug."""
    def tabulate(spec, **kwargs):
        raise exc

    monkeypatch.setattr(bsdf_tab.api, "tabulate", tabulate)
    spec = tmp_path / "s.json"
    spec.write_text(json.dumps({"table": "albedo_avg", "axes": {"alpha": [0.5]}}))
    code, _, err = run(capsys, "bake", str(spec))
    assert code == 1 and len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert f"internal error: {type(exc).__name__}: {exc}" in err
    with pytest.raises(type(exc), match=str(exc).split()[0]):  # --debug: the exception propagates (a traceback)
        cli.main(["--debug", "bake", str(spec)])


def test_keyboard_interrupt_exit_130(monkeypatch, tmp_path, capsys):
    def tabulate(spec, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(bsdf_tab.api, "tabulate", tabulate)
    spec = tmp_path / "s.json"
    spec.write_text(json.dumps({"table": "albedo_avg", "axes": {"alpha": [0.5]}}))
    code, _, err = run(capsys, "bake", str(spec))
    assert code == 130
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err


# --------------------------------------------------------------------------- info


def test_info_prints_axes_and_max_error(tmp_path, capsys):
    table = hand_table({"table": "dielectric", "axes": {"mu": [0.25, 1.0], "alpha": {"size": 3}, "eta": [1.5]}})
    table.channels["T_err"][1, 2, 0] = 3.25e-6
    path = tmp_path / "glass.exr"
    table.write_exr(path)
    code, out, err = run(capsys, "info", str(path))
    assert code == 0 and err == ""
    assert "table: dielectric" in out
    assert "mu" in out and "size 2" in out and "min 0.25" in out
    assert "alpha" in out and "size 3" in out and "max 1" in out
    assert "eta" in out and "min 1.5" in out
    assert "channels: R, T, R_err, T_err" in out
    assert "R: 2.5e-07" in out
    assert "T: 3.25e-06" in out
    assert "method: adaptive" in out
    assert "version: 9.9.9" in out
    assert "alpha: walter" in out  # conventions


# --------------------------------------------------------------------------- bake (fake api)


def test_bake_spec_file_with_fake_api(tmp_path, capsys, fake_api):
    spec = tmp_path / "tiny.json"
    spec.write_text(json.dumps({"table": "albedo", "axes": {"mu": {"size": 3}, "alpha": [0.1, 0.5]}}))
    code, out, err = run(capsys, "bake", str(spec), "--device", "cpu", "--quiet", "--workers", "2")
    assert code == 0, err
    assert fake_api[0]["device"] == "cpu" and fake_api[0]["workers"] == 2 and fake_api[0]["progress"] is False
    assert fake_api[0]["spec"]["table"] == "albedo"
    written = tmp_path / "tiny.exr"
    table = read_exr(written)
    assert table.shape == (3, 2)
    assert str(written) in out and "mu 3 x alpha 2" in out and "2.5e-07" in out
    assert len(out.strip().splitlines()) == 1


def test_bake_output_option_and_formats(tmp_path, capsys, fake_api):
    spec = tmp_path / "s.json"
    spec.write_text(json.dumps({"table": "albedo_avg", "axes": {"alpha": [0.1, 0.5]}}))
    out_exr = tmp_path / "custom.exr"
    assert run(capsys, "bake", str(spec), "-o", str(out_exr), "-q")[0] == 0
    assert read_exr(out_exr).axes["alpha"].tolist() == [0.1, 0.5]
    out_npz = tmp_path / "t.npz"
    assert run(capsys, "bake", str(spec), "-o", str(out_npz), "-q")[0] == 0
    assert Table.from_npz_bytes(out_npz.read_bytes()).shape == (2,)
    code, _, err = run(capsys, "bake", str(spec), "-o", str(tmp_path / "t.tga"), "-q")
    assert_one_line_error(code, err, ".exr")


def test_default_specs_content():
    specs = dict(default_specs())
    assert len(specs) == 7
    shapes = {name: tuple(len(a) for a in resolve_axes(s).values()) for name, s in specs.items()}
    assert shapes["ggx_albedo.exr"] == (32, 32)
    assert shapes["beckmann_albedo_avg.exr"] == (32,)
    assert shapes["ggx_dielectric_eta_gt1.exr"] == (16, 16, 16)
    assert shapes["ggx_dfg.exr"] == (128, 128)
    for name, spec in specs.items():
        n = normalize_spec(spec)
        assert n["shadowing"] == "correlated"
        assert n["fresnel"]["type"] in ("one", "dielectric")
    assert normalize_spec(specs["beckmann_albedo.exr"])["distribution"] == "beckmann"
    gt = resolve_axes(specs["ggx_dielectric_eta_gt1.exr"])["eta"]
    lt = resolve_axes(specs["ggx_dielectric_eta_lt1.exr"])["eta"]
    assert gt.min() > 1 and lt.max() < 1
    np.testing.assert_allclose(np.sort(1.0 / lt), gt, rtol=1e-15)
    dfg = resolve_axes(specs["ggx_dfg.exr"])
    assert list(dfg) == ["mu", "roughness"]
    assert dfg["mu"][0] == pytest.approx(0.5 / 128) and dfg["roughness"][-1] == pytest.approx(1 - 0.5 / 128)


def test_bake_default_set_with_fake_api(tmp_path, capsys, fake_api):
    out_dir = tmp_path / "luts"
    code, out, err = run(capsys, "bake", "-o", str(out_dir))
    assert code == 0, err
    names = sorted(p.name for p in out_dir.iterdir())
    assert names == sorted(name for name, _ in default_specs())
    assert all(callable(call["progress"]) for call in fake_api)
    assert read_exr(out_dir / "ggx_dfg.exr").shape == (128, 128)
    assert len(out.strip().splitlines()) == 7


# --------------------------------------------------------------------------- bake (real api)


def test_bake_tiny_spec_with_real_api(tmp_path, capsys):
    spec = tmp_path / "tiny.json"
    spec.write_text(json.dumps({"table": "albedo", "axes": {"mu": [0.5, 1.0], "alpha": [0.2, 1.0]}, "tolerance": 1e-5}))
    code, out, err = run(capsys, "bake", str(spec), "--device", "cpu", "--quiet")
    assert code == 0, err
    table = read_exr(tmp_path / "tiny.exr")
    assert table.shape == (2, 2)
    assert set(table.value_channels) == {"E"} and "E_err" in table.channels
    # closed form: GGX, F = 1, mu = 1, alpha = 1 -> E = 1 - ln 2 (both shadowing modes)
    assert table.channels["E"][1, 1] == pytest.approx(1 - np.log(2), abs=1e-4)
    assert np.all((table.channels["E"] > 0) & (table.channels["E"] <= 1))
    assert table.meta["spec"] == normalize_spec(json.loads(spec.read_text()))


def test_bake_spec_file_to_every_export_format(tmp_path, capsys):
    """A spec file can be written as half EXR, .npy (one structured array), per-channel .npy
    files or a C header (by -o name or --format), and the printed max error is that of what was
    written (half: with the float16 rounding)."""
    from bsdf_tab import io

    spec = tmp_path / "s.json"
    spec.write_text(json.dumps({"table": "albedo", "axes": {"mu": [0.3, 1.0], "alpha": [0.2, 0.6]}, "tolerance": 1e-6}))
    code, out, err = run(capsys, "bake", str(spec), "-o", str(tmp_path / "t.half.exr"), "-q")
    assert code == 0, err
    half = read_exr(tmp_path / "t.half.exr")
    printed = max_error_printed(out)
    # float16 spacing near E ~ 0.5-1 is 2^-11 or 2^-12: the rounding dominates the 1e-6 integration error
    assert printed == pytest.approx(float(half.channels["E_err"].astype(np.float64).max()), rel=5e-3)
    assert printed > 1e-5
    code, out, err = run(capsys, "bake", str(spec), "--format", "npy-channels", "-o", str(tmp_path), "-q")
    assert code == 0, err
    table = io.read(tmp_path / "s.meta.json", factory=Table)
    assert table.shape == (2, 2) and 1e-7 < max_error_printed(out) <= 1e-6
    code, out, err = run(capsys, "bake", str(spec), "--format", "npy", "-o", str(tmp_path), "-q")
    assert code == 0, err
    arr = np.load(tmp_path / "s.npy")  # plain numpy: one structured array, a field per channel
    assert arr.shape == (2, 2) and set(arr.dtype.names) == {"E", "E_err"}
    assert arr["E"][1, 1] == pytest.approx(table.channels["E"][1, 1], abs=1e-7)
    code, out, err = run(capsys, "bake", str(spec), "-o", str(tmp_path / "lut.h"), "-q")
    assert code == 0, err
    text = (tmp_path / "lut.h").read_text()
    assert "lut" in text and "0.2" in text and str(tmp_path / "lut.h") in out
    code, _, err = run(capsys, "bake", str(spec), "--format", "h", "-o", str(tmp_path / "x.exr"), "-q")
    assert_one_line_error(code, err, "--format h", ".h")


def test_bake_cli_option_errors_are_one_line(tmp_path, capsys):
    scene = tmp_path / "scene.json"
    scene.write_text(json.dumps({"materials": [{"type": "schlick", "f0": 0.04, "alpha": 0.2}], "tolerance": 0.01}))
    code, _, err = run(capsys, "bake", str(scene), "--format", "npy", "-o", str(tmp_path / "o"))
    assert_one_line_error(code, err, "--format", "scene")
    code, _, err = run(capsys, "bake", "--format", "npy", "-o", str(tmp_path / "d"))
    assert_one_line_error(code, err, "--format")


@pytest.mark.parametrize("argv,fragment", [(["--methods", "bogus,adaptive"], "bogus"), (["--methods", ","], "--methods"),
                                           (["--workers", "0"], "--workers")])
def test_bench_accuracy_rejects_bad_options_before_running(tmp_path, capsys, argv, fragment):
    code, out, err = run(capsys, "bench", "accuracy", "--quick", "-o", str(tmp_path), *argv)
    assert_one_line_error(code, err, fragment)
    assert not any(tmp_path.iterdir())  # nothing ran


def test_default_set_progress_never_goes_backwards(tmp_path, capsys, monkeypatch):
    """The integrator may report more work items than texels (mu-averaged tables): the bar is
    scaled to the table's share and only moves forward."""
    updates = []

    class Bar:
        n = 0

        def __init__(self, total, quiet):
            self.total = total

        def __enter__(self):
            return self

        def __exit__(self, *exc):
            return False

        def update(self, k):
            updates.append(k)
            self.n += k

        def set_postfix_str(self, *a, **k):
            pass

        def write(self, *a, **k):
            pass

    def tabulate(spec, *, device=None, workers=None, progress=False, scheduler=None):
        n = texel_count(spec)
        for done in (n, 2 * n, 3 * n):  # three work items per texel
            progress(done, 3 * n)
        return hand_table(spec)

    monkeypatch.setattr(bsdf_tab.api, "tabulate", tabulate)
    monkeypatch.setattr(many_command, "_bar", Bar)
    assert run(capsys, "bake", "-o", str(tmp_path / "luts"))[0] == 0
    assert updates and min(updates) >= 0
    assert sum(updates) == sum(texel_count(normalize_spec(s)) for _, s in default_specs())


def test_max_seconds_refuses_a_bake_predicted_too_long(tmp_path, capsys):
    # the cost model predicts before anything runs: 2^26 Monte Carlo samples per texel take minutes
    spec = tmp_path / "big.json"
    spec.write_text(json.dumps({"table": "albedo", "method": "mc_vndf", "effort": 1 << 26,
                                "axes": {"mu": {"size": 4}, "alpha": {"size": 4}}}))
    code, out, err = run(capsys, "bake", str(spec), "--max-seconds", "5", "-q")
    assert_one_line_error(code, err, "--max-seconds 5", "effort")
    assert not (tmp_path / "big.exr").exists()
    code, out, err = run(capsys, "bake", "--max-seconds", "0.01", "-o", str(tmp_path / "d"), "-q")
    assert_one_line_error(code, err, "--max-seconds 0.01", "predicted")
