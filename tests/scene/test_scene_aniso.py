"""Anisotropic materials in scene files (issue 17): a material of type ``anisotropic`` gets an
``albedo_aniso`` table (mu, phi_v, alpha or roughness, anisotropy) limited to its ranges. The
baked EXR, read through the manifest alone with SciPy's grid interpolator in the texel
coordinate (scene_cases.renderer_lookup), meets the lookup tolerance against exact values:
nested SciPy quadrature of f_r cos over the outgoing hemisphere, with the anisotropic GGX D
and Smith Lambda and the documented widths written here."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scene_cases import renderer_lookup
from scipy import integrate

from bsdf_tab import read_exr
from bsdf_tab.errors import SpecError
from bsdf_tab.scene import bake_scene, parse_scene, plan_scene

ANISO = {"lookup": {"spacings": ["linear", "square"]},
         "materials": [{"name": "brushed", "type": "anisotropic", "roughness": [0.4, 0.6],
                        "anisotropy": {"range": [0.3, 0.8]}}]}
TOL = 2e-2


def widths(alpha: float, a: float) -> tuple[float, float]:
    """alpha_x = alpha / sqrt(1 - 0.9 a), alpha_y = alpha sqrt(1 - 0.9 a) (1 - 0.9 a >= 0.1)."""
    s = math.sqrt(1.0 - 0.9 * a)
    return alpha / s, alpha * s


def exact_albedo(mu: float, phi: float, ax: float, ay: float) -> float:
    """E = int f_r cos dw_o, height-correlated Smith G, F = 1 (Walter et al. 2007 eq. 20)."""
    def lam(w):  # w_z > 0 here
        return 0.5 * (-1.0 + math.sqrt(1.0 + (ax * ax * w[0] ** 2 + ay * ay * w[1] ** 2) / (w[2] * w[2])))

    def D(h):
        return 1.0 / (math.pi * ax * ay * ((h[0] / ax) ** 2 + (h[1] / ay) ** 2 + h[2] ** 2) ** 2)

    si = math.sqrt(1.0 - mu * mu)
    wi = np.array([si * math.cos(phi), si * math.sin(phi), mu])
    li = lam(wi)

    def f(po, mo):
        so = math.sqrt(max(0.0, 1.0 - mo * mo))
        wo = np.array([so * math.cos(po), so * math.sin(po), mo])
        h = wi + wo
        h = h / np.linalg.norm(h)  # |wi + wo| > 0 for mu, mo > 0
        return D(h) / (1.0 + li + lam(wo)) / (4.0 * mu)

    pm = phi + math.pi  # the mirror azimuth, where the lobe peaks
    inner = lambda mo: integrate.quad(f, pm - math.pi, pm + math.pi, args=(mo,), points=[pm], epsabs=1e-9,
                                      limit=200)[0]
    return integrate.quad(inner, 1e-9, 1.0, points=[mu], epsabs=1e-8, limit=200)[0]


@pytest.fixture(scope="module")
def baked(tmp_path_factory):
    # max_texels: below the 32 x 9 x 32 x 8 fixed-size table, so its comparison is skipped
    plan = plan_scene(ANISO, TOL, max_texels=20000)
    out = tmp_path_factory.mktemp("aniso")
    bake_scene(plan, out)
    return plan, json.loads((out / "manifest.json").read_text()), out


def test_aniso_table_planned_over_the_scene_ranges(baked):
    plan, manifest, _ = baked
    (entry,) = manifest["tables"]
    assert entry["table"] == "albedo_aniso" and entry["fresnel"] is None
    assert [a["name"] for a in entry["axes"]] == ["mu", "phi_v", "roughness", "anisotropy"]
    mu, phi, rough, an = entry["axes"]
    assert phi["lookup"] == "interpolate" and phi["range"] == pytest.approx([0.0, math.pi / 2])
    assert rough == {"name": "roughness", "lookup": "index", "values": [0.4, 0.6], "size": 2}
    assert an["lookup"] == "interpolate" and an["range"] == [0.3, 0.8]
    assert len(entry["shape"]) == 4 and entry["shape"][2] == 2
    assert manifest["max_error"] <= TOL and plan.bytes < plan.fixed_bytes
    mat = manifest["materials"]["brushed"]
    assert mat["coords"]["roughness"] == {"values": [0.4, 0.6], "index": [0, 1]}
    assert "0.9 a" in mat["formula"] and "[0, pi/2]" in mat["coords"]["phi_v"]


def test_aniso_table_meets_tol_against_exact_values(baked):
    _plan, manifest, out = baked
    (entry,) = manifest["tables"]
    table = read_exr(out / entry["file"])
    rng = np.random.default_rng(11)
    worst = 0.0
    for k in range(6):
        mu = float(rng.uniform(0.1, 1.0))
        phi = float(rng.uniform(0.0, 2.0 * math.pi))  # any azimuth: the renderer folds it
        rough = [0.4, 0.6][k % 2]
        a = float(rng.uniform(0.3, 0.8))
        folded = math.atan2(abs(math.sin(phi)), abs(math.cos(phi)))
        got = renderer_lookup(entry, table.channels["E"],
                              {"mu": [mu], "phi_v": [folded], "roughness": [rough], "anisotropy": [a]}, "linear")
        want = exact_albedo(mu, phi, *widths(rough * rough, a))
        worst = max(worst, abs(float(got.ravel()[0]) - want))
    assert worst <= TOL, worst


def test_aniso_scene_errors():
    bad = [({"type": "anisotropic", "alpha": 0.3}, "materials[0].anisotropy"),
           ({"type": "anisotropic", "alpha": 0.3, "anisotropy": 1.5}, "materials[0].anisotropy"),
           ({"type": "anisotropic", "alpha": 0.3, "anisotropy": 0.5, "distribution": "beckmann"},
            "materials[0].distribution"),
           ({"type": "anisotropic", "alpha": 0.3, "anisotropy": 0.5, "f0": 0.04}, "materials[0].f0"),
           ({"type": "schlick", "f0": 0.04, "alpha": 0.3, "anisotropy": 0.5}, "materials[0].anisotropy")]
    for mat, param in bad:
        with pytest.raises(SpecError) as info:
            parse_scene({"materials": [mat]})
        assert info.value.param == param, (mat, info.value.param)
