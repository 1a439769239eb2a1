"""Scenes: plan and bake the minimal set of tables a scene needs, at the lookup error it asks for.

``docs/scenes.md`` describes the scene format, the planner and the manifest::

    from bsdf_tab.scene import plan_scene, bake_scene
    plan = plan_scene(scene_dict, 1e-3)     # tables computed (bsdf_tab.api.tabulate) and checked
    print(plan.text()); bake_scene(plan, "luts/")

Modules: :mod:`.parse` (scene files, validation through :mod:`bsdf_tab.spec`), :mod:`.plan`
(the plan types and ``plan_scene``), :mod:`.search` (the search for the smallest table and its
checks), :mod:`.bounds` (failure certificates: candidates known to fail from points already
checked), :mod:`.texels` (every texel of a planning run computed once), :mod:`.lookup` (how a
renderer reads a planned table),
:mod:`.manifest` (``manifest.json`` and the bake). The command line (``bsdf-tab plan``,
``bsdf-tab bake SCENE``) lives in :mod:`bsdf_tab.cli.plan`, ``POST /scenes`` in the service.
"""

from __future__ import annotations

from .lookup import AxisPlan, lookup
from .manifest import bake_scene
from .parse import (
    INTERPOLATIONS,
    LOOKUP_TOL_RANGE,
    MATERIAL_TABLES,
    check_lookup_tol,
    is_scene,
    load_scene_file,
    parse_scene,
)
from .plan import FIXED_SIZES, PLAN_MARGIN, ScenePlan, TablePlan, plan_scene

__all__ = [
    "AxisPlan",
    "FIXED_SIZES",
    "INTERPOLATIONS",
    "LOOKUP_TOL_RANGE",
    "MATERIAL_TABLES",
    "PLAN_MARGIN",
    "ScenePlan",
    "TablePlan",
    "bake_scene",
    "check_lookup_tol",
    "is_scene",
    "load_scene_file",
    "lookup",
    "parse_scene",
    "plan_scene",
]
