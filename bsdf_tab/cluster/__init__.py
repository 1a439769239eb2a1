"""Baking on a Dask cluster (optional: ``pip install 'dask[distributed]'``).

``bsdf_tab.tabulate(spec, scheduler=...)`` and :func:`bsdf_tab.api.tabulate_many` take a
``distributed.Client``, a scheduler address (``tcp://host:8786``) or ``"local:N"`` (a
``LocalCluster`` of N worker processes, one thread each). Each table is cut into chunks of an
outer axis; each chunk runs the same Warp kernels on the worker's own device; the chunks are
assembled into the same :class:`~bsdf_tab.table.Table`, bit for bit the in-process result for
any number of workers and any chunking. Without a scheduler nothing here is imported.

Modules: :mod:`.connect` (client from an argument, the worker plugin), :mod:`.worker` (what
runs on a worker), :mod:`.graph` (chunks, submission, assembly).
"""

from .connect import SchedulerError, close, connect, dashboard_link, parse_scheduler
from .graph import TableTasks, chunk_texels, chunks, completed, completed_chunks, submit_table
from .worker import WarpWorker, compute_chunk

__all__ = [
    "SchedulerError",
    "TableTasks",
    "WarpWorker",
    "chunk_texels",
    "chunks",
    "close",
    "completed",
    "completed_chunks",
    "compute_chunk",
    "connect",
    "dashboard_link",
    "parse_scheduler",
    "submit_table",
]
