"""Scene requests, shared by ``POST /scenes`` and scene jobs: parse, key, plan to answer bytes."""

from __future__ import annotations

import base64
import hashlib
import json

from bsdf_tab import __version__
from bsdf_tab.cost import CostLimitError, estimate
from bsdf_tab.errors import SpecError
from bsdf_tab.io import json_default
from bsdf_tab.scene import check_lookup_tol, is_scene, parse_scene, plan_scene

from .cache import table_key

__all__ = ["SceneBudget", "parse_scene_request", "parse_tol", "scene_key", "scene_plan_bytes"]


def parse_tol(text, param: str = "tol") -> float | None:
    """The lookup tolerance of a scene request (query text or a JSON number); None when absent."""
    if text is None:
        return None
    if isinstance(text, bool) or not isinstance(text, (str, int, float)):
        raise SpecError(param, f"must be a number, got {type(text).__name__}")  # a list or object is not a tolerance
    try:
        tol = float(text)
    except (ValueError, OverflowError):
        raise SpecError(param, f"must be a number, got {str(text)[:40]!r}") from None
    return check_lookup_tol(tol, param)  # rejects nan/inf before they reach the cache key


def scene_key(parsed: dict, tol: float | None) -> str:
    """Cache key of a scene request: version + sha256 of the normalized scene and ``tol``."""
    canon = json.dumps({"scene": parsed, "tol": tol}, sort_keys=True, separators=(",", ":"),
                       default=json_default, allow_nan=False)
    return table_key(hashlib.sha256(canon.encode()).hexdigest(), __version__)


class SceneBudget:
    """The planner's pre-compute hook (:func:`bsdf_tab.scene.plan_scene`'s ``before_compute``):
    the cost model's prediction (:func:`bsdf_tab.cost.estimate`) of every tabulation the planner
    is about to run, added up; the tabulation that would take the sum above ``limit``
    core-seconds is not run: :class:`~bsdf_tab.cost.CostLimitError` naming ``tol`` instead (413
    ``too_costly``). A scene whose first tabulation is already above it is refused before
    anything is computed; one whose search grows past it is stopped there."""

    def __init__(self, limit: float, scale: float = 1.0, tol: float | None = None):
        self.limit, self.scale, self.tol = limit, scale, tol
        self.spent = 0.0  # predicted core-seconds of the tabulations run so far
        self.tabulations = 0

    def __call__(self, spec: dict) -> None:
        cost = estimate(spec, scale=self.scale)
        if self.spent + cost.seconds > self.limit:
            at = f" at tol={self.tol:g}" if self.tol is not None else ""
            raise CostLimitError(
                "tol",
                f"planning this scene{at} is predicted to cost more than this service's limit of {self.limit:g} "
                f"core-seconds ({self.spent:.3g} for the {self.tabulations} tabulation(s) run, {cost.seconds:.3g} "
                f"for the next: {cost.texels} texels of {spec.get('table')}); loosen tol, or POST /jobs for big work",
                None, self.limit)
        self.spent += cost.seconds
        self.tabulations += 1


def scene_plan_bytes(scene: dict, tol, settings, checkpoint=None, planner=None, max_cost: float | None = None,
                     scheduler=None) -> bytes:
    """The answer of ``POST /scenes``: plan, then the JSON bytes (``checkpoint`` is the planner's log).

    ``planner`` defaults to :func:`bsdf_tab.scene.plan_scene` (tests count its calls). The cost
    limit (``max_cost``, default ``settings.max_cost_seconds``) is the planner's pre-compute hook
    (:class:`SceneBudget`): every tabulation is priced by the cost model before it runs, and the
    one that would take the predicted total above the limit is a
    :class:`~bsdf_tab.cost.CostLimitError` naming ``tol`` (413 ``too_costly``). The texel limit
    (``settings.max_texels``) bounds each planned table: candidates above it are skipped before
    they are computed (none left: :class:`~bsdf_tab.errors.TexelLimitError`, 413).
    ``scheduler`` (the store's Dask client, when ``BSDF_TAB_SCHEDULER`` is set) computes the
    candidate tables on the cluster.
    """
    limit = settings.max_cost_seconds if max_cost is None else max_cost
    parsed = parse_scene(scene)
    lookup_tol = tol if tol is not None else parsed.get("lookup_tol")
    budget = SceneBudget(limit, settings.cost_scale, None if lookup_tol is None else float(lookup_tol))
    extra = {"scheduler": scheduler} if scheduler is not None else {}
    plan = (planner or plan_scene)(scene, tol, device=settings.device, workers=settings.workers,
                                   max_texels=settings.max_texels, log=checkpoint, before_compute=budget, **extra)
    tables = {}
    for t in plan.tables:
        data = t.table.to_exr_bytes()
        tables[t.file] = {"format": "exr", "encoding": "base64", "bytes": len(data),
                          "data": base64.b64encode(data).decode("ascii")}
    body = {"plan": plan.to_dict(), "tables": tables}
    return json.dumps(body, default=json_default, allow_nan=False).encode()


def parse_scene_request(scene, tol) -> tuple[dict, str]:
    """(parsed scene, cache entry name) of a scene request; 400 naming the parameter."""
    if not isinstance(scene, dict):
        raise SpecError("body", f"the body must be a scene, a JSON object with a 'materials' list; got {type(scene).__name__}")
    if not is_scene(scene):
        raise SpecError("materials", "the body must be a scene: a JSON object with a 'materials' list")
    parsed = parse_scene(scene)  # 400 before taking a compute slot
    return parsed, f"{scene_key(parsed, tol)}.scene"


