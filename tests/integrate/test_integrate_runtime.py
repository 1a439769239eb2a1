"""The integrators' runtime: worker validation, results independent of workers and chunking."""

import numpy as np
import pytest

from bsdf_tab.integrate import METHODS
from bsdf_tab.integrate.runtime import check_workers, run_chunks, resolve_device


@pytest.mark.parametrize("workers", [0, -1, 1.5, True, "2"])
def test_workers_below_one_or_not_an_integer_is_rejected(workers):
    with pytest.raises(ValueError, match="workers"):
        check_workers(workers)
    with pytest.raises(ValueError, match="workers"):
        run_chunks(4, lambda idx: None, resolve_device("cpu"), workers=workers)


@pytest.mark.parametrize("method", sorted(METHODS))
def test_every_method_rejects_workers_zero(method):
    """0 used to mean "all cores" silently; None says that. Rejected before any kernel runs."""
    with pytest.raises(ValueError, match="workers"):
        METHODS[method]("reflect", np.array([0.5]), np.array([0.5]), device="cpu", workers=0)


def test_none_means_all_cores_and_one_is_fine():
    assert check_workers(None) is None and check_workers(1) == 1 and check_workers(np.int64(3)) == 3
    seen = []
    run_chunks(10, lambda idx: seen.extend(idx.numpy().tolist()), resolve_device("cpu"), workers=None, chunk=3)
    assert sorted(seen) == list(range(10))


def test_adaptive_does_not_depend_on_workers_or_chunking():
    rng = np.random.default_rng(3)
    mu, alpha = rng.uniform(0, 1, 70), 10 ** rng.uniform(-3, 0, 70)  # > 64: interleaved order
    a = METHODS["adaptive"]("reflect", mu, alpha, workers=1, tol=1e-5)
    b = METHODS["adaptive"]("reflect", mu, alpha, workers=2, tol=1e-5)
    c = METHODS["adaptive"]("reflect", mu[5:9], alpha[5:9], workers=1, tol=1e-5)
    assert all(np.array_equal(x, y) for x, y in zip(a, b))
    assert np.array_equal(a[0][5:9], c[0]) and np.array_equal(a[1][5:9], c[1])


def test_an_exception_from_progress_stops_the_remaining_chunks():
    # the service cancels abandoned computations by raising from the progress callback: with
    # several worker threads no chunk may start after it (was: every queued chunk still ran)
    import threading

    from bsdf_tab.integrate.runtime import resolve_device, run_chunks

    launched = []
    lock = threading.Lock()

    def launch(idx):
        with lock:
            launched.append(idx.shape[0])

    class Stop(Exception):
        pass

    def progress(done, total):
        if done >= 3:
            raise Stop()

    dev = resolve_device("cpu")
    with pytest.raises(Stop):
        run_chunks(1000, launch, dev, workers=2, chunk=1, progress=progress)
    assert len(launched) < 20  # 1000 chunks of one texel: stopped within a few of the third


class _FakeCuda:
    """What cuda_block_dim reads of a device: its multiprocessor count (an H200 has 132)."""

    def __init__(self, sm_count):
        self.sm_count = sm_count


@pytest.mark.parametrize(
    "n,sm_count,expected",
    [(1024, 132, 32), (4096, 132, 32), (256 * 132 - 1, 132, 32), (256 * 132, 132, 256), (262144, 132, 256),
     (1024, 4, 256), (1, 0, 32)],
)
def test_cuda_block_size_follows_the_launch_size(n, sm_count, expected, monkeypatch):
    """32 threads per block until blocks of 256 fill every multiprocessor (bench/gpu_launch.py
    --sweep on an H200: 16^3 texels 1.8x faster with 32, 64^3 1.27x faster with 256); a fixed
    size set for a benchmark wins."""
    from bsdf_tab.integrate import runtime

    assert runtime.cuda_block_dim(n, _FakeCuda(sm_count)) == expected
    monkeypatch.setattr(runtime, "CUDA_BLOCK_DIM", 64)
    assert runtime.cuda_block_dim(n, _FakeCuda(sm_count)) == 64


@pytest.mark.parametrize("n", [1, 5, 37, 300, 1031])
def test_guided_chunks_cover_every_texel_once_and_shrink_to_eight(n):
    import threading

    sizes, seen = [], []
    lock = threading.Lock()

    def launch(idx):
        with lock:
            sizes.append(idx.shape[0])
            seen.extend(idx.numpy().tolist())

    run_chunks(n, launch, resolve_device("cpu"), workers=2)
    assert sorted(seen) == list(range(n))
    # the first chunk (<= 4 texels) runs alone; the others are at most the default chunk
    # (n / 16, 1 .. 32 texels) and, but for the last, at least 8 texels or that chunk
    chunk = max(1, min(32, -(-n // 16)))
    rest = sorted(sizes)[1:] if len(sizes) > 1 else []
    assert max(sizes) <= max(chunk, 4) and all(s >= min(8, chunk) for s in rest[1:])


def test_a_launch_failing_in_a_pool_thread_reaches_the_caller():
    import threading

    caller = threading.get_ident()

    class Boom(Exception):
        pass

    def launch(idx):
        if threading.get_ident() != caller:
            raise Boom()
        # the calling thread is slow enough for a pool thread to take a chunk
        import time

        time.sleep(0.002)

    with pytest.raises(Boom):
        run_chunks(200, launch, resolve_device("cpu"), workers=2, chunk=4)
