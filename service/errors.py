"""Domain errors -> HTTP responses, in one place.

Every error the service returns is JSON::

    {"error": {"status": 400, "code": "invalid_parameter", "param": "axes.mu",
               "query_param": "mu", "message": "values must be strictly increasing, ...",
               "allowed": ...}}

``param`` is the dotted spec path (as in :class:`bsdf_tab.SpecError`), ``query_param`` the
name of the query parameter of ``GET /tables/{table}`` that sets it (when there is one).

Mapping: :class:`bsdf_tab.SpecError` -> 400; unknown table -> 404; too many texels, too
large a body or too costly a computation (:class:`bsdf_tab.cost.CostLimitError`) -> 413;
a job that is not known -> 404; a computation cancelled or over its wall-clock limit -> 503; unsupported format -> 406; malformed query or body -> 400; the compute
queue full -> 503 with ``Retry-After``; anything unexpected -> 500 (the fuzz tests make sure
no input gets there).
"""

from __future__ import annotations

import logging

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from starlette.exceptions import HTTPException as StarletteHTTPException

from bsdf_tab.cost import CostLimitError
from bsdf_tab.errors import SpecError, TexelLimitError
from bsdf_tab.spec import KIND_OPTION_KEYS

__all__ = ["ClientGone", "ServiceError", "install_handlers", "query_param_for", "error_body"]

log = logging.getLogger("bsdf_tab.service")


class ClientGone(Exception):
    """The client disconnected before its request was read or answered (one info line, no traceback)."""


class ServiceError(Exception):
    """An error with an HTTP status, the offending parameter and what is allowed."""

    def __init__(
        self,
        status: int,
        code: str,
        message: str,
        param: str | None = None,
        allowed=None,
        headers: dict | None = None,
        query_param: str | None = None,
    ) -> None:
        super().__init__(message)
        self.status = status
        self.code = code
        self.message = message
        self.param = param
        self.allowed = allowed
        self.headers = headers or {}
        self.query_param = query_param


def query_param_for(param: str | None) -> str | None:
    """The query parameter of ``GET /tables/{table}`` that sets spec path ``param``.

    ``axes.mu`` -> ``mu``, ``axes.mu.size`` -> ``mu_size``, ``axes.mu.range`` ->
    ``mu_min,mu_max``, ``fresnel.type`` -> ``fresnel``, ``fresnel.eta`` -> ``fresnel_eta``.
    """
    if not param:
        return None
    parts = param.split(".")
    if parts[0] == "axes" and len(parts) >= 2:
        axis = parts[1]
        if len(parts) == 2 or parts[2] == "values":
            return axis
        if parts[2] == "range":
            return f"{axis}_min,{axis}_max"
        return f"{axis}_{parts[2]}"
    if parts[0] == "axes":
        return None
    if parts[0] == "fresnel":
        return "fresnel" if len(parts) == 1 or parts[1] == "type" else f"fresnel_{parts[1]}"
    if parts[0] in KIND_OPTION_KEYS:  # a kind's own keys (sheen_shadowing=, amplitude=) are query parameters too
        return parts[0]
    return parts[0] if parts[0] in ("table", "distribution", "shadowing", "method", "tolerance", "effort") else None


def error_body(status: int, code: str, message: str, param=None, allowed=None, query_param=None) -> dict:
    err = {"status": status, "code": code, "message": message, "param": param}
    qp = query_param if query_param is not None else query_param_for(param)
    if qp:
        err["query_param"] = qp
    if allowed is not None:
        err["allowed"] = allowed
    return {"error": err}


#: spec parameter -> the query parameters of GET /tables/{table} that set it (cost errors)
def _cost_query_params(params: list[str], axes: list[str]) -> str:
    out = []
    for p in params:
        out += [f"{a}_size" for a in axes] if p == "axes" else [p]
    return ",".join(out)


def cost_error(exc: CostLimitError, axes=()) -> ServiceError:
    """413 naming the parameters that drive the cost, the prediction, the limit and the way out."""
    cost = exc.cost
    allowed = {"max_cost_seconds": exc.limit, "jobs": "POST /jobs"}
    if cost is not None:
        allowed.update(cost.to_dict())
    qp = _cost_query_params(list(cost.params), list(axes)) if cost else exc.param
    return ServiceError(413, "too_costly", exc.message, param=exc.param, allowed=allowed, query_param=qp)


def from_spec_error(exc: SpecError) -> ServiceError:
    if isinstance(exc, CostLimitError):
        return cost_error(exc)
    if isinstance(exc, TexelLimitError):
        return ServiceError(413, "too_many_texels", exc.message, param=exc.param, allowed={"max_texels": exc.limit})
    status, code = 400, "invalid_parameter"
    if exc.param == "table" and exc.message.startswith("must be one of"):
        status, code = 404, "unknown_table"
    return ServiceError(status, code, exc.message, param=exc.param)


def _json(status: int, body: dict, headers: dict | None = None) -> JSONResponse:
    return JSONResponse(body, status_code=status, headers=headers)


def install_handlers(app: FastAPI) -> None:
    """Register the exception handlers that turn errors into JSON responses."""

    @app.exception_handler(ServiceError)
    async def _service_error(request: Request, exc: ServiceError):
        body = error_body(exc.status, exc.code, exc.message, exc.param, exc.allowed, exc.query_param)
        return _json(exc.status, body, exc.headers)

    @app.exception_handler(SpecError)
    async def _spec_error(request: Request, exc: SpecError):
        return await _service_error(request, from_spec_error(exc))

    @app.exception_handler(RequestValidationError)
    async def _validation_error(request: Request, exc: RequestValidationError):
        errors = exc.errors()
        first = errors[0] if errors else {}
        loc = [str(x) for x in first.get("loc", ()) if x not in ("query", "path", "body")]
        param = ".".join(loc) or None
        message = str(first.get("msg", "invalid request"))
        return _json(400, error_body(400, "invalid_request", message, param, query_param=param))

    @app.exception_handler(StarletteHTTPException)
    async def _http_error(request: Request, exc: StarletteHTTPException):
        code = {404: "not_found", 405: "method_not_allowed"}.get(exc.status_code, "http_error")
        body = error_body(exc.status_code, code, str(exc.detail))
        return _json(exc.status_code, body, getattr(exc, "headers", None))

    @app.exception_handler(ClientGone)
    async def _client_gone(request: Request, exc: ClientGone):
        log.info("client gone: %s %s: %s", request.method, request.url.path, exc)
        return _json(400, error_body(400, "client_gone", str(exc)))  # nobody reads it

    @app.exception_handler(Exception)
    async def _internal(request: Request, exc: Exception):  # pragma: no cover - a bug if reached
        log.exception("internal error on %s %s", request.method, request.url.path)
        body = error_body(500, "internal_error", f"{type(exc).__name__}: {exc}")
        return _json(500, body)
