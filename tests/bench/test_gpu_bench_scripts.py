"""The GPU tooling in bench/ on a machine without a GPU: clear errors, the comparison of two runs'
values, and a kernel cache laid out where Warp's loader looks for it."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize(
    "argv",
    [["--block-dims", "0"], ["--block-dims", "x"], ["--chunks", "0"], ["--orders", "random"], ["--reps", "0"],
     ["--device", "cuda:97"]],
)
def test_gpu_launch_rejects_bad_arguments(argv, capsys):
    from bench import gpu_launch

    with pytest.raises(SystemExit) as info:
        gpu_launch.main(argv)
    assert info.value.code == 2
    assert "error:" in capsys.readouterr().err


@pytest.mark.parametrize(
    "argv",
    [["--device", "cuda:97", "--no-numpy"], ["--save-values", "x.npz"], ["--no-numpy", "--no-cost", "--save-values", "x.npz"],
     ["--no-numpy", "--compare-values", "/nonexistent/values.npz"]],
)
def test_core_rejects_bad_arguments(argv, capsys):
    from bench import core

    with pytest.raises(SystemExit) as info:
        core.main(argv)
    assert info.value.code == 2
    assert "error:" in capsys.readouterr().err


@pytest.mark.parametrize("script", ["core", "gpu_launch", "eval_cost", "accuracy_honesty"])
def test_an_unavailable_device_is_one_line_naming_the_option(script, capsys):
    import importlib

    mod = importlib.import_module(f"bench.{script}")
    with pytest.raises(SystemExit) as info:
        mod.main(["--device", "cuda:97"])
    assert info.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert "error: --device:" in err[-1] and "cuda:97" in err[-1]


def test_compare_values_counts_agreement_and_honesty():
    from bench.core import compare_values

    v = np.array([[0.5, 0.25], [0.1, 0.0], [0.3, 0.7]])
    err = np.full((3, 2), 1e-9)
    evals = np.array([100, 200, 300])
    ref = {"c/v": v.copy(), "c/err": err.copy(), "c/evals": evals.copy()}
    same = compare_values("c", {"v": v, "err": err, "evals": evals}, ref)
    assert same["max_abs_diff"] == 0.0 and same["texels_bit_identical"] == 1.0
    assert same["within_both_errors"] == 1.0 and same["texels_same_evals"] == 1.0
    moved = v.copy()
    moved[1, 0] += 1.5e-9  # within the two errors (2e-9)
    moved[2, 1] += 3e-9  # beyond them
    out = compare_values("c", {"v": moved, "err": err, "evals": evals + np.array([0, 0, 1])}, ref)
    assert out["max_abs_diff"] == pytest.approx(3e-9)
    assert out["texels_bit_identical"] == pytest.approx(1 / 3)
    assert out["within_both_errors"] == pytest.approx(2 / 3)
    assert out["texels_same_evals"] == pytest.approx(2 / 3)


def _prebuild(tmp_path, *args, env_cache=True):
    env = dict(os.environ)
    env.pop("WARP_CACHE_PATH", None)
    if env_cache:
        env["WARP_CACHE_PATH"] = str(tmp_path)
    return subprocess.run([sys.executable, str(ROOT / "bench" / "cuda_prebuild.py"), *args], cwd=ROOT, env=env,
                          capture_output=True, text=True, timeout=300)


def test_cuda_prebuild_needs_a_cache_path_and_known_modules(tmp_path):
    r = _prebuild(tmp_path, env_cache=False)
    assert r.returncode == 2 and "WARP_CACHE_PATH" in r.stderr
    r = _prebuild(tmp_path, "--modules", "bsdf_tab.nope")
    assert r.returncode == 2 and "bsdf_tab.nope" in r.stderr
    r = _prebuild(tmp_path, "--block-dims", "2000")
    assert r.returncode == 2 and "--block-dims" in r.stderr


def test_cuda_prebuild_writes_where_the_loader_looks(tmp_path):
    """The entry for each block size sits under the module identifier that Warp's loader computes
    for a launch of that block size (one small module; PTX for sm_90, as a GPU run would load it)."""
    module = "bsdf_tab.ltc.kernels"
    r = _prebuild(tmp_path, "--modules", module, "--format", "ptx", "--block-dims", "32,256", "-j", "1")
    assert r.returncode == 0, r.stdout + r.stderr
    ids = subprocess.run(
        [sys.executable, "-c",
         "import importlib, warp as wp; wp.config.quiet = True; importlib.import_module('%s'); "
         "m = wp.get_module('%s'); print(m.get_module_identifier(block_dim=32), m.get_module_identifier(block_dim=256))"
         % (module, module)],
        cwd=ROOT, capture_output=True, text=True, timeout=120,
    ).stdout.split()
    assert len(ids) == 2 and ids[0] != ids[1]
    for ident in ids:
        found = list(tmp_path.rglob(f"{ident}/*.sm90.ptx"))
        assert found, (ident, sorted(str(p.relative_to(tmp_path)) for p in tmp_path.rglob("*")))
