"""The default set: what ``bsdf-tab bake`` writes when given no spec."""

from __future__ import annotations

from ..axes import AXIS_DEFAULTS, resolve_axis

__all__ = ["default_specs"]


def _reciprocal_default_eta() -> list[float]:
    eta = resolve_axis("eta", dict(AXIS_DEFAULTS["eta"]))
    return sorted(float(1.0 / x) for x in eta)


def default_specs() -> list[tuple[str, dict]]:
    """The default tables, as (file name, spec).

    GGX and Beckmann ``albedo`` 32x32 and ``albedo_avg`` 32 (correlated shadowing, F = 1); GGX
    ``dielectric`` 16^3 for eta > 1 (the default eta axis) and for eta < 1 (the sorted
    reciprocals of the default eta axis); GGX ``dfg`` 128x128 on cell centres in mu and
    roughness.
    """
    specs: list[tuple[str, dict]] = []
    for dist in ("ggx", "beckmann"):
        common = {"distribution": dist, "shadowing": "correlated", "fresnel": {"type": "one"}}
        specs.append((f"{dist}_albedo.exr", {"table": "albedo", **common, "axes": {"mu": {"size": 32}, "alpha": {"size": 32}}}))
        specs.append((f"{dist}_albedo_avg.exr", {"table": "albedo_avg", **common, "axes": {"alpha": {"size": 32}}}))
    glass = {"table": "dielectric", "distribution": "ggx", "shadowing": "correlated", "fresnel": {"type": "dielectric"}}
    grid = {"mu": {"size": 16}, "alpha": {"size": 16}}
    specs.append(("ggx_dielectric_eta_gt1.exr", {**glass, "axes": {**grid, "eta": {"size": 16}}}))
    specs.append(("ggx_dielectric_eta_lt1.exr", {**glass, "axes": {**grid, "eta": _reciprocal_default_eta()}}))
    centers = {"size": 128, "nodes": "centers"}
    dfg_axes = {"mu": dict(centers), "roughness": dict(centers)}
    specs.append(("ggx_dfg.exr", {"table": "dfg", "distribution": "ggx", "shadowing": "correlated", "axes": dfg_axes}))
    return specs
