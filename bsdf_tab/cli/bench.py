"""``bsdf-tab bench NAME [ARGS...]``: run a benchmark script of the source checkout.

The benchmarks live in ``bench/`` of the checkout, never in the installed package (the accuracy
benchmark needs the independent reference in ``tests/reference``). This command finds the
checkout (``$BSDF_TAB_CHECKOUT``, else the one holding this package, as in an editable install,
else the current folder or one above it), loads ``bench/NAME.py`` and calls its
``main(argv, prog)`` with the remaining arguments, so ``bsdf-tab bench accuracy --quick`` and
``python bench/accuracy.py --quick`` are the same run. Nothing of ``bench/`` is imported until
then: building the parser stays cheap.
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import sys
from pathlib import Path

from .common import PROG, CliError, quiet_warp

NAME = "bench"

#: benchmark name -> (script under bench/, one-line description)
BENCHMARKS = {
    "accuracy": ("accuracy.py", "every integration method: error against time, Pareto front, heatmaps, honesty"),
    "compare_peers": ("compare_peers.py", "the engine presets against the tables the engines ship"),
    "ltc": ("ltc.py", "LTC fit side by side with the shipped table"),
    "cluster": ("cluster.py", "in-process against a local Dask cluster: overhead, per-task cost, bytes moved"),
    "core": ("core.py", "the core tables: times, integrand evaluations per texel and where they go"),
    "versions": ("versions.py", "two checkouts interleaved: the core tables and the example scene plan"),
    "honesty": ("accuracy_honesty.py", "the adaptive method's honesty and evaluations on 1634 reference texels"),
    "honesty_scans": ("honesty_scans.py", "stress scans of the error channel: near normal and grazing incidence, general, random seeds"),
    "inner_honesty": ("inner_honesty.py", "single inner integrals: where the two-stage rule's first stage under-reports"),
    "anisotropy": ("anisotropy.py", "the isotropic collapse of anisotropic GGX, and the furnace after it"),
    "anisotropy_tables": ("anisotropy_tables.py", "the smallest albedo_aniso table under a lookup error"),
    "sheen_peers": ("sheen_peers.py", "our sheen albedo against MaterialX's and three.js' fits and tables"),
    "eval_cost": ("eval_cost.py", "time per evaluation: the integrand alone against inside the inner phi integrals"),
    "gpu_launch": ("gpu_launch.py", "on a GPU: threads per block, texel order and launch size of the adaptive kernel"),
    "cuda_prebuild": ("cuda_prebuild.py", "fill Warp's kernel cache for a CUDA arch here, to carry to a GPU machine"),
    "load": ("load.py", "the service's hot path against a minimal app: requests/s and p99"),
    "startup": ("startup.py", "where users wait: --help, a small bake, the example plan, the service's cold start"),
}

HELP = "run a benchmark from the source checkout (" + ", ".join(BENCHMARKS) + ")"

#: environment variable naming the checkout explicitly
CHECKOUT_ENV = "BSDF_TAB_CHECKOUT"

#: the folder above this package: the checkout of an editable install
PACKAGE_PARENT = Path(__file__).resolve().parents[2]


def configure(parser: argparse.ArgumentParser) -> None:
    lines = [f"  {name:<14} {text}" for name, (_, text) in BENCHMARKS.items()]
    parser.description = (
        "Run a benchmark script of the source checkout (bench/NAME.py) with the arguments that "
        "follow its name (bsdf-tab bench NAME --help lists them). Outputs go to bench/out/ unless "
        "the benchmark's -o says otherwise."
    )
    parser.epilog = "benchmarks:\n" + "\n".join(lines)
    parser.formatter_class = argparse.RawDescriptionHelpFormatter
    parser.add_argument("benchmark", nargs="?", metavar="NAME", help="one of: " + ", ".join(BENCHMARKS))
    parser.add_argument("bench_args", nargs=argparse.REMAINDER, metavar="ARGS",
                        help="the benchmark's own options (e.g. accuracy --quick)")


def is_checkout(folder: Path) -> bool:
    """Whether ``folder`` is a source checkout of bsdf-tab (``bench/`` next to ``bsdf_tab/``)."""
    return (folder / "bench" / "accuracy.py").is_file() and (folder / "bsdf_tab").is_dir()


def find_checkout(cwd: Path | None = None) -> Path:
    """The source checkout whose ``bench/`` to run (see the module docstring).

    Raises
    ------
    CliError
        When none is found, or ``$BSDF_TAB_CHECKOUT`` names a folder that is not one.
    """
    named = os.environ.get(CHECKOUT_ENV)
    if named:
        folder = Path(named).expanduser().resolve()
        if not is_checkout(folder):
            raise CliError(f"{PROG} bench needs a source checkout: {CHECKOUT_ENV}={named} has no bench/accuracy.py "
                           "next to bsdf_tab/")
        return folder
    if is_checkout(PACKAGE_PARENT):
        return PACKAGE_PARENT
    start = (cwd or Path.cwd()).resolve()
    for folder in (start, *start.parents):
        if is_checkout(folder):
            return folder
    raise CliError(f"{PROG} bench needs a source checkout: none holds this package ({PACKAGE_PARENT}) or the "
                   f"current folder ({start}); run it from a clone of the repository or set {CHECKOUT_ENV}")


def load_script(path: Path):
    """Import ``path`` as a module under a private name (its ``__main__`` block does not run)."""
    spec = importlib.util.spec_from_file_location(f"_bsdf_tab_bench_{path.stem}", path)
    if spec is None or spec.loader is None:
        raise CliError(f"cannot load {path}")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def run(args: argparse.Namespace) -> int:
    name = getattr(args, "benchmark", None)
    if not name:
        raise CliError(f"choose a benchmark: {PROG} bench NAME [ARGS...], NAME one of {', '.join(BENCHMARKS)} "
                       f"(e.g. {PROG} bench accuracy --quick)")
    if name not in BENCHMARKS:
        raise CliError(f"unknown benchmark {name!r}; one of {', '.join(BENCHMARKS)}")
    checkout = find_checkout()
    script = checkout / "bench" / BENCHMARKS[name][0]
    if not script.is_file():
        raise CliError(f"{PROG} bench needs a source checkout with {script.relative_to(checkout)}: not in {checkout}")
    quiet_warp(args)
    if str(checkout) not in sys.path:
        sys.path.insert(0, str(checkout))
    main = getattr(load_script(script), "main", None)
    if main is None:
        raise CliError(f"{script} has no main(argv, prog)")
    try:
        return int(main(list(getattr(args, "bench_args", None) or []), prog=f"{PROG} bench {name}") or 0)
    except SystemExit as exc:  # the benchmark's argparse: --help (0) or a usage error (2)
        return exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 2)
    except RuntimeError as exc:  # e.g. the reference is not importable
        raise CliError(str(exc)) from None
    except ValueError as exc:
        if not _option_error(exc, script):  # a ValueError deeper down is a bug: an internal error
            raise
        raise BenchOptionError(str(exc)) from None


class BenchOptionError(CliError, ValueError):
    """A benchmark's bad option: one line, exit 2 (a :class:`CliError`), and still the
    ValueError the benchmarks' ``main`` documents for callers of :func:`run`."""


def _option_error(exc: ValueError, script: Path) -> bool:
    """Whether ``exc`` was raised by the benchmark's own option checks: the benchmarks' contract
    is that ``main`` (or ``main_from_args``) of a ``bench/`` script raises ValueError for a bad
    option, so the innermost frame is such a function in ``bench/``."""
    tb = exc.__traceback__
    if tb is None:
        return False
    while tb.tb_next is not None:
        tb = tb.tb_next
    code = tb.tb_frame.f_code
    return Path(code.co_filename).resolve().parent == script.resolve().parent and code.co_name.startswith("main")
