"""The benchmarks' shared pieces (bench/common.py) against independent truths: the Pareto front
and the pooling on hand-made points, the distribution / shadowing selectors through one
integrator run judged by the reference (a swapped selector would miss it by far more than the
tolerance), and the layering: the installed package never imports ``bench`` or ``tests``."""

from __future__ import annotations

import ast
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from bench.common import CASES, Case, aggregate, pareto, parse_variants, reference_values, run_method

ROOT = Path(__file__).resolve().parents[2]


def test_pareto_and_aggregate():
    assert pareto([(1.0, 1e-2), (2.0, 1e-3), (3.0, 1e-2), (0.5, 1.0)]) == [3, 0, 1]
    rows = [{"method": "m", "effort": 1, "case": c, "time_s": 1.0, "n_texels": 10, "evals_per_texel": 4.0,
             "max_abs_err": x, "mean_abs_err": x / 10, "honesty": h, "n_dishonest": d, "invalid_values": False}
            for c, x, h, d in (("a", 1e-3, 1.0, 0), ("b", 1e-2, 0.5, 5))]
    (s,) = aggregate(rows)
    assert s["label"] == "m@1" and s["max_abs_err"] == 1e-2 and s["mean_abs_err"] == pytest.approx(5.5e-4)
    assert s["time_per_1k_texels_s"] == pytest.approx(100.0)
    assert s["honesty"] == pytest.approx(0.75) and s["n_dishonest"] == 5


@pytest.mark.parametrize("case", [c for c in CASES if c.mode == "reflect"] + [CASES[4]], ids=lambda c: c.name)
def test_selectors_through_the_adaptive_method(case: Case):
    """Spec names -> integrator selectors: ``adaptive`` at 1e-7 matches the reference at
    texels where GGX and Beckmann, separable and correlated differ by > 1e-3."""
    mu, alpha = np.array([0.3, 0.9]), np.array([0.5, 0.8])
    eta = np.full(2, case.eta or 1.0)
    v, e, evals = run_method("adaptive", 1e-7, case, mu, alpha, eta, workers=1, device="cpu")
    rv, re = reference_values(case, mu, alpha)
    nch = len(case.channels)
    assert evals > 0
    np.testing.assert_allclose(v[:, :nch], rv[:, :nch], rtol=0, atol=1e-6)
    other = Case("other", case.mode, "beckmann" if case.dist == "ggx" else "ggx", case.shadowing, case.eta)
    assert np.abs(reference_values(other, mu, alpha)[0][:, :nch] - rv[:, :nch]).max() > 1e-3


def test_reference_values_are_cached(tmp_path):
    case = CASES[0]
    first = reference_values(case, [0.5], [0.3], cache_dir=tmp_path)
    (cached,) = tmp_path.glob("reference_*.npz")
    assert cached.is_file()
    second = reference_values(case, [0.5], [0.3], cache_dir=tmp_path)
    np.testing.assert_array_equal(first[0], second[0])


def _imports(path: Path) -> set[str]:
    names = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            names.update(a.name.split(".")[0] for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names.add(node.module.split(".")[0])
    return names


def test_the_package_never_imports_bench_or_tests():
    for path in (ROOT / "bsdf_tab").rglob("*.py"):
        assert not _imports(path) & {"bench", "tests"}, path
    assert not (ROOT / "bsdf_tab" / "benchmarks").exists()


def test_importing_the_package_loads_no_checkout_module(tmp_path):
    code = ("import sys, bsdf_tab, bsdf_tab.cli; "
            "print(sorted(m for m in sys.modules if m.split('.')[0] in ('bench', 'tests')))")
    env = {**os.environ, "PYTHONPATH": str(ROOT)}  # this checkout: bench/ and tests/ importable, yet never imported
    out = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=env, capture_output=True, text=True,
                         check=True)
    assert out.stdout.strip() == "[]"
    assert not any(tmp_path.iterdir())


def test_parse_variants_types_and_errors():
    got = parse_variants(["inner_share=0.5,max_rules_outer=300", "shared_error=false,outer_first=0", "x=TRUE,y=-2"])
    assert got == [{"inner_share": 0.5, "max_rules_outer": 300}, {"shared_error": False, "outer_first": 0},
                   {"x": True, "y": -2}]
    assert type(got[0]["max_rules_outer"]) is int and type(got[1]["shared_error"]) is bool
    for bad in ("inner_share", "=3", "a=b"):
        with pytest.raises(ValueError):
            parse_variants([bad])
