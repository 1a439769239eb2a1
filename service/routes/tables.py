"""Table endpoints: the catalog, a table by query or by spec, its metadata and preview."""

from __future__ import annotations

from fastapi import APIRouter, Request
from fastapi.responses import JSONResponse, Response

from bsdf_tab.spec import TABLE_KINDS, channel_names

from ..compute import Prepared
from ..dependencies import accept_of, etag_matches, read_json_body, store_of
from ..errors import ServiceError
from ..params import (
    FORMAT_PARAM,
    MEDIA_TYPES,
    query_param,
    catalog,
    negotiate,
    only_params,
    query_parameters,
    spec_from_query,
    spec_json_schema,
)
from ..preview import check_preview, render_png

router = APIRouter(tags=["tables"])

_ERR = {"content": {"application/json": {}}}
_TABLE_RESPONSES = {
    200: {
        "description": "the table (EXR by default)",
        "content": {t: {"schema": {"type": "string", "format": "binary"}} for t in MEDIA_TYPES.values()},
    },
    304: {"description": "not modified (If-None-Match matched the ETag)"},
    400: {"description": "invalid parameter (the error names it)", **_ERR},
    404: {"description": "unknown table", **_ERR},
    406: {"description": "unsupported format", **_ERR},
    413: {"description": "too many texels / body too large / predicted cost above the limit (use POST /jobs)", **_ERR},
    503: {"description": "too many computations queued (retry later), or the computation was cancelled or ran "
                         "out of time", **_ERR},
}
TABLE_PATH_PARAM = {"name": "table", "in": "path", "required": True,
                    "schema": {"type": "string", "enum": list(TABLE_KINDS)}, "description": "the table kind"}
PREVIEW_PARAMS = [
    query_param("channel", {"type": "string"}, "channel to show (default: the first value channel)"),
    query_param("slice", {"type": "integer"}, "tables of 3 or more axes: the held axes' indices, an integer "
                "(one held axis) or axis=i pairs, e.g. alpha=3,anisotropy=2 (default: the middle of each)"),
    query_param("slice_axis", {"type": "string"}, "tables of 3 or more axes: the held axes, comma-separated "
                "(default: all but the first two)"),
]


def _check_table(table: str) -> None:
    if table not in TABLE_KINDS:
        raise ServiceError(404, "unknown_table", f"unknown table {table[:60]!r}", param="table", allowed=list(TABLE_KINDS))


def _headers(request: Request, prep: Prepared, variant: str, vary: bool) -> dict:
    max_age = request.app.state.settings.cache_max_age
    headers = {
        "ETag": f'"{prep.key}.{variant}"',
        "Cache-Control": f"public, max-age={max_age}, immutable",
        "X-BSDF-Tab-Key": prep.key,
    }
    if vary:
        headers["Vary"] = "Accept"
    return headers


async def send_variant(request: Request, prep: Prepared, variant: str, media_type: str, *, vary: bool = False,
                       derive=None, filename: str | None = None) -> Response:
    """The response for one representation, with ETag / 304 / Cache-Control."""
    headers = _headers(request, prep, variant, vary)
    if filename:
        disposition = "inline" if variant in ("json",) else "attachment"
        headers["Content-Disposition"] = f'{disposition}; filename="{filename}"'
    if etag_matches(request, headers["ETag"]):
        return Response(status_code=304, headers=headers)
    store = store_of(request)
    body = store.cached(prep, variant)  # the hot path: memory, no thread hop
    if body is None:
        body = await store.variant(prep, variant, derive=derive, client=request.is_disconnected)
    return Response(body, media_type=media_type, headers=headers)


async def send_table(request: Request, spec: dict | None, fmt_param: str | None, prep: Prepared | None = None) -> Response:
    fmt = negotiate(fmt_param, accept_of(request))
    if prep is None:
        prep = store_of(request).prepare(spec)
    filename = f"{prep.kind}-{prep.key.rsplit('-', 1)[-1][:12]}.{fmt}"
    response = await send_variant(request, prep, fmt, MEDIA_TYPES[fmt], vary=fmt_param is None, filename=filename)
    response.headers["X-BSDF-Tab-Axes"] = ",".join(prep.axes)
    hot = request.app.state.hot
    if hot is not None and response.status_code == 200:
        hot.remember(request.scope, f"{prep.key}.{fmt}", 200, response.raw_headers)
    return response


@router.get("/tables", summary="Catalog: tables, parameters, types, ranges, defaults, limits")
async def get_catalog(request: Request) -> JSONResponse:
    return JSONResponse(catalog(request.app.state.settings))


@router.head("/tables/{table}", include_in_schema=False)
@router.get(
    "/tables/{table}",
    summary="A table by query parameters",
    description=(
        "Axes: `A=v0,v1,...` (explicit) or `A_size=N&A_spacing=linear|square&A_nodes=endpoints|centers"
        "&A_min=LO&A_max=HI` per axis A of the table; Fresnel: `fresnel=schlick&fresnel_f0=0.04`. "
        "Format: `format=exr|npz|npy|json` or an Accept header (EXR by default)."
    ),
    responses=_TABLE_RESPONSES,
    openapi_extra={"parameters": [TABLE_PATH_PARAM] + query_parameters([FORMAT_PARAM])},
)
async def get_table(request: Request) -> Response:
    # the path parameter is read here, not declared: FastAPI's per-request dependency solving
    # was a third of the hot path (bench/load.py); the OpenAPI document declares it above
    table = request.path_params["table"]
    _check_table(table)
    items = tuple(request.query_params.multi_items())
    prep, extra = store_of(request).prepare_query(
        table, items, lambda: spec_from_query(table, items, extra=("format",)),
        lambda extra: negotiate(extra.get("format"), accept_of(request)))
    return await send_table(request, None, extra.get("format"), prep)


@router.get(
    "/tables/by-key/{key}",
    summary="A computed table by its cache key (a job's result): immutable, with its ETag",
    responses={**{k: v for k, v in _TABLE_RESPONSES.items() if k not in (413, 503)},
               404: {"description": "no table of that key is in the cache (not computed, or evicted)", **_ERR}},
    openapi_extra={"parameters": [FORMAT_PARAM]},
)
async def get_by_key(key: str, request: Request) -> Response:
    extra = only_params(request.query_params.multi_items(), ("format",))
    fmt = negotiate(extra.get("format"), accept_of(request))
    store = store_of(request)
    prep = await store.prepare_key(key)
    return await send_table(request, None, fmt if "format" in extra else None, prep)


@router.post(
    "/tables",
    summary="A table by spec (JSON body)",
    responses=_TABLE_RESPONSES,
    openapi_extra={
        "parameters": [FORMAT_PARAM],
        "requestBody": {"required": True, "content": {"application/json": {"schema": spec_json_schema()}}},
    },
)
async def post_table(request: Request) -> Response:
    extra = only_params(request.query_params.multi_items(), ("format",))
    fmt = negotiate(extra.get("format"), accept_of(request))  # 406 before reading the body
    spec = await read_json_body(request)
    if not isinstance(spec, dict):
        raise ServiceError(400, "invalid_body", f"the body must be a spec, a JSON object; got {type(spec).__name__}",
                           param="body")
    return await send_table(request, spec, fmt if "format" in extra else None)


@router.get(
    "/tables/{table}/info",
    summary="Table metadata: spec, conventions, method, max error (computes the table if needed)",
    responses={k: v for k, v in _TABLE_RESPONSES.items() if k != 406},
    openapi_extra={"parameters": query_parameters()},
)
async def get_info(table: str, request: Request) -> Response:
    _check_table(table)
    spec, _ = spec_from_query(table, request.query_params.multi_items())
    prep = store_of(request).prepare(spec)
    return await send_variant(request, prep, "info", "application/json")


@router.get(
    "/tables/{table}/preview.png",
    summary="Heatmap PNG of one channel (3-D and 4-D tables: one slice, the middle by default)",
    responses={200: {"content": {"image/png": {}}}, **{k: v for k, v in _TABLE_RESPONSES.items() if k not in (200, 406)}},
    openapi_extra={"parameters": query_parameters(PREVIEW_PARAMS)},
)
async def get_preview(table: str, request: Request) -> Response:
    _check_table(table)
    spec, extra = spec_from_query(table, request.query_params.multi_items(), extra=("channel", "slice", "slice_axis"))
    prep = store_of(request).prepare(spec)
    params = check_preview(prep.axes, channel_names(table, errors=True), extra.get("channel"),
                           extra.get("slice_axis"), extra.get("slice"))
    return await send_variant(request, prep, params.variant, "image/png",
                              derive=lambda t: render_png(t, params))
