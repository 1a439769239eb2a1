"""Lookup code generated with a table, and the Python reference lookup it must agree with.

``docs/lookup-code.md`` describes the generated functions::

    from bsdf_tab.lookup import emit_files, lookup
    emit_files(table, "luts/dfg.exr", ["glsl", "c"])     # luts/dfg.lookup.glsl, luts/dfg.lookup.h
    # a .ktx2 / .dds file: the code samples the 1-D / 2-D / 3-D texture the file holds
    lookup(table, nov, roughness)                       # {"A": ..., "B": ...}: the same lookup in numpy

Modules: :mod:`.axes` (how each axis was baked: spacing, nodes, range, clamp; the reference
lookup through :func:`bsdf_tab.scene.lookup`), :mod:`.dialects` (GLSL, HLSL, WGSL, C, Warp),
:mod:`.emit` (the generator and :func:`emit_files`).
"""

from __future__ import annotations

from .axes import PARAM_NAMES, AxisMap, LookupPlan, fit_axis, lookup, lookup_plan
from .emit import LANGS, LAYOUTS, emit_files, emit_source, file_prefix, output_paths, texture_layout

__all__ = ["AxisMap", "LANGS", "LAYOUTS", "LookupPlan", "PARAM_NAMES", "emit_files", "emit_source", "file_prefix",
           "fit_axis", "lookup", "lookup_plan", "output_paths", "texture_layout"]
