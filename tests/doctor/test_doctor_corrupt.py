"""The doctor on our own exact tables, corrupted on purpose in each of the ways engines get wrong.

Truth: the corruption we applied (and, for the clean table, the spec we baked).
"""

from __future__ import annotations

import numpy as np
import pytest

import bsdf_tab
from bsdf_tab.doctor import check_image, check_lut, srgb_decode
from bsdf_tab.doctor.readers import LutImage

from conftest import N, dfg_table, image_of, unit


def _check(data, **kw) -> dict:
    img = LutImage(np.asarray(data, dtype=np.float64), "npy", [str(i) for i in range(data.shape[2])])
    return check_image(img, **kw).to_dict()


def _has(r: dict, text: str) -> bool:
    return any(text in f for f in r["findings"])


def _axes(r):
    return [(a["name"], a["spacing"], a["nodes"], a["reversed"]) for a in r["axes"]]


CLEAN_AXES = [("mu", "linear", "endpoints", False), ("roughness", "linear", "endpoints", False)]


def test_clean_table_identified_exactly(ours):
    r = _check(image_of(ours))
    assert (r["table"], r["distribution"], r["shadowing"], r["encoding"]) == ("dfg", "ggx", "correlated", "linear")
    assert r["channels"] == {"0": "A", "1": "B"}
    assert _axes(r) == CLEAN_AXES
    assert r["max_error"] < 3e-6
    assert r["findings"] == []


def test_multiscatter_channels(ours):
    """(B, E) as Filament's multiscatter texture and Unity's FGD store it."""
    img = np.stack([ours.channels["B"], ours.channels["A"] + ours.channels["B"]], axis=-1)
    r = _check(img)
    assert r["table"] == "dfg_multiscatter" and r["channels"] == {"0": "B", "1": "E"}


def test_decoded_as_srgb(ours):
    r = _check(srgb_decode(image_of(ours)))
    assert r["encoding"] == "srgb-decoded" and _has(r, "decoded as sRGB")
    assert _axes(r) == CLEAN_AXES and r["max_error"] < 1e-5


def test_y_flipped(ours):
    r = _check(image_of(ours)[::-1])
    assert _axes(r)[0] == ("mu", "linear", "endpoints", True) and _has(r, "Y flipped")
    assert r["max_error"] < 1e-5


def test_axes_swapped_against_the_files_claim(ours, tmp_path):
    """A bsdf-tab EXR that says [mu, roughness] but holds the transpose."""
    swapped = bsdf_tab.Table(dict(ours.axes), {c: np.asarray(v).T.copy() for c, v in ours.channels.items()}, ours.meta)
    path = tmp_path / "swapped.exr"
    swapped.write(path)
    r = check_lut(path).to_dict()
    assert [a["name"] for a in r["axes"]] == ["roughness", "mu"]
    assert _has(r, "axes swapped")
    clean = check_lut(_write(ours, tmp_path / "clean.exr")).to_dict()
    assert not _has(clean, "axes swapped") and clean["findings"] == []


def _write(table, path):
    table.write(path)
    return path


def test_grid_shifted_by_half_a_texel():
    """Baked at mu = (i + 1/2) / (n - 1) (clamped to 1): an endpoints table read half a texel off."""
    mu = np.clip((np.arange(N) + 0.5) / (N - 1), 0, 1)  # the last node clamps to 1
    r = _check(image_of(dfg_table(mu=mu)))
    assert r["axes"][0]["nodes"] == "endpoints+0.5" and _has(r, "grid shifted by half a texel")
    assert r["max_error"] < 1e-5


def test_grid_shifted_by_one_texel(ours):
    data = image_of(ours)
    data = np.concatenate([data[:, 1:], data[:, -1:]], axis=1)  # column j holds roughness node j + 1
    r = _check(data)
    assert r["axes"][1]["nodes"] == "endpoints+1" and _has(r, "grid shifted by one texel along the columns")


def test_stored_at_8_bits(ours, tmp_path):
    """Through bsdf-tab's own 8-bit PNG writer (a real file, read back by the doctor's PNG reader)."""
    from bsdf_tab.io.png import png_bytes

    path = tmp_path / "dfg8.png"
    path.write_bytes(png_bytes(ours, "unorm8"))
    r = check_lut(path).to_dict()
    assert r["storage"] == "unorm8" and _has(r, "stored at 8 bits")
    assert r["table"] == "dfg" and _axes(r) == CLEAN_AXES
    assert 1e-3 < r["max_error"] <= 0.5 / 255 + 1e-6


def test_ndf_sampled_noise_at_grazing(ours):
    """Noise whose spread grows toward mu = 0, as an NDF-sampling estimator's does."""
    rng = np.random.default_rng(7)
    mu = unit()[:, None, None]
    sigma = 4e-3 * np.exp(-mu / 0.12) + 2e-5
    r = _check(image_of(ours) + rng.normal(0.0, 1.0, (N, N, 2)) * sigma)
    assert _has(r, "NDF-sampled noise at grazing angles")
    assert r["table"] == "dfg" and _axes(r) == CLEAN_AXES and r["shadowing"] == "correlated"
    flat = _check(image_of(ours) + rng.normal(0.0, 3e-4, (N, N, 2)))
    assert not _has(flat, "at grazing") and _has(flat, "Monte Carlo noise")


def test_roughness_mapped_as_alpha(tmp_path):
    """A file that says its columns are roughness while its values follow alpha = x."""
    t = dfg_table(roughness=None, axes={"mu": [float(x) for x in unit()], "alpha": [float(x) for x in unit()]})
    lied = bsdf_tab.Table({"mu": t.axes["mu"], "roughness": t.axes["alpha"]}, t.channels, t.meta)
    r = check_lut(_write(lied, tmp_path / "lied.exr")).to_dict()
    assert r["axes"][1]["name"] == "alpha" and _has(r, "roughness mapped as alpha")


def test_beckmann_separable_sqrt_mu():
    """Beckmann, separable, Unity's sqrt(NdotV) spacing: the model and the spacing are both named."""
    t = dfg_table(mu=unit() ** 2, distribution="beckmann", shadowing="separable")
    r = _check(image_of(t))
    assert (r["distribution"], r["shadowing"]) == ("beckmann", "separable")
    assert _axes(r)[0] == ("mu", "sqrt", "endpoints", False)
    assert r["max_error"] < 1e-5


def test_file_declares_srgb_but_holds_linear(ours, tmp_path):
    """An 8-bit PNG with an sRGB chunk over linear data: a loader would decode it."""
    import struct
    import zlib

    from bsdf_tab.io.png import png_bytes

    data = png_bytes(ours, "unorm8")
    chunk = b"sRGB" + b"\x00"
    srgb = struct.pack(">I", 1) + chunk + struct.pack(">I", zlib.crc32(chunk) & 0xFFFFFFFF)
    at = 8 + 25  # after the signature and IHDR
    path = tmp_path / "tagged.png"
    path.write_bytes(data[:at] + srgb + data[at:])
    r = check_lut(path).to_dict()
    assert r["declared_transfer"] == "srgb" and r["encoding"] == "linear"
    assert _has(r, "declares sRGB but holds linear values")


@pytest.mark.parametrize("bad", ["nan", "tiny", "constant"])
def test_unusable_inputs_are_one_clear_error(ours, bad):
    from bsdf_tab.errors import SpecError

    data = image_of(ours)
    if bad == "nan":
        data = data.copy()
        data[3, 5, 0] = np.nan
        r = _check(data)  # NaN texels are reported, not fatal
        assert _has(r, "NaN") and r["table"] == "dfg"
        return
    data = data[:3, :3] if bad == "tiny" else np.ones((8, 8, 1))
    with pytest.raises(SpecError, match="lut: "):
        _check(data)


def test_claimed_endpoints_but_baked_at_centres(tmp_path):
    """A bsdf-tab EXR whose mu axis says endpoints i/(n-1) while its texels were baked at (i + 1/2)/n."""
    centres = dfg_table(mu=(np.arange(N) + 0.5) / N)
    lied = bsdf_tab.Table({"mu": unit(), "roughness": centres.axes["roughness"]}, centres.channels, centres.meta)
    r = check_lut(_write(lied, tmp_path / "centres.exr")).to_dict()
    assert r["axes"][0]["nodes"] == "centers"
    assert _has(r, "grid offset along the rows: the file says endpoints, the data sits at centers")
