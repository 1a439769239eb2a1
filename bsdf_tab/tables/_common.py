"""Shared pieces of the table modules: spec -> integrator parameters, grids, mu-averages."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from ..axes import alpha_values
from ..integrate import get_method
from ..integrate.quadrature import GK_WG, GK_WK, GK_X
from ..model.distribution import DISTRIBUTIONS
from ..model.fresnel import FRESNELS
from ..model.shadowing import SHADOWINGS


@dataclass
class Context:
    """Execution settings of one tabulation: device, worker threads, progress reporting."""

    device: object = None
    workers: int | None = None
    progress: Callable[[int, int], None] | None = None
    _done: int = field(default=0, repr=False)
    _total: int = field(default=0, repr=False)

    def expect(self, n: int) -> None:
        """Announce ``n`` more texel integrations (totals may grow, e.g. adaptive averages)."""
        self._total += n
        if self.progress is not None:
            self.progress(self._done, self._total)

    def reporter(self) -> Callable[[int, int], None]:
        """A progress callback for one integrate_texels call, added to the running count."""
        base = self._done

        def report(done: int, _total: int) -> None:
            self._done = base + done
            if self.progress is not None:
                self.progress(self._done, self._total)

        return report


def integrator_params(nspec: dict) -> dict:
    """Keyword arguments of :func:`integrate_texels` from a normalized spec."""
    fres = nspec.get("fresnel") or {"type": "one"}
    ftype, p0, p1 = "one", 0.0, 0.0
    if fres["type"] == "schlick":
        ftype, p0 = "schlick", fres["f0"]
    elif fres["type"] == "dielectric" and "eta" in fres:
        ftype, p0 = "dielectric", fres["eta"]
    elif fres["type"] == "conductor":
        ftype, p0, p1 = "conductor", fres["eta"], fres["k"]
    extra = {"effort": nspec["effort"]} if nspec.get("effort") is not None else {}
    return {
        **extra,
        "dist": int(DISTRIBUTIONS[nspec["distribution"]]),
        "shadowing": int(SHADOWINGS[nspec["shadowing"]]),
        "ftype": int(FRESNELS[ftype]),
        "fp0": float(p0),
        "fp1": float(p1),
        "tol": float(nspec["tolerance"]),
    }


def run_grid(mode: str, nspec: dict, axes: dict, ctx: Context, eta_axis: np.ndarray | None = None):
    """Integrate the full (mu, alpha[, eta]) grid. Returns (values, errors), each (..., 2)."""
    mu = np.asarray(axes["mu"], dtype=np.float64)
    alpha = alpha_values(axes)
    grids = np.meshgrid(mu, alpha, *([eta_axis] if eta_axis is not None else []), indexing="ij")
    shape = grids[0].shape
    ctx.expect(grids[0].size)
    values, errors = get_method(nspec["method"])(
        mode,
        grids[0].ravel(),
        grids[1].ravel(),
        grids[2].ravel() if eta_axis is not None else None,
        device=ctx.device,
        workers=ctx.workers,
        progress=ctx.reporter(),
        **integrator_params(nspec),
    )
    return values.reshape(shape + (2,)), errors.reshape(shape + (2,))




def mu_average(
    mode: str,
    nspec: dict,
    alpha: np.ndarray,
    eta: np.ndarray | None,
    ctx: Context,
    breaks: Callable[[float, float], list[float]] | None = None,
    max_rounds: int = 14,
):
    """2 int_0^1 X(mu) mu dmu for each (alpha[k], eta[k]), adaptive over w with mu = w^2.

    With mu = w^2 the integrand 4 X(w^2) w^3 is smooth at grazing even where X has a
    mu ln(mu) term (correlated shadowing, SPEC section 5). Panels in w are refined by G7-K15
    until |K - G| plus the propagated texel errors meets half the tolerance per unit length;
    the texels are integrated with a quarter of it. ``breaks(alpha, eta)`` adds panel ends
    (in mu) where X has kinks. Returns (values, errors), each (K, 2).
    """
    params = integrator_params(nspec)
    tol = params["tol"]
    params["tol"] = 0.25 * tol
    n = alpha.size
    eta = np.ones(n) if eta is None else eta
    # pending panels: (texel k, w0, w1, depth)
    panels = []
    for k in range(n):
        ends = {0.0, 0.25, 0.5, 0.75, 1.0}
        if breaks is not None:
            ends.update(math.sqrt(b) for b in breaks(alpha[k], eta[k]) if 0.0 < b < 1.0)
        ends = sorted(ends)
        panels += [(k, a, b, 0) for a, b in zip(ends[:-1], ends[1:])]
    value = np.zeros((n, 2))
    error = np.zeros((n, 2))
    for _round in range(max_rounds):
        if not panels:
            break
        ks = np.array([p[0] for p in panels])
        w0 = np.array([p[1] for p in panels])[:, None]
        w1 = np.array([p[2] for p in panels])[:, None]
        half = 0.5 * (w1 - w0)
        w = 0.5 * (w0 + w1) + half * GK_X[None, :]
        mu = w * w
        ctx.expect(mu.size)
        vals, errs = get_method(nspec["method"])(
            mode, mu.ravel(), np.repeat(alpha[ks], GK_X.size), np.repeat(eta[ks], GK_X.size),
            device=ctx.device, workers=ctx.workers, progress=ctx.reporter(), **params,
        )
        weight = 4.0 * w**3 * half  # (P, 15)
        vals = vals.reshape(w.shape + (2,))
        errs = errs.reshape(w.shape + (2,))
        k15 = np.einsum("pj,j,pjc->pc", weight, GK_WK, vals)
        g7 = np.einsum("pj,j,pjc->pc", weight, GK_WG, vals)
        e_nodes = np.einsum("pj,j,pjc->pc", weight, GK_WK, errs)
        e_quad = np.abs(k15 - g7)
        last = _round == max_rounds - 1
        nxt = []
        for i, (k, a, b, depth) in enumerate(panels):
            if e_quad[i].max() <= 0.5 * tol * (b - a) or last:
                value[k] += k15[i]
                error[k] += e_quad[i] + e_nodes[i]
            else:
                m = 0.5 * (a + b)
                nxt += [(k, a, m, depth + 1), (k, m, b, depth + 1)]
        panels = nxt
    return value, error
