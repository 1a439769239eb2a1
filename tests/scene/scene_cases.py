"""What the scene tests share: the test scenes, one plan of each (computed once per session),
and a renderer's read of a table written here from the manifest alone (SciPy's grid
interpolator in the decoded texel coordinate, apart from ``bsdf_tab.scene.lookup``)."""

from __future__ import annotations

import numpy as np

from bsdf_tab.scene import plan_scene

METALS = {
    "materials": [
        {"name": "gold", "type": "conductor", "eta": 0.18, "k": 3.42, "roughness": {"range": [0.3, 0.6]}},
        {"name": "copper", "type": "conductor", "ior": [0.27, 3.61], "roughness": 0.4},
    ]
}
MIXED = {
    "lookup": {"interpolation": "linear", "spacings": ["linear"]},
    "materials": [
        {"name": "plastic", "type": "schlick", "f0": 0.04, "alpha": {"range": [0.1, 0.4]}},
        {"name": "glass", "type": "dielectric", "eta": 1.5, "alpha": [0.2, 0.3], "distribution": "beckmann"},
    ],
}
NEAREST = {
    "lookup": {"interpolation": "nearest"},
    "materials": [
        {"name": "rough", "type": "schlick", "f0": 0.5, "roughness": {"range": [0.5, 0.9]}, "shadowing": "separable"}
    ],
}
TINY = {"materials": [{"name": "steel", "type": "conductor", "eta": 2.5, "k": 3.0, "alpha": 0.3}]}
GLASS3D = {"materials": [{"name": "g", "type": "dielectric", "eta": {"range": [1.3, 1.6]}, "alpha": {"range": [0.3, 0.5]}}]}
SCENES = [("metals", METALS, 2e-3), ("mixed", MIXED, 2e-3), ("nearest", NEAREST, 2e-2), ("glass3d", GLASS3D, 5e-3)]

_PLANS: dict = {}


def planned(name: str, scene: dict, tol: float):
    """The plan of a test scene, computed once per test session."""
    if name not in _PLANS:
        _PLANS[name] = plan_scene(scene, tol)
    return _PLANS[name]


def material_points(mat: dict, rng, n: int = 4) -> dict:
    """Random coordinates of a material: {axis: sorted values} in the table's units (before
    alpha = roughness^2 conversion, handled by the caller)."""
    def pick(v):
        if "range" in v:
            lo, hi = v["range"]
            return sorted(set(np.round(rng.uniform(lo, hi, n), 12).tolist()))
        return list(v["values"])

    out = {}
    for key in ("alpha", "roughness"):
        if key in mat:
            out[key] = pick(mat[key] if isinstance(mat[key], dict) else {"values": np.atleast_1d(mat[key]).tolist()})
    if mat["type"] == "dielectric":
        out["eta"] = pick({"values": np.atleast_1d(mat["eta"]).tolist()} if not isinstance(mat["eta"], dict) else mat["eta"])
    return out


def renderer_lookup(entry: dict, values: np.ndarray, points: dict, interpolation: str) -> np.ndarray:
    """Read ``values`` (a table channel) at the grid ``points`` ({axis: coordinates}) as a
    renderer does from the manifest entry: an ``index`` axis picks its listed value; an
    interpolated axis is linear or nearest in the texel coordinate t = (g(x) - g(lo)) /
    (g(hi) - g(lo)) with g = sqrt for ``square`` spacing and g(x) = x for ``linear``."""
    from scipy.interpolate import RegularGridInterpolator

    grid, query = [], []
    values = np.asarray(values, dtype=np.float64)
    for k, ax in enumerate(entry["axes"]):
        x = np.asarray(points[ax["name"]], dtype=np.float64)
        if ax["lookup"] == "index":
            idx = [ax["values"].index(v) if v in ax["values"] else int(np.argmin(np.abs(np.asarray(ax["values"]) - v)))
                   for v in x]
            assert np.allclose(np.asarray(ax["values"])[idx], x), (ax, x)
            values = np.take(values, idx, axis=k)
            grid.append(np.arange(len(idx), dtype=np.float64))
            query.append(np.arange(len(idx), dtype=np.float64))
            continue
        g = np.sqrt if ax["spacing"] == "square" else (lambda v: v)
        lo, hi = ax["range"]
        grid.append(np.linspace(0.0, ax["size"] - 1.0, ax["size"]))
        query.append((g(np.clip(x, lo, hi)) - g(lo)) / (g(hi) - g(lo)) * (ax["size"] - 1))
    mesh = np.meshgrid(*query, indexing="ij")
    interp = RegularGridInterpolator(grid, values, method=interpolation)
    return interp(np.stack([m.ravel() for m in mesh], axis=-1)).reshape(mesh[0].shape)
