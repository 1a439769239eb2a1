"""Engine presets: tables in the exact layout and value convention that peers ship.

A *preset* names a table that a renderer ships (Blender Cycles' ``ggx_E``, Filament's DFG,
Unity HDRP's FGD, Adobe OpenPBR's energy-complement tables) and says how to build it from
plain bsdf-tab tables: which specs to tabulate (axes given as explicit value lists, so any
peer axis can be reproduced, including Cycles' IOR axis through z and OpenPBR's IOR axis with
1.0 twice), and the post-processing that turns them into the peer's array: sums
(Cycles glass E = R + T), complements (OpenPBR 1 - E), channel packing (Filament multiscatter
(B, E)), axis order (Cycles glass [ior, mu, roughness], OpenPBR [ior, roughness, cos],
textures [roughness, u]) and clamps. Error channels follow the transformations (absolute
errors add; a clamp or the Cycles mirror rule adds what it changed).

The resulting :class:`~bsdf_tab.table.Table` has the peer's axes (named ``ior``, ``mu``,
``roughness``, ``cos``), one value channel per peer channel plus its ``<X>_err`` channel, and
``meta["preset"]`` recording exactly which conventions were reproduced (and which were not).

Use :func:`build_preset` (optionally on a subset of the axes: ``select={"mu": [0, 5]}``),
:func:`preset_names` / :func:`get_preset` to browse, and :func:`bake_preset` to write files.
Group names (``cycles``, ``openpbr``, ``filament``, ``unity``) expand to their members.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from .spec import AXIS_DOMAINS, normalize_spec
from .table import Table

__all__ = [
    "Preset",
    "PRESETS",
    "GROUPS",
    "preset_names",
    "get_preset",
    "expand_preset",
    "build_preset",
    "bake_preset",
    "cycles_axis",
    "cycles_ior_axis",
    "openpbr_ior_axis",
    "describe",
    "write_table",
    "FORMATS",
]

CYCLES_MIRROR_ALPHA2 = 5e-7  # Cycles: alpha_x * alpha_y <= 5e-7 is a perfect mirror (E = 1)


# --------------------------------------------------------------------------- peer axes


def cycles_axis(n: int) -> np.ndarray:
    """Cycles' mu and roughness axes: ``clamp(i / (n - 1), 1e-4, 1)``."""
    return np.clip(np.arange(n) / (n - 1), 1e-4, 1.0)


def cycles_z_axis(n: int = 16) -> np.ndarray:
    """Cycles' glass z axis: ``clamp(k / (n - 1), 1e-4, 0.99)`` (F0 = z^4)."""
    return np.clip(np.arange(n) / (n - 1), 1e-4, 0.99)


def cycles_ior_axis(n: int = 16) -> np.ndarray:
    """Cycles' glass IOR axis from z: ``ior = (1 + z^2) / (1 - z^2)`` (1.00000002 .. 99.5)."""
    z2 = cycles_z_axis(n) ** 2
    return (1.0 + z2) / (1.0 - z2)


def openpbr_ior_axis() -> np.ndarray:
    """OpenPBR's 32 IORs: index i < 16: ``1/ior = 1 + 1.5 (15 - i)/15``; i >= 16: ``ior = 1 + 1.5 (i - 16)/15``.

    0.4 .. 1 then 1 .. 2.5: the value 1.0 appears twice (indices 15 and 16).
    """
    return np.array([1.0 / (1.0 + 1.5 * (15 - i) / 15.0) if i < 16 else 1.0 + 1.5 * (i - 16) / 15.0 for i in range(32)])


def _unit_endpoints(n: int) -> np.ndarray:
    return np.arange(n) / (n - 1)


def _unit_centers(n: int) -> np.ndarray:
    return (np.arange(n) + 0.5) / n


# --------------------------------------------------------------------------- computing


def _api_tabulate():
    # looked up at call time through sys.modules, so a replaced bsdf_tab.api is honoured
    return importlib.import_module("bsdf_tab.api").tabulate


@dataclass
class _Runner:
    """Tabulates specs whose axes may be unsorted, repeated, or (eta) beyond the spec domain."""

    tabulate: Callable | None = None
    device: str | None = None
    workers: int | None = None
    progress: Callable[[int, int], None] | None = None
    specs: list = field(default_factory=list)
    source_meta: list = field(default_factory=list)
    notes: list = field(default_factory=list)

    def __call__(self, spec: dict) -> dict[str, np.ndarray]:
        """Channels of ``spec`` on exactly its (explicit) axis values, in the spec's axis order."""
        names = list(spec["axes"])
        uniq, inverse = {}, {}
        for name in names:
            values = np.asarray(spec["axes"][name], dtype=np.float64)
            uniq[name], inverse[name] = np.unique(values, return_inverse=True)
        channels = self._eta_split(spec, uniq)
        index = np.ix_(*[inverse[n] for n in names])
        return {k: np.asarray(v, dtype=np.float64)[index] for k, v in channels.items()}

    def _eta_split(self, spec: dict, axes: dict) -> dict[str, np.ndarray]:
        eta_hi = AXIS_DOMAINS["eta"][1]
        if "eta" not in axes or axes["eta"].max() <= eta_hi:
            return self._tabulate(spec, axes)
        # eta beyond the spec domain (Cycles' last IOR, 99.5): those slices go to the same
        # table computation directly, the others through tabulate()
        eta = axes["eta"]
        inside, outside = eta[eta <= eta_hi], eta[eta > eta_hi]
        parts = []
        if inside.size:
            parts.append(self._tabulate(spec, {**axes, "eta": inside}))
        parts.append(self._direct(spec, {**axes, "eta": outside}))
        self.notes.append(
            f"eta {', '.join(f'{x:.6g}' for x in outside)} is beyond the spec domain (eta <= {eta_hi:g}); "
            "computed by the same table code (bsdf_tab.tables) without spec validation"
        )
        k = list(axes).index("eta")
        return {c: np.concatenate([p[c] for p in parts], axis=k) for c in parts[0]}

    def _tabulate(self, spec: dict, axes: dict) -> dict[str, np.ndarray]:
        full = {**spec, "axes": {n: [float(x) for x in v] for n, v in axes.items()}}
        tabulate = self.tabulate or _api_tabulate()
        table = tabulate(full, device=self.device, workers=self.workers, progress=self._progress())
        self.specs.append(normalize_spec(full))
        self.source_meta.append({k: table.meta.get(k) for k in ("method", "version", "max_error")})
        return table.channels

    def _direct(self, spec: dict, axes: dict) -> dict[str, np.ndarray]:
        from .integrate.parallel import resolve_device
        from .tables import COMPUTE, Context

        eta_hi = AXIS_DOMAINS["eta"][1]
        placeholder = {**spec, "axes": {n: ([eta_hi] if n == "eta" else [float(x) for x in v]) for n, v in axes.items()}}
        nspec = normalize_spec(placeholder)
        nspec["axes"]["eta"] = {"values": [float(x) for x in axes["eta"]]}
        ctx = Context(resolve_device(self.device), self.workers, self.progress if callable(self.progress) else None)
        channels = COMPUTE[nspec["table"]](nspec, dict(axes), ctx)
        self.specs.append(nspec)
        return channels

    def _progress(self):
        return self.progress if callable(self.progress) else bool(self.progress)


# --------------------------------------------------------------------------- presets


@dataclass(frozen=True)
class Preset:
    """One peer table.

    Attributes
    ----------
    name : str
        Registry name (``cycles-ggx-E``).
    peer : str
        The engine and the table's name there.
    description : str
        One line.
    axes : callable
        ``axes() -> dict`` of the full output axes, in the peer's order (name -> values).
    compute : callable
        ``compute(axes, run) -> dict`` of output channels (values and ``_err``) on ``axes``;
        ``run(spec) -> channels`` tabulates one spec with explicit axis lists.
    conventions : dict
        What is reproduced (recorded in ``meta["preset"]``).
    anchor : str or None
        ``<folder>/<file>.npy`` of the peer's own table in the anchors folder, if shipped there.
    anchor_axes : dict
        Output axis name -> anchor axis file, for checking axes against the peer's.
    """

    name: str
    peer: str
    description: str
    axes: Callable[[], dict]
    compute: Callable[[dict, Callable], dict]
    conventions: dict
    anchor: str | None = None
    anchor_axes: dict = field(default_factory=dict)

    @property
    def shape(self) -> tuple[int, ...]:
        return tuple(len(v) for v in self.axes().values())


def _ggx(shadowing: str) -> dict:
    return {"distribution": "ggx", "shadowing": shadowing}


def _mirror_rule(values: np.ndarray, errors: np.ndarray, alpha: np.ndarray, axis: int, ndim: int):
    """Cycles' rule: alpha^2 <= 5e-7 is a perfect mirror, E = 1 (error grows by the change)."""
    shape = [1] * ndim
    shape[axis] = alpha.size
    mirror = (alpha**2 <= CYCLES_MIRROR_ALPHA2).reshape(shape)
    new = np.where(mirror, 1.0, values)
    return new, errors + np.abs(new - values)


def _clamp01(values: np.ndarray, errors: np.ndarray):
    new = np.clip(values, 0.0, 1.0)
    return new, errors + np.abs(new - values)


_CYCLES_COMMON = {
    "distribution": "GGX, isotropic",
    "shadowing": "height-correlated G2 = 1 / (1 + Lambda_i + Lambda_o)",
    "axes": "mu_j = clamp(j/(n-1), 1e-4, 1) (linear in cos theta_i); roughness r_i = clamp(i/(n-1), 1e-4, 1), "
    "alpha = r^2; lookup node i at coordinate i/(n-1)",
    "mirror_rule": "alpha^2 <= 5e-7 is a perfect mirror: E = 1 (roughness node 0)",
    "clamp": "values clamped to [0, 1]",
    "not_reproduced": "Cycles prints 6 decimals and integrates by Monte Carlo (VNDF, Sobol); ours are "
    "float64 quadrature values with error estimates",
}


def _cycles_E(axes: dict, run: Callable) -> dict:
    mu, rough = axes["mu"], axes["roughness"]
    ch = run({"table": "albedo", **_ggx("correlated"), "fresnel": {"type": "one"},
              "axes": {"mu": mu, "roughness": rough}})
    e, err = _mirror_rule(ch["E"], ch["E_err"], rough**2, 1, 2)
    e, err = _clamp01(e, err)
    return {"E": e, "E_err": err}


def _cycles_Eavg(axes: dict, run: Callable) -> dict:
    rough = axes["roughness"]
    ch = run({"table": "albedo_avg", **_ggx("correlated"), "fresnel": {"type": "one"}, "axes": {"roughness": rough}})
    e, err = _mirror_rule(ch["E_avg"], ch["E_avg_err"], rough**2, 0, 1)
    e, err = _clamp01(e, err)
    return {"E_avg": e, "E_avg_err": err}


def _cycles_glass(inverse: bool) -> Callable:
    def compute(axes: dict, run: Callable) -> dict:
        ior, mu, rough = axes["ior"], axes["mu"], axes["roughness"]
        eta = 1.0 / ior if inverse else ior
        ch = run({"table": "dielectric", **_ggx("correlated"), "fresnel": {"type": "dielectric"},
                  "axes": {"mu": mu, "roughness": rough, "eta": eta}})
        # (mu, rough, eta) -> (ior, mu, rough)
        e = np.transpose(ch["R"] + ch["T"], (2, 0, 1))
        err = np.transpose(ch["R_err"] + ch["T_err"], (2, 0, 1))
        e, err = _mirror_rule(e, err, rough**2, 2, 3)
        e, err = _clamp01(e, err)
        return {"E": e, "E_err": err}

    return compute


def _cycles_glass_avg(inverse: bool) -> Callable:
    def compute(axes: dict, run: Callable) -> dict:
        ior, rough = axes["ior"], axes["roughness"]
        eta = 1.0 / ior if inverse else ior
        ch = run({"table": "dielectric_avg", **_ggx("correlated"), "fresnel": {"type": "dielectric"},
                  "axes": {"roughness": rough, "eta": eta}})
        e = (ch["R_avg"] + ch["T_avg"]).T  # (rough, eta) -> (ior, rough)
        err = (ch["R_avg_err"] + ch["T_avg_err"]).T
        e, err = _mirror_rule(e, err, rough**2, 1, 2)
        e, err = _clamp01(e, err)
        return {"E_avg": e, "E_avg_err": err}

    return compute


def _glass_conventions(inverse: bool, avg: bool) -> dict:
    return {
        **_CYCLES_COMMON,
        "value": ("2 int_0^1 (R + T)(mu) mu dmu" if avg else "E = R + T")
        + ": dielectric, exact unpolarized Fresnel, transmission in the energy form (R + T -> 1 as alpha -> 0)",
        "eta": "eta = 1 / ior < 1 (light from inside)" if inverse else "eta = ior > 1 (light from outside)",
        "ior_axis": "z_k = clamp(k/15, 1e-4, 0.99), F0 = z^4, ior = (1 + z^2) / (1 - z^2); node k at coordinate k/15",
        "layout": "[ior, roughness]" if avg else "[ior, mu, roughness]",
    }


def _openpbr_metal(axes: dict, run: Callable) -> dict:
    rough, cos = axes["roughness"], axes["cos"]
    ch = run({"table": "albedo", **_ggx("separable"), "fresnel": {"type": "one"}, "axes": {"mu": cos, "roughness": rough}})
    return {"energy_complement": 1.0 - ch["E"].T, "energy_complement_err": ch["E_err"].T}


def _openpbr_metal_avg(axes: dict, run: Callable) -> dict:
    ch = run({"table": "albedo_avg", **_ggx("separable"), "fresnel": {"type": "one"},
              "axes": {"roughness": axes["roughness"]}})
    return {"energy_complement": 1.0 - ch["E_avg"], "energy_complement_err": ch["E_avg_err"]}


def _openpbr_dielectric(opaque: bool) -> Callable:
    def compute(axes: dict, run: Callable) -> dict:
        ior, rough, cos = axes["ior"], axes["roughness"], axes["cos"]
        ch = run({"table": "dielectric", **_ggx("separable"), "fresnel": {"type": "dielectric"},
                  "axes": {"mu": cos, "roughness": rough, "eta": ior}})
        e = ch["R"] if opaque else ch["R"] + ch["T"]
        err = ch["R_err"] if opaque else ch["R_err"] + ch["T_err"]
        # (cos, rough, ior) -> (ior, rough, cos)
        return {"energy_complement": 1.0 - np.transpose(e, (2, 1, 0)),
                "energy_complement_err": np.transpose(err, (2, 1, 0))}

    return compute


def _openpbr_dielectric_avg(opaque: bool) -> Callable:
    def compute(axes: dict, run: Callable) -> dict:
        ior, rough = axes["ior"], axes["roughness"]
        ch = run({"table": "dielectric_avg", **_ggx("separable"), "fresnel": {"type": "dielectric"},
                  "axes": {"roughness": rough, "eta": ior}})
        e = ch["R_avg"] if opaque else ch["R_avg"] + ch["T_avg"]
        err = ch["R_avg_err"] if opaque else ch["R_avg_err"] + ch["T_avg_err"]
        return {"energy_complement": 1.0 - e.T, "energy_complement_err": err.T}  # (rough, ior) -> (ior, rough)

    return compute


_OPENPBR_COMMON = {
    "distribution": "GGX, isotropic",
    "shadowing": "separable G = G1(i) G1(o) (OpenPBR's runtime shadowing)",
    "value": "energy complement 1 - E",
    "axes": "roughness r_i = i/31 (alpha = r^2), cos_j = j/31, node i at coordinate i/31",
    "not_reproduced": "OpenPBR stores uint16 UNORM (x 65535); ours are floats. Its generator is not public; "
    "it treats roughness 0 and cos 0 specially (0 there), ours are the quadrature values",
}


def _openpbr_dielectric_conventions(opaque: bool, avg: bool) -> dict:
    what = "R (reflection only)" if opaque else "R + T (transmission in the energy form)"
    return {
        **_OPENPBR_COMMON,
        "value": f"energy complement 1 - {'2 int_0^1 ' if avg else ''}{what}{' mu dmu' if avg else ''}"
        ", exact unpolarized dielectric Fresnel",
        "eta": "eta = ior (ior < 1: light from inside); ior_i for i < 16: 1/ior = 1 + 1.5 (15 - i)/15, "
        "i >= 16: ior = 1 + 1.5 (i - 16)/15 (1.0 twice)",
        "layout": "[ior, roughness]" if avg else "[ior, roughness, cos]",
    }


def _dfg_rows(axes: dict, run: Callable) -> dict:
    rough, mu = axes["roughness"], axes["mu"]
    ch = run({"table": "dfg", **_ggx("correlated"), "axes": {"mu": mu, "roughness": rough}})
    return {k: v.T for k, v in ch.items()}  # (mu, rough) -> (rough, mu): rows = roughness


def _filament_dfg(axes: dict, run: Callable) -> dict:
    ch = _dfg_rows(axes, run)
    return {"A": ch["A"], "B": ch["B"], "A_err": ch["A_err"], "B_err": ch["B_err"]}


def _filament_dfg_ms(axes: dict, run: Callable) -> dict:
    ch = _dfg_rows(axes, run)
    return {"B": ch["B"], "E": ch["A"] + ch["B"], "B_err": ch["B_err"], "E_err": ch["A_err"] + ch["B_err"]}


_FILAMENT_COMMON = {
    "distribution": "GGX, isotropic",
    "shadowing": "height-correlated (Filament's V_SmithGGXCorrelated)",
    "axes": "mu = NoV_i = (i + 0.5)/128, perceptual roughness r_j = (j + 0.5)/128 (texel centres), alpha = r^2",
    "layout": "[roughness, mu]: row j = roughness (texture v), column i = NoV (texture u); row 0 = v lowest",
    "not_reproduced": "Filament samples 1024 Hammersley points with NDF sampling and stores RGB16F; the third "
    "(cloth / Charlie) channel is not computed",
}

_PRESET_LIST = [
    Preset(
        "cycles-ggx-E", "Blender Cycles ggx_E", "GGX directional albedo, F = 1, 32 x 32 [mu, roughness]",
        lambda: {"mu": cycles_axis(32), "roughness": cycles_axis(32)}, _cycles_E,
        {**_CYCLES_COMMON, "value": "directional albedo E, F = 1", "layout": "[mu, roughness]"},
        "blender_cycles/ggx_E.npy", {"mu": "blender_cycles/axis_mu32.npy", "roughness": "blender_cycles/axis_rough32.npy"},
    ),
    Preset(
        "cycles-ggx-Eavg", "Blender Cycles ggx_Eavg", "GGX average albedo, F = 1, 32 [roughness]",
        lambda: {"roughness": cycles_axis(32)}, _cycles_Eavg,
        {**_CYCLES_COMMON, "value": "E_avg = 2 int_0^1 E(mu) mu dmu, F = 1", "layout": "[roughness]"},
        "blender_cycles/ggx_Eavg.npy", {"roughness": "blender_cycles/axis_rough32.npy"},
    ),
    Preset(
        "cycles-ggx-glass-E", "Blender Cycles ggx_glass_E", "GGX glass R + T, eta = ior > 1, 16^3 [ior, mu, roughness]",
        lambda: {"ior": cycles_ior_axis(16), "mu": cycles_axis(16), "roughness": cycles_axis(16)},
        _cycles_glass(False), _glass_conventions(False, False), "blender_cycles/ggx_glass_E.npy",
        {"ior": "blender_cycles/axis_ior16.npy", "mu": "blender_cycles/axis_mu16.npy", "roughness": "blender_cycles/axis_rough16.npy"},
    ),
    Preset(
        "cycles-ggx-glass-inv-E", "Blender Cycles ggx_glass_inv_E",
        "GGX glass R + T, eta = 1/ior < 1, 16^3 [ior, mu, roughness]",
        lambda: {"ior": cycles_ior_axis(16), "mu": cycles_axis(16), "roughness": cycles_axis(16)},
        _cycles_glass(True), _glass_conventions(True, False), "blender_cycles/ggx_glass_inv_E.npy",
        {"ior": "blender_cycles/axis_ior16.npy", "mu": "blender_cycles/axis_mu16.npy", "roughness": "blender_cycles/axis_rough16.npy"},
    ),
    Preset(
        "cycles-ggx-glass-Eavg", "Blender Cycles ggx_glass_Eavg", "GGX glass average R + T, eta = ior > 1, 16^2 [ior, roughness]",
        lambda: {"ior": cycles_ior_axis(16), "roughness": cycles_axis(16)},
        _cycles_glass_avg(False), _glass_conventions(False, True), "blender_cycles/ggx_glass_Eavg.npy",
        {"ior": "blender_cycles/axis_ior16.npy", "roughness": "blender_cycles/axis_rough16.npy"},
    ),
    Preset(
        "cycles-ggx-glass-inv-Eavg", "Blender Cycles ggx_glass_inv_Eavg",
        "GGX glass average R + T, eta = 1/ior < 1, 16^2 [ior, roughness]",
        lambda: {"ior": cycles_ior_axis(16), "roughness": cycles_axis(16)},
        _cycles_glass_avg(True), _glass_conventions(True, True), "blender_cycles/ggx_glass_inv_Eavg.npy",
        {"ior": "blender_cycles/axis_ior16.npy", "roughness": "blender_cycles/axis_rough16.npy"},
    ),
    Preset(
        "openpbr-ideal-metal", "Adobe OpenPBR ideal_metal_energy_complement",
        "GGX 1 - E, F = 1, separable, 32 x 32 [roughness, cos]",
        lambda: {"roughness": _unit_endpoints(32), "cos": _unit_endpoints(32)}, _openpbr_metal,
        {**_OPENPBR_COMMON, "value": "energy complement 1 - E, F = 1", "layout": "[roughness, cos]"},
        "adobe_openpbr_bsdf/ideal_metal_energy_complement.npy",
        {"roughness": "adobe_openpbr_bsdf/axis_rough32.npy", "cos": "adobe_openpbr_bsdf/axis_cos32.npy"},
    ),
    Preset(
        "openpbr-ideal-metal-avg", "Adobe OpenPBR ideal_metal_avg_energy_complement",
        "GGX 1 - E_avg, F = 1, separable, 32 [roughness]",
        lambda: {"roughness": _unit_endpoints(32)}, _openpbr_metal_avg,
        {**_OPENPBR_COMMON, "value": "energy complement 1 - E_avg, F = 1", "layout": "[roughness]"},
        "adobe_openpbr_bsdf/ideal_metal_avg_energy_complement.npy", {"roughness": "adobe_openpbr_bsdf/axis_rough32.npy"},
    ),
    Preset(
        "openpbr-ideal-dielectric", "Adobe OpenPBR ideal_dielectric_energy_complement",
        "GGX glass 1 - (R + T), separable, 32^3 [ior, roughness, cos]",
        lambda: {"ior": openpbr_ior_axis(), "roughness": _unit_endpoints(32), "cos": _unit_endpoints(32)},
        _openpbr_dielectric(False), _openpbr_dielectric_conventions(False, False),
        "adobe_openpbr_bsdf/ideal_dielectric_energy_complement.npy",
        {"ior": "adobe_openpbr_bsdf/axis_ior32.npy", "roughness": "adobe_openpbr_bsdf/axis_rough32.npy",
         "cos": "adobe_openpbr_bsdf/axis_cos32.npy"},
    ),
    Preset(
        "openpbr-ideal-dielectric-avg", "Adobe OpenPBR ideal_dielectric_avg_energy_complement",
        "GGX glass 1 - (R_avg + T_avg), separable, 32^2 [ior, roughness]",
        lambda: {"ior": openpbr_ior_axis(), "roughness": _unit_endpoints(32)},
        _openpbr_dielectric_avg(False), _openpbr_dielectric_conventions(False, True),
        "adobe_openpbr_bsdf/ideal_dielectric_avg_energy_complement.npy",
        {"ior": "adobe_openpbr_bsdf/axis_ior32.npy", "roughness": "adobe_openpbr_bsdf/axis_rough32.npy"},
    ),
    Preset(
        "openpbr-opaque-dielectric", "Adobe OpenPBR opaque_dielectric_energy_complement",
        "GGX dielectric reflection 1 - R, separable, 32^3 [ior, roughness, cos]",
        lambda: {"ior": openpbr_ior_axis(), "roughness": _unit_endpoints(32), "cos": _unit_endpoints(32)},
        _openpbr_dielectric(True), _openpbr_dielectric_conventions(True, False),
        "adobe_openpbr_bsdf/opaque_dielectric_energy_complement.npy",
        {"ior": "adobe_openpbr_bsdf/axis_ior32.npy", "roughness": "adobe_openpbr_bsdf/axis_rough32.npy",
         "cos": "adobe_openpbr_bsdf/axis_cos32.npy"},
    ),
    Preset(
        "openpbr-opaque-dielectric-avg", "Adobe OpenPBR opaque_dielectric_avg_energy_complement",
        "GGX dielectric reflection 1 - R_avg, separable, 32^2 [ior, roughness]",
        lambda: {"ior": openpbr_ior_axis(), "roughness": _unit_endpoints(32)},
        _openpbr_dielectric_avg(True), _openpbr_dielectric_conventions(True, True),
        "adobe_openpbr_bsdf/opaque_dielectric_avg_energy_complement.npy",
        {"ior": "adobe_openpbr_bsdf/axis_ior32.npy", "roughness": "adobe_openpbr_bsdf/axis_rough32.npy"},
    ),
    Preset(
        "filament-dfg", "Filament DFG (single scattering)",
        "split-sum (A, B), E = f0 A + B, 128 x 128 [roughness, NoV] at texel centres",
        lambda: {"roughness": _unit_centers(128), "mu": _unit_centers(128)}, _filament_dfg,
        {**_FILAMENT_COMMON,
         "value": "(A, B) = (int (f/F)(1 - (1 - v.h)^5) cos, int (f/F)(1 - v.h)^5 cos): texture (x, y) = (A, B), "
         "specular = f0 x + y"},
    ),
    Preset(
        "filament-dfg-multiscatter", "Filament DFG (multiscatter variant)",
        "(B, E) with E = A + B (F = 1), 128 x 128 [roughness, NoV] at texel centres",
        lambda: {"roughness": _unit_centers(128), "mu": _unit_centers(128)}, _filament_dfg_ms,
        {**_FILAMENT_COMMON,
         "value": "texture (x, y) = (B, E): x = int (f/F)(1 - v.h)^5 cos (the Schlick-weighted 'scale' term), "
         "y = E = int (f/F) cos (F = 1) = A + B; specular = mix(x, y, f0), energy compensation 1 + f0 (1/y - 1)"},
    ),
    Preset(
        "unity-hdrp-fgd", "Unity HDRP pre-integrated FGD (GGX part)",
        "(B, E), 64 x 64 [roughness, NdotV] with sqrt(NdotV) = i/63, endpoints on texel centres",
        lambda: {"roughness": _unit_endpoints(64), "mu": _unit_endpoints(64) ** 2}, _filament_dfg_ms,
        {"distribution": "GGX, isotropic", "shadowing": "height-correlated",
         "axes": "texture u = sqrt(NdotV) = i/63 (mu = u^2), v = perceptual roughness r_j = j/63 (alpha = r^2); "
         "endpoints on texel centres (lookup coordinate remapped by half a texel)",
         "value": "texture (x, y) = (B, E): specularFGD = lerp(x, y, f0), reflectivity = y",
         "layout": "[roughness, mu]: row j = perceptual roughness (texture v), column i = sqrt(NdotV) (texture u)",
         "not_reproduced": "HDRP samples 4096 Hammersley points with NDF sampling and stores 10-bit UNORM; "
         "the z channel (Disney diffuse FGD - 0.5) is not computed"},
    ),
]

#: Preset name -> :class:`Preset`.
PRESETS: dict[str, Preset] = {p.name: p for p in _PRESET_LIST}
#: Group name -> member preset names.
GROUPS: dict[str, list[str]] = {
    "cycles": [n for n in PRESETS if n.startswith("cycles-")],
    "openpbr": [n for n in PRESETS if n.startswith("openpbr-")],
    "filament": ["filament-dfg", "filament-dfg-multiscatter"],
    "unity": ["unity-hdrp-fgd"],
}


def preset_names() -> list[str]:
    """Names of all presets, in registry order."""
    return list(PRESETS)


def get_preset(name: str) -> Preset:
    """The preset ``name``; ValueError (one line, with the choices) if unknown."""
    if name not in PRESETS:
        raise ValueError(
            f"unknown preset {name!r}; choose one of: {', '.join(PRESETS)} (or a group: {', '.join(GROUPS)})"
        )
    return PRESETS[name]


def expand_preset(name: str) -> list[str]:
    """A preset or group name -> the preset names it stands for."""
    if name in GROUPS:
        return list(GROUPS[name])
    return [get_preset(name).name]


def _select(axes: dict, select: dict | None) -> dict:
    if not select:
        return dict(axes)
    unknown = set(select) - set(axes)
    if unknown:
        raise ValueError(f"select: unknown axis {sorted(unknown)[0]!r}; axes are {', '.join(axes)}")
    return {n: (v[np.asarray(select[n], dtype=int)] if n in select else v) for n, v in axes.items()}


def build_preset(
    name: str,
    *,
    select: dict | None = None,
    device: str | None = None,
    workers: int | None = None,
    progress: bool | Callable[[int, int], None] = False,
    tabulate: Callable | None = None,
) -> Table:
    """Compute the preset ``name`` in its peer's layout.

    Parameters
    ----------
    name : str
        A preset name (see :func:`preset_names`).
    select : dict, optional
        Output axis name -> indices into the full peer axis: compute only that subset
        (the values are the peer's; used by tests and quick looks).
    device, workers, progress :
        Passed to :func:`bsdf_tab.tabulate`.
    tabulate : callable, optional
        Replacement for :func:`bsdf_tab.tabulate` (default: looked up at call time).

    Returns
    -------
    Table
        Axes in the peer's order, the peer's channels plus ``_err`` channels, and
        ``meta["preset"]`` with the conventions, the source specs and notes.
    """
    preset = get_preset(name)
    axes = _select(preset.axes(), select)
    run = _Runner(tabulate, device, workers, progress)
    channels = preset.compute(axes, run)
    table = Table(axes, channels, {})
    library = run.source_meta[0] if run.source_meta else {}
    table.meta = {
        "table": preset.name,
        "spec": {"table": f"preset:{preset.name}", "preset": preset.name, "sources": run.specs},
        "preset": {
            "name": preset.name,
            "peer": preset.peer,
            "description": preset.description,
            "conventions": preset.conventions,
            "axis_order": list(axes),
            "full_shape": list(preset.shape),
            "subset": {k: [int(i) for i in v] for k, v in (select or {}).items()},
            "notes": run.notes,
        },
        "conventions": preset.conventions,
        "method": library.get("method"),
        "max_error": table.max_error(),
        "version": library.get("version"),
    }
    return table


# --------------------------------------------------------------------------- writing

FORMATS = {"exr": ".exr", "half-exr": ".half.exr", "npy": "", "h": ".h"}


def write_table(table: Table, out_dir: Path, stem: str, fmt: str) -> list[Path]:
    """Write ``table`` as ``fmt`` (exr, half-exr, npy, h) into ``out_dir``; returns the paths written."""
    from . import export

    out_dir = Path(out_dir)
    if fmt == "exr":
        path = out_dir / f"{stem}.exr"
        table.write_exr(path)
        return [path]
    if fmt == "half-exr":
        path = out_dir / f"{stem}.half.exr"
        export.write_half_exr(table, path)
        return [path]
    if fmt == "npy":
        return export.write_npy(table, out_dir, stem)
    if fmt == "h":
        path = out_dir / f"{stem}.h"
        export.write_header(table, path, name=stem)
        return [path]
    raise ValueError(f"unknown format {fmt!r}; choose one of: {', '.join(FORMATS)}")


def bake_preset(
    name: str,
    out_dir,
    fmt: str = "exr",
    *,
    device: str | None = None,
    workers: int | None = None,
    progress: bool | Callable[[int, int], None] = False,
    tabulate: Callable | None = None,
) -> list[tuple[Path, Table]]:
    """Build a preset (or every member of a group) and write it to ``out_dir`` as ``fmt``.

    Returns a list of (path, table), one per file written (npy writes several files per table;
    the first is listed).
    """
    names = expand_preset(name)
    if fmt not in FORMATS:
        raise ValueError(f"unknown format {fmt!r}; choose one of: {', '.join(FORMATS)}")
    out_dir = Path(out_dir)
    if out_dir.exists() and not out_dir.is_dir():
        raise ValueError(f"output {out_dir} exists and is not a folder")
    out_dir.mkdir(parents=True, exist_ok=True)
    written = []
    for member in names:
        table = build_preset(member, device=device, workers=workers, progress=progress, tabulate=tabulate)
        paths = write_table(table, out_dir, member.replace("-", "_"), fmt)
        written.append((paths[0], table))
    return written


def describe(preset: Preset) -> str:
    """One line: name, shape and description."""
    shape = " x ".join(f"{n} {len(v)}" for n, v in preset.axes().items())
    return f"{preset.name:<31} {shape:<30} {preset.description}"
