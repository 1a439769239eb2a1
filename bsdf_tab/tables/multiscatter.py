"""``kulla_conty``: Kulla-Conty 2017 energy compensation data on (mu, alpha), F = 1.

Channels (each with an ``_err`` channel):

- ``E``: single-scattering directional albedo E(mu, alpha) (as the ``albedo`` table, F = 1);
- ``E_avg``: E_avg(alpha) = 2 int_0^1 E(mu) mu dmu (as ``albedo_avg``), repeated along mu;
- ``C``: (1 - E) / sqrt(pi (1 - E_avg)), so the compensation lobe is
  f_ms(mu_i, mu_o) = C(mu_i) C(mu_o) = (1 - E(mu_i)) (1 - E(mu_o)) / (pi (1 - E_avg)).

Errors: E and E_avg carry the integrator's estimates; C's is propagated to first order,
dC = dE / sqrt(pi m) + (1 - E) dE_avg / (2 sqrt(pi) m^(3/2)), m = 1 - E_avg, evaluated with
m lowered by its error (never below that error). Where 1 - E_avg is not resolved
(alpha -> 0, nothing to compensate) C is set to 0 and its error says how large it could be.
"""

from __future__ import annotations

import numpy as np

from ..axes import alpha_values
from ._common import Context, mu_average, run_grid


def compensation(E, E_err, E_avg, E_avg_err):
    """(C, C_err) from E (mu, alpha) and E_avg (alpha) with their errors (NumPy, float64)."""
    E = np.asarray(E, dtype=np.float64)
    E_err = np.asarray(E_err, dtype=np.float64)
    miss = 1.0 - np.asarray(E_avg, dtype=np.float64)
    miss_err = np.asarray(E_avg_err, dtype=np.float64)
    resolved = miss > 2.0 * miss_err
    low = np.maximum(miss - miss_err, miss_err)  # the smallest plausible 1 - E_avg, > 0
    low = np.where(low > 0.0, low, np.finfo(np.float64).tiny)
    one_minus_e = np.maximum(1.0 - E, 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        C = np.where(resolved, one_minus_e / np.sqrt(np.pi * np.where(resolved, miss, 1.0)), 0.0)
        C_err = (E_err / np.sqrt(np.pi * low)
                 + (one_minus_e + E_err) * miss_err / (2.0 * np.sqrt(np.pi) * low**1.5))
        C_err = np.where(resolved, C_err, (one_minus_e + E_err) / np.sqrt(np.pi * low))
    return C, C_err


def compute(nspec: dict, axes: dict, ctx: Context) -> dict:
    values, errors = run_grid("reflect", nspec, axes, ctx)
    E, E_err = values[..., 0], errors[..., 0]
    avg, avg_err = mu_average("reflect", nspec, alpha_values(axes), None, ctx)
    E_avg = np.broadcast_to(avg[:, 0], E.shape).copy()
    E_avg_err = np.broadcast_to(avg_err[:, 0], E.shape).copy()
    C, C_err = compensation(E, E_err, E_avg, E_avg_err)
    return {"E": E, "E_avg": E_avg, "C": C, "E_err": E_err, "E_avg_err": E_avg_err, "C_err": C_err}


KINDS = {
    "kulla_conty": {
        "axes": ("mu", "alpha"),
        "channels": ("E", "E_avg", "C"),
        "fresnel": "one",
        "description": "Kulla-Conty 2017 multiple-scattering compensation: single-scattering E (F = 1), "
        "E_avg (repeated along mu) and C = (1 - E) / sqrt(pi (1 - E_avg)), so f_ms(i, o) = C(mu_i) C(mu_o)",
        "compute": compute,
        # chunked along alpha on a cluster: E_avg(alpha) is computed once per alpha
        "chunk_axis": 1,
    },
}
