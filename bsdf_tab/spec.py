"""Table specs: parse, validate, normalize, hash, and resolve axes.

A *spec* is a JSON-serializable dict that describes one table, for example::

    {"table": "albedo", "distribution": "ggx", "shadowing": "correlated",
     "fresnel": {"type": "one"},
     "axes": {"mu": [0.1, 0.5, 1.0], "alpha": [0.05, 0.3]}}

:func:`normalize_spec` checks it (raising :class:`~bsdf_tab.errors.SpecError`
that names the offending parameter) and returns the canonical form with every
default filled in; :func:`spec_hash` hashes that canonical form, so specs that
differ only in spelling (defaults omitted, key order) hash equal.

Axes
----
An axis is either an explicit list of numbers (stored as ``{"values": [...]}``)
or a resolution ``{"size": n, "spacing": "linear" | "square",
"nodes": "endpoints" | "centers" | "left", "range": [lo, hi], "clamp": [c0, c1] | None}``.
With ``t_i = i / (n - 1)`` (endpoints; ``t = 0`` when ``n = 1``),
``t_i = (i + 1/2) / n`` (centers) or ``t_i = i / n`` (left: bin starts, as MERL):

- linear: ``x = lo + (hi - lo) t``
- square: ``x = (sqrt(lo) + (sqrt(hi) - sqrt(lo)) t)^2`` (Unity's sqrt(NdotV) axis)

then ``x`` is clamped to ``[c0, c1]`` when a clamp is given. Endpoint nodes hit
``lo`` and ``hi`` exactly. Resolved values must be strictly increasing and lie
in the axis domain.

Adding a table kind is one entry in :data:`TABLE_KINDS`.
"""

from __future__ import annotations

import hashlib
import json
import math
from typing import Any

import numpy as np

from .errors import SpecError

__all__ = [
    "SpecError",
    "TABLE_KINDS",
    "AXIS_DEFAULTS",
    "AXIS_DOMAINS",
    "DISTRIBUTIONS",
    "SHADOWINGS",
    "FRESNEL_TYPES",
    "METHODS",
    "DEFAULT_TOLERANCE",
    "MAX_AXIS_SIZE",
    "normalize_spec",
    "spec_hash",
    "canonical_json",
    "resolve_axes",
    "resolve_axis",
    "alpha_values",
    "texel_count",
    "axis_names",
    "channel_names",
]

#: Axis slot that accepts either ``alpha`` or ``roughness`` (alpha = roughness^2).
ROUGHNESS_SLOT = "alpha"
ROUGHNESS_NAMES = ("alpha", "roughness")

#: Per-table data. ``axes``: axis names in table order, where ``"alpha"`` stands
#: for the roughness slot (``alpha`` or ``roughness``); ``channels``: value
#: channel names (each also gets an ``<X>_err`` error channel); ``fresnel``:
#: ``"any"`` (a fresnel parameter), ``"axis"`` (dielectric with eta from the
#: ``eta`` axis) or ``"one"`` (Fresnel-independent, F = 1 only). Optional: ``methods`` (the
#: only methods the kind accepts, the first sorted is the default), ``params`` (kind-only
#: top-level keys, see :data:`KIND_KEYS`) and ``parametrizations`` (name -> axis slots; the
#: ``axes`` entry is the default one's).
TABLE_KINDS: dict[str, dict[str, Any]] = {
    "albedo": {
        "axes": ("mu", "alpha"),
        "channels": ("E",),
        "fresnel": "any",
        "description": "directional albedo E(mu, alpha) of the microfacet BRDF",
    },
    "albedo_avg": {
        "axes": ("alpha",),
        "channels": ("E_avg",),
        "fresnel": "any",
        "description": "hemispherical average E_avg = 2 int_0^1 E(mu) mu dmu",
    },
    "dielectric": {
        "axes": ("mu", "alpha", "eta"),
        "channels": ("R", "T"),
        "fresnel": "axis",
        "description": "reflected R and transmitted T energy of a rough dielectric interface",
    },
    "dielectric_avg": {
        "axes": ("alpha", "eta"),
        "channels": ("R_avg", "T_avg"),
        "fresnel": "axis",
        "description": "mu-weighted averages of R and T of a rough dielectric interface",
    },
    "dfg": {
        "axes": ("mu", "alpha"),
        "channels": ("A", "B"),
        "fresnel": "one",
        "description": "split-sum DFG terms: E = f0 A + B for Schlick Fresnel",
    },
    "bsdf": {
        # axes of the default parametrization; see "parametrizations"
        "axes": ("theta_i", "theta_o", "phi_d"),
        "channels": ("f_r", "f_t"),
        "fresnel": "any",
        "methods": ("point",),
        "params": ("alpha", "roughness", "parametrization"),
        "parametrizations": {
            "angles": ("theta_i", "theta_o", "phi_d"),
            "half_diff": ("theta_h", "theta_d", "phi_d"),
        },
        "description": "BSDF values f_r (reflection) and f_t (transmission, dielectric Fresnel) of one "
        "material on an angular grid: plain angles or Rusinkiewicz half/difference angles (MERL layout)",
    },
    "kulla_conty": {
        "axes": ("mu", "alpha"),
        "channels": ("E", "E_avg", "C"),
        "fresnel": "one",
        "description": "Kulla-Conty 2017 multiple-scattering compensation: single-scattering E (F = 1), "
        "E_avg (repeated along mu) and C = (1 - E) / sqrt(pi (1 - E_avg)), so f_ms(i, o) = C(mu_i) C(mu_o)",
    },
}

#: Scalar material parameters of the ``bsdf`` table: (low, high) open-closed domain, default.
SCALAR_PARAMS: dict[str, tuple[float, float]] = {"alpha": (0.0, 4.0), "roughness": (0.0, 2.0)}
DEFAULT_BSDF_ALPHA = 0.5

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
}

DISTRIBUTIONS = {"ggx", "beckmann"}
SHADOWINGS = {"correlated", "separable"}
#: Fresnel type -> its numeric parameters.
FRESNEL_TYPES: dict[str, tuple[str, ...]] = {
    "one": (),
    "schlick": ("f0",),
    "dielectric": ("eta",),
    "conductor": ("eta", "k"),
}
#: Integration methods; other modules add theirs. A kind with its own "methods" (``bsdf``:
#: "point", exact point evaluation) accepts only those.
METHODS = {"adaptive", "grid", "mc_cosine", "mc_dcos", "mc_vndf", "qmc_vndf", "vndf_gl"}
#: Methods of fixed effort: the optional top-level key ``effort`` (samples or nodes per texel,
#: a positive int; absent = the method's default) applies to them, not to ``adaptive``.
EFFORT_METHODS = METHODS - {"adaptive"}
MAX_EFFORT = 1 << 26

DEFAULT_TOLERANCE = 5e-7
TOLERANCE_RANGE = (1e-12, 1e-1)
MAX_AXIS_SIZE = 4096
SPACINGS = ("linear", "square")
NODES = ("endpoints", "centers", "left")

TOP_LEVEL_KEYS = ("table", "distribution", "shadowing", "fresnel", "axes", "method", "tolerance", "effort")
#: Keys that only some kinds accept (TABLE_KINDS[kind]["params"]).
KIND_KEYS = ("alpha", "roughness", "parametrization")
AXIS_KEYS = ("size", "spacing", "nodes", "range", "clamp")


# --------------------------------------------------------------------------- helpers


def _one_of(options) -> str:
    return "must be one of " + ", ".join(sorted(options))


def _number(value: Any, param: str, where: str = "") -> float:
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


def _integer(value: Any, param: str) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise SpecError(param, f"must be an integer, got {type(value).__name__} {value!r}")
    return int(value)


def _choice(value: Any, options, param: str) -> str:
    if not isinstance(value, str) or value not in options:
        raise SpecError(param, f"{_one_of(options)}, got {value!r}")
    return value


def _check_keys(obj: dict, allowed, param_prefix: str) -> None:
    for key in obj:
        if key not in allowed:
            where = f"{param_prefix}.{key}" if param_prefix else str(key)
            raise SpecError(where, f"unknown parameter; allowed: {', '.join(allowed)}")


def _pair(value: Any, param: str) -> list[float]:
    if not isinstance(value, (list, tuple)) or len(value) != 2:
        raise SpecError(param, f"must be a list of 2 numbers [lo, hi], got {value!r}")
    lo = _number(value[0], param, "[0] ")
    hi = _number(value[1], param, "[1] ")
    if lo > hi:
        raise SpecError(param, f"must have lo <= hi, got {value!r}")
    return [lo, hi]


def _parse(spec: dict | str) -> dict:
    if isinstance(spec, (str, bytes, bytearray)):
        try:
            spec = json.loads(spec)
        except json.JSONDecodeError as exc:
            raise SpecError(None, f"invalid JSON: {exc}") from None
    if not isinstance(spec, dict):
        raise SpecError(None, f"a spec must be a JSON object (dict), got {type(spec).__name__}")
    return spec


# --------------------------------------------------------------------------- fresnel


def _normalize_fresnel(value: Any, kind: str) -> dict:
    policy = TABLE_KINDS[kind]["fresnel"]
    if value is None:
        return {"type": "dielectric"} if policy == "axis" else {"type": "one"}
    if isinstance(value, str):  # shorthand: "one" -> {"type": "one"}
        value = {"type": value}
    if not isinstance(value, dict):
        raise SpecError("fresnel", f"must be an object like {{\"type\": \"one\"}}, got {value!r}")
    ftype = _choice(value.get("type", "one"), FRESNEL_TYPES, "fresnel.type")
    params = FRESNEL_TYPES[ftype]
    _check_keys(value, ("type",) + params, "fresnel")
    if policy == "axis":
        return _fresnel_from_axis(value, ftype, kind)
    if policy == "one" and ftype != "one":
        raise SpecError("fresnel.type", f"must be one for table {kind} (it is Fresnel-independent), got {ftype!r}")
    return _fresnel_params(value, ftype)


def _fresnel_from_axis(value: dict, ftype: str, kind: str) -> dict:
    if ftype != "dielectric":
        raise SpecError("fresnel.type", f"must be dielectric for table {kind}, got {ftype!r}")
    if "eta" in value:
        raise SpecError("fresnel.eta", f"must not be given for table {kind}: eta is the table's eta axis")
    return {"type": "dielectric"}


def _fresnel_params(value: dict, ftype: str) -> dict:
    out: dict[str, Any] = {"type": ftype}
    for name in FRESNEL_TYPES[ftype]:
        param = f"fresnel.{name}"
        if name not in value:
            raise SpecError(param, f"is required for fresnel type {ftype}")
        out[name] = _number(value[name], param)
    if ftype == "schlick" and not 0.0 <= out["f0"] <= 1.0:
        raise SpecError("fresnel.f0", f"must be in [0, 1], got {out['f0']!r}")
    if "eta" in out and not out["eta"] > 0.0:
        raise SpecError("fresnel.eta", f"must be > 0, got {out['eta']!r}")
    if "k" in out and not out["k"] >= 0.0:
        raise SpecError("fresnel.k", f"must be >= 0, got {out['k']!r}")
    return out


# --------------------------------------------------------------------------- axes


def _kind_axes(kind: str, parametrization: str | None = None) -> tuple[str, ...]:
    """Axis slots of a kind (of its parametrization, for kinds that have several)."""
    info = TABLE_KINDS[kind]
    if parametrization is not None and "parametrizations" in info:
        return tuple(info["parametrizations"][parametrization])
    return tuple(info["axes"])


def _table_axis_names(kind: str, axes_in: dict, parametrization: str | None = None) -> list[str]:
    """Axis names of this spec in table order, with the roughness slot resolved."""
    slots = _kind_axes(kind, parametrization)
    if ROUGHNESS_SLOT not in slots:
        return list(slots)
    given = [n for n in ROUGHNESS_NAMES if n in axes_in]
    if len(given) > 1:
        raise SpecError("axes", "give only one of alpha, roughness (alpha = roughness^2)")
    rough = given[0] if given else "alpha"
    return [rough if n == ROUGHNESS_SLOT else n for n in slots]


def _normalize_axes(value: Any, kind: str, parametrization: str | None = None) -> dict:
    if value is None:
        value = {}
    if not isinstance(value, dict):
        raise SpecError("axes", f"must be an object mapping axis name -> axis spec, got {value!r}")
    slots = _kind_axes(kind, parametrization)
    names = _table_axis_names(kind, value, parametrization)
    allowed = [n for n in slots if n != ROUGHNESS_SLOT]
    if ROUGHNESS_SLOT in slots:
        allowed += list(ROUGHNESS_NAMES)
    for key in value:
        if key not in allowed:
            order = ", ".join(n if n != ROUGHNESS_SLOT else "alpha|roughness" for n in slots)
            where = f" with parametrization {parametrization}" if parametrization else ""
            raise SpecError(f"axes.{key}", f"unknown axis for table {kind}{where}; allowed: {order}")
    out = {}
    for name in names:
        axis = _normalize_axis(name, value.get(name))
        resolve_axis(name, axis)  # validates resolved values (domain, increasing)
        out[name] = axis
    return out


def _normalize_axis(name: str, value: Any) -> dict:
    param = f"axes.{name}"
    if value is None:
        return dict(AXIS_DEFAULTS[name])
    if isinstance(value, (list, tuple)):
        return {"values": _explicit_values(value, param)}
    if not isinstance(value, dict):
        raise SpecError(param, f"must be a list of numbers or an object with 'size', got {value!r}")
    if "values" in value:
        _check_keys(value, ("values",), param)
        if not isinstance(value["values"], (list, tuple)):
            raise SpecError(f"{param}.values", "must be a list of numbers")
        return {"values": _explicit_values(value["values"], f"{param}.values")}
    return _resolution(name, value, param)


def _explicit_values(values, param: str) -> list[float]:
    if len(values) == 0:
        raise SpecError(param, "must not be empty")
    if len(values) > MAX_AXIS_SIZE:
        raise SpecError(param, f"must have at most {MAX_AXIS_SIZE} values, got {len(values)}")
    return [_number(v, param, f"[{i}] ") for i, v in enumerate(values)]


def _resolution(name: str, value: dict, param: str) -> dict:
    _check_keys(value, AXIS_KEYS, param)
    if "size" not in value:
        raise SpecError(f"{param}.size", "is required (or give an explicit list of values)")
    size = _integer(value["size"], f"{param}.size")
    if not 1 <= size <= MAX_AXIS_SIZE:
        raise SpecError(f"{param}.size", f"must be in [1, {MAX_AXIS_SIZE}], got {size}")
    default = AXIS_DEFAULTS[name]
    out = {
        "size": size,
        "spacing": _choice(value.get("spacing", default["spacing"]), SPACINGS, f"{param}.spacing"),
        "nodes": _choice(value.get("nodes", default["nodes"]), NODES, f"{param}.nodes"),
        "range": _pair(value.get("range", default["range"]), f"{param}.range"),
        "clamp": None,
    }
    if value.get("clamp") is not None:
        out["clamp"] = _pair(value["clamp"], f"{param}.clamp")
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


def _check_resolved(name: str, x: np.ndarray, clamped: bool) -> None:
    param = f"axes.{name}"
    lo, hi, lo_inclusive = AXIS_DOMAINS[name]
    below = x < lo if lo_inclusive else x <= lo
    if below.any() or (x > hi).any():
        bad = float(x[below | (x > hi)][0])
        interval = f"{'[' if lo_inclusive else '('}{lo:g}, {hi:g}]"
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
    _check_resolved(name, x, clamped=axis.get("clamp") is not None)
    return x


# --------------------------------------------------------------------------- public


def normalize_spec(spec: dict | str) -> dict:
    """Validate a spec and return its canonical form with all defaults filled in.

    Parameters
    ----------
    spec : dict or str
        The spec, as a dict or a JSON string.

    Returns
    -------
    dict
        A new dict with keys ``table``, ``distribution``, ``shadowing``,
        ``fresnel``, ``axes`` (in table axis order), ``method``, ``tolerance``;
        the ``bsdf`` table also has ``parametrization`` and ``alpha`` (or
        ``roughness``), its single material's width parameter.
        Idempotent: ``normalize_spec(normalize_spec(s)) == normalize_spec(s)``.

    Raises
    ------
    SpecError
        With ``param`` naming the offending parameter.
    """
    spec = _parse(spec)
    _check_keys(spec, TOP_LEVEL_KEYS + KIND_KEYS, "")
    if "table" not in spec:
        raise SpecError("table", f"is required; {_one_of(TABLE_KINDS)}")
    kind = _choice(spec["table"], TABLE_KINDS, "table")
    info = TABLE_KINDS[kind]
    own = info.get("params", ())
    for key in KIND_KEYS:
        if key in spec and key not in own:
            hint = f"; for table {kind} {key} is an axis: give axes.{key}" if key in ROUGHNESS_NAMES else ""
            raise SpecError(key, f"is not a parameter of table {kind}{hint}")
    methods = info.get("methods", METHODS)
    out = {
        "table": kind,
        "distribution": _choice(spec.get("distribution", "ggx"), DISTRIBUTIONS, "distribution"),
        "shadowing": _choice(spec.get("shadowing", "correlated"), SHADOWINGS, "shadowing"),
        "fresnel": _normalize_fresnel(spec.get("fresnel"), kind),
    }
    parametrization = None
    if "parametrizations" in info:
        parametrization = _normalize_parametrization(spec, kind)
        out["parametrization"] = parametrization
    if "alpha" in own:
        out.update(_normalize_scalar_alpha(spec))
    out["axes"] = _normalize_axes(spec.get("axes"), kind, parametrization)
    out["method"] = _choice(spec.get("method", sorted(methods)[0] if "methods" in info else "adaptive"), methods, "method")
    out["tolerance"] = _normalize_tolerance(spec.get("tolerance", DEFAULT_TOLERANCE))
    if spec.get("effort") is not None:
        out["effort"] = _normalize_effort(spec["effort"], out["method"])
    return out


def _normalize_effort(value: Any, method: str) -> int:
    """Samples or nodes per texel of a fixed-effort method (absent: the method's default)."""
    if method not in EFFORT_METHODS:
        raise SpecError("effort", f"is not a parameter of method {method} (it is error-controlled: give tolerance)")
    effort = _integer(value, "effort")
    if not 8 <= effort <= MAX_EFFORT:
        raise SpecError("effort", f"must be in [8, {MAX_EFFORT}], got {effort}")
    return effort


def _normalize_parametrization(spec: dict, kind: str) -> str:
    """The parametrization given, or inferred from the axis names (default: the first one)."""
    options = TABLE_KINDS[kind]["parametrizations"]
    if "parametrization" in spec:
        return _choice(spec["parametrization"], options, "parametrization")
    axes = spec.get("axes")
    if isinstance(axes, dict):
        for name, slots in options.items():
            if axes and all(key in slots for key in axes):
                return name
    return next(iter(options))


def _normalize_scalar_alpha(spec: dict) -> dict:
    """``{"alpha": a}`` or ``{"roughness": r}`` (alpha = r^2) of a one-material table."""
    given = [n for n in ROUGHNESS_NAMES if n in spec]
    if len(given) > 1:
        raise SpecError("alpha", "give only one of alpha, roughness (alpha = roughness^2)")
    name = given[0] if given else "alpha"
    value = _number(spec.get(name, DEFAULT_BSDF_ALPHA), name)
    lo, hi = SCALAR_PARAMS[name]
    if not lo < value <= hi:
        raise SpecError(
            name, f"must be in ({lo:g}, {hi:g}], got {value!r} (0 is a mirror: a Dirac delta has no point values)"
        )
    return {name: value}


def _normalize_tolerance(value: Any) -> float:
    tol = _number(value, "tolerance")
    lo, hi = TOLERANCE_RANGE
    if not lo <= tol <= hi:
        raise SpecError("tolerance", f"must be in [{lo:g}, {hi:g}], got {tol!r}")
    return tol


def canonical_json(spec: dict | str) -> str:
    """Canonical JSON text of the normalized spec (sorted keys, compact)."""
    return json.dumps(normalize_spec(spec), sort_keys=True, separators=(",", ":"), allow_nan=False)


def spec_hash(spec: dict | str) -> str:
    """SHA-256 hex digest of :func:`canonical_json` of ``spec``.

    Specs that normalize equal (defaults omitted or given, any key order)
    hash equal.
    """
    return hashlib.sha256(canonical_json(spec).encode("utf-8")).hexdigest()


def resolve_axes(nspec: dict | str) -> dict[str, np.ndarray]:
    """Resolve every axis of a spec to float64 values.

    Parameters
    ----------
    nspec : dict or str
        A spec (normalized or not; it is normalized again, which is cheap).

    Returns
    -------
    dict[str, numpy.ndarray]
        Insertion-ordered in the table's axis order; the roughness axis is
        keyed ``"alpha"`` or ``"roughness"`` as given.
    """
    nspec = normalize_spec(nspec)
    return {name: resolve_axis(name, axis) for name, axis in nspec["axes"].items()}


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


def texel_count(nspec: dict | str) -> int:
    """Number of texels of the table (product of the axis sizes)."""
    nspec = normalize_spec(nspec)
    count = 1
    for axis in nspec["axes"].values():
        count *= len(axis["values"]) if "values" in axis else axis["size"]
    return count


def axis_names(kind: str) -> tuple[str, ...]:
    """Axis slots of a table kind in order (``"alpha"`` also accepts ``roughness``)."""
    return tuple(TABLE_KINDS[_choice(kind, TABLE_KINDS, "table")]["axes"])


def channel_names(kind: str, errors: bool = False) -> list[str]:
    """Value channel names of a table kind, plus ``<X>_err`` names if ``errors``."""
    values = list(TABLE_KINDS[_choice(kind, TABLE_KINDS, "table")]["channels"])
    return values + [f"{c}_err" for c in values] if errors else values
