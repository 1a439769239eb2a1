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

Kinds come from the table registry (:mod:`bsdf_tab.tables`), methods from the integrators'
(:mod:`bsdf_tab.integrate`), distributions and shadowing modes from the model's.
"""

from __future__ import annotations

import hashlib
import json
from typing import Any

import numpy as np

from . import jsontext
from .errors import SpecError
from .integrate import METHODS as INTEGRATORS
from .model.distribution import DISTRIBUTIONS as MODEL_DISTRIBUTIONS
from .model.fresnel import FRESNELS as MODEL_FRESNELS
from .model.shadowing import SHADOWINGS as MODEL_SHADOWINGS
from .tables import CATALOG
from .validate import check_keys, choice, integer, number, one_of
from .axes import (  # noqa: F401  (re-exported: the spec's vocabulary)
    AXIS_DEFAULTS,
    AXIS_DOMAINS,
    AXIS_KEYS,
    MAX_AXIS_SIZE,
    NODES,
    ROUGHNESS_NAMES,
    ROUGHNESS_SLOT,
    SPACINGS,
    alpha_values,
    normalize_axis,
    resolve_axis,
)

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
    "KIND_OPTIONS",
    "KIND_OPTION_KEYS",
    "kind_options",
]

#: Table kind -> its catalog entry (axes, channels, fresnel policy, description, and optional
#: methods / params / parametrizations): read from the table registry, :data:`bsdf_tab.tables.CATALOG`.
TABLE_KINDS: dict[str, dict[str, Any]] = CATALOG

#: Scalar material parameters of the ``bsdf`` table: (low, high) open-closed domain, default.
SCALAR_PARAMS: dict[str, tuple[float, float]] = {"alpha": (0.0, 4.0), "roughness": (0.0, 2.0)}
DEFAULT_BSDF_ALPHA = 0.5

#: Distribution and shadowing names: the model's registries.
DISTRIBUTIONS = set(MODEL_DISTRIBUTIONS)
SHADOWINGS = set(MODEL_SHADOWINGS)
#: Fresnel type -> its numeric parameters (the types are the model's, :data:`bsdf_tab.model.FRESNELS`).
FRESNEL_TYPES: dict[str, tuple[str, ...]] = {
    "one": (),
    "schlick": ("f0",),
    "dielectric": ("eta",),
    "conductor": ("eta", "k"),
}
if set(FRESNEL_TYPES) != set(MODEL_FRESNELS):  # a new Fresnel type of the model needs its parameters here
    raise ImportError(f"spec.FRESNEL_TYPES {sorted(FRESNEL_TYPES)} != model FRESNELS {sorted(MODEL_FRESNELS)}")
#: Integration methods: the integrators' registry. A kind with its own "methods" (``bsdf``:
#: "point", exact point evaluation) accepts only those.
METHODS = set(INTEGRATORS)
#: Methods of fixed effort: the optional top-level key ``effort`` (samples or nodes per texel,
#: a positive int; absent = the method's default) applies to them, not to ``adaptive``.
EFFORT_METHODS = METHODS - {"adaptive"}
MAX_EFFORT = 1 << 26

DEFAULT_TOLERANCE = 5e-7
TOLERANCE_RANGE = (1e-12, 1e-1)
#: Methods of a fixed rule, neither error-controlled nor of adjustable effort: ``gauss_kronrod``, the
#: composite G7-K15 of ``sheen_albedo``, ``sheen_albedo_avg`` and ``albedo_aniso`` (its error estimate is
#: the ``_err`` channels). ``tolerance`` is accepted for them (range-checked, so a spec or query valid for
#: any kind stays valid) but ignored: the normalized spec does not record it, so specs that differ only
#: in it hash equal (one cache entry for one table) and no file claims a target the rule did not meet.
FIXED_RULE_METHODS = ("gauss_kronrod",)

TOP_LEVEL_KEYS = ("table", "distribution", "shadowing", "fresnel", "axes", "method", "tolerance", "effort")
#: Keys that only some kinds accept (TABLE_KINDS[kind]["params"]).
KIND_KEYS = ("alpha", "roughness", "parametrization")
#: Keys a kind declares for itself in its catalog entry, one path for every kind:
#: ``TABLE_KINDS[kind]["keys"] = {name: {"choices": (...), "default": value, "description": text,
#: "legacy": an older top-level spelling (optional)}}``. :func:`normalize_spec` validates each against
#: its choices, fills its default (so it is part of the canonical spec, its hash and every table's
#: metadata) and rejects it for the kinds that do not declare it.
KIND_OPTIONS: dict[str, dict[str, dict[str, Any]]] = {
    kind: dict(info.get("keys", {})) for kind, info in TABLE_KINDS.items() if info.get("keys")
}
KIND_OPTION_KEYS: tuple[str, ...] = tuple(sorted({name for keys in KIND_OPTIONS.values() for name in keys}))
for _kind, _keys in KIND_OPTIONS.items():  # a declaration error is the catalog's, caught at import
    for _name, _decl in _keys.items():
        if _name in TOP_LEVEL_KEYS or _name in KIND_KEYS or _decl.get("default") not in tuple(_decl.get("choices", ())):
            raise ImportError(f"table {_kind}: kind key {_name!r} clashes with a spec key or its default is not a choice")


def _parse(spec: dict | str) -> dict:
    if isinstance(spec, (str, bytes, bytearray)):
        try:
            spec = jsontext.loads(spec)  # a repeated key is a SpecError naming it
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
    ftype = choice(value.get("type", "one"), FRESNEL_TYPES, "fresnel.type")
    params = FRESNEL_TYPES[ftype]
    check_keys(value, ("type",) + params, "fresnel")
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


#: Largest ``fresnel.eta`` of a dielectric Fresnel: the eta axis' bound (:data:`AXIS_DOMAINS`).
MAX_DIELECTRIC_ETA = AXIS_DOMAINS["eta"][1]
#: Largest ``fresnel.eta`` and ``fresnel.k`` of a conductor (complex IOR eta + i k). Metals have
#: eta, k < 100 from the UV to the far infrared; within 1000 the exact Fresnel's intermediate
#: eta^2 k^2 stays far inside float32 and float64 range (its float64 value agrees with a 50-digit
#: evaluation to 1e-11; beyond ~1e77 the float64 kernel overflows to NaN).
MAX_CONDUCTOR_IOR = 1000.0


def _fresnel_params(value: dict, ftype: str) -> dict:
    out: dict[str, Any] = {"type": ftype}
    for name in FRESNEL_TYPES[ftype]:
        param = f"fresnel.{name}"
        if name not in value:
            raise SpecError(param, f"is required for fresnel type {ftype}")
        out[name] = number(value[name], param)
    if ftype == "schlick" and not 0.0 <= out["f0"] <= 1.0:
        raise SpecError("fresnel.f0", f"must be in [0, 1], got {out['f0']!r}")
    if "eta" in out and not out["eta"] > 0.0:
        raise SpecError("fresnel.eta", f"must be > 0, got {out['eta']!r}")
    if "k" in out and not out["k"] >= 0.0:
        raise SpecError("fresnel.k", f"must be >= 0, got {out['k']!r}")
    # bounded above: a huge IOR overflows the Fresnel kernels (NaN texels), and no material has one
    eta_max = MAX_DIELECTRIC_ETA if ftype == "dielectric" else MAX_CONDUCTOR_IOR
    if "eta" in out and out["eta"] > eta_max:
        raise SpecError("fresnel.eta", f"must be <= {eta_max:g} for fresnel type {ftype}, got {out['eta']!r}")
    if "k" in out and out["k"] > MAX_CONDUCTOR_IOR:
        raise SpecError("fresnel.k", f"must be <= {MAX_CONDUCTOR_IOR:g}, got {out['k']!r}")
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
        axis = normalize_axis(name, value.get(name))
        resolve_axis(name, axis)  # validates resolved values (domain, increasing)
        out[name] = axis
    return out


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
        ``fresnel``, ``axes`` (in table axis order), ``method``, ``tolerance`` (not for a
        fixed-rule method, :data:`FIXED_RULE_METHODS`, which ignores it);
        the ``bsdf`` table also has ``parametrization`` and ``alpha`` (or
        ``roughness``), its single material's width parameter; a kind that declares its own
        keys (``TABLE_KINDS[kind]["keys"]``, :data:`KIND_OPTIONS`) has each of them.
        Idempotent: ``normalize_spec(normalize_spec(s)) == normalize_spec(s)``.

    Raises
    ------
    SpecError
        With ``param`` naming the offending parameter.
    """
    spec = _parse(spec)
    check_keys(spec, TOP_LEVEL_KEYS + KIND_KEYS + KIND_OPTION_KEYS, "")
    if "table" not in spec:
        raise SpecError("table", f"is required; {one_of(TABLE_KINDS)}")
    kind = choice(spec["table"], TABLE_KINDS, "table")
    info = TABLE_KINDS[kind]
    own = info.get("params", ())
    legacy = {d["legacy"] for d in KIND_OPTIONS.get(kind, {}).values() if d.get("legacy")}
    for key in KIND_KEYS:
        if key in spec and key not in own and key not in legacy:
            hint = f"; for table {kind} {key} is an axis: give axes.{key}" if key in ROUGHNESS_NAMES else ""
            raise SpecError(key, f"is not a parameter of table {kind}{hint}")
    methods = info.get("methods", METHODS)
    out = {
        "table": kind,
        "distribution": choice(spec.get("distribution", "ggx"), DISTRIBUTIONS, "distribution"),
        "shadowing": choice(spec.get("shadowing", "correlated"), SHADOWINGS, "shadowing"),
        "fresnel": _normalize_fresnel(spec.get("fresnel"), kind),
    }
    out.update(_normalize_kind_options(spec, kind))
    parametrization = None
    if "parametrizations" in info:
        parametrization = _normalize_parametrization(spec, kind)
        out["parametrization"] = parametrization
    if "alpha" in own:
        out.update(_normalize_scalar_alpha(spec))
    out["axes"] = _normalize_axes(spec.get("axes"), kind, parametrization)
    out["method"] = choice(spec.get("method", sorted(methods)[0] if "methods" in info else "adaptive"), methods, "method")
    tolerance = _normalize_tolerance(spec.get("tolerance", DEFAULT_TOLERANCE))
    if out["method"] not in FIXED_RULE_METHODS:  # a fixed rule ignores it: not recorded (nor hashed)
        out["tolerance"] = tolerance
    if spec.get("effort") is not None:
        out["effort"] = _normalize_effort(spec["effort"], out["method"])
    return out


def _normalize_kind_options(spec: dict, kind: str) -> dict:
    """The kind's own keys (:data:`KIND_OPTIONS`): each given value checked, absent ones defaulted."""
    declared = KIND_OPTIONS.get(kind, {})
    for key in KIND_OPTION_KEYS:
        if key in spec and key not in declared:
            owners = sorted(k for k, keys in KIND_OPTIONS.items() if key in keys)
            raise SpecError(key, f"is not a parameter of table {kind} (only of {', '.join(owners)})")
    out = {}
    for name, decl in declared.items():
        choices = tuple(decl["choices"])
        value = choice(spec[name], choices, name) if name in spec else None
        old = decl.get("legacy")
        if old and old in spec:  # the older spelling, still accepted: normalized to the key itself
            former = choice(spec[old], choices, old)
            if value is not None and value != former:
                raise SpecError(old, f"is the older spelling of {name}; they disagree ({former!r} vs {value!r}): give {name} only")
            value = former
        out[name] = decl["default"] if value is None else value
    return out


def _normalize_effort(value: Any, method: str) -> int:
    """Samples or nodes per texel of a fixed-effort method (absent: the method's default)."""
    if method not in EFFORT_METHODS:
        if method in FIXED_RULE_METHODS:
            why = ("a fixed composite Gauss-Kronrod 7-15 rule: neither effort nor tolerance changes it; "
                   "its error estimate is in the _err channels")
        elif method == "point":
            why = "exact point evaluation: its _err channels are rounding bounds"
        else:
            why = "it is error-controlled: give tolerance"
        raise SpecError("effort", f"is not a parameter of method {method} ({why})")
    effort = integer(value, "effort")
    if not 8 <= effort <= MAX_EFFORT:
        raise SpecError("effort", f"must be in [8, {MAX_EFFORT}], got {effort}")
    return effort


def _normalize_parametrization(spec: dict, kind: str) -> str:
    """The parametrization given, or inferred from the axis names (default: the first one)."""
    options = TABLE_KINDS[kind]["parametrizations"]
    if "parametrization" in spec:
        return choice(spec["parametrization"], options, "parametrization")
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
    value = number(spec.get(name, DEFAULT_BSDF_ALPHA), name)
    lo, hi = SCALAR_PARAMS[name]
    if not lo < value <= hi:
        raise SpecError(
            name, f"must be in ({lo:g}, {hi:g}], got {value!r} (0 is a mirror: a Dirac delta has no point values)"
        )
    return {name: value}


def _normalize_tolerance(value: Any) -> float:
    tol = number(value, "tolerance")
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


def texel_count(nspec: dict | str) -> int:
    """Number of texels of the table (product of the axis sizes)."""
    nspec = normalize_spec(nspec)
    count = 1
    for axis in nspec["axes"].values():
        count *= len(axis["values"]) if "values" in axis else axis["size"]
    return count


def kind_options(kind: str) -> dict[str, dict[str, Any]]:
    """The keys a table kind declares for itself: name -> {choices, default, description[, legacy]}."""
    return dict(KIND_OPTIONS.get(choice(kind, TABLE_KINDS, "table"), {}))


def axis_names(kind: str) -> tuple[str, ...]:
    """Axis slots of a table kind in order (``"alpha"`` also accepts ``roughness``)."""
    return tuple(TABLE_KINDS[choice(kind, TABLE_KINDS, "table")]["axes"])


def channel_names(kind: str, errors: bool = False) -> list[str]:
    """Value channel names of a table kind, plus ``<X>_err`` names if ``errors``."""
    values = list(TABLE_KINDS[choice(kind, TABLE_KINDS, "table")]["channels"])
    return values + [f"{c}_err" for c in values] if errors else values
