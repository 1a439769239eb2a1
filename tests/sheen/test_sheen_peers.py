"""Our sheen albedo against a peer's published numbers: MaterialX's rational fit of the Imageworks
sheen directional albedo (coefficients from AcademySoftwareFoundation/MaterialX,
libraries/pbrlib/genglsl/lib/mx_microfacet_sheen.glsl; the formula is written in bench/sheen_peers.py).
Its convention: Charlie D with alpha = roughness, the Neubelt visibility, E clamped to [0, 1].
A fit, so a loose bound: on NdotV >= 1/4 it stays within 0.034 of our table (bench/sheen_peers.py,
32 x 32 texel centres); a wrong convention (alpha = roughness^2, or another visibility) is 0.1-0.3 off."""

from __future__ import annotations

import numpy as np

from bench.sheen_peers import materialx_fit
from bsdf_tab.tables.sheen import sheen_albedo_values


def test_materialx_fit_agrees_with_its_convention_only():
    c = np.linspace(0.3, 0.95, 6)
    r = np.linspace(0.1, 0.95, 6)
    C, R = np.meshgrid(c, r, indexing="ij")
    peer = materialx_fit(C, R)
    ours = np.clip(sheen_albedo_values(C, R, "ashikhmin")[0], 0.0, 1.0)
    d = np.abs(peer - ours)
    assert d.max() < 0.04 and d.mean() < 0.01, (d.max(), d.mean())
    wrong = np.clip(sheen_albedo_values(C, R * R, "ashikhmin")[0], 0.0, 1.0)  # alpha = roughness^2
    assert np.abs(peer - wrong).max() > 0.1
