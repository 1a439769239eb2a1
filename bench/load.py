"""Load benchmark of the HTTP service against a minimal FastAPI app, on loopback only.

Starts ``bsdf-tab serve`` on 127.0.0.1 (a free port, a fresh cache folder) and, beside it, a
minimal FastAPI app on uvicorn (the same uvicorn defaults) whose one route returns the very bytes
of the service's cached table: the framework's ceiling on this machine. Then, with N concurrent
keep-alive clients:

- ``cached`` / ``minimal``: for 1, 8 and 64 clients (``--clients``), interleaved in one run
  (service, minimal, minimal, service, ... ``--repeats`` times each, ``--duration`` seconds per
  phase), every client fetches the same computed table as fast as it can. The table reports the
  medians over the repeats and the ratios service / minimal (requests/s, p99);
- ``cold``: rounds of a *new* table (never computed before); all N clients ask for it at the
  same moment, wait for everyone, and the next round starts. One computation per round.

The machine's load average before and after is recorded (shared machines: read ratios, not
absolute figures). Prints a table and writes JSON to ``bench/out/load.json``. Stops by itself:
each phase is capped at 60 s, clients at 256, repeats at 9.

    python bench/load.py                                   # 1, 8, 64 clients, 3 repeats, 3 s
    python bench/load.py --clients 64 --repeats 1 --duration 2
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

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import stop_process  # noqa: E402

HOST = "127.0.0.1"  # loopback only, never configurable
OUT = Path(__file__).resolve().parent / "out"
MAX_DURATION = 60.0
MAX_CLIENTS = 256
MAX_REPEATS = 9

MINIMAL_APP = """
import sys
from pathlib import Path
from fastapi import FastAPI
from fastapi.responses import Response
import uvicorn

DATA = Path(sys.argv[2]).read_bytes()
app = FastAPI()


@app.get("/tables/albedo")
async def table() -> Response:
    return Response(DATA, media_type="image/x-exr")


uvicorn.run(app, host="127.0.0.1", port=int(sys.argv[1]), log_level="warning")
"""


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


async def cached_phase(port: int, path: str, clients: int, duration: float, name: str = "cached",
                       counted: bool = True) -> dict:
    c0 = health(port)["computations"] if counted else 0
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
    result = summary(name, latencies, errors, elapsed, (health(port)["computations"] - c0) if counted else 0)
    result["clients"] = clients
    return result


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


def start(cmd: list[str], port: int) -> subprocess.Popen:
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 60
    while True:
        if proc.poll() is not None:
            raise RuntimeError(proc.stderr.read().decode()[-2000:])
        try:
            with socket.create_connection((HOST, port), timeout=1):
                return proc
        except OSError:
            if time.monotonic() > deadline:
                raise RuntimeError(f"{cmd[:3]} did not start within 60 s")
            time.sleep(0.1)


def median_of(runs: list[dict]) -> dict:
    out = dict(runs[0])
    for k in ("requests_per_s", "p50_ms", "p99_ms", "mean_ms", "max_ms"):
        values = [r[k] for r in runs if r.get(k) is not None]
        out[k] = round(statistics.median(values), 2) if values else None
    out["requests"] = sum(r["requests"] for r in runs)
    out["errors"] = sum(r["errors"] for r in runs)
    out["computations"] = sum(r["computations"] for r in runs)
    out["repeats"] = len(runs)
    out["runs_requests_per_s"] = [r["requests_per_s"] for r in runs]
    return out


def main(argv=None, prog=None) -> int:
    ap = argparse.ArgumentParser(prog=prog, description=__doc__.split("\n\n")[0])
    ap.add_argument("--clients", type=int, nargs="+", default=[1, 8, 64])
    ap.add_argument("--repeats", type=int, default=3, help="interleaved repeats per client count (medians)")
    ap.add_argument("--duration", type=float, default=3.0, help="seconds per phase (at most 60)")
    ap.add_argument("--workers", type=int, default=None, help="server: CPU threads per computation")
    ap.add_argument("--cached", default="/tables/albedo?mu_size=32&alpha_size=32",
                    help="path of the table for the cached phase (EXR)")
    ap.add_argument("--cold", default="/tables/albedo?mu_size=16&alpha_size=16",
                    help="path of the table for the cold phase (a new tolerance per round)")
    ap.add_argument("--no-cold", action="store_true", help="skip the cold phase")
    ap.add_argument("--out", default=str(OUT / "load.json"))
    args = ap.parse_args(argv)
    client_counts = [max(1, min(c, MAX_CLIENTS)) for c in args.clients]
    duration = max(0.5, min(args.duration, MAX_DURATION))
    repeats = max(1, min(args.repeats, MAX_REPEATS))

    port, minimal_port = free_port(), free_port()
    cache = tempfile.mkdtemp(prefix="bsdf-tab-load-")
    cmd = [sys.executable, "-m", "bsdf_tab.cli", "serve", "--host", HOST, "--port", str(port),
           "--cache-dir", cache, "--log-level", "warning"]
    if args.workers:
        cmd += ["--workers", str(args.workers)]
    load_before = os.getloadavg()
    server = minimal = None
    results, comparison = [], []
    try:
        server = start(cmd, port)
        # the cached table: computed once before the phases start; the minimal app serves its bytes
        data = urllib.request.urlopen(f"http://{HOST}:{port}{args.cached}", timeout=120).read()
        body_file = Path(cache) / "minimal-body.bin"
        body_file.write_bytes(data)
        script = Path(cache) / "minimal_app.py"
        script.write_text(MINIMAL_APP)
        minimal = start([sys.executable, str(script), str(minimal_port), str(body_file)], minimal_port)
        minimal_path = "/tables/albedo"
        for clients in client_counts:
            runs = {"cached": [], "minimal": []}
            for rep in range(repeats):
                order = ("cached", "minimal") if rep % 2 == 0 else ("minimal", "cached")
                for which in order:
                    if which == "cached":
                        runs["cached"].append(asyncio.run(cached_phase(port, args.cached, clients, duration)))
                    else:
                        runs["minimal"].append(asyncio.run(cached_phase(
                            minimal_port, minimal_path, clients, duration, name="minimal", counted=False)))
            svc, ref = median_of(runs["cached"]), median_of(runs["minimal"])
            results += [svc, ref]
            comparison.append({
                "clients": clients,
                "service_rps": svc["requests_per_s"], "minimal_rps": ref["requests_per_s"],
                "rps_ratio": round(svc["requests_per_s"] / ref["requests_per_s"], 3) if ref["requests_per_s"] else None,
                "service_p99_ms": svc["p99_ms"], "minimal_p99_ms": ref["p99_ms"],
                "p99_ratio": round(svc["p99_ms"] / ref["p99_ms"], 3) if ref["p99_ms"] else None,
            })
        stop_process(minimal)
        minimal = None
        if not args.no_cold:
            results.append(asyncio.run(cold_phase(port, args.cold, max(client_counts), duration)))
        final_health = health(port)
    finally:
        for proc in (server, minimal):
            if proc is not None:
                stop_process(proc)
        shutil.rmtree(cache, ignore_errors=True)
    load_after = os.getloadavg()

    print(f"bsdf-tab service load test: {duration:g} s per phase, {repeats} interleaved repeats (medians), "
          f"{os.cpu_count()} CPUs, loopback; load average {load_before[0]:.2f} before, {load_after[0]:.2f} after")
    cols = ["phase", "clients", "requests", "errors", "requests_per_s", "p50_ms", "p99_ms", "computations", "rounds"]
    print("  ".join(f"{c:>14}" for c in cols))
    for r in results:
        print("  ".join(f"{str(r.get(c, '-')):>14}" for c in cols))
    print("service / minimal FastAPI app (goal: requests/s >= 0.8, p99 <= 1.5x):")
    for c in comparison:
        print(f"  {c['clients']:>3} clients: requests/s {c['service_rps']:>8} / {c['minimal_rps']:>8} = {c['rps_ratio']}"
              f"   p99 {c['service_p99_ms']} / {c['minimal_p99_ms']} ms = {c['p99_ratio']}")
    record = {
        "clients": client_counts,
        "duration_s": duration,
        "repeats": repeats,
        "cached_path": args.cached,
        "cold_path": args.cold,
        "cpus": os.cpu_count(),
        "load_average_before": load_before,
        "load_average_after": load_after,
        "python": platform.python_version(),
        "platform": platform.platform(),
        "time": time.strftime("%Y-%m-%dT%H:%M:%S"),
        "comparison": comparison,
        "results": results,
        "server_health": final_health,
    }
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(record, indent=2))
    print(f"wrote {out}")
    ok = all(r["errors"] == 0 for r in results) and (args.no_cold or results[-1]["one_computation_per_round"])
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
