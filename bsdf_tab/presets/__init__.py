"""Engine presets: tables in the exact layout and value convention that peers ship.

A *preset* names a table that a renderer ships (Blender Cycles' ``ggx_E``, Filament's DFG,
Unity HDRP's FGD, Adobe OpenPBR's energy-complement tables) and says, as data
(:mod:`.engines`, in the form of :mod:`.recipe`), how it follows from one plain bsdf-tab
table: which spec to tabulate (the peer's axes as explicit value lists, so any peer axis can be
reproduced, including Cycles' IOR axis through z and OpenPBR's IOR axis with 1.0 twice), which
sums or complements give the peer's channels (Cycles glass E = R + T, OpenPBR 1 - E, Filament
multiscatter (B, E)), the axis order (Cycles glass [ior, mu, roughness], OpenPBR [ior,
roughness, cos], textures [roughness, u]) and the peer's rules (Cycles' mirror rule, the clamp
to [0, 1]). Error channels follow the transformations.

:func:`build_preset` computes one (optionally on a subset of the axes: ``select={"mu": [0, 5]}``)
through :func:`bsdf_tab.tabulate`; :func:`preset_names` / :func:`get_preset` browse; group names
(``cycles``, ``openpbr``, ``filament``, ``unity``) expand to their members. Files are written by
:mod:`bsdf_tab.io`. :func:`default_specs` is the default set of ``bsdf-tab bake``.
"""

from .axes import cycles_axis, cycles_ior_axis, cycles_z_axis, openpbr_ior_axis
from .build import (
    CYCLES_MIRROR_ALPHA2,
    PresetJob,
    build_preset,
    describe,
    expand_preset,
    get_preset,
    prepare_preset,
    preset_names,
)
from .default_set import default_specs
from .engines import GROUPS, PRESETS
from .recipe import Output, Preset

__all__ = [
    "CYCLES_MIRROR_ALPHA2",
    "GROUPS",
    "Output",
    "PRESETS",
    "Preset",
    "PresetJob",
    "build_preset",
    "cycles_axis",
    "cycles_ior_axis",
    "cycles_z_axis",
    "default_specs",
    "describe",
    "expand_preset",
    "get_preset",
    "openpbr_ior_axis",
    "prepare_preset",
    "preset_names",
]
