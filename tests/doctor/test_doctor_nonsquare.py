"""The doctor on LUTs that are neither square (2-D) nor cubic (3-D).

Before the fix the N-D search cached its model predictions under the sorted axis keys alone,
so two assignments of the quantities to axes of different sizes shared one prediction and NumPy
failed to broadcast (``shapes (1,5,5,4) (5,5,4,5)``), bsdf-tab's own 5 x 5 x 4 files included.
The truth for bsdf-tab's own files is their spec (what was baked), not the doctor's search.
"""

from __future__ import annotations

import numpy as np
import pytest

import bsdf_tab
from bsdf_tab.cli import main as cli_main
from bsdf_tab.doctor import check_lut

TOL = 1e-4  # a quick bake; the doctor's exact check is far tighter than the differences between models


def bake(tmp_path, name, spec):
    path = tmp_path / name
    bsdf_tab.tabulate({**spec, "tolerance": TOL}).write_exr(path)
    return path


@pytest.mark.parametrize("sizes", [(5, 5, 4), (6, 5, 4), (4, 5, 6)])
def test_own_dielectric_files_of_any_shape_are_identified(tmp_path, sizes):
    mu, alpha, eta = sizes
    path = bake(tmp_path, "d.exr", {"table": "dielectric", "shadowing": "correlated",
                                    "axes": {"mu": {"size": mu}, "alpha": {"size": alpha}, "eta": {"size": eta}}})
    r = check_lut(path).to_dict()
    assert (r["table"], r["distribution"], r["shadowing"]) == ("dielectric", "ggx", "correlated")
    assert r["channels"] == {"R": "R", "T": "T"}
    assert [a["name"] for a in r["axes"]] == ["mu", "alpha", "ior"]
    assert [a["size"] for a in r["axes"]] == list(sizes)
    np.testing.assert_allclose(r["axes"][2]["range"], [1.01, 4.0])  # the default eta axis, as baked
    assert r["max_error"] < 10 * TOL


def test_own_dielectric_avg_file_is_identified(tmp_path):
    path = bake(tmp_path, "davg.exr", {"table": "dielectric_avg", "shadowing": "separable",
                                       "axes": {"alpha": {"size": 8}, "eta": {"size": 6}}})
    r = check_lut(path).to_dict()
    assert (r["table"], r["shadowing"]) == ("dielectric_avg", "separable")
    assert r["channels"] == {"R_avg": "R", "T_avg": "T"}
    assert r["max_error"] < 10 * TOL


@pytest.mark.parametrize("shape", [(8, 6), (6, 6, 5), (8, 6, 2)])
def test_random_arrays_of_any_shape_give_a_report(tmp_path, capsys, shape):
    path = tmp_path / "r.npy"
    np.save(path, np.random.default_rng(7).random(shape))
    code = cli_main(["check", str(path)])
    out, err = capsys.readouterr()
    assert code == 0, err
    assert "no candidate fits well" in out  # noise is no table: the report says so


def test_non_square_array_file_gives_a_report(tmp_path, capsys):
    path = tmp_path / "dfg_arr.js"
    values = np.random.default_rng(3).random(64)
    path.write_text("const DFG = [" + ", ".join(f"{v:.6f}" for v in values) + "];\n")
    code = cli_main(["check", str(path), "--shape", "8,4,2"])
    out, err = capsys.readouterr()
    assert code == 0, err
    assert out.startswith("dfg_arr.js: array 8 x 4 x 2")
