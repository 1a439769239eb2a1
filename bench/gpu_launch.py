"""How the adaptive kernel is launched on a GPU: threads per block and the texels' order.

Run (on a machine with CUDA): ``python bench/gpu_launch.py [--device cuda:0] [--block-dims 256,32]``.
Prints a table and writes ``bench/out/gpu_launch.json``. For each case of ``bench/core.py``
(and its 64^3 table) it times ``integrate_texels`` on the device, the median of ``--reps`` runs,
under each block size (``runtime.CUDA_BLOCK_DIM``, set for the run; ``rule``: the library's
``runtime.cuda_block_dim``), each launch size (``--chunks``, ``runtime.CUDA_CHUNK``) and two orders of the
texels: the table's own (what the library launches on CUDA) and the CPU's interleave (every 7th
texel together, which spreads expensive texels over worker threads; given here as permuted
inputs). Values do not depend on either (asserted: bit-identical per texel). ``--sweep`` times
dielectric tables of 16^3 .. 64^3 texels instead (eta > 1, the spec's axes), for the block size
rule of ``runtime.cuda_block_dim``; ``--orders`` picks the orders.

Each block size is a separate compile of the module (Warp hashes it into the module): fill the
kernel cache first with ``bench/cuda_prebuild.py --block-dims`` under the same Python version,
or expect a compile per block size on the GPU machine.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import bsdf_tab  # noqa: E402
from bsdf_tab.integrate import runtime  # noqa: E402
from bsdf_tab.integrate.adaptive import integrate_texels  # noqa: E402
import core  # noqa: E402
from common import device_arg  # noqa: E402


def interleave(n: int) -> np.ndarray:
    """The CPU launch order of the adaptive method (bsdf_tab.integrate.adaptive)."""
    return np.argsort(np.arange(n) % 7, kind="stable")


def main(argv=None, prog=None) -> int:
    parser = argparse.ArgumentParser(prog=prog, description=__doc__.splitlines()[0])
    parser.add_argument("--device", default="cuda:0")
    parser.add_argument("--block-dims", default="256,32", help="comma-separated threads per block, or rule")
    parser.add_argument("--chunks", default=str(runtime.CUDA_CHUNK), help="comma-separated texels per launch")
    parser.add_argument("--orders", default="table,interleaved", help="comma-separated: table, interleaved")
    parser.add_argument("--sweep", action="store_true", help="dielectric tables 16^3 .. 64^3 instead of the core cases")
    parser.add_argument("--reps", type=int, default=3)
    parser.add_argument("--tol", type=float, default=None, help="the tables' tolerance (default: the spec's)")
    parser.add_argument("--out", default=str(Path(__file__).resolve().parent / "out" / "gpu_launch.json"))
    args = parser.parse_args(argv)
    try:
        dims = [None if x == "rule" else int(x) for x in args.block_dims.split(",")]
        chunks = [int(x) for x in args.chunks.split(",")]
    except ValueError:
        parser.error("--block-dims takes integers or rule, --chunks integers")
    if not dims or any(d is not None and not 1 <= d <= 1024 for d in dims):
        parser.error("--block-dims: each in 1..1024, or rule")
    if not chunks or any(c < 1 for c in chunks):
        parser.error("--chunks: each >= 1")
    if args.reps < 1:
        parser.error("--reps must be >= 1")
    orders = args.orders.split(",")
    if not orders or not set(orders) <= {"table", "interleaved"}:
        parser.error("--orders: table and/or interleaved")
    dev = device_arg(parser, args.device)
    cases = []
    if args.sweep:
        todo = [(f"dielectric {k}^3 eta>1", {"table": "dielectric", "axes": {a: {"size": k} for a in ("mu", "alpha", "eta")}},
                 "dielectric") for k in (16, 24, 32, 40, 48, 64)]
    else:
        todo = core.CASES + [core.LARGE]
    for name, spec, mode in todo:
        spec = json.loads(json.dumps(spec))
        if args.tol is not None:
            spec["tolerance"] = args.tol
        table = bsdf_tab.tabulate(spec, device=dev)
        mu, alpha, eta, _ = core.flat_texels(table, mode)
        cases.append((name, mode, mu, alpha, eta, core.integrator_keywords(spec)))
    rows = []
    configs = [(d, c, o) for d in dims for c in chunks for o in orders]

    def label(d, c, o):
        return f"{d or 'rule'}/{o}" + (f"/{c}" if len(chunks) > 1 else "")

    print(f"{'case':<24} {'texels':>7} " + " ".join(f"{label(*k):>16}" for k in configs))
    for name, mode, mu, alpha, eta, kw in cases:
        row = {"case": name, "texels": int(mu.size), "seconds": {}}
        first = None
        for d, c, order_name in configs:
            runtime.CUDA_BLOCK_DIM, runtime.CUDA_CHUNK = d, c
            perm = np.arange(mu.size) if order_name == "table" else interleave(mu.size)
            inv = np.argsort(perm)
            integrate_texels(mode, mu[perm], alpha[perm], eta[perm], device=dev, **kw)  # load
            times = []
            for _ in range(args.reps):
                t0 = time.perf_counter()
                v, _e = integrate_texels(mode, mu[perm], alpha[perm], eta[perm], device=dev, **kw)
                times.append(time.perf_counter() - t0)
            v = v[inv]
            if first is None:
                first = v
            assert np.array_equal(v, first), f"{name}: values depend on the launch ({label(d, c, order_name)})"
            row["seconds"][label(d, c, order_name)] = statistics.median(times)
        rows.append(row)
        print(f"{name:<24} {row['texels']:>7} " + " ".join(f"{s:>16.4f}" for s in row["seconds"].values()), flush=True)
    os.makedirs(os.path.dirname(args.out), exist_ok=True)
    with open(args.out, "w") as fh:
        json.dump({"device": dev.alias, "device_name": dev.name, "tol": args.tol, "sweep": args.sweep, "rows": rows}, fh, indent=2)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
