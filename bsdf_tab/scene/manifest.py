"""The manifest of a planned scene (``manifest.json``) and the bake: tables + manifest in a folder.

The manifest is what a renderer needs to use the tables without this package: the plan
(``lookup_tol``, the max lookup error asked for; ``interpolation``; bytes; the verified
``max_error``), for each table its file, kind, Fresnel, channels, spec and axes (how to compute
the texel coordinate), and for each material its table and coordinates. ``POST /scenes``
answers the same object as ``plan``.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import SpecError
from ..io import json_default, write_text

__all__ = ["bake_scene", "material_entry", "plan_dict"]


def _finite_or_none(x: float) -> float | None:
    """JSON has no nan: a comparison that was not computed is null."""
    return None if math.isnan(x) else x


def plan_dict(plan) -> dict:
    """The JSON form of a :class:`~bsdf_tab.scene.ScenePlan` (``manifest.json``)."""
    return {
        "lookup_tol": plan.lookup_tol,
        "interpolation": plan.interpolation,
        "bytes": plan.bytes,
        "fixed_bytes": plan.fixed_bytes,
        "max_error": plan.max_error,
        "fixed_max_error": _finite_or_none(plan.fixed_error),
        "tables": [_table_entry(t) for t in plan.tables],
        "materials": plan.materials,
    }


def _table_entry(t) -> dict:
    return {
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
        "integration_tolerance": t.integration_tol,
        "fixed_alternative": {"shape": list(t.fixed_shape), "bytes": t.fixed_bytes,
                              "max_error": _finite_or_none(t.fixed_error),
                              "axes": [a.describe() for a in t.fixed_axes()]},
        "materials": list(t.materials),
        "spec": t.spec(),
    }


def material_entry(m: dict, tp, rname: str) -> dict:
    """The manifest entry of material ``m`` (normalized, :func:`~bsdf_tab.scene.parse_scene`)
    planned into table ``tp`` (a :class:`~bsdf_tab.scene.TablePlan`) whose roughness axis is
    ``rname`` (``alpha`` or ``roughness``)."""
    coords: dict[str, Any] = {"mu": "cos(theta_i) of the shading point"}
    r = m["rough"] if m["rough_name"] == rname else {k: [v * v for v in vs] for k, vs in m["rough"].items()}
    src = {rname: r}
    if m["type"] == "dielectric":
        src["eta"] = m["eta_axis"]
    if m["type"] == "anisotropic":
        src["anisotropy"] = m["aniso_axis"]
    for ax in tp.axes[1:]:
        if ax.name == "phi_v":
            coords["phi_v"] = ("view azimuth from the tangent (the alpha_x direction), folded into [0, pi/2]: "
                               "atan2(|sin phi|, |cos phi|)")
            continue
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
    elif m["type"] == "anisotropic":
        entry["formula"] = ("E (F = 1) of anisotropic GGX: alpha_x = alpha / sqrt(1 - 0.9 a), "
                            "alpha_y = alpha sqrt(1 - 0.9 a), a = anisotropy")
    else:
        entry["formula"] = "R, T (energy form; eta = eta_o / eta_i)"
    return entry


def bake_scene(plan, out_dir: str | Path) -> Path:
    """Write the plan's tables (EXR) and ``manifest.json`` into ``out_dir``; return the manifest path."""
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise SpecError("output", f"{out} exists and is not a folder")
    out.mkdir(parents=True, exist_ok=True)
    for t in plan.tables:
        t.table.write_exr(out / t.file)
    path = out / "manifest.json"
    write_text(path, json.dumps(plan_dict(plan), indent=2, default=json_default) + "\n")
    return path
