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
    (["{npy}", "--axes", "mu"], "--axes: give two names"),
])
def test_errors_are_one_line_exit_2(tmp_path, capsys, argv, message):
    arr = tmp_path / "lut.h"
    arr.write_text("static const float lut[2][4] = {0.1f, 0.2f, 0.3f, 0.4f, 0.5f, 0.6f, 0.7f, 0.8f};\n")
    npy = tmp_path / "lut.npy"
    np.save(npy, np.ones((4, 4)))
    argv = [a.format(arr=arr, npy=npy) for a in argv]
    code, out, err = run(capsys, "check", *argv)
    assert code == 2 and out == ""
    assert len(err.strip().splitlines()) == 1 and message in err and "Traceback" not in err
