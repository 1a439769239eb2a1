"""Adobe OpenPBR: the energy-complement tables (the anchors README: ``../shared/anchors/adobe_openpbr_bsdf``)."""

from __future__ import annotations

from .axes import openpbr_ior_axis, unit_endpoints
from .recipe import Output, Preset

__all__ = ["PRESET_LIST"]

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


_OPENPBR_AXES3 = {"ior": "adobe_openpbr_bsdf/axis_ior32.npy", "roughness": "adobe_openpbr_bsdf/axis_rough32.npy",
                  "cos": "adobe_openpbr_bsdf/axis_cos32.npy"}
_OPENPBR_AXES2 = {"ior": "adobe_openpbr_bsdf/axis_ior32.npy", "roughness": "adobe_openpbr_bsdf/axis_rough32.npy"}


PRESET_LIST = [
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
]
