"""The glTF Sample Viewer's GGX LUT (``u_GGXLUT``), as its IBL sampler bakes it.

From KhronosGroup/glTF-Sample-Viewer ``source/shaders/ibl_filtering.frag`` (``LUT(NdotV,
roughness)``: GGX NDF importance sampling, ``V_SmithGGXCorrelated`` with a2 = roughness^4, so
alpha = roughness^2; channels 4 (A, B) of the Schlick split) and ``source/ibl_sampler.js``
(``lutResolution = 1024``, one fragment per texel, uv at texel centres); the viewer samples
``texture(u_GGXLUT, vec2(NdotV, perceptualRoughness))`` with no remap (``source/shaders/ibl.glsl``),
``specular = specularColor brdf.x + brdf.y``. The Charlie (sheen) LUT of the same shader is the
preset ``gltf-charlie-lut`` (:mod:`.sheen`, group ``sheen``).
"""

from __future__ import annotations

from .axes import unit_centers
from .recipe import Output, Preset

__all__ = ["PRESET_LIST"]

PRESET_LIST = [
    Preset(
        name="gltf-ggx-lut", peer="glTF Sample Viewer GGX LUT (u_GGXLUT, lut_ggx.png)",
        description="split-sum (A, B), 1024 x 1024 [roughness, NdotV] at texel centres, 16-bit PNG",
        axes=lambda: {"roughness": unit_centers(1024), "mu": unit_centers(1024)},
        table="dfg", shadowing="correlated", spec_axes={"mu": "mu", "roughness": "roughness"},
        outputs=(Output("A", ("A",)), Output("B", ("B",))),
        conventions={
            "distribution": "GGX, isotropic", "shadowing": "height-correlated Smith (V_SmithGGXCorrelated)",
            "axes": "NdotV_i = (i + 0.5)/1024 (texture u, columns), perceptual roughness r_j = (j + 0.5)/1024 "
            "(texture v, rows), alpha = r^2; no coordinate remap in ibl.glsl",
            "value": "texture (r, g) = (A, B): specular = specularColor r + g; b = 0 (the Charlie LUT is apart)",
            "layout": "[roughness, mu]: row j = roughness (PNG row j from the top = texture v = (j + 0.5)/1024 "
            "when uploaded without a flip), column i = NdotV",
            "storage": "16-bit PNG, unorm16, linear (no colour conversion on upload)",
            "not_reproduced": "the sampler's 512-1024 NDF importance samples per texel; the Charlie (sheen) LUT "
            "(preset gltf-charlie-lut)",
        },
        file_format="png", storage="unorm16",
    ),
]
