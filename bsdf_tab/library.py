"""Material libraries: many materials, each with its own tables, baked as one graph.

A library file (TOML or JSON) has a top-level ``library`` table::

    [library]
    name = "studio"
    distribution = "ggx"          # defaults for every material
    shadowing = "correlated"
    mu = 16                       # axis sizes of every material's tables
    roughness = 16

    [[library.materials]]
    name = "gold"
    type = "conductor"            # complex IOR (eta, k) at each wavelength
    wavelengths_nm = [650, 550, 450]
    ior = [[0.166, 3.15], [0.43, 2.45], [1.46, 1.95]]

    [[library.materials]]
    name = "crown-glass"
    type = "dielectric"           # eta = n_inside / n_outside: light entering (eta) and leaving (1/eta)
    eta = 1.52                    # in [0.01, 100], not 1: both eta and 1/eta are tabulated

    [[library.materials]]
    name = "white-plastic"
    type = "schlick"
    f0 = 0.04

Each material gets its tables under ``<out>/<material name>/``: a conductor one ``albedo``
table per wavelength (``albedo_650nm.exr``: E(mu, roughness) with the exact conductor Fresnel),
a dielectric ``dielectric.exr`` (R, T over mu, roughness and eta in {1/eta, eta}) and
``dielectric_avg.exr``, a Schlick material ``albedo.exr`` (Schlick Fresnel with its f0).
A dielectric's ``eta`` must be in [0.01, 100] and not 1 (:data:`DIELECTRIC_ETA_RANGE`): both eta
and 1/eta lie on the eta axis, whose domain is (0, 100].
Materials may override ``distribution``, ``shadowing``, ``mu`` and ``roughness``. Every spec is
validated by :func:`bsdf_tab.spec.normalize_spec`; errors name the library parameter
(``library.materials[3].ior[1]``).
"""

from __future__ import annotations

import re
from typing import Any

from .errors import SpecError
from .spec import AXIS_DOMAINS, DISTRIBUTIONS, SHADOWINGS, normalize_spec
from .validate import check_keys, choice, integer, number

__all__ = ["DIELECTRIC_ETA_RANGE", "LIBRARY_KEYS", "MATERIAL_TYPES", "is_library", "library_specs"]

LIBRARY_KEYS = ("name", "distribution", "shadowing", "mu", "roughness", "materials")
MATERIAL_TYPES = ("conductor", "dielectric", "schlick")
_COMMON = ("name", "type", "distribution", "shadowing", "mu", "roughness")
_MATERIAL_KEYS = {
    "conductor": _COMMON + ("wavelengths_nm", "ior"),
    "dielectric": _COMMON + ("eta",),
    "schlick": _COMMON + ("f0",),
}
_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._-]{0,63}$")
DEFAULT_SIZE = 16
#: A dielectric material's eta: the library tabulates eta and 1/eta, and both must lie in the eta
#: axis' domain (0, hi], so eta in [1/hi, hi] (hi = 100: [0.01, 100]); eta = 1 is no interface.
DIELECTRIC_ETA_RANGE = (1.0 / AXIS_DOMAINS["eta"][1], AXIS_DOMAINS["eta"][1])


def is_library(obj: Any) -> bool:
    """A parsed file is a library if it has a top-level ``library`` table."""
    return isinstance(obj, dict) and "library" in obj


def _size(value: Any, param: str) -> int:
    n = integer(value, param)
    if not 2 <= n <= 1024:
        raise SpecError(param, f"must be in [2, 1024], got {n}")
    return n


def _renamed(exc: SpecError, param: str) -> SpecError:
    return SpecError(param, exc.message)


def _spec(table: str, mat: dict, fresnel: dict | None, extra_axes: dict, param: str) -> dict:
    spec = {"table": table, "distribution": mat["distribution"], "shadowing": mat["shadowing"],
            "axes": {"mu": {"size": mat["mu"]}, "roughness": {"size": mat["roughness"]}, **extra_axes}}
    if table == "dielectric_avg":
        del spec["axes"]["mu"]
    if fresnel is not None:
        spec["fresnel"] = fresnel
    try:
        return normalize_spec(spec)
    except SpecError as exc:  # e.g. a conductor eta <= 0: name the library's parameter
        raise _renamed(exc, param) from None


def _conductor(m: dict, mat: dict, p: str) -> list[tuple[str, dict]]:
    waves, iors = m.get("wavelengths_nm"), m.get("ior")
    if not isinstance(iors, list) or not iors:
        raise SpecError(f"{p}.ior", "is required: a list of [eta, k] pairs, one per wavelength")
    if not isinstance(waves, list) or len(waves) != len(iors):
        raise SpecError(f"{p}.wavelengths_nm", f"must be a list of {len(iors)} wavelengths (one per ior pair)")
    out = []
    for j, (w, pair) in enumerate(zip(waves, iors)):
        nm = number(w, f"{p}.wavelengths_nm[{j}]")
        if not 100.0 <= nm <= 20000.0:
            raise SpecError(f"{p}.wavelengths_nm[{j}]", f"must be in [100, 20000] nm, got {nm!r}")
        if not isinstance(pair, list) or len(pair) != 2:
            raise SpecError(f"{p}.ior[{j}]", f"must be [eta, k], got {pair!r}")
        eta, k = number(pair[0], f"{p}.ior[{j}]", "[0] "), number(pair[1], f"{p}.ior[{j}]", "[1] ")
        spec = _spec("albedo", mat, {"type": "conductor", "eta": eta, "k": k}, {}, f"{p}.ior[{j}]")
        out.append((f"albedo_{nm:g}nm.exr", spec))
    return out


def _dielectric(m: dict, mat: dict, p: str) -> list[tuple[str, dict]]:
    if "eta" not in m:
        raise SpecError(f"{p}.eta", "is required for a dielectric (eta = n_inside / n_outside)")
    eta = number(m["eta"], f"{p}.eta")
    lo, hi = DIELECTRIC_ETA_RANGE
    if not (lo <= eta <= hi and eta != 1.0):  # checked here, in the user's terms: the axis also holds 1/eta
        raise SpecError(f"{p}.eta", f"must be in [{lo:g}, {hi:g}] and not 1 (eta and 1/eta are both tabulated), "
                        f"got {eta!r}")
    etas = sorted({eta, 1.0 / eta})
    fres = {"type": "dielectric"}
    return [("dielectric.exr", _spec("dielectric", mat, fres, {"eta": etas}, f"{p}.eta")),
            ("dielectric_avg.exr", _spec("dielectric_avg", mat, fres, {"eta": etas}, f"{p}.eta"))]


def _schlick(m: dict, mat: dict, p: str) -> list[tuple[str, dict]]:
    if "f0" not in m:
        raise SpecError(f"{p}.f0", "is required for a Schlick material")
    f0 = number(m["f0"], f"{p}.f0")
    return [("albedo.exr", _spec("albedo", mat, {"type": "schlick", "f0": f0}, {}, f"{p}.f0"))]


_TABLES = {"conductor": _conductor, "dielectric": _dielectric, "schlick": _schlick}


def library_specs(obj: Any) -> list[tuple[str, dict]]:
    """The (relative output path, normalized spec) of every table of a parsed library file.

    Raises
    ------
    SpecError
        Naming the library parameter (``library.materials[2].f0``).
    """
    if not is_library(obj):
        raise SpecError("library", "a library file needs a top-level 'library' table")
    lib = obj["library"]
    if not isinstance(lib, dict):
        raise SpecError("library", f"must be a table (object), got {type(lib).__name__}")
    check_keys(lib, LIBRARY_KEYS, "library")
    defaults = {
        "distribution": choice(lib.get("distribution", "ggx"), DISTRIBUTIONS, "library.distribution"),
        "shadowing": choice(lib.get("shadowing", "correlated"), SHADOWINGS, "library.shadowing"),
        "mu": _size(lib.get("mu", DEFAULT_SIZE), "library.mu"),
        "roughness": _size(lib.get("roughness", DEFAULT_SIZE), "library.roughness"),
    }
    mats = lib.get("materials")
    if not isinstance(mats, list) or not mats:
        raise SpecError("library.materials", "must be a non-empty list of materials")
    out, names = [], set()
    for i, m in enumerate(mats):
        p = f"library.materials[{i}]"
        if not isinstance(m, dict):
            raise SpecError(p, f"must be a table (object), got {type(m).__name__}")
        kind = choice(m.get("type"), MATERIAL_TYPES, f"{p}.type")
        check_keys(m, _MATERIAL_KEYS[kind], p)
        name = m.get("name")
        if not isinstance(name, str) or not _NAME.match(name):
            raise SpecError(f"{p}.name", "is required: letters, digits, '.', '_' or '-' (a folder name)")
        if name in names:
            raise SpecError(f"{p}.name", f"duplicate material name {name!r}")
        names.add(name)
        mat = {
            "distribution": choice(m.get("distribution", defaults["distribution"]), DISTRIBUTIONS, f"{p}.distribution"),
            "shadowing": choice(m.get("shadowing", defaults["shadowing"]), SHADOWINGS, f"{p}.shadowing"),
            "mu": _size(m.get("mu", defaults["mu"]), f"{p}.mu"),
            "roughness": _size(m.get("roughness", defaults["roughness"]), f"{p}.roughness"),
        }
        tables = _TABLES[kind](m, mat, p)
        files = [file for file, _ in tables]
        twice = sorted({f for f in files if files.count(f) > 1})
        if twice:  # e.g. wavelengths 550 and 550.0000001 name one file: the second would overwrite the first
            raise SpecError(f"{p}.wavelengths_nm" if "wavelengths_nm" in m else p,
                            f"two of its tables would be written to {name}/{twice[0]}: give values that differ "
                               "in their printed form (file names use 6 significant digits)")
        out += [(f"{name}/{file}", spec) for file, spec in tables]
    return out
