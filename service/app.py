"""The FastAPI app: ``create_app()`` wires settings, the table store, routes and error handlers.

``uvicorn service.app:app`` serves the module-level :data:`app` (settings from ``BSDF_TAB_*``
environment variables); ``bsdf-tab serve`` builds one with :func:`create_app` from its options.
Nothing heavy happens at import: the cache folder is created and scanned on first use.
"""

from __future__ import annotations

import asyncio
import logging
from contextlib import asynccontextmanager

from fastapi import FastAPI, Request
from fastapi.responses import JSONResponse

from bsdf_tab import __version__
from bsdf_tab.api import quiet_warp

from .compute import TableStore
from .errors import ServiceError, install_handlers
from .hotpath import HotPath
from .jobs import Jobs
from .routes import jobs as jobs_routes
from .routes import check, pages, scenes, tables
from .settings import Settings

__all__ = ["create_app", "app"]

log = logging.getLogger("bsdf_tab.service")

DESCRIPTION = """Microfacet BSDF lookup tables (albedo, dielectric R/T, DFG), computed with Warp kernels,
cached by the canonical hash of their spec, returned as OpenEXR (default), NumPy or JSON.

Errors are JSON `{"error": {"status", "code", "param", "query_param", "message", "allowed"}}`."""


async def _warm_in_turns(store: TableStore) -> None:
    """Load the Warp kernels of every table kind, one kind per task of the compute pool.

    A request that arrives meanwhile queues behind the one kind being warmed, not behind all
    of them (one task for every kind made the first request of a fresh service wait about
    0.5 core-seconds for kinds it did not ask for)."""
    from .warmup import warm_kind, warm_kinds

    loop = asyncio.get_running_loop()
    for kind in warm_kinds():
        await loop.run_in_executor(store.compute_pool, warm_kind, kind, store.settings.device)
    # the landing page's table (GET / without a query): a cache hit from now on, never queued behind work
    try:
        await store.variant(store.prepare({"table": pages.DEFAULT_TABLE}), "info")
    except ServiceError as exc:  # limits below the default table: the page fits one when asked
        log.info("landing page table not prepared: %s", exc.message)


def create_app(settings: Settings | None = None) -> FastAPI:
    """Build the service.

    Parameters
    ----------
    settings : Settings, optional
        Defaults to ``Settings()`` (environment variables ``BSDF_TAB_*``).
    """
    settings = settings or Settings()
    quiet_warp()
    store = TableStore(settings)
    jobs = Jobs(store)

    @asynccontextmanager
    async def lifespan(app: FastAPI):
        warm = None
        if settings.warmup:  # in the background, one kind per compute-pool task (_warm_in_turns)
            warm = asyncio.get_running_loop().create_task(_warm_in_turns(store))
        try:
            resumed = jobs.recover()  # jobs a dead process left queued or running
            if resumed:
                log.info("resumed %d job(s)", resumed)
        except Exception as exc:  # an unreadable job database must not keep the service down
            log.warning("cannot recover jobs from %s: %s", jobs.db.path, exc)
        try:
            yield
        finally:
            if warm is not None and not warm.done():
                warm.cancel()
            await jobs.shutdown()
            store.shutdown()

    app = FastAPI(
        title="bsdf-tab",
        version=__version__,
        description=DESCRIPTION,
        lifespan=lifespan,
    )
    app.state.settings = settings
    app.state.store = store
    app.state.jobs = jobs
    app.state.hot = None
    install_handlers(app)
    app.add_middleware(HotPath, memory=store.memory, state=app.state)  # outermost: repeated GETs from memory
    app.include_router(tables.router)
    app.include_router(pages.router)
    app.include_router(scenes.router)
    app.include_router(jobs_routes.router)
    app.include_router(check.router)

    @app.head("/healthz", include_in_schema=False)  # load balancers probe with HEAD
    @app.get("/healthz", tags=["health"], summary="Liveness and counters (never waits on a computation)")
    async def healthz(request: Request) -> JSONResponse:
        hot = app.state.hot.summary() if app.state.hot is not None else None
        return JSONResponse({**store.health(), "jobs": jobs.health(), "hot_path": hot},
                            headers={"Cache-Control": "no-store"})

    return app


app = create_app()
