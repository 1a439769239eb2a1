"""What the routers share: the store, ETag matching, strict JSON body reading.

Routers never import each other; everything two of them need lives here.
"""

from __future__ import annotations

import asyncio
import logging

from fastapi import Request
from starlette.requests import ClientDisconnect

from bsdf_tab import jsontext

from .compute import TableStore
from .errors import ClientGone, ServiceError

__all__ = ["ClientGone", "accept_of", "etag_matches", "jobs_of", "read_body", "read_json_body", "store_of"]

log = logging.getLogger("bsdf_tab.service")


def store_of(request: Request) -> TableStore:
    """The app's :class:`~service.compute.TableStore`."""
    return request.app.state.store


def jobs_of(request: Request):
    """The app's :class:`~service.jobs.Jobs`."""
    return request.app.state.jobs


def accept_of(request: Request) -> str | None:
    """The ``Accept`` header: its field lines joined by commas, as RFC 9110 5.3 combines them.

    ``request.headers.get`` would read the first line only, while a cache or the hot path may
    see them all: one reading for every consumer keeps a response filed under what it answered.
    """
    lines = request.headers.getlist("accept")
    return ", ".join(lines) if lines else None


def etag_matches(request: Request, etag: str) -> bool:
    """Weak comparison of ``If-None-Match`` with ``etag`` (RFC 9110 13.1.2)."""
    header = request.headers.get("if-none-match")
    if not header:
        return False
    if header.strip() == "*":
        return True
    tags = [t.strip() for t in header.split(",")]
    return any((t[2:] if t.startswith("W/") else t) == etag for t in tags)


async def read_body(request: Request, limit: int, what: str = "the body") -> bytes:
    """The raw body: at most ``limit`` bytes (413), arriving within ``body_timeout`` seconds (408).

    uvicorn bounds the headers (``header_timeout``) but not the body: a client that declares
    100 bytes and sends one would hold the request (and its connection) forever.
    """
    declared = request.headers.get("content-length")
    if declared and declared.isdigit() and int(declared) > limit:
        raise ServiceError(413, "body_too_large", f"{what} has {declared} bytes; at most {limit}", param="body",
                           allowed={"max_bytes": limit})
    timeout = request.app.state.settings.body_timeout
    chunks, size = [], 0
    try:
        async with asyncio.timeout(timeout):
            async for chunk in request.stream():
                size += len(chunk)
                if size > limit:
                    raise ServiceError(413, "body_too_large", f"{what} is larger than {limit} bytes", param="body",
                                       allowed={"max_bytes": limit})
                chunks.append(chunk)
    except TimeoutError:
        raise ServiceError(408, "body_timeout", f"{what} did not arrive within {timeout:g} s ({size} bytes came)",
                           param="body", headers={"Connection": "close"}) from None
    except ClientDisconnect:
        raise ClientGone(f"{request.method} {request.url.path}: the client disconnected mid-body") from None
    return b"".join(chunks)


async def read_json_body(request: Request):
    """The request body as JSON: at most ``max_body_bytes`` (413), in time (408), valid JSON (400),
    no repeated key (400)."""
    raw = await read_body(request, request.app.state.settings.max_body_bytes)
    if not raw.strip():
        raise ServiceError(400, "invalid_body", "the body must be a JSON object, got an empty body", param="body")
    try:
        return jsontext.loads(raw)
    except jsontext.RepeatedKey as exc:  # JSON allows it, but which one was meant is a guess: refuse it
        raise ServiceError(400, "invalid_body", exc.message, param=f"body.{exc.key}") from None
    except (ValueError, RecursionError) as exc:  # JSONDecodeError, bad UTF-8, too-deep nesting
        raise ServiceError(400, "invalid_body", f"the body is not valid JSON: {str(exc)[:200]}", param="body") from None
