"""Bevy: the split-sum DFG (``f_ab``) of its environment-map lighting.

From ``crates/bevy_pbr/src/environment_map/environment_map.wgsl``: Bevy 0.10 sampled a BRDF LUT
texture, ``textureSample(environment_map_brdf_lut, s, vec2(NdotV, perceptual_roughness)).rg``
(no remap: texel centres), later versions compute the same ``f_ab`` analytically with
``F_AB(perceptual_roughness, NdotV)`` (Karis' mobile fit, ``pbr_lighting.wgsl``); both are used
as FssEss = kS f_ab.x + f_ab.y, Ess = f_ab.x + f_ab.y (Fdez-Agüera multiscattering). The shader
does not fix a size: 64 x 64 here. The fit's coefficients are Bevy's shipped numbers (compared
in docs/presets.md).
"""

from __future__ import annotations

from .axes import unit_centers
from .recipe import Output, Preset

__all__ = ["PRESET_LIST"]

PRESET_LIST = [
    Preset(
        name="bevy-dfg", peer="Bevy environment map f_ab (environment_map_brdf_lut / F_AB)",
        description="split-sum (A, B), 64 x 64 [perceptual roughness, NdotV] at texel centres, RG16F KTX2",
        axes=lambda: {"roughness": unit_centers(64), "mu": unit_centers(64)},
        table="dfg", shadowing="correlated", spec_axes={"mu": "mu", "roughness": "roughness"},
        outputs=(Output("A", ("A",)), Output("B", ("B",))),
        conventions={
            "distribution": "GGX, isotropic", "shadowing": "height-correlated Smith",
            "axes": "NdotV_i = (i + 0.5)/64 (texture u, columns), perceptual roughness r_j = (j + 0.5)/64 "
            "(texture v, rows), alpha = r^2",
            "value": "texture (r, g) = f_ab = (A, B): FssEss = kS r + g, Ess = r + g",
            "layout": "[roughness, mu]: row j = perceptual roughness, column i = NdotV; row 0 first",
            "storage": "RG16F KTX2 (Bevy loads KTX2); the resolution is ours, the shader does not fix one",
            "not_reproduced": "current Bevy evaluates Karis' analytic fit F_AB instead of a texture",
        },
        file_format="ktx2", storage="float16",
    ),
]
