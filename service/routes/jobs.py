"""``POST /jobs``, ``GET /jobs/{id}``, ``DELETE /jobs/{id}``: big work in the background (:mod:`service.jobs`)."""

from __future__ import annotations

from fastapi import APIRouter, Request
from fastapi.responses import JSONResponse

from ..dependencies import jobs_of, read_json_body
from ..params import only_params, spec_json_schema

router = APIRouter(tags=["jobs"])

_ERR = {"content": {"application/json": {}}}
_JOB = {
    "type": "object",
    "properties": {
        "id": {"type": "string"}, "kind": {"type": "string", "enum": ["table", "scene"]},
        "status": {"type": "string", "enum": ["queued", "running", "done", "failed", "cancelled"]},
        "progress": {"type": "object", "properties": {"done": {"type": "integer"}, "total": {"type": "integer"}}},
        "eta_seconds": {"type": ["number", "null"]}, "result": {"type": ["string", "null"]},
        "error": {"type": ["string", "null"]},
    },
}
_BODY = {
    "oneOf": [
        {"type": "object", "required": ["spec"], "additionalProperties": False,
         "properties": {"spec": spec_json_schema()}},
        {"type": "object", "required": ["scene"], "additionalProperties": False,
         "properties": {"scene": {"type": "object"}, "tol": {"type": "number"}}},
    ]
}


def _answer(request: Request, job: dict, status: int) -> JSONResponse:
    headers = {"Location": f"/jobs/{job['id']}", "Cache-Control": "no-store"}
    if job["status"] == "done" and job["result"]:
        headers["Content-Location"] = job["result"]
    return JSONResponse(job, status_code=status, headers=headers)


@router.post(
    "/jobs",
    status_code=202,
    summary="Start a job: a table spec or a scene; 202 with Location: /jobs/{id} (an identical job: the same id)",
    responses={202: {"description": "accepted (or already known)", "content": {"application/json": {"schema": _JOB}}},
               400: {"description": "invalid spec, scene or tol (the error names it)", **_ERR},
               404: {"description": "unknown table", **_ERR},
               413: {"description": "body too large / too many texels / above the job cost limit", **_ERR}},
    openapi_extra={"requestBody": {"required": True, "content": {"application/json": {"schema": _BODY}}}},
)
async def post_job(request: Request) -> JSONResponse:
    only_params(request.query_params.multi_items(), ())
    body = await read_json_body(request)
    job = await jobs_of(request).submit(body)
    return _answer(request, job, 202)


_ID_RESPONSES = {200: {"description": "the job", "content": {"application/json": {"schema": _JOB}}},
                 404: {"description": "no such job", **_ERR}}


@router.get("/jobs/{id}", summary="A job's status, progress, ETA, result URL and error", responses=_ID_RESPONSES)
async def get_job(id: str, request: Request) -> JSONResponse:
    only_params(request.query_params.multi_items(), ())
    return _answer(request, await jobs_of(request).view(id), 200)


@router.delete("/jobs/{id}", summary="Cancel a job (a finished one stays as it is)", responses=_ID_RESPONSES)
async def delete_job(id: str, request: Request) -> JSONResponse:
    only_params(request.query_params.multi_items(), ())
    return _answer(request, await jobs_of(request).cancel(id), 200)
