"""Godot 4: the DFG texture of the Forward+ renderer.

From ``servers/rendering/renderer_rd/shaders/forward_clustered/integrate_dfg.glsl`` (Godot
4.x): 128 x 128 ``rgba16f``; texel (x, y) computed at NdotV = (x + 0.5)/128, roughness =
(y + 0.5)/128 (alpha = roughness^2) and stored at row ``127 - y``; the scene shader samples
``prefiltered_dfg(roughness, NoV) = texture(dfg, vec2(NoV, 1.0 - roughness))``
(``scene_forward_clustered_inc.glsl``). Channels: r = int Fc G_Vis (our B), g = int G_Vis (our
E = A + B, F = 1); specular = (f90 - f0) r + f0 g, energy compensation from g; b = the cloth
(Charlie) term, not here. Shadowing: Schlick-GGX G1 with k = alpha / 2, separable.

Godot's generator writes row y at roughness ``(SIZE - y + 0.5) / SIZE`` = (128.5 - y)/128
(``main()`` in integrate_dfg.glsl), one texel above the (127.5 - y)/128 its lookup
``1 - roughness`` reads there (row 0 at 1.0039); this preset follows the lookup, so it is the
table Godot's shader expects. Against Godot's own numbers (the shader run in NumPy,
``bench/compare_peers.py --engines``) the differences are its Schlick-GGX G: docs/presets.md.
"""

from __future__ import annotations

import numpy as np

from .axes import unit_centers
from .recipe import Output, Preset

__all__ = ["PRESET_LIST"]


def _flipped_centers(n: int) -> np.ndarray:
    """Row k of the texture holds roughness (n - 1 - k + 0.5)/n: decreasing down the rows."""
    return unit_centers(n)[::-1].copy()


PRESET_LIST = [
    Preset(
        name="godot-dfg", peer="Godot 4 DFG texture (integrate_dfg.glsl)",
        description="(B, E), 128 x 128 [roughness (rows top = 1), NoV], texel centres, RGBA16F",
        axes=lambda: {"roughness": _flipped_centers(128), "mu": unit_centers(128)},
        table="dfg", shadowing="separable", spec_axes={"mu": "mu", "roughness": "roughness"},
        outputs=(Output("B", ("B",)), Output("E", ("A", "B"))),
        conventions={
            "distribution": "GGX, isotropic",
            "shadowing": "separable Smith G1(i) G1(o) (Godot: Schlick-GGX G1 with k = alpha/2, an approximation)",
            "axes": "NoV_i = (i + 0.5)/128 (texture u, columns); row k holds roughness (127 - k + 0.5)/128, "
            "alpha = roughness^2: looked up at v = 1 - roughness",
            "value": "texture (r, g) = (B, E): r = int (f/F)(1 - v.h)^5 cos, g = int (f/F) cos (F = 1); "
            "specular = (f90 - f0) r + f0 g",
            "layout": "[roughness, mu] with roughness decreasing down the rows (row 0 = roughness 1 - 0.5/128)",
            "storage": "rgba16f image (float16)",
            "not_reproduced": "Godot's 1024 NDF samples and Schlick-GGX G; its generator's rows, computed one "
            "texel off its lookup at (128.5 - k)/128; the b (cloth / Charlie) channel",
        },
        file_format="ktx2", storage="float16",
    ),
]
