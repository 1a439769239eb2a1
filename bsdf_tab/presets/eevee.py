"""Blender EEVEE (Next, Blender 4.x): the split-sum BRDF LUT and the BTDF LUT for IOR > 1.

From ``source/blender/draw/engines/eevee_next/shaders/eevee_lut_comp.glsl`` (the generator of
the arrays in ``eevee_lut.cc``, declared in ``eevee_lut.hh``): texel (x, y, z) at
lut_coord = id / (extent - 1), i.e. nodes on both ends with node i at texel centre i (the
lookup remaps by half a texel, ``lut_coords``); perceptual roughness r = lut_coord, GGX alpha
= r^2; ``NV = clamp(1 - y^2, 1e-4, 0.9999)`` (y = sqrt(1 - cos theta)); VNDF sampling with
weight G1(L) from ``bxdf_ggx_eval_reflection`` / ``_refraction``, i.e. separable Smith
G1(V) G1(L).

- ``brdf_ggx[64][64][2]`` [y][x] (``bsdf_split_sum_ggx`` in older EEVEE Next; the generator now
  also returns metal_bias, the F82 tint term, not here): (scale, bias) with Schlick's
  (1 - v.h)^5 split, F0 scale + F90 bias. Measured against the shipped rows y = 56..63:
  mean |diff| 3e-5 (docs/presets.md), and correlated shadowing would be off by 0.36.
- ``btdf_ggx[16][64][64][1]`` [z = roughness][y][x]: IOR > 1 with x = sqrt((ior - 1)/(ior + 1))
  (f = clamp(x^2, 1e-4, 0.9999), ior = (1 + f)/(1 - f)); EEVEE stores the Schlick factor
  int (1 - (1 - |h.v|)^5) btdf cos, used as transmittance = (1 - F0) factor, F0 = f^2 =
  ((ior - 1)/(ior + 1))^2 (the shader's ``bsdf_lut``). This preset stores T / (1 - F0) with the
  exact transmittance T (exact unpolarized Fresnel), so that EEVEE's shader, multiplying by
  1 - F0, gets the exact T: it drops in, and is more accurate than EEVEE's Schlick factor.
  EEVEE's last IOR node is x = 1: f = 0.9999, ior = 19999, beyond the spec's eta domain
  (<= 100); it is computed at ior 100. The stored ratio T / (1 - F0) varies slowly at large ior
  (both T and 1 - F0 fall like 4/ior), so the shader's (1 - F0(19999)) x ratio(100) is close to
  T at 19999.

Both are uploaded into EEVEE's utility texture array (64 x 64 layers, RGBA16F).
"""

from __future__ import annotations

import numpy as np

from .axes import unit_endpoints
from .recipe import Output, Preset

__all__ = ["EEVEE_IOR_CAP", "PRESET_LIST", "eevee_btdf_ior_axis", "eevee_mu_axis"]

#: The spec's eta domain ends at 100; EEVEE's last IOR node (x = 1: ior 19999) is computed there.
EEVEE_IOR_CAP = 100.0


def _one_over_one_minus_f0(axes: dict) -> np.ndarray:
    """1 / (1 - F0(ior)) on the [roughness, mu, ior] layout: EEVEE multiplies the texel by 1 - F0."""
    ior = np.asarray(axes["ior"], dtype=np.float64)
    f0 = ((ior - 1.0) / (ior + 1.0)) ** 2  # ior >= 1.0002 here: 1 - f0 >= 0.039 (ior <= 100)
    return (1.0 / (1.0 - f0))[None, None, :]


def eevee_mu_axis(n: int = 64) -> np.ndarray:
    """``NV = clamp(1 - y^2, 1e-4, 0.9999)``, y = j/(n - 1): decreasing from 0.9999 to 1e-4."""
    return np.clip(1.0 - unit_endpoints(n) ** 2, 1e-4, 0.9999)


def eevee_btdf_ior_axis(n: int = 64) -> np.ndarray:
    """``f = clamp((i/(n-1))^2, 1e-4, 0.9999)``, ``ior = (1 + f)/(1 - f)``, capped at 100."""
    f = np.clip(unit_endpoints(n) ** 2, 1e-4, 0.9999)
    return np.minimum((1.0 + f) / (1.0 - f), EEVEE_IOR_CAP)


_COMMON = {
    "distribution": "GGX, isotropic",
    "shadowing": "separable Smith G1(V) G1(L) (EEVEE: VNDF sampling weighted by G1(L))",
    "axes": "lut_coord = id/(extent - 1) (endpoints on texel centres); y: NV = clamp(1 - y^2, 1e-4, 0.9999); "
    "perceptual roughness r = lut_coord, alpha = r^2",
    "storage": "float32 arrays in eevee_lut.cc, uploaded into the RGBA16F utility texture array",
}

PRESET_LIST = [
    Preset(
        name="eevee-brdf-split-sum", peer="Blender EEVEE brdf_ggx (split-sum BRDF LUT)",
        description="(scale, bias) = (A, B), 64 x 64 [y = sqrt(1 - NV), roughness], endpoints on texel centres",
        axes=lambda: {"mu": eevee_mu_axis(64), "roughness": unit_endpoints(64)},
        table="dfg", shadowing="separable", spec_axes={"mu": "mu", "roughness": "roughness"},
        outputs=(Output("A", ("A",)), Output("B", ("B",))),
        conventions={
            **_COMMON,
            "value": "texture (r, g) = (A, B): F0 r + F90 g (Schlick split, (1 - v.h)^5)",
            "layout": "[y][x] = [mu, roughness]: row j at y = j/63 (NV = clamp(1 - y^2, 1e-4, 0.9999), decreasing), "
            "column i = roughness i/63",
            "not_reproduced": "EEVEE's 512^2 VNDF Hammersley samples; the third (metal_bias, F82 tint) channel",
        },
        file_format="ktx2", storage="float16",
    ),
    Preset(
        name="eevee-btdf", peer="Blender EEVEE btdf_ggx (BTDF LUT, IOR > 1)",
        description="transmittance T, 16 x 64 x 64 [roughness, y = sqrt(1 - NV), x = sqrt((ior-1)/(ior+1))]",
        axes=lambda: {"roughness": unit_endpoints(16), "mu": eevee_mu_axis(64), "ior": eevee_btdf_ior_axis(64)},
        table="dielectric", shadowing="separable",
        spec_axes={"mu": "mu", "roughness": "roughness", "eta": "ior"},
        outputs=(Output("T", ("T",), scale=_one_over_one_minus_f0),),
        conventions={
            **_COMMON,
            "value": "T / (1 - F0), F0 = ((ior - 1)/(ior + 1))^2, T the transmitted energy (exact unpolarized "
            "Fresnel, energy form), eta = ior > 1: EEVEE's shader multiplies the texel by (1 - F0) and gets T "
            "(EEVEE's own table holds int (1 - (1 - |h.v|)^5) btdf cos, Schlick's factor)",
            "ior_axis": "x_i = i/63, f = clamp(x^2, 1e-4, 0.9999), ior = (1 + f)/(1 - f) (1.0002 .. 19999); "
            "node 63 computed at ior = 100, the end of the spec's eta domain",
            "layout": "[z][y][x] = [roughness (16 layers, r = k/15), mu (as the BRDF LUT), ior]",
            "not_reproduced": "EEVEE's Schlick transmission factor (exact Fresnel here, divided by 1 - F0 so the "
            "shader's product is exact); its 512^2 samples; the "
            "bsdf_ggx table for IOR < 1",
        },
        file_format="ktx2", storage="float16",
    ),
]
