"""Compile the package's kernel modules for a CUDA architecture into Warp's kernel cache, here.

A GPU machine that is lent for minutes should spend them on the run, not on NVRTC (about a
minute of one core per module for the adaptive kernels). Warp compiles CUDA code without a driver
(its wheel ships NVRTC), so the cache can be filled on the machine you work on and carried:

    WARP_CACHE_PATH=/some/dir python bench/cuda_prebuild.py --arch 90 --format cubin
    # on the GPU machine, with /some/dir copied there:
    WARP_CACHE_PATH=/some/dir python bench/core.py --device cuda:0 --no-numpy --large

The cache entry is found by the module's hash and the warp-lang version. The hash covers the
source, the options (the block size among them: one entry per ``--block-dims`` value; the library
launches CUDA kernels in blocks of 32 or 256 threads, ``runtime.cuda_block_dim``) and, measured, the Python
minor version: 3.11 and 3.12 hash the same module differently. So run this under the Python version
of the GPU machine, on the same commit and warp-lang; a module whose entry does not match is
compiled there as usual (slower, never wrong: the adaptive module took 95 s on an H200 machine).
Format: Warp loads PTX only where the driver is at least as new as the wheel's CUDA toolkit, and
CUBIN otherwise; ``--format both`` fills both. Prints one line per module and exits 1 when one
fails.
"""

from __future__ import annotations

import argparse
import importlib
import os
import re
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1] / "bsdf_tab"


def kernel_modules() -> list[str]:
    """Every module of the package that defines a kernel (the CUDA compile test's rule)."""
    return sorted(
        "bsdf_tab." + ".".join(p.relative_to(ROOT).with_suffix("").parts)
        for p in ROOT.rglob("*.py")
        if re.search(r"^@wp\.kernel", p.read_text(encoding="utf-8"), re.MULTILINE)
    )


def _compile(name: str, arch: int, formats: tuple[str, ...], block_dim: int) -> tuple[str, float, str]:
    import warp as wp

    t0 = time.perf_counter()
    try:
        module = importlib.import_module(name)
        wp.get_module(name).options["block_dim"] = block_dim  # part of the hash and the cache entry
        for fmt in formats:
            wp.compile_aot_module(module, arch=arch, use_ptx=fmt == "ptx")
        return name, time.perf_counter() - t0, ""
    except Exception as exc:  # reported per module; the others go on
        return name, time.perf_counter() - t0, f"{type(exc).__name__}: {exc}"


def main(argv=None, prog=None) -> int:
    parser = argparse.ArgumentParser(prog=prog, description=__doc__.splitlines()[0])
    parser.add_argument("--arch", type=int, default=90, help="compute capability x 10 (default 90: Hopper)")
    parser.add_argument("--format", choices=("cubin", "ptx", "both"), default="cubin")
    parser.add_argument("--block-dims", default=None,
                        help="comma-separated threads per block (default: 32,256, the library's two)")
    parser.add_argument("--modules", default=None, help="comma-separated module names (default: every kernel module)")
    parser.add_argument("-j", "--jobs", type=int, default=os.cpu_count() or 1, help="processes (default: all cores)")
    args = parser.parse_args(argv)
    if "WARP_CACHE_PATH" not in os.environ:
        parser.error("set WARP_CACHE_PATH to the cache folder to fill (the one you will carry)")
    if args.jobs < 1:
        parser.error("--jobs must be >= 1")
    formats = ("cubin", "ptx") if args.format == "both" else (args.format,)
    try:
        dims = [int(x) for x in (args.block_dims or "32,256").split(",")]
    except ValueError:
        parser.error("--block-dims takes integers, e.g. 32,256")
    if any(d < 1 or d > 1024 for d in dims):
        parser.error("--block-dims: each in 1..1024")
    names = kernel_modules()
    if args.modules is not None:
        unknown = set(args.modules.split(",")) - set(names)
        if unknown:
            parser.error(f"--modules: not kernel modules: {', '.join(sorted(unknown))}")
        names = args.modules.split(",")
    failed = 0
    with ProcessPoolExecutor(max_workers=args.jobs) as pool:
        futures = [(d, pool.submit(_compile, name, args.arch, formats, d)) for d in dims for name in names]
        for d, fut in futures:
            name, seconds, error = fut.result()
            failed += bool(error)
            print(f"{name:<40} block {d:<4} {seconds:7.1f} s  {'FAILED ' + error if error else 'ok'}", flush=True)
    print(f"cache: {os.environ['WARP_CACHE_PATH']}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
