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
from .bsdf import brdf, btdf
from .multiscatter import kc_f_ms, kc_F_ms, kc_lobe, kc_C, fresnel_avg, lerp_grid_1d, lerp_grid_2d
from .ltc import ltc_edge, ltc_eval, ltc_minv, ltc_polygon_integral, ltc_quad_integral
from .charlie import (
    CHARLIE_ALPHA_MIN,
    charlie_D,
    charlie_lambda_cos_exact,
    charlie_lambda_exact,
    charlie_lambda_fitted,
    charlie_pdf,
    charlie_projected_area,
    charlie_projected_area_table,
    charlie_sample,
    charlie_V_ashikhmin,
    charlie_V_exact,
    charlie_V_fitted,
)
from .ggx_aniso import (
    aniso_widths,
    ggx_aniso_D,
    ggx_aniso_G1,
    ggx_aniso_lambda,
    ggx_aniso_lambda_cos,
    ggx_aniso_pdf_vndf,
    ggx_aniso_sample_vndf,
)

__all__ = [name for name in dir() if not name.startswith("_")]
