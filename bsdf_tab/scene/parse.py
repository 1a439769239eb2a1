"""Scene files: load (JSON or TOML), validate and normalize a scene.

A *scene* is a JSON object with a ``materials`` list (``docs/scenes.md``,
``examples/scene.json``)::

    {"lookup": {"interpolation": "linear", "spacings": ["linear", "square"]},
     "materials": [
       {"name": "gold", "type": "conductor", "eta": 0.18, "k": 3.42, "roughness": {"range": [0.3, 0.6]}},
       {"name": "plastic", "type": "schlick", "f0": 0.04, "alpha": [0.1, 0.2]},
       {"name": "glass", "type": "dielectric", "eta": 1.5, "alpha": 0.05}]}

Material keys: ``name`` (unique), ``type`` (``conductor``, ``dielectric``, ``schlick``, ``anisotropic``),
``distribution``, ``shadowing``, one of ``alpha`` or ``roughness`` (alpha = roughness^2) as a
number, a list of numbers or ``{"range": [lo, hi]}``; conductors: ``eta`` and ``k`` (complex
IOR; or ``"ior": [eta, k]``); dielectrics: ``eta`` (number, list or range; eta = eta_o / eta_i);
Schlick: ``f0`` (number or RGB list; it does not enter the table); anisotropic (GGX, F = 1):
``anisotropy`` (number, list or range in [0, 1]). The scene's ``tolerance`` is
its default lookup tolerance (the max lookup error; normalized as ``lookup_tol``).

What a value may be is decided once, by the table specs: the distributions, shadowings, axis
domains and Fresnel parameters are checked by :mod:`bsdf_tab.spec` (and
:mod:`bsdf_tab.validate`), their :class:`SpecError` renamed to the scene's parameter
(``materials[1].alpha``). Only what is the scene's own is checked here: the material types, the
lookup (interpolation, spacings), ranges and the lookup tolerance.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from .. import jsontext
from ..errors import SpecError
from ..spec import DISTRIBUTIONS, FRESNEL_TYPES, SHADOWINGS, SPACINGS, normalize_spec, resolve_axis
from ..validate import check_keys, choice, number

__all__ = [
    "MATERIAL_TABLES",
    "INTERPOLATIONS",
    "LOOKUP_TOL_RANGE",
    "check_lookup_tol",
    "is_scene",
    "load_scene_file",
    "parse_scene",
]

#: Material type -> the table kind its materials are planned into (the type is its Fresnel type;
#: ``anisotropic``: anisotropic GGX, F = 1, the energy table of energy compensation).
MATERIAL_TABLES = {"conductor": "albedo", "dielectric": "dielectric", "schlick": "dfg", "anisotropic": "albedo_aniso"}
#: Distributions an anisotropic material may use (the ``albedo_aniso`` kernel is GGX's).
ANISO_DISTRIBUTIONS = ("ggx",)
#: How the renderer reads the tables.
INTERPOLATIONS = ("linear", "nearest")
#: The lookup tolerance (max lookup error, absolute, per channel) a scene may ask for.
LOOKUP_TOL_RANGE = (1e-6, 1e-1)
SCENE_KEYS = ("name", "materials", "lookup", "tolerance")
LOOKUP_KEYS = ("interpolation", "spacings")
COMMON_KEYS = ("name", "type", "distribution", "shadowing", "alpha", "roughness")
#: Keys of each material type: its Fresnel parameters (conductors also ``ior``: [eta, k]).
MATERIAL_KEYS = {t: FRESNEL_TYPES[t] + (("ior",) if t == "conductor" else ()) for t in MATERIAL_TABLES if t in FRESNEL_TYPES}
MATERIAL_KEYS["anisotropic"] = ("anisotropy",)
SPACING_ALIASES = {"sqrt": "square"}  # t uniform in sqrt(x)


def check_lookup_tol(tol: Any, param: str = "tol") -> float:
    """A lookup tolerance: a finite number in ``LOOKUP_TOL_RANGE`` (SpecError naming ``param``)."""
    x = number(tol, param)
    lo, hi = LOOKUP_TOL_RANGE
    if not lo <= x <= hi:
        raise SpecError(param, f"must be in [{lo:g}, {hi:g}] (the max lookup error), got {x!r}")
    return x


def is_scene(obj: Any) -> bool:
    """True for a JSON object with a top-level ``materials`` key (a scene, not a table spec)."""
    return isinstance(obj, dict) and "materials" in obj


def load_scene_file(path: str | Path, strict: bool = True) -> Any:
    """The contents of a scene (or spec) file: TOML for a ``.toml`` name, JSON otherwise.

    ``strict`` (the default): a JSON object that repeats a key is an error; ``False`` keeps the
    last, for telling a scene from a spec before the strict read reports it.

    Raises
    ------
    SpecError
        A missing or unreadable file, or invalid JSON / TOML (one line naming the file).
    """
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise SpecError(None, f"file not found: {p}") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise SpecError(None, f"cannot read {p}: {exc}") from None
    if p.suffix.lower() == ".toml":
        import tomllib  # only for TOML scenes: 2 ms of imports a JSON scene does not need

        try:
            return tomllib.loads(text)
        except tomllib.TOMLDecodeError as exc:
            raise SpecError(None, f"{p}: invalid TOML: {exc}") from None
    try:
        return jsontext.loads(text) if strict else json.loads(text)  # strict: as spec files and the service
    except json.JSONDecodeError as exc:
        raise SpecError(None, f"{p}: invalid JSON: {exc}") from None
    except SpecError as exc:
        raise SpecError(None, f"{p}: {exc.message}") from None


def parse_scene(scene: dict | str) -> dict:
    """Validate a scene and return its normalized form.

    Returns
    -------
    dict
        ``lookup`` (``interpolation``, ``spacings``), ``materials`` (normalized: ``rough_name``
        and ``rough`` for the alpha or roughness values, ``eta_axis`` for a dielectric) and
        ``lookup_tol`` when the scene gives a ``tolerance``.

    Raises
    ------
    SpecError
        Naming the parameter (``materials[1].alpha``, ``lookup.interpolation``, ...).
    """
    if isinstance(scene, (str, bytes, bytearray)):
        try:
            scene = jsontext.loads(scene)
        except json.JSONDecodeError as exc:
            raise SpecError(None, f"invalid JSON: {exc}") from None
    if not isinstance(scene, dict):
        raise SpecError(None, f"a scene must be a JSON object, got {type(scene).__name__}")
    check_keys(scene, SCENE_KEYS, "")
    out: dict[str, Any] = {"lookup": _lookup(scene.get("lookup", {}))}
    if "tolerance" in scene:
        out["lookup_tol"] = check_lookup_tol(scene["tolerance"], "tolerance")
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


def _lookup(lk: Any) -> dict:
    if not isinstance(lk, dict):
        raise SpecError("lookup", f"must be an object, got {lk!r}")
    check_keys(lk, LOOKUP_KEYS, "lookup")
    interp = choice(lk.get("interpolation", "linear"), INTERPOLATIONS, "lookup.interpolation")
    spacings = lk.get("spacings", list(SPACINGS))
    if not isinstance(spacings, list) or not spacings:
        raise SpecError("lookup.spacings", f"must be a non-empty list of {', '.join(SPACINGS)}, got {spacings!r}")
    spacings = list(dict.fromkeys(
        choice(SPACING_ALIASES.get(s, s) if isinstance(s, str) else s, SPACINGS, "lookup.spacings") for s in spacings))
    return {"interpolation": interp, "spacings": spacings}


def _relabel(param: str, check, *args):
    """``check(*args)``, a SpecError it raises named ``param`` (the scene's name of the value)."""
    try:
        return check(*args)
    except SpecError as exc:
        raise SpecError(param, exc.message) from None


def _axis_value(v: Any, axis: str, param: str) -> float:
    """A value of axis ``axis`` (alpha, roughness, eta): a number in the spec's axis domain."""
    x = number(v, param)
    _relabel(param, resolve_axis, axis, {"values": [x]})  # the axis domain: spec.AXIS_DOMAINS[axis]
    return x


def _values(v: Any, axis: str, param: str) -> dict:
    """A number, a non-empty list of numbers or {"range": [lo, hi]} -> {"values": [...]} or {"range": [...]}."""
    if isinstance(v, dict):
        if set(v) != {"range"}:
            raise SpecError(param, f"must be a number, a list of numbers or {{\"range\": [lo, hi]}}, got {v!r}")
        r = v["range"]
        if not isinstance(r, (list, tuple)) or len(r) != 2:
            raise SpecError(f"{param}.range", f"must be [lo, hi], got {r!r}")
        a, b = (_axis_value(x, axis, f"{param}.range") for x in r)
        if not a < b:
            raise SpecError(f"{param}.range", f"must have lo < hi, got {list(r)!r}")
        return {"range": [a, b]}
    if isinstance(v, (list, tuple)):
        if not v:
            raise SpecError(param, "must not be empty")
        return {"values": sorted({_axis_value(x, axis, param) for x in v})}
    return {"values": [_axis_value(v, axis, param)]}


def _fresnel(ftype: str, given: dict, params: dict[str, str]) -> dict:
    """The Fresnel parameters ``given``, validated as a table spec's ``fresnel`` (its SpecError
    named as the scene names the value: ``params`` maps the spec's parameter to the scene's)."""
    try:
        return normalize_spec({"table": "albedo", "fresnel": {"type": ftype, **given}})["fresnel"]
    except SpecError as exc:
        raise SpecError(params.get(exc.param, exc.param), exc.message) from None


def _material(m: Any, p: str) -> dict:
    if not isinstance(m, dict):
        raise SpecError(p, f"must be an object, got {m!r}")
    if "type" not in m:
        raise SpecError(f"{p}.type", f"is required; must be one of {', '.join(MATERIAL_TABLES)}")
    mtype = choice(m["type"], MATERIAL_TABLES, f"{p}.type")
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
        "distribution": choice(m.get("distribution", "ggx"), ANISO_DISTRIBUTIONS if mtype == "anisotropic"
                               else DISTRIBUTIONS, f"{p}.distribution"),
        "shadowing": choice(m.get("shadowing", "correlated"), SHADOWINGS, f"{p}.shadowing"),
    }
    given = [k for k in ("alpha", "roughness") if k in m]
    if len(given) != 1:
        raise SpecError(f"{p}.alpha", "give exactly one of alpha, roughness (alpha = roughness^2)")
    rk = given[0]
    out["rough_name"] = rk
    out["rough"] = _values(m[rk], rk, f"{p}.{rk}")
    if mtype == "conductor":
        out.update(_conductor(m, p))
    elif mtype == "anisotropic":
        if "anisotropy" not in m:
            raise SpecError(f"{p}.anisotropy", "is required for an anisotropic material (a in [0, 1]: "
                            "alpha_x = alpha / sqrt(1 - 0.9 a), alpha_y = alpha sqrt(1 - 0.9 a))")
        out["aniso_axis"] = _values(m["anisotropy"], "anisotropy", f"{p}.anisotropy")
    elif mtype == "dielectric":
        if "eta" not in m:
            raise SpecError(f"{p}.eta", "is required for a dielectric (eta = eta_o / eta_i)")
        out["eta_axis"] = _values(m["eta"], "eta", f"{p}.eta")
    else:
        if "f0" not in m:
            raise SpecError(f"{p}.f0", "is required for a Schlick material")
        f0 = m["f0"]
        params = {"fresnel.f0": f"{p}.f0"}
        out["f0"] = ([_fresnel("schlick", {"f0": x}, params)["f0"] for x in f0] if isinstance(f0, list)
                     else _fresnel("schlick", {"f0": f0}, params)["f0"])
    return out


def _conductor(m: dict, p: str) -> dict:
    """``eta`` and ``k`` of a conductor (complex IOR eta + i k), given as such or as ``ior``."""
    if "ior" in m:
        if "eta" in m or "k" in m:
            raise SpecError(f"{p}.ior", "give either ior [eta, k] or eta and k, not both")
        ior = m["ior"]
        if not isinstance(ior, (list, tuple)) or len(ior) != 2:
            raise SpecError(f"{p}.ior", f"must be [eta, k], got {ior!r}")
        eta, k = ior
        params = {"fresnel.eta": f"{p}.ior", "fresnel.k": f"{p}.ior"}
    else:
        for key in ("eta", "k"):
            if key not in m:
                raise SpecError(f"{p}.{key}", "is required for a conductor (complex IOR eta + i k)")
        eta, k = m["eta"], m["k"]
        params = {"fresnel.eta": f"{p}.eta", "fresnel.k": f"{p}.k"}
    fresnel = _fresnel("conductor", {"eta": eta, "k": k}, params)
    return {"eta": fresnel["eta"], "k": fresnel["k"]}
