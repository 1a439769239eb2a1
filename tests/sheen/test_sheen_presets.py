"""Sheen presets: axes and layouts as the engines load them, values against the SciPy reference."""

import json
import math

import numpy as np
import pytest

from bsdf_tab.presets import GROUPS, build_preset, get_preset
from tests.sheen.test_sheen_albedo import E_ref

SHEEN_AXES = {
    "filament-dfg-cloth": {"roughness": (np.arange(128) + 0.5) / 128, "mu": (np.arange(128) + 0.5) / 128},
    "gltf-charlie-lut": {"roughness": (np.arange(1024) + 0.5) / 1024, "mu": (np.arange(1024) + 0.5) / 1024},
    "khr-sheen-E-fitted": {"roughness": (np.arange(32) + 0.5) / 32, "mu": (np.arange(32) + 0.5) / 32},
}


@pytest.mark.parametrize("name", sorted(SHEEN_AXES))
def test_sheen_preset_axes(name):
    axes = get_preset(name).axes()
    assert list(axes) == list(SHEEN_AXES[name])
    for k, v in SHEEN_AXES[name].items():
        np.testing.assert_allclose(axes[k], v, rtol=1e-12, atol=0)
    assert name in GROUPS["sheen"]


@pytest.mark.parametrize("name,mode", [("filament-dfg-cloth", "ashikhmin"), ("khr-sheen-E-fitted", "fitted")])
def test_sheen_preset_values(name, mode):
    i, j = 20 * len(SHEEN_AXES[name]["roughness"]) // 32, 25 * len(SHEEN_AXES[name]["mu"]) // 32
    t = build_preset(name, select={"roughness": [i], "mu": [j]})
    r, mu = SHEEN_AXES[name]["roughness"][i], SHEEN_AXES[name]["mu"][j]
    ref = E_ref(mu, r * r, mode)
    assert np.asarray(t.channels["E"]).shape == (1, 1)
    assert abs(float(t.channels["E"][0, 0]) - ref) < 1e-6
    (source,) = t.meta["spec"]["sources"]
    assert source["sheen_shadowing"] == mode and "parametrization" not in source
    assert not math.isnan(float(t.channels["E_err"][0, 0]))
