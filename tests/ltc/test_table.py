"""The ``ltc`` kind as a table like every other (spec, channels, EXR, presets), and a quad light
shaded in a user's Warp kernel with a baked table against the exact integral (SciPy, here)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import warp as wp
from scipy import integrate

import bsdf_tab
from bsdf_tab.model.ltc import ltc_minv, ltc_quad_integral
from bsdf_tab.presets import build_preset, get_preset
from bsdf_tab.spec import normalize_spec
from bsdf_tab.tables import CATALOG
from tests.reference import microfacet_ref as ref


def test_catalog_and_spec():
    info = CATALOG["ltc"]
    assert info["axes"] == ("mu", "alpha") and info["fresnel"] == "one"
    assert {"Minv_00", "Minv_20", "Minv_02", "Minv_22", "E", "fresnel", "sphere", "fit_l1", "horizon", "magnitude",
            "magnitude_fresnel", "fit_l1_clipped"} <= set(info["channels"])
    n = normalize_spec({"table": "ltc", "axes": {"mu": [0.5], "roughness": [0.5]}})
    assert list(n["axes"]) == ["mu", "roughness"]
    with pytest.raises(bsdf_tab.SpecError, match="fresnel"):
        normalize_spec({"table": "ltc", "fresnel": {"type": "schlick", "f0": 0.04}})


@pytest.fixture(scope="module")
def table():
    return bsdf_tab.tabulate({"table": "ltc", "axes": {"mu": [0.5, 0.9], "roughness": [0.55, 0.8]}})


def test_channels_exr_round_trip(table, tmp_path):
    for name in CATALOG["ltc"]["channels"]:
        assert table.channels[name].shape == (2, 2) and f"{name}_err" in table.channels
    np.testing.assert_array_equal(table.channels["Minv_00_err"], 0.0)
    path = tmp_path / "ltc.exr"
    table.write_exr(path)
    back = bsdf_tab.read_exr(path)
    np.testing.assert_array_equal(back.channels["fit_l1"], table.channels["fit_l1"].astype(np.float32))
    assert back.meta["table"] == "ltc"


@wp.kernel
def _shade(e: wp.array(dtype=wp.vec4d), amp: wp.array(dtype=wp.float64), quads: wp.array2d(dtype=wp.vec3d),
           out: wp.array2d(dtype=wp.float64)):
    i, q = wp.tid()
    minv = ltc_minv(e[i][0], e[i][1], e[i][2], e[i][3])
    out[i, q] = amp[i] * ltc_quad_integral(minv, quads[q, 0], quads[q, 1], quads[q, 2], quads[q, 3])


def exact_quad(quad, mu, alpha):
    """int over the quad of f_r cos dw (GGX, correlated, F = 1): SciPy over two triangles."""
    wi = ref.wi_of_mu(mu)
    total = 0.0
    for a, b, c in ((quad[0], quad[1], quad[2]), (quad[0], quad[2], quad[3])):
        e1, e2 = b - a, c - a
        nrm = np.cross(e1, e2)
        area2 = np.linalg.norm(nrm)
        n = nrm / area2

        def f(v, u):
            x = a + u * e1 + v * e2
            r = np.linalg.norm(x)
            d = x / r
            return float(ref.f_r(wi, d, alpha, "ggx", "correlated")) * d[2] * abs(n @ x) / r**3 * area2

        total += integrate.dblquad(f, 0.0, 1.0, 0.0, lambda u: 1.0 - u, epsabs=1e-9, epsrel=1e-8)[0]
    return total


QUADS = np.array([
    # over the mirror direction of mu = 0.5 .. 0.9 (x < 0), wound so the integral is positive
    [[-1.2, -0.5, 1.0], [-0.1, -0.5, 1.0], [-0.1, 0.5, 1.0], [-1.2, 0.5, 1.0]],
    # off to the side, tilted
    [[0.2, 0.4, 0.6], [0.9, 0.5, 0.9], [0.8, 1.3, 1.0], [0.1, 1.1, 0.7]],
])


def test_quad_light_shaded_in_a_warp_kernel(table):
    ch = table.channels
    mu, rough = table.axes["mu"], table.axes["roughness"]
    idx = [(i, j) for i in range(2) for j in range(2)]
    e = np.array([[ch[k][i, j] for k in ("Minv_00", "Minv_20", "Minv_02", "Minv_22")] for i, j in idx])
    amp = np.array([ch["magnitude"][i, j] for i, j in idx])  # E / horizon: the default amplitude
    out = wp.zeros((len(idx), len(QUADS)), dtype=wp.float64, device="cpu")
    wp.launch(_shade, dim=(len(idx), len(QUADS)), device="cpu",
              inputs=[wp.array(e, dtype=wp.vec4d, device="cpu"), wp.array(amp, dtype=wp.float64, device="cpu"),
                      wp.array(QUADS, dtype=wp.vec3d, device="cpu"), out])
    shaded = out.numpy()
    for k, (i, j) in enumerate(idx):
        for q, quad in enumerate(QUADS):
            exact = exact_quad(quad, mu[i], rough[j] ** 2)
            # a light above the horizon: E |int_P (D_ltc / m_up - T)| <= E fit_l1_clipped / 2 (both lobes have
            # unit mass over the upper hemisphere), the bound the table states
            bound = ch["E"][i, j] * (ch["fit_l1_clipped"][i, j] + ch["fit_l1_clipped_err"][i, j]) / 2 + 1e-7
            assert abs(shaded[k, q] - exact) <= bound
        big = exact_quad(QUADS[0], mu[i], rough[j] ** 2)
        assert shaded[k, 0] == pytest.approx(big, rel=0.1)


def test_presets_layout_and_axes():
    heitz = get_preset("heitz-ltc")
    x = np.arange(64) / 63
    np.testing.assert_allclose(heitz.axes()["mu"], np.cos(np.minimum(1.57, np.arccos(1 - x * x))), rtol=0, atol=1e-15)
    np.testing.assert_allclose(get_preset("heitz-ltc-rgba").axes()["mu"], 1 - x * x, rtol=0, atol=0)
    t = build_preset("heitz-ltc-rgba", select={"mu": [0, 63], "alpha": [0, 63]})
    assert list(t.channels)[:8] == ["ltc1_r", "ltc1_g", "ltc1_b", "ltc1_a", "ltc2_r", "ltc2_g", "ltc2_a", "fit_l1"]
    # normal incidence, alpha = 1: the lobe is isotropic (ltc_1 = (a, 0, 0, d), the polish keeps it so); the
    # presets' amplitude is the shading one, s E / m_up with m_up = 1 there: the stored magnitude over the
    # exact albedo E = 1 - ln 2 is the polished s, within the few percent the polish moves it
    assert t.channels["ltc1_g"][0, 1] == pytest.approx(0.0, abs=1e-6)
    assert t.channels["ltc1_b"][0, 1] == pytest.approx(0.0, abs=1e-6)
    assert t.channels["ltc2_r"][0, 1] / (1.0 - math.log(2.0)) == pytest.approx(1.0, abs=0.05)
    albedo = build_preset("heitz-ltc", select={"mu": [0], "alpha": [63]}).channels["albedo"]
    assert albedo[0, 0] == pytest.approx(1.0 - math.log(2.0), abs=2e-6)
    # the sphere term at v = 0 is max(z, 0), at v = 1 it is (1 + z) / 2
    assert t.channels["ltc2_a"][0, 1] == pytest.approx(1.0, abs=1e-12)
    assert t.channels["ltc2_a"][1, 1] == pytest.approx(1.0, abs=1e-12)
    assert t.channels["ltc2_a"][1, 0] == pytest.approx(0.5 * (2 * math.sqrt(1e-5)), abs=1e-9)
