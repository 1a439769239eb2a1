"""Sheen tables as engines load them: Filament's cloth DFG channel, the glTF Sample Viewer's Charlie LUT.

- **Filament** (google/filament, ``libs/ibl`` cmgen ``DFV_Charlie`` with ``shaders/src/brdf.fs``
  ``D_Charlie`` and ``V_Neubelt``): the third channel of the DFG texture, 128 x 128, NoV and
  perceptual roughness r at texel centres (alpha = r^2), RGB16F: E = int D_Charlie V_Neubelt
  NoL dL, our ``sheen_albedo`` with ``sheen_shadowing = ashikhmin``. Baked as a HALF EXR
  (``half-exr``: float16, the storage of Filament's RGB16F; one channel, E).
- **glTF Sample Viewer** (KhronosGroup/glTF-Sample-Viewer ``source/shaders/ibl_filtering.frag``,
  ``LUT()`` with ``u_distribution = cCharlie``): the blue channel of the Charlie LUT, E of
  D_Charlie with ``V_Ashikhmin`` = clamp(1 / (4 (NdotL + NdotV - NdotL NdotV)), 0, 1) (the clamp
  is not reproduced: it only changes texels with NdotV + NdotL - NdotV NdotL < 1/4), at
  the same resolution and axes as its GGX LUT (``lutResolution = 1024``, texel centres, u =
  NdotV, v = sheen roughness, alpha = r^2), stored as an 8-bit PNG (``lut_charlie.png``); the
  Charlie sample count and the exact PNG size were not verified against the shipped file.
- ``khr-sheen-E-fitted``: what the ``KHR_materials_sheen`` albedo scaling
  ``1 - max(sheenColor) E(NdotV, sheenRoughness)`` means with the glTF shading model's own
  visibility (the Estevez-Kulla fitted Lambda, ``V_Sheen``): 32 x 32 at texel centres, float32,
  clamped to [0, 1]. The Sample Viewer's shipped ``lut_sheen_E.png`` was not available to compare;
  it is a PNG, which holds only [0, 1], so the reference's E never exceeds 1 and its albedo scaling
  is never negative. The fitted E itself exceeds 1 at grazing NdotV (1 + 1/(1 + 4 alpha) at
  NdotV = 0; on this grid 5 texels of the first NdotV column, roughness 3/64 .. 11/64, up to 1.454),
  where 1 - max(sheenColor) E would be negative: the clamp (its change added to ``E_err``, as every
  preset clamp) makes those texels 1, as the reference's storage does.

Each preset subclasses :class:`~.recipe.Preset` only to leave the microfacet distribution and
shadowing out of its spec; the sheen table's ``sheen_shadowing`` is in the preset's ``options``.
"""

from __future__ import annotations

from dataclasses import dataclass

from .axes import unit_centers
from .recipe import Output, Preset

__all__ = ["PRESET_LIST", "SheenPreset"]


@dataclass(frozen=True)
class SheenPreset(Preset):
    """A :class:`~.recipe.Preset` of a ``sheen_albedo`` table: no distribution or microfacet
    shadowing (its ``sheen_shadowing`` choice is in ``options``)."""

    def spec(self, axes: dict) -> dict:
        spec = super().spec(axes)
        spec.pop("shadowing", None)
        spec.pop("distribution", None)
        return spec


_E = (Output("E", ("E",)),)

PRESET_LIST = [
    SheenPreset(
        name="filament-dfg-cloth", peer="Filament DFG texture, third channel (cloth, D_Charlie x V_Neubelt)",
        description="sheen albedo E, 128 x 128 [roughness, NoV] at texel centres, RGB16F (blue channel)",
        axes=lambda: {"roughness": unit_centers(128), "mu": unit_centers(128)},
        table="sheen_albedo", shadowing="correlated", spec_axes={"mu": "mu", "roughness": "roughness"},
        outputs=_E, options={"sheen_shadowing": "ashikhmin"},
        conventions={"distribution": "Charlie (Estevez and Kulla 2017), alpha = r^2",
                     "visibility": "V_Neubelt = 1 / (4 (NoL + NoV - NoL NoV)), unclamped",
                     "axes": "NoV_i = (i + 0.5)/128 (u), perceptual roughness r_j = (j + 0.5)/128 (v)",
                     "layout": "[roughness, mu]", "storage": "float16 (RGB16F with the DFG (A, B) or (B, E))",
                     "not_reproduced": "Filament's uniform-hemisphere Monte Carlo (its sample noise); the DFG "
                     "channels themselves are the filament-dfg presets"},
        file_format="half-exr", storage="float16",
    ),
    SheenPreset(
        name="gltf-charlie-lut", peer="glTF Sample Viewer Charlie LUT (u_CharlieLUT, lut_charlie.png, blue)",
        description="sheen albedo E (D_Charlie x V_Ashikhmin), 1024 x 1024 [roughness, NdotV] at texel centres, "
        "8-bit PNG",
        axes=lambda: {"roughness": unit_centers(1024), "mu": unit_centers(1024)},
        table="sheen_albedo", shadowing="correlated", spec_axes={"mu": "mu", "roughness": "roughness"},
        outputs=_E, options={"sheen_shadowing": "ashikhmin"}, clamp01=True,
        conventions={"distribution": "Charlie, sheenRoughness clamped at 1e-6, alpha = r^2",
                     "visibility": "V_Ashikhmin = clamp(1 / (4 (NdotL + NdotV - NdotL NdotV)), 0, 1)",
                     "axes": "NdotV_i = (i + 0.5)/1024 (u), sheen roughness r_j = (j + 0.5)/1024 (v), as the GGX LUT",
                     "layout": "[roughness, mu]", "storage": "8-bit PNG (unorm8), linear",
                     "not_reproduced": "the V clamp inside the integral (texels with NdotV + NdotL - NdotV NdotL "
                     "< 1/4 reachable: grazing NdotV); the sampler's Hammersley noise; E is clamped to [0, 1] "
                     "as an 8-bit texture stores it"},
        file_format="png", storage="unorm8",
    ),
    SheenPreset(
        name="khr-sheen-E-fitted", peer="KHR_materials_sheen albedo scaling E(NdotV, sheenRoughness), fitted V",
        description="sheen albedo E with the Estevez-Kulla fitted Lambda (V_Sheen, clamped to [0, 1]), E clamped "
        "to [0, 1] as a PNG LUT holds it, 32 x 32 [roughness, NdotV] at texel centres",
        axes=lambda: {"roughness": unit_centers(32), "mu": unit_centers(32)},
        table="sheen_albedo", shadowing="correlated", spec_axes={"mu": "mu", "roughness": "roughness"},
        outputs=_E, options={"sheen_shadowing": "fitted"}, clamp01=True,
        conventions={"distribution": "Charlie, alpha = sheenRoughness^2",
                     "visibility": "V_Sheen = clamp(1 / ((1 + Lambda(NdotV) + Lambda(NdotL)) 4 NdotV NdotL), 0, 1), "
                     "Lambda the Estevez-Kulla fit",
                     "axes": "texel centres (i + 0.5)/32 in NdotV (u) and sheen roughness (v)", "layout": "[roughness, mu]",
                     "clamp": "E clamped to [0, 1], as the Sample Viewer's PNG LUT (lut_sheen_E.png) can only hold it: "
                     "the fitted E exceeds 1 at grazing NdotV (1 + 1/(1 + 4 alpha) at NdotV = 0; here 5 texels of "
                     "the first NdotV column, roughness 3/64 .. 11/64, up to 1.454), where the albedo scaling "
                     "1 - max(sheenColor) E would be negative; E_err includes what the clamp changed",
                     "not_reproduced": "the shipped lut_sheen_E.png (its resolution and generator were not verified)"},
    ),
]
