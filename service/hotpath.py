"""The hot path: repeated ``GET /tables/{table}?...`` answered at the ASGI layer, from memory.

Cached tables are immutable (a key never changes meaning), so once the table route has
answered a query with 200 from verified bytes, the same request (path, raw query string,
``Accept``) is answered again by :class:`HotPath`, an ASGI middleware in front of the app:
one dict lookup for the response headers, one for the bytes in the store's
:class:`~service.cache.MemoryLRU` (bounded in bytes), no routing, no dependency solving,
no thread hop. Everything else goes to the app as before: other methods and paths, requests
with ``If-None-Match`` (304 logic stays in the route), queries not yet answered, and entries
the memory LRU has evicted.

The header map is bounded in entries (:data:`MAX_ENTRIES`, least recently used first); the
bytes are not duplicated (the LRU holds them).
"""

from __future__ import annotations

import threading
from collections import OrderedDict

__all__ = ["HotPath", "MAX_ENTRIES"]

#: answered requests remembered (path, query, Accept) -> (entry name, raw headers)
MAX_ENTRIES = 4096


class HotPath:
    """ASGI middleware serving remembered ``GET /tables/...`` answers from the memory LRU."""

    def __init__(self, app, memory, state=None, prefix: str = "/tables/") -> None:
        self.app = app
        if state is not None:
            state.hot = self  # the routes remember answers through app.state.hot
        self.memory = memory
        self.prefix = prefix
        self._answers: OrderedDict = OrderedDict()
        self._lock = threading.Lock()
        self.hits = 0

    @staticmethod
    def request_key(scope) -> tuple | None:
        """(path, query, Accept) of a plain GET that may be remembered, else None."""
        accept = None
        for name, value in scope["headers"]:
            if name == b"accept":
                if accept is not None:  # several Accept lines: the route combines them; not remembered
                    return None
                accept = value
            elif name == b"if-none-match":  # conditional: the route decides (304)
                return None
        return scope["path"], scope.get("query_string", b""), accept or b""

    def remember(self, scope, name: str, status: int, headers: list[tuple[bytes, bytes]]) -> None:
        """Record the answer to ``scope``: entry ``name`` of the memory LRU with these raw headers."""
        if status != 200 or scope.get("method") != "GET":
            return
        key = self.request_key(scope)
        if key is None:
            return
        with self._lock:
            self._answers[key] = (name, headers)
            self._answers.move_to_end(key)
            if len(self._answers) > MAX_ENTRIES:
                self._answers.popitem(last=False)

    async def __call__(self, scope, receive, send):
        if scope["type"] == "http" and scope["method"] == "GET" and scope["path"].startswith(self.prefix):
            key = self.request_key(scope)
            hit = self._answers.get(key) if key is not None else None
            if hit is not None:
                body = self.memory.get(hit[0])
                if body is not None:
                    self.hits += 1
                    await send({"type": "http.response.start", "status": 200, "headers": hit[1]})
                    await send({"type": "http.response.body", "body": body})
                    return
        await self.app(scope, receive, send)

    def summary(self) -> dict:
        return {"entries": len(self._answers), "max_entries": MAX_ENTRIES, "hits": self.hits}
