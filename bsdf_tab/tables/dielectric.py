"""``dielectric``: R(mu, alpha, eta) and T(mu, alpha, eta) of a rough dielectric interface.

eta = eta_o / eta_i (far side over the side of w_i): eta > 1 from outside a denser medium,
eta < 1 from inside (total internal reflection). T is the energy form (R + T -> 1 as alpha ->
0). ``dielectric_avg``: the 2 mu-weighted averages over mu.
"""

from __future__ import annotations

import math

import numpy as np

from ..axes import alpha_values
from ._common import Context, mu_average, run_grid


def compute(nspec: dict, axes: dict, ctx: Context) -> dict:
    values, errors = run_grid("dielectric", nspec, axes, ctx, eta_axis=np.asarray(axes["eta"]))
    return {
        "R": values[..., 0],
        "T": values[..., 1],
        "R_err": errors[..., 0],
        "T_err": errors[..., 1],
    }


def _critical_mu(alpha: float, eta: float) -> list[float]:
    # cosine of the critical angle: R(mu) has a kink there when alpha is small
    return [math.sqrt(1.0 - eta * eta)] if eta < 1.0 else []


def compute_avg(nspec: dict, axes: dict, ctx: Context) -> dict:
    alpha = alpha_values(axes)
    eta = np.asarray(axes["eta"], dtype=np.float64)
    a_grid, e_grid = np.meshgrid(alpha, eta, indexing="ij")
    values, errors = mu_average(
        "dielectric", nspec, a_grid.ravel(), e_grid.ravel(), ctx, breaks=_critical_mu
    )
    shape = a_grid.shape
    return {
        "R_avg": values[:, 0].reshape(shape),
        "T_avg": values[:, 1].reshape(shape),
        "R_avg_err": errors[:, 0].reshape(shape),
        "T_avg_err": errors[:, 1].reshape(shape),
    }


KINDS = {
    "dielectric": {
        "axes": ("mu", "alpha", "eta"),
        "channels": ("R", "T"),
        "fresnel": "axis",
        "description": "reflected R and transmitted T energy of a rough dielectric interface",
        "compute": compute,
    },
    "dielectric_avg": {
        "axes": ("alpha", "eta"),
        "channels": ("R_avg", "T_avg"),
        "fresnel": "axis",
        "description": "mu-weighted averages of R and T of a rough dielectric interface",
        "compute": compute_avg,
    },
}
