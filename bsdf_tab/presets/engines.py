"""The registry of engine presets: one module per engine, each with its ``PRESET_LIST``.

Each entry says, as data (:mod:`.recipe`), which spec the peer's table follows from and how;
its conventions text records what is reproduced and what is not, from the engine's public
sources (cited in each module and in docs/presets.md). Adding an engine: a module here and its
name in :data:`_ENGINES`; a group of the same name lists its presets.
"""

from __future__ import annotations

from . import bevy, cycles, eevee, filament, gltf, godot, ltc, openpbr, sheen, threejs, unity, unreal
from .recipe import Preset

__all__ = ["GROUPS", "PRESETS"]

_ENGINES = {
    "cycles": cycles,
    "openpbr": openpbr,
    "filament": filament,
    "unity": unity,
    "eevee": eevee,
    "gltf": gltf,
    "godot": godot,
    "bevy": bevy,
    "threejs": threejs,
    "unreal": unreal,
    "heitz": ltc,
    "sheen": sheen,
}

#: Preset name -> :class:`~.recipe.Preset`, engine by engine.
PRESETS: dict[str, Preset] = {p.name: p for module in _ENGINES.values() for p in module.PRESET_LIST}
#: Group name (the engine) -> member preset names.
GROUPS: dict[str, list[str]] = {name: [p.name for p in module.PRESET_LIST] for name, module in _ENGINES.items()}
