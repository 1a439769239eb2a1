"""From a spec to response bytes: validate, price, look up the caches, compute once, derive formats.

:class:`TableStore` is the one object the routes talk to. A request goes

1. :meth:`TableStore.prepare` (or :meth:`TableStore.prepare_query`, memoized query -> key):
   normalize the spec once (``SpecError`` -> 400), check the texel limit (-> 413) and the
   predicted cost (:mod:`bsdf_tab.cost`, ``max_cost_seconds``; jobs ``max_job_cost_seconds``;
   -> 413 naming the parameters and the prediction), compute the cache key. Cheap; on the loop.
2. :meth:`TableStore.variant`: the bytes of one representation (``exr``, ``npz``, ``npy``,
   ``json``, ``info``, ``png-...``). Recently served entries are in a bounded in-memory LRU
   (:class:`~service.cache.MemoryLRU`, no thread hop); a disk hit is read, checksum-verified
   and validated in a small I/O pool. A miss goes through :class:`~service.cache.SingleFlight`
   keyed by the entry name, so concurrent requests share one derivation, which itself needs the
   ``npz`` master, again single-flight, and only a master miss computes.
3. A master computation takes the key's inter-process lock (:meth:`DiskCache.key_lock`:
   replicas sharing the folder compute each key once; the others poll the cache), then runs in
   a pool of ``settings.max_concurrent`` threads (each ``tabulate`` call uses
   ``settings.workers`` threads of its own), never on the event loop; at most
   ``settings.max_queued`` distinct computations wait (more -> 503 with ``Retry-After``).
   Scenes (:meth:`TableStore.run_scene`) and LUT checks (:meth:`TableStore.run_call`) go
   through the same queue, slots and counters. Jobs have a lane of their own
   (``settings.max_concurrent_jobs`` threads), so a long job never holds the synchronous
   requests' slots.
4. Every computation is a :class:`~service.computation.Computation` (its cancellation and
   limits are described there); each waiter leaves after its own limit (:meth:`TableStore.watch`).

``tabulate`` is looked up on this module at call time, so tests can monkeypatch
``service.compute.tabulate`` to count computations.
"""

from __future__ import annotations

import asyncio
import io
import json
import logging
import math
import os
import re
import threading
import time
from collections import OrderedDict
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import Awaitable, Callable

import numpy as np

from bsdf_tab import __version__
from bsdf_tab.api import tabulate  # noqa: F401  (monkeypatch point)
from bsdf_tab.cost import Cost, CostLimitError, estimate
from bsdf_tab.errors import SpecError
from bsdf_tab.spec import normalize_spec, resolve_axes, spec_hash
import bsdf_tab.io as bsdf_io
from bsdf_tab.table import Table

from .cache import DiskCache, MemoryLRU, SingleFlight, table_key
from .errors import ClientGone, ServiceError, cost_error
from .representations import DERIVE, MASTER
from .computation import Cancelled, Computation, Lanes
from .settings import Settings

__all__ = ["Cancelled", "Computation", "TableStore", "Prepared", "validator"]

log = logging.getLogger("bsdf_tab.service")

#: seconds between two checks that a waiting client is still connected
POLL_SECONDS = 0.25
#: seconds between two looks at the cache while another process holds a key's lock
PEER_POLL_SECONDS = 0.1
_KEY_RE = re.compile(r"^v[A-Za-z0-9.+_]{1,40}-[0-9a-f]{64}$")
_SCENE_RE = re.compile(r"^v[A-Za-z0-9.+_]{1,40}-[0-9a-f]{64}\.scene$")
#: prepared queries remembered (query -> key); entries are small
MEMO_ENTRIES = 4096


@dataclass(frozen=True)
class Prepared:
    """A validated request: normalized spec, its resolved axes, cache key and predicted cost."""

    nspec: dict
    key: str
    texels: int
    axes: dict
    cost: Cost | None = None

    @property
    def kind(self) -> str:
        return self.nspec["table"]


def _normalize(spec) -> dict:
    try:
        return normalize_spec(spec)
    except SpecError:
        raise
    except (OverflowError, ValueError, TypeError, RecursionError, MemoryError) as exc:
        # e.g. an integer too large for a float (10**400): the library raises OverflowError
        raise ServiceError(400, "invalid_parameter", f"invalid spec: {type(exc).__name__}: {exc}") from None


def validator(variant: str, key: str) -> Callable[[bytes], bool] | None:
    """What an intact payload of ``variant`` must be to be served (None: no check beyond the checksum)."""
    if variant == MASTER:
        expected = key.rsplit("-", 1)[-1]

        def master_ok(payload: bytes) -> bool:
            table = Table.from_npz_bytes(payload)  # a table at all, and the one of this key
            return spec_hash(table.meta["spec"]) == expected

        return master_ok
    if variant == "exr":
        return lambda payload: payload[:4] == b"\x76\x2f\x31\x01" and bsdf_io.from_bytes(payload, "exr") is not None
    if variant in ("json", "info", "scene"):
        return lambda payload: isinstance(json.loads(payload), dict)
    if variant == "npy":
        return lambda payload: np.load(io.BytesIO(payload), allow_pickle=False).dtype.names is not None
    if variant.startswith("png"):
        return lambda payload: payload[:8] == b"\x89PNG\r\n\x1a\n"
    return None


class TableStore(Lanes):
    """Caches + single flight + bounded executors + cost limits around :func:`bsdf_tab.tabulate`."""

    def __init__(self, settings: Settings) -> None:
        self.settings = settings
        self.cache = DiskCache(settings.cache_dir, settings.cache_max_bytes)
        self.memory = MemoryLRU(settings.memory_cache_bytes)
        self.flight = SingleFlight()
        self.compute_pool = ThreadPoolExecutor(settings.max_concurrent, thread_name_prefix="bsdf-tab-compute")
        self.job_pool = ThreadPoolExecutor(settings.max_concurrent_jobs, thread_name_prefix="bsdf-tab-job")
        self.io_pool = ThreadPoolExecutor(4, thread_name_prefix="bsdf-tab-io")
        self.computations = 0  # computations that finished (or failed), tables and scenes
        self.computing = 0  # computations running now
        self.lanes = {"sync": 0, "job": 0}  # computations queued or running, per lane (``waiting``: both)
        self._limits: dict[str, float] = {}  # key -> the largest limit of its waiters
        self.compute_seconds = 0.0
        self.counters = {"cancelled": 0, "timed_out": 0, "failed": 0, "peer_computed": 0, "scenes": 0,
                         "rejected_cost": 0, "busy": 0, "queue_timeout": 0, "client_gone": 0, "checks": 0}
        self.running: dict[str, Computation] = {}
        self._waiters: dict[str, int] = {}
        self._memo: OrderedDict = OrderedDict()
        self._lock = threading.Lock()
        self._client = None  # the Dask client when BSDF_TAB_SCHEDULER is set (see cluster())
        self._owns_client = False
        self.started = time.time()

    # ------------------------------------------------------------------ cluster

    def cluster(self) -> dict:
        """``{"scheduler": client}`` when ``BSDF_TAB_SCHEDULER`` is set (connected once), else ``{}``.

        Raises
        ------
        ServiceError
            503 naming the scheduler when it is malformed or does not answer.
        """
        if not self.settings.scheduler:
            return {}
        with self._lock:
            if self._client is None:
                from bsdf_tab.cluster import SchedulerError, connect

                try:
                    self._client, self._owns_client = connect(self.settings.scheduler)
                except SchedulerError as exc:
                    raise ServiceError(503, "scheduler_unavailable", str(exc), param="scheduler",
                                       headers={"Retry-After": "5"}) from None
            return {"scheduler": self._client}

    # ------------------------------------------------------------------ requests

    def prepare(self, spec, *, max_cost: float | None = None) -> Prepared:
        """Validate ``spec`` (400), apply the texel limit and the cost limit (413), key it."""
        nspec = _normalize(spec)
        axes = resolve_axes(nspec)
        texels = int(np.prod([len(a) for a in axes.values()])) if axes else 1
        if texels > self.settings.max_texels:
            sizes = " x ".join(str(len(a)) for a in axes.values())
            raise ServiceError(
                413, "too_many_texels",
                f"the table has {texels} texels ({sizes}); this service computes at most {self.settings.max_texels}",
                param="axes", allowed={"max_texels": self.settings.max_texels},
            )
        limit = self.settings.max_cost_seconds if max_cost is None else max_cost
        cost = estimate(nspec, scale=self.settings.cost_scale)
        if cost.seconds > limit:
            self.counters["rejected_cost"] += 1
            way = "POST /jobs for big work" if limit < self.settings.max_job_cost_seconds else "fewer texels"
            msg = (f"predicted cost {cost.seconds:.3g} core-seconds ({cost.texels} texels, method {cost.method}, "
                   f"{cost.per_integration:.2g} s per integration) is above this service's limit of {limit:g}; "
                   + ("use a coarser tolerance" if cost.method == "adaptive" else "use a lower effort")
                   + f", fewer texels, or {way}")
            raise cost_error(CostLimitError(",".join(cost.params), msg, cost, limit), axes)
        return Prepared(nspec=nspec, key=table_key(spec_hash(nspec), __version__), texels=texels, axes=axes,
                        cost=cost)

    def prepare_query(self, table: str, items: tuple, parse: Callable[[], tuple[dict, dict]],
                      check: Callable[[dict], object] | None = None) -> tuple[Prepared, dict]:
        """(:meth:`prepare` of the spec, the extra parameters) that ``parse()`` builds from query
        ``items``, memoized: a repeated query is normalized, priced and hashed once.

        ``check(extra)`` runs before the spec is prepared (the format's 406 comes before a 413).
        Only successes are remembered (an error is raised again by the next ``parse()``).
        """
        memo_key = (table, items)
        hit = self._memo.get(memo_key)
        if hit is not None:
            self._memo.move_to_end(memo_key)
            return hit
        spec, extra = parse()
        if check is not None:
            check(extra)
        hit = (self.prepare(spec), extra)
        self._memo[memo_key] = hit
        if len(self._memo) > MEMO_ENTRIES:
            self._memo.popitem(last=False)
        return hit

    async def prepare_key(self, key: str) -> Prepared:
        """The :class:`Prepared` of a table already in the cache, by its key (404 otherwise)."""
        if not _KEY_RE.match(key):
            raise ServiceError(404, "unknown_key", f"not a table key: {key[:80]!r}", param="key")
        name = f"{key}.{MASTER}"
        payload = self.memory.get(name) or await self._cache_get(name, validator(MASTER, key))
        if payload is None:
            raise ServiceError(404, "unknown_key", "no table of this key is in the cache (not computed, or "
                               "evicted): POST /jobs again", param="key")
        spec = Table.from_npz_bytes(payload).meta["spec"]
        prep = self.prepare(spec, max_cost=math.inf)  # computed already: no cost limit
        if prep.key != key:  # an entry of another release
            raise ServiceError(404, "unknown_key", "this key belongs to another version of the service", param="key")
        return prep

    async def cached_scene(self, name: str) -> bytes:
        """A planned scene's answer by its entry name (404 when not in the cache)."""
        if not _SCENE_RE.match(name):
            raise ServiceError(404, "unknown_key", f"not a scene key: {name[:80]!r}", param="name")
        payload = self.memory.get(name) or await self._cache_get(name, validator("scene", name))
        if payload is None:
            raise ServiceError(404, "unknown_key", "no scene of this key is in the cache: POST /jobs again",
                               param="name")
        return payload

    def cached(self, prep: Prepared, variant: str) -> bytes | None:
        """The bytes of a recently served entry, from memory (no I/O, no thread hop), else None."""
        return self.memory.get(f"{prep.key}.{variant}")

    async def variant(self, prep: Prepared, variant: str, derive=None, client=None) -> bytes:
        """Bytes of representation ``variant`` of the table (from a cache, else made once).

        ``derive(table) -> bytes`` makes it from the master table; the built-in formats need none.
        ``client()`` (an awaitable callable, e.g. ``request.is_disconnected``) says whether the
        requesting client has gone; when every waiter has gone the computation is cancelled.
        """
        name = f"{prep.key}.{variant}"
        payload = self.memory.get(name)
        if payload is not None:
            return payload
        if variant == MASTER:
            return await self.master(prep, client)
        payload = await self._cache_get(name, validator(variant, prep.key))
        if payload is not None:
            return payload
        make = derive or DERIVE[variant]

        async def produce() -> bytes:
            master = await self._master_flight(prep, self.settings.max_compute_seconds)
            loop = asyncio.get_running_loop()
            return await loop.run_in_executor(self.io_pool, self._derive_and_store, name, master, make)

        return await self.watch(prep.key, self.flight.run(name, produce), client, self.settings.max_compute_seconds)

    async def master(self, prep: Prepared, client=None, *, limit_seconds: float | None = None,
                     lane: str = "sync") -> bytes:
        """The ``npz`` master of the table: cached, or computed exactly once per key at a time.

        The caller is one waiter of the computation (see :meth:`watch`), for at most
        ``limit_seconds`` (default ``max_compute_seconds``), which is also the wall-clock limit of
        a computation this call starts; ``lane`` ``"job"`` runs it in the jobs' pool.
        """
        name = f"{prep.key}.{MASTER}"
        payload = self.memory.get(name)
        if payload is not None:
            return payload
        limit = self.settings.max_compute_seconds if limit_seconds is None else limit_seconds
        return await self.watch(prep.key, self._master_flight(prep, limit, lane), client, limit)

    async def _master_flight(self, prep: Prepared, limit_seconds: float, lane: str = "sync") -> bytes:
        name = f"{prep.key}.{MASTER}"
        payload = self.memory.get(name)
        if payload is None:
            payload = await self._cache_get(name, validator(MASTER, prep.key))
        if payload is not None:
            return payload
        return await self.flight.run(name, lambda: self._compute(prep, name, limit_seconds, lane))

    async def table(self, prep: Prepared) -> Table:
        master = await self.master(prep)
        return Table.from_npz_bytes(master)

    async def watch(self, key: str, awaitable: Awaitable, client=None, limit_seconds: float | None = None):
        """Await ``awaitable`` as one waiter of computation ``key``; the last waiter to leave cancels it.

        The waiter leaves when ``client()`` says its client has gone, or after ``limit_seconds``
        (503: ``busy`` if the computation is still queued, ``time_limit`` if it runs).
        """
        with self._lock:
            self._waiters_add(key, 1, limit_seconds)
        task = asyncio.ensure_future(awaitable)
        since = time.monotonic()
        overdue = False
        try:
            while True:
                done, _ = await asyncio.wait({task}, timeout=POLL_SECONDS)
                if done:
                    return task.result()
                if client is not None and await client():
                    self.counters["client_gone"] += 1
                    task.cancel()  # our shield on the shared task; the computation is the last waiter's call
                    raise ClientGone("the client disconnected while its table was computed")
                if limit_seconds is not None and time.monotonic() - since > limit_seconds:
                    overdue = True
                    task.cancel()
                    raise self._overdue(self.running.get(key), limit_seconds)
        except asyncio.CancelledError:
            task.cancel()
            raise
        finally:
            with self._lock:
                left = self._waiters_add(key, -1)
            if left <= 0:
                self._abandon(key, f"its last waiter left after waiting {limit_seconds:g} s" if overdue
                              else "every client waiting for it has gone")

    def _waiters_add(self, key: str, n: int, limit_seconds: float | None = None) -> int:  # with self._lock
        """Count a waiter of ``key`` in or out; a waiter's limit extends the computation's (a job that
        joins a computation a request started must not be stopped by the request's limit)."""
        counts = self._waiters
        counts[key] = counts.get(key, 0) + n
        left = counts[key]
        if limit_seconds is not None:
            self._limits[key] = max(self._limits.get(key, 0.0), limit_seconds)
        if left <= 0:
            del counts[key]
            self._limits.pop(key, None)
        comp = self.running.get(key)
        if comp is not None:
            comp.waiters = max(0, left)
            comp.limit_seconds = max(comp.limit_seconds, self._limits.get(key, 0.0))
        return left

    def _abandon(self, key: str, reason: str) -> None:
        """Nobody waits for computation ``key`` any more: cancel it, and forget its flights so that the
        next request starts afresh instead of joining a cancelled one. A queued computation's task is
        cancelled too (its place in the queue is freed now, its executor future never runs); a running
        one stops at its next chunk and keeps its place until then."""
        comp = self.running.get(key)
        if comp is not None:
            comp.cancel(reason)
        queued = comp is None or comp.started is None
        for task in self.flight.forget(lambda name: name == key or name.startswith(f"{key}.")):
            if queued:
                task.cancel()

    def _overdue(self, comp: Computation | None, limit_seconds: float) -> ServiceError:
        """The 503 of a waiter that waited ``limit_seconds``: still queued (busy) or not finished."""
        if comp is None or comp.started is None:
            self.counters["queue_timeout"] += 1
            return ServiceError(
                503, "busy", f"waited {limit_seconds:g} s for a compute slot ({self.waiting} computations running "
                             "or queued); try again later", headers={"Retry-After": "5"})
        self.counters["timed_out"] += 1  # the request's; the computation goes on if another waiter (a job) holds it
        return ServiceError(503, "time_limit", f"the computation did not finish within {limit_seconds:g} s")

    def progress_of(self, key: str) -> dict | None:
        comp = self.running.get(key)
        return None if comp is None else comp.status()

    # ------------------------------------------------------------------ internals

    async def _cache_get(self, name: str, validate=None) -> bytes | None:
        loop = asyncio.get_running_loop()
        payload = await loop.run_in_executor(self.io_pool, self.cache.get, name, validate)
        if payload is not None:
            self.memory.put(name, payload)
        return payload

    async def _compute(self, prep: Prepared, name: str, limit_seconds: float, lane: str = "sync") -> bytes:
        # a request that finished while we were scheduled (or a peer process) may have stored it
        payload = await self._cache_get(name, validator(MASTER, prep.key))
        if payload is not None:
            return payload
        self._admit(lane)
        comp = self._begin(prep.key, name, limit_seconds, lane)
        lock = self.cache.key_lock(name)
        try:
            while not lock.try_acquire():  # another process computes this key: wait for its entry
                await asyncio.sleep(PEER_POLL_SECONDS)
                payload = await self._cache_get(name, validator(MASTER, prep.key))
                if payload is not None:
                    self.counters["peer_computed"] += 1
                    return payload
                comp.progress(comp.done, comp.total)  # our waiters may have left, or the time run out
            try:
                payload = await self._cache_get(name, validator(MASTER, prep.key))
                if payload is not None:  # stored by a peer between our look and the lock
                    return payload
                loop = asyncio.get_running_loop()
                return await loop.run_in_executor(self._pool(lane), self._compute_and_store, prep, name, comp)
            finally:
                lock.release()
        except Cancelled as exc:
            raise self._cancelled(exc) from None
        finally:
            self._end(prep.key, comp)

    def _cancelled(self, exc: Cancelled) -> ServiceError:
        timed_out = "wall-clock" in exc.reason
        self.counters["timed_out" if timed_out else "cancelled"] += 1
        log.info("computation stopped: %s", exc.reason)
        return ServiceError(503, "time_limit" if timed_out else "cancelled", f"the computation stopped: {exc.reason}",
                            headers={} if timed_out else {"Retry-After": "1"})

    def _compute_and_store(self, prep: Prepared, name: str, comp: Computation) -> bytes:
        t0 = time.perf_counter()
        try:
            with self._counted(comp):
                comp.progress(0, prep.texels)
                # the module global is looked up at call time: tests monkeypatch it
                table = tabulate(prep.nspec, device=self.settings.device, workers=self.settings.workers,
                                 progress=comp.progress, **self.cluster())
        except Exception:
            if comp.cancel_reason is None:
                self.counters["failed"] += 1
            raise
        payload = table.to_npz_bytes()
        self._store(name, payload)
        log.info("computed %s (%d texels) in %.2f s", name, prep.texels, time.perf_counter() - t0)
        return payload

    async def run_scene(self, name: str, plan: Callable[[Callable[[str], None]], bytes], client=None,
                        limit_seconds: float | None = None, lane: str = "sync") -> bytes:
        """Run ``plan(checkpoint)`` (a scene) through the same queue, slots, counters and limits.

        ``checkpoint(line)`` is the planner's log callback: it raises :class:`Cancelled` when the
        scene's waiters are gone or its time is up.
        """
        limit = self.settings.max_compute_seconds if limit_seconds is None else limit_seconds

        async def produce() -> bytes:
            payload = await self._cache_get(name, validator("scene", name))
            if payload is not None:
                return payload
            return await self._in_lane(name, limit, lane, self._scene_and_store, name, plan)

        return await self.watch(name, self.flight.run(name, produce), client, limit)

    def _scene_and_store(self, comp: Computation, name: str, plan) -> bytes:
        steps = [0]

        def checkpoint(_line: str) -> None:
            steps[0] += 1
            comp.progress(steps[0], 0)

        with self._counted(comp, "scenes"):
            comp.progress(0, 0)
            payload = plan(checkpoint)
        self._store(name, payload)
        return payload

    def _derive_and_store(self, name: str, master: bytes, make) -> bytes:
        payload = make(Table.from_npz_bytes(master))
        self._store(name, payload)
        return payload

    def _store(self, name: str, payload: bytes) -> None:
        self.memory.put(name, payload)
        try:
            self.cache.put(name, payload)
        except OSError as exc:  # a full or read-only disk: serve anyway, uncached
            log.warning("cannot write cache entry %s: %s", name, exc)

    def warmup(self) -> None:
        """Load (compile on first use) the Warp kernels of every table kind."""
        from .warmup import warm_all

        warm_all(self.settings.device)

    def health(self) -> dict:
        with self._lock:
            running = [c.status() for c in self.running.values()]
        return {
            "status": "ok",
            "version": __version__,
            "pid": os.getpid(),
            "uptime_s": round(time.time() - self.started, 3),
            "computations": self.computations,
            "computing": self.computing,
            "queued": max(0, self.waiting - self.computing),
            "in_flight": len(self.flight),
            "compute_seconds": round(self.compute_seconds, 3),
            "running": running,
            **self.counters,
            "limits": {"max_cost_seconds": self.settings.max_cost_seconds,
                       "max_job_cost_seconds": self.settings.max_job_cost_seconds,
                       "max_compute_seconds": self.settings.max_compute_seconds,
                       "job_max_seconds": self.settings.job_max_seconds,
                       "max_concurrent": self.settings.max_concurrent,
                       "max_concurrent_jobs": self.settings.max_concurrent_jobs},
            "cache": self.cache.summary(),
            "memory": self.memory.summary(),
        }

    def shutdown(self) -> None:
        with self._lock:
            for comp in self.running.values():
                comp.cancel("the service is shutting down")
        self.compute_pool.shutdown(wait=False, cancel_futures=True)
        self.job_pool.shutdown(wait=False, cancel_futures=True)
        self.io_pool.shutdown(wait=False, cancel_futures=True)
        self.shutdown_cluster()

    def shutdown_cluster(self) -> None:
        """Close the Dask client (and the local cluster it started, if any)."""
        with self._lock:
            client, owned, self._client = self._client, self._owns_client, None
        if client is not None and owned:
            from bsdf_tab.cluster import close

            close(client)
