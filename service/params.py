"""The HTTP parameter scheme: query string -> spec, format negotiation, the catalog.

Query parameters of ``GET /tables/{table}`` (every one optional; the library's defaults fill
the rest, see ``GET /tables``):

- ``distribution``, ``shadowing``, ``method``, ``tolerance``, ``effort`` (samples or nodes per
  texel of a fixed-effort method): as in the spec.
- ``fresnel`` (the Fresnel type), ``fresnel_f0``, ``fresnel_eta``, ``fresnel_k``.
- per axis ``A`` of the table (``mu``, ``alpha`` or ``roughness``, ``eta``):

  - ``A=0.1,0.5,1`` explicit, strictly increasing values; or
  - ``A_size=32&A_spacing=linear|square&A_nodes=endpoints|centers&A_min=0&A_max=1&A_clamp=lo,hi``
    (a resolution; omitted keys take the axis defaults).

- ``format``: ``exr`` (default), ``npz``, ``npy``, ``json``; or an ``Accept`` header.

Everything here is derived from the library's tables (``TABLE_KINDS``, ``AXIS_DEFAULTS``,
...), so a new table kind or axis needs no change in the service.
"""

from __future__ import annotations

import math
import re
from typing import Any, Iterable

import bsdf_tab.io as bsdf_io
from bsdf_tab import __version__
from bsdf_tab.spec import (
    AXIS_DEFAULTS,
    AXIS_DOMAINS,
    DEFAULT_TOLERANCE,
    DISTRIBUTIONS,
    FRESNEL_TYPES,
    MAX_AXIS_SIZE,
    MAX_EFFORT,
    METHODS,
    NODES,
    ROUGHNESS_NAMES,
    ROUGHNESS_SLOT,
    SHADOWINGS,
    SPACINGS,
    DEFAULT_BSDF_ALPHA,
    KIND_KEYS,
    KIND_OPTIONS,
    KIND_OPTION_KEYS,
    SCALAR_PARAMS as MATERIAL_SCALARS,
    TABLE_KINDS,
    TOLERANCE_RANGE,
)

from .errors import ServiceError


__all__ = [
    "FORMATS",
    "MEDIA_TYPES",
    "spec_from_query",
    "negotiate",
    "only_params",
    "query_parameters",
    "catalog",
    "spec_json_schema",
    "AXIS_SUFFIXES",
    "KIND_KEYS",
]

#: the formats served (their names, endings and media types are bsdf_tab.io's registry)
FORMATS = ("exr", "npz", "npy", "json")
#: format -> media type
MEDIA_TYPES = bsdf_io.media_types(FORMATS)
DEFAULT_FORMAT = "exr"

#: Accept media types understood, -> format: each format's own and alias types, and wildcards
_ACCEPT = {
    **bsdf_io.accept_types(FORMATS),
    "application/octet-stream": "exr",
    "*/*": DEFAULT_FORMAT,
    "image/*": "exr",
    "application/*": "npz",
}

AXIS_SUFFIXES = ("size", "spacing", "nodes", "min", "max", "clamp")
AXIS_NAMES = tuple(AXIS_DEFAULTS)  # mu, alpha, roughness, eta, ... (whatever the library has)
FRESNEL_PARAMS = tuple(sorted({p for params in FRESNEL_TYPES.values() for p in params}))
SCALAR_PARAMS = ("distribution", "shadowing", "method", "tolerance", "effort", "fresnel") + tuple(
    f"fresnel_{p}" for p in FRESNEL_PARAMS
)


def spec_params() -> list[str]:
    """Every query parameter that sets a part of the spec."""
    names = list(SCALAR_PARAMS) + list(KIND_OPTION_KEYS)  # a kind's own keys (sheen_shadowing=...)
    for axis in AXIS_NAMES:
        names.append(axis)
        names.extend(f"{axis}_{s}" for s in AXIS_SUFFIXES)
    return names


# ------------------------------------------------------------------------- parsing


def _bad(qp: str, message: str, allowed=None) -> ServiceError:
    return ServiceError(400, "invalid_parameter", message, param=qp, allowed=allowed, query_param=qp)


_FLOAT_RE = re.compile(r"^[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?$|^[+-]?(?:nan|inf|infinity)$", re.I)


def _float(text: str, qp: str) -> float:
    t = text.strip()
    if len(t) > 1000 or not _FLOAT_RE.match(t):  # plain ASCII decimals: no "1_0", no other scripts' digits
        raise _bad(qp, f"must be a number, got {text[:40]!r}")
    try:
        return float(t)
    except (ValueError, OverflowError):
        raise _bad(qp, f"must be a number, got {text[:40]!r}") from None


_INT_RE = re.compile(r"^[+-]?[0-9]{1,12}$")


def _int(text: str, qp: str) -> int:
    t = text.strip()
    if not _INT_RE.match(t):  # ASCII digits only: str.isdigit() also accepts "\u00b2", which int() refuses
        raise _bad(qp, f"must be an integer, got {text[:40]!r}")
    return int(t)


def _float_list(text: str, qp: str) -> list[float]:
    items = [s for s in text.split(",")]
    if text.strip() == "":
        raise _bad(qp, "must not be empty: give comma-separated values like 0.1,0.5,1")
    if len(items) > MAX_AXIS_SIZE:
        raise _bad(qp, f"must have at most {MAX_AXIS_SIZE} values, got {len(items)}")
    return [_float(s, qp) for s in items]


def spec_from_query(table: str, items: Iterable[tuple[str, str]], extra: Iterable[str] = ()) -> tuple[dict, dict]:
    """Build a spec from the query items of ``GET /tables/{table}``.

    Parameters
    ----------
    table : str
        The table kind (from the path).
    items : iterable of (name, value)
        The query string items, repeats included.
    extra : iterable of str
        Other parameters the route accepts (``format``, ``channel``, ...); returned apart.

    Returns
    -------
    (dict, dict)
        The spec (not yet normalized) and the extra parameters given.

    Raises
    ------
    ServiceError
        400 for an unknown or repeated parameter, or a value that is not a number.
    """
    extra = set(extra)
    known = set(spec_params()) | set(KIND_KEYS)
    kind_params = set(TABLE_KINDS[table].get("params", ())) if table in TABLE_KINDS else set()
    seen: dict[str, str] = {}
    for name, value in items:
        if name not in known and name not in extra:
            raise _bad(name, "unknown parameter", allowed=sorted(known | extra))
        if name in seen:
            raise _bad(name, "given more than once")
        seen[name] = value
    spec: dict[str, Any] = {"table": table}
    for key in ("distribution", "shadowing", "method", *KIND_OPTION_KEYS):
        if key in seen:
            spec[key] = seen[key]  # strings: the library checks them (a kind's own keys against its choices)
    if "tolerance" in seen:
        spec["tolerance"] = _float(seen["tolerance"], "tolerance")
    if "effort" in seen:
        spec["effort"] = _int(seen["effort"], "effort")
    fresnel: dict[str, Any] = {}
    if "fresnel" in seen:
        fresnel["type"] = seen["fresnel"]
    for p in FRESNEL_PARAMS:
        if f"fresnel_{p}" in seen:
            fresnel[p] = _float(seen[f"fresnel_{p}"], f"fresnel_{p}")
    if fresnel:
        spec["fresnel"] = fresnel
    for key in KIND_KEYS:  # a kind's own scalar (bsdf: alpha=0.3 is the material, not an axis)
        if key in seen and key in kind_params:
            value = seen.pop(key)
            spec[key] = value if key == "parametrization" else _float(value, key)
        elif key in seen and key not in AXIS_NAMES:
            spec[key] = seen.pop(key)  # the library names what is wrong with it
    axes: dict[str, Any] = {}
    for axis in AXIS_NAMES:
        axis_spec = _axis_from_query(axis, seen)
        if axis_spec is not None:
            axes[axis] = axis_spec
    if axes:
        spec["axes"] = axes
    return spec, {k: v for k, v in seen.items() if k in extra}


def only_params(items: Iterable[tuple[str, str]], allowed: Iterable[str]) -> dict[str, str]:
    """The query items as a dict; 400 for a parameter not in ``allowed`` or given twice."""
    allowed = tuple(allowed)
    seen: dict[str, str] = {}
    for name, value in items:
        if name not in allowed:
            raise _bad(name, "unknown parameter", allowed=list(allowed))
        if name in seen:
            raise _bad(name, "given more than once")
        seen[name] = value
    return seen


def _axis_from_query(axis: str, seen: dict[str, str]) -> Any:
    res_keys = [s for s in AXIS_SUFFIXES if f"{axis}_{s}" in seen]
    if axis in seen:
        if res_keys:
            raise _bad(
                f"{axis}_{res_keys[0]}",
                f"give either explicit values {axis}=... or a resolution {axis}_size=..., not both",
            )
        return _float_list(seen[axis], axis)
    if not res_keys:
        return None
    default = AXIS_DEFAULTS[axis]
    out: dict[str, Any] = {"size": _int(seen[f"{axis}_size"], f"{axis}_size") if "size" in res_keys else default["size"]}
    for key in ("spacing", "nodes"):
        if key in res_keys:
            out[key] = seen[f"{axis}_{key}"]
    if "min" in res_keys or "max" in res_keys:
        lo = _float(seen[f"{axis}_min"], f"{axis}_min") if "min" in res_keys else default["range"][0]
        hi = _float(seen[f"{axis}_max"], f"{axis}_max") if "max" in res_keys else default["range"][1]
        out["range"] = [lo, hi]
    if "clamp" in res_keys:
        qp = f"{axis}_clamp"
        values = _float_list(seen[qp], qp)
        if len(values) != 2:
            raise _bad(qp, f"must be two numbers lo,hi, got {seen[qp]!r}")
        out["clamp"] = values
    return out


# ------------------------------------------------------------------------- formats


def negotiate(fmt: str | None, accept: str | None) -> str:
    """The response format from ``format=`` (wins) or the ``Accept`` header; 406 if none fits."""
    if fmt is not None:
        if fmt not in MEDIA_TYPES:
            raise ServiceError(
                406, "unsupported_format", f"unsupported format {fmt[:40]!r}", param="format",
                allowed=list(FORMATS), query_param="format",
            )
        return fmt
    if accept is None or not accept.strip():
        return DEFAULT_FORMAT
    best, best_q = None, 0.0
    for part in accept.split(","):
        fields = [f.strip() for f in part.split(";")]
        media = fields[0].lower()
        q = 1.0
        for f in fields[1:]:
            if f.lower().startswith("q="):
                try:
                    q = float(f[2:])
                except ValueError:
                    q = 0.0
                if not math.isfinite(q):
                    q = 0.0
        if media in _ACCEPT and q > best_q:
            best, best_q = _ACCEPT[media], q
    if best is None:
        raise ServiceError(
            406, "not_acceptable", f"none of the Accept media types can be served: {accept[:100]!r}",
            param="Accept", allowed=sorted(set(MEDIA_TYPES.values())), query_param="format",
        )
    return best


# ------------------------------------------------------------------------- catalog / OpenAPI


def _axis_doc(name: str) -> dict:
    lo, hi, lo_inclusive = AXIS_DOMAINS[name]
    default = AXIS_DEFAULTS[name]
    return {
        "name": name,
        "type": "number",
        "domain": {"min": lo, "max": hi, "min_inclusive": lo_inclusive, "max_inclusive": True},
        "default": default,
        "query": {
            "explicit": f"{name}=v0,v1,... (strictly increasing)",
            "resolution": f"{name}_size=N&{name}_spacing={'|'.join(SPACINGS)}&{name}_nodes={'|'.join(NODES)}"
            f"&{name}_min=LO&{name}_max=HI[&{name}_clamp=C0,C1]",
        },
    }


def catalog(settings) -> dict:
    """The ``GET /tables`` document: tables, parameters, formats and the service limits."""
    tables = {}
    for kind, info in TABLE_KINDS.items():
        axes = []
        for slot in info["axes"]:
            if slot == ROUGHNESS_SLOT:
                doc = _axis_doc("alpha")
                doc["alternatives"] = [_axis_doc(n) for n in ROUGHNESS_NAMES if n != "alpha"]
                doc["note"] = "give alpha or roughness (alpha = roughness^2), not both"
                axes.append(doc)
            else:
                axes.append(_axis_doc(slot))
        fresnel = {
            "any": {"types": sorted(FRESNEL_TYPES), "default": "one"},
            "axis": {"types": ["dielectric"], "default": "dielectric", "note": "eta is the table's eta axis"},
            "one": {"types": ["one"], "default": "one", "note": "Fresnel-independent"},
        }[info["fresnel"]]
        entry = {
            "description": info["description"],
            "axes": axes,
            "channels": list(info["channels"]),
            "error_channels": [f"{c}_err" for c in info["channels"]],
            "fresnel": fresnel,
            "url": f"/tables/{kind}",
            "methods": sorted(info.get("methods", METHODS)),
        }
        if info.get("params"):
            entry["params"] = {
                name: (
                    {"type": "number", "range": list(MATERIAL_SCALARS.get(name, ())),
                     "default": DEFAULT_BSDF_ALPHA if name == "alpha" else None,
                     "query_param": name}
                    if name != "parametrization"
                    else {"type": "string", "enum": list(info.get("parametrizations", {})), "query_param": name}
                )
                for name in info["params"]
            }
        if KIND_OPTIONS.get(kind):
            entry["keys"] = {
                name: {"type": "string", "enum": list(decl["choices"]), "default": decl["default"],
                       "description": decl.get("description", ""), "query_param": name,
                       **({"legacy": decl["legacy"]} if decl.get("legacy") else {})}
                for name, decl in KIND_OPTIONS[kind].items()
            }
        if info.get("parametrizations"):
            entry["parametrizations"] = {k: list(v) for k, v in info["parametrizations"].items()}
            entry["axes_by_parametrization"] = {
                k: [_axis_doc(a) for a in v] for k, v in info["parametrizations"].items()
            }
        tables[kind] = entry
    return {
        "version": __version__,
        "tables": tables,
        "parameters": {
            "distribution": {"type": "string", "enum": sorted(DISTRIBUTIONS), "default": "ggx"},
            "shadowing": {"type": "string", "enum": sorted(SHADOWINGS), "default": "correlated"},
            "method": {"type": "string", "enum": sorted(METHODS), "default": "adaptive",
                       "note": "a table kind may take only its own methods (tables.<kind>.methods)"},
            "tolerance": {
                "type": "number", "min": TOLERANCE_RANGE[0], "max": TOLERANCE_RANGE[1], "default": DEFAULT_TOLERANCE,
            },
            "effort": {"type": "integer", "min": 8, "max": MAX_EFFORT,
                       "note": "samples or nodes per texel; only fixed-effort methods (not adaptive)"},
            "fresnel": {"type": "string", "enum": sorted(FRESNEL_TYPES), "query_param": "fresnel"},
            "fresnel_params": {
                t: {p: {"type": "number", "query_param": f"fresnel_{p}"} for p in params}
                for t, params in FRESNEL_TYPES.items()
            },
            "fresnel_ranges": {"f0": "[0, 1]", "eta": "> 0", "k": ">= 0"},
            "format": {"type": "string", "enum": list(FORMATS), "default": DEFAULT_FORMAT, "media_types": MEDIA_TYPES},
        },
        "limits": {
            "max_texels": settings.max_texels,
            "max_axis_size": MAX_AXIS_SIZE,
            "max_body_bytes": settings.max_body_bytes,
            "max_concurrent_computations": settings.max_concurrent,
            "max_queued_computations": settings.max_queued,
            "max_cost_seconds": settings.max_cost_seconds,
            "max_job_cost_seconds": settings.max_job_cost_seconds,
            "max_compute_seconds": settings.max_compute_seconds,
            "job_max_seconds": settings.job_max_seconds,
        },
        "endpoints": {
            "GET /tables/{table}": "a table by query parameters",
            "POST /tables": "a table by a spec JSON body",
            "GET /tables/{table}/info": "metadata: spec, conventions, method, max error",
            "GET /tables/{table}/preview.png": "heatmap of one channel (channel=, slice=, slice_axis=)",
            "POST /jobs": "big work in the background: {\"spec\": ...} or {\"scene\": ..., \"tol\": x}",
            "GET /jobs/{id}": "status, progress, eta_seconds, result URL, error",
            "DELETE /jobs/{id}": "cancel a job",
            "GET /tables/by-key/{key}": "a computed table by its cache key (a job's result)",
        },
    }


def query_param(name: str, schema: dict, description: str) -> dict:
    return {"name": name, "in": "query", "required": False, "schema": schema, "description": description}


def query_parameters(extra: Iterable[dict] = ()) -> list[dict]:
    """OpenAPI ``parameters`` for the query scheme (documentation, and the fuzz tests' source)."""
    out = [
        query_param("distribution", {"type": "string", "enum": sorted(DISTRIBUTIONS)}, "microfacet distribution"),
        query_param("shadowing", {"type": "string", "enum": sorted(SHADOWINGS)}, "shadowing-masking form"),
        query_param("method", {"type": "string"}, "integration method (see GET /tables for each table's)"),
        query_param("tolerance", {"type": "number"}, f"target absolute error, in {list(TOLERANCE_RANGE)}"),
        query_param("effort", {"type": "integer", "minimum": 8, "maximum": MAX_EFFORT},
           "samples or nodes per texel of a fixed-effort method (not adaptive)"),
        query_param("fresnel", {"type": "string", "enum": sorted(FRESNEL_TYPES)}, "Fresnel type"),
    ]
    out += [query_param(f"fresnel_{p}", {"type": "number"}, f"Fresnel parameter {p}") for p in FRESNEL_PARAMS]
    out += [
        query_param(k, {"type": "string"}, f"table parameter {k} (only tables that take it, see GET /tables)")
        for k in KIND_KEYS
        if k not in AXIS_NAMES
    ]
    # a kind's own keys (KIND_OPTIONS, e.g. sheen_shadowing) are accepted like the keys above and
    # documented per table in the catalog (GET /tables: tables.<kind>.keys) and in the POST schema
    for axis in AXIS_NAMES:
        out += [
            query_param(axis, {"type": "string", "pattern": r"^[-+0-9.eE,]+$"}, f"explicit {axis} values, comma-separated, increasing"
               + (" (for a table that takes a scalar {axis}, that scalar)" if axis in KIND_KEYS else "")),
            query_param(f"{axis}_size", {"type": "integer", "minimum": 1, "maximum": MAX_AXIS_SIZE}, f"{axis} resolution"),
            query_param(f"{axis}_spacing", {"type": "string", "enum": list(SPACINGS)}, f"{axis} spacing"),
            query_param(f"{axis}_nodes", {"type": "string", "enum": list(NODES)}, f"{axis} node placement"),
            query_param(f"{axis}_min", {"type": "number"}, f"{axis} range low end"),
            query_param(f"{axis}_max", {"type": "number"}, f"{axis} range high end"),
            query_param(f"{axis}_clamp", {"type": "string"}, f"clamp resolved {axis} values to lo,hi"),
        ]
    out += list(extra)
    return out


FORMAT_PARAM = query_param("format", {"type": "string", "enum": list(FORMATS)}, "response format (default exr; or use Accept)")


def spec_json_schema() -> dict:
    """JSON Schema of a spec (the ``POST /tables`` body)."""
    number = {"type": "number"}
    axis = {
        "oneOf": [
            {"type": "array", "items": number, "minItems": 1, "maxItems": MAX_AXIS_SIZE},
            {
                "type": "object",
                "properties": {
                    "size": {"type": "integer", "minimum": 1, "maximum": MAX_AXIS_SIZE},
                    "spacing": {"type": "string", "enum": list(SPACINGS)},
                    "nodes": {"type": "string", "enum": list(NODES)},
                    "range": {"type": "array", "items": number, "minItems": 2, "maxItems": 2},
                    "clamp": {"type": "array", "items": number, "minItems": 2, "maxItems": 2},
                },
                "additionalProperties": False,
            },
        ]
    }
    return {
        "type": "object",
        "required": ["table"],
        "additionalProperties": False,
        "properties": {
            "table": {"type": "string", "enum": list(TABLE_KINDS)},
            "distribution": {"type": "string", "enum": sorted(DISTRIBUTIONS)},
            "shadowing": {"type": "string", "enum": sorted(SHADOWINGS)},
            "method": {"type": "string"},
            "tolerance": number,
            "effort": {"type": "integer", "minimum": 8, "maximum": MAX_EFFORT},
            **{k: ({"type": "string"} if k == "parametrization" else number) for k in KIND_KEYS},
            **{k: {"type": "string"} for k in KIND_OPTION_KEYS},
            "fresnel": {
                "type": "object",
                "properties": {"type": {"type": "string", "enum": sorted(FRESNEL_TYPES)}, **{p: number for p in FRESNEL_PARAMS}},
                "additionalProperties": False,
            },
            "axes": {"type": "object", "properties": {a: axis for a in AXIS_NAMES}, "additionalProperties": False},
        },
        "example": {
            "table": "albedo",
            "distribution": "ggx",
            "shadowing": "correlated",
            "fresnel": {"type": "one"},
            "axes": {"mu": [0.1, 0.5, 1.0], "alpha": {"size": 8}},
        },
    }
