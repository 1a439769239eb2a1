"""Unity HDRP: the pre-integrated FGD texture (GGX part), sqrt(NdotV) axis with endpoints on texel centres."""

from __future__ import annotations

from .axes import unit_endpoints
from .recipe import Output, Preset

__all__ = ["PRESET_LIST"]

_DFG_B_E = (Output("B", ("B",)), Output("E", ("A", "B")))


PRESET_LIST = [
    Preset(
        name="unity-hdrp-fgd", peer="Unity HDRP pre-integrated FGD (GGX part)",
        description="(B, E), 64 x 64 [roughness, NdotV] with sqrt(NdotV) = i/63, endpoints on texel centres",
        axes=lambda: {"roughness": unit_endpoints(64), "mu": unit_endpoints(64) ** 2},
        table="dfg", shadowing="correlated", spec_axes={"mu": "mu", "roughness": "roughness"}, outputs=_DFG_B_E,
        conventions={
            "distribution": "GGX, isotropic", "shadowing": "height-correlated",
            "axes": "texture u = sqrt(NdotV) = i/63 (mu = u^2), v = perceptual roughness r_j = j/63 (alpha = r^2); "
            "endpoints on texel centres (lookup coordinate remapped by half a texel)",
            "value": "texture (x, y) = (B, E): specularFGD = lerp(x, y, f0), reflectivity = y",
            "layout": "[roughness, mu]: row j = perceptual roughness (texture v), column i = sqrt(NdotV) (texture u)",
            "not_reproduced": "HDRP samples 4096 Hammersley points with NDF sampling and stores 10-bit UNORM; "
            "the z channel (Disney diffuse FGD - 0.5) is not computed",
        },
    ),
]
