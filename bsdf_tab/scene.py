"""Scenes: plan and bake the minimal set of tables a scene needs, at the accuracy it needs.

A *scene* is a JSON object with a ``materials`` list (see ``docs/scenes.md`` and
``examples/scene.json``)::

    {"lookup": {"interpolation": "linear", "spacings": ["linear", "square"]},
     "materials": [
       {"name": "gold", "type": "conductor", "eta": 0.18, "k": 3.42, "roughness": {"range": [0.3, 0.6]}},
       {"name": "plastic", "type": "schlick", "f0": 0.04, "alpha": [0.1, 0.2]},
       {"name": "glass", "type": "dielectric", "eta": 1.5, "alpha": 0.05}]}

Material keys: ``name`` (unique), ``type`` (``conductor``, ``dielectric``, ``schlick``),
``distribution`` (``ggx``, ``beckmann``), ``shadowing`` (``correlated``, ``separable``), one of
``alpha`` or ``roughness`` (alpha = roughness^2) as a number, a list of numbers or
``{"range": [lo, hi]}``; conductors: ``eta`` and ``k`` (complex IOR; or ``"ior": [eta, k]``);
dielectrics: ``eta`` (number, list or range; eta = eta_o / eta_i); Schlick: ``f0`` (number or
RGB list; it does not enter the table).

Planner (:func:`plan_scene`):

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
  midpoint by tabulating the refined grid (the nodes of the next rung), is below ``tol``:
  error = max |lookup(table) - direct| + max integration error of the direct values. The axis
  whose midpoints err most is refined first. Every spacing combination is tried; the one with
  the fewest texels wins (ties: the first, in the order the scene lists spacings).
- the table's own integration tolerance is ``tol / 20``.

Bytes are counted as float32 value channels (error channels are not shipped to a renderer).
The fixed-size alternative is one Cycles-style table per planned table: 32 x 32 for the 2-D
kinds, 16^3 for dielectrics, linear in each axis; the plan reports its bytes and its lookup error
at the same check points (:meth:`TablePlan.fixed_axes`).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

import numpy as np

from .errors import SpecError, TexelLimitError

__all__ = ["parse_scene", "plan_scene", "bake_scene", "lookup", "axes_from_manifest", "ScenePlan", "TablePlan", "AxisPlan", "is_scene", "check_tol"]

MATERIAL_TYPES = ("conductor", "dielectric", "schlick")
INTERPOLATIONS = ("linear", "nearest")
SPACINGS = ("linear", "square")
TOL_RANGE = (1e-6, 1e-1)
PLAN_MARGIN = 0.8  # plan to 0.8 tol at the midpoints: headroom for points between them
MAX_NODES = 1025
MAX_CHECK_TEXELS = 300_000
FIXED_SIZES = {"albedo": (32, 32), "dfg": (32, 32), "dielectric": (16, 16, 16)}
CHANNELS = {"albedo": ("E",), "dfg": ("A", "B"), "dielectric": ("R", "T")}
MATERIAL_KEYS = {
    "conductor": ("eta", "k", "ior"),
    "dielectric": ("eta",),
    "schlick": ("f0",),
}
COMMON_KEYS = ("name", "type", "distribution", "shadowing", "alpha", "roughness")


# --------------------------------------------------------------------------- parsing


def _num(v: Any, param: str, lo: float | None = None, hi: float | None = None, lo_open: bool = False) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise SpecError(param, f"must be a number, got {v!r}")
    x = float(v)
    if not math.isfinite(x):
        raise SpecError(param, f"must be finite, got {v!r}")
    if lo is not None and (x <= lo if lo_open else x < lo):
        raise SpecError(param, f"must be {'>' if lo_open else '>='} {lo:g}, got {x!r}")
    if hi is not None and x > hi:
        raise SpecError(param, f"must be <= {hi:g}, got {x!r}")
    return x


def check_tol(tol: Any, param: str = "tolerance") -> float:
    """A lookup tolerance: a finite number in ``TOL_RANGE`` (SpecError naming ``param`` otherwise)."""
    return _num(tol, param, *TOL_RANGE)


def _values(v: Any, param: str, lo: float, hi: float, lo_open: bool = False) -> dict:
    """A number, a non-empty list of numbers or {"range": [lo, hi]} -> {"values": [...]} or {"range": [...]}."""
    if isinstance(v, dict):
        if set(v) != {"range"}:
            raise SpecError(param, f"must be a number, a list of numbers or {{\"range\": [lo, hi]}}, got {v!r}")
        r = v["range"]
        if not isinstance(r, (list, tuple)) or len(r) != 2:
            raise SpecError(f"{param}.range", f"must be [lo, hi], got {r!r}")
        a = _num(r[0], f"{param}.range", lo, hi, lo_open)
        b = _num(r[1], f"{param}.range", lo, hi, lo_open)
        if not a < b:
            raise SpecError(f"{param}.range", f"must have lo < hi, got {list(r)!r}")
        return {"range": [a, b]}
    if isinstance(v, (list, tuple)):
        if not v:
            raise SpecError(param, "must not be empty")
        return {"values": sorted({_num(x, param, lo, hi, lo_open) for x in v})}
    return {"values": [_num(v, param, lo, hi, lo_open)]}


def _choice(v: Any, options, param: str) -> str:
    if not isinstance(v, str) or v not in options:
        raise SpecError(param, f"must be one of {', '.join(options)}, got {v!r}")
    return v


def is_scene(obj: Any) -> bool:
    """True for a JSON object with a top-level ``materials`` key (a scene, not a table spec)."""
    return isinstance(obj, dict) and "materials" in obj


def parse_scene(scene: dict | str) -> dict:
    """Validate a scene and return its normalized form.

    Raises
    ------
    SpecError
        Naming the parameter (``materials[1].alpha``, ``lookup.interpolation``, ...).
    """
    if isinstance(scene, (str, bytes, bytearray)):
        try:
            scene = json.loads(scene)
        except json.JSONDecodeError as exc:
            raise SpecError(None, f"invalid JSON: {exc}") from None
    if not isinstance(scene, dict):
        raise SpecError(None, f"a scene must be a JSON object, got {type(scene).__name__}")
    for key in scene:
        if key not in ("materials", "lookup", "tolerance", "name"):
            raise SpecError(str(key), "unknown scene parameter; allowed: name, materials, lookup, tolerance")
    lk = scene.get("lookup", {})
    if not isinstance(lk, dict):
        raise SpecError("lookup", f"must be an object, got {lk!r}")
    for key in lk:
        if key not in ("interpolation", "spacings"):
            raise SpecError(f"lookup.{key}", "unknown parameter; allowed: interpolation, spacings")
    interp = _choice(lk.get("interpolation", "linear"), INTERPOLATIONS, "lookup.interpolation")
    spacings = lk.get("spacings", list(SPACINGS))
    if not isinstance(spacings, list) or not spacings:
        raise SpecError("lookup.spacings", f"must be a non-empty list of {', '.join(SPACINGS)}, got {spacings!r}")
    alias = {"sqrt": "square"}  # t uniform in sqrt(x)
    spacings = list(dict.fromkeys(_choice(alias.get(s, s) if isinstance(s, str) else s, SPACINGS, "lookup.spacings")
                                  for s in spacings))
    out: dict[str, Any] = {"lookup": {"interpolation": interp, "spacings": spacings}}
    if "tolerance" in scene:
        out["tolerance"] = check_tol(scene["tolerance"])
    mats = scene.get("materials")
    if not isinstance(mats, list) or not mats:
        raise SpecError("materials", "must be a non-empty list of materials")
    out["materials"] = []
    names = set()
    for i, m in enumerate(mats):
        nm = _material(m, f"materials[{i}]")
        if nm["name"] in names:
            raise SpecError(f"materials[{i}].name", f"duplicate material name {nm['name']!r}")
        names.add(nm["name"])
        out["materials"].append(nm)
    return out


def _material(m: Any, p: str) -> dict:
    if not isinstance(m, dict):
        raise SpecError(p, f"must be an object, got {m!r}")
    if "type" not in m:
        raise SpecError(f"{p}.type", f"is required; must be one of {', '.join(MATERIAL_TYPES)}")
    mtype = _choice(m["type"], MATERIAL_TYPES, f"{p}.type")
    allowed = COMMON_KEYS + MATERIAL_KEYS[mtype]
    for key in m:
        if key not in allowed:
            raise SpecError(f"{p}.{key}", f"unknown parameter for a {mtype} material; allowed: {', '.join(allowed)}")
    name = m.get("name", p)
    if not isinstance(name, str) or not name:
        raise SpecError(f"{p}.name", f"must be a non-empty string, got {name!r}")
    out = {
        "name": name,
        "type": mtype,
        "distribution": _choice(m.get("distribution", "ggx"), ("ggx", "beckmann"), f"{p}.distribution"),
        "shadowing": _choice(m.get("shadowing", "correlated"), ("correlated", "separable"), f"{p}.shadowing"),
    }
    given = [k for k in ("alpha", "roughness") if k in m]
    if len(given) != 1:
        raise SpecError(f"{p}.alpha", "give exactly one of alpha, roughness (alpha = roughness^2)")
    rk = given[0]
    out["rough_name"] = rk
    out["rough"] = _values(m[rk], f"{p}.{rk}", 0.0, 4.0 if rk == "alpha" else 2.0)
    if mtype == "conductor":
        if "ior" in m:
            if "eta" in m or "k" in m:
                raise SpecError(f"{p}.ior", "give either ior [eta, k] or eta and k, not both")
            ior = m["ior"]
            if not isinstance(ior, (list, tuple)) or len(ior) != 2:
                raise SpecError(f"{p}.ior", f"must be [eta, k], got {ior!r}")
            eta, k = ior
            ep, kp = f"{p}.ior", f"{p}.ior"
        else:
            for key in ("eta", "k"):
                if key not in m:
                    raise SpecError(f"{p}.{key}", "is required for a conductor (complex IOR eta + i k)")
            eta, k = m["eta"], m["k"]
            ep, kp = f"{p}.eta", f"{p}.k"
        out["eta"] = _num(eta, ep, 0.0, 100.0, lo_open=True)
        out["k"] = _num(k, kp, 0.0, 100.0)
    elif mtype == "dielectric":
        if "eta" not in m:
            raise SpecError(f"{p}.eta", "is required for a dielectric (eta = eta_o / eta_i)")
        out["eta_axis"] = _values(m["eta"], f"{p}.eta", 0.0, 100.0, lo_open=True)
    else:
        if "f0" not in m:
            raise SpecError(f"{p}.f0", "is required for a Schlick material")
        f0 = m["f0"]
        out["f0"] = [_num(x, f"{p}.f0", 0.0, 1.0) for x in f0] if isinstance(f0, list) else _num(f0, f"{p}.f0", 0.0, 1.0)
    return out


# --------------------------------------------------------------------------- plan data


@dataclass
class AxisPlan:
    """One axis of a planned table: ``interp`` (spacing, range, size) or ``discrete`` (values)."""

    name: str
    mode: str  # "interp" | "discrete"
    values: list[float] = field(default_factory=list)  # discrete
    range: tuple[float, float] = (0.0, 1.0)
    spacing: str = "linear"
    size: int = 2

    def nodes(self) -> np.ndarray:
        if self.mode == "discrete":
            return np.asarray(self.values, dtype=np.float64)
        return _spaced(self.range, self.spacing, self.size)

    def spec(self):
        if self.mode == "discrete":
            return list(self.values)
        return {"size": self.size, "spacing": self.spacing, "nodes": "endpoints", "range": list(self.range)}

    def coord(self, x: np.ndarray) -> np.ndarray:
        """Fractional texel coordinate of values ``x`` (as the renderer computes it)."""
        x = np.asarray(x, dtype=np.float64)
        if self.mode == "discrete":
            vals = np.asarray(self.values)
            idx = np.searchsorted(vals, x)
            idx = np.clip(idx, 0, len(vals) - 1)
            left = np.clip(idx - 1, 0, len(vals) - 1)
            idx = np.where(np.abs(vals[left] - x) < np.abs(vals[idx] - x), left, idx)
            return idx.astype(np.float64)
        g = np.sqrt if self.spacing == "square" else (lambda v: v)
        lo, hi = self.range
        t = (g(np.clip(x, lo, hi)) - g(lo)) / (g(hi) - g(lo))
        return t * (self.size - 1)

    def describe(self) -> dict:
        if self.mode == "discrete":
            return {"name": self.name, "lookup": "index", "values": list(self.values), "size": len(self.values)}
        g = "sqrt(x)" if self.spacing == "square" else "x"
        glo = f"sqrt({self.range[0]:.6g})" if self.spacing == "square" else f"{self.range[0]:.6g}"
        ghi = f"sqrt({self.range[1]:.6g})" if self.spacing == "square" else f"{self.range[1]:.6g}"
        return {
            "name": self.name,
            "lookup": "interpolate",
            "spacing": self.spacing,
            "range": list(self.range),
            "size": self.size,
            "coordinate": f"t = ({g} - {glo}) / ({ghi} - {glo}) * {self.size - 1}  (texel index, endpoints nodes)",
        }


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
    tolerance: float  # integration tolerance of the table
    max_error: float = math.nan  # verified lookup error at the midpoints (plus integration error)
    table: Any = None  # the baked Table (values at the planned nodes)
    fixed_error: float = math.nan  # the fixed-size alternative's lookup error at the same points

    @property
    def channels(self) -> tuple[str, ...]:
        return CHANNELS[self.kind]

    @property
    def shape(self) -> tuple[int, ...]:
        return tuple(len(a.nodes()) for a in self.axes)

    @property
    def bytes(self) -> int:
        return int(np.prod(self.shape)) * len(self.channels) * 4

    @property
    def fixed_bytes(self) -> int:
        return int(np.prod(FIXED_SIZES[self.kind])) * len(self.channels) * 4

    def fixed_axes(self) -> list[AxisPlan]:
        """The fixed-size alternative: linear axes with ``FIXED_SIZES`` endpoint nodes, mu and
        alpha / roughness over [0, max(1, hi)], eta over the hull of the scene's eta values
        (a single eta: that value only, which favours the fixed table)."""
        out = []
        for a, n in zip(self.axes, FIXED_SIZES[self.kind]):
            lo, hi = (min(a.values), max(a.values)) if a.mode == "discrete" else a.range
            if a.name != "eta":
                lo, hi = 0.0, max(1.0, hi)
            out.append(AxisPlan(a.name, "interp", range=(lo, hi), spacing="linear", size=n) if hi > lo
                       else AxisPlan(a.name, "discrete", values=[lo]))
        return out

    def spec(self) -> dict:
        return _table_spec(self.kind, self.distribution, self.shadowing, self.fresnel,
                           {a.name: a.spec() for a in self.axes}, self.tolerance)


@dataclass
class ScenePlan:
    tolerance: float
    interpolation: str
    tables: list[TablePlan]
    materials: dict[str, dict]  # name -> manifest entry

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
        return {
            "tolerance": self.tolerance,
            "interpolation": self.interpolation,
            "bytes": self.bytes,
            "fixed_bytes": self.fixed_bytes,
            "max_error": self.max_error,
            "fixed_max_error": _finite_or_none(self.fixed_error),
            "tables": [
                {
                    "file": t.file,
                    "table": t.kind,
                    "distribution": t.distribution,
                    "shadowing": t.shadowing,
                    "fresnel": t.fresnel,
                    "channels": list(t.channels),
                    "axes": [a.describe() for a in t.axes],
                    "shape": list(t.shape),
                    "bytes": t.bytes,
                    "max_error": t.max_error,
                    "integration_tolerance": t.tolerance,
                    "fixed_alternative": {"shape": list(FIXED_SIZES[t.kind]), "bytes": t.fixed_bytes,
                                          "max_error": _finite_or_none(t.fixed_error),
                                          "axes": [a.describe() for a in t.fixed_axes()]},
                    "materials": list(t.materials),
                    "spec": t.spec(),
                }
                for t in self.tables
            ],
            "materials": self.materials,
        }

    def text(self) -> str:
        lines = [f"plan for tol {self.tolerance:g} ({self.interpolation} lookup): {len(self.tables)} table(s)"]
        for t in self.tables:
            axes = " x ".join(
                f"{a.name} {len(a.values)} (values)" if a.mode == "discrete"
                else f"{a.name} {a.size} ({a.spacing} [{a.range[0]:.4g}, {a.range[1]:.4g}])"
                for a in t.axes
            )
            fixed = " x ".join(str(n) for n in FIXED_SIZES[t.kind])
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
            f"{pct:.1f}%); max lookup error {self.max_error:.3g} <= tol {self.tolerance:g} "
            + (f"(fixed-size alternative: {self.fixed_error:.3g} at the same points)" if not math.isnan(self.fixed_error)
               else "(fixed-size alternative's error not computed: above the texel limit)")
        )
        return "\n".join(lines)


# --------------------------------------------------------------------------- helpers


def _finite_or_none(x: float) -> float | None:
    """JSON has no nan: a comparison that was not computed is null."""
    return None if math.isnan(x) else x


def _err_text(x: float) -> str:
    return "not computed (above the texel limit)" if math.isnan(x) else f"{x:.3g}"


def _spaced(rng, spacing: str, n: int) -> np.ndarray:
    lo, hi = rng
    t = np.arange(n, dtype=np.float64) / (n - 1) if n > 1 else np.zeros(1)
    if spacing == "square":
        x = (math.sqrt(lo) + (math.sqrt(hi) - math.sqrt(lo)) * t) ** 2
    else:
        x = lo + (hi - lo) * t
    x[0] = lo
    if n > 1:
        x[-1] = hi
    return x


def _table_spec(kind, dist, shadowing, fresnel, axes: dict, tol: float) -> dict:
    spec = {"table": kind, "distribution": dist, "shadowing": shadowing, "axes": axes, "tolerance": tol}
    if fresnel is not None:
        spec["fresnel"] = fresnel
    return spec


def lookup(values: np.ndarray, axes: list[AxisPlan], points: list[np.ndarray], interpolation: str,
           round_down: tuple[bool, ...] | None = None) -> np.ndarray:
    """Look a table up at points as a renderer does.

    ``values`` is shaped by the axes; ``points`` one array of coordinates per axis (broadcast
    together). Interpolated axes: multilinear (``linear``) or nearest texel in the texel
    coordinate t; discrete axes: the texel of the value. ``round_down`` (per axis, nearest
    lookup): a tie t = i + 1/2 goes to texel i instead of i + 1 (the planner checks both sides
    of every cell boundary).
    """
    pts = np.broadcast_arrays(*[np.asarray(p, dtype=np.float64) for p in points])
    idx0, wts = [], []
    for k, (ax, p) in enumerate(zip(axes, pts)):
        t = ax.coord(p)
        n = len(ax.nodes())
        if ax.mode == "discrete" or n == 1 or interpolation == "nearest":
            down = round_down is not None and round_down[k] and ax.mode == "interp"
            i = np.clip(np.ceil(t - 0.5) if down else np.floor(t + 0.5), 0, n - 1).astype(np.int64)
            idx0.append(i)
            wts.append(None)
        else:
            i = np.clip(np.floor(t), 0, n - 2).astype(np.int64)
            idx0.append(i)
            wts.append(t - i)
    out = np.zeros(pts[0].shape)
    d = len(axes)
    for corner in range(1 << d):
        w = np.ones(pts[0].shape)
        index = []
        skip = False
        for a in range(d):
            bit = (corner >> a) & 1
            if wts[a] is None:
                if bit:
                    skip = True
                    break
                index.append(idx0[a])
            else:
                w = w * (wts[a] if bit else 1.0 - wts[a])
                index.append(idx0[a] + bit)
        if skip:
            continue
        out = out + w * values[tuple(index)]
    return out


class _Cache:
    """Memoized tabulate calls, keyed by the canonical spec."""

    def __init__(self, tabulate: Callable, device, workers, max_texels: int | None = None):
        self.tabulate, self.device, self.workers = tabulate, device, workers
        self.max_texels = max_texels
        self.tables: dict[str, Any] = {}
        self.calls = 0

    def __call__(self, spec: dict):
        key = json.dumps(spec, sort_keys=True)
        if key not in self.tables:
            self.calls += 1
            self.tables[key] = self.tabulate(spec, device=self.device, workers=self.workers)
        return self.tables[key]


# --------------------------------------------------------------------------- planning


def _group_key(m: dict) -> tuple:
    if m["type"] == "conductor":
        return ("albedo", m["distribution"], m["shadowing"], m["eta"], m["k"])
    if m["type"] == "schlick":
        return ("dfg", m["distribution"], m["shadowing"])
    return ("dielectric", m["distribution"], m["shadowing"])


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
    vals = {ch: np.asarray(fine.channels[ch], dtype=np.float64) for ch in CHANNELS[kind]}
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
                              {a.name: a.spec() for a in axes}, plan.tolerance))
    grids, vals, errs = _fine_grid(fine, plan.kind)
    diffs = {ch: lookup(np.asarray(fixed.channels[ch], dtype=np.float64), axes, grids, interpolation) - v
             for ch, v in vals.items()}
    fixed_err = {ch: np.max(np.asarray(fixed.channels[ch + "_err"], dtype=np.float64)) for ch in vals}
    return float(np.max(_combine(plan.kind, diffs, errs))) + max(fixed_err.values())


def _check(plan: TablePlan, combo, sizes, tol: float, interpolation: str, cache: _Cache):
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
    fine = cache(_table_spec(plan.kind, plan.distribution, plan.shadowing, plan.fresnel, fine_axes, plan.tolerance))
    trial = [AxisPlan(a.name, a.mode, a.values, a.range) for a in plan.axes]
    it = iter(zip(combo, sizes))
    for a in trial:
        if a.mode == "interp":
            a.spacing, a.size = next(it)
    probe = TablePlan(plan.file, plan.kind, plan.distribution, plan.shadowing, plan.fresnel, trial, [], plan.tolerance)
    total, per_axis = _errors(probe, fine, interpolation, list(sizes))
    return total, per_axis, fine


def _plan_table(plan: TablePlan, spacings: list[str], tol: float, interpolation: str, cache: _Cache,
                log: Callable[[str], None] | None = None) -> None:
    """Best-first search over (spacing combination, doubling-ladder sizes).

    Every spacing combination starts at 2 nodes per interpolated axis; the candidate with the
    fewest texels is verified next (ties: the earlier combination); a failing candidate doubles
    its axis whose midpoints err most. The first candidate verified below ``PLAN_MARGIN * tol``
    is the smallest on the ladder.
    """
    interp = [a for a in plan.axes if a.mode == "interp"]
    combos: list[tuple] = [()]
    for a in interp:
        opts = spacings if a.range[0] >= 0.0 else ["linear"]
        combos = [c + (sp,) for c in combos for sp in opts]
    target = PLAN_MARGIN * tol
    frontier = [(1 if not interp else 2 ** len(interp), ci, tuple(2 for _ in interp)) for ci in range(len(combos))]
    best = None
    limited = False
    while frontier:
        frontier.sort()
        texels, ci, sizes = frontier.pop(0)
        res = _check(plan, combos[ci], sizes, tol, interpolation, cache)
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
            "tolerance",
            f"table {plan.file} cannot reach {tol:g} within the limit of {cache.max_texels} texels per table; "
            "loosen the tolerance",
            limit=cache.max_texels,
        )
    if best is None:
        raise SpecError(
            "tolerance",
            f"cannot reach {tol:g} for table {plan.file} within {MAX_NODES} nodes per axis "
            f"({MAX_CHECK_TEXELS} check texels); loosen the tolerance",
        )
    combo, sizes, err, fine = best
    for a, s, n in zip(interp, combo, sizes):
        a.spacing, a.size = s, n
    plan.max_error = err
    # the planned table: the nodes of the verified fine grid at even indices (nested ladder)
    from .table import Table

    sl = tuple(slice(None, None, 2) if a.mode == "interp" else slice(None) for a in plan.axes)
    axes = {a.name: a.nodes() for a in plan.axes}
    channels = {c: np.ascontiguousarray(np.asarray(v)[sl]) for c, v in fine.channels.items()}
    meta = dict(fine.meta)
    from .spec import normalize_spec

    meta["spec"] = normalize_spec(plan.spec())
    table = Table(axes=axes, channels=channels, meta=meta)
    meta["max_error"] = table.max_error()
    meta["lookup_max_error"] = err
    plan.table = table
    if cache.max_texels is not None and int(np.prod(FIXED_SIZES[plan.kind])) > cache.max_texels:
        return  # the comparison would itself exceed the caller's texel limit: fixed_error stays nan
    plan.fixed_error = _fixed_error(plan, fine, interpolation, cache)
    if log is not None:
        log(f"{plan.file}: fixed-size alternative {' x '.join(map(str, FIXED_SIZES[plan.kind]))}: "
            f"lookup error {plan.fixed_error:.3g} at the same points")


def plan_scene(
    scene: dict | str,
    tol: float | None = None,
    *,
    device: str | None = None,
    workers: int | None = None,
    tabulate: Callable | None = None,
    max_texels: int | None = None,
    log: Callable[[str], None] | None = None,
) -> ScenePlan:
    """Plan (and compute) the minimal tables of a scene for lookup error ``tol``.

    Parameters
    ----------
    scene : dict or str
        The scene (see module docs).
    tol : float, optional
        Max lookup error (absolute, per channel; dfg: of E = f0 A + B for any f0). Default: the
        scene's ``tolerance``.
    tabulate : callable, optional
        ``tabulate(spec, device=, workers=)``; default :func:`bsdf_tab.api.tabulate`.
    max_texels : int, optional
        Largest table the caller accepts. Candidates above it are skipped before anything is
        computed; when no smaller candidate meets ``tol``, :class:`TexelLimitError`.
    log : callable, optional
        Receives one line per verified candidate (progress; the CLI prints them on stderr).

    Returns
    -------
    ScenePlan
        Tables (with their computed ``Table``), bytes, verified errors, manifest entries.
    """
    sc = parse_scene(scene)
    if tol is None:
        if "tolerance" not in sc:
            raise SpecError("tolerance", "is required: give --tol T (or a scene 'tolerance')")
        tol = sc["tolerance"]
    tol = check_tol(tol)
    if tabulate is None:
        from .api import tabulate
    cache = _Cache(tabulate, device, workers, max_texels)
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
                       tolerance=max(tol / 20.0, 1e-9))
        _plan_table(tp, spacings, tol, interpolation, cache, log)
        tables.append(tp)
        for m in mats:
            manifest[m["name"]] = _manifest_entry(m, tp, rname)
    plan = ScenePlan(tol, interpolation, tables, manifest)
    plan.tabulate_calls = cache.calls  # type: ignore[attr-defined]
    return plan


def _manifest_entry(m: dict, tp: TablePlan, rname: str) -> dict:
    coords: dict[str, Any] = {"mu": "cos(theta_i) of the shading point"}
    r = m["rough"] if m["rough_name"] == rname else {k: [v * v for v in vs] for k, vs in m["rough"].items()}
    src = {rname: r}
    if m["type"] == "dielectric":
        src["eta"] = m["eta_axis"]
    for ax in tp.axes[1:]:
        given = src[ax.name]
        if ax.mode == "discrete":
            idx = [int(ax.coord(np.array([v]))[0]) for v in given["values"]]
            coords[ax.name] = {"values": given["values"], "index": idx}
        else:
            coords[ax.name] = given.get("values") and {"values": given["values"]} or {"range": given["range"]}
    entry = {"type": m["type"], "table": tp.file, "channels": list(tp.channels), "coords": coords}
    if m["rough_name"] != rname:
        entry["note"] = f"the table's {rname} axis is alpha: look up alpha = roughness^2"
    if m["type"] == "schlick":
        entry["f0"] = m["f0"]
        entry["formula"] = "E = f0 * A + B"
    elif m["type"] == "conductor":
        entry["fresnel"] = {"type": "conductor", "eta": m["eta"], "k": m["k"]}
        entry["formula"] = "E (albedo with this conductor's exact Fresnel)"
    else:
        entry["formula"] = "R, T (energy form; eta = eta_o / eta_i)"
    return entry


def axes_from_manifest(entry: dict) -> list[AxisPlan]:
    """The :class:`AxisPlan` list of one ``tables[i]`` entry of a manifest (for :func:`lookup`)."""
    out = []
    for a in entry["axes"]:
        if a["lookup"] == "index":
            out.append(AxisPlan(a["name"], "discrete", values=list(a["values"])))
        else:
            out.append(AxisPlan(a["name"], "interp", range=tuple(a["range"]), spacing=a["spacing"], size=a["size"]))
    return out


def bake_scene(plan: ScenePlan, out_dir: str | Path) -> Path:
    """Write the plan's tables (EXR) and ``manifest.json`` into ``out_dir``; return the manifest path."""
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise SpecError("output", f"{out} exists and is not a folder")
    out.mkdir(parents=True, exist_ok=True)
    for t in plan.tables:
        t.table.write_exr(out / t.file)
    manifest = plan.to_dict()
    path = out / "manifest.json"
    path.write_text(json.dumps(manifest, indent=2, default=_json_default) + "\n", encoding="utf-8")
    return path


def _json_default(obj):
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    raise TypeError(type(obj).__name__)


# --------------------------------------------------------------------------- CLI


def load_scene_file(path: str | Path) -> Any:
    """The contents of a scene (or spec) file: TOML for a ``.toml`` name, JSON otherwise.

    Raises
    ------
    SpecError
        A missing or unreadable file, or invalid JSON / TOML (one line naming the file).
    """
    import tomllib

    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise SpecError(None, f"file not found: {p}") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise SpecError(None, f"cannot read {p}: {exc}") from None
    if p.suffix.lower() == ".toml":
        try:
            return tomllib.loads(text)
        except tomllib.TOMLDecodeError as exc:
            raise SpecError(None, f"{p}: invalid TOML: {exc}") from None
    try:
        return json.loads(text)
    except json.JSONDecodeError as exc:
        raise SpecError(None, f"{p}: invalid JSON: {exc}") from None


def configure_plan(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("scene", help="scene file, JSON or .toml (a 'materials' list; docs/scenes.md)")
    parser.add_argument("--tol", type=float, default=None, help="max lookup error (default: the scene's tolerance)")
    parser.add_argument("--json", action="store_true", help="print the plan as JSON")
    parser.add_argument("--device", default=None, help="Warp device (default: Warp's)")
    parser.add_argument("--workers", type=int, default=None, help="number of parallel workers")
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress lines on stderr")


def _plan_from_args(args: argparse.Namespace) -> ScenePlan:
    from .cli import _quiet_warp

    path = getattr(args, "scene", None) or args.spec
    if args.workers is not None and args.workers < 1:
        raise SpecError("workers", "--workers must be >= 1")
    scene = load_scene_file(path)
    if not is_scene(scene):
        raise SpecError("materials", f"{path} is not a scene (no top-level 'materials' list)")
    _quiet_warp(args)

    def log(line: str) -> None:
        print(line, file=sys.stderr, flush=True)

    try:
        return plan_scene(scene, args.tol, device=args.device, workers=args.workers,
                          log=None if getattr(args, "quiet", False) else log)
    except SpecError as exc:
        raise SpecError(None, f"{path}: {exc}") from None


def cmd_plan(args: argparse.Namespace) -> int:
    """``bsdf-tab plan SCENE --tol T``: print the plan."""
    plan = _plan_from_args(args)
    if args.json:
        print(json.dumps(plan.to_dict(), indent=2, default=_json_default))
    else:
        print(plan.text())
    return 0


def cmd_bake_scene(args: argparse.Namespace) -> int:
    """``bsdf-tab bake SCENE --tol T -o DIR``: bake the plan and its manifest."""
    if not args.output:
        raise SpecError("output", "give -o DIR: the folder for the scene's tables and manifest.json")
    plan = _plan_from_args(args)
    path = bake_scene(plan, args.output)
    print(plan.text())
    print(f"wrote {len(plan.tables)} table(s) and {path}")
    return 0
