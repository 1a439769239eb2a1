"""Tables as Dask tasks: chunks of an outer axis, submitted together, assembled as they finish.

Every table is cut along one axis (the kind's ``chunk_axis``, default the first: whole slices
keep the chunks regular) into chunks of about :func:`chunk_texels` texels. A chunk takes every
n-th slice (slices j, j + n, j + 2n, ...), not a run of neighbours: texels near grazing cost
several times more than the others, and interleaving spreads them over the chunks, so the
workers finish together. All chunks of all tables go to the scheduler at once (one graph:
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

#: Bounds of a chunk's size in texels: below, the scheduler's per-task cost (~ms) shows;
#: above, too few tasks to balance the workers.
MIN_CHUNK_TEXELS = 256
MAX_CHUNK_TEXELS = 16384


def chunk_texels(total: int, n_workers: int) -> int:
    """Texels per chunk: about four chunks per worker, within the bounds above."""
    want = -(-total // max(1, 4 * n_workers))
    return int(min(MAX_CHUNK_TEXELS, max(MIN_CHUNK_TEXELS, want)))


def chunks(n_axis: int, per_slice: int, target: int) -> list[np.ndarray]:
    """Slice indices of each chunk of an axis of ``n_axis`` values, about ``target`` texels each.

    Chunk j of n holds the slices j, j + n, j + 2n, ... (interleaved: see the module docstring).
    """
    per_chunk = max(1, target // max(1, per_slice))
    n = -(-n_axis // per_chunk)
    return [np.arange(j, n_axis, n) for j in range(n)]


@dataclass
class TableTasks:
    """The futures of one table's chunks, in axis order."""

    index: int
    axis: int
    spans: list[np.ndarray]
    futures: list
    texels: list[int]
    pending: set = field(default_factory=set)


def submit_table(client, index: int, nspec: dict, axes: dict, *, n_workers: int,
                 target: int | None = None, device: str | None = None) -> TableTasks:
    """Submit the chunks of one table; ``index`` identifies it in :func:`completed`."""
    axis = int(KINDS[nspec["table"]].get("chunk_axis", 0))
    sizes = [len(v) for v in axes.values()]
    per_slice = math.prod(s for i, s in enumerate(sizes) if i != axis)
    total = math.prod(sizes)
    spans = chunks(sizes[axis], per_slice, target or chunk_texels(total, n_workers))
    axes = {n: np.asarray(v, dtype=np.float64) for n, v in axes.items()}
    futures = [client.submit(compute_chunk, nspec, axes, axis, idx, device, pure=True) for idx in spans]
    texels = [len(idx) * per_slice for idx in spans]
    return TableTasks(index, axis, spans, futures, texels, set(range(len(futures))))


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


def _assemble(t: TableTasks, parts: list[dict]) -> dict:
    """The table's channels from its chunks (each holding the slices ``t.spans[k]``)."""
    order = np.concatenate(t.spans)
    back = np.empty_like(order)
    back[order] = np.arange(order.size)  # position of slice i in the concatenation
    return {n: np.take(np.concatenate([p[n] for p in parts], axis=t.axis), back, axis=t.axis) for n in parts[0]}


def completed_chunks(client, table: TableTasks,
                     progress: Callable[[int, int], None] | None = None) -> Iterator[tuple[int, int, dict]]:
    """Yield ``(lo, lo + 1, channels)`` for each axis slice of one table, chunk by chunk as the
    chunks complete (any order; a streaming writer takes any order).

    Each chunk's result leaves the cluster once yielded, so a writer holds one chunk at a time.
    """
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
        for j, i in enumerate(table.spans[k]):
            yield int(i), int(i) + 1, {n: np.take(v, [j], axis=table.axis) for n, v in channels.items()}
