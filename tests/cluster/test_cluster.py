"""Baking on a Dask cluster: a LocalCluster of worker processes and real `dask scheduler` /
`dask worker` processes started here, on 127.0.0.1, and stopped by PID.

The truth is the in-process table: the cluster path must give it bit for bit, for any number of
workers and any chunking, also when a worker is killed mid-bake (its chunks rerun elsewhere).
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

distributed = pytest.importorskip("distributed")

import bsdf_tab  # noqa: E402
from bsdf_tab import api, cluster  # noqa: E402
from bsdf_tab.spec import normalize_spec, resolve_axes  # noqa: E402

DIELECTRIC = {"table": "dielectric", "axes": {"mu": {"size": 6}, "alpha": {"size": 4}, "eta": [0.7, 1.5]}}
KULLA_CONTY = {"table": "kulla_conty", "axes": {"mu": {"size": 4}, "alpha": {"size": 5}}}
BSDF = {"table": "bsdf", "alpha": 0.3, "fresnel": {"type": "dielectric", "eta": 1.5},
        "axes": {"theta_i": {"size": 9}, "theta_o": {"size": 8}, "phi_d": {"size": 6}}}


def same(a, b):
    return list(a.channels) == list(b.channels) and all(np.array_equal(a.channels[c], b.channels[c]) for c in a.channels)


@pytest.fixture(scope="module")
def client():
    lc = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address=None, silence_logs=40)
    c = distributed.Client(lc)
    yield c
    c.close()
    lc.close()


@pytest.fixture(scope="module")
def in_process():
    return {name: bsdf_tab.tabulate(spec, device="cpu") for name, spec in
            {"dielectric": DIELECTRIC, "kulla_conty": KULLA_CONTY, "bsdf": BSDF}.items()}


def test_local_cluster_tables_equal_in_process(client, in_process):
    for name, spec in {"dielectric": DIELECTRIC, "kulla_conty": KULLA_CONTY, "bsdf": BSDF}.items():
        t = bsdf_tab.tabulate(spec, scheduler=client)
        assert same(t, in_process[name]), name
        assert t.meta == in_process[name].meta


@pytest.mark.parametrize("target,n_chunks", [(1, 6 * 4), (4, 6 * 2), (16, 3), (24, 2), (10_000, 1)])
def test_any_chunking_gives_the_same_table(client, in_process, target, n_chunks):
    nspec = normalize_spec(DIELECTRIC)
    axes = resolve_axes(nspec)
    task = cluster.submit_table(client, 0, nspec, axes, n_workers=2, target=target)
    assert len(task.spans) == n_chunks  # 8 texels per mu slice: below that, alpha is cut too
    (_, channels), = list(cluster.completed(client, [task]))
    for c, v in in_process["dielectric"].channels.items():
        assert np.array_equal(v, channels[c]), c


def test_many_tables_one_graph_and_blocks_in_any_order(client, in_process, tmp_path):
    seen = []
    got = dict(api.tabulate_many([BSDF, DIELECTRIC], scheduler=client, progress=lambda d, t: seen.append((d, t))))
    assert same(got[0], in_process["bsdf"]) and same(got[1], in_process["dielectric"])
    assert seen[-1][0] == seen[-1][1] == 9 * 8 * 6 + 6 * 4 * 2
    from bsdf_tab import io

    io.write_stream(api.iter_blocks(BSDF, scheduler=client, block_texels=48), tmp_path / "b.exr")
    assert same(bsdf_tab.read_exr(tmp_path / "b.exr"), bsdf_tab.read_exr(_written(in_process["bsdf"], tmp_path)))


def _written(table, folder: Path) -> Path:
    path = folder / "mem.exr"
    table.write_exr(path)
    return path


def test_bad_or_unreachable_scheduler_is_one_line(capsys, tmp_path):
    with pytest.raises(cluster.SchedulerError, match="scheduler"):
        cluster.parse_scheduler("local:0")
    with pytest.raises(cluster.SchedulerError, match="scheduler"):
        cluster.parse_scheduler("nonsense")
    t0 = time.monotonic()
    with pytest.raises(cluster.SchedulerError, match="not reachable"):
        cluster.connect("tcp://127.0.0.1:9")  # discard port: nothing listens
    assert time.monotonic() - t0 < 20.0


# --------------------------------------------------------------------------- real processes


def _free_port() -> int:
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _start(cmd, log: Path) -> subprocess.Popen:
    return subprocess.Popen(cmd, stdout=open(log, "wb"), stderr=subprocess.STDOUT, start_new_session=True)


def _stop(proc: subprocess.Popen) -> None:
    if proc.poll() is None:
        os.killpg(proc.pid, signal.SIGTERM)
        try:
            proc.wait(10)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait(10)


def test_real_scheduler_and_workers_survive_a_killed_worker(tmp_path, in_process):
    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    bindir = Path(sys.executable).parent
    dask = str(bindir / "dask") if (bindir / "dask").exists() else "dask"
    procs = [_start([dask, "scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard"],
                    tmp_path / "scheduler.log")]
    try:
        for k in range(2):
            procs.append(_start([dask, "worker", address, "--nthreads", "1", "--nworkers", "1", "--no-dashboard",
                                 "--host", "127.0.0.1", "--name", f"w{k}"], tmp_path / f"worker{k}.log"))
        c = distributed.Client(address, timeout="20s")
        try:
            c.wait_for_workers(2, timeout=60)
            killed = []

            def progress(done, total):
                if done and not killed:  # the first chunk is back: kill a worker while the rest run
                    os.killpg(procs[1].pid, signal.SIGKILL)
                    killed.append(procs[1].pid)

            nspec = normalize_spec(DIELECTRIC)
            task = cluster.submit_table(c, 0, nspec, resolve_axes(nspec), n_workers=2, target=8)
            (_, channels), = list(cluster.completed(c, [task], progress))
            assert killed
            for name, v in in_process["dielectric"].channels.items():
                assert np.array_equal(v, channels[name]), name
        finally:
            c.close()
    finally:
        for p in reversed(procs):
            _stop(p)
    assert all(p.poll() is not None for p in procs)


def test_monte_carlo_tables_are_the_same_on_the_cluster(client):
    # the samples of a texel are seeded by its parameters, not its index in a launch
    spec = {"table": "albedo", "method": "mc_vndf", "effort": 512, "axes": {"mu": {"size": 5}, "alpha": [0.2, 0.6]}}
    a = bsdf_tab.tabulate(spec, device="cpu")
    nspec = normalize_spec(spec)
    task = cluster.submit_table(client, 0, nspec, resolve_axes(nspec), n_workers=2, target=2)
    (_, channels), = list(cluster.completed(client, [task]))
    assert len(task.spans) == 5
    assert all(np.array_equal(a.channels[c], channels[c]) for c in a.channels)
