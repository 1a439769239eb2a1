"""The engine presets as data: Blender Cycles, Adobe OpenPBR, Filament and Unity HDRP.

Each entry says which spec the peer's table follows from and how (see :mod:`.recipe`); the
conventions texts record what is reproduced and what is not. Sources: the anchors READMEs in
``../shared/anchors`` (axes, layouts and value conventions of the shipped tables).
"""

from __future__ import annotations

from .axes import cycles_axis, cycles_ior_axis, openpbr_ior_axis, unit_centers, unit_endpoints
from .recipe import Output, Preset

__all__ = ["GROUPS", "PRESETS"]

_CYCLES_COMMON = {
    "distribution": "GGX, isotropic",
    "shadowing": "height-correlated G2 = 1 / (1 + Lambda_i + Lambda_o)",
    "axes": "mu_j = clamp(j/(n-1), 1e-4, 1) (linear in cos theta_i); roughness r_i = clamp(i/(n-1), 1e-4, 1), "
    "alpha = r^2; lookup node i at coordinate i/(n-1)",
    "mirror_rule": "alpha^2 <= 5e-7 is a perfect mirror: E = 1 (roughness node 0)",
    "clamp": "values clamped to [0, 1]",
    "not_reproduced": "Cycles prints 6 decimals and integrates by Monte Carlo (VNDF, Sobol); ours are "
    "float64 quadrature values with error estimates",
}


def _glass_conventions(inverse: bool, avg: bool) -> dict:
    return {
        **_CYCLES_COMMON,
        "value": ("2 int_0^1 (R + T)(mu) mu dmu" if avg else "E = R + T")
        + ": dielectric, exact unpolarized Fresnel, transmission in the energy form (R + T -> 1 as alpha -> 0)",
        "eta": "eta = 1 / ior < 1 (light from inside)" if inverse else "eta = ior > 1 (light from outside)",
        "ior_axis": "z_k = clamp(k/15, 1e-4, 0.99), F0 = z^4, ior = (1 + z^2) / (1 - z^2); node k at coordinate k/15",
        "layout": "[ior, roughness]" if avg else "[ior, mu, roughness]",
    }


_OPENPBR_COMMON = {
    "distribution": "GGX, isotropic",
    "shadowing": "separable G = G1(i) G1(o) (OpenPBR's runtime shadowing)",
    "value": "energy complement 1 - E",
    "axes": "roughness r_i = i/31 (alpha = r^2), cos_j = j/31, node i at coordinate i/31",
    "not_reproduced": "OpenPBR stores uint16 UNORM (x 65535); ours are floats. Its generator is not public; "
    "it treats roughness 0 and cos 0 specially (0 there), ours are the quadrature values",
}


def _openpbr_dielectric_conventions(opaque: bool, avg: bool) -> dict:
    what = "R (reflection only)" if opaque else "R + T (transmission in the energy form)"
    return {
        **_OPENPBR_COMMON,
        "value": f"energy complement 1 - {'2 int_0^1 ' if avg else ''}{what}{' mu dmu' if avg else ''}"
        ", exact unpolarized dielectric Fresnel",
        "eta": "eta = ior (ior < 1: light from inside); ior_i for i < 16: 1/ior = 1 + 1.5 (15 - i)/15, "
        "i >= 16: ior = 1 + 1.5 (i - 16)/15 (1.0 twice)",
        "layout": "[ior, roughness]" if avg else "[ior, roughness, cos]",
    }


_FILAMENT_COMMON = {
    "distribution": "GGX, isotropic",
    "shadowing": "height-correlated (Filament's V_SmithGGXCorrelated)",
    "axes": "mu = NoV_i = (i + 0.5)/128, perceptual roughness r_j = (j + 0.5)/128 (texel centres), alpha = r^2",
    "layout": "[roughness, mu]: row j = roughness (texture v), column i = NoV (texture u); row 0 = v lowest",
    "not_reproduced": "Filament samples 1024 Hammersley points with NDF sampling and stores RGB16F; the third "
    "(cloth / Charlie) channel is not computed",
}

_CYCLES_MU_ROUGH = {"mu": "blender_cycles/axis_mu32.npy", "roughness": "blender_cycles/axis_rough32.npy"}
_CYCLES_GLASS_AXES = {"ior": "blender_cycles/axis_ior16.npy", "mu": "blender_cycles/axis_mu16.npy",
                      "roughness": "blender_cycles/axis_rough16.npy"}
_CYCLES_GLASS_AVG_AXES = {"ior": "blender_cycles/axis_ior16.npy", "roughness": "blender_cycles/axis_rough16.npy"}
_OPENPBR_AXES3 = {"ior": "adobe_openpbr_bsdf/axis_ior32.npy", "roughness": "adobe_openpbr_bsdf/axis_rough32.npy",
                  "cos": "adobe_openpbr_bsdf/axis_cos32.npy"}
_OPENPBR_AXES2 = {"ior": "adobe_openpbr_bsdf/axis_ior32.npy", "roughness": "adobe_openpbr_bsdf/axis_rough32.npy"}

_E_RT = (Output("E", ("R", "T")),)
_EAVG_RT = (Output("E_avg", ("R_avg", "T_avg")),)
_DFG_B_E = (Output("B", ("B",)), Output("E", ("A", "B")))

_PRESET_LIST = [
    Preset(
        name="cycles-ggx-E", peer="Blender Cycles ggx_E",
        description="GGX directional albedo, F = 1, 32 x 32 [mu, roughness]",
        axes=lambda: {"mu": cycles_axis(32), "roughness": cycles_axis(32)},
        table="albedo", shadowing="correlated", fresnel="one",
        spec_axes={"mu": "mu", "roughness": "roughness"}, outputs=(Output("E", ("E",)),),
        mirror_rule=True, clamp01=True,
        conventions={**_CYCLES_COMMON, "value": "directional albedo E, F = 1", "layout": "[mu, roughness]"},
        anchor="blender_cycles/ggx_E.npy", anchor_axes=_CYCLES_MU_ROUGH,
    ),
    Preset(
        name="cycles-ggx-Eavg", peer="Blender Cycles ggx_Eavg", description="GGX average albedo, F = 1, 32 [roughness]",
        axes=lambda: {"roughness": cycles_axis(32)},
        table="albedo_avg", shadowing="correlated", fresnel="one",
        spec_axes={"roughness": "roughness"}, outputs=(Output("E_avg", ("E_avg",)),),
        mirror_rule=True, clamp01=True,
        conventions={**_CYCLES_COMMON, "value": "E_avg = 2 int_0^1 E(mu) mu dmu, F = 1", "layout": "[roughness]"},
        anchor="blender_cycles/ggx_Eavg.npy", anchor_axes={"roughness": "blender_cycles/axis_rough32.npy"},
    ),
    Preset(
        name="cycles-ggx-glass-E", peer="Blender Cycles ggx_glass_E",
        description="GGX glass R + T, eta = ior > 1, 16^3 [ior, mu, roughness]",
        axes=lambda: {"ior": cycles_ior_axis(16), "mu": cycles_axis(16), "roughness": cycles_axis(16)},
        table="dielectric", shadowing="correlated", fresnel="dielectric",
        spec_axes={"mu": "mu", "roughness": "roughness", "eta": "ior"}, outputs=_E_RT,
        mirror_rule=True, clamp01=True, conventions=_glass_conventions(False, False),
        anchor="blender_cycles/ggx_glass_E.npy", anchor_axes=_CYCLES_GLASS_AXES,
    ),
    Preset(
        name="cycles-ggx-glass-inv-E", peer="Blender Cycles ggx_glass_inv_E",
        description="GGX glass R + T, eta = 1/ior < 1, 16^3 [ior, mu, roughness]",
        axes=lambda: {"ior": cycles_ior_axis(16), "mu": cycles_axis(16), "roughness": cycles_axis(16)},
        table="dielectric", shadowing="correlated", fresnel="dielectric",
        spec_axes={"mu": "mu", "roughness": "roughness", "eta": ("1/", "ior")}, outputs=_E_RT,
        mirror_rule=True, clamp01=True, conventions=_glass_conventions(True, False),
        anchor="blender_cycles/ggx_glass_inv_E.npy", anchor_axes=_CYCLES_GLASS_AXES,
    ),
    Preset(
        name="cycles-ggx-glass-Eavg", peer="Blender Cycles ggx_glass_Eavg",
        description="GGX glass average R + T, eta = ior > 1, 16^2 [ior, roughness]",
        axes=lambda: {"ior": cycles_ior_axis(16), "roughness": cycles_axis(16)},
        table="dielectric_avg", shadowing="correlated", fresnel="dielectric",
        spec_axes={"roughness": "roughness", "eta": "ior"}, outputs=_EAVG_RT,
        mirror_rule=True, clamp01=True, conventions=_glass_conventions(False, True),
        anchor="blender_cycles/ggx_glass_Eavg.npy", anchor_axes=_CYCLES_GLASS_AVG_AXES,
    ),
    Preset(
        name="cycles-ggx-glass-inv-Eavg", peer="Blender Cycles ggx_glass_inv_Eavg",
        description="GGX glass average R + T, eta = 1/ior < 1, 16^2 [ior, roughness]",
        axes=lambda: {"ior": cycles_ior_axis(16), "roughness": cycles_axis(16)},
        table="dielectric_avg", shadowing="correlated", fresnel="dielectric",
        spec_axes={"roughness": "roughness", "eta": ("1/", "ior")}, outputs=_EAVG_RT,
        mirror_rule=True, clamp01=True, conventions=_glass_conventions(True, True),
        anchor="blender_cycles/ggx_glass_inv_Eavg.npy", anchor_axes=_CYCLES_GLASS_AVG_AXES,
    ),
    Preset(
        name="openpbr-ideal-metal", peer="Adobe OpenPBR ideal_metal_energy_complement",
        description="GGX 1 - E, F = 1, separable, 32 x 32 [roughness, cos]",
        axes=lambda: {"roughness": unit_endpoints(32), "cos": unit_endpoints(32)},
        table="albedo", shadowing="separable", fresnel="one",
        spec_axes={"mu": "cos", "roughness": "roughness"},
        outputs=(Output("energy_complement", ("E",), complement=True),),
        conventions={**_OPENPBR_COMMON, "value": "energy complement 1 - E, F = 1", "layout": "[roughness, cos]"},
        anchor="adobe_openpbr_bsdf/ideal_metal_energy_complement.npy",
        anchor_axes={"roughness": "adobe_openpbr_bsdf/axis_rough32.npy", "cos": "adobe_openpbr_bsdf/axis_cos32.npy"},
    ),
    Preset(
        name="openpbr-ideal-metal-avg", peer="Adobe OpenPBR ideal_metal_avg_energy_complement",
        description="GGX 1 - E_avg, F = 1, separable, 32 [roughness]",
        axes=lambda: {"roughness": unit_endpoints(32)},
        table="albedo_avg", shadowing="separable", fresnel="one",
        spec_axes={"roughness": "roughness"},
        outputs=(Output("energy_complement", ("E_avg",), complement=True),),
        conventions={**_OPENPBR_COMMON, "value": "energy complement 1 - E_avg, F = 1", "layout": "[roughness]"},
        anchor="adobe_openpbr_bsdf/ideal_metal_avg_energy_complement.npy",
        anchor_axes={"roughness": "adobe_openpbr_bsdf/axis_rough32.npy"},
    ),
    Preset(
        name="openpbr-ideal-dielectric", peer="Adobe OpenPBR ideal_dielectric_energy_complement",
        description="GGX glass 1 - (R + T), separable, 32^3 [ior, roughness, cos]",
        axes=lambda: {"ior": openpbr_ior_axis(), "roughness": unit_endpoints(32), "cos": unit_endpoints(32)},
        table="dielectric", shadowing="separable", fresnel="dielectric",
        spec_axes={"mu": "cos", "roughness": "roughness", "eta": "ior"},
        outputs=(Output("energy_complement", ("R", "T"), complement=True),),
        conventions=_openpbr_dielectric_conventions(False, False),
        anchor="adobe_openpbr_bsdf/ideal_dielectric_energy_complement.npy", anchor_axes=_OPENPBR_AXES3,
    ),
    Preset(
        name="openpbr-ideal-dielectric-avg", peer="Adobe OpenPBR ideal_dielectric_avg_energy_complement",
        description="GGX glass 1 - (R_avg + T_avg), separable, 32^2 [ior, roughness]",
        axes=lambda: {"ior": openpbr_ior_axis(), "roughness": unit_endpoints(32)},
        table="dielectric_avg", shadowing="separable", fresnel="dielectric",
        spec_axes={"roughness": "roughness", "eta": "ior"},
        outputs=(Output("energy_complement", ("R_avg", "T_avg"), complement=True),),
        conventions=_openpbr_dielectric_conventions(False, True),
        anchor="adobe_openpbr_bsdf/ideal_dielectric_avg_energy_complement.npy", anchor_axes=_OPENPBR_AXES2,
    ),
    Preset(
        name="openpbr-opaque-dielectric", peer="Adobe OpenPBR opaque_dielectric_energy_complement",
        description="GGX dielectric reflection 1 - R, separable, 32^3 [ior, roughness, cos]",
        axes=lambda: {"ior": openpbr_ior_axis(), "roughness": unit_endpoints(32), "cos": unit_endpoints(32)},
        table="dielectric", shadowing="separable", fresnel="dielectric",
        spec_axes={"mu": "cos", "roughness": "roughness", "eta": "ior"},
        outputs=(Output("energy_complement", ("R",), complement=True),),
        conventions=_openpbr_dielectric_conventions(True, False),
        anchor="adobe_openpbr_bsdf/opaque_dielectric_energy_complement.npy", anchor_axes=_OPENPBR_AXES3,
    ),
    Preset(
        name="openpbr-opaque-dielectric-avg", peer="Adobe OpenPBR opaque_dielectric_avg_energy_complement",
        description="GGX dielectric reflection 1 - R_avg, separable, 32^2 [ior, roughness]",
        axes=lambda: {"ior": openpbr_ior_axis(), "roughness": unit_endpoints(32)},
        table="dielectric_avg", shadowing="separable", fresnel="dielectric",
        spec_axes={"roughness": "roughness", "eta": "ior"},
        outputs=(Output("energy_complement", ("R_avg",), complement=True),),
        conventions=_openpbr_dielectric_conventions(True, True),
        anchor="adobe_openpbr_bsdf/opaque_dielectric_avg_energy_complement.npy", anchor_axes=_OPENPBR_AXES2,
    ),
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

#: Preset name -> :class:`~.recipe.Preset`.
PRESETS: dict[str, Preset] = {p.name: p for p in _PRESET_LIST}
#: Group name -> member preset names.
GROUPS: dict[str, list[str]] = {
    "cycles": [n for n in PRESETS if n.startswith("cycles-")],
    "openpbr": [n for n in PRESETS if n.startswith("openpbr-")],
    "filament": ["filament-dfg", "filament-dfg-multiscatter"],
    "unity": ["unity-hdrp-fgd"],
}
