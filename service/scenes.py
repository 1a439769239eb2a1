"""Scene requests, shared by ``POST /scenes`` and scene jobs: parse, key, plan to answer bytes."""

from __future__ import annotations

import base64
import hashlib
import json

from bsdf_tab import __version__
from bsdf_tab.errors import SpecError
from bsdf_tab.io import json_default
from bsdf_tab.scene import check_lookup_tol, is_scene, parse_scene, plan_scene

from .cache import table_key

__all__ = ["parse_scene_request", "parse_tol", "scene_key", "scene_plan_bytes"]


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


def scene_plan_bytes(scene: dict, tol, settings, checkpoint=None, planner=None) -> bytes:
    """The answer of ``POST /scenes``: plan, then the JSON bytes (``checkpoint`` is the planner's log).

    ``planner`` defaults to :func:`bsdf_tab.scene.plan_scene` (tests count its calls).
    """
    # candidates above the texel limit are skipped before computing; none left -> 413
    plan = (planner or plan_scene)(scene, tol, device=settings.device, workers=settings.workers, max_texels=settings.max_texels,
                      log=checkpoint)
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


