"""Where and how texel kernels run: the device, resolved once, and chunks over worker threads.

A Warp CPU launch runs on one thread and releases the GIL, so W Python threads that launch on
disjoint index sets keep W cores busy. Texels are independent, so the result does not depend
on the number of workers or on the chunking (tested). On a CUDA device one thread launches
large chunks instead (:data:`CUDA_CHUNK`), in blocks of :func:`cuda_block_dim` threads.

The calling thread is one of the W workers; the other W - 1 are pool threads that persist: each
calling thread keeps one pool per worker count (thread-local, so concurrent computations never
queue behind each other's chunks), and a program that tabulates many small tables (the scene
planner: hundreds of calls) starts its threads once. Each worker takes the next chunk in a loop
(one hand-off between threads per worker, not per chunk), and the chunks shrink towards the end
so that the workers finish together.
A forked child drops the pools it inherited (their threads do not exist there).
"""

from __future__ import annotations

import os
import threading
from concurrent.futures import ThreadPoolExecutor, wait
from typing import Callable

import numpy as np
import warp as wp

ProgressFn = Callable[[int, int], None]

#: Threads per CUDA block: None for :func:`cuda_block_dim`'s rule, or a fixed number (benchmarks).
CUDA_BLOCK_DIM: int | None = None
#: Texels per CUDA launch (each launch is followed by a synchronize, for progress and cancellation):
#: 2^18, a 64^3 table in one launch (0.36 s on an H200 against 0.42 s in four of 2^16: each launch
#: waits for its slowest texel; bench/gpu_launch.py --chunks).
CUDA_CHUNK = 262144


def cuda_block_dim(n: int, device: wp.Device) -> int:
    """Threads per block for a CUDA launch of ``n`` texels (one thread each).

    32 while ``n`` is under 256 per multiprocessor, else 256 (Warp's default). One thread
    integrates one texel, so a 1024-texel table made 4 blocks of 256, on 4 of an H200's 132
    multiprocessors; blocks of 32 spread it over 32. Once blocks of 256 fill every multiprocessor,
    they are the faster (measured on an H200, ``bench/gpu_launch.py --sweep``: dielectric 16^3 in
    0.029 s with 32 against 0.053 s with 256, 32^3 even, 64^3 in 0.41 s with 256 against 0.52 s).
    """
    if CUDA_BLOCK_DIM is not None:
        return CUDA_BLOCK_DIM
    return 256 if n >= 256 * max(1, device.sm_count) else 32

_local = threading.local()  # .pools: {workers: ThreadPoolExecutor} of the calling thread


def _reset_after_fork() -> None:
    global _local
    _local = threading.local()  # the inherited executors have no threads in the child


if hasattr(os, "register_at_fork"):  # pragma: no branch - POSIX
    os.register_at_fork(after_in_child=_reset_after_fork)


def _pool(workers: int) -> ThreadPoolExecutor:
    """The calling thread's pool of ``workers`` threads (created on first use)."""
    pools = getattr(_local, "pools", None)
    if pools is None:
        pools = _local.pools = {}
    pool = pools.get(workers)
    if pool is None:
        pool = pools[workers] = ThreadPoolExecutor(max_workers=workers, thread_name_prefix="bsdf-tab-chunk")
    return pool


def default_workers() -> int:
    """Worker threads for CPU launches: the cores this process may use."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - non-Linux
        return max(1, os.cpu_count() or 1)


def check_workers(workers: int | None) -> int | None:
    """``workers`` itself, validated: None (all cores) or an integer >= 1."""
    if workers is None:
        return None
    if isinstance(workers, bool) or not isinstance(workers, (int, np.integer)) or workers < 1:
        # 0 used to mean "all cores" silently; None says that explicitly
        raise ValueError(f"workers must be an integer >= 1 (None: all cores), got {workers!r}")
    return int(workers)


def resolve_device(device: str | wp.Device | None) -> wp.Device:
    """The Warp device to use: the given one, else CUDA when present, else the CPU."""
    wp.init()
    if isinstance(device, wp.Device):
        return device
    if device is None:
        return wp.get_device("cuda:0") if wp.is_cuda_available() else wp.get_device("cpu")
    try:
        return wp.get_device(device)
    except Exception as exc:  # Warp raises plain RuntimeError for unknown devices
        raise ValueError(f"unknown or unavailable device {device!r}: {exc}") from None


def run_chunks(
    n: int,
    launch: Callable[[wp.array], None],
    device: wp.Device,
    *,
    workers: int | None = None,
    chunk: int | None = None,
    progress: ProgressFn | None = None,
    order: np.ndarray | None = None,
) -> None:
    """Call ``launch(idx)`` for chunks of texel indices covering ``range(n)`` once each.

    ``order`` permutes the texels before chunking (interleave cheap and expensive texels);
    ``progress(done, total)`` is called after each chunk, from the calling thread's lock.
    ``workers``: None for all cores, else >= 1 (ValueError otherwise; ignored on CUDA).

    Cancellation: an exception raised by ``progress`` (or by a launch) stops the computation
    between chunks: no chunk starts after it, the chunks already running finish, and the
    exception propagates to the caller (the service cancels abandoned requests this way).
    """
    workers = check_workers(workers)
    if n == 0:
        return
    ids = np.arange(n, dtype=np.int32) if order is None else np.asarray(order, dtype=np.int32)
    if device.is_cuda:
        workers = 1
        chunk = chunk or CUDA_CHUNK
    else:
        workers = workers or default_workers()
        chunk = chunk or max(1, min(32, -(-n // (8 * workers))))
    # one device array of all indices, chunks as views of it (an array per chunk cost ~50 us each)
    ids_w = wp.array(ids, dtype=wp.int32, device=device)
    # the first chunk runs alone (below): a few texels only, so that the other workers do not
    # wait for a whole chunk (1/16 of a 1024-texel table with chunks of 64)
    first = min(n, chunk, 4) if workers > 1 else min(n, chunk)
    pieces = [(0, first)]
    s = first
    while s < n:
        # guided: towards the end the chunks shrink (half of each worker's share of what is left,
        # at least 8 texels or the chunk asked for), so that the workers finish together
        size = chunk if workers == 1 else max(min(8, chunk), min(chunk, (n - s) // (2 * workers)))
        pieces.append((s, min(n, s + size)))
        s += size
    done = 0
    taken = 1  # pieces handed out (the first runs before the workers start)
    lock = threading.Lock()
    stop = threading.Event()  # set by the first failure: the remaining chunks do not start

    def work(piece: tuple[int, int]) -> None:
        nonlocal done
        if stop.is_set():
            return
        try:
            launch(ids_w[piece[0] : piece[1]])
            if device.is_cuda:
                wp.synchronize_device(device)
            with lock:
                done += piece[1] - piece[0]
                if progress is not None:
                    progress(done, n)
        except BaseException:
            stop.set()
            raise

    def worker() -> None:
        # each worker takes the next chunk until none is left: one hand-off between threads per
        # worker, not per chunk (a future per chunk cost ~50-80 us of wake-up on this VM)
        nonlocal taken
        while not stop.is_set():
            with lock:
                if taken >= len(pieces):
                    return
                piece = pieces[taken]
                taken += 1
            work(piece)

    # the first chunk runs here: it compiles/loads the module once, before threads race for it
    work(pieces[0])
    if workers == 1 or len(pieces) == 1:
        worker()
        return
    # the calling thread is one of the workers
    futures = [_pool(workers - 1).submit(worker) for _ in range(min(workers - 1, len(pieces) - 1))]
    try:
        worker()
    except BaseException:
        stop.set()
        wait(futures)  # the chunks already running finish before the caller sees the exception
        raise
    wait(futures)
    for fut in futures:
        fut.result()  # a worker's failure (stop is set: the others have finished)


def chunk_launcher(kernel, inputs: list, device: wp.Device) -> Callable[[wp.array], None]:
    """A ``launch(idx)`` for :func:`run_chunks`: ``kernel`` over the chunk ``idx`` (its first
    argument) with the other arguments ``inputs``. Each worker thread records the launch once
    (``wp.launch(..., record_cmd=True)``) and then only sets idx and the dimension: packing the
    adaptive kernel's 31 arguments took ~85 us per chunk, ~1.4 ms of CPU for a 1024-texel table
    (with the array per chunk that :func:`run_chunks` no longer makes, ~3 ms: ~5% of such a table
    at tolerance 1e-3)."""
    recorded = threading.local()

    def launch(idx: wp.array) -> None:
        block_dim = cuda_block_dim(idx.shape[0], device) if device.is_cuda else None
        cmds = getattr(recorded, "cmds", None)  # this thread's recorded launches, one per block size
        if cmds is None:
            cmds = recorded.cmds = {}
        cmd = cmds.get(block_dim)
        if cmd is None:
            cmd = cmds[block_dim] = wp.launch(kernel, dim=idx.shape[0], inputs=[idx, *inputs], device=device,
                                              record_cmd=True, block_dim=block_dim)
        else:
            cmd.set_param_at_index(0, idx)
        cmd.set_dim(idx.shape[0])
        cmd.launch()

    return launch


def texel_arrays(mu, alpha, eta, device: wp.Device):
    """Flat float64 copies of the texel inputs (eta = 1 when None) and their device arrays.

    Returns (mu, alpha, eta, mu_w, alpha_w, eta_w); ValueError when the lengths differ.
    """
    mu = np.ascontiguousarray(mu, dtype=np.float64).ravel()
    alpha = np.ascontiguousarray(alpha, dtype=np.float64).ravel()
    n = mu.size
    eta = np.ones(n) if eta is None else np.ascontiguousarray(eta, dtype=np.float64).ravel()
    if not (alpha.size == n and eta.size == n):
        raise ValueError("mu, alpha and eta must have the same number of texels")
    arrays = [wp.array(a, dtype=wp.float64, device=device) for a in (mu, alpha, eta)]
    return (mu, alpha, eta, *arrays)
