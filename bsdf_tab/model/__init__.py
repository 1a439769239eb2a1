"""Device code: microfacet model functions as Warp ``@wp.func``.

Every function here is generic over the floating-point type: call it with ``wp.float32`` or
``wp.float64`` arguments (and ``wp.vec3f`` / ``wp.vec3d`` directions) from your own
``@wp.kernel``. Integer selectors (distribution, shadowing mode, Fresnel type) are
``wp.int32`` constants exported below.

Host-side registries (name -> integer id) for the other layers: :data:`DISTRIBUTIONS` (with
:data:`DISTRIBUTION_DESCRIPTIONS`), :data:`SHADOWINGS`, :data:`FRESNELS`.

Conventions follow Walter et al. 2007, "Microfacet Models for Refraction through Rough
Surfaces": local frame with macro normal n = +z, all directions unit vectors pointing away from
the surface, ``alpha`` is Walter's width parameter (alpha_g for GGX, alpha_b for Beckmann).

No I/O happens in this package: it is importable into any user's kernel module.
"""

import importlib

from .frame import cos_theta, sin2_theta, tan2_theta, reflect, refract, refract_k2, expm1_, log1p_
from .ggx import (
    ggx_D,
    ggx_lambda,
    ggx_lambda_cos,
    ggx_sample_vndf,
    ggx_dcos_sample_tan,
    ggx_dcos_tan_of_v,
    ggx_dcos_v_of_theta,
    ggx_dlnD_dcos,
)
from .beckmann import (
    beckmann_D,
    beckmann_lambda,
    beckmann_lambda_a2,
    beckmann_lambda_cos,
    beckmann_sample_vndf,
    beckmann_dcos_sample_tan,
    beckmann_dcos_tan_of_v,
    beckmann_dcos_v_of_theta,
    beckmann_dlnD_dcos,
)
from .distribution import (
    DISTRIBUTIONS,
    DISTRIBUTION_DESCRIPTIONS,
    distribution_id,
    GGX,
    BECKMANN,
    D,
    Lambda,
    lambda_cos,
    smith_G1,
    sample_vndf,
    pdf_vndf,
    dcos_sample_tan,
    dcos_tan_of_v,
    dcos_v_of_theta,
    dlnD_dcos,
)
from .shadowing import (
    SHADOWINGS,
    SEPARABLE,
    CORRELATED,
    smith_G,
    smith_G_over_cos_i,
    smith_G_over_cos_i_from_lambda,
    smith_G_over_cos_i_equal,
)
from .fresnel import (
    FRESNELS,
    FRESNEL_ONE,
    FRESNEL_SCHLICK,
    FRESNEL_DIELECTRIC,
    FRESNEL_CONDUCTOR,
    fresnel_schlick,
    fresnel_dielectric,
    fresnel_conductor,
    fresnel,
)
from .ggx_aniso import (  # imported by ggx anyway
    aniso_widths,
    ggx_aniso_D,
    ggx_aniso_G1,
    ggx_aniso_lambda,
    ggx_aniso_lambda_cos,
    ggx_aniso_pdf_vndf,
    ggx_aniso_sample_vndf,
)

# The models no integrator of the adaptive path calls (the BSDF point evaluation, the
# multiple-scattering compensation, the LTC lobe, the Charlie sheen) load on
# first use (PEP 562 ``__getattr__``): ``from bsdf_tab.model import charlie_D`` works as before,
# and a command that integrates isotropic tables (``plan``) does not define their Warp functions
# (17-20 ms of imports on the 2-core machine).
#: public name -> the submodule that defines it
_LAZY = {
    **dict.fromkeys(("brdf", "btdf"), "bsdf"),
    **dict.fromkeys(("kc_f_ms", "kc_F_ms", "kc_lobe", "kc_C", "fresnel_avg", "lerp_grid_1d", "lerp_grid_2d"),
                    "multiscatter"),
    **dict.fromkeys(("ltc_edge", "ltc_eval", "ltc_minv", "ltc_polygon_integral", "ltc_quad_integral"), "ltc"),
    **dict.fromkeys((
        "CHARLIE_ALPHA_MIN",
        "charlie_D",
        "charlie_lambda_cos_exact",
        "charlie_lambda_exact",
        "charlie_lambda_fitted",
        "charlie_pdf",
        "charlie_projected_area",
        "charlie_projected_area_table",
        "charlie_sample",
        "charlie_V_ashikhmin",
        "charlie_V_exact",
        "charlie_V_fitted",
    ), "charlie"),
}


def __getattr__(name: str):
    """A lazy model function (imported from its submodule on first access, then cached here),
    or a submodule not imported yet (``bsdf_tab.model.charlie`` after ``import bsdf_tab.model``)."""
    module = _LAZY.get(name)
    if module is not None:
        value = getattr(importlib.import_module(f".{module}", __name__), name)
        globals()[name] = value
        return value
    if name in set(_LAZY.values()):
        return importlib.import_module(f".{name}", __name__)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY) | set(_LAZY.values()))


__all__ = sorted({name for name in globals() if not name.startswith("_")} - {"importlib"}
                 | set(_LAZY) | set(_LAZY.values()))
