"""The entries of the table kinds whose modules define Warp kernels of their own (``bsdf``,
``ltc``, ``sheen_albedo``, ``sheen_albedo_avg``, ``albedo_aniso``): declared here, so that the
catalog (:data:`bsdf_tab.tables.CATALOG`, what the spec validates against) does not import those
modules. Their functions are :class:`Deferred`: the kind's module is imported on the first call
(``bsdf-tab plan``, which tabulates ``albedo``, ``dfg`` and ``dielectric`` only, never defines
their kernels: 35 ms of imports on the 2-core machine). The constants the entries need live here too; the modules
import them from here.
"""

from __future__ import annotations

import importlib


class Deferred:
    """``module.name`` of this package, imported on the first call (then called directly)."""

    __slots__ = ("module", "name", "_fn")

    def __init__(self, module: str, name: str):
        self.module, self.name, self._fn = module, name, None

    def resolve(self):
        """The function itself (importing its module)."""
        if self._fn is None:
            self._fn = getattr(importlib.import_module(f".{self.module}", __package__), self.name)
        return self._fn

    def __call__(self, *args, **kwargs):
        return self.resolve()(*args, **kwargs)

    def __reduce__(self):  # pickled by name (a cluster worker imports the module itself)
        return (Deferred, (self.module, self.name))

    def __repr__(self) -> str:
        return f"Deferred({__package__}.{self.module}.{self.name})"


#: The shadowing choices (the spec's ``sheen_shadowing`` of the sheen kinds) -> kernel mode.
SHEEN_SHADOWINGS = {"fitted": 0, "exact": 1, "ashikhmin": 2}
SHEEN_PARAMS = {
    "methods": ("gauss_kronrod",),
    "keys": {
        "sheen_shadowing": {
            "choices": tuple(SHEEN_SHADOWINGS),
            "default": "fitted",
            "legacy": "parametrization",  # the spelling before the key existed (still accepted)
            "description": "the Charlie shadowing / visibility: fitted (Estevez-Kulla fitted Lambda, glTF V_Sheen "
            "clamped to [0, 1]), exact (the Smith Lambda of D, height-correlated), ashikhmin (Filament V_Neubelt)",
        },
    },
}

LTC_MATRIX_CHANNELS = ("Minv_00", "Minv_20", "Minv_02", "Minv_22", "M_00", "M_20", "M_02", "M_22")
LTC_CHANNELS = LTC_MATRIX_CHANNELS + ("E", "fresnel", "sphere", "horizon", "magnitude", "magnitude_fresnel",
                                       "fit_l1", "fit_l1_clipped")
LTC_AMPLITUDES = ("horizon", "albedo", "shading")


BSDF_KINDS = {
    "bsdf": {
        # axes of the default parametrization; see "parametrizations"
        "axes": ("theta_i", "theta_o", "phi_d"),
        "channels": ("f_r", "f_t"),
        "fresnel": "any",
        "methods": ("point",),
        "params": ("alpha", "roughness", "parametrization"),
        "parametrizations": {
            "angles": ("theta_i", "theta_o", "phi_d"),
            "half_diff": ("theta_h", "theta_d", "phi_d"),
        },
        "description": "BSDF values f_r (reflection) and f_t (transmission, dielectric Fresnel) of one "
        "material on an angular grid: plain angles or Rusinkiewicz half/difference angles (MERL layout)",
        "compute": Deferred("bsdf", "compute"),
        "blocks": Deferred("bsdf", "blocks"),
    },
}

LTC_KINDS = {
    "ltc": {
        "axes": ("mu", "alpha"),
        "channels": LTC_CHANNELS,
        "fresnel": "one",
        "description": "Linearly Transformed Cosine fit (Heitz et al. 2016) of the BRDF lobe f_r cos / E: "
        "Minv / Minv_11 entries (Minv_00, Minv_20, Minv_02, Minv_22: the ltc_1 RGBA of the public code and "
        "three.js), M = its inverse, the exact albedo E, the Schlick split amplitude fresnel (ltc_2.y), the "
        "clipped-sphere term sphere (ltc_2.w at u = roughness, v = sqrt(1 - mu)) and the L1 fit error fit_l1 "
        "= int |D_ltc - f_r cos / E| in [0, 2]; horizon (the lobe's mass above the horizon), magnitude and "
        "magnitude_fresnel (the amplitudes shading multiplies the polygon integral by: E / horizon, fresnel / horizon "
        "with amplitude horizon, E and fresnel with amplitude albedo) and fit_l1_clipped (int over the upper "
        "hemisphere of |(magnitude / E) D_ltc - f_r cos / E|: E fit_l1_clipped / 2 bounds the shading error of a "
        "light above the horizon with the horizon amplitude)",
        "keys": {
            "amplitude": {
                "choices": LTC_AMPLITUDES,
                "default": "horizon",
                "description": "the shading amplitude and the fit objective: horizon (magnitude = E / the LTC's mass "
                "above the horizon, the fit minimizes fit_l1_clipped), albedo (magnitude = E as the public code "
                "stores it, the fit minimizes fit_l1) or shading (the horizon fit, then the matrix and magnitude = "
                "s E / horizon polished on fit_l1_clipped + 100 x the mean shading error over 96 fixed quad lights per "
                "texel with fit_l1 (fine fit rule) held within 0.5% of the fit's (grazing rows, mu <= 0.22: + fit_l1, unconstrained); a "
                "light above the horizon is shaded within E (fit_l1_clipped + |s - 1|) / 2)",
            },
        },
        "compute": Deferred("ltc", "compute"),
    },
}

SHEEN_KINDS = {
    "sheen_albedo": {
        "axes": ("mu", "alpha"),
        "channels": ("E",),
        "fresnel": "one",
        "description": "directional albedo E(mu, alpha) of the Charlie sheen BRDF (Estevez and Kulla 2017), "
        "alpha = sheenRoughness^2; sheen_shadowing: fitted (glTF V_Sheen), exact (Smith), "
        "ashikhmin (Filament V_Neubelt)",
        "compute": Deferred("sheen", "compute"),
        **SHEEN_PARAMS,
    },
    "sheen_albedo_avg": {
        "axes": ("alpha",),
        "channels": ("E_avg",),
        "fresnel": "one",
        "description": "hemispherical average 2 int_0^1 E(mu) mu dmu of the Charlie sheen albedo; "
        "sheen_shadowing: fitted, exact, ashikhmin",
        "compute": Deferred("sheen", "compute_avg"),
        **SHEEN_PARAMS,
    },
}

ANISO_KINDS = {
    "albedo_aniso": {
        "axes": ("mu", "phi_v", "alpha", "anisotropy"),
        "channels": ("E",),
        "fresnel": "one",
        "methods": ("gauss_kronrod",),
        "description": "directional albedo E(mu, phi_v, alpha, anisotropy) of anisotropic GGX (F = 1): "
        "alpha_x = alpha / sqrt(1 - 0.9 a), alpha_y = alpha sqrt(1 - 0.9 a) (alpha = sqrt(alpha_x alpha_y)), "
        "phi_v = view azimuth from the tangent (alpha_x) direction",
        "compute": Deferred("aniso", "compute"),
    },
}
