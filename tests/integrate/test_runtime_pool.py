"""run_chunks keeps its worker threads between calls, per calling thread, and after a fork."""

from __future__ import annotations

import os
import threading

import numpy as np
import pytest
import warp as wp

from bsdf_tab.integrate.runtime import run_chunks


def _chunk_threads():
    return {t.ident for t in threading.enumerate() if t.name.startswith("bsdf-tab-chunk")}


def _run(n, workers, seen=None):
    device = wp.get_device("cpu")
    out = np.zeros(n, dtype=np.int64)

    def launch(idx):
        ids = idx.numpy()
        out[ids] += 1
        if seen is not None:
            seen.add(threading.get_ident())

    run_chunks(n, launch, device, workers=workers, chunk=1)
    return out


def test_every_index_once_and_the_threads_are_reused():
    """From a fresh calling thread (its pools are its own: earlier tests' threads do not count)."""
    wp.init()
    result = {}

    def caller():
        before = _chunk_threads()
        ok = (_run(50, 2) == 1).all()
        first = _chunk_threads() - before
        for _ in range(20):  # bounded: twenty more tabulations from this thread
            ok = ok and (_run(17, 2) == 1).all()
        result.update(ok=ok, first=first, later=_chunk_threads() - before)

    t = threading.Thread(target=caller)
    t.start()
    t.join(timeout=120)
    assert result["ok"]
    assert 1 <= len(result["first"]) <= 2  # this caller's pool started its threads once
    assert result["later"] == result["first"]  # and no new ones on the next twenty calls


def test_concurrent_callers_have_their_own_pools():
    wp.init()
    seen = [set(), set()]
    barrier, both_ran = threading.Barrier(2), threading.Barrier(2)

    def caller(k):
        barrier.wait(timeout=30)
        assert (_run(40, 2, seen[k]) == 1).all()
        # both callers (so both pools and their threads) stay alive until both have run: a
        # finished caller's pool threads exit, and a later thread may reuse their ident
        both_ran.wait(timeout=30)

    threads = [threading.Thread(target=caller, args=(k,)) for k in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(timeout=60)
    # each caller ran its first chunk itself and the rest on its own pool's threads
    pool_threads = [s - {t.ident for t in threads} for s in seen]
    assert pool_threads[0] and pool_threads[1]
    assert not (pool_threads[0] & pool_threads[1])


@pytest.mark.skipif(not hasattr(os, "fork"), reason="POSIX fork")
def test_a_forked_child_starts_fresh_threads():
    wp.init()
    _run(10, 2)  # this thread now has a pool; a child must not use its (absent) threads
    pid = os.fork()
    if pid == 0:  # child: a deadlock here would hang; the parent waits with a bound
        try:
            ok = (_run(10, 2) == 1).all()
        finally:
            os._exit(0 if ok else 3)
    for _ in range(600):  # bounded wait: 60 s
        done, status = os.waitpid(pid, os.WNOHANG)
        if done:
            break
        threading.Event().wait(0.1)
    else:
        os.kill(pid, 9)
        os.waitpid(pid, 0)
        pytest.fail("the forked child hung on the inherited pool")
    assert os.waitstatus_to_exitcode(status) == 0
