"""The background PTX compiles (tests/integrate/ptx_background.py) that the CUDA compile check
collects: a module that does not compile fails with NVRTC's own message, a worker that crashes
or hangs fails the module it was compiling (bounded: killed by PID after the timeout) and the
others still get their result, a worker that cannot start fails what it was given, and stop()
kills the worker. Small modules written here; each case starts real worker processes."""

from __future__ import annotations

import os
import textwrap
import threading
import time

import pytest

MODULES = {
    "ptxbg_good": """
        import warp as wp

        @wp.kernel
        def twice(a: wp.array(dtype=wp.float64)):
            i = wp.tid()
            a[i] = wp.float64(2.0) * a[i]
        """,
    # valid for Warp's code generator, rejected by NVRTC: the CUDA source itself is broken
    "ptxbg_bad": """
        import warp as wp

        @wp.func_native("return x +* 1.0;")
        def broken(x: wp.float64) -> wp.float64: ...

        @wp.kernel
        def uses_it(a: wp.array(dtype=wp.float64)):
            i = wp.tid()
            a[i] = broken(a[i])
        """,
    "ptxbg_crash": "import os\nos._exit(3)\n",
    "ptxbg_hang": "import time\ntime.sleep(3600)\n",
    "ptxbg_nokernel": "import warp as wp\n",  # compile_aot_module refuses it at once (no NVRTC)
}


@pytest.fixture
def make_job(tmp_path, ptx_background):
    src = tmp_path / "src"
    src.mkdir()
    for name, text in MODULES.items():
        (src / f"{name}.py").write_text(textwrap.dedent(text), encoding="utf-8")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(src), os.environ.get("PYTHONPATH", "")]))
    jobs = []

    def make(names, extra_path=None, **kw):
        e = dict(env)
        if extra_path is not None:
            e["PYTHONPATH"] = os.pathsep.join([str(extra_path), e["PYTHONPATH"]])
        job = ptx_background.BackgroundCompiles(names, env=e, out_dir=tmp_path / f"out{len(jobs)}", **kw)
        job.out.mkdir()
        jobs.append(job)
        return job

    yield make
    for job in jobs:
        job.stop()


def _gone(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return True
    return False


def test_good_module_gives_ptx_bad_one_the_compiler_message(make_job, ptx_background):
    job = make_job(["ptxbg_good", "ptxbg_bad"])
    job.start()
    good = job.result("ptxbg_good")
    assert good["ok"], ptx_background.failure_message("ptxbg_good", good)
    ptx = [p for p in good["paths"] if p.endswith(".ptx")]
    text = open(ptx[0], encoding="utf-8").read()
    assert ".target sm_90" in text and ".entry" in text
    bad = job.result("ptxbg_bad")
    assert not bad["ok"]
    message = ptx_background.failure_message("ptxbg_bad", bad)
    # NVRTC's diagnostic (printed by native code, not in the exception) reaches the failure
    assert "error" in bad["log"] and "+*" in bad["log"], bad["log"]
    assert "+*" in message and "build failed" in message, message
    assert len(job.pids) == 1  # one worker compiled both
    job.stop()
    assert not (job.out / "tmp").exists()  # NVRTC's precompiled header went with it


def test_a_crash_fails_that_module_and_the_rest_go_on(make_job):
    job = make_job(["ptxbg_crash", "ptxbg_nokernel"])
    job.start()
    crash = job.result("ptxbg_crash")
    assert not crash["ok"] and "exited with status 3 while compiling ptxbg_crash" in crash["error"]
    after = job.result("ptxbg_nokernel")
    assert not after["ok"] and "No compilable kernels" in after["error"], after  # a second worker ran it
    assert len(job.pids) == 2


def test_a_hang_is_killed_after_the_timeout_and_the_rest_go_on(make_job):
    job = make_job(["ptxbg_hang", "ptxbg_nokernel"], module_timeout=3.0)
    job.start()
    t0 = time.monotonic()
    got = {}
    waiter = threading.Thread(target=lambda: got.update(job.result("ptxbg_hang")), daemon=True)
    waiter.start()
    waiter.join(timeout=60)  # this test is bounded even where the wait is not
    waited = time.monotonic() - t0
    assert not waiter.is_alive(), "result() still waiting on a hung compile after 60 s"
    assert not got["ok"] and "ran over 3 s" in got["error"], got
    assert 3.0 <= waited < 30.0
    assert _gone(job.pids[0])
    after = job.result("ptxbg_nokernel")
    assert "No compilable kernels" in after["error"]
    assert len(job.pids) == 2


def test_a_worker_that_cannot_start_fails_its_modules(make_job, tmp_path):
    # a broken `warp` ahead on the path: the worker dies before it begins any module
    fake = tmp_path / "fake"
    fake.mkdir()
    (fake / "warp.py").write_text("raise ImportError('no warp in this test')\n", encoding="utf-8")
    job = make_job(["ptxbg_good", "ptxbg_nokernel"], extra_path=fake)
    job.start()
    for name in ("ptxbg_good", "ptxbg_nokernel"):
        r = job.result(name)
        assert not r["ok"] and f"before compiling {name}" in r["error"], r
        assert "no warp in this test" in r["log"]
    assert len(job.pids) == 1  # judged once, not restarted in a loop


def test_stop_kills_the_worker_by_pid(make_job):
    job = make_job(["ptxbg_hang"])
    job.start()
    pid = job.pids[0]
    deadline = time.monotonic() + 60
    while not (job.out / "ptxbg_hang.start").exists():  # bounded: the worker imports warp first
        assert time.monotonic() < deadline and job.proc.poll() is None
        time.sleep(0.05)
    assert not _gone(pid)
    job.stop()
    assert _gone(pid)
