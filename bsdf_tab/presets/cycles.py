"""Blender Cycles: the GGX albedo and glass tables of ``intern/cycles`` (the anchors README:
``../shared/anchors/blender_cycles``), with Cycles' mirror rule and the clamp to [0, 1]."""

from __future__ import annotations

from .axes import cycles_axis, cycles_ior_axis
from .recipe import Output, Preset

__all__ = ["PRESET_LIST"]

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


_CYCLES_MU_ROUGH = {"mu": "blender_cycles/axis_mu32.npy", "roughness": "blender_cycles/axis_rough32.npy"}
_CYCLES_GLASS_AXES = {"ior": "blender_cycles/axis_ior16.npy", "mu": "blender_cycles/axis_mu16.npy",
                      "roughness": "blender_cycles/axis_rough16.npy"}
_CYCLES_GLASS_AVG_AXES = {"ior": "blender_cycles/axis_ior16.npy", "roughness": "blender_cycles/axis_rough16.npy"}
_E_RT = (Output("E", ("R", "T")),)
_EAVG_RT = (Output("E_avg", ("R_avg", "T_avg")),)


PRESET_LIST = [
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
]
