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
    python bench/startup.py --checkout ../before --checkout .     # two checkouts, interleaved
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

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import stop_process  # noqa: E402

REPO_ROOT = Path(__file__).resolve().parents[1]
DEFAULT_OUT = REPO_ROOT / "bench" / "out" / "startup.json"
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


def _run(cmd: list[str], env: dict, root: Path = REPO_ROOT) -> tuple[float, float]:
    """(wall, child CPU) of one command; a failure stops the benchmark with its output."""
    c0, t0 = _child_cpu(), time.perf_counter()
    proc = subprocess.run(cmd, cwd=root, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed ({proc.returncode}): {proc.stderr.decode()[-2000:]}")
    return wall, _child_cpu() - c0


def _serve(env: dict, tmp: Path, warmup: bool, root: Path = REPO_ROOT) -> tuple[float, float]:
    """(seconds from process start to the first table response, child CPU until then)."""
    port = _free_port()
    cache = Path(tempfile.mkdtemp(dir=tmp, prefix="cache-"))
    cmd = _cli("serve", "--host", "127.0.0.1", "--port", str(port), "--cache-dir", str(cache),
               "--log-level", "warning", *([] if warmup else ["--no-warmup"]))
    log = open(cache / "server.log", "wb")
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, cwd=root, env=env, stdout=log, stderr=subprocess.STDOUT)
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
        stop_process(proc)
        log.close()
    return wall, cpu


def _proc_cpu(pid: int) -> float:
    """User + system seconds of a running process (Linux /proc; nan elsewhere)."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
    except (OSError, IndexError, ValueError):
        return float("nan")


def _environment(mode: str, tmp: Path, root: Path) -> dict:
    env = dict(os.environ)
    env["PYTHONPATH"] = str(root) + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    if mode == "cached":
        env.pop("PYTHONDONTWRITEBYTECODE", None)
        env["PYTHONPYCACHEPREFIX"] = str(tmp / "pycache" / root.name)
    return env


def measure(names: list[str], modes: list[str], repeats: int, roots: list[Path]) -> list[dict]:
    """Rows of medians per (checkout, bytecode mode, command); checkouts and commands interleaved."""
    rows = []
    with tempfile.TemporaryDirectory(prefix="bsdf-tab-startup-") as tmpdir:
        tmp = Path(tmpdir)
        spec = tmp / "small.json"
        spec.write_text(json.dumps(SMALL_SPEC))
        runs = {
            "help": lambda env, root: _run(_cli("--help"), env, root),
            "bake": lambda env, root: _run(_cli("bake", str(spec), "-o", str(tmp / "small.exr"), "-q"), env, root),
            "plan": lambda env, root: _run(_cli("plan", str(root / "examples" / "scene.json"), "--tol", "1e-3",
                                                "--json", "-q"), env, root),
            "serve": lambda env, root: _serve(env, tmp, True, root),
            "serve_nowarm": lambda env, root: _serve(env, tmp, False, root),
        }
        for mode in modes:
            envs = [_environment(mode, tmp, root) for root in roots]
            for env, root in zip(envs, roots):  # kernels compiled (and .pyc written) before timing
                _run(_cli("--help"), env, root)
                _run(_cli("bake", str(spec), "-o", str(tmp / "small.exr"), "-q"), env, root)
            times = {(i, n): [] for i in range(len(roots)) for n in names}
            load = os.getloadavg()[0]
            for _ in range(repeats):
                for n in names:
                    for i, (env, root) in enumerate(zip(envs, roots)):
                        times[(i, n)].append(runs[n](env, root))
            for i, root in enumerate(roots):
                for n in names:
                    walls = [w for w, _ in times[(i, n)]]
                    cpus = [c for _, c in times[(i, n)]]
                    rows.append({"checkout": str(root), "command": n, "bytecode": mode,
                                 "wall_s": statistics.median(walls), "cpu_s": statistics.median(cpus),
                                 "walls": walls, "cpus": cpus, "load_1min": load})
    return rows


BREAKDOWN_CHILD = r"""
import gc, json, sys, threading, time
t_start = time.perf_counter()
gc_time = [0.0]
_gc_t0 = [0.0]
def _cb(phase, info):
    if phase == "start":
        _gc_t0[0] = time.perf_counter()
    else:
        gc_time[0] += time.perf_counter() - _gc_t0[0]
gc.callbacks.append(_cb)
out = {}
def mark(name, t0, gc0):
    out[name] = time.perf_counter() - t0
    out[name + "_gc"] = gc_time[0] - gc0
if sys.argv[1] == "paused":  # as bsdf-tab does: every import of the command with the collector paused
    gc.disable()
t, g = time.perf_counter(), gc_time[0]; import numpy; mark("import_numpy", t, g)
t, g = time.perf_counter(), gc_time[0]; import warp; mark("import_warp", t, g)
t, g = time.perf_counter(), gc_time[0]
import bsdf_tab.cli.main as cli_main
mark("import_cli", t, g)
t, g = time.perf_counter(), gc_time[0]
import bsdf_tab.scene, bsdf_tab.api
if sys.argv[1] == "paused":
    gc.freeze()
    gc.enable()
mark("import_bsdf_tab", t, g)
from bsdf_tab.api import quiet_warp
quiet_warp()
t = time.perf_counter(); warp.init(); out["warp_init"] = time.perf_counter() - t
import warp._src.context as ctx
loads, launches, lock = [], [0.0, 0], threading.Lock()
real_load = ctx.Module.load
def load(self, *a, **k):
    s = time.perf_counter(); r = real_load(self, *a, **k)
    with lock:
        loads.append(time.perf_counter() - s)
    return r
ctx.Module.load = load
real_launch = warp.launch
def launch(*a, **k):
    s = time.perf_counter(); r = real_launch(*a, **k)
    with lock:
        launches[0] += time.perf_counter() - s; launches[1] += 1
    return r
warp.launch = launch
import bsdf_tab.api as api
import bsdf_tab.integrate as integrate
evals, group_evals = [0], []
real_method = integrate.METHODS["adaptive"]
def counted(*a, **k):  # the integrand evaluations of every texel (the integrator's own count)
    v, e, c = real_method(*a, **dict(k, return_cost=True))
    with lock:
        evals[0] += int(c.sum())
    return v, e
integrate.METHODS["adaptive"] = counted
real_tab, tab = api.tabulate, [0.0]
def tabulate(spec, **kw):
    s = time.perf_counter(); r = real_tab(spec, **kw)
    with lock:
        tab[0] += time.perf_counter() - s
    return r
api.tabulate = tabulate
from bsdf_tab.scene import load_scene_file, plan_scene
from bsdf_tab.io import json_default
import bsdf_tab.scene.plan as plan_module
plan_module.GROUP_THREADS = 1  # one group at a time: the parts add up
groups_cpu = []
if hasattr(plan_module, "_plan_table"):
    real_plan_table = plan_module._plan_table
    def plan_table(*a, **k):
        c, e = time.process_time(), evals[0]
        r = real_plan_table(*a, **k)
        groups_cpu.append(time.process_time() - c)
        group_evals.append(evals[0] - e)
        return r
    plan_module._plan_table = plan_table
scene = load_scene_file(sys.argv[2])
t, c, g = time.perf_counter(), time.process_time(), gc_time[0]
plan = plan_scene(scene, float(sys.argv[3]))
out["plan"] = time.perf_counter() - t
out["plan_cpu"] = time.process_time() - c
out["plan_gc"] = gc_time[0] - g
t = time.perf_counter(); text = json.dumps(plan.to_dict(), indent=2, default=json_default); out["json"] = time.perf_counter() - t
out["tabulate_wall"] = tab[0]
out["launch_thread_s"] = launches[0]
out["launches"] = launches[1]
out["module_load_first"] = loads[0] if loads else 0.0
out["module_load_total"] = sum(loads)
out["tabulate_calls"] = plan.tabulate_calls
out["texels_computed"] = plan.texels_computed
out["groups_cpu"] = groups_cpu
out["evaluations"] = evals[0]
out["groups_evaluations"] = group_evals
out["candidates_certified"] = getattr(plan, "candidates_certified", 0)
out["line_probes"] = getattr(plan, "line_probes", 0)
out["in_process_total"] = time.perf_counter() - t_start
out["process_cpu"] = time.process_time()
print(json.dumps(out))
"""


def _breakdown_run(mode: str, env: dict, root: Path) -> dict:
    """One breakdown run of ``root``'s plan (see :func:`breakdown`), with the interpreter start."""
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-c", "pass"], env=env, check=True)
    start = time.perf_counter() - t0
    proc = subprocess.run([sys.executable, "-c", BREAKDOWN_CHILD, mode, str(root / "examples" / "scene.json"),
                           "1e-3"], cwd=root,
                          env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    if proc.returncode != 0:
        raise SystemExit(f"breakdown child failed: {proc.stderr[-2000:]}")
    return dict(json.loads(proc.stdout.strip().splitlines()[-1]), interpreter_start=start)


def _medians(runs: list[dict]) -> dict:
    lists = ("groups_cpu", "groups_evaluations")
    out = {k: statistics.median(r[k] for r in runs) for k in runs[0] if k not in lists}
    for k in lists:
        out[k] = [statistics.median(g) for g in zip(*(r[k] for r in runs))]
    return out


def breakdown(mode: str, repeats: int, roots: list[Path]) -> dict:
    """Where the plan's time goes, from inside one process (medians of ``repeats`` runs per
    checkout, the checkouts interleaved): interpreter start (``python -c pass``), the imports
    (NumPy, Warp, the rest of what ``plan`` imports, with the time of garbage collections during
    each), Warp's init, the kernel-module loads, the planner (its tabulations' wall time, the
    kernel launches summed over threads, the integrand evaluations), the JSON output. The groups
    are planned one after the other here (``GROUP_THREADS = 1``) so that the parts add up; the
    ``plan`` command above plans them on threads. ``mode``: ``paused`` imports as ``bsdf-tab``
    does (collector paused), ``plain`` with the collector running."""
    runs: dict[Path, list[dict]] = {root: [] for root in roots}
    for _ in range(repeats):
        for root in roots:
            runs[root].append(_breakdown_run(mode, _environment("env", Path("."), root), root))
    return {str(root): _medians(r) for root, r in runs.items()}


def _print_breakdown(b: dict) -> None:
    imports = b["import_numpy"] + b["import_warp"] + b["import_cli"] + b["import_bsdf_tab"]
    gc_imports = b["import_numpy_gc"] + b["import_warp_gc"] + b["import_cli_gc"] + b["import_bsdf_tab_gc"]
    rows = [
        ("interpreter start (python -c pass)", b["interpreter_start"]),
        ("import numpy", b["import_numpy"]),
        ("import warp", b["import_warp"]),
        ("import bsdf_tab.cli", b["import_cli"]),
        ("import what plan needs (spec, catalog, kernels, scene, api)", b["import_bsdf_tab"]),
        ("  of the imports: garbage collection", gc_imports),
        ("warp.init()", b["warp_init"]),
        ("plan_scene (groups one after the other)", b["plan"]),
        ("  of it: tabulations (api.tabulate, wall)", b["tabulate_wall"]),
        ("  of it: kernel launches (summed over threads)", b["launch_thread_s"]),
        ("  of it: kernel-module loads (first / all)", b["module_load_total"]),
        ("  planner's own work (plan - tabulations)", b["plan"] - b["tabulate_wall"]),
        ("JSON of the plan", b["json"]),
    ]
    print(f"where `plan examples/scene.json --tol 1e-3` spends its time (medians; {b['tabulate_calls']:.0f} "
          f"tabulations, {b['texels_computed']:.0f} texels, {b['evaluations'] / 1e6:.2f} M integrand evaluations, "
          f"{b['launches']:.0f} launches, {b['candidates_certified']:.0f} candidates certified, "
          f"{b['line_probes']:.0f} line probes; imports {imports:.2f} s):")
    for name, value in rows:
        print(f"  {name:<62} {value:7.3f} s")
    print(f"  {'plan CPU (all threads) / first module load':<62} {b['plan_cpu']:7.3f} s / {b['module_load_first']:.3f} s")
    if b.get("groups_cpu"):
        g = b["groups_cpu"]
        print(f"  {'CPU of each group (table), in order':<62} " + " ".join(f"{x:.2f}" for x in g) + " s")
        print(f"  {'integrand evaluations of each group, in order':<62} "
              + " ".join(f"{x / 1e6:.2f}" for x in b["groups_evaluations"]) + " M")
        print(f"  {'  on 2 free cores, groups on threads: at least max(largest, sum / 2)':<62} "
              f"{max(max(g), sum(g) / 2):7.3f} s")


def main(argv: list[str] | None = None, prog: str | None = None) -> int:
    ap = argparse.ArgumentParser(prog=prog, description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeats", type=int, default=3, help="runs per command (median; default 3)")
    ap.add_argument("--only", default=",".join(COMMANDS), help=f"commands, comma-separated ({', '.join(COMMANDS)})")
    ap.add_argument("--bytecode", default="env,cached", help="modes: env, cached (default both)")
    ap.add_argument("--checkout", action="append", default=None, metavar="DIR",
                    help="time the commands of this source checkout (repeat: checkouts interleaved, "
                         "e.g. before and after a change); default: this one")
    ap.add_argument("-o", "--output", default=str(DEFAULT_OUT), help="JSON output (default bench/out/startup.json)")
    ap.add_argument("--breakdown", default="paused", choices=("paused", "plain", "none"),
                    help="also time the plan's parts from inside one process, for each checkout (paused: "
                         "imports with the garbage collector paused, as bsdf-tab does; plain: running; none: skip)")
    args = ap.parse_args(argv)
    names = [n for n in args.only.split(",") if n]
    modes = [m for m in args.bytecode.split(",") if m]
    roots = [Path(c).resolve() for c in (args.checkout or [str(REPO_ROOT)])]
    bad = [n for n in names if n not in COMMANDS] + [m for m in modes if m not in ("env", "cached")]
    bad += [str(r) for r in roots if not (r / "bsdf_tab" / "__init__.py").is_file()]
    if bad or args.repeats < 1:
        print(f"{prog or 'startup.py'}: error: unknown command, mode or checkout: {', '.join(bad) or '--repeats < 1'}",
              file=sys.stderr)
        return 2
    load0 = os.getloadavg()
    rows = measure(names, modes, args.repeats, roots)
    parts = breakdown(args.breakdown, args.repeats, roots) if args.breakdown != "none" else {}
    print(f"load average at start: {load0[0]:.2f} {load0[1]:.2f} {load0[2]:.2f} ({os.cpu_count()} cores), "
          f"at end: {os.getloadavg()[0]:.2f}")
    print(f"{'checkout':<28} {'command':<14} {'bytecode':<8} {'wall s (median)':>16} {'cpu s':>8}  walls")
    for r in rows:
        walls = " ".join(f"{w:.2f}" for w in r["walls"])
        print(f"{r['checkout'][-28:]:<28} {r['command']:<14} {r['bytecode']:<8} {r['wall_s']:>16.2f} "
              f"{r['cpu_s']:>8.2f}  {walls}")
    for root, b in parts.items():
        print(f"{root}:")
        _print_breakdown(b)
    out = Path(args.output)
    out.parent.mkdir(parents=True, exist_ok=True)
    record = {
        "breakdown": parts, "breakdown_mode": args.breakdown,
        "load_average_at_start": load0, "load_average_at_end": os.getloadavg(), "cores": os.cpu_count(),
        "repeats": args.repeats, "python": sys.version.split()[0], "platform": platform.platform(),
        "pythondontwritebytecode": os.environ.get("PYTHONDONTWRITEBYTECODE"),
        "rows": rows,
    }
    out.write_text(json.dumps(record, indent=2))
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
