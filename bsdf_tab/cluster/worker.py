"""What runs on a Dask worker: Warp set up once per process, and one chunk of a table.

A chunk is a set of indices along one or two axes of a normalized spec's resolved axes. The table kinds
compute texels independently, so the slices assembled on the client are the in-process
table bit for bit (tested), whatever the chunking and the number of workers.
"""

from __future__ import annotations

import os

import numpy as np

__all__ = ["WarpWorker", "compute_chunk"]

try:  # a WorkerPlugin subclass when Dask is installed; a plain class otherwise (never used then)
    from distributed.diagnostics.plugin import WorkerPlugin as _Base
except ImportError:  # pragma: no cover - the library without the optional dependency
    _Base = object


class WarpWorker(_Base):
    """Initializes Warp once per worker process, with a shared kernel cache if given."""

    def __init__(self, warp_cache: str | None = None) -> None:
        self.warp_cache = warp_cache

    def setup(self, worker) -> None:
        if self.warp_cache:
            os.environ["WARP_CACHE_PATH"] = self.warp_cache  # read by wp.init()
        import warp as wp

        wp.config.log_level = getattr(wp, "LOG_WARNING", 30)
        wp.config.quiet = True
        wp.init()


def _worker_threads() -> int | None:
    try:
        from distributed import get_worker

        return max(1, int(get_worker().state.nthreads))
    except (ImportError, ValueError, AttributeError):  # not on a worker (tests call it directly)
        return None


def compute_chunk(nspec: dict, axes: dict, cut: dict, device: str | None = None) -> dict:
    """The channels of the sub-table ``cut`` (axis number -> indices) of a normalized spec's table.

    Runs on the worker's own device (CUDA when the worker has one, as dask-cuda pins one GPU
    per worker; else the CPU with the worker's thread count).
    """
    from ..integrate.runtime import resolve_device
    from ..tables import KINDS, Context

    names = list(axes)
    sub = {n: (np.asarray(v)[np.asarray(cut[i], dtype=np.int64)] if i in cut else np.asarray(v))
           for i, (n, v) in enumerate(axes.items())}
    sub = {n: sub[n] for n in names}
    ctx = Context(resolve_device(device), _worker_threads(), None)
    channels = KINDS[nspec["table"]]["compute"](nspec, sub, ctx)
    return {k: np.ascontiguousarray(v) for k, v in channels.items()}
