"""Unreal Engine 4 style EnvBRDF: the ``PreintegratedGF`` system texture.

From ``Engine/Source/Runtime/Renderer/Private/SystemTextures.cpp`` (UE 4.x): 128 x 32,
``PF_G16R16`` (R16G16 UNORM, code ``(int)(clamp(x, 0, 1) * 65535 + 0.5)``) where supported
(else R8G8); x = NoV = (x + 0.5)/128, y = roughness = (y + 0.5)/32 (perceptual, m = r^2),
channels (A, B) with specular = SpecularColor A + B; looked up as
``PreIntegratedGF.SampleLevel(float2(NoV, Roughness))`` (``BasePassPixelShader`` /
``ReflectionEnvironmentShared.ush``: ``EnvBRDF``).
"""

from __future__ import annotations

from .axes import unit_centers
from .recipe import Output, Preset

__all__ = ["PRESET_LIST"]

PRESET_LIST = [
    Preset(
        name="unreal-envbrdf", peer="Unreal Engine 4 PreintegratedGF (EnvBRDF)",
        description="split-sum (A, B), 32 x 128 [roughness, NoV] at texel centres, R16G16 UNORM (DDS)",
        axes=lambda: {"roughness": unit_centers(32), "mu": unit_centers(128)},
        table="dfg", shadowing="correlated", spec_axes={"mu": "mu", "roughness": "roughness"},
        outputs=(Output("A", ("A",)), Output("B", ("B",))), clamp01=True,
        conventions={
            "distribution": "GGX, isotropic",
            "shadowing": "height-correlated Smith (UE uses Vis_SmithJointApprox, an approximation of it)",
            "axes": "NoV_i = (i + 0.5)/128 (texture u, columns), roughness r_j = (j + 0.5)/32 (texture v, rows), "
            "alpha = r^2",
            "value": "texture (r, g) = (A, B): EnvBRDF = SpecularColor A + B",
            "layout": "[roughness, mu]: row j = roughness, column i = NoV; row 0 first",
            "clamp": "values clamped to [0, 1] (as UE does before quantizing)",
            "storage": "PF_G16R16 = R16G16_UNORM, round(clamp(x, 0, 1) * 65535)",
            "not_reproduced": "UE's 128 Hammersley-like NDF samples per texel and Vis_SmithJointApprox; the R8G8 "
            "fallback; the third (diffuse) channel of the A16B16G16R16 variant",
        },
        file_format="dds", storage="unorm16",
    ),
]
