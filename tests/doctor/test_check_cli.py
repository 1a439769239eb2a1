"""``bsdf-tab check``: the JSON report's keys, the text report, the heatmap, and one-line errors."""

from __future__ import annotations

import json

import numpy as np
import pytest

from bsdf_tab.cli import main as cli_main

from conftest import image_of

REQUIRED = ("table", "distribution", "shadowing", "axes", "channels", "encoding", "max_error", "mean_error", "findings")


def run(capsys, *argv):
    code = cli_main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_json_report_and_heatmap(ours, tmp_path, capsys):
    path = tmp_path / "flipped.npy"
    np.save(path, image_of(ours)[::-1])
    heat = tmp_path / "heat.png"
    code, out, err = run(capsys, "check", str(path), "--json", "--heatmap", str(heat))
    assert code == 0, err
    report = json.loads(out)
    assert all(k in report for k in REQUIRED)
    for axis in report["axes"]:
        assert all(k in axis for k in ("name", "spacing", "nodes", "range", "reversed"))
    assert report["axes"][0]["reversed"] is True and any("Y flipped" in f for f in report["findings"])
    assert heat.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    from PIL import Image

    assert Image.open(heat).size[0] > 100


def test_text_report_and_expected_axes(ours, tmp_path, capsys):
    path = tmp_path / "lut.npy"
    np.save(path, image_of(ours))
    code, out, _ = run(capsys, "check", str(path), "--axes", "roughness,mu")
    assert code == 0
    assert "best match: dfg, ggx, correlated" in out and "axes swapped" in out


@pytest.mark.parametrize("argv,message", [
    (["missing.npy"], "LUT file not found"),
    (["{arr}"], "shape: an array file needs its shape"),
    (["{arr}", "--shape", "3,y"], "--shape: give integers"),
    (["{arr}", "--shape", "2,4", "--array-values", "int"], "array_values: must be one of"),
    (["{arr}", "--shape", "64,64"], "shape: the array file holds"),
    (["{npy}", "--axes", "mu,roughness,ior,x"], "--axes: give 1 to 3 names"),
    (["{npy}", "--axes", "mu,,roughness"], "--axes: give 1 to 3 names"),
    (["{ramp}", "--axes", "mu"], "axes"),  # one name for a 2-D file: the doctor names the mismatch
    (["{arr2}", "--shape", "2,2", "--array-name", "nope"], "nope"),
])
def test_errors_are_one_line_exit_2(tmp_path, capsys, argv, message):
    arr = tmp_path / "lut.h"
    arr.write_text("static const float lut[2][4] = {0.1f, 0.2f, 0.3f, 0.4f, 0.5f, 0.6f, 0.7f, 0.8f};\n")
    npy = tmp_path / "lut.npy"
    np.save(npy, np.ones((4, 4)))
    arr2 = tmp_path / "two.h"
    arr2.write_text("const float a[2][2] = {1, 2, 3, 4};\nconst float b[2][2] = {5, 6, 7, 8};\n")
    ramp = tmp_path / "ramp.npy"
    np.save(ramp, np.linspace(0.0, 1.0, 64).reshape(8, 8))
    argv = [a.format(arr=arr, npy=npy, arr2=arr2, ramp=ramp) for a in argv]
    code, out, err = run(capsys, "check", *argv)
    assert code == 2 and out == ""
    assert len(err.strip().splitlines()) == 1 and message in err and "Traceback" not in err


def test_array_name_picks_one_of_several_arrays(tmp_path, capsys):
    """Two arrays of different sizes in one file: --array-name reads the named one."""
    ramp = np.linspace(0.0, 1.0, 8 * 8).reshape(8, 8) ** 2
    body = ", ".join(f"{v:.6f}" for v in ramp.ravel())
    other = ", ".join(f"{v:.3f}" for v in np.linspace(0, 1, 16 * 16))
    src = tmp_path / "two.cc"
    src.write_text(f"const float big[16][16] = {{{other}}};\nconst float ramp[8][8] = {{{body}}};\n")
    code, out, err = run(capsys, "check", str(src), "--shape", "8,8", "--array-name", "ramp", "--json")
    assert code == 0, err
    code2, out2, err2 = run(capsys, "check", str(src), "--shape", "16,16", "--array-name", "big", "--json")
    assert code2 == 0, err2
    # a squared ramp and a linear ramp are different data: different fits
    assert json.loads(out)["max_error"] != json.loads(out2)["max_error"]


def test_array_with_more_numbers_than_the_shape_is_an_error(tmp_path, capsys):
    """--shape smaller than the data is refused like a larger one (never a silent partial read),
    and a file with several arrays suggests --array-name."""
    one = tmp_path / "dfg_arr.js"
    one.write_text("const DFG = [" + ", ".join(f"{v:.4f}" for v in np.linspace(0, 1, 128)) + "];\n")
    code, out, err = run(capsys, "check", str(one), "--shape", "8,8")
    assert code == 2 and out == "" and len(err.strip().splitlines()) == 1
    assert "holds 128 numbers, the shape (8, 8) needs 64" in err and "--array-name" not in err
    two = tmp_path / "two.cc"
    two.write_text("const float big[4] = {1, 2, 3, 4};\nconst float small[2] = {5, 6};\n")
    code, out, err = run(capsys, "check", str(two), "--shape", "4")
    assert code == 2 and out == "" and len(err.strip().splitlines()) == 1
    assert "2 arrays (big, small)" in err and "--array-name" in err
