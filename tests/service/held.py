"""What the service's concurrency tests share: an in-process client and a bounded wait for a held call."""

from __future__ import annotations

import asyncio

import httpx


def asgi_client(app) -> httpx.AsyncClient:
    """An httpx client that calls ``app`` in this event loop (no sockets)."""
    return httpx.AsyncClient(transport=httpx.ASGITransport(app=app), base_url="http://svc")


async def started(state: dict, seconds: float = 10.0) -> None:
    """Wait, at most ``seconds``, until the held call of ``state`` has set ``state["started"]``."""
    for _ in range(int(seconds / 0.01)):
        if state["started"].is_set():
            return
        await asyncio.sleep(0.01)
    raise AssertionError(f"the held call did not start within {seconds:g} s")
