"""``POST /check``: the LUT doctor (:func:`bsdf_tab.doctor.check_lut_bytes`) over HTTP.

Body: the LUT file's bytes (EXR, KTX2, DDS, PNG, ``.npy``, or a C/C++/JS array file), any
content type, at most :data:`MAX_LUT_BYTES`. Query parameters: ``name`` (the file name; only
array files need it), ``shape`` (``32,32`` or ``16,16,2``: an array file's shape),
``array_values`` (``float``, ``half``, ``unorm8``, ``unorm16``), ``axes`` (the axes the caller
believes the file has, rows first: ``mu,roughness``), ``heatmap`` (``1``: add the error map as
a base64 PNG). The answer is the report of ``bsdf-tab check --json`` (``table``,
``distribution``, ``shadowing``, ``axes``, ``channels``, ``encoding``, ``max_error``,
``mean_error``, ``findings``, ...), with ``heatmap_png`` (base64) when asked.

Errors: an unreadable file -> 400 ``param: body``; a bad ``shape`` / ``array_values`` /
``axes`` / ``heatmap`` -> 400 naming it; an unknown parameter -> 400; a body over the limit
-> 413. The identification runs in the synchronous compute lane (:meth:`TableStore.run_call`):
admitted like a table (503 ``busy`` when the queue is full), listed in ``/healthz``, dropped
unstarted when its client leaves.
"""

from __future__ import annotations

import base64
import tempfile
from pathlib import Path

from fastapi import APIRouter, Request
from fastapi.responses import JSONResponse

from bsdf_tab.doctor import ARRAY_VALUES, check_lut_bytes
from bsdf_tab.errors import SpecError

from ..errors import ServiceError
from ..params import only_params
from ..dependencies import read_body, store_of

__all__ = ["MAX_LUT_BYTES", "PARAMS", "router"]

router = APIRouter(tags=["check"])

#: The largest LUT file accepted (a 512 x 512 RGBA float32 texture and then some).
MAX_LUT_BYTES = 8 * 1024 * 1024
PARAMS = ("name", "shape", "array_values", "array_name", "axes", "heatmap")
_ERR = {"content": {"application/json": {}}}


def _bad(param: str, message: str, allowed=None) -> ServiceError:
    return ServiceError(400, "invalid_parameter", message, param=param, allowed=allowed, query_param=param)


def _shape(text: str | None):
    if text is None:
        return None
    try:
        if not text.isascii():  # int() reads other scripts' digits; the table routes do not
            raise ValueError(text)
        shape = tuple(int(x) for x in text.split(",") if x.strip())
    except ValueError:
        raise _bad("shape", f"must be integers separated by commas (32,32 or 16,16,2), got {text[:40]!r}") from None
    if not 1 <= len(shape) <= 3 or min(shape) < 1 or max(shape) > 4096:
        raise _bad("shape", f"must be 1 to 3 sizes in [1, 4096], got {text[:40]!r}")
    return shape


def _axes(text: str | None):
    if text is None:
        return None
    names = [a.strip() for a in text.split(",")]
    if not 1 <= len(names) <= 3 or not all(names):
        raise _bad("axes", f"must be 1 to 3 axis names, the file's first axis first (mu,roughness or "
                           f"ior,mu,roughness), got {text[:40]!r}")
    return names


def check_payload(data: bytes, name: str, shape, array_values: str, axes, heatmap: bool,
                  array_name: str | None = None) -> dict:
    """The report of the LUT ``data`` as JSON, with the heatmap PNG (base64) if asked."""
    with tempfile.TemporaryDirectory() as folder:
        png = Path(folder) / "heatmap.png" if heatmap else None
        try:
            report = check_lut_bytes(data, name, shape=shape, array_values=array_values, expect_axes=axes, heatmap=png,
                                     array_name=array_name)
        except SpecError as exc:
            param = "body" if exc.param in (None, "lut") else exc.param
            raise ServiceError(400, "invalid_lut" if param == "body" else "invalid_parameter", exc.message,
                               param=param, query_param=None if param == "body" else param) from None
        out = report.to_dict()
        if png is not None:
            out["heatmap_png"] = base64.b64encode(png.read_bytes()).decode("ascii")
    return out


@router.post(
    "/check",
    summary="Identify a LUT file (the LUT doctor): table kind, model, axes, encoding, error and findings",
    responses={200: {"description": "the report (as bsdf-tab check --json)", "content": {"application/json": {}}},
               400: {"description": "unreadable LUT or a bad parameter (the error names it)", **_ERR},
               413: {"description": "LUT file too large", **_ERR}},
    openapi_extra={
        "parameters": [
            {"name": "name", "in": "query", "required": False, "schema": {"type": "string"},
             "description": "the file name (array files are recognised by content; .npy and images by magic)"},
            {"name": "shape", "in": "query", "required": False, "schema": {"type": "string"},
             "description": "an array file's shape: 32,32 or 16,16,2"},
            {"name": "array_values", "in": "query", "required": False,
             "schema": {"type": "string", "enum": list(ARRAY_VALUES), "default": "float"},
             "description": "how an array file's numbers are read"},
            {"name": "array_name", "in": "query", "required": False, "schema": {"type": "string"},
             "description": "in an array file that initializes several arrays, the one to read (brdf_ggx)"},
            {"name": "axes", "in": "query", "required": False, "schema": {"type": "string"},
             "description": "the axes the file should have, its first axis first (mu,roughness; ior,mu,roughness)"},
            {"name": "heatmap", "in": "query", "required": False, "schema": {"type": "boolean", "default": False},
             "description": "add the error heatmap as a base64 PNG (heatmap_png)"},
        ],
        "requestBody": {"required": True, "content": {"application/octet-stream": {"schema": {"type": "string",
                                                                                              "format": "binary"}}}},
    },
)
async def post_check(request: Request) -> JSONResponse:
    extra = only_params(request.query_params.multi_items(), PARAMS)
    shape = _shape(extra.get("shape"))
    axes = _axes(extra.get("axes"))
    array_values = extra.get("array_values", "float")
    if array_values not in ARRAY_VALUES:
        raise _bad("array_values", f"must be one of {', '.join(ARRAY_VALUES)}, got {array_values[:40]!r}",
                   allowed=list(ARRAY_VALUES))
    heatmap_text = extra.get("heatmap", "0").lower()
    if heatmap_text not in ("0", "1", "true", "false"):
        raise _bad("heatmap", f"must be 0, 1, true or false, got {heatmap_text[:40]!r}")
    data = await read_body(request, MAX_LUT_BYTES, "the LUT")
    if not data:
        raise ServiceError(400, "invalid_body", "the body must be the LUT file's bytes, got an empty body", param="body")
    array_name = extra.get("array_name") or None
    if array_name is not None and not (array_name.isascii() and array_name.replace("_", "a").isalnum()):
        raise _bad("array_name", f"must be an identifier (letters, digits, _), got {array_name[:40]!r}")
    payload = await store_of(request).run_call("check", check_payload, data, extra.get("name", "lut"), shape,
                                               array_values, axes, heatmap_text in ("1", "true"), array_name,
                                               client=request.is_disconnected)
    return JSONResponse(payload, headers={"Cache-Control": "no-store"})
