"""``albedo``: E(mu, alpha) = int f_r cos(theta_o) dw_o; ``albedo_avg``: 2 int E(mu) mu dmu."""

from __future__ import annotations

from ..axes import alpha_values
from ._common import Context, mu_average, run_grid


def compute(nspec: dict, axes: dict, ctx: Context) -> dict:
    values, errors = run_grid("reflect", nspec, axes, ctx)
    return {"E": values[..., 0], "E_err": errors[..., 0]}


def compute_avg(nspec: dict, axes: dict, ctx: Context) -> dict:
    values, errors = mu_average("reflect", nspec, alpha_values(axes), None, ctx)
    return {"E_avg": values[:, 0], "E_avg_err": errors[:, 0]}


KINDS = {
    "albedo": {
        "axes": ("mu", "alpha"),
        "channels": ("E",),
        "fresnel": "any",
        "description": "directional albedo E(mu, alpha) of the microfacet BRDF",
        "compute": compute,
    },
    "albedo_avg": {
        "axes": ("alpha",),
        "channels": ("E_avg",),
        "fresnel": "any",
        "description": "hemispherical average E_avg = 2 int_0^1 E(mu) mu dmu",
        "compute": compute_avg,
    },
}
