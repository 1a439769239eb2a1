"""The predicted cost of a table, before anything runs: :func:`estimate` and :func:`check`.

A table's cost is counted in **core-seconds** (CPU seconds of one core; ``workers`` threads
divide the wall time by about ``min(workers, texels)``). The model is

    core_seconds = integrations x seconds_per_integration x scale

- **integrations**: texel integrals the kind launches. ``albedo``, ``dfg``, ``dielectric``:
  one per texel; ``albedo_avg`` / ``dielectric_avg``: per (alpha[, eta]) point, the
  mu-average's first round of :data:`AVG_PANELS` panels x 15 Gauss-Kronrod nodes (one more
  panel per critical-angle break, eta < 1), refined by panel bisection up to
  :data:`AVG_MAX_ROUNDS` rounds; ``kulla_conty``: its grid plus the alpha average; ``bsdf``:
  one point evaluation per texel; ``ltc``: its grid plus the host fit per texel
  (:data:`KIND_HOST_SECONDS`).
- **seconds per integration**: fixed-effort methods ``overhead + per_node x nodes`` (nodes =
  ``effort``, or the method's default effort; ``grid`` integrates both hemispheres for
  dielectric tables, ``vndf_gl`` adds its half-order check rule); ``adaptive``
  ``ADAPTIVE_BASE[mode] x (1e-3 / tolerance) ** ADAPTIVE_EXPONENT`` (mu-averages integrate
  their texels at a quarter of the tolerance).
- **bound** (:attr:`Cost.bound_seconds`): what the rule caps allow at most. Adaptive texels are
  capped at ``max_rules_outer`` outer x ``max_rules_inner`` inner G7-K15 rules per phi piece
  (:mod:`bsdf_tab.integrate.adaptive`); the mu-averages at :data:`AVG_MAX_ROUNDS` rounds of
  bisection. A fixed-effort method cannot converge a mu-average whose noise exceeds the
  tolerance, so for Monte Carlo methods on the ``_avg`` kinds the prediction *is* the bound
  (every round refines every panel: about 10^6 integrations per point).

Calibration
-----------
The constants below were measured with :func:`calibrate` (``python -m bsdf_tab.cost``) on the
development machine: 2 shared x86-64 cores, Warp 1.19 on the CPU, ``workers=1``, CPU time
(``time.process_time``, so the load of other processes changes it little), default axes (grazing
mu = 0 and alpha = 0 included) of 8 x 8 (2-D) and 4 x 4 x 4 (3-D) texels, per method at two
efforts (4096 and 65536 samples / 1024 and 16384 nodes) and adaptive at tolerances 1e-3, 1e-5,
5e-7, 1e-9, 1e-11. Adaptive cost grows like ``tol ** -0.125`` (x10 over those 8 decades;
issue 14's fourth round made the loose tolerances cheaper, the tight ones less so). ``tests/test_cost.py`` checks that predicted and measured core-seconds agree within
a factor :data:`AGREEMENT_FACTOR` over a sweep of kinds, methods, efforts and tolerances. On
other hardware, multiply by ``scale`` (the service's ``BSDF_TAB_COST_SCALE``) or re-run
:func:`calibrate` and compare. CUDA devices are much faster than this model says (it is a
CPU model; it stays an upper bound there).

Functions for callers: :func:`estimate` (spec -> :class:`Cost`), :func:`check` (raises
:class:`CostLimitError`, a :class:`~bsdf_tab.errors.SpecError`, above a limit), :func:`measure`.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

from .errors import SpecError
from .spec import DEFAULT_TOLERANCE, normalize_spec, resolve_axes

__all__ = [
    "ADAPTIVE_BASE",
    "ADAPTIVE_EXPONENT",
    "AGREEMENT_FACTOR",
    "Cost",
    "CostLimitError",
    "PER_NODE",
    "calibrate",
    "check",
    "estimate",
    "measure",
]

#: Integrand family of each table kind (``bsdf`` is a point evaluation, not an integral).
KIND_MODE = {
    "albedo": "reflect",
    "albedo_avg": "reflect",
    "kulla_conty": "reflect",
    "dfg": "dfg",
    "dielectric": "dielectric",
    "dielectric_avg": "dielectric",
    "bsdf": "point",
    "ltc": "dfg",  # E and the Schlick amplitude through the grid, then the per-texel fit
    # own fixed-rule kernels (tables/sheen.py, tables/aniso.py): priced as host work per texel
    "sheen_albedo": "point",
    "sheen_albedo_avg": "point",
    "albedo_aniso": "point",
}
#: Kinds with host work besides their integrals: (fixed core-seconds, core-seconds per texel)
#: (measured: ltc 4 x 4 0.40 s, 8 x 8 0.92 s: the L1 fits of the LTC matrices).
KIND_HOST_SECONDS = {"ltc": (0.15, 0.011),
                     # measured (2 cores, one worker's CPU time): a sheen texel 0.0013 core-s fitted
                     # (0.007 exact: KIND_OPTION_HOST_SCALE), a sheen mu-average 0.08 per alpha; an
                     # anisotropic texel 0.010 on the default-range grid 8 x 5 x 8 x 5 after its panel
                     # fix (were priced 0.015 / 0.9 / 0.05: 5-10x high)
                     "sheen_albedo": (0.02, 0.0015), "sheen_albedo_avg": (0.02, 0.08), "albedo_aniso": (0.0, 0.012)}
#: A kind's own spec keys that scale its host cost: kind -> key -> value -> factor (measured:
#: the exact Smith Lambda of Charlie tabulates the projected area per alpha: ~5x the fitted texel,
#: ~2x the fitted mu-average; the LTC shading refit, amplitude "shading" with issue 16's third-round
#: polish (96 quads, the fit_l1 constraint): 2.2x the horizon fit of a 16 x 16 table, 2.8x at 64 x 64).
KIND_OPTION_HOST_SCALE = {"sheen_albedo": {"sheen_shadowing": {"exact": 5.0}},
                          "sheen_albedo_avg": {"sheen_shadowing": {"exact": 2.0}},
                          "ltc": {"amplitude": {"shading": 2.3}}}
#: Kinds that average over mu (one integration per node of the mu-average's panels).
AVG_KINDS = {"albedo_avg", "dielectric_avg"}

#: Core-seconds of one adaptive texel at tolerance 1e-3, per integrand family. After issue 14's
#: tenth round (chunks taken by worker loops, the inner cuts' sort, acos, Beckmann's G), x0.88:
#: the calibration sweep measured 0.53 (albedo 1e-9), 0.51 (dfg), 0.53 (dielectric 1e-5), 0.51
#: (albedo_avg) of the ninth round's 25 / 30 / 54 us, where the fixed-effort methods measured
#: 0.61-0.73 of theirs. After the
#: ninth round (per-evaluation work and the G1 ramp cuts at loose tolerances), x0.7 / x0.7 / x0.8:
#: the calibration sweep measured 0.42 (albedo 1e-9), 0.64 (dfg), 0.75 (dielectric 1e-5), 0.72
#: (albedo_avg) of the seventh round's 35 / 42 / 67 us. After the seventh round (the outer first stage, the inner end maps, carry 2), x0.6 / x0.6 / x0.7: the
#: calibration sweep measured 0.51 (albedo 1e-9), 0.49 (dfg), 0.60 (dielectric 1e-5), 0.48
#: (albedo_avg) of the sixth round's 59 / 70 / 95 us, the fixed-effort methods 0.77-1.03 of theirs.
#: After the sixth round (the outer map), x0.75 each: the calibration sweep measured 0.42 (albedo 1e-9),
#: 0.47 (dfg), 0.56 (dielectric 1e-5), 0.37 (albedo_avg) of the fifth round's 79 / 94 / 126 us on
#: a machine where the fixed-effort methods measured 0.64-0.78 of theirs (the fifth round's fit:
#: the fourth round's 105 / 125 / 210 us x0.75 / x0.75 / x0.6; 190 / 240 / 390 us before it).
ADAPTIVE_BASE = {"reflect": 2.2e-5, "dfg": 2.6e-5, "dielectric": 4.8e-5}
#: Adaptive cost ~ (1e-3 / tolerance) ** ADAPTIVE_EXPONENT (measured: x9.6 / x12.9 / x10.0 over
#: 1e-3 .. 1e-11 for reflect / dfg / dielectric; x5.3 before issue 14's fourth round).
ADAPTIVE_EXPONENT = 0.125
#: Adaptive cost never falls below this fraction of the 1e-3 figure (the breakpoints' fixed rules).
ADAPTIVE_FLOOR = 0.7
#: Core-seconds per sample / node of each fixed-effort method (measured, reflect and dfg).
PER_NODE = {
    "mc_vndf": 9.0e-8,
    "mc_cosine": 6.5e-8,
    "mc_dcos": 5.2e-8,
    "qmc_vndf": 1.3e-7,
    "grid": 4.5e-8,
    "vndf_gl": 8.0e-8,
}
#: Fixed-effort methods whose dielectric texels cost differently per node (measured: 0.82-0.85x
#: of 8e-8 for vndf_gl after issue 14's fifth round, one root for F and refraction; was 2.4x, which
#: already predicted 2.3x too much at a643761 and 2.7x after the round).
DIELECTRIC_FACTOR = {"vndf_gl": 0.85}
#: Core-seconds of one fixed-effort texel besides its samples (launch, setup, guards).
OVERHEAD = 3.0e-5
#: Core-seconds of one ``bsdf`` point texel.
POINT_SECONDS = 2.6e-7
#: mu-average: first-round panels (w = 0, 1/4, 1/2, 3/4, 1), nodes per panel, round cap
#: (:func:`bsdf_tab.tables._common.mu_average`'s defaults).
AVG_PANELS = 4
AVG_NODES = 15
AVG_MAX_ROUNDS = 14
#: Adaptive mu-averages: integrations per first-round node, 1 + slope x log10(1e-3 / tol), per
#: family (measured: reflect converges in the first round; dielectric x1.0 at 1e-3, x2.3 at 5e-7).
AVG_ADAPTIVE_REFINE = {"reflect": 0.0, "dfg": 0.0, "dielectric": 0.4}
#: Rule caps of the adaptive integrator (``integrate_texels`` defaults) and the seconds of one
#: G7-K15 inner rule (15 integrand evaluations): the bound of one adaptive texel.
ADAPTIVE_MAX_RULES = (400, 200)
ADAPTIVE_PIECES = 4
RULE_SECONDS = 15 * 6.5e-8  # measured 5.7e-8 .. 7.3e-8 s per evaluation
#: Predicted and measured core-seconds agree within this factor (tests/test_cost.py).
AGREEMENT_FACTOR = 3.0

_STOCHASTIC = {"mc_vndf", "mc_cosine", "mc_dcos", "qmc_vndf"}


class CostLimitError(SpecError):
    """A valid spec whose predicted cost is above a limit (the service answers 413).

    ``cost`` is the :class:`Cost`, ``limit`` the limit in seconds; ``param`` names the spec
    parameters that drive the cost (``"axes,effort"``, ``"axes,tolerance"``).
    """

    def __init__(self, param: str | None, message: str, cost: "Cost | None" = None,
                 limit: float | None = None) -> None:
        self.cost = cost
        self.limit = limit
        super().__init__(param, message)

    def __reduce__(self):
        return (type(self), (self.param, self.message, self.cost, self.limit))


@dataclass(frozen=True)
class Cost:
    """The predicted cost of one table.

    Attributes
    ----------
    seconds : float
        Predicted core-seconds (one core; see :meth:`wall_seconds`).
    bound_seconds : float
        The most the rule caps allow, core-seconds (>= ``seconds``).
    texels : int
        Texels of the table.
    integrations : int
        Texel integrals launched (more than ``texels`` for the mu-averages).
    per_integration : float
        Predicted core-seconds of one integration.
    method : str
        The method of the normalized spec.
    params : tuple of str
        The spec parameters that drive the cost, most effective first.
    """

    seconds: float
    bound_seconds: float
    texels: int
    integrations: int
    per_integration: float
    method: str
    params: tuple[str, ...]

    def wall_seconds(self, workers: int | None = 1) -> float:
        """Predicted wall-clock seconds on ``workers`` cores (None: all cores)."""
        if workers is None:
            from .integrate.runtime import default_workers

            workers = default_workers()
        return self.seconds / max(1, min(int(workers), max(1, self.integrations)))

    def to_dict(self) -> dict:
        """JSON-ready summary (what the service reports)."""
        return {
            "predicted_seconds": round(self.seconds, 3),
            "bound_seconds": round(self.bound_seconds, 3),
            "texels": self.texels,
            "integrations": self.integrations,
            "method": self.method,
            "params": list(self.params),
        }


def _default_effort(method: str) -> int:
    # the integrators' own defaults (imported here: they load Warp)
    if method == "grid":
        from .integrate.grid import DEFAULT_EFFORT

        return int(DEFAULT_EFFORT)
    if method == "vndf_gl":
        from .integrate.vndf_gl import DEFAULT_EFFORT

        return int(DEFAULT_EFFORT)
    from .integrate.montecarlo import DEFAULT_EFFORT

    return int(DEFAULT_EFFORT[method])


def _nodes(method: str, effort: int, mode: str) -> float:
    """Integrand evaluations of one fixed-effort texel."""
    if method == "grid":
        nz = max(2, 2 * int(round(math.sqrt(effort / 2.0) / 2.0)))
        return 2.0 * nz * nz * (2.0 if mode == "dielectric" else 1.0)  # both hemispheres for R and T
    if method == "vndf_gl":
        n = max(2, 2 * int(round(math.sqrt(effort) / 2.0)))
        return n * n + (n // 2) ** 2  # the rule and its half-order check
    if method == "qmc_vndf":
        return 8.0 * max(2, effort // 8)  # 8 replicates
    return float(effort)


def _per_integration(nspec: dict, mode: str, tol: float) -> float:
    method = nspec["method"]
    if mode == "point":
        return POINT_SECONDS
    if method == "adaptive":
        factor = max(ADAPTIVE_FLOOR, (1e-3 / tol) ** ADAPTIVE_EXPONENT)
        return ADAPTIVE_BASE[mode] * factor
    effort = nspec.get("effort") or _default_effort(method)
    per = PER_NODE.get(method, max(PER_NODE.values()))
    if mode == "dielectric":
        per *= DIELECTRIC_FACTOR.get(method, 1.0)
    return OVERHEAD + per * _nodes(method, int(effort), mode)


def estimate(spec: dict | str, *, scale: float = 1.0) -> Cost:
    """The predicted cost of the table of ``spec`` (nothing is computed).

    Parameters
    ----------
    spec : dict or str
        A table spec (normalized here; a :class:`~bsdf_tab.errors.SpecError` if invalid).
    scale : float
        Multiplies every figure (hardware slower or faster than the calibration machine).

    Returns
    -------
    Cost
    """
    if not (isinstance(scale, (int, float)) and math.isfinite(scale) and scale > 0):
        raise ValueError(f"scale must be a finite number > 0, got {scale!r}")  # a bad setting, not a spec
    nspec = normalize_spec(spec)
    kind, method = nspec["table"], nspec["method"]
    axes = resolve_axes(nspec)
    sizes = {name: len(values) for name, values in axes.items()}
    texels = math.prod(sizes.values())
    mode = KIND_MODE.get(kind, "dielectric")  # an unknown kind: the dearest family
    tol = float(nspec.get("tolerance", DEFAULT_TOLERANCE))  # absent for a fixed-rule kind (not used by it)
    drivers = ("axes", "tolerance") if method == "adaptive" else ("axes", "effort")
    if mode == "point":
        drivers = ("axes",)

    points = 0  # (alpha[, eta]) points of a mu-average
    if kind in AVG_KINDS:
        points = texels
    elif kind == "kulla_conty":
        points = sizes.get("alpha", sizes.get("roughness", 1))
    grid = 0 if kind in AVG_KINDS else texels
    per_point = AVG_PANELS * AVG_NODES
    if mode == "dielectric" and points:
        eta = axes.get("eta")
        below = 0 if eta is None else sum(1 for e in eta if e < 1.0)
        per_point += AVG_NODES * below / max(1, len(eta))  # one more panel at the critical angle
    cap_per_point = per_point * (2**AVG_MAX_ROUNDS - 1)

    per_grid = _per_integration(nspec, mode, tol)
    per_avg = _per_integration(nspec, mode, 0.25 * tol) if points else 0.0
    if method == "adaptive":
        refine = 1.0 + AVG_ADAPTIVE_REFINE.get(mode, 0.4) * max(0.0, math.log10(1e-3 / tol))
        rule_bound = ADAPTIVE_MAX_RULES[0] * (1 + ADAPTIVE_PIECES * ADAPTIVE_MAX_RULES[1]) * RULE_SECONDS
        grid_bound, avg_bound = max(per_grid, rule_bound), max(per_avg, rule_bound)
    else:
        refine = (2**AVG_MAX_ROUNDS - 1) if method in _STOCHASTIC else 1.0
        grid_bound, avg_bound = per_grid, per_avg
    avg_integrations = points * per_point * refine
    integrations = int(grid + avg_integrations)
    fixed, per_texel = KIND_HOST_SECONDS.get(kind, (0.0, 0.0))
    for key, choices in KIND_OPTION_HOST_SCALE.get(kind, {}).items():  # a kind's own keys that change its cost
        factor = choices.get(nspec.get(key), 1.0)
        fixed, per_texel = fixed * factor, per_texel * factor
    host = fixed + per_texel * texels
    seconds = (grid * per_grid + avg_integrations * per_avg + host) * scale
    bound = (grid * grid_bound + points * cap_per_point * avg_bound + host) * scale
    per = seconds / integrations if integrations else 0.0
    return Cost(seconds=seconds, bound_seconds=max(bound, seconds), texels=texels, integrations=integrations,
                per_integration=per, method=method, params=drivers)


def check(spec: dict | str, max_seconds: float, *, workers: int | None = 1, scale: float = 1.0) -> Cost:
    """:func:`estimate`, raising :class:`CostLimitError` when the prediction exceeds ``max_seconds``.

    Parameters
    ----------
    spec : dict or str
        The table spec.
    max_seconds : float
        The limit: core-seconds with ``workers=1`` (the service), wall seconds on ``workers``
        cores otherwise (the CLI's ``--max-seconds``; None: all cores).
    workers, scale
        As for :meth:`Cost.wall_seconds` and :func:`estimate`.

    Returns
    -------
    Cost
        The estimate, when it is within the limit.
    """
    cost = estimate(spec, scale=scale)
    seconds = cost.wall_seconds(workers) if workers != 1 else cost.seconds
    if seconds > max_seconds:
        raise CostLimitError(",".join(cost.params), _message(cost, seconds, max_seconds, workers), cost, max_seconds)
    return cost


def _message(cost: Cost, seconds: float, limit: float, workers) -> str:
    unit = "core-seconds" if workers == 1 else "seconds"
    if cost.method == "adaptive":
        way = "a coarser tolerance, fewer texels"
    elif "effort" in cost.params:
        way = "a lower effort, fewer texels"
    else:
        way = "fewer texels"
    return (f"predicted cost {seconds:.3g} {unit} ({cost.texels} texels, {cost.integrations} integrations "
            f"of method {cost.method} at {cost.per_integration:.2g} s each) is above the limit of {limit:g}; "
            f"use {way}, or a job for big work")


def measure(spec: dict | str, *, device: str | None = "cpu") -> float:
    """Core-seconds (CPU time, ``workers=1``) that computing ``spec`` takes here, kernels loaded first."""
    from .api import tabulate

    nspec = normalize_spec(spec)
    small = {**nspec, "axes": {name: {"size": 2} for name in nspec["axes"]}}
    small.pop("effort", None)
    if nspec.get("effort") is not None:
        small["effort"] = 8
    tabulate(small, device=device, workers=1)  # load / compile the kernels outside the timing
    t0 = time.process_time()
    tabulate(nspec, device=device, workers=1)
    return time.process_time() - t0


#: The calibration sweep (:func:`calibrate`) and the agreement test's sweep.
SWEEP = (
    {"table": "albedo", "axes": {"mu": {"size": 8}, "alpha": {"size": 8}}, "method": "mc_vndf", "effort": 16384},
    {"table": "albedo", "axes": {"mu": {"size": 8}, "alpha": {"size": 8}}, "tolerance": 1e-9},
    {"table": "dfg", "axes": {"mu": {"size": 8}, "alpha": {"size": 8}}, "method": "grid", "effort": 16384},
    {"table": "dfg", "axes": {"mu": {"size": 8}, "alpha": {"size": 8}}},
    {"table": "dielectric", "axes": {"mu": {"size": 4}, "alpha": {"size": 4}, "eta": {"size": 4}},
     "method": "vndf_gl", "effort": 4096},
    {"table": "dielectric", "axes": {"mu": {"size": 4}, "alpha": {"size": 4}, "eta": {"size": 4}}, "tolerance": 1e-5},
    {"table": "albedo_avg", "axes": {"alpha": {"size": 4}}},
    {"table": "ltc", "axes": {"mu": {"size": 4}, "alpha": {"size": 4}}},
    {"table": "ltc", "amplitude": "shading", "axes": {"mu": {"size": 4}, "alpha": {"size": 4}}},
    {"table": "albedo_aniso", "axes": {"mu": {"size": 3}, "phi_v": {"size": 2}, "alpha": {"size": 3},
                                       "anisotropy": {"size": 2}}},
    {"table": "sheen_albedo", "axes": {"mu": {"size": 8}, "alpha": {"size": 8}}},
    {"table": "sheen_albedo", "sheen_shadowing": "exact", "axes": {"mu": {"size": 4}, "alpha": {"size": 4}}},
    {"table": "sheen_albedo_avg", "axes": {"alpha": {"size": 3}}},
)


def calibrate(specs=SWEEP) -> list[dict]:
    """Predicted and measured core-seconds of each spec (prints a table; the calibration's check)."""
    rows = []
    for spec in specs:
        predicted = estimate(spec).seconds
        measured = measure(spec)
        rows.append({"spec": spec, "predicted": predicted, "measured": measured,
                     "ratio": measured / predicted if predicted else math.inf})
    return rows


if __name__ == "__main__":  # python -m bsdf_tab.cost: the calibration table
    from .api import quiet_warp

    quiet_warp()
    print(f"{'table':14} {'method':9} {'effort/tol':>10} {'predicted':>10} {'measured':>10} {'ratio':>6}")
    for row in calibrate():
        s = row["spec"]
        print(f"{s['table']:14} {s.get('method', 'adaptive'):9} {s.get('effort', s.get('tolerance', '-'))!s:>10} "
              f"{row['predicted']:10.4f} {row['measured']:10.4f} {row['ratio']:6.2f}")
