"""How the adaptive kernel is launched on a GPU: threads per block and the texels' order.

Run (on a machine with CUDA): ``python bench/gpu_launch.py [--device cuda:0] [--block-dims 256,32]``.
Prints a table and writes ``bench/out/gpu_launch.json``. For each case of ``bench/core.py``
(and its 64^3 table) it times ``integrate_texels`` on the device, the median of ``--reps`` runs,
under each block size (``runtime.CUDA_BLOCK_DIM``, set for the run) and two orders of the
texels: the table's own (what the library launches on CUDA) and the CPU's interleave (every 7th
texel together, which spreads expensive texels over worker threads; given here as permuted
inputs). Values do not depend on either (asserted: bit-identical per texel).

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


def interleave(n: int) -> np.ndarray:
    """The CPU launch order of the adaptive method (bsdf_tab.integrate.adaptive)."""
    return np.argsort(np.arange(n) % 7, kind="stable")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--device", default="cuda:0")
    parser.add_argument("--block-dims", default="256,32", help="comma-separated threads per block")
    parser.add_argument("--reps", type=int, default=3)
    parser.add_argument("--tol", type=float, default=None, help="the tables' tolerance (default: the spec's)")
    parser.add_argument("--out", default=str(Path(__file__).resolve().parent / "out" / "gpu_launch.json"))
    args = parser.parse_args(argv)
    try:
        dims = [int(x) for x in args.block_dims.split(",")]
    except ValueError:
        parser.error("--block-dims takes integers, e.g. 256,32")
    if not dims or any(d < 1 or d > 1024 for d in dims):
        parser.error("--block-dims: each in 1..1024")
    if args.reps < 1:
        parser.error("--reps must be >= 1")
    dev = runtime.resolve_device(args.device)
    cases = []
    for name, spec, mode in core.CASES + [core.LARGE]:
        spec = json.loads(json.dumps(spec))
        if args.tol is not None:
            spec["tolerance"] = args.tol
        table = bsdf_tab.tabulate(spec, device=dev)
        mu, alpha, eta, _ = core._flat(table, mode)
        cases.append((name, mode, mu, alpha, eta, core._kw(table, spec)))
    rows = []
    print(f"{'case':<24} {'texels':>7} " + " ".join(f"{f'{d}/{o}':>14}" for d in dims for o in ("table", "interleaved")))
    for name, mode, mu, alpha, eta, kw in cases:
        row = {"case": name, "texels": int(mu.size), "seconds": {}}
        first = None
        for d in dims:
            runtime.CUDA_BLOCK_DIM = d
            for order_name in ("table", "interleaved"):
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
                assert np.array_equal(v, first), f"{name}: values depend on the launch ({d}, {order_name})"
                row["seconds"][f"{d}/{order_name}"] = statistics.median(times)
        rows.append(row)
        print(f"{name:<24} {row['texels']:>7} " + " ".join(f"{s:>14.4f}" for s in row["seconds"].values()), flush=True)
    os.makedirs(os.path.dirname(args.out), exist_ok=True)
    with open(args.out, "w") as fh:
        json.dump({"device": dev.alias, "device_name": dev.name, "tol": args.tol, "rows": rows}, fh, indent=2)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
