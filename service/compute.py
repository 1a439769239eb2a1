"""From a spec to response bytes: validate, look up the cache, compute once, derive formats.

:class:`TableStore` is the one object the routes talk to. A request goes

1. :meth:`TableStore.prepare`: normalize the spec (``SpecError`` -> 400), check the texel limit
   (-> 413), compute the cache key. Cheap; runs on the event loop.
2. :meth:`TableStore.variant`: the bytes of one representation (``exr``, ``npz``, ``npy``,
   ``json``, ``info``, ``png-...``). A cache hit is read (and checksum-verified) in a small I/O
   thread pool. A miss goes through :class:`~service.cache.SingleFlight` keyed by the entry
   name, so concurrent requests share one derivation, which itself needs the ``npz`` master,
   again single-flight, and only a master miss calls :func:`tabulate`.
3. Computations run in a :class:`~concurrent.futures.ThreadPoolExecutor` of
   ``settings.max_concurrent`` threads (each ``tabulate`` call uses ``settings.workers``
   threads of its own), never on the event loop; at most ``settings.max_queued`` distinct
   tables wait for a slot (more -> 503 with ``Retry-After``).

``tabulate`` is looked up on this module at call time, so tests can monkeypatch
``service.compute.tabulate`` to count computations.
"""

from __future__ import annotations

import asyncio
import json
import logging
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np

from bsdf_tab import __version__
from bsdf_tab.api import tabulate  # noqa: F401  (monkeypatch point)
from bsdf_tab.errors import SpecError
from bsdf_tab.spec import normalize_spec, resolve_axes, spec_hash, texel_count
import bsdf_tab.io as bsdf_io
from bsdf_tab.io import json_default
from bsdf_tab.io.json import finite_json
from bsdf_tab.table import Table

from .cache import DiskCache, SingleFlight, table_key
from .errors import ServiceError
from .settings import Settings

__all__ = ["TableStore", "Prepared"]

log = logging.getLogger("bsdf_tab.service")

MASTER = "npz"


@dataclass(frozen=True)
class Prepared:
    """A validated request: normalized spec, its resolved axes and cache key."""

    nspec: dict
    key: str
    texels: int
    axes: dict

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


class TableStore:
    """Cache + single flight + bounded executors around :func:`bsdf_tab.tabulate`."""

    def __init__(self, settings: Settings) -> None:
        self.settings = settings
        self.cache = DiskCache(settings.cache_dir, settings.cache_max_bytes)
        self.flight = SingleFlight()
        self.compute_pool = ThreadPoolExecutor(settings.max_concurrent, thread_name_prefix="bsdf-tab-compute")
        self.io_pool = ThreadPoolExecutor(4, thread_name_prefix="bsdf-tab-io")
        self.computations = 0  # tabulate calls that finished (or failed)
        self.computing = 0  # tabulate calls running now
        self.waiting = 0  # masters waiting for a compute slot or running
        self.compute_seconds = 0.0
        self._lock = threading.Lock()
        self.started = time.time()

    # ------------------------------------------------------------------ requests

    def prepare(self, spec) -> Prepared:
        """Validate ``spec`` (400 naming the parameter), apply the texel limit (413), key it."""
        nspec = _normalize(spec)
        texels = texel_count(nspec)
        if texels > self.settings.max_texels:
            sizes = " x ".join(
                str(len(a["values"]) if "values" in a else a["size"]) for a in nspec["axes"].values()
            )
            raise ServiceError(
                413, "too_many_texels",
                f"the table has {texels} texels ({sizes}); this service computes at most {self.settings.max_texels}",
                param="axes", allowed={"max_texels": self.settings.max_texels},
            )
        try:
            axes = resolve_axes(nspec)
        except SpecError:
            raise
        return Prepared(nspec=nspec, key=table_key(spec_hash(nspec), __version__), texels=texels, axes=axes)

    async def variant(self, prep: Prepared, variant: str, derive=None) -> bytes:
        """Bytes of representation ``variant`` of the table (from cache, else made once).

        ``derive(table) -> bytes`` makes it from the master table; the built-in formats need none.
        """
        if variant == MASTER:
            return await self.master(prep)
        name = f"{prep.key}.{variant}"
        payload = await self._cache_get(name)
        if payload is not None:
            return payload
        make = derive or _DERIVE[variant]

        async def produce() -> bytes:
            master = await self.master(prep)
            loop = asyncio.get_running_loop()
            return await loop.run_in_executor(self.io_pool, self._derive_and_store, name, master, make)

        return await self.flight.run(name, produce)

    async def master(self, prep: Prepared) -> bytes:
        """The ``npz`` master of the table: cached, or computed exactly once per key at a time."""
        name = f"{prep.key}.{MASTER}"
        payload = await self._cache_get(name)
        if payload is not None:
            return payload
        return await self.flight.run(name, lambda: self._compute(prep, name))

    async def table(self, prep: Prepared) -> Table:
        master = await self.master(prep)
        return Table.from_npz_bytes(master)

    # ------------------------------------------------------------------ internals

    async def _cache_get(self, name: str) -> bytes | None:
        loop = asyncio.get_running_loop()
        return await loop.run_in_executor(self.io_pool, self.cache.get, name)

    async def _compute(self, prep: Prepared, name: str) -> bytes:
        loop = asyncio.get_running_loop()
        # a request that finished while we were scheduled may have stored it
        payload = await loop.run_in_executor(self.io_pool, self.cache.get, name)
        if payload is not None:
            return payload
        limit = self.settings.max_concurrent + self.settings.max_queued
        if self.waiting >= limit:
            raise ServiceError(
                503, "busy", f"{self.waiting} tables are being computed or queued; try again later",
                headers={"Retry-After": "5"},
            )
        self.waiting += 1
        try:
            return await loop.run_in_executor(self.compute_pool, self._compute_and_store, prep, name)
        finally:
            self.waiting -= 1

    def _compute_and_store(self, prep: Prepared, name: str) -> bytes:
        payload = self.cache.get(name)  # stored by another process sharing the folder
        if payload is not None:
            return payload
        with self._lock:
            self.computing += 1
        t0 = time.perf_counter()
        try:
            # the module global is looked up at call time: tests monkeypatch it
            table = tabulate(prep.nspec, device=self.settings.device, workers=self.settings.workers)
        finally:
            with self._lock:
                self.computing -= 1
                self.computations += 1
                self.compute_seconds += time.perf_counter() - t0
        payload = table.to_npz_bytes()
        self._store(name, payload)
        log.info("computed %s (%d texels) in %.2f s", name, prep.texels, time.perf_counter() - t0)
        return payload

    def _derive_and_store(self, name: str, master: bytes, make) -> bytes:
        payload = make(Table.from_npz_bytes(master))
        self._store(name, payload)
        return payload

    def _store(self, name: str, payload: bytes) -> None:
        try:
            self.cache.put(name, payload)
        except OSError as exc:  # a full or read-only disk: serve anyway, uncached
            log.warning("cannot write cache entry %s: %s", name, exc)

    def warmup(self) -> None:
        """Load (compile on first use) the Warp kernels of every table kind."""
        from .warmup import warm_all

        warm_all(self.settings.device)

    def health(self) -> dict:
        return {
            "status": "ok",
            "version": __version__,
            "uptime_s": round(time.time() - self.started, 3),
            "computations": self.computations,
            "computing": self.computing,
            "queued": max(0, self.waiting - self.computing),
            "in_flight": len(self.flight),
            "compute_seconds": round(self.compute_seconds, 3),
            "cache": self.cache.summary(),
        }

    def shutdown(self) -> None:
        self.compute_pool.shutdown(wait=False, cancel_futures=True)
        self.io_pool.shutdown(wait=False, cancel_futures=True)


# ---------------------------------------------------------------------- representations
# The file formats are bsdf_tab.io's (one meaning per name, the same bytes as the CLI writes);
# ``info`` is the service's own summary.


def to_exr(table: Table) -> bytes:
    """The float32 EXR file (:mod:`bsdf_tab.io.exr`)."""
    return bsdf_io.to_bytes(table, "exr")


def to_npy(table: Table) -> bytes:
    """One structured ``.npy`` array shaped by the axes, a float64 field per channel.

    (:mod:`bsdf_tab.io.npy`; ``np.load(..., allow_pickle=False)`` reads it; axes are in the
    npz / JSON / EXR forms.)
    """
    return bsdf_io.to_bytes(table, "npy")


def to_json(table: Table) -> bytes:
    """The table as strict, compact JSON (:mod:`bsdf_tab.io.json`)."""
    return bsdf_io.to_bytes(table, "json")


def to_info(table: Table) -> bytes:
    """Metadata without the data: spec, conventions, method, max error, axes summary."""
    meta = finite_json(json.loads(json.dumps(table.meta, default=json_default)))
    info = {
        "table": table.kind,
        "shape": list(table.shape),
        "axes": {
            n: {"size": int(len(a)), "min": float(a.min()), "max": float(a.max())} for n, a in table.axes.items()
        },
        "channels": list(table.channels),
        "max_error": {k: (v if np.isfinite(v) else None) for k, v in table.max_error().items()},
        "conventions": meta.get("conventions"),
        "method": meta.get("method"),
        "spec": meta.get("spec"),
        "version": meta.get("version"),
    }
    return json.dumps(info, allow_nan=False).encode()


#: variant -> how it is made from the master table (the master itself is ``MASTER``)
_DERIVE = {"exr": to_exr, "npy": to_npy, "json": to_json, "info": to_info}
