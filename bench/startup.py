"""Where users wait: wall time of whole commands, from process start to the answer.

Each command runs in a fresh process (nothing warm but the OS file cache and Warp's kernel
cache), ``--repeats`` times, the commands interleaved round-robin so that a change of load
hits them all alike; the table reports the median wall time and the median CPU time of the
child (user + system, all its threads), and the 1-minute load average before the run.

- ``--help``: ``bsdf-tab --help`` (the parser only: no Warp, no table code);
- ``bake``: ``bsdf-tab bake SPEC -o T.exr`` of one small table (albedo 8 x 8, tolerance 1e-4);
- ``plan``: ``bsdf-tab plan examples/scene.json --tol 1e-3 --json -q`` (issue 14's goal: <= 2 s);
- ``serve``: the service's cold start, ``bsdf-tab serve`` on a free port with an empty cache
  folder, timed from process start to the first table response (``GET /tables/albedo``, 4 x 4),
  polled every 20 ms from the moment the process starts; with and without the start-up warm-up.

The commands run as ``python -m bsdf_tab.cli`` with this interpreter (the console script is the
same import plus a shim). ``--bytecode`` modes: ``env`` runs with this environment as it is
(``PYTHONDONTWRITEBYTECODE=1`` here: every ``bsdf_tab`` module is compiled from source at each
start); ``cached`` removes that variable and points ``PYTHONPYCACHEPREFIX`` at a temporary
folder, warmed by one run first, as an installed package with its ``.pyc`` files starts.

    python bench/startup.py [--repeats 3] [--only help,bake,plan,serve] [-o bench/out/startup.json]
"""

from __future__ import annotations

import argparse
import http.client
import json
import os
import platform
import resource
import socket
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parents[1]
DEFAULT_OUT = REPO_ROOT / "bench" / "out" / "startup.json"
SCENE = REPO_ROOT / "examples" / "scene.json"
SMALL_SPEC = {"table": "albedo", "axes": {"mu": {"size": 8}, "alpha": {"size": 8}}, "tolerance": 1e-4}
TABLE_PATH = "/tables/albedo?mu_size=4&alpha_size=4"
COMMANDS = ("help", "bake", "plan", "serve", "serve_nowarm")
SERVE_TIMEOUT = 120.0


def _child_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def _free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _cli(*args: str) -> list[str]:
    return [sys.executable, "-m", "bsdf_tab.cli", *args]


def _run(cmd: list[str], env: dict) -> tuple[float, float]:
    """(wall, child CPU) of one command; a failure stops the benchmark with its output."""
    c0, t0 = _child_cpu(), time.perf_counter()
    proc = subprocess.run(cmd, cwd=REPO_ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed ({proc.returncode}): {proc.stderr.decode()[-2000:]}")
    return wall, _child_cpu() - c0


def _serve(env: dict, tmp: Path, warmup: bool) -> tuple[float, float]:
    """(seconds from process start to the first table response, child CPU until then)."""
    port = _free_port()
    cache = Path(tempfile.mkdtemp(dir=tmp, prefix="cache-"))
    cmd = _cli("serve", "--host", "127.0.0.1", "--port", str(port), "--cache-dir", str(cache),
               "--log-level", "warning", *([] if warmup else ["--no-warmup"]))
    log = open(cache / "server.log", "wb")
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, cwd=REPO_ROOT, env=env, stdout=log, stderr=subprocess.STDOUT)
    try:
        while True:
            if proc.poll() is not None:
                raise SystemExit(f"serve exited with {proc.returncode}: {(cache / 'server.log').read_text()[-2000:]}")
            try:
                conn = http.client.HTTPConnection("127.0.0.1", port, timeout=SERVE_TIMEOUT)
                conn.request("GET", TABLE_PATH)
                resp = conn.getresponse()
                resp.read()
                conn.close()
                if resp.status != 200:
                    raise SystemExit(f"GET {TABLE_PATH}: HTTP {resp.status}")
                wall = time.perf_counter() - t0
                break
            except (ConnectionRefusedError, ConnectionResetError):
                time.sleep(0.02)
            if time.perf_counter() - t0 > SERVE_TIMEOUT:
                raise SystemExit(f"no table response within {SERVE_TIMEOUT:.0f} s")
        # the child's CPU until now: read from /proc (it is still running)
        cpu = _proc_cpu(proc.pid)
    finally:
        proc.terminate()
        try:
            proc.wait(10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
        log.close()
    return wall, cpu


def _proc_cpu(pid: int) -> float:
    """User + system seconds of a running process (Linux /proc; nan elsewhere)."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
    except (OSError, IndexError, ValueError):
        return float("nan")


def _environment(mode: str, tmp: Path) -> dict:
    env = dict(os.environ)
    if mode == "cached":
        env.pop("PYTHONDONTWRITEBYTECODE", None)
        env["PYTHONPYCACHEPREFIX"] = str(tmp / "pycache")
    return env


def measure(names: list[str], modes: list[str], repeats: int) -> list[dict]:
    rows = []
    with tempfile.TemporaryDirectory(prefix="bsdf-tab-startup-") as tmpdir:
        tmp = Path(tmpdir)
        spec = tmp / "small.json"
        spec.write_text(json.dumps(SMALL_SPEC))
        runs = {
            "help": lambda env: _run(_cli("--help"), env),
            "bake": lambda env: _run(_cli("bake", str(spec), "-o", str(tmp / "small.exr"), "-q"), env),
            "plan": lambda env: _run(_cli("plan", str(SCENE), "--tol", "1e-3", "--json", "-q"), env),
            "serve": lambda env: _serve(env, tmp, warmup=True),
            "serve_nowarm": lambda env: _serve(env, tmp, warmup=False),
        }
        for mode in modes:
            env = _environment(mode, tmp)
            if mode == "cached":
                _run(_cli("--help"), env)  # write the .pyc files of what --help imports
                _run(_cli("bake", str(spec), "-o", str(tmp / "small.exr"), "-q"), env)  # and of a computation
            times: dict[str, list[tuple[float, float]]] = {n: [] for n in names}
            load = os.getloadavg()[0]
            for _ in range(repeats):
                for n in names:
                    times[n].append(runs[n](env))
            for n in names:
                walls = [w for w, _ in times[n]]
                cpus = [c for _, c in times[n]]
                rows.append({"command": n, "bytecode": mode, "wall_s": statistics.median(walls),
                             "cpu_s": statistics.median(cpus), "walls": walls, "cpus": cpus, "load_1min": load})
    return rows


def main(argv: list[str] | None = None, prog: str | None = None) -> int:
    ap = argparse.ArgumentParser(prog=prog, description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeats", type=int, default=3, help="runs per command (median; default 3)")
    ap.add_argument("--only", default=",".join(COMMANDS), help=f"commands, comma-separated ({', '.join(COMMANDS)})")
    ap.add_argument("--bytecode", default="env,cached", help="modes: env, cached (default both)")
    ap.add_argument("-o", "--output", default=str(DEFAULT_OUT), help="JSON output (default bench/out/startup.json)")
    args = ap.parse_args(argv)
    names = [n for n in args.only.split(",") if n]
    modes = [m for m in args.bytecode.split(",") if m]
    bad = [n for n in names if n not in COMMANDS] + [m for m in modes if m not in ("env", "cached")]
    if bad or args.repeats < 1:
        print(f"{prog or 'startup.py'}: error: unknown command or mode: {', '.join(bad) or '--repeats < 1'}",
              file=sys.stderr)
        return 2
    load0 = os.getloadavg()
    rows = measure(names, modes, args.repeats)
    print(f"load average at start: {load0[0]:.2f} {load0[1]:.2f} {load0[2]:.2f} ({os.cpu_count()} cores)")
    print(f"{'command':<14} {'bytecode':<8} {'wall s (median)':>16} {'cpu s':>8}  walls")
    for r in rows:
        walls = " ".join(f"{w:.2f}" for w in r["walls"])
        print(f"{r['command']:<14} {r['bytecode']:<8} {r['wall_s']:>16.2f} {r['cpu_s']:>8.2f}  {walls}")
    out = Path(args.output)
    out.parent.mkdir(parents=True, exist_ok=True)
    record = {
        "load_average_at_start": load0, "cores": os.cpu_count(), "repeats": args.repeats,
        "python": sys.version.split()[0], "platform": platform.platform(),
        "pythondontwritebytecode": os.environ.get("PYTHONDONTWRITEBYTECODE"),
        "rows": rows,
    }
    out.write_text(json.dumps(record, indent=2))
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
