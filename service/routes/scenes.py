"""``POST /scenes``: plan and bake the minimal tables of a scene (bsdf_tab.scene).

Body: a scene JSON object (``materials``, optional ``lookup`` and ``tolerance``); query ``tol``
(the max lookup error; default the scene's ``tolerance``). The answer is JSON::

    {"plan": {...the plan and manifest, as bsdf-tab bake SCENE writes to manifest.json...},
     "tables": {"<file>.exr": {"format": "exr", "encoding": "base64", "bytes": n, "data": "..."}}}

Errors: a bad scene or tolerance -> 400 naming the parameter (``materials[0].alpha``), a
planned table above the service's texel limit -> 413 ``too_many_texels`` (such candidates are
skipped before anything is computed), a planning whose predicted cost (the cost model, before
each tabulation the planner runs: :class:`service.scenes.SceneBudget`) exceeds the service's
``max_cost_seconds`` -> 413 ``too_costly`` naming ``tol``, refused before the tabulation that
would exceed it. The planner's own caps (nodes per axis, check texels) bound the computation.
Planning runs in the compute pool, off the event loop.

The planner is deterministic, so the answer is cached like a table: key = package version +
sha256 of the normalized scene and ``tol``; simultaneous requests for one scene share one
planning run (single flight); the answer carries a strong ``ETag`` and ``If-None-Match`` gives
304 without planning anything.
"""

from __future__ import annotations

from fastapi import APIRouter, Request
from fastapi.responses import Response

from bsdf_tab.scene import plan_scene  # noqa: F401  (looked up at call time: tests count planner runs)

from ..dependencies import etag_matches, read_json_body, store_of
from ..params import only_params
from ..scenes import parse_scene_request, parse_tol, scene_plan_bytes

router = APIRouter(tags=["scenes"])

_ERR = {"content": {"application/json": {}}}


_RESPONSES = {
    200: {"description": "the plan and the tables", "content": {"application/json": {}}},
    304: {"description": "not modified (If-None-Match matched the ETag)"},
    400: {"description": "invalid scene or tolerance (the error names it)", **_ERR},
    413: {"description": "body too large / a planned table above the texel limit / the planning's predicted cost "
                 "above the limit (too_costly, param tol)", **_ERR},
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
    tol = parse_tol(extra.get("tol"))
    scene = await read_json_body(request)
    _parsed, name = parse_scene_request(scene, tol)
    # POST answers are not stored by HTTP caches; the ETag lets a client revalidate cheaply
    headers = {"ETag": f'"{name}"', "Cache-Control": "no-cache"}
    if etag_matches(request, headers["ETag"]):
        return Response(status_code=304, headers=headers)
    store = store_of(request)
    settings = request.app.state.settings
    payload = await store.run_scene(name, lambda checkpoint: scene_plan_bytes(scene, tol, settings, checkpoint,
                                                                              planner=plan_scene, **store.cluster()),
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
