"""Two real ``bsdf-tab serve`` processes on 127.0.0.1 sharing one cache folder (issue 12).

- concurrent identical requests to both compute the table once in total, identical bytes;
- a client that disconnects cancels its computation (between chunks, ``--workers 1``);
- a job whose server is killed (-9) mid-run is resumed by the restarted server.

Servers are started and stopped here by PID; every loop is bounded in count and time.
"""

from __future__ import annotations

import http.client
import json
import os
import signal
import socket
import subprocess
import sys
import threading
import time

import pytest

pytest.importorskip("uvicorn")

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
#: about 1.5 core-seconds: long enough for the two servers' requests to overlap
TABLE = "/tables/albedo?mu_size=16&alpha_size=16&method=mc_vndf&effort=65536"
#: 16 texels x 2^23 samples: ~12 core-seconds, chunks of 4 texels (~3 s) with one worker
LONG = "/tables/albedo?mu_size=4&alpha_size=4&method=mc_vndf&effort=8388608"


def _free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _request(port: int, method: str, path: str, body=None, timeout: float = 60):
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=timeout)
    try:
        data = None if body is None else json.dumps(body).encode()
        conn.request(method, path, body=data, headers={"Content-Type": "application/json"} if data else {})
        r = conn.getresponse()
        return r.status, {k.lower(): v for k, v in r.getheaders()}, r.read()
    finally:
        conn.close()


def _health(port: int) -> dict:
    return json.loads(_request(port, "GET", "/healthz", timeout=5)[2])


class Server:
    def __init__(self, cache, log_name: str) -> None:
        self.cache, self.port = cache, _free_port()
        self.log = open(cache.parent / log_name, "ab")
        cmd = [sys.executable, "-m", "bsdf_tab.cli", "serve", "--host", "127.0.0.1", "--port", str(self.port),
               "--cache-dir", str(cache), "--workers", "1", "--no-warmup", "--log-level", "warning"]
        self.proc = subprocess.Popen(cmd, stdout=self.log, stderr=subprocess.STDOUT, cwd=ROOT)

    def wait_ready(self, timeout: float = 60) -> None:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if self.proc.poll() is not None:
                pytest.fail(f"server exited with {self.proc.returncode}")
            try:
                if _request(self.port, "GET", "/healthz", timeout=2)[0] == 200:
                    return
            except OSError:
                pass
            time.sleep(0.1)
        pytest.fail("server did not answer /healthz in time")

    def stop(self, sig=signal.SIGTERM) -> None:
        if self.proc.poll() is None:
            os.kill(self.proc.pid, sig)
            try:
                self.proc.wait(10)
            except subprocess.TimeoutExpired:
                os.kill(self.proc.pid, signal.SIGKILL)
                self.proc.wait()
        self.log.close()


@pytest.fixture(scope="module")
def pair(tmp_path_factory):
    cache = tmp_path_factory.mktemp("replicas") / "cache"
    cache.mkdir()
    servers = [Server(cache, "a.log"), Server(cache, "b.log")]
    try:
        for s in servers:
            s.wait_ready()
        yield servers
    finally:
        for s in servers:
            s.stop()


def test_two_replicas_compute_once_and_serve_identical_bytes(pair):
    a, b = pair
    results = []

    def fetch(port):
        results.append(_request(port, "GET", TABLE))

    threads = [threading.Thread(target=fetch, args=(s.port,)) for s in (a, b, a, b, a, b)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(90)
    assert len(results) == 6 and all(r[0] == 200 for r in results), [r[0] for r in results]
    assert len({r[2] for r in results}) == 1  # identical bytes from both processes
    ha, hb = _health(a.port), _health(b.port)
    assert ha["computations"] + hb["computations"] == 1, (ha, hb)
    assert ha["pid"] != hb["pid"]
    # the one that did not compute found the peer's entry (waiting on its lock, or in the cache)
    assert ha["peer_computed"] + hb["peer_computed"] + ha["cache"]["hits"] + hb["cache"]["hits"] >= 1


def test_a_client_that_leaves_cancels_its_computation(pair):
    a, _b = pair
    before = _health(a.port)["computations"]
    sock = socket.create_connection(("127.0.0.1", a.port), timeout=5)
    sock.sendall(f"GET {LONG} HTTP/1.1\r\nHost: x\r\n\r\n".encode())
    deadline = time.monotonic() + 20
    while not _health(a.port)["running"] and time.monotonic() < deadline:
        time.sleep(0.1)
    assert _health(a.port)["running"], "the computation did not start"
    sock.close()  # the only client leaves
    t0 = time.monotonic()
    while time.monotonic() - t0 < 15:
        h = _health(a.port)
        if h["cancelled"] == 1 and h["computing"] == 0:
            break
        time.sleep(0.2)
    h = _health(a.port)
    assert h["cancelled"] == 1 and h["computing"] == 0 and h["client_gone"] == 1, h
    assert time.monotonic() - t0 < 10  # a ~12 core-second table stopped within one ~3 s chunk
    assert h["computations"] == before + 1


def test_a_job_survives_kill_9_of_its_server(pair):  # last: it kills server a
    a, b = pair
    status, headers, body = _request(a.port, "POST", "/jobs", body={"spec": {
        "table": "albedo", "method": "mc_vndf", "effort": 1048576, "axes": {"mu": {"size": 4}, "alpha": {"size": 4}}}})
    assert status == 202, body
    job_id = json.loads(body)["id"]
    assert headers["location"] == f"/jobs/{job_id}"
    deadline = time.monotonic() + 20
    while json.loads(_request(b.port, "GET", f"/jobs/{job_id}")[2])["status"] != "running":
        assert time.monotonic() < deadline
        time.sleep(0.1)
    a.stop(signal.SIGKILL)  # a crash mid-computation
    restarted = Server(a.cache, "a2.log")
    try:
        restarted.wait_ready()
        deadline = time.monotonic() + 60
        while True:
            job = json.loads(_request(restarted.port, "GET", f"/jobs/{job_id}")[2])
            if job["status"] in ("done", "failed", "cancelled") or time.monotonic() > deadline:
                break
            time.sleep(0.2)
        assert job["status"] == "done", job
        status, headers, table = _request(b.port, "GET", job["result"])
        assert status == 200 and headers["etag"].endswith('.exr"')
        assert _health(restarted.port)["jobs"]["resumed"] + _health(b.port)["jobs"]["resumed"] == 1
    finally:
        restarted.stop()
