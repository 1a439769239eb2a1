"""Where the fitted sheen albedo exceeds 1 (docs/sheen.md, "fitted E above 1"), against independent
SciPy quadrature, and the khr-sheen-E-fitted preset's clamp (docs/presets.md).

At mu = 0 the fitted V_Sheen's denominator 4 mu_i mu_o (1 + Lambda_i + Lambda_o) vanishes, so its
clamp makes V = 1 and E = int D(h) mu_o dw_o, which is 1 + 1 / (1 + 4 alpha) (2 as alpha -> 0).
"""

import math

import numpy as np
import pytest
from scipy import integrate

import bsdf_tab
from bsdf_tab.presets import build_preset
from bsdf_tab.tables.sheen import sheen_albedo_values
from tests.sheen.test_sheen_albedo import D_ref, E_ref


def E0_ref(a):
    """E at mu = 0 with V = 1 (the clamp), nested quad over w_o (independent of the kernel)."""

    def inner(mo):
        so = math.sqrt(max(0.0, 1 - mo * mo))

        def g(phi):  # h = w_i + w_o with w_i = (1, 0, 0)
            hx, hy, hz = 1 + so * math.cos(phi), so * math.sin(phi), mo
            return D_ref(hz / math.sqrt(hx * hx + hy * hy + hz * hz), a)

        return 2 * integrate.quad(g, 0, math.pi, epsabs=1e-13, epsrel=1e-12, limit=200)[0]

    return integrate.quad(lambda mo: inner(mo) * mo, 0, 1, epsabs=1e-11, epsrel=1e-10, limit=200)[0]


@pytest.mark.parametrize("alpha", [0.01, 0.25, 1.0, 3.0])
def test_fitted_E_at_grazing_is_above_one(alpha):
    E, err = sheen_albedo_values(np.zeros(1), np.array([alpha]), "fitted")
    ref = E0_ref(alpha)
    assert abs(ref - (1 + 1 / (1 + 4 * alpha))) < 1e-9
    assert abs(E[0] - ref) <= max(err[0], 1e-9) and E[0] > 1


@pytest.mark.parametrize("mu,r,above", [(1 / 64, 3 / 64, True), (0.04, 0.078, True), (0.045, 0.078, False),
                                        (0.01, 0.19, False), (0.1, 0.03, False)])
def test_fitted_E_above_one_region(mu, r, above):
    """docs/sheen.md: for mu > 0, E > 1 only for mu < 0.043 and roughness < 0.19 (mu >= 1e-5)."""
    ref = E_ref(mu, r * r, "fitted")
    E, err = sheen_albedo_values(np.array([mu]), np.array([r * r]), "fitted")
    assert abs(E[0] - ref) <= max(err[0], 1e-9)
    assert (ref > 1) == above, ref


def test_khr_preset_clamps_E_to_one_and_says_what_it_changed():
    """The reference LUT is a PNG (values in [0, 1]): the preset's E <= 1, so 1 - max(sheenColor) E >= 0."""
    t = build_preset("khr-sheen-E-fitted", select={"roughness": [1, 6], "mu": [0, 1]})
    E, err = np.asarray(t.channels["E"]), np.asarray(t.channels["E_err"])
    ref = E_ref(1 / 64, (3 / 64) ** 2, "fitted")  # roughness node 1, NdotV node 0: 1.454
    assert ref > 1.4
    assert E[0, 0] == 1.0 and err[0, 0] >= ref - 1.0
    assert (E <= 1.0).all()
    # a texel below 1 is not touched: roughness 13/64, NdotV 3/64
    ref2 = E_ref(3 / 64, (13 / 64) ** 2, "fitted")
    assert ref2 < 1 and abs(E[1, 1] - ref2) <= max(err[1, 1], 1e-6)


def test_spec_tolerance_does_not_change_a_sheen_table():
    """The fixed rule ignores tolerance: same values, same recorded spec (docs/sheen.md)."""
    spec = {"table": "sheen_albedo", "axes": {"mu": [0.02, 0.5], "roughness": [0.1, 0.7]}}
    a = bsdf_tab.tabulate({**spec, "tolerance": 1e-2})
    b = bsdf_tab.tabulate({**spec, "tolerance": 1e-11})
    for name in ("E", "E_err"):
        np.testing.assert_array_equal(a.channels[name], b.channels[name])
    assert a.meta["spec"] == b.meta["spec"] and a.meta["spec"].get("tolerance", 5e-7) == 5e-7
