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
  on the doubling ladder 2, 3, 5, 9, 17, ... such that the lookup error, measured at every cell
  midpoint by tabulating the refined grid (the nodes of the next rung), is below ``lookup_tol``:
  error = max |lookup(table) - direct| + max integration error of the direct values. The axis
  whose midpoints err most is refined first. Every spacing combination is tried; the one with
  the fewest texels wins (ties: the first, in the order the scene lists spacings).
- each table is integrated at ``lookup_tol / 20`` (its spec's ``tolerance``, the integration
  error). Every table is computed by :func:`bsdf_tab.api.tabulate`, memoized by spec.

Bytes are counted as float32 value channels (error channels are not shipped to a renderer).
The fixed-size alternative is one Cycles-style table per planned table: 32 x 32 for the 2-D
kinds, 16^3 for dielectrics, linear in each axis; the plan reports its bytes and its lookup error
at the same check points (:meth:`TablePlan.fixed_axes`).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

from ..errors import SpecError, TexelLimitError
from ..spec import channel_names, normalize_spec
from ..table import Table
from .lookup import AxisPlan, lookup
from .manifest import material_entry, plan_dict
from .parse import MATERIAL_TABLES, check_lookup_tol, parse_scene

__all__ = ["ScenePlan", "TablePlan", "plan_scene", "FIXED_SIZES", "PLAN_MARGIN"]

PLAN_MARGIN = 0.8  # plan to 0.8 lookup_tol at the midpoints: headroom for points between them
INTEGRATION_DIVISOR = 20.0  # a table's integration tolerance: lookup_tol / INTEGRATION_DIVISOR
MIN_INTEGRATION_TOL = 1e-9
MAX_NODES = 1025
MAX_CHECK_TEXELS = 300_000
FIXED_SIZES = {"albedo": (32, 32), "dfg": (32, 32), "dielectric": (16, 16, 16)}


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
    max_error: float = math.nan  # verified lookup error at the midpoints (plus integration error)
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
            if a.name != "eta":
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


def _err_text(x: float) -> str:
    return "not computed (above the texel limit)" if math.isnan(x) else f"{x:.3g}"


def _table_spec(kind, dist, shadowing, fresnel, axes: dict, integration_tol: float) -> dict:
    spec = {"table": kind, "distribution": dist, "shadowing": shadowing, "axes": axes, "tolerance": integration_tol}
    if fresnel is not None:
        spec["fresnel"] = fresnel
    return spec


class _Cache:
    """Tables computed by :func:`bsdf_tab.api.tabulate` (the one path), memoized by spec."""

    def __init__(self, device, workers, max_texels: int | None = None, scheduler=None):
        self.device, self.workers, self.scheduler = device, workers, scheduler
        self.max_texels = max_texels
        self.tables: dict[str, Any] = {}
        self.calls = 0

    def __call__(self, spec: dict) -> Table:
        from .. import api  # at call time: the api (and Warp) load only when a table is computed

        key = json.dumps(spec, sort_keys=True)
        if key not in self.tables:
            self.calls += 1
            self.tables[key] = api.tabulate(spec, device=self.device, workers=self.workers,
                                            **({"scheduler": self.scheduler} if self.scheduler is not None else {}))
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


def _combine(kind: str, diffs: dict, errs: dict) -> np.ndarray:
    """Per-point lookup error from per-channel lookup differences and integration errors."""
    if kind == "dfg":
        # E = f0 A + B for any f0 in [0, 1]: the lookup error f0 dA + dB is largest at f0 = 0 or 1
        return np.maximum(np.abs(diffs["B"]), np.abs(diffs["A"] + diffs["B"])) + errs["A"] + errs["B"]
    return np.max([np.abs(diffs[ch]) + errs[ch] for ch in diffs], axis=0)


def _fine_grid(fine, kind: str) -> tuple[list[np.ndarray], dict, dict]:
    """The check points of a refined table (meshgrid), its values and error channels."""
    grids = np.meshgrid(*[np.asarray(v) for v in fine.axes.values()], indexing="ij")
    vals = {ch: np.asarray(fine.channels[ch], dtype=np.float64) for ch in channel_names(kind)}
    errs = {ch: np.asarray(fine.channels[ch + "_err"], dtype=np.float64) for ch in vals}
    return grids, vals, errs


def _errors(plan: TablePlan, fine, interpolation: str, sizes: list[int]) -> tuple[float, list[float]]:
    """Lookup error of the candidate (every other node of ``fine`` on interp axes) at the fine points.

    Returns (max error overall, per interp axis the max error at points that are midpoints along
    that axis only); integration error of the fine values included.
    """
    interp = [i for i, a in enumerate(plan.axes) if a.mode == "interp"]
    sl = tuple(slice(None, None, 2) if a.mode == "interp" else slice(None) for a in plan.axes)
    grids, vals, errs = _fine_grid(fine, plan.kind)
    d = len(plan.axes)
    # nearest: every texel that can be nearest to a cell boundary point (ties either way)
    modes = [None] if interpolation != "nearest" else [tuple(bool((c >> k) & 1) for k in range(d)) for c in range(1 << d)]
    total = np.zeros(grids[0].shape)
    for m in modes:
        diffs = {ch: lookup(v[sl], plan.axes, grids, interpolation, m) - v for ch, v in vals.items()}
        total = np.maximum(total, _combine(plan.kind, diffs, errs))
    per_axis = []
    for a in interp:
        mask = np.ones(total.shape, dtype=bool)
        for b in interp:
            odd = (np.arange(total.shape[b]) % 2 == 1) if b == a else (np.arange(total.shape[b]) % 2 == 0)
            shape = [1] * total.ndim
            shape[b] = -1
            mask &= odd.reshape(shape)
        per_axis.append(float(total[mask].max()) if mask.any() else 0.0)
    return float(total.max()), per_axis


def _fixed_error(plan: TablePlan, fine, interpolation: str, cache: "_Cache") -> float:
    """Lookup error of the fixed-size alternative (:meth:`TablePlan.fixed_axes`, read with the
    scene's interpolation) at the points that verified the plan."""
    axes = plan.fixed_axes()
    fixed = cache(_table_spec(plan.kind, plan.distribution, plan.shadowing, plan.fresnel,
                              {a.name: a.spec() for a in axes}, plan.integration_tol))
    grids, vals, errs = _fine_grid(fine, plan.kind)
    diffs = {ch: lookup(np.asarray(fixed.channels[ch], dtype=np.float64), axes, grids, interpolation) - v
             for ch, v in vals.items()}
    fixed_err = {ch: np.max(np.asarray(fixed.channels[ch + "_err"], dtype=np.float64)) for ch in vals}
    return float(np.max(_combine(plan.kind, diffs, errs))) + max(fixed_err.values())


def _check(plan: TablePlan, combo, sizes, interpolation: str, cache: _Cache):
    """Verify one candidate (spacings ``combo``, node counts ``sizes`` of the interp axes).

    Tabulates the refined grid (every cell midpoint added) and returns (max error, per-axis
    midpoint errors, the fine table), None past the caps, or "limit" when the candidate itself
    has more texels than ``cache.max_texels`` (checked before anything is computed).
    """
    if cache.max_texels is not None:
        own = int(np.prod(sizes)) * int(np.prod([len(a.values) for a in plan.axes if a.mode != "interp"]))
        if own > cache.max_texels:
            return "limit"
    fine_axes = {}
    it = iter(zip(combo, sizes))
    for a in plan.axes:
        if a.mode == "interp":
            sp, n = next(it)
            fine_axes[a.name] = {"size": 2 * n - 1, "spacing": sp, "nodes": "endpoints", "range": list(a.range)}
        else:
            fine_axes[a.name] = list(a.values)
    texels = int(np.prod([v["size"] if isinstance(v, dict) else len(v) for v in fine_axes.values()]))
    if texels > MAX_CHECK_TEXELS or any(n > MAX_NODES for n in sizes):
        return None
    fine = cache(_table_spec(plan.kind, plan.distribution, plan.shadowing, plan.fresnel, fine_axes, plan.integration_tol))
    trial = [AxisPlan(a.name, a.mode, a.values, a.range) for a in plan.axes]
    it = iter(zip(combo, sizes))
    for a in trial:
        if a.mode == "interp":
            a.spacing, a.size = next(it)
    probe = TablePlan(plan.file, plan.kind, plan.distribution, plan.shadowing, plan.fresnel, trial, [], plan.integration_tol)
    total, per_axis = _errors(probe, fine, interpolation, list(sizes))
    return total, per_axis, fine


def _plan_table(plan: TablePlan, spacings: list[str], lookup_tol: float, interpolation: str, cache: _Cache,
                log: Callable[[str], None] | None = None) -> None:
    """Best-first search over (spacing combination, doubling-ladder sizes).

    Every spacing combination starts at 2 nodes per interpolated axis; the candidate with the
    fewest texels is verified next (ties: the earlier combination); a failing candidate doubles
    its axis whose midpoints err most. The first candidate verified below ``PLAN_MARGIN * lookup_tol``
    is the smallest on the ladder.
    """
    interp = [a for a in plan.axes if a.mode == "interp"]
    combos: list[tuple] = [()]
    for a in interp:
        opts = spacings if a.range[0] >= 0.0 else ["linear"]
        combos = [c + (sp,) for c in combos for sp in opts]
    target = PLAN_MARGIN * lookup_tol
    frontier = [(1 if not interp else 2 ** len(interp), ci, tuple(2 for _ in interp)) for ci in range(len(combos))]
    best = None
    limited = False
    while frontier:
        frontier.sort()
        texels, ci, sizes = frontier.pop(0)
        res = _check(plan, combos[ci], sizes, interpolation, cache)
        if res == "limit":
            limited = True
            continue
        if res is None:
            continue
        total, per_axis, fine = res
        if log is not None:
            shape = " x ".join(f"{a.name} {n} {sp}" for a, n, sp in zip(interp, sizes, combos[ci])) or "discrete axes only"
            log(f"{plan.file}: {shape}: lookup error {total:.3g} ({'ok' if total <= target else 'refine'}; "
                f"target {target:.3g})")
        if total <= target or not interp:
            best = (combos[ci], sizes, total, fine)
            break
        worst = int(np.argmax(per_axis))
        grown = tuple(2 * n - 1 if k == worst else n for k, n in enumerate(sizes))
        frontier.append((int(np.prod(grown)), ci, grown))
    if best is None and limited:
        raise TexelLimitError(
            "tol",
            f"table {plan.file} cannot reach a lookup error of {lookup_tol:g} within the limit of "
            f"{cache.max_texels} texels per table; loosen tol",
            limit=cache.max_texels,
        )
    if best is None:
        raise SpecError(
            "tol",
            f"cannot reach a lookup error of {lookup_tol:g} for table {plan.file} within {MAX_NODES} nodes per "
            f"axis ({MAX_CHECK_TEXELS} check texels); loosen tol",
        )
    combo, sizes, err, fine = best
    for a, s, n in zip(interp, combo, sizes):
        a.spacing, a.size = s, n
    plan.max_error = err
    # the planned table: the nodes of the verified fine grid at even indices (nested ladder)
    sl = tuple(slice(None, None, 2) if a.mode == "interp" else slice(None) for a in plan.axes)
    axes = {a.name: a.nodes() for a in plan.axes}
    channels = {c: np.ascontiguousarray(np.asarray(v)[sl]) for c, v in fine.channels.items()}
    meta = dict(fine.meta)
    meta["spec"] = normalize_spec(plan.spec())
    table = Table(axes=axes, channels=channels, meta=meta)
    meta["max_error"] = table.max_error()
    meta["lookup_max_error"] = err
    plan.table = table
    if cache.max_texels is not None and int(np.prod(plan.fixed_shape)) > cache.max_texels:
        return  # the comparison would itself exceed the caller's texel limit: fixed_error stays nan
    plan.fixed_error = _fixed_error(plan, fine, interpolation, cache)
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
    cache = _Cache(device, workers, max_texels, scheduler)
    spacings = sc["lookup"]["spacings"]
    interpolation = sc["lookup"]["interpolation"]
    groups: dict[tuple, list[dict]] = {}
    for m in sc["materials"]:
        groups.setdefault(_group_key(m), []).append(m)
    tables: list[TablePlan] = []
    manifest: dict[str, dict] = {}
    counts: dict[str, int] = {}
    for key, mats in groups.items():
        kind, dist, shadowing = key[:3]
        rname = "roughness" if all(m["rough_name"] == "roughness" for m in mats) else "alpha"
        axes = [AxisPlan("mu", "interp", range=(0.0, 1.0), spacing=spacings[0], size=2),
                _merge_axis(rname, _rough_entries(mats, rname), spacings)]
        fresnel = None
        if kind == "albedo":
            fresnel = {"type": "conductor", "eta": key[3], "k": key[4]}
        elif kind == "dielectric":
            axes.append(_merge_axis("eta", [m["eta_axis"] for m in mats], spacings))
        base = f"{dist}_{shadowing}_{kind}"
        counts[base] = counts.get(base, 0) + 1
        fname = f"{base}_{counts[base]}.exr" if kind == "albedo" else f"{base}.exr"
        tp = TablePlan(fname, kind, dist, shadowing, fresnel, axes, [m["name"] for m in mats],
                       integration_tol=max(lookup_tol / INTEGRATION_DIVISOR, MIN_INTEGRATION_TOL))
        _plan_table(tp, spacings, lookup_tol, interpolation, cache, log)
        tables.append(tp)
        for m in mats:
            manifest[m["name"]] = material_entry(m, tp, rname)
    return ScenePlan(lookup_tol, interpolation, tables, manifest, tabulate_calls=cache.calls)


