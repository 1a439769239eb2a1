"""The checks every parser of user input shares (spec, scene, service query): each raises
:class:`~bsdf_tab.errors.SpecError` naming the parameter, so every front end reports alike."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .errors import SpecError

__all__ = ["check_keys", "choice", "integer", "number", "one_of", "pair"]


def one_of(options) -> str:
    """``"must be one of a, b, c"`` (sorted)."""
    return "must be one of " + ", ".join(sorted(options))


def number(value: Any, param: str, where: str = "") -> float:
    """Return ``value`` as a finite float or raise SpecError naming ``param``.

    ``where`` (for example ``"[2] "``) locates the value inside a list.
    """
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise SpecError(param, f"{where}must be a number, got {type(value).__name__} {value!r}")
    try:
        x = float(value)
    except OverflowError:
        # an int too large for a float64 (JSON allows arbitrary integers)
        raise SpecError(param, f"{where}must be finite, got an integer of {len(str(value))} digits") from None
    if not math.isfinite(x):
        raise SpecError(param, f"{where}must be finite, got {value!r}")
    return x


def integer(value: Any, param: str) -> int:
    """Return ``value`` as an int (bools refused) or raise SpecError naming ``param``."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise SpecError(param, f"must be an integer, got {type(value).__name__} {value!r}")
    return int(value)


def choice(value: Any, options, param: str) -> str:
    """Return ``value`` if it is one of ``options`` (strings), else raise SpecError."""
    if not isinstance(value, str) or value not in options:
        raise SpecError(param, f"{one_of(options)}, got {value!r}")
    return value


def check_keys(obj: dict, allowed, param_prefix: str) -> None:
    """Raise SpecError for the first key of ``obj`` not in ``allowed``."""
    for key in obj:
        if key not in allowed:
            where = f"{param_prefix}.{key}" if param_prefix else str(key)
            raise SpecError(where, f"unknown parameter; allowed: {', '.join(allowed)}")


def pair(value: Any, param: str) -> list[float]:
    """``[lo, hi]`` with finite lo <= hi, or SpecError."""
    if not isinstance(value, (list, tuple)) or len(value) != 2:
        raise SpecError(param, f"must be a list of 2 numbers [lo, hi], got {value!r}")
    lo = number(value[0], param, "[0] ")
    hi = number(value[1], param, "[1] ")
    if lo > hi:
        raise SpecError(param, f"must have lo <= hi, got {value!r}")
    return [lo, hi]
