"""Schlick-GGX shadowing (k = alpha / 2: UE4's notes, learnopengl, Godot) in the doctor.

Truth: bsdf-tab's own separable Smith table for the quadrature rule (with Smith's G1 swapped
in), SciPy's adaptive quadrature over the outgoing direction for the Schlick-GGX values, and a
table made here as Godot's ``integrate_dfg.glsl`` makes it (Hammersley NDF sampling, rows at
(n - y + 0.5) / n, written from the shader's formulas) for the identification.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import bsdf_tab
from bsdf_tab.doctor import check_image
from bsdf_tab.doctor.readers import LutImage
from bsdf_tab.doctor.schlick import dfg_quadrature, schlick_g1, smith_g1


def test_rule_reproduces_the_smith_separable_table():
    mu = np.array([1e-3, 0.02, 0.1, 0.4, 0.8, 1.0])
    alpha = np.array([0.0, 0.004, 0.03, 0.2, 0.6, 1.0])
    t = bsdf_tab.tabulate({"table": "dfg", "shadowing": "separable", "tolerance": 1e-8,
                           "axes": {"mu": [float(x) for x in mu], "alpha": [float(x) for x in alpha]}})
    A, B = dfg_quadrature(mu, alpha, smith_g1, n_u=128, n_phi=64)
    assert np.abs(A - np.asarray(t.channels["A"])).max() < 2e-5
    assert np.abs(B - np.asarray(t.channels["B"])).max() < 2e-5


@pytest.mark.parametrize("mu,alpha", [(0.5, 0.25), (0.1, 0.6), (0.9, 0.05)])
def test_schlick_values_against_scipy(mu, alpha):
    """E and B by SciPy over (theta_l, phi_l): f = D G F / (4 mu cos_l), G = Schlick G1(mu) G1(cos_l)."""
    from scipy import integrate

    k = alpha / 2.0
    v = np.array([math.sqrt(1 - mu * mu), 0.0, mu])

    def integrand(phi, tl, fresnel):
        l = np.array([math.sin(tl) * math.cos(phi), math.sin(tl) * math.sin(phi), math.cos(tl)])
        h = v + l
        h /= np.linalg.norm(h)
        c = h[2]
        d = alpha**2 / (math.pi * (c * c * (alpha**2 - 1) + 1) ** 2)
        g = (mu / (mu * (1 - k) + k)) * (l[2] / (l[2] * (1 - k) + k))
        fc = (1 - float(v @ h)) ** 5
        return d * g * (fc if fresnel else 1.0) / (4 * mu) * math.sin(tl)  # f cos_l dw = D G F / (4 mu) dw

    opts = {"epsabs": 1e-9, "epsrel": 1e-9}
    E = 2 * integrate.dblquad(integrand, 0, math.pi / 2, 0, math.pi, args=(False,), **opts)[0]
    Bv = 2 * integrate.dblquad(integrand, 0, math.pi / 2, 0, math.pi, args=(True,), **opts)[0]
    A, B = dfg_quadrature([mu], [alpha], schlick_g1, n_u=128, n_phi=64)
    assert A[0, 0] + B[0, 0] == pytest.approx(E, abs=2e-5)
    assert B[0, 0] == pytest.approx(Bv, abs=2e-5)


def godot_like(n: int = 24, samples: int = 4096) -> np.ndarray:
    """(rows, columns, 2) = (int Fc G_Vis, int G_Vis) as Godot's integrate_dfg.glsl: row y at roughness
    (n - y + 0.5) / n, column x at NdotV (x + 0.5) / n, 'samples' Hammersley points, NDF sampling."""
    i = np.arange(samples)
    bits = i.astype(np.uint64)
    rad = np.zeros(samples)
    for b in range(32):  # van der Corput radical inverse, bit by bit
        rad += ((bits >> np.uint64(b)) & np.uint64(1)).astype(np.float64) * 2.0 ** (-(b + 1))
    xi1, xi2 = i / samples, rad
    out = np.zeros((n, n, 2))
    nov = (np.arange(n) + 0.5) / n
    for y in range(n):
        r = (n - y + 0.5) / n
        a = r * r
        ct = np.sqrt((1 - xi2) / (1 + (a * a - 1) * xi2))
        st = np.sqrt(1 - ct * ct)
        hx, hz = np.cos(2 * np.pi * xi1) * st, ct
        for x, nv in enumerate(nov):
            sv = math.sqrt(1 - nv * nv)
            vdh = sv * hx + nv * hz
            lz = 2 * vdh * hz - nv
            ok = lz > 0
            k = r * r / 2
            g = (nv / (nv * (1 - k) + k)) * (lz / (lz * (1 - k) + k))
            gv = np.where(ok, g * np.clip(vdh, 0, 1) / (hz * nv), 0.0)
            fc = (1 - np.clip(vdh, 0, 1)) ** 5
            out[y, x] = [np.mean(fc * gv), np.mean(gv)]
    return out.astype(np.float16).astype(np.float64)


def test_godot_style_lut_is_identified():
    data = godot_like()
    r = check_image(LutImage(data, "npy", ["R", "G"])).to_dict()
    assert (r["table"], r["distribution"], r["shadowing"]) == ("dfg_multiscatter", "ggx", "schlick")
    assert r["channels"] == {"R": "B", "G": "E"}
    assert [(a["name"], a["nodes"], a["reversed"]) for a in r["axes"]] == [("roughness", "centers+1", True),
                                                                              ("mu", "centers", False)]
    assert any("grid shifted by one texel along the rows" in f for f in r["findings"])
    assert any("Schlick-GGX" in f for f in r["findings"])
    assert r["alternatives"][0]["mean_error"] > 3 * r["screening_error"]
