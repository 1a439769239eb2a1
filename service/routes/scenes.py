"""``POST /scenes``: plan and bake the minimal tables of a scene (bsdf_tab.scene).

Body: a scene JSON object (``materials``, optional ``lookup`` and ``tolerance``); query ``tol``
(the max lookup error; default the scene's ``tolerance``). The answer is JSON::

    {"plan": {...the plan and manifest, as bsdf-tab bake SCENE writes to manifest.json...},
     "tables": {"<file>.exr": {"format": "exr", "encoding": "base64", "bytes": n, "data": "..."}}}

Errors: a bad scene or tolerance -> 400 naming the parameter (``materials[0].alpha``), a
planned table above the service's texel limit -> 413 (such candidates are skipped before
anything is computed). The planner's own caps (nodes per axis, check texels) bound the computation. Planning runs in the compute pool, off the event loop.

The planner is deterministic, so the answer is cached like a table: key = package version +
sha256 of the normalized scene and ``tol``; simultaneous requests for one scene share one
planning run (single flight); the answer carries a strong ``ETag`` and ``If-None-Match`` gives
304 without planning anything.
"""

from __future__ import annotations

import base64
import hashlib
import json

from fastapi import APIRouter, Request
from fastapi.responses import Response

from bsdf_tab import __version__
from bsdf_tab.errors import SpecError
from bsdf_tab.scene import check_lookup_tol, is_scene, parse_scene, plan_scene
from bsdf_tab.io import json_default

from ..cache import table_key
from ..params import only_params
from ..dependencies import etag_matches, read_json_body, store_of

router = APIRouter(tags=["scenes"])

_ERR = {"content": {"application/json": {}}}


def _tol(extra: dict) -> float | None:
    if "tol" not in extra:
        return None
    try:
        tol = float(extra["tol"])
    except ValueError:
        raise SpecError("tol", f"must be a number, got {extra['tol'][:40]!r}") from None
    return check_lookup_tol(tol, "tol")  # rejects nan/inf before they reach the cache key


def scene_key(parsed: dict, tol: float | None) -> str:
    """Cache key of a scene request: version + sha256 of the normalized scene and ``tol``."""
    canon = json.dumps({"scene": parsed, "tol": tol}, sort_keys=True, separators=(",", ":"),
                       default=json_default, allow_nan=False)
    return table_key(hashlib.sha256(canon.encode()).hexdigest(), __version__)


def scene_plan_bytes(scene: dict, tol, settings, checkpoint=None) -> bytes:
    """The answer of ``POST /scenes``: plan, then the JSON bytes (``checkpoint`` is the planner's log)."""
    # candidates above the texel limit are skipped before computing; none left -> 413
    plan = plan_scene(scene, tol, device=settings.device, workers=settings.workers, max_texels=settings.max_texels,
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


_RESPONSES = {
    200: {"description": "the plan and the tables", "content": {"application/json": {}}},
    304: {"description": "not modified (If-None-Match matched the ETag)"},
    400: {"description": "invalid scene or tolerance (the error names it)", **_ERR},
    413: {"description": "body too large / a planned table above the texel limit", **_ERR},
    503: {"description": "too many computations queued (retry later), or cancelled / out of time", **_ERR},
}


@router.post(
    "/scenes",
    summary="Plan and bake the minimal tables of a scene (JSON: plan, manifest, base64 EXR tables)",
    responses=_RESPONSES,
    openapi_extra={
        "parameters": [{"name": "tol", "in": "query", "required": False, "schema": {"type": "number"},
                        "description": "max lookup error (default: the scene's tolerance)"}],
        "requestBody": {"required": True, "content": {"application/json": {"schema": {"type": "object"}}}},
    },
)
async def post_scene(request: Request) -> Response:
    extra = only_params(request.query_params.multi_items(), ("tol",))
    tol = _tol(extra)
    scene = await read_json_body(request)
    _parsed, name = parse_scene_request(scene, tol)
    # POST answers are not stored by HTTP caches; the ETag lets a client revalidate cheaply
    headers = {"ETag": f'"{name}"', "Cache-Control": "no-cache"}
    if etag_matches(request, headers["ETag"]):
        return Response(status_code=304, headers=headers)
    store = store_of(request)
    settings = request.app.state.settings
    payload = await store.run_scene(name, lambda checkpoint: scene_plan_bytes(scene, tol, settings, checkpoint),
                                    client=request.is_disconnected)
    return Response(payload, media_type="application/json", headers=headers)


@router.get(
    "/scenes/by-key/{name}",
    summary="A planned scene by its cache entry name (a job's result), with its ETag",
    responses={200: _RESPONSES[200], 304: _RESPONSES[304],
               404: {"description": "no scene of that name is in the cache", **_ERR}},
)
async def get_scene(name: str, request: Request) -> Response:
    only_params(request.query_params.multi_items(), ())
    headers = {"ETag": f'"{name}"', "Cache-Control": f"public, max-age={request.app.state.settings.cache_max_age}, immutable"}
    payload = await store_of(request).cached_scene(name)
    if etag_matches(request, headers["ETag"]):
        return Response(status_code=304, headers=headers)
    return Response(payload, media_type="application/json", headers=headers)
