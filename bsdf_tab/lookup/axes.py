"""How a table was baked, axis by axis, and the reference lookup that reads it that way.

Every axis of a table maps a physical value (``NdotV``, ``roughness``, ``alpha``, ``eta``, an
angle) to a fractional texel index ``t`` in ``[0, n - 1]``:

- ``uniform`` axes: nodes evenly spaced in ``g(x)``, ``g(x) = x`` (``linear`` spacing) or
  ``g(x) = sqrt(x)`` (``square`` spacing, Unity's ``sqrt(NdotV)``), over a ``range`` with
  ``endpoints`` (node i at ``u = i / (n - 1)``), ``centers`` (``u = (i + 1/2) / n``) or ``left``
  nodes (``u = i / n``), u = (g(x) - g(lo)) / (g(hi) - g(lo)). A ``clamp`` of the node values
  (Cycles' ``clamp(i / (n - 1), 1e-4, 1)``) does not move the nodes: node i stays at its
  unclamped coordinate, exactly as the engine reads it.
- ``nodes`` axes (irregular explicit values, e.g. an IOR axis): ``t = i + (x - x_i) /
  (x_{i+1} - x_i)`` between the bracketing nodes (linear in x).

An axis may be stored in decreasing order (Godot's roughness rows, EEVEE's ``NV = 1 - y^2``):
a uniform axis then has ``range = (hi, lo)`` in node order (node 0 at ``hi``, a negative
scale), a ``nodes`` axis its values in decreasing order (bracketed with ``x_{i+1} <= x <=
x_i``); the coordinate is clamped to ``[min, max]`` of the axis either way.

``t`` is clamped to ``[0, n - 1]`` (the table's ends are held, never extrapolated). The value
is the multilinear interpolation in ``t`` (:func:`bsdf_tab.scene.lookup`, the one
interpolation routine of the package). :func:`lookup_plan` reads the mapping from the spec
(``meta["spec"]["axes"]``) when it has a resolution, otherwise fits it to the axis values.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..scene import lookup as multilinear

__all__ = ["AxisMap", "LookupPlan", "PARAM_NAMES", "fit_axis", "lookup", "lookup_plan"]

#: Table axis -> the name of the lookup function's parameter.
PARAM_NAMES = {"mu": "NdotV", "roughness": "roughness", "alpha": "alpha", "eta": "eta"}

_NODE_OFFSET = {"endpoints": 0.0, "centers": -0.5, "left": 0.0}


@dataclass(frozen=True)
class AxisMap:
    """One table axis as a lookup reads it.

    Attributes
    ----------
    name : str
        The table axis (``mu``, ``roughness``, ...).
    size : int
        Number of nodes.
    kind : str
        ``uniform`` or ``nodes``.
    spacing, nodes : str
        ``linear`` / ``square``; ``endpoints`` / ``centers`` / ``left`` (uniform axes).
    range : tuple of float
        ``(g^-1(u = 0), g^-1(u = 1))`` of the uniform grid (before any clamp), in node order:
        ``(lo, hi)`` for an increasing axis, ``(hi, lo)`` for a decreasing one.
    clamp : tuple of float or None
        The clamp applied to the node values when baked, ``(min, max)``.
    values : tuple of float
        The node values (as baked, clamp included).
    """

    name: str
    size: int
    kind: str
    spacing: str = "linear"
    nodes: str = "endpoints"
    range: tuple[float, float] = (0.0, 1.0)
    clamp: tuple[float, float] | None = None
    values: tuple[float, ...] = ()
    mode: str = "interp"  # for bsdf_tab.scene.lookup

    def __len__(self) -> int:
        return self.size

    @property
    def param(self) -> str:
        """The lookup function's parameter for this axis."""
        return PARAM_NAMES.get(self.name, self.name)

    @property
    def decreasing(self) -> bool:
        """Whether the nodes decrease with the index (a reversed range, or decreasing values)."""
        if self.size < 2:
            return False
        if self.kind == "nodes":
            return self.values[-1] < self.values[0]
        return self.range[1] < self.range[0]

    def bounds(self) -> tuple[float, float]:
        """``(min, max)`` the coordinate is clamped to: the range (uniform) or the end nodes."""
        ends = (self.values[0], self.values[-1]) if self.kind == "nodes" else self.range
        return (float(min(ends)), float(max(ends)))

    def scale_offset(self) -> tuple[float, float, float, float]:
        """``(g(r0), g(r1), scale, offset)``: ``t = (g(x) - g(r0)) * scale + offset`` (uniform axes),
        ``(r0, r1) = range`` in node order (scale < 0 on a decreasing axis)."""
        g = math.sqrt if self.spacing == "square" else float
        glo, ghi = g(self.range[0]), g(self.range[1])
        n = self.size
        span = (n - 1) if self.nodes == "endpoints" else n
        scale = span / (ghi - glo) if ghi != glo else 0.0
        return glo, ghi, scale, _NODE_OFFSET[self.nodes]

    def coord(self, x) -> np.ndarray:
        """Fractional texel index of values ``x``, clamped to ``[0, n - 1]``."""
        x = np.asarray(x, dtype=np.float64)
        n = self.size
        if n == 1:
            return np.zeros(x.shape)
        lo, hi = self.bounds()
        xc = np.clip(x, lo, hi)
        if self.kind == "nodes":
            v = np.asarray(self.values, dtype=np.float64)
            # the last node i with v_i <= x (increasing) or v_i >= x (decreasing: search in -v)
            w, xw = (-v, -xc) if self.decreasing else (v, xc)
            i = np.clip(np.searchsorted(w, xw, side="right") - 1, 0, n - 2)
            with np.errstate(divide="ignore", invalid="ignore"):
                frac = np.clip((xc - v[i]) / (v[i + 1] - v[i]), 0.0, 1.0)
            t = i + np.nan_to_num(frac)
        else:
            glo, ghi, scale, offset = self.scale_offset()
            g = np.sqrt(xc) if self.spacing == "square" else xc
            t = (g - glo) * scale + offset
        return np.clip(t, 0.0, n - 1.0)

    def describe(self) -> dict:
        """The mapping as JSON (for metadata and generated comments)."""
        out = {"name": self.name, "param": self.param, "size": self.size, "kind": self.kind}
        if self.kind == "uniform":
            out.update(spacing=self.spacing, nodes=self.nodes, range=list(self.range),
                       clamp=list(self.clamp) if self.clamp else None)
        else:
            out["values"] = list(self.values)
        return out

    def formula(self) -> str:
        """The texel coordinate in words (``t = sqrt(NdotV) * 63``)."""
        p = self.param
        if self.size == 1:
            return "t = 0 (one node)"
        if self.kind == "nodes":
            lo, hi = self.bounds()
            order = (f"decreasing nodes: x_(i+1) <= {p} <= x_i" if self.decreasing
                     else f"x_i <= {p} <= x_(i+1)")
            return (f"t = i + ({p} - x_i) / (x_(i+1) - x_i) between the bracketing nodes ({order}; linear in "
                    f"{p}, clamped to [{lo:.9g}, {hi:.9g}])")
        glo, ghi, scale, offset = self.scale_offset()
        lo, hi = self.bounds()
        g = f"sqrt(clamp({p}, {lo:.9g}, {hi:.9g}))" if self.spacing == "square" else f"clamp({p}, {lo:.9g}, {hi:.9g})"
        if scale < 0:
            shifted = f"({glo:.9g} - {g})"
        else:
            shifted = g if glo == 0.0 else f"({g} - {glo:.9g})"
        off = "" if offset == 0 else f" - {-offset:g}"
        order = ", decreasing: node 0 at the first end" if scale < 0 else ""
        return (f"t = clamp({shifted} * {abs(scale):.9g}{off}, 0, {self.size - 1})  "
                f"({self.nodes} nodes on {self.name} from {self.range[0]:.9g} to {self.range[1]:.9g}{order}"
                + (f", node values clamped to [{self.clamp[0]:.9g}, {self.clamp[1]:.9g}]" if self.clamp else "")
                + ")")


def _nice(y: float) -> float:
    """Distance of ``y`` to the nearest multiple of 1/2 (a 'round' range end)."""
    return abs(y - round(y * 2.0) / 2.0)


def fit_axis(name: str, values) -> AxisMap:
    """The mapping of explicit axis values: uniform in x or sqrt(x) (interior nodes), else ``nodes``.

    The two end nodes may be clamped (Cycles' 1e-4 ends): the grid is fitted to the interior
    nodes and an end that is off the grid becomes the clamp. Of the node conventions that give
    the same grid, the one with the roundest range wins (endpoints first). Decreasing values
    (Godot's roughness rows) give a uniform axis with ``range = (hi, lo)`` (node order) or a
    ``nodes`` axis with the values as they are.

    Parameters
    ----------
    name : str
        The axis name.
    values : array_like
        The node values, increasing or decreasing.

    Returns
    -------
    AxisMap
    """
    x = np.asarray(values, dtype=np.float64)
    n = x.size
    if n < 2:
        return AxisMap(name, n, "uniform", range=(float(x[0]), float(x[0]) + 1.0), values=tuple(map(float, x)))
    for spacing in ("linear", "square"):
        if spacing == "square" and x.min() < 0:
            continue
        y = np.sqrt(x) if spacing == "square" else x
        i = np.arange(n, dtype=np.float64)
        inner = slice(1, n - 1) if n >= 6 else slice(0, n)  # clamped ends need >= 4 interior nodes
        b, a = np.polyfit(i[inner], y[inner], 1)
        tol = 1e-9 * max(abs(b) * n, 1e-300)
        fit = a + b * i
        if b == 0 or np.abs(y[inner] - fit[inner]).max() > tol:
            continue
        sign = 1.0 if b > 0 else -1.0  # decreasing values: the grid runs from the high end
        lo_ok, hi_ok = abs(y[0] - fit[0]) <= tol, abs(y[-1] - fit[-1]) <= tol
        if not (lo_ok or sign * (y[0] - fit[0]) > 0) or not (hi_ok or sign * (y[-1] - fit[-1]) < 0):
            continue  # an end off the grid must be clamped inward
        best = None
        for nodes, (g0, g1) in (("endpoints", (a, a + b * (n - 1))), ("centers", (a - b / 2, a + b * (n - 0.5))),
                                ("left", (a, a + b * n))):
            if spacing == "square" and min(g0, g1) < -tol:
                continue
            score = _nice(g0) + _nice(g1)
            if best is None or score < best[0] - 1e-12:
                best = (score, nodes, g0, g1)
        if best is None:
            continue
        _, nodes, g0, g1 = best
        # snap round ends (a range of [0, 1] fitted as 1e-17 .. 0.99999999)
        g0, g1 = (round(v * 2) / 2 if _nice(v) < 1e-9 else v for v in (g0, g1))
        inv = (lambda v: max(v, 0.0) ** 2) if spacing == "square" else (lambda v: v)
        clamp = None
        if not (lo_ok and hi_ok):
            clamp = (float(x[0]) if not lo_ok else float(inv(g0) if nodes == "endpoints" else x[0]),
                     float(x[-1]) if not hi_ok else float(inv(g1) if nodes == "endpoints" else x[-1]))
            clamp = (min(clamp), max(clamp))
        return AxisMap(name, n, "uniform", spacing, nodes, (float(inv(g0)), float(inv(g1))), clamp,
                       tuple(map(float, x)))
    return AxisMap(name, n, "nodes", values=tuple(map(float, x)))


def _from_spec(name: str, axis: dict, values: np.ndarray) -> AxisMap:
    clamp = tuple(axis["clamp"]) if axis.get("clamp") else None
    return AxisMap(name, int(axis["size"]), "uniform", axis["spacing"], axis["nodes"],
                   (float(axis["range"][0]), float(axis["range"][1])), clamp, tuple(map(float, values)))


@dataclass(frozen=True)
class LookupPlan:
    """A table's lookup: its axes (in table order) and value channels (in table order).

    Attributes
    ----------
    axes : tuple of AxisMap
    channels : tuple of str
        The value channels; component k of a lookup's result is ``channels[k]``.
    kind : str or None
        The table kind (``dfg``, ``albedo``, ``preset:<name>``).
    conventions : dict
        ``meta["preset"]["conventions"]`` or ``meta["conventions"]``.
    """

    axes: tuple[AxisMap, ...]
    channels: tuple[str, ...]
    kind: str | None
    conventions: dict

    @property
    def shape(self) -> tuple[int, ...]:
        return tuple(a.size for a in self.axes)

    def image_size(self) -> tuple[int, int]:
        """``(width, height)`` of the table as an image (bsdf_tab's EXR layout: last axis = width)."""
        sizes = self.shape
        width = sizes[-1]
        height = int(np.prod(sizes[:-1])) if len(sizes) > 1 else 1
        return width, height

    def describe(self) -> dict:
        width, height = self.image_size()
        return {"axes": [a.describe() for a in self.axes], "channels": list(self.channels), "kind": self.kind,
                "image": {"width": width, "height": height,
                          "x": self.axes[-1].name, "y": [a.name for a in self.axes[:-1]],
                          "row_0": "the first scanline of the file (the top row)"}}


def lookup_plan(table) -> LookupPlan:
    """How ``table`` was baked: axis mappings from its spec or its axis values, and its channels.

    Parameters
    ----------
    table : Table
        Any table (``bsdf_tab.tabulate``, a preset, a file read back).

    Returns
    -------
    LookupPlan
    """
    meta = table.meta or {}
    spec = meta.get("spec") if isinstance(meta.get("spec"), dict) else {}
    spec_axes = spec.get("axes") if isinstance(spec.get("axes"), dict) else {}
    axes = []
    for name, values in table.axes.items():
        steps = np.diff(np.asarray(values, dtype=np.float64))
        if steps.size and not ((steps >= 0).all() or (steps <= 0).all()) or (steps.size and not steps.any()):
            raise ValueError(f"lookup: axis {name!r} is neither increasing nor decreasing; "
                             "lookup code needs monotonic axis values")
        axis = spec_axes.get(name)
        if isinstance(axis, dict) and "size" in axis and axis.get("spacing") in ("linear", "square"):
            axes.append(_from_spec(name, axis, np.asarray(values)))
        else:
            axes.append(fit_axis(name, values))
    preset = meta.get("preset") if isinstance(meta.get("preset"), dict) else {}
    conventions = preset.get("conventions") or meta.get("conventions") or {}
    kind = spec.get("table") or meta.get("table")
    return LookupPlan(tuple(axes), tuple(table.value_channels), kind, dict(conventions))


def lookup(table, *points, plan: LookupPlan | None = None) -> dict[str, np.ndarray]:
    """Read ``table`` at ``points`` exactly as the generated lookup code does (the reference).

    Parameters
    ----------
    table : Table
    *points : array_like
        One array of physical values per axis, in table order (``NdotV``, ``roughness``),
        broadcast together.
    plan : LookupPlan, optional
        Default :func:`lookup_plan` of the table.

    Returns
    -------
    dict[str, numpy.ndarray]
        Value channel -> interpolated values (float64).
    """
    plan = plan or lookup_plan(table)
    if len(points) != len(plan.axes):
        raise ValueError(f"lookup: {len(plan.axes)} axes ({', '.join(a.param for a in plan.axes)}), "
                         f"got {len(points)} coordinates")
    return {c: multilinear(np.asarray(table.channels[c], dtype=np.float64), list(plan.axes), list(points), "linear")
            for c in plan.channels}
