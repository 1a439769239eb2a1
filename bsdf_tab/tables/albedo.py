"""``albedo``: E(mu, alpha) = int f_r cos(theta_o) dw_o; ``albedo_avg``: 2 int E(mu) mu dmu."""

from __future__ import annotations

from ..spec import alpha_values
from ._common import Context, mu_average, run_grid


def compute(nspec: dict, axes: dict, ctx: Context) -> dict:
    values, errors = run_grid("reflect", nspec, axes, ctx)
    return {"E": values[..., 0], "E_err": errors[..., 0]}


def compute_avg(nspec: dict, axes: dict, ctx: Context) -> dict:
    values, errors = mu_average("reflect", nspec, alpha_values(axes), None, ctx)
    return {"E_avg": values[:, 0], "E_avg_err": errors[:, 0]}
