"""Bad input is one line and exit 2; internal errors exit 1; never a table with NaN values.

Each test here failed before its fix: a huge Fresnel IOR baked an all-NaN table with exit 0, a
bare ValueError (a bug's) was reported as bad input, ``--scheduler local:abc`` printed
``invalid literal for int()``, a truncated EXR printed OpenEXR's own lines on stdout and stderr.
"""

from __future__ import annotations

import json

import mpmath
import numpy as np
import pytest

import bsdf_tab
import bsdf_tab.api
from bsdf_tab import cli
from bsdf_tab.errors import NonFiniteTableError, SpecError
from bsdf_tab.spec import normalize_spec
from bsdf_tab.tables import KINDS

ALBEDO_4 = {"table": "albedo", "axes": {"mu": {"size": 4}, "alpha": {"size": 4}}, "tolerance": 1e-3}


def run(capsys, *argv):
    code = cli.main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def one_line(code, err, expected_code=2):
    assert code == expected_code, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("bsdf-tab: error: ") and "Traceback" not in err, err
    return lines[0]


# --------------------------------------------------------------------------- Fresnel bounds


@pytest.mark.parametrize("fresnel, param", [
    ({"type": "conductor", "eta": 1e300, "k": 1e300}, "fresnel.eta"),
    ({"type": "conductor", "eta": 1.0, "k": 1e300}, "fresnel.k"),
    ({"type": "conductor", "eta": 1000.5, "k": 0.0}, "fresnel.eta"),
    ({"type": "conductor", "eta": 0.2, "k": 1001.0}, "fresnel.k"),
    ({"type": "dielectric", "eta": 1e300}, "fresnel.eta"),
    ({"type": "dielectric", "eta": 100.5}, "fresnel.eta"),
])
def test_fresnel_ior_beyond_the_bound_is_a_spec_error(fresnel, param):
    with pytest.raises(SpecError) as info:
        normalize_spec({"table": "albedo", "fresnel": fresnel})
    assert info.value.param == param and "must be <=" in info.value.message


def test_fresnel_ior_at_the_bound_is_accepted():
    normalize_spec({"table": "albedo", "fresnel": {"type": "dielectric", "eta": 100.0}})
    normalize_spec({"table": "albedo", "fresnel": {"type": "conductor", "eta": 1000.0, "k": 1000.0}})


def _fresnel_conductor(mu, eta, k):
    """Unpolarized Fresnel reflectance of a complex IOR, amplitude form (Born and Wolf), 50 digits."""
    with mpmath.workdps(50):
        n, c = mpmath.mpc(eta, k), mpmath.mpf(mu)
        ct = mpmath.sqrt(n * n - (1 - c * c)) / n
        rs, rp = (c - n * ct) / (c + n * ct), (n * c - ct) / (n * c + ct)
        return float((abs(rs) ** 2 + abs(rp) ** 2) / 2)


def test_the_bound_is_computed_accurately():
    """At eta = k = 1000 the mirror limit (alpha = 0, E = F(mu)) matches a 50-digit Fresnel."""
    mu = [0.05, 0.5, 1.0]
    t = bsdf_tab.tabulate({"table": "albedo", "fresnel": {"type": "conductor", "eta": 1000.0, "k": 1000.0},
                           "axes": {"mu": mu, "alpha": [0.0]}})
    want = [_fresnel_conductor(m, 1000.0, 1000.0) for m in mu]
    np.testing.assert_allclose(t.channels["E"][:, 0], want, rtol=0, atol=1e-9)


def test_bake_of_a_huge_ior_is_one_line_and_writes_nothing(tmp_path, capsys):
    spec = tmp_path / "c.json"
    spec.write_text(json.dumps({**ALBEDO_4, "fresnel": {"type": "conductor", "eta": 1e300, "k": 1e300}}))
    code, out, err = run(capsys, "bake", str(spec), "-o", str(tmp_path / "c.exr"), "-q")
    assert "fresnel.eta" in one_line(code, err) and "c.json" in err
    assert not (tmp_path / "c.exr").exists()


def test_scene_with_a_huge_ior_is_refused_up_front(tmp_path, capsys):
    scene = tmp_path / "scene.json"
    scene.write_text(json.dumps({"materials": [{"type": "conductor", "eta": 1e300, "k": 1.0, "alpha": 0.3}]}))
    code, out, err = run(capsys, "plan", str(scene), "--tol", "1e-3", "-q")
    assert "materials[0].eta" in one_line(code, err)


# --------------------------------------------------------------------------- the last guard


@pytest.fixture
def nan_albedo(monkeypatch):
    """The albedo kind's compute returns a NaN texel (a stand-in for a kernel bug)."""
    compute = KINDS["albedo"]["compute"]

    def broken(nspec, axes, ctx):
        channels = compute(nspec, axes, ctx)
        channels["E"] = np.array(channels["E"], dtype=np.float64)
        channels["E"].flat[1] = np.nan
        return channels

    monkeypatch.setitem(KINDS["albedo"], "compute", broken)


def test_tabulate_never_returns_nan_values(nan_albedo):
    with pytest.raises(NonFiniteTableError, match="channel E has 1 of 16 texels NaN or infinite"):
        bsdf_tab.tabulate(ALBEDO_4)
    with pytest.raises(NonFiniteTableError):
        list(bsdf_tab.api.iter_blocks(ALBEDO_4))  # the streamed path: before a writer sees the block


def test_bake_never_writes_nan_values(nan_albedo, tmp_path, capsys):
    spec = tmp_path / "a.json"
    spec.write_text(json.dumps(ALBEDO_4))
    code, out, err = run(capsys, "bake", str(spec), "-o", str(tmp_path / "a.exr"), "-q")
    assert "internal error: NonFiniteTableError" in one_line(code, err, expected_code=1)
    assert not (tmp_path / "a.exr").exists()


# --------------------------------------------------------------------------- bad input vs internal errors


def test_malformed_scheduler_names_the_option(tmp_path, capsys):
    spec = tmp_path / "a.json"
    spec.write_text(json.dumps(ALBEDO_4))
    code, out, err = run(capsys, "bake", str(spec), "-o", str(tmp_path / "a.exr"), "--scheduler", "local:abc", "-q")
    line = one_line(code, err)
    assert "--scheduler" in line and "local:abc" in line and "invalid literal" not in line


def test_unknown_device_names_the_option(tmp_path, capsys):
    spec = tmp_path / "a.json"
    spec.write_text(json.dumps(ALBEDO_4))
    code, out, err = run(capsys, "bake", str(spec), "-o", str(tmp_path / "a.exr"), "--device", "bogus", "-q")
    assert "--device" in one_line(code, err) and "bogus" in err
    assert not (tmp_path / "a.exr").exists()


def test_a_bug_in_the_doctor_is_an_internal_error(monkeypatch, tmp_path, capsys):
    """A ValueError raised by the code (NumPy broadcasting) is exit 1, its traceback with --debug."""
    import bsdf_tab.doctor

    def broken(*args, **kwargs):
        raise ValueError("operands could not be broadcast together with shapes (1,5,5,4) (5,5,4,5)")

    monkeypatch.setattr(bsdf_tab.doctor, "check_lut", broken)
    lut = tmp_path / "lut.npy"
    np.save(lut, np.ones((4, 4)))
    code, out, err = run(capsys, "check", str(lut))
    assert "internal error: ValueError" in one_line(code, err, expected_code=1)
    with pytest.raises(ValueError, match="broadcast"):
        cli.main(["--debug", "check", str(lut)])


def test_float_array_read_as_integers_is_one_line(tmp_path, capsys):
    arr = tmp_path / "lut.js"
    arr.write_text("const L = [" + ", ".join(f"{v:.4f}" for v in np.linspace(0, 1, 64)) + "];\n")
    code, out, err = run(capsys, "check", str(arr), "--shape", "8,8", "--array-values", "unorm8")
    assert "array_values" in one_line(code, err) and "float" in err


# --------------------------------------------------------------------------- damaged EXR


@pytest.fixture
def damaged(tmp_path):
    """A good bsdf-tab EXR and two damaged copies: the tail cut off, the header cut short."""
    table = bsdf_tab.tabulate(ALBEDO_4)
    good = tmp_path / "good.exr"
    table.write_exr(good)
    data = good.read_bytes()
    (tmp_path / "trunc_tail.exr").write_bytes(data[:-20])
    (tmp_path / "trunc_head.exr").write_bytes(data[:400])
    return tmp_path


@pytest.mark.parametrize("command", ["info", "check"])
@pytest.mark.parametrize("name", ["trunc_tail.exr", "trunc_head.exr"])
def test_truncated_exr_is_one_line_naming_the_file(damaged, capfd, command, name):
    code = cli.main([command, str(damaged / name)])
    out, err = capfd.readouterr()  # fd level: OpenEXR's C++ writes to the process' stdout / stderr
    assert out == ""
    line = one_line(code, err)
    assert f"{name}: truncated or corrupt OpenEXR file" in line
    assert "/tmp/tmp" not in line and "lut.exr" not in line


def test_good_exr_reads_after_the_check(damaged, capsys):
    code, out, err = run(capsys, "info", str(damaged / "good.exr"))
    assert code == 0 and "table: albedo" in out


# --------------------------------------------------------------------------- smaller ones


def test_table_too_large_for_memory_is_refused_up_front(tmp_path, capsys):
    spec = tmp_path / "big.json"
    spec.write_text(json.dumps({"table": "dielectric",
                                "axes": {"mu": {"size": 4096}, "alpha": {"size": 4096}, "eta": {"size": 4096}}}))
    code, out, err = run(capsys, "bake", str(spec), "-o", str(tmp_path / "big.exr"))
    line = one_line(code, err)
    assert "68,719,476,736 texels" in line and "mu 4096 x alpha 4096 x eta 4096" in line  # 4096^3 = 2^36


@pytest.mark.parametrize("argv, message", [
    (["bake", "a.json", "--workers", "abc"], "bsdf-tab bake: error: argument --workers: invalid int value: 'abc'"),
    (["bake", "a.json", "--tol", "x"], "bsdf-tab bake: error: argument --tol: invalid float value: 'x'"),
    (["bake", "a.json", "--format", "foo"], "bsdf-tab bake: error: argument --format: invalid choice: 'foo'"),
    (["check", "lut.npy", "--no-such-option"], "bsdf-tab: error: unrecognized arguments: --no-such-option"),
])
def test_argparse_errors_are_one_line(capsys, argv, message):
    code, out, err = run(capsys, *argv)
    assert code == 2 and out == ""
    assert err.strip().splitlines() == [err.strip()] and err.startswith(message) and "usage:" not in err


def test_help_still_prints_usage(capsys):
    code, out, err = run(capsys, "bake", "--help")
    assert code == 0 and out.startswith("usage: bsdf-tab bake")


@pytest.mark.parametrize("argv, fragment", [
    (["bake", "--preset", "threejs-dfg", "-o", "{tmp}/pout/x.exr"], "x.exr"),
    (["bake", "{scene}", "--tol", "0.01", "-o", "{tmp}/scfile.exr"], "scfile.exr"),
])
def test_a_file_name_for_a_folder_of_files_is_refused(tmp_path, capsys, argv, fragment):
    scene = tmp_path / "scene.json"
    scene.write_text(json.dumps({"materials": [{"type": "schlick", "f0": 0.04, "alpha": 0.2}]}))
    argv = [a.format(tmp=tmp_path, scene=scene) for a in argv]
    code, out, err = run(capsys, *argv, "-q")
    assert fragment in one_line(code, err) and "folder" in err
    assert not (tmp_path / "pout").exists() and not (tmp_path / "scfile.exr").exists()


def test_max_seconds_is_refused_for_a_scene(tmp_path, capsys):
    scene = tmp_path / "scene.json"
    scene.write_text(json.dumps({"materials": [{"type": "schlick", "f0": 0.04, "alpha": 0.2}]}))
    code, out, err = run(capsys, "bake", str(scene), "--tol", "0.01", "-o", str(tmp_path / "d"),
                         "--max-seconds", "10", "-q")
    assert "--max-seconds" in one_line(code, err) and "scene" in err
    assert not (tmp_path / "d").exists()


@pytest.mark.parametrize("text, fragment", [
    ('"albedo"', "a spec must be a JSON object, got a JSON string"),
    ("[1, 2]", "a spec must be a JSON object, got a JSON array"),
    ('{"table": "albedo", "table": "dfg"}', "the key 'table' is given more than once"),
    ('{"table": "albedo", "axes": {"mu": {"size": 4, "size": 5}}}', "the key 'size' is given more than once"),
])
def test_spec_file_that_is_no_object_or_repeats_a_key(tmp_path, capsys, text, fragment):
    spec = tmp_path / "s.json"
    spec.write_text(text)
    code, out, err = run(capsys, "bake", str(spec), "-o", str(tmp_path / "s.exr"))
    line = one_line(code, err)
    assert fragment in line and "s.json" in line and "invalid JSON" not in line


@pytest.mark.parametrize("command", ["plan", "bake"])
def test_scene_file_that_repeats_a_key(tmp_path, capsys, command):
    """Scene and library files are read as strictly as spec files: a repeated key is refused."""
    scene = tmp_path / "scene.json"
    scene.write_text('{"materials": [{"type": "schlick", "f0": 0.04, "alpha": 0.3, "alpha": 0.5}]}')
    argv = [command, str(scene), "--tol", "1e-2"] + (["-o", str(tmp_path / "out")] if command == "bake" else [])
    code, out, err = run(capsys, *argv)
    line = one_line(code, err)
    assert "the key 'alpha' is given more than once" in line and "scene.json" in line
    assert not (tmp_path / "out").exists()


def test_a_spec_string_that_repeats_a_key_is_a_spec_error():
    with pytest.raises(SpecError, match="'table' is given more than once"):
        normalize_spec('{"table": "albedo", "table": "dfg"}')
