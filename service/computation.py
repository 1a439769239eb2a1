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

import asyncio
import os
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Callable

from .errors import ServiceError

__all__ = ["Cancelled", "Computation", "Lanes"]


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


class Lanes:
    """The two lanes of :class:`~service.compute.TableStore` (a mixin): admission, the pools, the
    running computations' bookkeeping, and :meth:`run_call` for a plain function.

    The store provides ``settings``, ``compute_pool``, ``job_pool``, ``lanes`` (queued or running
    per lane), ``running`` (key -> :class:`Computation`), ``_waiters``, ``_limits``, ``_lock``,
    ``counters``, ``computing``, ``computations``, ``compute_seconds``, ``watch`` and ``_cancelled``.
    """

    settings: object
    compute_pool: ThreadPoolExecutor
    job_pool: ThreadPoolExecutor
    lanes: dict
    running: dict
    _waiters: dict
    _limits: dict
    _lock: threading.Lock
    counters: dict

    def _admit(self, lane: str = "sync") -> None:
        """A place in the synchronous lane's queue, or 503 (one door for tables, scenes and checks).

        Jobs are not refused here: their records are their queue, and their lane waits for them."""
        if lane == "job":
            return
        limit = self.settings.max_concurrent + self.settings.max_queued
        if self.lanes["sync"] >= limit:
            self.counters["busy"] += 1
            raise ServiceError(
                503, "busy", f"{self.lanes['sync']} computations are running or queued; try again later",
                headers={"Retry-After": "5"},
            )

    def _pool(self, lane: str) -> ThreadPoolExecutor:
        if lane not in ("sync", "job"):
            raise ValueError(f"lane must be 'sync' or 'job', got {lane!r}")
        return self.job_pool if lane == "job" else self.compute_pool

    def _begin(self, key: str, name: str, limit_seconds: float, lane: str = "sync") -> Computation:
        comp = Computation(name=name, limit_seconds=limit_seconds, lane=lane)
        with self._lock:
            comp.waiters = self._waiters.get(key, 0)
            comp.limit_seconds = max(limit_seconds, self._limits.get(key, 0.0))
            self.running[key] = comp
        if comp.waiters == 0:  # its last waiter left while it was being prepared: it never runs
            comp.cancel("every client waiting for it has gone")
        self.lanes[lane] += 1
        return comp

    def _end(self, key: str, comp: Computation) -> None:
        self.lanes[comp.lane] -= 1
        with self._lock:
            if self.running.get(key) is comp:  # a fresh computation of the key may have replaced it
                del self.running[key]

    @property
    def waiting(self) -> int:
        """Computations running or queued, both lanes."""
        return self.lanes["sync"] + self.lanes["job"]

    @contextmanager
    def _counted(self, comp: Computation, counter: str | None = None):
        """The thread side of a computation: started (or dropped, if cancelled while queued), counted, timed."""
        comp.start()
        with self._lock:
            self.computing += 1
        t0 = time.perf_counter()
        try:
            yield
        finally:
            with self._lock:
                self.computing -= 1
                self.computations += 1
                self.compute_seconds += time.perf_counter() - t0
                if counter is not None:
                    self.counters[counter] += 1

    async def _in_lane(self, name: str, limit: float, lane: str, work: Callable, *args):
        """``work(comp, *args)`` in ``lane``'s pool as computation ``name``: admitted (or 503), listed, limited."""
        self._admit(lane)
        comp = self._begin(name, name, limit, lane)
        held = False
        try:
            loop = asyncio.get_running_loop()
            future = loop.run_in_executor(self._pool(lane), work, comp, *args)
            try:
                return await asyncio.shield(future)
            except asyncio.CancelledError:
                if comp.started is not None:  # it runs on in its thread: it keeps its place until it ends
                    held = True
                    future.add_done_callback(lambda _f: self._end(name, comp))
                else:
                    future.cancel()  # still queued: never runs
                raise
        except Cancelled as exc:
            raise self._cancelled(exc) from None
        finally:
            if not held:
                self._end(name, comp)

    async def run_call(self, label: str, fn: Callable, *args, client=None):
        """``fn(*args)`` in the synchronous lane, through the tables' door: admitted or 503, seen in
        ``/healthz``, dropped unstarted when its client leaves, its waiter bounded by
        ``max_compute_seconds`` (a call cannot be stopped once it runs: keep ``fn`` bounded)."""
        name = f"{label}-{os.urandom(8).hex()}"
        limit = self.settings.max_compute_seconds
        self.counters["checks"] += 1
        return await self.watch(name, self._in_lane(name, limit, "sync", self._call, fn, args), client, limit)

    def _call(self, comp: Computation, fn: Callable, args: tuple):
        with self._counted(comp):
            return fn(*args)
