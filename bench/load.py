"""Load benchmark of the HTTP service, on loopback only.

Starts ``bsdf-tab serve`` on 127.0.0.1 (a free port, a fresh cache folder), then runs two
bounded phases with N concurrent keep-alive clients:

- ``cached``: every client fetches the same (already computed) table, as fast as it can, for
  ``--duration`` seconds;
- ``cold``: rounds of a *new* table (never computed before); all N clients ask for it at the
  same moment, wait for everyone, and the next round starts, until ``--duration`` is up. The
  service must run exactly one computation per round.

Prints a table (requests/s, p50/p99 latency, errors, computations) and writes JSON to
``bench/out/load.json``. Stops by itself: each phase is capped at 60 s, clients at 256.

    python bench/load.py                    # 64 clients, 10 s per phase
    python bench/load.py --clients 16 --duration 3
"""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import platform
import shutil
import socket
import statistics
import subprocess
import sys
import tempfile
import time
import urllib.request
from pathlib import Path

HOST = "127.0.0.1"  # loopback only, never configurable
OUT = Path(__file__).resolve().parent / "out"
MAX_DURATION = 60.0
MAX_CLIENTS = 256


def free_port() -> int:
    with socket.socket() as s:
        s.bind((HOST, 0))
        return s.getsockname()[1]


def health(port: int) -> dict:
    with urllib.request.urlopen(f"http://{HOST}:{port}/healthz", timeout=5) as r:
        return json.loads(r.read())


class Client:
    """A minimal HTTP/1.1 keep-alive client (GET only) on asyncio streams: cheap on CPU."""

    def __init__(self, port: int) -> None:
        self.port = port
        self.reader = self.writer = None

    async def get(self, path: str) -> tuple[int, int]:
        if self.writer is None:
            self.reader, self.writer = await asyncio.open_connection(HOST, self.port)
        self.writer.write(f"GET {path} HTTP/1.1\r\nHost: {HOST}\r\nAccept: */*\r\n\r\n".encode())
        await self.writer.drain()
        head = await self.reader.readuntil(b"\r\n\r\n")
        lines = head.decode("latin-1").split("\r\n")
        status = int(lines[0].split()[1])
        length = 0
        close = False
        for line in lines[1:]:
            name, _, value = line.partition(":")
            if name.lower() == "content-length":
                length = int(value)
            elif name.lower() == "connection" and value.strip().lower() == "close":
                close = True
        body = await self.reader.readexactly(length)
        if close:
            await self.close()
        return status, len(body)

    async def close(self) -> None:
        if self.writer is not None:
            self.writer.close()
            try:
                await self.writer.wait_closed()
            except OSError:
                pass
        self.reader = self.writer = None


def summary(name: str, latencies: list[float], errors: int, elapsed: float, computations: int, extra=None) -> dict:
    lat = sorted(latencies)

    def pct(p):
        return lat[min(len(lat) - 1, int(round(p / 100 * (len(lat) - 1))))] * 1000 if lat else float("nan")

    out = {
        "phase": name,
        "requests": len(lat) + errors,
        "ok": len(lat),
        "errors": errors,
        "seconds": round(elapsed, 3),
        "requests_per_s": round(len(lat) / elapsed, 1) if elapsed > 0 else 0.0,
        "p50_ms": round(pct(50), 2),
        "p99_ms": round(pct(99), 2),
        "max_ms": round(lat[-1] * 1000, 2) if lat else None,
        "mean_ms": round(statistics.fmean(lat) * 1000, 2) if lat else None,
        "computations": computations,
    }
    out.update(extra or {})
    return out


async def cached_phase(port: int, path: str, clients: int, duration: float) -> dict:
    c0 = health(port)["computations"]
    latencies, errors = [], 0
    stop = time.perf_counter() + duration

    async def worker():
        nonlocal errors
        cl = Client(port)
        try:
            while time.perf_counter() < stop:
                t0 = time.perf_counter()
                try:
                    status, _ = await cl.get(path)
                except (OSError, asyncio.IncompleteReadError, ValueError):
                    errors += 1
                    await cl.close()
                    continue
                if status == 200:
                    latencies.append(time.perf_counter() - t0)
                else:
                    errors += 1
        finally:
            await cl.close()

    t0 = time.perf_counter()
    await asyncio.gather(*(worker() for _ in range(clients)))
    elapsed = time.perf_counter() - t0
    return summary("cached", latencies, errors, elapsed, health(port)["computations"] - c0)


async def cold_phase(port: int, table_query: str, clients: int, duration: float) -> dict:
    c0 = health(port)["computations"]
    latencies, errors, rounds, round_times = [], 0, 0, []
    pool = [Client(port) for _ in range(clients)]
    stop = time.perf_counter() + duration
    t_start = time.perf_counter()
    try:
        while time.perf_counter() < stop:
            # a tolerance never asked before: a new cache key, a real computation
            path = f"{table_query}&tolerance={1e-6 * (1 + rounds / 997):.12g}"

            async def one(cl):
                nonlocal errors
                t0 = time.perf_counter()
                try:
                    status, _ = await cl.get(path)
                except (OSError, asyncio.IncompleteReadError, ValueError):
                    errors += 1
                    await cl.close()
                    return
                if status == 200:
                    latencies.append(time.perf_counter() - t0)
                else:
                    errors += 1

            r0 = time.perf_counter()
            await asyncio.gather(*(one(cl) for cl in pool))
            round_times.append(time.perf_counter() - r0)
            rounds += 1
    finally:
        for cl in pool:
            await cl.close()
    elapsed = time.perf_counter() - t_start
    computations = health(port)["computations"] - c0
    return summary(
        "cold", latencies, errors, elapsed, computations,
        {"rounds": rounds, "round_p50_ms": round(statistics.median(round_times) * 1000, 1) if round_times else None,
         "one_computation_per_round": computations == rounds},
    )


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--clients", type=int, default=64)
    ap.add_argument("--duration", type=float, default=10.0, help="seconds per phase (at most 60)")
    ap.add_argument("--workers", type=int, default=None, help="server: CPU threads per computation")
    ap.add_argument("--cached", default="/tables/albedo?mu_size=32&alpha_size=32",
                    help="path of the table for the cached phase (EXR)")
    ap.add_argument("--cold", default="/tables/albedo?mu_size=16&alpha_size=16",
                    help="path of the table for the cold phase (a new tolerance per round)")
    ap.add_argument("--out", default=str(OUT / "load.json"))
    args = ap.parse_args(argv)
    clients = max(1, min(args.clients, MAX_CLIENTS))
    duration = max(0.5, min(args.duration, MAX_DURATION))

    port = free_port()
    cache = tempfile.mkdtemp(prefix="bsdf-tab-load-")
    cmd = [sys.executable, "-m", "bsdf_tab.cli", "serve", "--host", HOST, "--port", str(port),
           "--cache-dir", cache, "--log-level", "warning"]
    if args.workers:
        cmd += ["--workers", str(args.workers)]
    server = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        deadline = time.monotonic() + 60
        while True:
            if server.poll() is not None:
                print(server.stderr.read().decode()[-2000:], file=sys.stderr)
                return 1
            try:
                health(port)
                break
            except OSError:
                if time.monotonic() > deadline:
                    print("server did not start within 60 s", file=sys.stderr)
                    return 1
                time.sleep(0.1)
        # the cached table: computed once before the phase starts
        urllib.request.urlopen(f"http://{HOST}:{port}{args.cached}", timeout=120).read()
        results = [
            asyncio.run(cached_phase(port, args.cached, clients, duration)),
            asyncio.run(cold_phase(port, args.cold, clients, duration)),
        ]
        final_health = health(port)
    finally:
        server.terminate()
        try:
            server.wait(10)
        except subprocess.TimeoutExpired:
            server.kill()
        shutil.rmtree(cache, ignore_errors=True)

    cols = ["phase", "requests", "errors", "requests_per_s", "p50_ms", "p99_ms", "max_ms", "computations", "rounds"]
    print(f"bsdf-tab service load test: {clients} clients, {duration:g} s per phase, {os.cpu_count()} CPUs, loopback")
    print("  ".join(f"{c:>14}" for c in cols))
    for r in results:
        print("  ".join(f"{str(r.get(c, '-')):>14}" for c in cols))
    record = {
        "clients": clients,
        "duration_s": duration,
        "cached_path": args.cached,
        "cold_path": args.cold,
        "cpus": os.cpu_count(),
        "python": platform.python_version(),
        "platform": platform.platform(),
        "time": time.strftime("%Y-%m-%dT%H:%M:%S"),
        "results": results,
        "server_health": final_health,
    }
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(record, indent=2))
    print(f"wrote {out}")
    ok = all(r["errors"] == 0 for r in results) and results[1]["one_computation_per_round"]
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
