"""The doctor on 1-D averages and 3-D glass tables: the peers' (named as their READMEs give them)
and our own, corrupted on purpose in each of the ways engines get wrong.

Truth: ``../shared/anchors/README.md`` for the peers; for ours, the spec we baked and the
corruption we applied (axis values written here from the conventions, not from the doctor).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

import bsdf_tab
from bsdf_tab.doctor import check_image, check_lut, srgb_decode
from bsdf_tab.doctor.readers import LutImage

ANCHORS = Path(os.environ.get("BSDF_TAB_ANCHORS", Path(__file__).resolve().parents[3] / "shared" / "anchors"))


def _anchor(rel: str) -> dict:
    path = ANCHORS / rel
    if not path.is_file():
        pytest.skip(f"{rel} not in the anchors ({ANCHORS})")
    return check_lut(path).to_dict()


def _axes(r: dict) -> list:
    return [(a["name"], a["spacing"], a["nodes"], a["reversed"]) for a in r["axes"]]


def _has(r: dict, text: str) -> bool:
    return any(text in f for f in r["findings"])


def _check(data: np.ndarray) -> dict:
    data = np.asarray(data, dtype=np.float64)[..., None]  # one channel
    return check_image(LutImage(data, "npy", [str(i) for i in range(data.shape[-1])])).to_dict()


# ----------------------------------------------------------------------------- the peers' tables

def test_cycles_ggx_eavg():
    """README: ggx_Eavg (32,) [rough] = 2 int E mu dmu, r_i = clamp(i/31, 1e-4, 1), correlated, F = 1."""
    r = _anchor("blender_cycles/ggx_Eavg.npy")
    assert (r["table"], r["quantity"], r["distribution"], r["shadowing"]) == ("albedo_avg", "E_avg", "ggx", "correlated")
    assert _axes(r) == [("roughness", "linear", "endpoints", False)]
    assert r["max_error"] < 2e-6 and r["findings"] == []


def test_openpbr_metal_avg():
    """README: ideal_metal_avg_energy_complement (32,) = 1 - E_avg, r = i/31, separable, uint16."""
    r = _anchor("adobe_openpbr_bsdf/ideal_metal_avg_energy_complement.npy")
    assert (r["table"], r["quantity"], r["shadowing"]) == ("albedo_avg", "1-E_avg", "separable")
    assert _axes(r) == [("roughness", "linear", "endpoints", False)]
    assert r["storage"] == "unorm16" and r["max_error"] < 1e-3


@pytest.mark.parametrize("rel,side", [("blender_cycles/ggx_glass_E.npy", "eta > 1"),
                                      ("blender_cycles/ggx_glass_inv_E.npy", "eta < 1")])
def test_cycles_glass(rel, side):
    """README: (16, 16, 16) [ior, mu, rough]; z_k = clamp(k/15, 1e-4, 0.99), ior = (1 + z^2)/(1 - z^2);
    mu_j = clamp(j/15, 1e-4, 1); R + T, correlated; eta = ior (glass_E) or 1/ior (glass_inv_E)."""
    r = _anchor(rel)
    assert (r["table"], r["quantity"], r["distribution"], r["shadowing"]) == ("dielectric", "R+T", "ggx", "correlated")
    assert r["eta"].startswith(side)
    assert _axes(r) == [("ior", "z-inv" if "inv" in rel else "z", "endpoints", False),
                        ("mu", "linear", "endpoints", False), ("roughness", "linear", "endpoints", False)]
    if "inv" in rel:  # README: biased upward (refracted directions ending above the surface kept)
        assert _has(r, "biased: the values lie above") and r["mean_signed_error"] > 0.01
    else:  # README: agrees with quadrature to about 3e-3, except the ior ~ 1 slice (Cycles stores 1)
        assert r["axes"][1]["clamp"] == pytest.approx(1e-4) and _has(r, "clamped end")
        assert _has(r, "slices node 0 (ior = 1") and r["interior"]["max_error"] < 3e-3


def test_cycles_glass_avg():
    """README: ggx_glass_Eavg (16, 16) [ior, rough], the mu-average of ggx_glass_E."""
    r = _anchor("blender_cycles/ggx_glass_Eavg.npy")
    assert (r["table"], r["quantity"], r["shadowing"]) == ("dielectric_avg", "R+T", "correlated")
    assert r["eta"].startswith("eta > 1")
    assert _axes(r) == [("ior", "z", "endpoints", False), ("roughness", "linear", "endpoints", False)]
    assert r["interior"]["max_error"] < 1e-4


@pytest.mark.parametrize("rel,quantity", [("adobe_openpbr_bsdf/ideal_dielectric_avg_energy_complement.npy", "1-(R+T)"),
                                          ("adobe_openpbr_bsdf/opaque_dielectric_avg_energy_complement.npy", "1-R")])
def test_openpbr_dielectric_avg(rel, quantity):
    """README: (32, 32) [ior, rough], index i < 16: 1/ior = 1 + 1.5 (15 - i)/15, else ior = 1 + 1.5 (i - 16)/15;
    separable; uint16 UNORM; 'ideal' 1 - (R + T), 'opaque' 1 - R (docs/presets.md)."""
    r = _anchor(rel)
    assert (r["table"], r["quantity"], r["shadowing"]) == ("dielectric_avg", quantity, "separable")
    assert _axes(r) == [("ior", "openpbr", "endpoints", False), ("roughness", "linear", "endpoints", False)]
    assert r["axes"][0]["range"] == pytest.approx([0.4, 2.5])
    assert r["storage"] == "unorm16" and r["mean_error"] < 1e-3


def test_openpbr_ideal_dielectric_3d():
    """README: (32, 32, 32) [ior, rough, cos], cos_j = j/31, 1 - (R + T), separable."""
    r = _anchor("adobe_openpbr_bsdf/ideal_dielectric_energy_complement.npy")
    assert (r["table"], r["quantity"], r["shadowing"]) == ("dielectric", "1-(R+T)", "separable")
    assert [a[:3] for a in _axes(r)] == [("ior", "openpbr", "endpoints"), ("roughness", "linear", "endpoints"),
                                         ("mu", "linear", "endpoints")]
    assert r["mean_error"] < 1e-3


# ----------------------------------------------------------------------------- our own, corrupted

N3 = 8


def cycles_like_axes(n: int = N3) -> dict:
    """[ior, mu, roughness] as Cycles: z_k = clamp(k/(n-1), 1e-4, 0.99), ior = (1 + z^2)/(1 - z^2); endpoints."""
    z = np.clip(np.arange(n) / (n - 1), 1e-4, 0.99)
    return {"ior": (1 + z**2) / (1 - z**2), "mu": np.arange(n) / (n - 1), "roughness": np.arange(n) / (n - 1)}


def glass(mu=None, inverse: bool = False, shadowing: str = "correlated") -> np.ndarray:
    """R + T on the Cycles-like axes (explicit spec), as an array [ior, mu, roughness]."""
    ax = cycles_like_axes()
    mu = ax["mu"] if mu is None else mu
    eta = 1.0 / ax["ior"] if inverse else ax["ior"]
    order = np.argsort(eta)
    t = bsdf_tab.tabulate({"table": "dielectric", "distribution": "ggx", "shadowing": shadowing, "tolerance": 1e-6,
                           "axes": {"mu": [float(x) for x in mu], "roughness": [float(x) for x in ax["roughness"]],
                                    "eta": [float(x) for x in eta[order]]}})
    rt = np.asarray(t.channels["R"]) + np.asarray(t.channels["T"])  # [mu, roughness, eta sorted]
    rt = rt[:, :, np.argsort(order)]
    return np.transpose(rt, (2, 0, 1))


@pytest.fixture(scope="module")
def ours3() -> np.ndarray:
    return glass()


def test_our_glass_clean(ours3):
    r = _check(ours3)
    assert (r["table"], r["quantity"], r["shadowing"], r["encoding"]) == ("dielectric", "R+T", "correlated", "linear")
    assert _axes(r) == [("ior", "z", "endpoints", False), ("mu", "linear", "endpoints", False),
                        ("roughness", "linear", "endpoints", False)]
    assert r["max_error"] < 1e-5 and r["findings"] == []


def test_our_glass_eta_below_one():
    r = _check(glass(inverse=True))
    assert r["eta"].startswith("eta < 1") and r["axes"][0]["spacing"] == "z-inv" and r["max_error"] < 1e-5


def test_our_glass_y_flipped(ours3):
    r = _check(ours3[:, ::-1])
    assert _axes(r)[1] == ("mu", "linear", "endpoints", True) and _has(r, "Y flipped")


def test_our_glass_axes_swapped_against_the_files_claim(ours3, tmp_path):
    """A bsdf-tab EXR that says [ior, mu, roughness] but holds [ior, roughness, mu]."""
    ax = cycles_like_axes()
    t = bsdf_tab.Table({"ior": ax["ior"], "mu": ax["mu"], "roughness": ax["roughness"]},
                       {"E": np.ascontiguousarray(np.swapaxes(ours3, 1, 2))}, {})
    path = tmp_path / "swapped.exr"
    t.write(path)
    r = check_lut(path).to_dict()
    assert [a["name"] for a in r["axes"]] == ["ior", "roughness", "mu"] and _has(r, "axes swapped")


def test_our_glass_half_texel_shift():
    n = N3
    mu = np.clip((np.arange(n) + 0.5) / (n - 1), 0, 1)
    r = _check(glass(mu=mu))
    assert r["axes"][1]["nodes"] == "endpoints+0.5" and _has(r, "grid shifted by half a texel along the rows")


def test_our_glass_srgb_decoded_and_8_bit(ours3):
    r = _check(srgb_decode(np.clip(ours3, 0, 1)))
    assert r["encoding"] == "srgb-decoded" and _has(r, "decoded as sRGB") and r["axes"][1]["name"] == "mu"
    r8 = _check(np.round(np.clip(ours3, 0, 1) * 255) / 255)
    assert r8["storage"] == "unorm8" and _has(r8, "stored at 8 bits") and r8["max_error"] <= 0.5 / 255 + 1e-5


def test_our_glass_3d_ktx2(ours3):
    """A 3-D KTX2 from bsdf-tab's writer (float16), read back as a volume."""
    from bsdf_tab.doctor import check_lut_bytes
    from bsdf_tab.io.ktx2 import ktx2_bytes

    ax = cycles_like_axes()
    t = bsdf_tab.Table(dict(ax), {"E": ours3}, {})
    r = check_lut_bytes(ktx2_bytes(t, "float16"), "glass.ktx2").to_dict()
    assert r["shape"] == [N3, N3, N3, 1] and r["table"] == "dielectric" and r["storage"] == "float16"
    assert _axes(r)[0] == ("ior", "z", "endpoints", False)


def albedo_avg(alpha, distribution="ggx", shadowing="correlated") -> np.ndarray:
    uniq, inv = np.unique(np.asarray(alpha, dtype=np.float64), return_inverse=True)  # a clamped end repeats
    t = bsdf_tab.tabulate({"table": "albedo_avg", "distribution": distribution, "shadowing": shadowing,
                           "tolerance": 1e-7, "axes": {"alpha": [float(a) for a in uniq]}})
    return np.asarray(t.channels["E_avg"], dtype=np.float64)[inv]


@pytest.fixture(scope="module")
def ours1() -> np.ndarray:
    return albedo_avg((np.arange(16) / 15) ** 2)


def test_our_eavg_clean_and_corrupted(ours1):
    r = _check(ours1)
    assert (r["table"], r["quantity"]) == ("albedo_avg", "E_avg") and r["findings"] == []
    assert _axes(r) == [("roughness", "linear", "endpoints", False)] and r["max_error"] < 1e-6
    rev = _check(ours1[::-1])
    assert _axes(rev)[0][3] is True and _has(rev, "reversed")
    enc = _check(srgb_decode(ours1))
    assert enc["encoding"] == "srgb-decoded" and _has(enc, "decoded as sRGB")
    q = _check(np.round(ours1 * 255) / 255)
    assert q["storage"] == "unorm8" and _has(q, "stored at 8 bits")
    comp = _check(1.0 - ours1)
    assert comp["quantity"] == "1-E_avg"


def test_our_eavg_alpha_axis_and_shift():
    r = _check(albedo_avg(np.arange(16) / 15))
    assert r["axes"][0]["name"] == "alpha"
    shifted = _check(albedo_avg(np.clip((np.arange(16) + 1.0) / 15, 0, 1) ** 2))
    assert shifted["axes"][0]["nodes"] == "endpoints+1" and _has(shifted, "one texel")


def test_our_eavg_beckmann_separable():
    r = _check(albedo_avg((np.arange(16) / 15) ** 2, "beckmann", "separable"))
    assert (r["distribution"], r["shadowing"]) == ("beckmann", "separable")


def test_our_glass_through_the_cli_json_and_heatmap(ours3, tmp_path, capsys):
    import json

    from bsdf_tab.cli import main as cli_main

    path = tmp_path / "glass.npy"
    np.save(path, ours3[::-1])  # the ior slices reversed
    heat = tmp_path / "heat.png"
    assert cli_main(["check", str(path), "--json", "--heatmap", str(heat)]) == 0
    r = json.loads(capsys.readouterr().out)
    assert r["table"] == "dielectric" and r["axes"][0]["reversed"] is True and _has(r, "Z flipped")
    assert heat.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_our_glass_average_transposed_and_flipped():
    """R_avg + T_avg [ior, roughness] (Cycles-like z axis, 6 x 6), stored as [roughness, ior] with
    the roughness running high to low: the kind, the side, the order and the flip are named."""
    z = np.clip(np.arange(6) / 5, 1e-4, 0.99)
    ior = (1 + z**2) / (1 - z**2)
    r = np.arange(6) / 5
    t = bsdf_tab.tabulate({"table": "dielectric_avg", "shadowing": "correlated", "tolerance": 1e-6,
                           "axes": {"roughness": [float(x) for x in r], "eta": [float(x) for x in ior]}})
    avg = np.asarray(t.channels["R_avg"]) + np.asarray(t.channels["T_avg"])  # [roughness, eta]
    rep = _check(avg[::-1])
    assert (rep["table"], rep["quantity"], rep["shadowing"]) == ("dielectric_avg", "R+T", "correlated")
    assert rep["eta"].startswith("eta > 1")
    assert _axes(rep) == [("roughness", "linear", "endpoints", True), ("ior", "z", "endpoints", False)]
    assert _has(rep, "Y flipped") and rep["max_error"] < 2e-4


@pytest.mark.parametrize("shape", [(24, 24), (8, 8, 8)])
def test_a_table_of_no_known_kind_gets_no_guessed_findings(shape):
    """A smooth table that is no albedo, split-sum or glass table: the report says so and does not
    describe the closest candidate's flips, shifts, encoding or noise as the file's."""
    grids = np.meshgrid(*[np.linspace(0, 1, n) for n in shape], indexing="ij")
    data = 0.5 + 0.4 * np.sin(3 * grids[0] + 1) * np.cos(5 * grids[-1])
    r = _check(data)
    assert r["findings"][0].startswith("no candidate fits well")
    assert all(f.startswith(("no candidate fits well", "left out: ")) for f in r["findings"])
