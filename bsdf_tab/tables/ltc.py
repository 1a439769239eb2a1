"""``ltc``: Linearly Transformed Cosine fits of the BRDF lobe on (mu, alpha), with the fit error.

Heitz, Dupuy, Hill, Neubelt 2016, "Real-Time Polygonal-Light Shading with Linearly Transformed
Cosines". Per texel (V = (sqrt(1 - mu^2), 0, mu), F = 1), the matrix M whose transformed
clamped cosine D_ltc(L) = max(0, (Minv L)_z) |det Minv| / (pi |Minv L|^4) best matches the
normalized lobe f_r(V, L) cos(theta_L) / E in the L1 sense (:mod:`bsdf_tab.ltc.fit`).

Channels (each with ``<X>_err``):

- ``Minv_00``, ``Minv_20``, ``Minv_02``, ``Minv_22``: Minv / Minv_11 (row, column), the
  storage form of the public code's ``ltc_1`` and three.js (RGBA = these four, in this order;
  GLSL ``mat3(vec3(x, 0, y), vec3(0, 1, 0), vec3(z, 0, w))``). Their errors are 0: the entries
  define the fitted lobe exactly; how well it fits is ``fit_l1``.
- ``M_00``, ``M_20``, ``M_02``, ``M_22``: the matrix M = (Minv / Minv_11)^-1 (M_11 = 1).
- ``E``: the albedo int f_r cos dL (F = 1), exact, from the table integrators (the ``dfg``
  grid through :func:`~bsdf_tab.tables._common.run_grid`, E = A + B); the LTC magnitude.
- ``fresnel``: int (f_r / F) (1 - V.h)^5 cos dL, the Schlick split's second amplitude
  (``ltc_2.y``): with Schlick F0 the reflected radiance is (F0 E + (1 - F0) fresnel) x the
  polygon integral.
- ``sphere``: the horizon-clipped sphere form factor ``ltc_2.w`` of the two-texture layout, at
  this texel's texture coordinates (u, v) = (roughness, sqrt(1 - mu)) (roughness = sqrt(alpha)
  on an alpha axis): S(2u - 1, v), :mod:`bsdf_tab.ltc.sphere`; its error is a rounding bound.
- ``horizon``: m_up, the LTC lobe's mass above the horizon, (1 + n_z) / 2 with n along M's row 2
  (closed form; error: a rounding bound).
- ``magnitude``, ``magnitude_fresnel``: what multiplies the polygon integral in shading (the
  public code's ``ltc_2.x`` and ``ltc_2.y``). With ``amplitude: horizon`` (the default)
  E / horizon and fresnel / horizon: the horizon-clipped lobe is renormalized, so a light that
  covers the whole upper hemisphere is shaded exactly; with ``amplitude: albedo``, E and fresnel
  (the public code's choice).
- ``fit_l1``: int |D_ltc - f_r cos / E| dL over the sphere, in [0, 2] (mass of D_ltc below the
  horizon counts), by composite Gauss-Legendre quadrature in the lobe's micro-normal
  coordinates; its error is the difference of two rules plus the rule's mass defect against E,
  and 2 below alpha = 1e-6 (the lobe there is the alpha = 1e-6 fit: a Dirac lobe has no density).
- ``fit_l1_clipped``: int over the upper hemisphere of |(magnitude / E) D_ltc - f_r cos / E| dL,
  the shading metric: a one-sided light P above the horizon is shaded with an error of at most
  E (fit_l1_clipped + |horizon magnitude / E - 1|) / 2 (E fit_l1_clipped / 2 with the horizon
  amplitude). With ``amplitude: horizon`` it is what the fit minimizes; same quadrature and error.
- ``amplitude: shading``: the horizon fit, then per row the shading polish of
  :func:`bsdf_tab.ltc.fit._polish` (:mod:`bsdf_tab.ltc.shading`): magnitude = s E / horizon with
  s fitted with the matrix; the bound is E (fit_l1_clipped + |s - 1|) / 2 (s = horizon magnitude / E).
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import numpy as np

from ..axes import alpha_values
from ..ltc import fit_metrics, fit_table, sphere_term_at, storage, upper_mass
from ..ltc.fit import SHADING
from ._common import Context, run_grid
from .kinds import LTC_AMPLITUDES as AMPLITUDES  # noqa: F401  (this module's names before kinds.py)
from .kinds import LTC_CHANNELS as CHANNELS, LTC_MATRIX_CHANNELS as MATRIX_CHANNELS

_ROUNDING = 8.0 * np.finfo(np.float64).eps


def _workers(ctx: Context) -> int:
    if ctx.workers is not None:
        return ctx.workers
    from ..integrate.runtime import default_workers

    return default_workers()


def _metrics(nspec: dict, mu: np.ndarray, alpha: np.ndarray, minv: np.ndarray, E: np.ndarray, amp: np.ndarray,
             workers: int) -> dict:
    """fit_metrics over the grid, in chunks of texels on ``workers`` threads: {name: (value, error)}."""
    MU, AL = np.meshgrid(mu, alpha, indexing="ij")
    flat = (MU.ravel(), AL.ravel(), minv.reshape(-1, 3, 3), E.ravel(), amp.ravel())
    pieces = np.array_split(np.arange(MU.size), max(1, min(4 * workers, MU.size)))

    def one(p):
        return fit_metrics(nspec["distribution"], nspec["shadowing"], *(a[p] for a in flat))

    with ThreadPoolExecutor(max_workers=workers) as pool:
        parts = list(pool.map(one, pieces))
    return {name: tuple(np.concatenate([part[name][k] for part in parts]).reshape(MU.shape) for k in range(2))
            for name in parts[0]}


def compute(nspec: dict, axes: dict, ctx: Context) -> dict:
    values, errors = run_grid("dfg", nspec, axes, ctx)
    E = values[..., 0] + values[..., 1]
    E_err = errors[..., 0] + errors[..., 1]
    mu = np.asarray(axes["mu"], dtype=np.float64)
    alpha = alpha_values(axes)
    rough = np.asarray(axes["roughness"], dtype=np.float64) if "roughness" in axes else np.sqrt(alpha)
    n = mu.size * alpha.size
    ctx.expect(2 * n)  # the fit, then the metrics
    report = ctx.reporter()
    done = 0

    def progress(k: int) -> None:
        nonlocal done
        done += k
        report(done, 2 * n)

    workers = _workers(ctx)
    amplitude = nspec["amplitude"]
    scale = np.ones_like(E)
    if amplitude == "shading":
        minv, scale = fit_table(nspec["distribution"], nspec["shadowing"], mu, alpha, progress, workers=workers,
                                device=ctx.device, clipped=True, shading=SHADING, E=E)
    else:
        minv = fit_table(nspec["distribution"], nspec["shadowing"], mu, alpha, progress, workers=workers,
                         device=ctx.device, clipped=amplitude == "horizon")
    m_up = upper_mass(minv)
    # m_up > 0: a fitted lobe has its mass about the true lobe's, above the horizon
    amp = scale / np.maximum(m_up, 1e-300) if amplitude != "albedo" else np.ones_like(E)
    metrics = _metrics(nspec, mu, alpha, minv, E, amp, workers)
    fit_l1, fit_l1_err = metrics["fit_l1"]
    clip_l1, clip_l1_err = metrics["fit_l1_clipped"]
    progress(n)
    inv_entries, m_entries = storage(minv)
    out = {name: inv_entries[..., k] for k, name in enumerate(MATRIX_CHANNELS[:4])}
    out.update({name: m_entries[..., k] for k, name in enumerate(MATRIX_CHANNELS[4:])})
    sphere = sphere_term_at(mu[:, None], rough[None, :])
    out.update({"E": E, "fresnel": values[..., 1], "sphere": sphere, "horizon": m_up, "magnitude": amp * E,
                "magnitude_fresnel": amp * values[..., 1], "fit_l1": fit_l1, "fit_l1_clipped": clip_l1})
    for name in MATRIX_CHANNELS:
        out[f"{name}_err"] = np.zeros_like(E)
    out.update({"E_err": E_err, "fresnel_err": errors[..., 1], "sphere_err": _ROUNDING * np.maximum(1.0, sphere),
                "horizon_err": _ROUNDING * np.ones_like(E), "magnitude_err": amp * E_err + _ROUNDING * amp * E,
                "magnitude_fresnel_err": amp * errors[..., 1] + _ROUNDING * amp * values[..., 1],
                "fit_l1_err": fit_l1_err, "fit_l1_clipped_err": clip_l1_err})
    return out
