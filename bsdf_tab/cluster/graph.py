"""Tables as Dask tasks: chunks of an outer axis, submitted together, assembled as they finish.

Every table is cut along one axis (the kind's ``chunk_axis``, default the first: whole slices
keep the chunks regular) into chunks of about :func:`chunk_texels` texels. A chunk takes every
n-th slice (slices j, j + n, j + 2n, ...), not a run of neighbours: texels near grazing cost
several times more than the others, and interleaving spreads them over the chunks, so the
workers finish together. When one slice alone is more than a chunk (a 128^3 table has 128
slices of 16384 texels, too few tasks for hundreds of workers), the next axis is cut too, the
same way, so the number of tasks follows the number of workers, not the table's first axis. All chunks of all tables go to the scheduler at once (one graph:
the workers stay busy across table boundaries); :func:`completed` yields each table's channels
as soon as its last chunk is back. Tasks are pure: a worker lost mid-bake has its chunks rerun
elsewhere by the scheduler, with the same result.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, Iterator

import numpy as np

from ..tables import KINDS
from .worker import compute_chunk

__all__ = ["TableTasks", "chunk_texels", "chunks", "completed", "completed_chunks", "submit_table"]

#: Bounds of a chunk's size in texels: below, the scheduler's per-task cost (~10 ms round trip
#: on 2 cores) shows; above, too few tasks to balance the workers. 1024 since issue 14 made a
#: texel ~7x cheaper (256 before: albedo 64^2 and dielectric 16^3 measured 1.73 / 1.65x the
#: in-process time with it, 1.33 / 1.21x with 1024; bench/cluster.py, docs/cluster.md).
MIN_CHUNK_TEXELS = 1024
MAX_CHUNK_TEXELS = 16384


#: Chunks per worker: enough that the last chunks balance the workers (the texels' costs vary
#: by several times), few enough that the per-task cost stays small (measured: bench/cluster.py).
CHUNKS_PER_WORKER = 8


def chunk_texels(total: int, n_workers: int) -> int:
    """Texels per chunk: about :data:`CHUNKS_PER_WORKER` chunks per worker, within the bounds above."""
    want = -(-total // max(1, CHUNKS_PER_WORKER * n_workers))
    return int(min(MAX_CHUNK_TEXELS, max(MIN_CHUNK_TEXELS, want)))


def _interleaved(n_axis: int, n: int) -> list[np.ndarray]:
    return [np.arange(j, n_axis, n) for j in range(n)]


def chunks(sizes: list[int], axis: int, target: int) -> list[dict[int, np.ndarray]]:
    """The chunks of a table of shape ``sizes``, about ``target`` texels each.

    Each chunk is ``{axis: indices}`` (whole slices of ``axis``) or, when one slice is larger
    than ``target``, ``{axis: [i], other: indices}`` (part of one slice: ``other`` is the next
    axis). Chunk j of n along an axis holds the indices j, j + n, j + 2n, ... (interleaved).
    """
    per_slice = math.prod(s for i, s in enumerate(sizes) if i != axis)
    if per_slice <= target or len(sizes) == 1:
        n = -(-sizes[axis] // max(1, target // max(1, per_slice)))
        return [{axis: idx} for idx in _interleaved(sizes[axis], n)]
    other = next(i for i in range(len(sizes)) if i != axis)
    per_row = per_slice // sizes[other]
    n = -(-sizes[other] // max(1, target // max(1, per_row)))
    return [{axis: np.array([i]), other: idx} for i in range(sizes[axis]) for idx in _interleaved(sizes[other], n)]


@dataclass
class TableTasks:
    """The futures of one table's chunks, in axis order."""

    index: int
    axis: int
    shape: tuple[int, ...]
    spans: list[dict[int, np.ndarray]]
    futures: list
    texels: list[int]
    pending: set = field(default_factory=set)


def submit_table(client, index: int, nspec: dict, axes: dict, *, n_workers: int,
                 target: int | None = None, device: str | None = None) -> TableTasks:
    """Submit the chunks of one table; ``index`` identifies it in :func:`completed`."""
    axis = int(KINDS[nspec["table"]].get("chunk_axis", 0))
    sizes = [len(v) for v in axes.values()]
    total = math.prod(sizes)
    spans = chunks(sizes, axis, target or chunk_texels(total, n_workers))
    axes = {n: np.asarray(v, dtype=np.float64) for n, v in axes.items()}
    futures = [client.submit(compute_chunk, nspec, axes, cut, device, pure=True) for cut in spans]
    texels = [math.prod(len(cut[i]) if i in cut else s for i, s in enumerate(sizes)) for cut in spans]
    return TableTasks(index, axis, tuple(sizes), spans, futures, texels, set(range(len(futures))))


def completed(client, tables: list[TableTasks],
              progress: Callable[[int, int], None] | None = None) -> Iterator[tuple[int, dict]]:
    """Yield ``(index, channels)`` for each table as its last chunk completes.

    ``progress(done, total)`` counts texels of finished chunks over all tables. A failed chunk
    raises its exception here (the scheduler has already retried it on other workers).
    """
    from distributed import as_completed

    owner = {}
    for t in tables:
        for k, fut in enumerate(t.futures):
            owner[fut.key] = (t, k)
    total = sum(sum(t.texels) for t in tables)
    done = 0
    if progress is not None:
        progress(0, total)
    for fut in as_completed([f for t in tables for f in t.futures]):
        t, k = owner[fut.key]
        fut.result()  # raises the chunk's error, if any
        done += t.texels[k]
        t.pending.discard(k)
        if progress is not None:
            progress(done, total)
        if not t.pending:
            yield t.index, _assemble(t, client.gather(t.futures))


def _place(t: TableTasks, cut: dict) -> tuple:
    return np.ix_(*[cut[i] if i in cut else np.arange(s) for i, s in enumerate(t.shape)])


def _assemble(t: TableTasks, parts: list[dict]) -> dict:
    """The table's channels from its chunks (chunk k holds the indices ``t.spans[k]``)."""
    out = {n: np.empty(t.shape, dtype=np.asarray(v).dtype) for n, v in parts[0].items()}
    for cut, part in zip(t.spans, parts):
        where = _place(t, cut)
        for n, v in part.items():
            out[n][where] = v
    return out


def completed_chunks(client, table: TableTasks,
                     progress: Callable[[int, int], None] | None = None) -> Iterator[tuple[int, int, dict]]:
    """Yield ``(lo, lo + 1, channels)`` for each axis slice of one table, chunk by chunk as the
    chunks complete (any order; a streaming writer takes any order). Chunks must be whole
    slices of axis 0 (a table cut on a second axis is assembled with :func:`completed`).

    Each chunk's result leaves the cluster once yielded, so a writer holds one chunk at a time.
    """
    if table.axis != 0 or any(len(cut) > 1 for cut in table.spans):
        raise ValueError("completed_chunks needs chunks of whole axis-0 slices")
    from distributed import as_completed

    index = {fut.key: k for k, fut in enumerate(table.futures)}
    total, done = sum(table.texels), 0
    if progress is not None:
        progress(0, total)
    for fut in as_completed(list(table.futures)):
        k = index[fut.key]
        channels = fut.result()
        table.futures[k] = None  # release it on the cluster
        done += table.texels[k]
        if progress is not None:
            progress(done, total)
        for j, i in enumerate(table.spans[k][0]):
            yield int(i), int(i) + 1, {n: np.take(v, [j], axis=0) for n, v in channels.items()}
