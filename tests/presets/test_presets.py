"""Engine presets: axes, axis order and value conventions of each peer, and the CLI.

Axis values are written here from the peers' published formulas (the anchors README), not
taken from the preset code; preset texels are checked against the independent float64
reference (tests/reference) with the peer's transformation written here (so the sums,
complements, transposes, reversed eta and the duplicated OpenPBR ior = 1 are right, and the
values too), and, where the anchors are present, against the peers' own tables.
"""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path

import numpy as np
import pytest

from bsdf_tab import cli
from bsdf_tab.presets import GROUPS, PRESETS, build_preset, expand_preset, get_preset
from tests.reference import microfacet_ref as ref

ANCHORS = Path(os.environ.get("BSDF_TAB_ANCHORS") or Path(__file__).resolve().parents[3] / "shared" / "anchors")


def anchor(rel: str) -> np.ndarray:
    path = ANCHORS / rel
    if not path.exists():
        pytest.skip(f"anchor {rel} not present")
    return np.load(path)


def ch(table, name):
    return np.asarray(table.channels[name], dtype=np.float64)


# --------------------------------------------------------------------------- axes


def cycles_expected(n):
    return np.array([min(max(i / (n - 1), 1e-4), 1.0) for i in range(n)])


def cycles_ior_expected():
    z = [min(max(k / 15, 1e-4), 0.99) for k in range(16)]
    return np.array([(1 + x * x) / (1 - x * x) for x in z])


OPENPBR_IOR = np.array([1 / (1 + 1.5 * (15 - i) / 15) for i in range(16)] + [1 + 0.1 * k for k in range(16)])

EXPECTED_AXES = {
    "cycles-ggx-E": {"mu": cycles_expected(32), "roughness": cycles_expected(32)},
    "cycles-ggx-Eavg": {"roughness": cycles_expected(32)},
    "cycles-ggx-glass-E": {"ior": cycles_ior_expected(), "mu": cycles_expected(16), "roughness": cycles_expected(16)},
    "cycles-ggx-glass-inv-E": {"ior": cycles_ior_expected(), "mu": cycles_expected(16), "roughness": cycles_expected(16)},
    "cycles-ggx-glass-Eavg": {"ior": cycles_ior_expected(), "roughness": cycles_expected(16)},
    "cycles-ggx-glass-inv-Eavg": {"ior": cycles_ior_expected(), "roughness": cycles_expected(16)},
    "openpbr-ideal-metal": {"roughness": np.arange(32) / 31, "cos": np.arange(32) / 31},
    "openpbr-ideal-metal-avg": {"roughness": np.arange(32) / 31},
    "openpbr-ideal-dielectric": {"ior": OPENPBR_IOR, "roughness": np.arange(32) / 31, "cos": np.arange(32) / 31},
    "openpbr-ideal-dielectric-avg": {"ior": OPENPBR_IOR, "roughness": np.arange(32) / 31},
    "openpbr-opaque-dielectric": {"ior": OPENPBR_IOR, "roughness": np.arange(32) / 31, "cos": np.arange(32) / 31},
    "openpbr-opaque-dielectric-avg": {"ior": OPENPBR_IOR, "roughness": np.arange(32) / 31},
    "filament-dfg": {"roughness": (np.arange(128) + 0.5) / 128, "mu": (np.arange(128) + 0.5) / 128},
    "filament-dfg-multiscatter": {"roughness": (np.arange(128) + 0.5) / 128, "mu": (np.arange(128) + 0.5) / 128},
    "unity-hdrp-fgd": {"roughness": np.arange(64) / 63, "mu": (np.arange(64) / 63) ** 2},
}
# the Heitz LTC layouts (anchors README): x = t/63 with cos theta = 1 - x^2 (theta clamped to 1.57 in
# the shipped table), roughness r = a/63 with alpha = max(r^2, 1e-5)
_X = np.arange(64) / 63
_LTC_ALPHA = np.maximum(_X**2, 1e-5)
LTC_AXES = {
    "heitz-ltc": {"mu": np.cos(np.minimum(1.57, np.arccos(1 - _X**2))), "alpha": _LTC_ALPHA},
    "heitz-ltc-rgba": {"mu": 1 - _X**2, "alpha": _LTC_ALPHA},
}


@pytest.mark.parametrize("name", sorted(LTC_AXES))
def test_ltc_preset_axes(name):
    axes = get_preset(name).axes()
    assert list(axes) == list(LTC_AXES[name])
    for axis, values in LTC_AXES[name].items():
        np.testing.assert_allclose(axes[axis], values, rtol=1e-12, atol=1e-15)


#: the kind's own spec keys each preset must bake with (docs/ltc.md, docs/sheen.md)
KIND_OPTIONS = {"heitz-ltc": {"amplitude": "shading"}, "heitz-ltc-rgba": {"amplitude": "shading"},
                "filament-dfg-cloth": {"sheen_shadowing": "ashikhmin"},
                "gltf-charlie-lut": {"sheen_shadowing": "ashikhmin"},
                "khr-sheen-E-fitted": {"sheen_shadowing": "fitted"}}


@pytest.mark.parametrize("name", sorted(KIND_OPTIONS))
def test_kind_options_reach_the_normalized_spec(name):
    from bsdf_tab.spec import normalize_spec

    preset = get_preset(name)
    spec = preset.spec(preset.axes())
    spec["axes"] = {axis: sorted(np.asarray(values).tolist()) for axis, values in spec["axes"].items()}  # as build_preset sorts them
    spec = normalize_spec(spec)
    for key, value in KIND_OPTIONS[name].items():
        assert spec[key] == value, (name, key)


def test_every_preset_has_expected_axes():
    from tests.presets.test_engine_presets import ENGINE_AXES  # the issue-15 engines, from their sources

    from tests.sheen.test_sheen_presets import SHEEN_AXES  # the sheen presets, from their sources

    assert set(EXPECTED_AXES) | set(ENGINE_AXES) | set(LTC_AXES) | set(SHEEN_AXES) == set(PRESETS)


@pytest.mark.parametrize("name", sorted(EXPECTED_AXES))
def test_axes_values_and_order(name):
    axes = get_preset(name).axes()
    expected = EXPECTED_AXES[name]
    assert list(axes) == list(expected)  # the peer's axis order
    for axis, values in expected.items():
        np.testing.assert_allclose(axes[axis], values, rtol=1e-12, atol=0)


def test_known_axis_values():
    ior = get_preset("cycles-ggx-glass-E").axes()["ior"]
    assert ior[0] == pytest.approx(1.00000002, rel=1e-9) and ior[-1] == pytest.approx(99.50251256281392, rel=1e-12)
    pbr = get_preset("openpbr-ideal-dielectric").axes()["ior"]
    assert pbr[0] == pytest.approx(0.4) and pbr[15] == pbr[16] == 1.0 and pbr[-1] == pytest.approx(2.5)


@pytest.mark.parametrize("name", [n for n in sorted(PRESETS) if PRESETS[n].anchor_axes])
def test_axes_match_anchor_axis_files(name):
    preset = get_preset(name)
    axes = preset.axes()
    for axis, rel in preset.anchor_axes.items():
        np.testing.assert_allclose(axes[axis], anchor(rel), rtol=1e-12, atol=1e-15)
    if preset.anchor:
        assert anchor(preset.anchor).shape == preset.shape


def test_groups_and_unknown_preset():
    assert expand_preset("filament") == ["filament-dfg", "filament-dfg-multiscatter"]
    assert set(sum(GROUPS.values(), [])) == set(PRESETS)
    with pytest.raises(ValueError, match="unknown preset 'nope'"):
        get_preset("nope")


# --------------------------------------------------------------------------- values vs the float64 reference
# Each preset texel is checked against the independent reference (tests/reference: two float64
# quadratures), with the peer's transformation written here from its documented convention:
# this checks the axis order, the sums, complements and reversed eta, and the values at once.

TOL = 1e-6  # the default tolerance's promise, with room for the reference's own error


def ref_albedo(mu, r, shadowing):
    return ref.albedo(mu, r * r, "ggx", shadowing).value


def ref_rt(mu, r, eta, shadowing):
    R, T = ref.dielectric(mu, r * r, eta, "ggx", shadowing)
    return R.value, T.value


def test_cycles_E_is_correlated_albedo_with_mirror_rule():
    sel = {"mu": [0, 9, 31], "roughness": [0, 12, 31]}
    t = build_preset("cycles-ggx-E", select=sel)
    mu = [1e-4, 9 / 31, 1.0]
    e = ch(t, "E")
    assert e.shape == (3, 3)
    np.testing.assert_array_equal(e[:, 0], 1.0)  # alpha = 1e-8: alpha^2 <= 5e-7, a perfect mirror
    assert e[1, 1] == pytest.approx(min(1.0, ref_albedo(mu[1], 12 / 31, "correlated")), abs=TOL)
    assert e[2, 2] == pytest.approx(1 - np.log(2), abs=TOL)  # closed form E(mu = 1, alpha = 1)
    assert ch(t, "E_err")[0, 0] >= 0.0
    assert t.meta["preset"]["conventions"]["shadowing"].startswith("height-correlated")


def test_cycles_glass_inv_order_and_sum():
    sel = {"ior": [1, 8, 14], "mu": [2, 15], "roughness": [10]}
    t = build_preset("cycles-ggx-glass-inv-E", select=sel)
    ior = cycles_ior_expected()[[1, 8, 14]]
    mu, rough = [2 / 15, 1.0], 10 / 15
    e = ch(t, "E")
    assert e.shape == (3, 2, 1)  # [ior, mu, roughness]
    for k, j in [(0, 0), (2, 0), (1, 1)]:
        R, T = ref_rt(mu[j], rough, 1.0 / ior[k], "correlated")  # eta = 1 / ior: light from inside
        assert e[k, j, 0] == pytest.approx(min(1.0, R + T), abs=2 * TOL)
    assert (ch(t, "E_err") > 0).all()
    assert "1 / ior" in t.meta["preset"]["conventions"]["eta"]


def test_cycles_glass_last_ior_is_computed():
    # ior = 99.5 (z = 0.99), Cycles' last IOR node
    t = build_preset("cycles-ggx-glass-E", select={"ior": [15], "mu": [15], "roughness": [0, 1]})
    e = ch(t, "E")
    assert np.isfinite(e).all()
    assert e[0, 0, 0] == 1.0  # mirror rule
    assert e[0, 0, 1] == pytest.approx(1.0, abs=2e-3)  # energy form: R + T -> 1 as alpha -> 0


def test_openpbr_dielectric_complement_order_and_duplicate_ior():
    sel = {"ior": [3, 15, 16, 25], "roughness": [20], "cos": [7, 31]}
    t = build_preset("openpbr-ideal-dielectric", select=sel)
    o = build_preset("openpbr-opaque-dielectric", select=sel)
    c = ch(t, "energy_complement")
    assert c.shape == (4, 1, 2)  # [ior, roughness, cos]
    for k, j, eta in [(0, 0, 1 / (1 + 1.5 * 12 / 15)), (3, 1, 1.9)]:
        R, T = ref_rt([7 / 31, 1.0][j], 20 / 31, eta, "separable")
        assert c[k, 0, j] == pytest.approx(1.0 - (R + T), abs=2 * TOL)
        assert ch(o, "energy_complement")[k, 0, j] == pytest.approx(1.0 - R, abs=TOL)
    np.testing.assert_array_equal(c[1], c[2])  # ior = 1 twice
    assert c[1, 0, 1] == pytest.approx(0.0, abs=TOL)  # eta = 1: no interface, R + T = 1
    assert "separable" in t.meta["preset"]["conventions"]["shadowing"]


def test_openpbr_metal_is_one_minus_separable_albedo():
    t = build_preset("openpbr-ideal-metal", select={"roughness": [8, 31], "cos": [10, 31]})
    c = ch(t, "energy_complement")
    assert c.shape == (2, 2)  # [roughness, cos]
    assert c[0, 0] == pytest.approx(1.0 - ref_albedo(10 / 31, 8 / 31, "separable"), abs=TOL)
    assert c[1, 1] == pytest.approx(np.log(2), abs=TOL)  # 1 - (1 - ln 2)


@pytest.mark.parametrize("name,mu", [("filament-dfg-multiscatter", 100.5 / 128), ("unity-hdrp-fgd", (40 / 63) ** 2)])
def test_dfg_packing_b_e(name, mu):
    col = 40 if name.startswith("unity") else 100
    sel = {"roughness": [3, 50], "mu": [0, col]}
    t = build_preset(name, select=sel)
    r = get_preset(name).axes()["roughness"][50]
    assert list(t.axes) == ["roughness", "mu"]
    A, B = ref.dfg(mu, r * r, "ggx", "correlated")
    assert ch(t, "B")[1, 1] == pytest.approx(B.value, abs=TOL)
    assert ch(t, "E")[1, 1] == pytest.approx(A.value + B.value, abs=2 * TOL)


def test_filament_single_scatter_a_b():
    t = build_preset("filament-dfg", select={"roughness": [127], "mu": [127]})
    r = 127.5 / 128
    A, B = ref.dfg(127.5 / 128, r * r, "ggx", "correlated")
    assert ch(t, "A")[0, 0] == pytest.approx(A.value, abs=TOL)
    assert ch(t, "B")[0, 0] == pytest.approx(B.value, abs=TOL)


def test_average_presets():
    t = build_preset("openpbr-ideal-dielectric-avg", select={"ior": [5, 28], "roughness": [31]})
    R, T = ref.dielectric_avg(1.0, 2.2, "ggx", "separable")  # ior index 28: 1 + 1.5 * 12/15 = 2.2
    c = ch(t, "energy_complement")
    assert c.shape == (2, 1)  # [ior, roughness]
    assert c[1, 0] == pytest.approx(1.0 - (R.value + T.value), abs=2 * TOL + R.err + T.err)
    m = build_preset("openpbr-ideal-metal-avg", select={"roughness": [31]})
    # separable, F = 1, alpha = 1: E runs from 2 - 2 ln 2 (mu -> 0) to 1 - ln 2 (mu = 1), so
    # 1 - E_avg lies between 2 ln 2 - 1 and ln 2
    assert 2 * np.log(2) - 1 < ch(m, "energy_complement")[0] < np.log(2)


# --------------------------------------------------------------------------- against the peers' own tables


def test_cycles_E_matches_cycles_table():
    theirs = anchor("blender_cycles/ggx_E.npy")
    sel = {"mu": [0, 5, 20, 31], "roughness": [0, 3, 16, 31]}
    ours = ch(build_preset("cycles-ggx-E", select=sel), "E")
    np.testing.assert_allclose(ours, theirs[np.ix_(sel["mu"], sel["roughness"])], atol=2e-5)


def test_openpbr_dielectric_matches_openpbr_table_in_interior():
    theirs = anchor("adobe_openpbr_bsdf/ideal_dielectric_energy_complement.npy")
    sel = {"ior": [5, 20, 28], "roughness": [20, 31], "cos": [3, 16, 31]}
    ours = ch(build_preset("openpbr-ideal-dielectric", select=sel), "energy_complement")
    np.testing.assert_allclose(ours, theirs[np.ix_(sel["ior"], sel["roughness"], sel["cos"])], atol=2e-3)


def test_cycles_glass_matches_cycles_table():
    theirs = anchor("blender_cycles/ggx_glass_E.npy")
    sel = {"ior": [7, 15], "mu": [5, 15], "roughness": [5, 15]}
    ours = ch(build_preset("cycles-ggx-glass-E", select=sel), "E")
    np.testing.assert_allclose(ours, theirs[np.ix_(sel["ior"], sel["mu"], sel["roughness"])], atol=4e-3)


# --------------------------------------------------------------------------- CLI


def run(capsys, *argv):
    code = cli.main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_cli_presets_lists_all(capsys):
    code, out, err = run(capsys, "presets")
    assert code == 0
    for name in list(PRESETS) + list(GROUPS):
        assert name in out


@pytest.mark.parametrize("argv,fragment", [
    (["bake", "--preset", "nope"], "unknown preset 'nope'"),
    (["bake", "--format", "npy"], "--format applies to a spec file or --preset"),
    (["bake", "spec.json", "--preset", "cycles-ggx-E"], "either a spec file or --preset"),
])
def test_cli_preset_errors_one_line_exit_2(capsys, tmp_path, argv, fragment):
    code, out, err = run(capsys, *argv, "-o", str(tmp_path / "o"))
    assert code == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("bsdf-tab: error: ") and fragment in lines[0]
    assert "Traceback" not in err


def test_cli_bad_format_is_usage_error(capsys):
    code, out, err = run(capsys, "bake", "--preset", "cycles-ggx-E", "--format", "tiff")
    assert code == 2


@pytest.fixture
def small_presets(monkeypatch):
    """Shrink two presets to a few texels so the CLI bakes them in well under a second."""
    small = {
        "cycles-ggx-Eavg": lambda: {"roughness": np.array([1e-4, 0.5, 1.0])},
        "openpbr-ideal-metal": lambda: {"roughness": np.array([0.0, 1.0]), "cos": np.array([0.5, 1.0])},
    }
    for name, axes in small.items():
        monkeypatch.setitem(PRESETS, name, dataclasses.replace(PRESETS[name], axes=axes))


@pytest.mark.parametrize("fmt,suffix", [("exr", ".exr"), ("half-exr", ".half.exr"), ("npy", ".npy"), ("npy-channels", ".meta.json"),
                                        ("h", ".h")])
def test_cli_bake_preset_formats(capsys, tmp_path, small_presets, fmt, suffix):
    code, out, err = run(capsys, "bake", "--preset", "openpbr-ideal-metal", "-o", str(tmp_path), "--format", fmt, "-q")
    assert code == 0, err
    path = tmp_path / f"openpbr_ideal_metal{suffix}"
    assert path.exists()
    assert str(path) in out
    if fmt == "exr":
        from bsdf_tab import read_exr

        t = read_exr(path)
        assert list(t.axes) == ["roughness", "cos"]
        assert t.meta["preset"]["name"] == "openpbr-ideal-metal"
        assert t.channels["energy_complement"][1, 1] == pytest.approx(np.log(2), abs=2e-6)


def test_cli_bake_preset_default_format_exr(capsys, tmp_path, small_presets):
    code, out, err = run(capsys, "bake", "--preset", "cycles-ggx-Eavg", "-o", str(tmp_path), "-q")
    assert code == 0, err
    assert (tmp_path / "cycles_ggx_Eavg.exr").exists()
