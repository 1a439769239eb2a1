"""Running the app on uvicorn with a header-read timeout (``BSDF_TAB_HEADER_TIMEOUT``).

uvicorn bounds idle keep-alive connections, but not a client that opens a connection and sends
its request headers slowly, or never finishes them (a slow-loris): each such connection would be
held forever. :func:`header_timeout_protocol` is uvicorn's h11 protocol with one timer per
request: armed when the connection opens or a new request's first bytes arrive, cancelled once
the headers are complete; when it fires first, the connection is closed (one info line).
"""

from __future__ import annotations

import asyncio
import logging

import h11
from uvicorn.protocols.http.h11_impl import H11Protocol

__all__ = ["HeaderTimeoutProtocol", "header_timeout_protocol", "run"]

log = logging.getLogger("bsdf_tab.service")


def header_timeout_protocol(seconds: float) -> type:
    """uvicorn's h11 protocol class, closing connections whose headers take more than ``seconds``."""

    class HeaderTimeoutProtocol(H11Protocol):
        header_timeout = float(seconds)

        def connection_made(self, transport: asyncio.Transport) -> None:  # type: ignore[override]
            super().connection_made(transport)
            self._header_timer = None
            self._arm()

        def _arm(self) -> None:
            if self._header_timer is None:
                self._header_timer = self.loop.call_later(self.header_timeout, self._expired)

        def _disarm(self) -> None:
            if self._header_timer is not None:
                self._header_timer.cancel()
                self._header_timer = None

        def _expired(self) -> None:
            self._header_timer = None
            if self.conn.their_state is h11.IDLE and not self.transport.is_closing():
                log.info("closed a connection from %s: no complete request headers within %g s",
                         self.client, self.header_timeout)
                self.transport.close()

        def data_received(self, data: bytes) -> None:
            if self.conn.their_state is h11.IDLE:  # a new request starts (or goes on) arriving
                self._arm()
            super().data_received(data)
            if self.conn.their_state is not h11.IDLE:  # the headers are complete
                self._disarm()

        def connection_lost(self, exc: Exception | None) -> None:
            self._disarm()
            super().connection_lost(exc)

    return HeaderTimeoutProtocol


def run(app, settings, log_level: str = "info") -> None:
    """Serve ``app`` on ``settings.host:settings.port`` (uvicorn, h11, header-read timeout)."""
    import uvicorn

    # the service's own lines (computations, cancellations, clients gone) beside uvicorn's
    if not log.handlers:
        handler = logging.StreamHandler()
        handler.setFormatter(logging.Formatter("%(levelname)s:     bsdf-tab: %(message)s"))
        log.addHandler(handler)
        log.propagate = False
    log.setLevel(log_level.upper())
    uvicorn.run(app, host=settings.host, port=settings.port, log_level=log_level,
                http=header_timeout_protocol(settings.header_timeout))


def _env_timeout() -> float:
    import os

    try:
        value = float(os.environ.get("BSDF_TAB_HEADER_TIMEOUT", "10"))
    except ValueError:
        value = 10.0  # a malformed variable must not stop the server; Settings() reports it
    return value if value > 0 else 10.0


#: For ``uvicorn service.app:app --http service.server:HeaderTimeoutProtocol`` (``--workers N``):
#: the timeout from ``BSDF_TAB_HEADER_TIMEOUT`` (default 10 s).
HeaderTimeoutProtocol = header_timeout_protocol(_env_timeout())
