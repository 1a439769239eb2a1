"""Table axes: defaults, domains, the normalized form of one axis, and its resolution to values.

An axis is given as explicit values (a list) or as a resolution ``{"size", "spacing", "nodes",
"range", "clamp"}``: ``spacing`` linear or square (x = (lo' + (hi' - lo') t)^2 with the square
roots of the range), ``nodes`` endpoints (t = i / (n - 1)), centers (t = (i + 1/2) / n) or left
(t = i / n); both forms are recorded in every table's metadata. ``alpha_values`` turns the
roughness slot into alpha (alpha = roughness^2).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .errors import SpecError
from .validate import check_keys, choice, integer, number, pair

MAX_AXIS_SIZE = 4096
SPACINGS = ("linear", "square")
NODES = ("endpoints", "centers", "left")
AXIS_KEYS = ("size", "spacing", "nodes", "range", "clamp")

#: Axis slot that accepts either ``alpha`` or ``roughness`` (alpha = roughness^2).
ROUGHNESS_SLOT = "alpha"
ROUGHNESS_NAMES = ("alpha", "roughness")


#: Default resolution of each axis (used when the axis is omitted).
AXIS_DEFAULTS: dict[str, dict[str, Any]] = {
    "mu": {"size": 32, "spacing": "linear", "nodes": "endpoints", "range": [0.0, 1.0], "clamp": None},
    "alpha": {"size": 32, "spacing": "linear", "nodes": "endpoints", "range": [0.0, 1.0], "clamp": None},
    "roughness": {"size": 32, "spacing": "linear", "nodes": "endpoints", "range": [0.0, 1.0], "clamp": None},
    "eta": {"size": 16, "spacing": "linear", "nodes": "endpoints", "range": [1.01, 4.0], "clamp": None},
    # bsdf angles (radians): the MERL layout, bins starting at 0 (nodes "left": t = i / n)
    "theta_i": {"size": 90, "spacing": "linear", "nodes": "left", "range": [0.0, math.pi / 2], "clamp": None},
    "theta_o": {"size": 90, "spacing": "linear", "nodes": "left", "range": [0.0, math.pi / 2], "clamp": None},
    "theta_h": {"size": 90, "spacing": "square", "nodes": "left", "range": [0.0, math.pi / 2], "clamp": None},
    "theta_d": {"size": 90, "spacing": "linear", "nodes": "left", "range": [0.0, math.pi / 2], "clamp": None},
    "phi_d": {"size": 180, "spacing": "linear", "nodes": "left", "range": [0.0, math.pi], "clamp": None},
    # albedo_aniso: view azimuth from the tangent (E is symmetric about 0 and pi/2), anisotropy a
    "phi_v": {"size": 9, "spacing": "linear", "nodes": "endpoints", "range": [0.0, math.pi / 2], "clamp": None},
    "anisotropy": {"size": 8, "spacing": "linear", "nodes": "endpoints", "range": [0.0, 1.0], "clamp": None},
}

#: Axis domains: (low, high, low_inclusive).  The high bound is inclusive.
AXIS_DOMAINS: dict[str, tuple[float, float, bool]] = {
    "mu": (0.0, 1.0, True),
    "alpha": (0.0, 4.0, True),
    "roughness": (0.0, 2.0, True),
    "eta": (0.0, 100.0, False),
    "theta_i": (0.0, math.pi / 2, True),
    "theta_o": (0.0, math.pi / 2, True),
    "theta_h": (0.0, math.pi / 2, True),
    "theta_d": (0.0, math.pi / 2, True),
    "phi_d": (0.0, 2.0 * math.pi, True),
    "phi_v": (0.0, 2.0 * math.pi, True),
    "anisotropy": (0.0, 1.0, True),
}


def normalize_axis(name: str, value: Any) -> dict:
    param = f"axes.{name}"
    if value is None:
        return dict(AXIS_DEFAULTS[name])
    if isinstance(value, (list, tuple)):
        return {"values": _explicit_values(value, param)}
    if not isinstance(value, dict):
        raise SpecError(param, f"must be a list of numbers or an object with 'size', got {value!r}")
    if "values" in value:
        check_keys(value, ("values",), param)
        if not isinstance(value["values"], (list, tuple)):
            raise SpecError(f"{param}.values", "must be a list of numbers")
        return {"values": _explicit_values(value["values"], f"{param}.values")}
    return _resolution(name, value, param)


def _explicit_values(values, param: str) -> list[float]:
    if len(values) == 0:
        raise SpecError(param, "must not be empty")
    if len(values) > MAX_AXIS_SIZE:
        raise SpecError(param, f"must have at most {MAX_AXIS_SIZE} values, got {len(values)}")
    return [number(v, param, f"[{i}] ") for i, v in enumerate(values)]


def _resolution(name: str, value: dict, param: str) -> dict:
    check_keys(value, AXIS_KEYS, param)
    if "size" not in value:
        raise SpecError(f"{param}.size", "is required (or give an explicit list of values)")
    size = integer(value["size"], f"{param}.size")
    if not 1 <= size <= MAX_AXIS_SIZE:
        raise SpecError(f"{param}.size", f"must be in [1, {MAX_AXIS_SIZE}], got {size}")
    default = AXIS_DEFAULTS[name]
    out = {
        "size": size,
        "spacing": choice(value.get("spacing", default["spacing"]), SPACINGS, f"{param}.spacing"),
        "nodes": choice(value.get("nodes", default["nodes"]), NODES, f"{param}.nodes"),
        "range": pair(value.get("range", default["range"]), f"{param}.range"),
        "clamp": None,
    }
    if value.get("clamp") is not None:
        out["clamp"] = pair(value["clamp"], f"{param}.clamp")
    if out["spacing"] == "square" and out["range"][0] < 0.0:
        raise SpecError(f"{param}.range", f"must be >= 0 for square spacing, got {out['range']!r}")
    return out


def _node_positions(size: int, nodes: str) -> np.ndarray:
    i = np.arange(size, dtype=np.float64)
    if nodes == "centers":
        return (i + 0.5) / size
    if nodes == "left":
        return i / size
    if size == 1:
        return np.zeros(1)
    return i / (size - 1)


def _spaced(axis: dict) -> np.ndarray:
    lo, hi = axis["range"]
    t = _node_positions(axis["size"], axis["nodes"])
    if axis["spacing"] == "square":
        s_lo, s_hi = math.sqrt(lo), math.sqrt(hi)
        x = (s_lo + (s_hi - s_lo) * t) ** 2
    else:
        x = lo + (hi - lo) * t
    if axis["nodes"] == "endpoints":  # hit the range ends exactly despite rounding
        x[0] = lo
        if axis["size"] > 1:
            x[-1] = hi
    elif axis["nodes"] == "left":
        x[0] = lo
    if axis["clamp"] is not None:
        x = np.clip(x, axis["clamp"][0], axis["clamp"][1])
    return x


def _check_resolved(name: str, x: np.ndarray, clamped: bool, rng: list | None = None) -> None:
    param = f"axes.{name}"
    lo, hi, lo_inclusive = AXIS_DOMAINS[name]
    below = x < lo if lo_inclusive else x <= lo
    if below.any() or (x > hi).any():
        bad = float(x[below | (x > hi)][0])
        interval = f"{'[' if lo_inclusive else '('}{lo:g}, {hi:g}]"
        if rng is not None:  # a resolution's nodes: its range is what was given (the service's A_min, A_max)
            raise SpecError(f"{param}.range", f"must keep the nodes in {interval}, got {list(rng)!r} (a node at {bad!r})")
        raise SpecError(param, f"values must be in {interval}, got {bad!r}")
    steps = np.diff(x)
    if (steps <= 0).any():
        k = int(np.argmax(steps <= 0))
        hint = " (the clamp makes neighbouring values equal)" if clamped else ""
        raise SpecError(
            param,
            f"values must be strictly increasing, got {float(x[k])!r} then {float(x[k + 1])!r}"
            f" at index {k + 1}{hint}",
        )


def resolve_axis(name: str, axis: dict) -> np.ndarray:
    """Resolve one normalized axis spec to its float64 values.

    Parameters
    ----------
    name : str
        Axis name (``mu``, ``alpha``, ``roughness``, ``eta``).
    axis : dict
        A normalized axis: ``{"values": [...]}`` or the full resolution dict.

    Returns
    -------
    numpy.ndarray
        1-D float64 array, strictly increasing and inside the axis domain.

    Raises
    ------
    SpecError
        If the values leave the domain or are not strictly increasing.
    """
    if "values" in axis:
        x = np.asarray(axis["values"], dtype=np.float64)
    else:
        x = _spaced(axis)
    _check_resolved(name, x, clamped=axis.get("clamp") is not None, rng=axis.get("range"))
    return x



def alpha_values(axes: dict[str, np.ndarray]) -> np.ndarray:
    """The alpha values of resolved axes (``roughness**2`` if that axis is used).

    Raises
    ------
    KeyError
        If ``axes`` has neither an ``alpha`` nor a ``roughness`` axis.
    """
    if "alpha" in axes:
        return np.asarray(axes["alpha"], dtype=np.float64).copy()
    if "roughness" in axes:
        return np.asarray(axes["roughness"], dtype=np.float64) ** 2
    raise KeyError("axes have neither an 'alpha' nor a 'roughness' axis")


