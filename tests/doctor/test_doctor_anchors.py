"""The doctor on the peers' tables: it must name each one's conventions as its README gives them.

Truth: ``../shared/anchors/README.md`` (Blender Cycles ``ggx_E``, Adobe OpenPBR
``ideal_metal_energy_complement``, three.js ``dfg_lut16``, the Heitz LTC ``ltc_magnitude``).
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from bsdf_tab.doctor import check_lut

ANCHORS = Path(os.environ.get("BSDF_TAB_ANCHORS", Path(__file__).resolve().parents[3] / "shared" / "anchors"))

pytestmark = pytest.mark.skipif(not ANCHORS.is_dir(), reason=f"no anchors folder at {ANCHORS}")


def _check(rel: str, **kw) -> dict:
    path = ANCHORS / rel
    if not path.is_file():
        pytest.skip(f"{rel} not in the anchors")
    return check_lut(path, **kw).to_dict()


def _axis(r: dict, k: int) -> tuple:
    a = r["axes"][k]
    return a["name"], a["spacing"], a["nodes"], a["reversed"]


def test_cycles_ggx_E():
    """README: [mu, rough], mu_j = clamp(j/31, 1e-4, 1), r = i/31 (alpha = r^2), correlated G2, E with F = 1."""
    r = _check("blender_cycles/ggx_E.npy")
    assert (r["table"], r["distribution"], r["shadowing"]) == ("albedo", "ggx", "correlated")
    assert r["channels"] == {"0": "E"}
    assert _axis(r, 0) == ("mu", "linear", "endpoints", False)
    assert _axis(r, 1) == ("roughness", "linear", "endpoints", False)
    assert r["axes"][0]["clamp"] == pytest.approx(1e-4)
    assert r["encoding"] == "linear"
    assert r["max_error"] < 5e-6  # Cycles prints 6 decimals
    assert any("clamped end" in f for f in r["findings"])


def test_openpbr_ideal_metal_energy_complement():
    """README: [rough, cos], r_i = i/31, cos_j = j/31, 1 - E, separable G1 G1, uint16 UNORM."""
    r = _check("adobe_openpbr_bsdf/ideal_metal_energy_complement.npy")
    assert (r["table"], r["distribution"], r["shadowing"]) == ("albedo_complement", "ggx", "separable")
    assert r["channels"] == {"0": "1-E"}
    assert _axis(r, 0) == ("roughness", "linear", "endpoints", False)
    assert _axis(r, 1) == ("mu", "linear", "endpoints", False)
    assert r["storage"] == "unorm16"
    assert any("stored at 16 bits" in f for f in r["findings"])
    assert r["mean_error"] < 5e-4
    assert r["alternatives"][0]["shadowing"] == "correlated" and r["alternatives"][0]["mean_error"] > 10 * r["mean_error"]


def test_threejs_dfg_lut16():
    """README: rows NoV, columns roughness, both at texel centres; (scale, bias); correlated GGX with
    NDF-sampling noise; RG16F."""
    r = _check("threejs/dfg_lut16.npy")
    assert (r["table"], r["distribution"], r["shadowing"]) == ("dfg", "ggx", "correlated")
    assert r["channels"] == {"0": "A", "1": "B"}
    assert _axis(r, 0) == ("mu", "linear", "centers", False)
    assert _axis(r, 1) == ("roughness", "linear", "centers", False)
    assert r["storage"] == "float16"
    assert any("NDF-sampled noise at grazing angles" in f for f in r["findings"])
    assert 5e-3 < r["max_error"] < 3e-2  # README: max 1.4e-2 against exact quadrature


def test_heitz_ltc_magnitude():
    """README: [t, a], cos(theta_v) = 1 - x^2 with x = t/63, roughness a/63 (alpha = r^2), correlated, F = 1."""
    r = _check("heitz_ltc/ltc_magnitude.npy")
    assert (r["table"], r["distribution"], r["shadowing"]) == ("albedo", "ggx", "correlated")
    assert _axis(r, 0) == ("mu", "sqrt(1-mu)", "endpoints", False)
    assert _axis(r, 1) == ("roughness", "linear", "endpoints", False)
    assert r["mean_error"] < 1e-2
