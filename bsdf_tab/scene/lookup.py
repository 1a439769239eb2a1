"""How a renderer reads a planned table: its axes (nodes, texel coordinate) and the lookup.

An axis of a planned table is either *interpolated* (endpoint nodes over a range, ``linear``
spacing: t uniform in x, or ``square``: t uniform in sqrt(x)) or *discrete* (the exact values
the scene uses; the renderer indexes them). :func:`lookup` reads a table at any points the
way the manifest tells a renderer to: multilinear or nearest in the texel coordinate on
interpolated axes, the texel of the value on discrete ones. The planner measures its lookup
error with it.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field

import numpy as np

from ..spec import resolve_axis

__all__ = ["AxisPlan", "lookup", "texels_read"]


@dataclass
class AxisPlan:
    """One axis of a planned table: ``interp`` (spacing, range, size) or ``discrete`` (values)."""

    name: str
    mode: str  # "interp" | "discrete"
    values: list[float] = field(default_factory=list)  # discrete
    range: tuple[float, float] = (0.0, 1.0)
    spacing: str = "linear"
    size: int = 2

    def __len__(self) -> int:
        """The number of texels along the axis."""
        return len(self.values) if self.mode == "discrete" else self.size

    def nodes(self) -> np.ndarray:
        """The axis values of the table's texels (float64)."""
        if self.mode == "discrete":
            return np.asarray(self.values, dtype=np.float64)
        return _nodes(self.name, self.size, self.spacing, tuple(self.range)).copy()

    def spec(self):
        """The axis as a table spec gives it."""
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
        """The axis as the manifest tells a renderer to read it."""
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


@functools.lru_cache(maxsize=4096)
def _nodes(name: str, size: int, spacing: str, rng: tuple[float, float]) -> np.ndarray:
    """Endpoint nodes of an interpolated axis (memoized: the planner asks for the same ones often)."""
    spec = {"size": size, "spacing": spacing, "nodes": "endpoints", "range": list(rng), "clamp": None}
    return resolve_axis(name, spec)


def _texel(ax: AxisPlan, x: np.ndarray, interpolation: str, down: bool = False):
    """(first texel index, weight of the next one or None) of coordinates ``x`` along ``ax``."""
    t = ax.coord(x)
    n = len(ax)
    if ax.mode == "discrete" or n == 1 or interpolation == "nearest":
        down = down and ax.mode == "interp"
        return np.clip(np.ceil(t - 0.5) if down else np.floor(t + 0.5), 0, n - 1).astype(np.int64), None
    i = np.clip(np.floor(t), 0, n - 2).astype(np.int64)
    return i, t - i


def texels_read(ax: AxisPlan, x, interpolation: str, both_ties: bool = False) -> np.ndarray:
    """Sorted indices of the texels along ``ax`` that :func:`lookup` reads at coordinates ``x``
    (linear: both neighbours, even one of weight 0; ``both_ties``: both sides of a nearest tie)."""
    i, w = _texel(ax, np.asarray(x, dtype=np.float64), interpolation)
    used = [i] if w is None else [i, i + 1]
    if both_ties and w is None:
        used.append(_texel(ax, np.asarray(x, dtype=np.float64), interpolation, True)[0])
    return np.unique(np.concatenate([np.ravel(u) for u in used]))


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
        i, w = _texel(ax, p, interpolation, round_down is not None and round_down[k])
        idx0.append(i)
        wts.append(w)
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
