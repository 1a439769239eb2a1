"""Filament: the split-sum DFG texture, single-scattering (A, B) and multiscatter (B, E) variants."""

from __future__ import annotations

from .axes import unit_centers
from .recipe import Output, Preset

__all__ = ["PRESET_LIST"]

_FILAMENT_COMMON = {
    "distribution": "GGX, isotropic",
    "shadowing": "height-correlated (Filament's V_SmithGGXCorrelated)",
    "axes": "mu = NoV_i = (i + 0.5)/128, perceptual roughness r_j = (j + 0.5)/128 (texel centres), alpha = r^2",
    "layout": "[roughness, mu]: row j = roughness (texture v), column i = NoV (texture u); row 0 = v lowest",
    "not_reproduced": "Filament samples 1024 Hammersley points with NDF sampling and stores RGB16F; the third "
    "(cloth / Charlie) channel is the preset filament-dfg-cloth (group sheen)",
}

_DFG_B_E = (Output("B", ("B",)), Output("E", ("A", "B")))


PRESET_LIST = [
    Preset(
        name="filament-dfg", peer="Filament DFG (single scattering)",
        description="split-sum (A, B), E = f0 A + B, 128 x 128 [roughness, NoV] at texel centres",
        axes=lambda: {"roughness": unit_centers(128), "mu": unit_centers(128)},
        table="dfg", shadowing="correlated", spec_axes={"mu": "mu", "roughness": "roughness"},
        outputs=(Output("A", ("A",)), Output("B", ("B",))),
        conventions={**_FILAMENT_COMMON,
                     "value": "(A, B) = (int (f/F)(1 - (1 - v.h)^5) cos, int (f/F)(1 - v.h)^5 cos): texture (x, y) "
                     "= (A, B), specular = f0 x + y"},
    ),
    Preset(
        name="filament-dfg-multiscatter", peer="Filament DFG (multiscatter variant)",
        description="(B, E) with E = A + B (F = 1), 128 x 128 [roughness, NoV] at texel centres",
        axes=lambda: {"roughness": unit_centers(128), "mu": unit_centers(128)},
        table="dfg", shadowing="correlated", spec_axes={"mu": "mu", "roughness": "roughness"}, outputs=_DFG_B_E,
        conventions={**_FILAMENT_COMMON,
                     "value": "texture (x, y) = (B, E): x = int (f/F)(1 - v.h)^5 cos (the Schlick-weighted 'scale' "
                     "term), y = E = int (f/F) cos (F = 1) = A + B; specular = mix(x, y, f0), energy compensation "
                     "1 + f0 (1/y - 1)"},
    ),
]
