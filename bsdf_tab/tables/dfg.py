"""``dfg``: split-sum terms A = int (f_r/F)(1 - (1 - o.h)^5) cos, B = int (f_r/F)(1 - o.h)^5 cos.

For Schlick Fresnel, E = f0 A + B; with F = 1, A + B = E.
"""

from __future__ import annotations

from ._common import Context, run_grid


def compute(nspec: dict, axes: dict, ctx: Context) -> dict:
    values, errors = run_grid("dfg", nspec, axes, ctx)
    return {"A": values[..., 0], "B": values[..., 1], "A_err": errors[..., 0], "B_err": errors[..., 1]}


KINDS = {
    "dfg": {
        "axes": ("mu", "alpha"),
        "channels": ("A", "B"),
        "fresnel": "one",
        "description": "split-sum DFG terms: E = f0 A + B for Schlick Fresnel",
        "compute": compute,
    },
}
