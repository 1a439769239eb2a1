"""Scene requests, shared by ``POST /scenes`` and scene jobs: parse, key, plan to answer bytes."""

from __future__ import annotations

import base64
import hashlib
import json

from bsdf_tab import __version__
from bsdf_tab.cost import CostLimitError, estimate
from bsdf_tab.errors import SpecError, TexelLimitError
from bsdf_tab.io import json_default
from bsdf_tab.scene import check_lookup_tol, is_scene, parse_scene, plan_scene
from bsdf_tab.scene.plan import INTEGRATION_DIVISOR, MIN_INTEGRATION_TOL

from .cache import table_key

__all__ = ["parse_scene_request", "parse_tol", "scene_key", "scene_plan_bytes", "scene_texel_cap"]

#: The planner's cost for a table of N texels, in units of N texel integrations: its check grid
#: (every cell midpoint added: up to 2^3 = 8 x the texels of a 3-D candidate), and about as
#: much again for the smaller candidates tried before it.
CHECK_FACTOR = 16.0


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


def scene_texel_cap(lookup_tol: float, max_cost: float, scale: float = 1.0) -> int:
    """The largest table (texels) whose planning the cost model predicts within ``max_cost`` core-seconds.

    Priced as the dearest family (dielectric, adaptive) at the planner's integration tolerance
    (``lookup_tol / INTEGRATION_DIVISOR``), times :data:`CHECK_FACTOR`.
    """
    itol = max(lookup_tol / INTEGRATION_DIVISOR, MIN_INTEGRATION_TOL)
    one = estimate({"table": "dielectric", "tolerance": itol, "axes": {"mu": [0.5], "alpha": [0.5], "eta": [1.5]}},
                   scale=scale)
    return max(1, int(max_cost / (CHECK_FACTOR * one.per_integration)))


def scene_plan_bytes(scene: dict, tol, settings, checkpoint=None, planner=None, max_cost: float | None = None,
                     scheduler=None) -> bytes:
    """The answer of ``POST /scenes``: plan, then the JSON bytes (``checkpoint`` is the planner's log).

    ``planner`` defaults to :func:`bsdf_tab.scene.plan_scene` (tests count its calls). The cost
    limit (``max_cost``, default ``settings.max_cost_seconds``) becomes a texel cap for the
    planner (:func:`scene_texel_cap`): candidates above it are skipped before they are computed,
    and a scene that needs larger tables is a :class:`~bsdf_tab.cost.CostLimitError` naming ``tol``.
    ``scheduler`` (the store's Dask client, when ``BSDF_TAB_SCHEDULER`` is set) computes the
    candidate tables on the cluster.
    """
    limit = settings.max_cost_seconds if max_cost is None else max_cost
    parsed = parse_scene(scene)
    lookup_tol = tol if tol is not None else parsed.get("lookup_tol")
    cap = settings.max_texels
    if lookup_tol is not None:
        cap = min(cap, scene_texel_cap(float(lookup_tol), limit, settings.cost_scale))
    # candidates above the cap are skipped before computing; none left -> 413
    try:
        extra = {"scheduler": scheduler} if scheduler is not None else {}
        plan = (planner or plan_scene)(scene, tol, device=settings.device, workers=settings.workers, max_texels=cap,
                                       log=checkpoint, **extra)
    except TexelLimitError as exc:
        if cap >= settings.max_texels:
            raise  # the service's texel limit itself
        raise CostLimitError("tol", f"at this lookup tolerance the scene needs tables whose planning is predicted to "
                             f"cost more than {limit:g} core-seconds (tables above {cap} texels); loosen tol, or "
                             "POST /jobs for big work", None, limit) from None
    tables = {}
    for t in plan.tables:
        data = t.table.to_exr_bytes()
        tables[t.file] = {"format": "exr", "encoding": "base64", "bytes": len(data),
                          "data": base64.b64encode(data).decode("ascii")}
    body = {"plan": plan.to_dict(), "tables": tables}
    return json.dumps(body, default=json_default, allow_nan=False).encode()


def parse_scene_request(scene, tol) -> tuple[dict, str]:
    """(parsed scene, cache entry name) of a scene request; 400 naming the parameter."""
    if not is_scene(scene):
        raise SpecError("materials", "the body must be a scene: a JSON object with a 'materials' list")
    parsed = parse_scene(scene)  # 400 before taking a compute slot
    return parsed, f"{scene_key(parsed, tol)}.scene"


