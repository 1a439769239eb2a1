"""The doctor on bsdf-tab's own writers' files: every layout the writers make is read in the table's
shape, and the file's claims (table kind, axes, channels) are honoured.

Truth: the spec each table was baked from (its kind, axes and sizes, channels), and the
rearrangements applied here (axis order reversed, channels scaled).
"""

from __future__ import annotations

import json

import numpy as np
import pytest

import bsdf_tab
from bsdf_tab.doctor import check_image, check_lut, check_lut_bytes, read_lut_bytes
from bsdf_tab.doctor.readers import LutImage
from bsdf_tab.errors import SpecError

from conftest import image_of

BSDF_SPEC = {"table": "bsdf", "alpha": 0.1, "fresnel": {"type": "dielectric", "eta": 1.5},
             "axes": {"theta_i": {"size": 4}, "theta_o": {"size": 5}, "phi_d": {"size": 3}}}
KC_SPEC = {"table": "kulla_conty", "axes": {"mu": {"size": 4}, "alpha": {"size": 5}}}
DIEL_SPEC = {"table": "dielectric", "tolerance": 1e-6, "shadowing": "correlated",
             "axes": {"mu": {"size": 5}, "alpha": {"size": 4}, "eta": {"size": 6, "range": [1.1, 2.0]}}}
AVG_SPEC = {"table": "albedo_avg", "tolerance": 1e-7, "axes": {"roughness": {"size": 8}}}

GUESSES = ("decoded as sRGB", "stored sRGB-encoded", "flipped", "grid shifted", "noise", "shadowing: Schlick",
           "axes swapped", "best match")


def _has(r: dict, text: str) -> bool:
    return any(text in f for f in r["findings"])


def _guessed(r: dict) -> list:
    """Findings that describe a fitted candidate (flips, shifts, encodings, noise), which a file the
    doctor does not fit must not get ("left out: ..." says that some were dropped)."""
    return [f for f in r["findings"] if not f.startswith("left out: ") and any(g in f for g in GUESSES)]


@pytest.fixture(scope="module")
def bsdf_table():
    return bsdf_tab.tabulate(BSDF_SPEC)


@pytest.fixture(scope="module")
def diel_table():
    return bsdf_tab.tabulate(DIEL_SPEC)


@pytest.fixture(scope="module")
def avg_table():
    return bsdf_tab.tabulate(AVG_SPEC)


# ----------------------------------------------------------------------------- claimed kinds it cannot fit

@pytest.mark.parametrize("fmt", ["png", "ktx2", "h"])
def test_a_bsdf_table_is_reported_as_claimed_not_identified(bsdf_table, fmt):
    """A 3-D ``bsdf`` table (4 x 5 x 3 [theta_i, theta_o, phi_d]; f_r, f_t): never 'identified' as a
    dfg or glass table; its claimed kind, axes and channels are reported, and the values are not fitted."""
    from bsdf_tab.io.c_header import header_text
    from bsdf_tab.io.ktx2 import ktx2_bytes
    from bsdf_tab.io.png import png_bytes

    data = {"png": lambda: png_bytes(bsdf_table, "unorm16"), "ktx2": lambda: ktx2_bytes(bsdf_table, "float32"),
            "h": lambda: header_text(bsdf_table, "bsdf").encode()}[fmt]()
    r = check_lut_bytes(data, f"bsdf.{fmt}").to_dict()
    json.dumps(r, allow_nan=False)
    assert (r["table"], r["fitted"], r["distribution"], r["max_error"]) == ("bsdf", False, None, None)
    assert r["findings"][0].startswith("not fitted: the file says it is a `bsdf` table")
    assert _guessed(r) == []
    assert [(a["name"], a["size"]) for a in r["axes"]] == [("theta_i", 4), ("theta_o", 5), ("phi_d", 3)]
    assert r["shape"][:3] == [4, 5, 3]
    assert list(r["channels"].values())[:2] == ["f_r", "f_t"]
    ft = list(r["channels"])[1]
    f_t = np.asarray(bsdf_table.channels["f_t"])
    assert f_t.max() > 1  # the spec's transmission peak
    if fmt == "png":  # unorm16 clamps f_t to 1 (the writer's metadata says so; the texels at 1.0 show it too)
        assert r["values"][ft]["max"] == 1.0
        assert any("(f_t)" in f and "clipped" in f for f in r["findings"])
        assert r["channels"]["B"].startswith("padding (constant 0")
    else:
        assert r["values"][ft]["max"] == pytest.approx(f_t.max(), rel=1e-6) and not _has(r, "clipped")


def test_a_claimed_kind_report_has_text_and_heatmap(bsdf_table, tmp_path):
    from bsdf_tab.io.ktx2 import ktx2_bytes

    path = tmp_path / "bsdf.ktx2"
    path.write_bytes(ktx2_bytes(bsdf_table, "float16"))
    heat = tmp_path / "heat.png"
    rep = check_lut(path, heatmap=heat)
    text = rep.text()
    assert "claimed: bsdf" in text and "NOT FITTED" in text and "best match" not in text
    assert heat.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with pytest.raises(SpecError, match="^axes: give 3 axis names"):
        check_lut(path, expect_axes=["mu", "roughness"])


def test_kulla_conty_ktx2_is_not_identified():
    """kulla_conty (E, E_avg, C) on 4 x 5 [mu, alpha]: 3 channels in RGBA16F, A = 1 padding."""
    from bsdf_tab.io.ktx2 import ktx2_bytes

    t = bsdf_tab.tabulate(KC_SPEC)
    r = check_lut_bytes(ktx2_bytes(t, "float16"), "kc.ktx2").to_dict()
    assert (r["table"], r["fitted"]) == ("kulla_conty", False)
    assert r["channels"] == {"R": "E", "G": "E_avg", "B": "C", "A": "padding (constant 1)"}
    assert [(a["name"], a["size"]) for a in r["axes"]] == [("mu", 4), ("alpha", 5)]
    assert r["findings"] and r["findings"][0].startswith("not fitted")
    assert _guessed(r) == []


def test_a_dfg_claim_over_albedo_values_is_named(ours):
    """A bsdf-tab file that says dfg but holds E = A + B (one channel): identified as albedo, and the
    disagreement with the claim reported."""
    from bsdf_tab.io.ktx2 import ktx2_bytes

    t = bsdf_tab.Table(dict(ours.axes), {"E": np.asarray(ours.channels["A"]) + np.asarray(ours.channels["B"])},
                       {"spec": {"table": "dfg", "distribution": "ggx", "shadowing": "correlated"}})
    r = check_lut_bytes(ktx2_bytes(t, "float32"), "says_dfg.ktx2").to_dict()
    assert r["table"] == "albedo" and _has(r, "the file says it is a `dfg` table, its values fit `albedo`")


@pytest.mark.parametrize("bad", [5.0, np.inf])
def test_values_far_outside_the_unit_range_fit_no_candidate(ours, bad):
    """36 of 1152 values at 5 (no energy is 5) or infinite (a float16 overflow): no candidate fits,
    and the report stays JSON (no inf in the errors)."""
    data = image_of(ours).copy()
    data[::4, ::4, 1] = bad
    r = check_image(LutImage(data, "npy", ["0", "1"])).to_dict()
    json.dumps(r, allow_nan=False)
    assert _has(r, "values outside [0, 1]: 36 of 1152") and _has(r, "no candidate fits well")
    assert _guessed(r) == []
    one = image_of(ours).copy()
    one[3, 5, 0] = bad  # one bad texel: named, but the table is still identified
    r1 = check_image(LutImage(one, "npy", ["0", "1"])).to_dict()
    assert r1["table"] == "dfg" and _has(r1, "values outside [0, 1]: 1 of") and not _has(r1, "no candidate")


def test_generated_lookup_code_is_named_not_read():
    src = b"// dfg.ktx2: lookup generated by bsdf-tab. Do not edit.\nfloat dfg_lookup(float x) { return x; }\n"
    with pytest.raises(SpecError, match="lookup code bsdf-tab generated for dfg.ktx2"):
        read_lut_bytes(src, "dfg.lookup.h")


# ----------------------------------------------------------------------------- layouts read in the table's shape

def test_png_of_a_3d_dielectric_table_is_unstacked(diel_table):
    """5 x 4 x 6 [mu, alpha, eta 1.1 .. 2.0] in a PNG (slices stacked: 20 rows of 6): read as the 3-D
    table its claims give, and identified as the KTX2 of the same table is."""
    from bsdf_tab.io.ktx2 import ktx2_bytes
    from bsdf_tab.io.png import png_bytes

    truth = np.stack([diel_table.channels["R"], diel_table.channels["T"]], axis=-1)
    img = read_lut_bytes(png_bytes(diel_table, "unorm16"), "diel.png")
    assert img.data.shape == (5, 4, 6, 3)
    np.testing.assert_allclose(img.data[..., :2], np.round(truth * 65535) / 65535, atol=1e-12)
    reports = [check_lut_bytes(png_bytes(diel_table, "unorm16"), "diel.png").to_dict(),
               check_lut_bytes(ktx2_bytes(diel_table, "float32"), "diel.ktx2").to_dict()]
    for r in reports:
        assert (r["table"], r["distribution"], r["shadowing"]) == ("dielectric", "ggx", "correlated")
        assert [(a["name"], a["size"]) for a in r["axes"]] == [("mu", 5), ("alpha", 4), ("ior", 6)]
        assert r["axes"][2]["range"] == pytest.approx([1.1, 2.0])
        assert r["channels"]["R"] == "R" and r["channels"]["G"] == "T"
        assert r["eta"] == "eta as the file's header gives it"
    assert reports[0]["shape"] == [5, 4, 6, 3] and reports[0]["max_error"] < 2e-5
    assert reports[1]["max_error"] < 2e-5 and reports[1]["findings"] == []


def test_dds_volume_is_read_as_3d(diel_table):
    from bsdf_tab.io.dds import dds_bytes

    truth = np.stack([diel_table.channels["R"], diel_table.channels["T"]], axis=-1)
    img = read_lut_bytes(dds_bytes(diel_table, "float16"), "diel.dds")
    assert img.data.shape == (5, 4, 6, 2) and img.storage == "float16"
    np.testing.assert_array_equal(img.data, truth.astype(np.float16).astype(np.float64))


@pytest.mark.parametrize("fmt", ["ktx2", "dds", "png"])
def test_1d_textures_are_1d_tables(avg_table, fmt):
    """An albedo_avg table of 8 roughness nodes (linear, endpoints): a 1-D texture (KTX2 pixelHeight 0,
    DDS TEXTURE1D, one PNG row) is an 8-node table, identified as E_avg."""
    from bsdf_tab.io.dds import dds_bytes
    from bsdf_tab.io.ktx2 import ktx2_bytes
    from bsdf_tab.io.png import png_bytes

    data = {"ktx2": lambda: ktx2_bytes(avg_table, "float32"), "dds": lambda: dds_bytes(avg_table, "float32"),
            "png": lambda: png_bytes(avg_table, "unorm16")}[fmt]()
    img = read_lut_bytes(data, f"avg.{fmt}")
    assert img.data.shape[:-1] == (8,)
    r = check_lut_bytes(data, f"avg.{fmt}").to_dict()
    assert (r["table"], r["quantity"], r["distribution"], r["shadowing"]) == ("albedo_avg", "E_avg", "ggx", "correlated")
    assert r["axes"][0]["name"] == "roughness" and r["axes"][0]["size"] == 8 and r["max_error"] < 2e-5


# ----------------------------------------------------------------------------- our .h headers, npy-channels, .npy dtypes

def test_our_header_needs_no_shape(ours):
    """bsdf-tab's .h (``<P>_NDIM``, ``<P>_SIZE_<AXIS>``, one array per channel): read without --shape."""
    from bsdf_tab.io.c_header import header_text

    h = header_text(ours, "dfg").encode()
    img = read_lut_bytes(h, "dfg.h")
    assert img.data.shape == (24, 24, 2) and img.channels == ["A", "B"]
    np.testing.assert_array_equal(img.data.astype(np.float32), image_of(ours).astype(np.float32))  # 9 digits
    assert list(img.claims["axes"]) == ["mu", "roughness"] and img.claims["spec"]["table"] == "dfg"
    one = read_lut_bytes(h, "dfg.h", array_name="dfg_B")
    assert one.data.shape == (24, 24, 1) and one.channels == ["B"]
    r = check_lut_bytes(h, "dfg.h").to_dict()
    assert (r["table"], r["channels"], r["shadowing"]) == ("dfg", {"A": "A", "B": "B"}, "correlated")
    assert r["findings"] == [] and r["max_error"] < 3e-6


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_npy_channels_set_and_npy_dtypes(ours, tmp_path, dtype):
    from bsdf_tab.io.npy_channels import write_npy_channels

    name = np.dtype(dtype).name
    write_npy_channels(ours, tmp_path, "dfg", dtype=dtype)
    r = check_lut(tmp_path / "dfg.meta.json").to_dict()
    assert (r["format"], r["table"], r["storage"]) == ("npy-channels", "dfg", name)
    assert r["channels"] == {"A": "A", "B": "B"} and r["findings"] == []
    with pytest.raises(SpecError, match="^lut: dfg.meta.json: an npy-channels sidecar"):
        check_lut_bytes((tmp_path / "dfg.meta.json").read_bytes(), "dfg.meta.json")
    np.save(tmp_path / "dfg.npy", image_of(ours).astype(dtype))
    r = check_lut(tmp_path / "dfg.npy").to_dict()
    assert r["storage"] == name and r["table"] == "dfg"


# ----------------------------------------------------------------------------- the claimed axis order

def _reversed_rows_ktx2(ours, flip_data: bool) -> bytes:
    """[roughness, mu] with the roughness axis claimed high to low (as Godot's rows); the data
    follows the claim (flip_data) or not."""
    from bsdf_tab.io.ktx2 import ktx2_bytes

    rough = np.asarray(ours.axes["roughness"])[::-1]
    chans = {c: np.ascontiguousarray(np.asarray(ours.channels[c]).T[::-1] if flip_data else np.asarray(ours.channels[c]).T)
             for c in ("A", "B")}
    t = bsdf_tab.Table({"roughness": rough, "mu": np.asarray(ours.axes["mu"])}, chans,
                       {"spec": {"table": "dfg", "distribution": "ggx", "shadowing": "correlated"}})
    return ktx2_bytes(t, "float32")


def test_a_claimed_decreasing_axis_is_no_flip(ours):
    r = check_lut_bytes(_reversed_rows_ktx2(ours, True), "godot_like.ktx2").to_dict()
    assert r["table"] == "dfg" and r["axes"][0]["name"] == "roughness" and r["axes"][0]["reversed"] is True
    assert not _has(r, "flipped") and r["findings"] == []
    bad = check_lut_bytes(_reversed_rows_ktx2(ours, False), "godot_wrong.ktx2").to_dict()
    assert bad["axes"][0]["reversed"] is False
    assert _has(bad, "Y flipped: the file says the rows run from roughness high to low, the data runs low to high")
