"""three.js: the DFG texture behind its IBL (``src/renderers/shaders/DFGLUTData.js``).

16 x 16 RG16F, index [row, column] = [NoV, perceptual roughness] as in memory, both at texel
centres (i + 0.5)/16 (the shader samples ``texture(dfgLUT, vec2(roughness, dotNV))`` with no
remap), channels (scale, bias) of the Schlick split: specular = f0 scale + bias
(``../shared/anchors/threejs/README``). The shipped table is in the anchors
(``threejs/dfg_lut16.npy``); ``tests/presets/test_engine_presets.py`` and docs/presets.md compare.
"""

from __future__ import annotations

from .axes import unit_centers
from .recipe import Output, Preset

__all__ = ["PRESET_LIST"]

PRESET_LIST = [
    Preset(
        name="threejs-dfg", peer="three.js DFGLUTData (dfgLUT)",
        description="split-sum (scale, bias) = (A, B), 16 x 16 [NoV, roughness] at texel centres, RG16F",
        axes=lambda: {"mu": unit_centers(16), "roughness": unit_centers(16)},
        table="dfg", shadowing="correlated", spec_axes={"mu": "mu", "roughness": "roughness"},
        outputs=(Output("A", ("A",)), Output("B", ("B",))),
        conventions={
            "distribution": "GGX, isotropic", "shadowing": "height-correlated Smith",
            "axes": "NoV_i = (i + 0.5)/16 (texture v, rows), perceptual roughness r_j = (j + 0.5)/16 (texture u, "
            "columns), alpha = r^2; no coordinate remap in the shader",
            "value": "texture (r, g) = (A, B): specular = f0 r + g (A = int (f/F)(1 - (1 - v.h)^5) cos, "
            "B = int (f/F)(1 - v.h)^5 cos)",
            "layout": "[mu, roughness]: row i = NoV (texture v), column j = roughness (texture u); row 0 first",
            "storage": "RG16F (half floats in DFGLUTData.js)",
            "not_reproduced": "three.js' 4096-sample NDF-sampling noise (up to 1.4e-2 in scale)",
        },
        file_format="ktx2", storage="float16",
    ),
]
