"""One computation of the service (a table master, a scene, a LUT check): its progress, waiters,
cancellation and wall-clock limit, shared by :class:`~service.compute.TableStore`'s lanes.

Its progress callback (called by the library between chunks) raises :class:`Cancelled` once
every waiting client has gone (clients are polled for disconnects while they wait; a job is a
waiter until it is deleted) or once its wall-clock limit (``max_compute_seconds``, jobs
``job_max_seconds``) has passed since it left the queue. Each waiter is bounded too
(:meth:`~service.compute.TableStore.watch`): a synchronous request that has waited
``max_compute_seconds`` leaves with 503, ``busy`` (and ``Retry-After``) if its computation never
left the queue, ``time_limit`` if it ran and did not finish.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

__all__ = ["Cancelled", "Computation"]


class Cancelled(Exception):
    """A computation stopped between chunks: every client left, it was deleted, or it ran out of time."""

    def __init__(self, reason: str) -> None:
        super().__init__(reason)
        self.reason = reason


@dataclass
class Computation:
    """One running computation (a table master or a scene): progress, waiters, cancellation."""

    name: str
    limit_seconds: float
    lane: str = "sync"  # the pool it runs in: "sync" (requests) or "job"
    queued: float = field(default_factory=time.monotonic)
    started: float | None = None  # when it left the queue; its wall-clock limit counts from here
    done: int = 0
    total: int = 0
    waiters: int = 0
    cancel_reason: str | None = None

    def cancel(self, reason: str) -> None:
        if self.cancel_reason is None:
            self.cancel_reason = reason

    def start(self) -> None:
        """The computation leaves the queue (in its pool's thread); cancelled meanwhile: it does not run."""
        if self.cancel_reason is not None:
            raise Cancelled(self.cancel_reason)
        self.started = time.monotonic()

    def progress(self, done: int, total: int) -> None:
        """The library's progress callback: records, notifies, and stops the computation if asked."""
        self.done, self.total = int(done), int(total)
        if self.cancel_reason is not None:
            raise Cancelled(self.cancel_reason)
        if self.started is not None and time.monotonic() - self.started > self.limit_seconds:
            self.cancel(f"over its wall-clock limit of {self.limit_seconds:g} s")
            raise Cancelled(self.cancel_reason)

    def status(self) -> dict:
        now = time.monotonic()
        return {"name": self.name, "lane": self.lane, "state": "queued" if self.started is None else "running",
                "done": self.done, "total": self.total, "waiters": self.waiters,
                "elapsed_s": round(now - self.queued, 3),
                "running_s": 0.0 if self.started is None else round(now - self.started, 3),
                "limit_s": self.limit_seconds, "cancelling": self.cancel_reason}
