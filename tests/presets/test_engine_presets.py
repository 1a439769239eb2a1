"""The engine presets of issue 15 (EEVEE, glTF Sample Viewer, Godot, Bevy, three.js, Unreal).

Axis values are written here from the engines' sources (cited in docs/presets.md), not taken
from the preset code; texels on small subsets are checked against the independent float64
reference (tests/reference) with each engine's packing written here; three.js against its
shipped table (the anchors), Bevy against its shipped analytic fit F_AB (its coefficients).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from bsdf_tab.presets import GROUPS, PRESETS, build_preset, get_preset
from tests.reference import microfacet_ref as ref

ANCHORS = Path(os.environ.get("BSDF_TAB_ANCHORS") or Path(__file__).resolve().parents[3] / "shared" / "anchors")
TOL = 1e-6


def centres(n):
    return (np.arange(n) + 0.5) / n


def endpoints(n):
    return np.arange(n) / (n - 1)


def eevee_nv(n):
    # eevee_lut_comp.glsl: NV = clamp(1 - y^2, 1e-4, 0.9999), y = j / (n - 1)
    return np.array([min(max(1.0 - (j / (n - 1)) ** 2, 1e-4), 0.9999) for j in range(n)])


def eevee_ior(n):
    # ggx_btdf_gt_one: f = clamp(x^2, 1e-4, 0.9999), ior = (1 + f) / (1 - f); the spec's eta ends at 100
    out = []
    for i in range(n):
        f = min(max((i / (n - 1)) ** 2, 1e-4), 0.9999)
        out.append(min((1 + f) / (1 - f), 100.0))
    return np.array(out)


#: preset -> axes in the engine's order, from its source
ENGINE_AXES = {
    "eevee-brdf-split-sum": {"mu": eevee_nv(64), "roughness": endpoints(64)},
    "eevee-btdf": {"roughness": endpoints(16), "mu": eevee_nv(64), "ior": eevee_ior(64)},
    "gltf-ggx-lut": {"roughness": centres(1024), "mu": centres(1024)},
    "godot-dfg": {"roughness": np.array([(127 - k + 0.5) / 128 for k in range(128)]), "mu": centres(128)},
    "bevy-dfg": {"roughness": centres(64), "mu": centres(64)},
    "threejs-dfg": {"mu": centres(16), "roughness": centres(16)},
    "unreal-envbrdf": {"roughness": centres(32), "mu": centres(128)},
}

ENGINE_FILES = {  # preset -> (file format, storage) the engine uses
    "eevee-brdf-split-sum": ("ktx2", "float16"),
    "eevee-btdf": ("ktx2", "float16"),
    "gltf-ggx-lut": ("png", "unorm16"),
    "godot-dfg": ("ktx2", "float16"),
    "bevy-dfg": ("ktx2", "float16"),
    "threejs-dfg": ("ktx2", "float16"),
    "unreal-envbrdf": ("dds", "unorm16"),
}


def ch(table, name):
    return np.asarray(table.channels[name], dtype=np.float64)


@pytest.mark.parametrize("name", sorted(ENGINE_AXES))
def test_engine_axes_order_and_files(name):
    preset = get_preset(name)
    axes = preset.axes()
    assert list(axes) == list(ENGINE_AXES[name])
    for axis, values in ENGINE_AXES[name].items():
        np.testing.assert_allclose(axes[axis], values, rtol=1e-12, atol=0)
    assert (preset.file_format, preset.storage) == ENGINE_FILES[name]
    assert name.split("-")[0] in GROUPS and name in GROUPS[name.split("-")[0]]


def test_every_new_engine_is_registered():
    for engine in ("eevee", "gltf", "godot", "bevy", "threejs", "unreal"):
        assert GROUPS[engine] and all(n in PRESETS for n in GROUPS[engine])


def test_eevee_split_sum_is_separable_a_b_on_its_sqrt_axis():
    t = build_preset("eevee-brdf-split-sum", select={"mu": [20, 45], "roughness": [40]})
    r = 40 / 63
    assert list(t.axes) == ["mu", "roughness"]
    for k, j in enumerate([20, 45]):
        nv = min(max(1 - (j / 63) ** 2, 1e-4), 0.9999)
        A, B = ref.dfg(nv, r * r, "ggx", "separable")
        assert ch(t, "A")[k, 0] == pytest.approx(A.value, abs=TOL)
        assert ch(t, "B")[k, 0] == pytest.approx(B.value, abs=TOL)


def test_eevee_btdf_times_one_minus_f0_is_exact_transmission_layers_first():
    # EEVEE's shader (bsdf_lut): transmittance = (1 - F0) * texel, F0 = ((ior - 1)/(ior + 1))^2
    t = build_preset("eevee-btdf", select={"roughness": [10], "mu": [5], "ior": [20, 63]})
    assert ch(t, "T").shape == (1, 1, 2)  # [roughness, mu, ior]
    r, nv = 10 / 15, 1 - (5 / 63) ** 2
    f = (20 / 63) ** 2
    ior = (1 + f) / (1 - f)
    _, T = ref.dielectric(nv, r * r, ior, "ggx", "separable")
    one_minus_f0 = 1 - ((ior - 1) / (ior + 1)) ** 2
    assert ch(t, "T")[0, 0, 0] * one_minus_f0 == pytest.approx(T.value, abs=2 * TOL)
    assert ch(t, "T_err")[0, 0, 0] * one_minus_f0 <= 2 * TOL  # the error channel follows the scale
    _, T100 = ref.dielectric(nv, r * r, 100.0, "ggx", "separable")
    assert ch(t, "T")[0, 0, 1] * (1 - (99 / 101) ** 2) == pytest.approx(T100.value, abs=2 * TOL)
    assert t.axes["ior"][1] == 100.0 and "ior = 100" in t.meta["preset"]["conventions"]["ior_axis"]


def test_godot_rows_are_flipped_and_pack_b_e_separable():
    t = build_preset("godot-dfg", select={"roughness": [0, 100], "mu": [64]})
    nv = 64.5 / 128
    for k, r in [(0, 127.5 / 128), (1, 27.5 / 128)]:  # row 0 holds the roughest texel
        A, B = ref.dfg(nv, r * r, "ggx", "separable")
        assert ch(t, "B")[k, 0] == pytest.approx(B.value, abs=TOL)
        assert ch(t, "E")[k, 0] == pytest.approx(A.value + B.value, abs=2 * TOL)


@pytest.mark.parametrize("name", ["gltf-ggx-lut", "unreal-envbrdf", "bevy-dfg"])
def test_roughness_rows_nov_columns_correlated(name):
    axes = ENGINE_AXES[name]
    i, j = len(axes["roughness"]) // 3, len(axes["mu"]) - 2
    t = build_preset(name, select={"roughness": [i], "mu": [j]})
    r, nv = axes["roughness"][i], axes["mu"][j]
    A, B = ref.dfg(nv, r * r, "ggx", "correlated")
    assert ch(t, "A")[0, 0] == pytest.approx(A.value, abs=TOL)
    assert ch(t, "B")[0, 0] == pytest.approx(B.value, abs=TOL)


def test_threejs_against_its_shipped_table():
    path = ANCHORS / "threejs" / "dfg_lut16.npy"
    if not path.exists():
        pytest.skip("anchor threejs/dfg_lut16.npy not present")
    theirs = np.load(path)  # (16, 16, 2) [NoV, roughness, (scale, bias)], decoded RG16F
    t = build_preset("threejs-dfg")
    ours = np.stack([ch(t, "A"), ch(t, "B")], axis=-1)
    diff = np.abs(ours - theirs)
    # the anchors README: max 1.4e-2 (scale) / 7e-4 (bias), mean 8e-4 / 3e-5 against exact quadrature
    assert diff[..., 0].max() < 1.6e-2 and diff[..., 0].mean() < 1e-3
    assert diff[..., 1].max() < 1e-3 and diff[..., 1].mean() < 5e-5
    assert np.abs(np.swapaxes(ours, 0, 1) - theirs).max() > 0.3  # the transposed reading is far off


def bevy_f_ab(perceptual_roughness, nov):
    """Bevy's F_AB (pbr_lighting.wgsl; Karis, 'Physically Based Shading on Mobile'): its shipped numbers."""
    c0 = np.array([-1.0, -0.0275, -0.572, 0.022])
    c1 = np.array([1.0, 0.0425, 1.04, -0.04])
    r = perceptual_roughness * c0 + c1
    a004 = min(r[0] * r[0], 2.0 ** (-9.28 * nov)) * r[0] + r[1]
    return np.array([-1.04, 1.04]) * a004 + r[2:]


def test_bevy_table_is_what_its_fit_approximates():
    sel = {"roughness": list(range(4, 64, 8)), "mu": list(range(4, 64, 8))}
    t = build_preset("bevy-dfg", select=sel)
    rs, mus = centres(64)[sel["roughness"]], centres(64)[sel["mu"]]
    fit = np.array([[bevy_f_ab(r, m) for m in mus] for r in rs])
    ours = np.stack([ch(t, "A"), ch(t, "B")], axis=-1)
    # Karis' fit is crude (docs/presets.md: mean |A diff| 0.11 over the 64 x 64 table, E at
    # normal incidence and roughness 1 is 0.45 against the exact 1 - ln 2), but it is this table:
    assert np.abs(ours - fit).mean() < 0.08
    swapped = np.array([[bevy_f_ab(m, r) for m in mus] for r in rs])  # axes confused
    assert np.abs(ours - swapped).mean() > 1.5 * np.abs(ours - fit).mean()
    assert bevy_f_ab(1.0, 1.0).sum() == pytest.approx(0.45, abs=0.01)
