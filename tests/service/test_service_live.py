"""Service over real sockets: a uvicorn process (``bsdf-tab serve``) on 127.0.0.1, and the page
in headless Chromium (skipped when no browser is installed; ``service/ci-install.sh`` installs one)."""

from __future__ import annotations

import http.client
import json
import os
import shutil
import socket
import subprocess
import sys
import time

import pytest

pytest.importorskip("uvicorn")

from bsdf_tab.table import Table  # noqa: E402


def _free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _get(port: int, path: str, headers: dict | None = None, timeout: float = 60):
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=timeout)
    try:
        conn.request("GET", path, headers=headers or {})
        r = conn.getresponse()
        return r.status, dict(r.getheaders()), r.read()
    finally:
        conn.close()


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    cache = tmp_path_factory.mktemp("live-cache")
    port = _free_port()
    cmd = [
        sys.executable, "-m", "bsdf_tab.cli", "serve", "--host", "127.0.0.1", "--port", str(port),
        "--cache-dir", str(cache), "--workers", "2", "--max-texels", "4096", "--no-warmup", "--log-level", "info",
        "--header-timeout", "1.5",
    ]
    log = open(cache / "server.log", "wb")
    proc = subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT, cwd=os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))))
    try:
        deadline = time.monotonic() + 60
        while True:
            if proc.poll() is not None:
                pytest.fail(f"server exited with {proc.returncode}: {(cache / 'server.log').read_text()[-2000:]}")
            try:
                if _get(port, "/healthz", timeout=2)[0] == 200:
                    break
            except OSError:
                pass
            if time.monotonic() > deadline:
                pytest.fail("server did not answer /healthz within 60 s")
            time.sleep(0.1)
        yield port
    finally:
        proc.terminate()
        try:
            proc.wait(10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
        log.close()


def test_fetch_table_over_a_socket(server):
    status, headers, body = _get(server, "/tables/albedo?mu=0.2,0.6,1&alpha_size=4")
    assert status == 200
    assert headers["content-type"] == "image/x-exr"
    assert int(headers["content-length"]) == len(body)
    table = Table.from_bytes(body, "exr")
    assert table.shape == (3, 4)
    status304, _, empty = _get(server, "/tables/albedo?mu=0.2,0.6,1&alpha_size=4", {"If-None-Match": headers["etag"]})
    assert status304 == 304 and empty == b""
    status, _, body = _get(server, "/tables/albedo?alpha=-1")
    assert status == 400 and json.loads(body)["error"]["param"] == "axes.alpha"
    health = json.loads(_get(server, "/healthz")[2])
    assert health["computations"] == 1


def test_header_read_timeout_closes_a_slow_client(server):
    sock = socket.create_connection(("127.0.0.1", server), timeout=10)
    try:
        sock.sendall(b"GET /healthz HTTP/1.1\r\nHost: x\r\nX-Slow: ")  # headers never finished
        t0 = time.monotonic()
        assert sock.recv(100) == b""  # closed by the server, no answer
        assert 1.0 < time.monotonic() - t0 < 6
    finally:
        sock.close()
    # a well-behaved keep-alive client is not affected, also after an idle pause shorter than the timeout
    conn = http.client.HTTPConnection("127.0.0.1", server, timeout=10)
    try:
        for _ in range(2):
            conn.request("GET", "/healthz")
            assert conn.getresponse().read()
            time.sleep(0.5)
        conn.request("HEAD", "/healthz")
        r = conn.getresponse()
        assert r.status == 200 and r.read() == b""
    finally:
        conn.close()


def test_a_client_gone_mid_body_is_one_info_line(server, tmp_path_factory):
    log_path = [p for p in tmp_path_factory.getbasetemp().glob("live-cache*/server.log")][0]
    sock = socket.create_connection(("127.0.0.1", server), timeout=10)
    sock.sendall(b"POST /tables HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
                 b"Content-Length: 500\r\n\r\n{\"table\": ")
    time.sleep(0.5)
    sock.close()  # gone before the body was complete
    deadline = time.monotonic() + 5
    text = ""
    while time.monotonic() < deadline:
        text = log_path.read_text(errors="replace")
        if "client gone" in text:
            break
        time.sleep(0.1)
    assert "client gone: POST /tables" in text, text[-2000:]
    assert "Traceback" not in text and "internal error" not in text


def _browser() -> str | None:
    for name in ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable"):
        path = shutil.which(name)
        if path:
            return path
    return None


def test_page_in_headless_chromium(server, tmp_path):
    browser = _browser()
    if browser is None:
        pytest.skip("no chromium on PATH (service/ci-install.sh installs it)")
    url = f"http://127.0.0.1:{server}/?table=albedo&mu_size=24&alpha_size=24"
    # compute first, so the browser's time budget only covers loading the page and its image
    assert _get(server, url.split(str(server), 1)[1])[0] == 200
    common = [
        browser, "--headless", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage", "--no-first-run",
        "--hide-scrollbars", f"--user-data-dir={tmp_path / 'profile'}", "--window-size=1280,1000",
        "--virtual-time-budget=15000",
    ]
    dom = subprocess.run(common + ["--dump-dom", url], capture_output=True, text=True, timeout=90)
    assert dom.returncode == 0, dom.stderr[-2000:]
    html = dom.stdout
    assert 'id="preview"' in html
    assert 'data-loaded="640x480"' in html, "the preview PNG did not load in the browser"
    assert 'id="max-error"' in html and "E: " in html
    shot = tmp_path / "page.png"
    res = subprocess.run(common + [f"--screenshot={shot}", url], capture_output=True, text=True, timeout=90)
    assert res.returncode == 0 and shot.exists(), res.stderr[-2000:]
    assert shot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and shot.stat().st_size > 20_000
    keep = os.environ.get("BSDF_TAB_SCREENSHOT")
    if keep:
        shutil.copy(shot, keep)
