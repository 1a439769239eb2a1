"""The planner: the minimal set of tables a scene needs, at the lookup error it asks for.

:func:`plan_scene` takes a scene (:mod:`.parse`) and a lookup tolerance ``lookup_tol`` (the max
lookup error; the CLI's ``--tol``, the service's ``tol=``) and returns a :class:`ScenePlan`:

- groups: conductors with the same distribution, shadowing and complex IOR share one ``albedo``
  table (mu, alpha) -> E with that exact Fresnel (one table per distinct IOR: the albedo of a
  conductor is not linear in any Fresnel parameter); every Schlick material of a distribution /
  shadowing shares one ``dfg`` table (mu, alpha) -> A, B (E = f0 A + B, f0-free); dielectrics of
  a distribution / shadowing share one ``dielectric`` table (mu, alpha, eta) -> R, T.
- axes: ``mu`` is always an interpolated axis over [0, 1] (it varies per shading point). The
  alpha (or roughness) and eta axes are *discrete* when every material of the group gives
  single values or lists: the table holds exactly those values (one value: a 1-value axis, the
  constant axis is dropped from the lookup) and the renderer indexes them, no interpolation
  error. When a material gives a range, the axis is interpolated over the union of the group's
  values (the range restricted to what the scene uses).
- resolution: interpolated axes use endpoint nodes, a spacing the renderer supports
  (``linear``: t uniform in x; ``square``: t uniform in sqrt(x)) and the smallest node counts
  on the doubling ladder 2, 3, 5, 9, 17, ... such that the lookup error, measured by tabulating
  the check set (every cell midpoint and centre, and along each axis at the others' nodes at
  least 16 intervals and points ever closer to the low end of mu and alpha:
  :mod:`.search`), is below ``PLAN_MARGIN * lookup_tol``: error = max |lookup(table) -
  direct| + max integration error of the direct values. The axis whose check-line points inside
  its cells err most is refined first. Every spacing combination is tried; the one with
  the fewest texels wins (ties: the first, in the order the scene lists spacings).
- each table is integrated at ``lookup_tol / 20`` (its spec's ``tolerance``, the integration
  error). Every texel is computed by :func:`bsdf_tab.api.tabulate`, once per planning run
  (:mod:`.texels`); the search and its checks are :mod:`.search`.
- anisotropic materials share one ``albedo_aniso`` table (mu, phi_v, alpha, anisotropy) -> E
  (F = 1) per shadowing; phi_v (the view azimuth from the tangent, folded into [0, pi/2]) is
  always interpolated, like mu.

Bytes are counted as float32 value channels (error channels are not shipped to a renderer).
The fixed-size alternative is one Cycles-style table per planned table: 32 x 32 for the 2-D
kinds, 16^3 for dielectrics, linear in each axis; the plan reports its bytes and its lookup error
at the same check points (:meth:`TablePlan.fixed_axes`).
"""

from __future__ import annotations

import json
import math
import os
import threading
from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

from ..errors import SpecError
from ..spec import channel_names, normalize_spec
from ..table import Table
from .lookup import AxisPlan
from .manifest import material_entry, plan_dict
from .parse import MATERIAL_TABLES, check_lookup_tol, parse_scene
from .search import MAX_CHECK_TEXELS, MAX_NODES, PLAN_MARGIN, search
from .groups import run_groups
from .texels import TexelStore

__all__ = ["ScenePlan", "TablePlan", "plan_scene", "FIXED_SIZES", "MAX_CHECK_TEXELS", "MAX_NODES", "PLAN_MARGIN"]

#: Groups planned at the same time (None: as many as ``workers``, by default the cores).
GROUP_THREADS: int | None = None
INTEGRATION_DIVISOR = 20.0  # a table's integration tolerance: lookup_tol / INTEGRATION_DIVISOR
MIN_INTEGRATION_TOL = 1e-9
SMALL_BLOCK = 32  # tabulations of fewer texels run on one worker thread
#: albedo_aniso: no engine ships one (they use the isotropic collapse); its default axes
#: (``bsdf_tab.axes.AXIS_DEFAULTS``: mu 32, phi_v 9, alpha 32, anisotropy 8), what ``bsdf-tab bake`` writes.
FIXED_SIZES = {"albedo": (32, 32), "dfg": (32, 32), "dielectric": (16, 16, 16), "albedo_aniso": (32, 9, 32, 8)}
#: The range of an axis in every table of a kind (mu; phi_v, the view azimuth folded into
#: [0, pi/2] by E's symmetries E(phi) = E(-phi) = E(pi - phi)).
FULL_RANGES = {"mu": (0.0, 1.0), "phi_v": (0.0, 0.5 * math.pi)}


# --------------------------------------------------------------------------- plan data


@dataclass
class TablePlan:
    """A planned table: its spec, axes, the materials that use it, bytes and the verified error."""

    file: str
    kind: str
    distribution: str
    shadowing: str
    fresnel: dict
    axes: list[AxisPlan]
    materials: list[str]
    integration_tol: float  # the table spec's tolerance (integration error per texel)
    max_error: float = math.nan  # verified lookup error at the check points (plus integration error)
    table: Any = None  # the baked Table (values at the planned nodes)
    fixed_error: float = math.nan  # the fixed-size alternative's lookup error at the same points

    @property
    def channels(self) -> tuple[str, ...]:
        return tuple(channel_names(self.kind))

    @property
    def shape(self) -> tuple[int, ...]:
        return tuple(len(a) for a in self.axes)

    @property
    def bytes(self) -> int:
        return int(np.prod(self.shape)) * len(self.channels) * 4

    @property
    def fixed_shape(self) -> tuple[int, ...]:
        """The shape of the fixed-size alternative (``FIXED_SIZES``)."""
        return FIXED_SIZES[self.kind]

    @property
    def fixed_bytes(self) -> int:
        return int(np.prod(self.fixed_shape)) * len(self.channels) * 4

    def fixed_axes(self) -> list[AxisPlan]:
        """The fixed-size alternative: linear axes with ``FIXED_SIZES`` endpoint nodes, mu and
        alpha / roughness over [0, max(1, hi)], eta over the hull of the scene's eta values
        (a single eta: that value only, which favours the fixed table)."""
        out = []
        for a, n in zip(self.axes, self.fixed_shape):
            lo, hi = (min(a.values), max(a.values)) if a.mode == "discrete" else a.range
            if a.name in FULL_RANGES:
                lo, hi = FULL_RANGES[a.name]
            elif a.name == "anisotropy":
                lo, hi = 0.0, 1.0
            elif a.name != "eta":
                lo, hi = 0.0, max(1.0, hi)
            out.append(AxisPlan(a.name, "interp", range=(lo, hi), spacing="linear", size=n) if hi > lo
                       else AxisPlan(a.name, "discrete", values=[lo]))
        return out

    def spec(self) -> dict:
        return _table_spec(self.kind, self.distribution, self.shadowing, self.fresnel,
                           {a.name: a.spec() for a in self.axes}, self.integration_tol)


@dataclass
class ScenePlan:
    """The plan of a scene: its tables (computed), the manifest entry of each material."""

    lookup_tol: float  # the max lookup error asked for
    interpolation: str
    tables: list[TablePlan]
    materials: dict[str, dict]  # name -> manifest entry
    tabulate_calls: int = 0  # tabulations the planning ran (candidates, checks, comparisons)
    texels_computed: int = 0  # texels those tabulations integrated (each texel once)
    texels_requested: int = 0  # texels the checks read (repeats counted): what reuse saved
    candidates_certified: int = 0  # candidates failed by a point already checked (.bounds): no texel computed
    line_probes: int = 0  # lines checked only to certify candidates (.search)

    @property
    def bytes(self) -> int:
        return sum(t.bytes for t in self.tables)

    @property
    def fixed_bytes(self) -> int:
        return sum(t.fixed_bytes for t in self.tables)

    @property
    def max_error(self) -> float:
        return max(t.max_error for t in self.tables)

    @property
    def fixed_error(self) -> float:
        """Largest fixed-size error (nan when a table's comparison was not computed)."""
        errs = [t.fixed_error for t in self.tables]
        return math.nan if any(math.isnan(e) for e in errs) else max(errs)

    def to_dict(self) -> dict:
        """The plan as ``manifest.json`` records it (:func:`.manifest.plan_dict`)."""
        return plan_dict(self)

    def text(self) -> str:
        """The plan in words: one line per table, a total line."""
        lines = [f"plan for tol {self.lookup_tol:g} ({self.interpolation} lookup): {len(self.tables)} table(s)"]
        for t in self.tables:
            axes = " x ".join(
                f"{a.name} {len(a.values)} (values)" if a.mode == "discrete"
                else f"{a.name} {a.size} ({a.spacing} [{a.range[0]:.4g}, {a.range[1]:.4g}])"
                for a in t.axes
            )
            fixed = " x ".join(str(n) for n in t.fixed_shape)
            lines.append(
                f"  {t.file}: {t.kind} {t.distribution}/{t.shadowing} -> {','.join(t.channels)}; {axes}; "
                f"{t.bytes} bytes; max error {t.max_error:.3g}; fixed {fixed}: {t.fixed_bytes} bytes, "
                f"max error {_err_text(t.fixed_error)}; "
                f"materials: {', '.join(t.materials)}"
            )
        saved = self.fixed_bytes - self.bytes
        pct = 100.0 * saved / self.fixed_bytes if self.fixed_bytes else 0.0
        lines.append(
            f"total: {self.bytes} bytes (fixed-size alternative {self.fixed_bytes} bytes; saved {saved} bytes, "
            f"{pct:.1f}%); max lookup error {self.max_error:.3g} <= tol {self.lookup_tol:g} "
            + (f"(fixed-size alternative: {self.fixed_error:.3g} at the same points)" if not math.isnan(self.fixed_error)
               else "(fixed-size alternative's error not computed: above the texel limit)")
        )
        return "\n".join(lines)


# --------------------------------------------------------------------------- helpers


def _cores() -> int:
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - non-Linux
        return max(1, os.cpu_count() or 1)


def _err_text(x: float) -> str:
    return "not computed (above the texel limit)" if math.isnan(x) else f"{x:.3g}"


def _table_spec(kind, dist, shadowing, fresnel, axes: dict, integration_tol: float) -> dict:
    spec = {"table": kind, "distribution": dist, "shadowing": shadowing, "axes": axes, "tolerance": integration_tol}
    if fresnel is not None:
        spec["fresnel"] = fresnel
    return spec


class _CoreShare:
    """The worker threads of a tabulation while ``running`` groups are planned at once: the
    cores (``workers``, None: all) split among them, at least one each; all of them for a group
    that runs alone (the last one, or a scene of one table). Two groups on two cores so run one
    thread per tabulation each, instead of a pool of two per group behind a first chunk that
    runs alone: the example plan ends 0.14-0.21 s sooner and takes 0.11-0.19 CPU-s less
    (``bench/startup.py``, quiet machine, docs/scenes.md).
    A texel's value does not depend on the worker count (:mod:`bsdf_tab.integrate.runtime`),
    so neither does the plan."""

    def __init__(self, workers: int | None):
        self.workers = workers
        self.running = 0
        self.lock = threading.Lock()

    def enter(self) -> None:
        with self.lock:
            self.running += 1

    def leave(self) -> None:
        with self.lock:
            self.running -= 1

    def now(self) -> int | None:
        """The workers of a tabulation that starts now."""
        running = self.running
        if running <= 1:
            return self.workers
        return max(1, (self.workers or _cores()) // running)


class _Cache:
    """Tables computed by :func:`bsdf_tab.api.tabulate` (the one path), memoized by spec."""

    def __init__(self, device, workers, scheduler=None, first_of_kind=None, share: _CoreShare | None = None):
        self.device, self.workers, self.scheduler = device, workers, scheduler
        self.share = share
        self.first_of_kind = first_of_kind or (lambda kind, run: run())  # .groups: kernels load once
        self.tables: dict[str, Any] = {}
        self.calls = 0

    def __call__(self, spec: dict) -> Table:
        from .. import api  # at call time: the api (and Warp) load only when a table is computed

        key = json.dumps(spec, sort_keys=True)
        if key not in self.tables:
            self.calls += 1
            texels = math.prod(len(v) if isinstance(v, list) else SMALL_BLOCK for v in spec["axes"].values())
            # a few texels: one thread (starting a pool costs more than it saves; same values)
            workers = 1 if texels < SMALL_BLOCK else (self.share.now() if self.share is not None else self.workers)
            extra = {"scheduler": self.scheduler} if self.scheduler is not None else {}
            self.tables[key] = self.first_of_kind(
                (spec["table"], spec.get("method")),
                lambda: api.tabulate(spec, device=self.device, workers=workers, **extra))
        return self.tables[key]


# --------------------------------------------------------------------------- planning


def _group_key(m: dict) -> tuple:
    """(table kind, distribution, shadowing[, eta, k]): materials with one key share a table."""
    key = (MATERIAL_TABLES[m["type"]], m["distribution"], m["shadowing"])
    return key + (m["eta"], m["k"]) if m["type"] == "conductor" else key


def _merge_axis(name: str, entries: list[dict], spacings) -> AxisPlan:
    if all("values" in e for e in entries):
        vals = sorted({v for e in entries for v in e["values"]})
        return AxisPlan(name, "discrete", values=vals)
    lo = min(min(e.get("values", e.get("range", [math.inf]))) for e in entries)
    hi = max(max(e.get("values", e.get("range", [-math.inf]))) for e in entries)
    if lo == hi:  # pragma: no cover - ranges have lo < hi
        return AxisPlan(name, "discrete", values=[lo])
    return AxisPlan(name, "interp", range=(lo, hi), spacing=spacings[0], size=2)


def _rough_entries(mats: list[dict], name: str) -> list[dict]:
    out = []
    for m in mats:
        r = m["rough"]
        if m["rough_name"] != name:  # roughness given, alpha axis: alpha = roughness^2
            r = {k: [v * v for v in vs] for k, vs in r.items()}
        out.append(r)
    return out


def _check_rough_axis(axis: AxisPlan, mats: list[dict], every: list[dict]) -> None:
    """Refuse an interpolated alpha / roughness axis that starts at 0, before anything is computed.

    Every table kind is discontinuous at (mu = 0, alpha = 0): E(0, alpha) -> 1 as alpha -> 0, but
    along mu ~ alpha it dips by about 0.1 however small both are (a conductor's E(1e-4, 1e-4) =
    0.89), so the cell at that corner errs by that much at any node count, and no tolerance the
    planner accepts can be met. (A discrete 0, i.e. every material of the table giving values, is
    read without interpolation and is fine.)"""
    if axis.mode != "interp" or axis.range[0] > 0.0:
        return
    index = {id(m): i for i, m in enumerate(every)}
    culprit = next(m for m in mats if min(next(iter(m["rough"].values()))) <= 0.0)
    rk = culprit["rough_name"]
    param = f"materials[{index[id(culprit)]}].{rk}" + (".range" if "range" in culprit["rough"] else "")
    low = "0.02" if rk == "roughness" else "0.0004 (roughness 0.02)"
    raise SpecError(
        param,
        f"an interpolated {rk} range that starts at 0 cannot be tabulated at any tol: the table is "
        f"discontinuous at mu = 0, {rk} = 0 (near grazing it dips by about 0.1 along mu ~ alpha, however "
        f"small both are), so no node count reaches the lookup error. Start the {rk} range above 0, "
        f"e.g. at {low}",
    )


def _plan_table(plan: TablePlan, spacings: list[str], lookup_tol: float, interpolation: str, store: TexelStore,
                max_texels: int | None, log: Callable[[str], None] | None = None) -> None:
    """Search the smallest candidate (:func:`.search.search`), bake it from the verified texels,
    and compare the fixed-size alternative at the same check points."""
    from ..api import table_meta  # at call time: the api loads Warp

    trial, err, verifier = search(plan, spacings, lookup_tol, interpolation, store, max_texels, log)
    store.certified, store.probes = verifier.certified, verifier.probes
    plan.axes = trial
    plan.max_error = err
    channels = {c: np.ascontiguousarray(v) for c, v in verifier.values([a.nodes() for a in trial]).items()}
    table = Table(axes={a.name: a.nodes() for a in trial}, channels=channels, meta={})
    table.meta = table_meta(normalize_spec(plan.spec()), table.max_error())
    table.meta["lookup_max_error"] = err
    plan.table = table
    if max_texels is not None and int(np.prod(plan.fixed_shape)) > max_texels:
        return  # the comparison would itself exceed the caller's texel limit: fixed_error stays nan
    plan.fixed_error = verifier.fixed_error(plan.fixed_axes(), trial)
    if log is not None:
        log(f"{plan.file}: fixed-size alternative {' x '.join(map(str, plan.fixed_shape))}: "
            f"lookup error {plan.fixed_error:.3g} at the same points")


def plan_scene(
    scene: dict | str,
    lookup_tol: float | None = None,
    *,
    device: str | None = None,
    workers: int | None = None,
    max_texels: int | None = None,
    log: Callable[[str], None] | None = None,
    scheduler=None,
    before_compute: Callable[[dict], None] | None = None,
) -> ScenePlan:
    """Plan (and compute) the minimal tables of a scene for the max lookup error ``lookup_tol``.

    Parameters
    ----------
    scene : dict or str
        The scene (see module docs).
    lookup_tol : float, optional
        Max lookup error (absolute, per channel; dfg: of E = f0 A + B for any f0), in
        ``LOOKUP_TOL_RANGE``. Default: the scene's ``tolerance``. Every table is computed by
        :func:`bsdf_tab.api.tabulate`; ``device`` and ``workers`` are passed to it.
    max_texels : int, optional
        Largest table the caller accepts. Candidates above it are skipped before anything is
        computed; when no smaller candidate meets ``lookup_tol``, :class:`TexelLimitError`.
    log : callable, optional
        Receives one line per verified candidate (progress; the CLI prints them on stderr).
    scheduler : distributed.Client or str, optional
        Compute the candidate tables on a Dask cluster (passed to :func:`bsdf_tab.api.tabulate`).
    before_compute : callable, optional
        The pre-compute hook: called with the spec of every tabulation before it runs (the
        texels a check needs that no earlier check computed). It may raise to stop the planning
        (the service raises :class:`~bsdf_tab.cost.CostLimitError` once the predicted cost of
        the run would exceed its limit); the exception propagates.

    Returns
    -------
    ScenePlan
        Tables (with their computed ``Table``), bytes, verified errors, manifest entries.

    Raises
    ------
    SpecError
        A bad scene (naming its parameter) or lookup tolerance (``tol``; ``tolerance`` for the
        scene's), or one the caps cannot reach (``tol``).
    """
    sc = parse_scene(scene)
    if lookup_tol is None:
        if "lookup_tol" not in sc:
            raise SpecError("tol", "is required: give --tol T (or a scene 'tolerance')")
        lookup_tol = sc["lookup_tol"]
    else:
        lookup_tol = check_lookup_tol(lookup_tol, "tol")
    spacings = sc["lookup"]["spacings"]
    interpolation = sc["lookup"]["interpolation"]
    groups: dict[tuple, list[dict]] = {}
    for m in sc["materials"]:
        groups.setdefault(_group_key(m), []).append(m)
    planned: list[tuple[TablePlan, list[dict], str]] = []
    counts: dict[str, int] = {}
    for key, mats in groups.items():
        kind, dist, shadowing = key[:3]
        rname = "roughness" if all(m["rough_name"] == "roughness" for m in mats) else "alpha"
        axes = [AxisPlan("mu", "interp", range=FULL_RANGES["mu"], spacing=spacings[0], size=2),
                _merge_axis(rname, _rough_entries(mats, rname), spacings)]
        _check_rough_axis(axes[1], mats, sc["materials"])
        fresnel = None
        if kind == "albedo":
            fresnel = {"type": "conductor", "eta": key[3], "k": key[4]}
        elif kind == "dielectric":
            axes.append(_merge_axis("eta", [m["eta_axis"] for m in mats], spacings))
        elif kind == "albedo_aniso":  # (mu, phi_v, alpha, anisotropy): phi_v varies per shading point
            axes.insert(1, AxisPlan("phi_v", "interp", range=FULL_RANGES["phi_v"], spacing=spacings[0], size=2))
            axes.append(_merge_axis("anisotropy", [m["aniso_axis"] for m in mats], spacings))
        base = f"{dist}_{shadowing}_{kind}"
        counts[base] = counts.get(base, 0) + 1
        fname = f"{base}_{counts[base]}.exr" if kind == "albedo" else f"{base}.exr"
        tp = TablePlan(fname, kind, dist, shadowing, fresnel, axes, [m["name"] for m in mats],
                       integration_tol=max(lookup_tol / INTEGRATION_DIVISOR, MIN_INTEGRATION_TOL))
        planned.append((tp, mats, rname))

    share = _CoreShare(workers)

    def task(tp: TablePlan):
        def run(group_log, before, first_of_kind) -> TexelStore:
            store = TexelStore(_Cache(device, workers, scheduler, first_of_kind, share), before)
            share.enter()
            try:
                _plan_table(tp, spacings, lookup_tol, interpolation, store, max_texels, group_log)
            finally:
                share.leave()
            return store

        return run

    # the groups share no texels: searched on a few threads, with the outcome of a loop (.groups)
    threads = 1 if scheduler is not None else min(len(planned), GROUP_THREADS or workers or _cores())
    stores = run_groups([task(tp) for tp, _, _ in planned], threads, log, before_compute)
    manifest: dict[str, dict] = {}
    for tp, mats, rname in planned:
        for m in mats:
            manifest[m["name"]] = material_entry(m, tp, rname)
    return ScenePlan(lookup_tol, interpolation, [tp for tp, _, _ in planned], manifest,
                     tabulate_calls=sum(s.calls for s in stores), texels_computed=sum(s.texels for s in stores),
                     texels_requested=sum(s.requested for s in stores),
                     candidates_certified=sum(s.certified for s in stores), line_probes=sum(s.probes for s in stores))


