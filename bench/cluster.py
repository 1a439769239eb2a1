"""The cost of baking on a Dask cluster, measured on this machine, and a scaling model.

    python3 bench/cluster.py [--quick] [--workers 2] [--out bench/out/cluster.json]

In one run: each case baked in-process (worker threads) and on a warm ``LocalCluster`` of N
worker processes (one thread each), interleaved and repeated (medians); the per-task overhead
(a one-texel chunk's round trip), the bytes moved per chunk (arguments and results), and the
cluster's start-up. Prints a table and writes JSON; docs/cluster.md turns the figures into the
model of the speed-up at 8, 64 and 512 workers.
"""

from __future__ import annotations

import argparse
import json
import math
import pickle
import statistics
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import bsdf_tab  # noqa: E402
from bsdf_tab import api, cluster  # noqa: E402
from bsdf_tab.spec import normalize_spec, resolve_axes, texel_count  # noqa: E402

CASES = {
    "albedo 64^2": {"table": "albedo", "axes": {"mu": {"size": 64}, "alpha": {"size": 64}}},
    "dielectric 16^3": {"table": "dielectric", "axes": {"mu": {"size": 16}, "alpha": {"size": 16}, "eta": {"size": 16}}},
    "dielectric 24^3": {"table": "dielectric", "axes": {"mu": {"size": 24}, "alpha": {"size": 24}, "eta": {"size": 24}}},
}
QUICK = ("albedo 64^2", "dielectric 16^3")


def _time(fn, repeat: int) -> tuple[float, list[float]]:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), times


def task_overhead(client, repeat: int = 20) -> float:
    """Median round trip of a one-texel chunk (scheduling, pickling, the kernel launch)."""
    nspec = normalize_spec({"table": "albedo", "axes": {"mu": [0.5], "alpha": [0.5]}})
    axes = resolve_axes(nspec)
    times = []
    for k in range(repeat):
        t0 = time.perf_counter()
        fut = client.submit(cluster.compute_chunk, nspec, axes, {0: [0]}, None, pure=False, key=f"probe-{k}")
        fut.result()
        times.append(time.perf_counter() - t0)
    return statistics.median(times[2:])


def chunk_bytes(nspec: dict, axes: dict, n_workers: int) -> dict:
    """Bytes sent to and returned from the workers for one table (pickled sizes)."""
    sizes = [len(v) for v in axes.values()]
    total = math.prod(sizes)
    target = cluster.chunk_texels(total, n_workers)
    spans = cluster.chunks(sizes, 0, target)
    sent = sum(len(pickle.dumps((nspec, axes, cut, None))) for cut in spans)
    n_channels = 2 * len(bsdf_tab.tables.CATALOG[nspec["table"]]["channels"])
    returned = total * n_channels * 8
    return {"tasks": len(spans), "texels_per_task": target, "bytes_sent": sent, "bytes_returned": returned}


def main(argv=None, prog: str | None = None) -> int:
    parser = argparse.ArgumentParser(prog=prog, description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="two small cases, 2 repeats")
    parser.add_argument("--workers", type=int, default=2, help="local worker processes (default 2)")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--out", default=str(ROOT / "bench" / "out" / "cluster.json"))
    args = parser.parse_args(argv)
    if args.workers < 1 or args.repeat < 1:
        print(f"{prog or 'cluster.py'}: error: --workers and --repeat must be >= 1", file=sys.stderr)
        return 2
    import distributed

    api.quiet_warp()
    names = QUICK if args.quick else tuple(CASES)
    repeat = 2 if args.quick else args.repeat
    t0 = time.perf_counter()
    lc = distributed.LocalCluster(n_workers=args.workers, threads_per_worker=1, processes=True,
                                  host="127.0.0.1", dashboard_address=None, silence_logs=40)
    client = distributed.Client(lc)
    client.register_plugin(cluster.WarpWorker(), name="bsdf-tab-warp")
    startup = time.perf_counter() - t0
    try:
        # warm: every worker loads the kernel modules once
        bsdf_tab.tabulate({"table": "dielectric", "axes": {"mu": [0.5, 1.0], "alpha": [0.3], "eta": [1.5]}},
                          scheduler=client)
        bsdf_tab.tabulate({"table": "albedo", "axes": {"mu": [0.5, 1.0], "alpha": [0.3]}}, device="cpu")
        overhead = task_overhead(client)
        rows = []
        for name in names:
            spec = CASES[name]
            inproc, cl = [], []
            same = True
            ref = None
            for _ in range(repeat):  # interleaved: the machine's load hits both alike
                t = time.perf_counter()
                a = bsdf_tab.tabulate(spec, device="cpu", workers=args.workers)
                inproc.append(time.perf_counter() - t)
                t = time.perf_counter()
                b = bsdf_tab.tabulate(spec, scheduler=client)
                cl.append(time.perf_counter() - t)
                ref = ref or a
                same = same and all(np.array_equal(a.channels[c], b.channels[c]) for c in a.channels)
            nspec = normalize_spec(spec)
            moved = chunk_bytes(nspec, resolve_axes(nspec), args.workers)
            rows.append({"case": name, "texels": texel_count(nspec), "in_process_s": statistics.median(inproc),
                         "cluster_s": statistics.median(cl), "ratio": statistics.median(cl) / statistics.median(inproc),
                         "bit_identical": bool(same), "in_process_all": inproc, "cluster_all": cl, **moved})
    finally:
        client.close()
        lc.close()
    result = {"workers": args.workers, "startup_s": startup, "task_overhead_s": overhead, "rows": rows,
              "machine": "2-core CPU" if args.workers == 2 else f"{args.workers} local workers"}
    print(f"LocalCluster of {args.workers} processes: start-up {startup:.1f} s, per-task round trip "
          f"{overhead * 1e3:.1f} ms")
    print(f"{'case':<18} {'texels':>7} {'tasks':>5} {'in-process s':>13} {'local:%d s' % args.workers:>11} "
          f"{'ratio':>6} {'KB sent':>8} {'KB back':>8} {'identical':>9}")
    for r in rows:
        print(f"{r['case']:<18} {r['texels']:>7} {r['tasks']:>5} {r['in_process_s']:>13.2f} {r['cluster_s']:>11.2f} "
              f"{r['ratio']:>6.2f} {r['bytes_sent'] / 1e3:>8.1f} {r['bytes_returned'] / 1e3:>8.1f} "
              f"{str(r['bit_identical']):>9}")
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(result, indent=2))
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
