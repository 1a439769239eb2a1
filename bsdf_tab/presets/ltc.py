"""Heitz et al. 2016 LTC tables (the public fitting code ``selfshadow/ltc_code``, as shipped by
three.js, Godot, Bevy and others), from the ``ltc`` table kind (GGX, height-correlated, F = 1).

Heitz, Dupuy, Hill, Neubelt 2016, "Real-Time Polygonal-Light Shading with Linearly Transformed
Cosines". Both presets are the ``ltc`` kind with ``amplitude: shading`` (the horizon fit, then the matrix and
the magnitude polished for the shading of quad lights: docs/ltc.md), 64 x 64, index [t, a]: x = t/63, cos(theta) = 1 - x^2, roughness
r = a/63, alpha = max(r^2, 1e-5) (``../shared/anchors/heitz_ltc`` README):

- ``heitz-ltc``: the anchors' layout (``fit/results/ltc.inc``: the matrix and its inverse,
  the magnitude), theta clamped to 1.57 as the public code does; the nonzero entries of M and
  Minv (both normalized to a middle entry of 1: an LTC does not depend on the matrix's scale).
- ``heitz-ltc-rgba``: the two RGBA textures of the current public code and three.js
  (``ltc_1`` = Minv / Minv_11 entries (Minv_00, Minv_20, Minv_02, Minv_22); ``ltc_2`` =
  (magnitude, Schlick amplitude, unused 0, clipped-sphere term), both amplitudes s / (the lobe's
  mass above the horizon)), sampled at
  uv = (roughness, sqrt(1 - cos theta)): the row t is at mu = 1 - (t/63)^2 exactly (mu = 0 on
  the last row), so that the sphere term ``ltc_2.w`` holds S(z = 2 a/63 - 1, l = t/63) there.
"""

from __future__ import annotations

import numpy as np

from .recipe import Output, Preset

__all__ = ["PRESET_LIST"]

#: the fit objective of both presets (docs/ltc.md)
_OPTIONS = {"amplitude": "shading"}

_N = 64


def _heitz_mu() -> np.ndarray:
    """The anchors' view axis: cos(min(1.57, acos(1 - x^2))), x = t/63."""
    x = np.arange(_N) / (_N - 1)
    return np.cos(np.minimum(1.57, np.arccos(1.0 - x * x)))


def _texture_mu() -> np.ndarray:
    """The texture's view axis: mu = 1 - x^2, x = t/63 (v = sqrt(1 - mu) = x)."""
    x = np.arange(_N) / (_N - 1)
    return 1.0 - x * x


def _alpha() -> np.ndarray:
    """alpha = max((a/63)^2, 1e-5)."""
    return np.maximum((np.arange(_N) / (_N - 1)) ** 2, 1e-5)


_COMMON = {
    "distribution": "GGX, isotropic",
    "shadowing": "height-correlated Smith G2 = 1 / (1 + Lambda(V) + Lambda(L)) (exact Lambda)",
    "fresnel": "F = 1 in the matrix and magnitude; the Schlick split amplitude separately",
    "fit": "the clipped L1 distance int over the upper hemisphere of |D_ltc / m_up - f_r cos / E| (fit_l1_clipped) "
    "minimized by deterministic Nelder-Mead on accurate quadrature, then the matrix and the amplitude s polished on "
    "fit_l1_clipped + 100 x the mean shading error over 96 fixed quad lights per texel, fit_l1 (fine fit rule) held within 0.5% of "
    "the fit's (at mu <= 0.22 + fit_l1 instead; exact integrals of the "
    "true lobe by a graded Warp rule; docs/ltc.md); E (fit_l1_clipped + |s - 1|) / 2 bounds the shading error of "
    "any light above the horizon; fit_l1 is the L1 distance of the normalized lobes on the sphere; the public code: "
    "Nelder-Mead on a 32 x 32-sample estimate of a cubed error, float32",
    "magnitude": "s E / m_up: the exact albedo E = int f_r cos dL (F = 1, adaptive quadrature) over the LTC lobe's "
    "mass above the horizon m_up (closed form), times the polished amplitude s (docs/ltc.md); the public code: E "
    "from a 1024-sample estimate",
    "frame": "V = (sin theta, 0, cos theta); the lobe D(L) = max(0, (Minv L)_z) |det Minv| / (pi |Minv L|^4)",
}

PRESET_LIST = [
    Preset(
        name="heitz-ltc", peer="Heitz et al. 2016 LTC fit (ltc_code fit/results/ltc.inc, the anchors' layout)",
        description="LTC matrix M and inverse (nonzero entries), magnitude and fit error, 64 x 64 [t, a]",
        axes=lambda: {"mu": _heitz_mu(), "alpha": _alpha()},
        table="ltc", shadowing="correlated", spec_axes={"mu": "mu", "alpha": "alpha"}, options=_OPTIONS,
        outputs=(
            Output("M_00", ("M_00",)), Output("M_20", ("M_20",)), Output("M_02", ("M_02",)), Output("M_22", ("M_22",)),
            Output("Minv_00", ("Minv_00",)), Output("Minv_20", ("Minv_20",)), Output("Minv_02", ("Minv_02",)),
            Output("Minv_22", ("Minv_22",)), Output("magnitude", ("magnitude",)), Output("fit_l1", ("fit_l1",)),
            Output("fit_l1_clipped", ("fit_l1_clipped",)), Output("albedo", ("E",)),
        ),
        conventions={
            **_COMMON,
            "axes": "index [t, a]: x = t/63, cos theta = 1 - x^2 with theta clamped to 1.57 (last row mu = cos 1.57), "
            "roughness a/63, alpha = max(r^2, 1e-5)",
            "layout": "row t (view), column a (roughness); the anchors' ltc_M[..., k] in glm order k = 3 col + row: "
            "k = 0 -> M_00, 2 -> M_20, 6 -> M_02, 8 -> M_22, 4 -> M_11 = 1 (here), the others 0; ltc_Minv likewise",
            "value": "M and Minv normalized to a middle entry of 1 (the anchors' are scaled otherwise: an LTC is "
            "invariant to the scale of M); magnitude = s E / m_up (the anchors': E), albedo = E; fit_l1 in [0, 2] and fit_l1_clipped "
            "with their error channels",
            "not_reproduced": "the public code's sampled fit and its float32 noise (that is the point)",
        },
        anchor="heitz_ltc/ltc_magnitude.npy",
        anchor_axes={"mu": "heitz_ltc/axis_cos_theta64.npy", "alpha": "heitz_ltc/axis_alpha64.npy"},
    ),
    Preset(
        name="heitz-ltc-rgba", peer="Heitz et al. 2016 LTC textures ltc_1 / ltc_2 (ltc_code, three.js)",
        description="the two RGBA textures: ltc_1 = Minv entries, ltc_2 = (magnitude, fresnel, -, sphere), 64 x 64",
        axes=lambda: {"mu": _texture_mu(), "alpha": _alpha()},
        table="ltc", shadowing="correlated", spec_axes={"mu": "mu", "alpha": "alpha"}, options=_OPTIONS,
        outputs=(
            Output("ltc1_r", ("Minv_00",)), Output("ltc1_g", ("Minv_20",)), Output("ltc1_b", ("Minv_02",)),
            Output("ltc1_a", ("Minv_22",)), Output("ltc2_r", ("magnitude",)), Output("ltc2_g", ("magnitude_fresnel",)),
            Output("ltc2_a", ("sphere",)), Output("fit_l1", ("fit_l1",)), Output("fit_l1_clipped", ("fit_l1_clipped",)),
        ),
        conventions={
            **_COMMON,
            "axes": "index [t, a]: texture v = x = t/63, mu = 1 - x^2 (mu = 0 on the last row; the public code "
            "clamps theta to 1.57 there), texture u = roughness a/63, alpha = max(r^2, 1e-5)",
            "layout": "row t = texture v, column a = texture u; the shader samples uv = (roughness, sqrt(1 - NoV)) "
            "* 63/64 + 0.5/64",
            "value": "ltc_1 (r, g, b, a) = Minv / Minv_11 entries (Minv_00, Minv_20, Minv_02, Minv_22): GLSL "
            "mat3(vec3(r, 0, g), vec3(0, 1, 0), vec3(b, 0, a)); ltc_2 (r, g, b, a) = (s E / m_up, s fresnel / m_up, 0, "
            "sphere) "
            "with specular = (f0 r + (1 - f0) g) x polygon integral; the unused ltc_2.b (0) is not stored; "
            "ltc_2.a = S(z = 2u - 1, l = v), the clipped-sphere form factor / l (u = sqrt(alpha): column 0 at "
            "u = 0.00316)",
            "not_reproduced": "the public code's sampled fit and magnitude; its theta clamp on the last row",
        },
    ),
]
