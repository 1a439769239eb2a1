"""Host-side numerics of the LTC tables (Heitz, Dupuy, Hill, Neubelt 2016, "Real-Time
Polygonal-Light Shading with Linearly Transformed Cosines"), float64.

- :mod:`.lobe`: the true lobe f_r cos(theta_L) and its quadrature in micro-normal coordinates;
- :mod:`.matrix`: LTC matrices, the lobe density, the storage form, the L1 metrics, the mass above the horizon;
- :mod:`.fit`: the deterministic warm-started Nelder-Mead fit and the reported metric;
- :mod:`.kernels`: the fit's objective as a Warp kernel;
- :mod:`.sphere`: the horizon-clipped sphere form factor of the two-texture layout;
- :mod:`.polygon`: the clamped-cosine polygon integral with horizon clipping (NumPy);
- :mod:`.exact`: the true lobe integrated over quads (a graded Warp rule, float64);
- :mod:`.shading`: the fit's quad lights and the shading polish's objective (a Warp kernel).

The table kind is :mod:`bsdf_tab.tables.ltc`; the device functions for shaders written in Warp
are in :mod:`bsdf_tab.model.ltc`.
"""

from .fit import fit_metric, fit_metrics, fit_table
from .lobe import ALPHA_FLOOR, lobe_nodes, lobe_value
from .matrix import clipped_l1_metric, density, from_storage, l1_metric, storage, upper_mass
from .polygon import polygon_integral
from .sphere import cap_form_factor, sphere_term, sphere_term_at

__all__ = ["ALPHA_FLOOR", "cap_form_factor", "clipped_l1_metric", "density", "fit_metric", "fit_metrics", "fit_table",
           "from_storage", "l1_metric",
           "lobe_nodes", "lobe_value", "polygon_integral", "sphere_term", "sphere_term_at", "storage", "upper_mass"]
