"""Baking many tables at once: the default set, a preset group, a material library.

In-process the tables are computed one after the other; with ``--scheduler ADDRESS|local:N``
(or ``BSDF_TAB_SCHEDULER``) every chunk of every table goes to a Dask cluster as one graph and
each table is written as soon as it completes. ``--resume`` skips tables whose file exists
(every file is written atomically, so an existing file is a whole table). An interrupted bake
leaves no partial file and says how many tables it wrote.
"""

from __future__ import annotations

import argparse
import os
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from ..errors import SpecError
from .common import PROG, CliError, check_device, check_texels, quiet_warp, refuse_file_name, summary

__all__ = ["Job", "add_cluster_arguments", "bake_library", "bake_specs", "check_cost", "connect_cluster", "exr_job", "is_library_file",
           "scheduler_of", "storage_words"]

SCHEDULER_ENV = "BSDF_TAB_SCHEDULER"


def add_cluster_arguments(parser: argparse.ArgumentParser) -> None:
    """``--scheduler`` and ``--resume``."""
    parser.add_argument("--scheduler", default=None, metavar="ADDRESS|local:N",
                        help=f"bake on a Dask cluster: tcp://host:8786, or local:N worker processes "
                             f"(default: ${SCHEDULER_ENV}, else in-process threads)")
    parser.add_argument("--resume", action="store_true",
                        help="skip tables whose output file already exists (a rerun after an interruption)")
    parser.add_argument("--max-seconds", type=float, default=None, metavar="S",
                        help="refuse, before computing, a bake the cost model (bsdf_tab.cost) predicts to take "
                             "longer than S seconds here")


def scheduler_of(args: argparse.Namespace) -> str | None:
    """The scheduler asked for: ``--scheduler``, else ``$BSDF_TAB_SCHEDULER``, else None."""
    given = getattr(args, "scheduler", None)
    value = given or os.environ.get(SCHEDULER_ENV) or None
    if value is None:
        return None
    from ..cluster import SchedulerError, parse_scheduler

    where = "--scheduler" if given else f"scheduler ${SCHEDULER_ENV}"
    try:
        form, _ = parse_scheduler(value)
    except SchedulerError as exc:  # a malformed value is one line before anything starts
        raise CliError(f"{where}: {str(exc).removeprefix('scheduler: ')}") from None
    if form == "address" and value.strip().lower().startswith("local:"):  # local:abc is not host:port
        raise CliError(f"{where}: local:N needs a whole number N >= 1 of worker processes, got {value!r}")
    return value


def _bar(total: int, quiet: bool):
    from tqdm import tqdm

    return tqdm(total=total, unit="texel", unit_scale=True, file=sys.stderr, disable=quiet, desc=PROG)


@dataclass
class Job:
    """One table to bake: where, from which spec, in which format, and what to do before
    writing (``finish(table) -> table``: a preset's layout, the storage report)."""

    out: Path
    spec: dict
    fmt: str = "exr"
    finish: Callable | None = None
    words: Callable | None = None  # words(table) -> text after the summary line
    after: Callable | None = None  # after(table, out): more files beside it (lookup code)


def bake_specs(args: argparse.Namespace, jobs: list) -> int:
    """Compute and write ``jobs`` (:class:`Job`, or (output path, spec) pairs), each table as it completes."""
    jobs = [j if isinstance(j, Job) else Job(Path(j[0]), j[1]) for j in jobs]
    todo = [j for j in jobs if not (getattr(args, "resume", False) and j.out.exists())]
    skipped = len(jobs) - len(todo)
    if skipped:
        print(f"{PROG}: --resume: {skipped} of {len(jobs)} tables exist, skipped", file=sys.stderr)
    if not todo:
        return 0
    for job in todo:
        check_texels(job.spec, str(job.out))
    check_cost(args, [j.spec for j in todo])
    scheduler = scheduler_of(args)
    quiet_warp(args)
    check_device(args, scheduler)
    client, owned = None, False
    if scheduler:
        client, owned = connect_cluster(scheduler)
    try:
        return _bake(args, todo, client)
    finally:
        if owned:
            from ..cluster import close

            close(client)


def check_cost(args: argparse.Namespace, specs: list[dict]) -> None:
    """``--max-seconds S``: one CliError line when the predicted wall time of ``specs`` exceeds S."""
    limit = getattr(args, "max_seconds", None)
    if limit is None:
        return
    if not limit > 0:
        raise CliError(f"--max-seconds must be > 0, got {limit:g}")
    from ..cost import check, estimate

    if len(specs) == 1:
        try:
            check(specs[0], limit, workers=args.workers)
        except ValueError as exc:  # CostLimitError: names the parameters and the prediction
            raise CliError(f"--max-seconds {limit:g}: {exc}") from None
        return
    total = sum(estimate(s).wall_seconds(args.workers) for s in specs)
    if total > limit:
        raise CliError(f"--max-seconds {limit:g}: the {len(specs)} tables are predicted to take {total:.3g} s "
                       "here; raise the limit, bake fewer tables, or use --scheduler")


def connect_cluster(scheduler: str):
    """(client, owned) for ``scheduler``, with its dashboard link on stderr; one line if unreachable."""
    from ..cluster import SchedulerError, connect, dashboard_link

    try:
        client, owned = connect(scheduler)
    except SchedulerError as exc:
        raise CliError(str(exc)) from None
    except ValueError as exc:  # Dask's own parse of a malformed address (tcp://host:abc)
        raise CliError(f"--scheduler {scheduler}: not a scheduler address ({exc})") from None
    n = len(client.scheduler_info().get("workers", {}))
    link = dashboard_link(client)
    print(f"{PROG}: scheduler {client.scheduler.address}, {n} workers"
          + (f", dashboard {link}" if link else ""), file=sys.stderr)
    return client, owned


def _bake(args, todo: list[Job], client) -> int:
    from .. import api, io
    from ..spec import texel_count

    written = 0
    with _bar(sum(texel_count(j.spec) for j in todo), args.quiet) as bar:
        try:
            for i, table in _tables(api, args, todo, client, bar):
                job = todo[i]
                job.out.parent.mkdir(parents=True, exist_ok=True)
                if job.finish is not None:
                    table = job.finish(table)
                api.check_finite(table.channels, f"output {job.out}")  # the last guard: never a file with NaN values
                try:
                    io.write(table, job.out, job.fmt)
                except ValueError as exc:  # e.g. values beyond the float16 range
                    raise CliError(f"output {job.out}: {exc}") from None
                written += 1
                words = job.words(table) if job.words is not None else ""
                bar.write(summary(job.out, table.as_stored(job.fmt)) + words, file=sys.stdout)
                if job.after is not None:
                    job.after(table, job.out)
        except KeyboardInterrupt:
            print(f"{PROG}: interrupted: {written} of {len(todo)} tables written (whole files only); "
                  "rerun with --resume to finish", file=sys.stderr)
            raise
    return 0


def _tables(api, args, todo, client, bar):
    """(index, Table) for each job: on the cluster as they complete, else one after the other."""
    from ..spec import texel_count

    if client is not None:
        def advance(done: int, total: int) -> None:
            bar.update(max(0, int(bar.total * done / total if total else 0) - bar.n))

        yield from api.tabulate_many([j.spec for j in todo], device=args.device, progress=advance,
                                     scheduler=client)
        return
    for i, job in enumerate(todo):
        spec = job.spec
        start, n = bar.n, texel_count(spec)

        def advance(done, total, start=start, n=n):
            # the integrators count their own work items (an *_avg table integrates several mu
            # per texel): scale them onto this table's share of the bar, never backwards
            bar.update(max(0, start + int(n * done / total if total else 0) - bar.n))

        table = api.tabulate(spec, device=args.device, workers=args.workers, progress=advance)
        bar.update(start + n - bar.n)
        yield i, table


def is_library_file(path: str) -> bool:
    """A bake input that is a material library (a top-level ``library`` table)."""
    from ..library import is_library
    from ..scene import load_scene_file

    try:
        return is_library(load_scene_file(path, strict=False))  # the library loader reports a repeated key
    except Exception:  # noqa: BLE001 - the other loaders report what is wrong with the file
        return False


def bake_library(args: argparse.Namespace) -> int:
    """``bsdf-tab bake LIBRARY [-o DIR]``: every material's tables under ``DIR/<material>/``."""
    from ..library import library_specs
    from ..scene import load_scene_file

    try:
        specs = library_specs(load_scene_file(args.spec))
    except SpecError as exc:  # one line naming the library parameter
        raise CliError(f"{args.spec}: {exc}") from None
    refuse_file_name(args.output, "a material library bake")
    out_dir = Path(args.output or "luts")
    if out_dir.exists() and not out_dir.is_dir():
        raise CliError(f"output {out_dir} exists and is not a folder (a library is baked into -o DIR)")
    return bake_specs(args, [exr_job(out_dir / rel, spec) for rel, spec in specs])


def exr_job(out: Path, spec: dict) -> Job:
    """A float32 EXR job whose table records its storage report (the rounding to float32)."""
    from ..io.storage import storage_report

    def finish(table):
        table.meta["storage"] = storage_report(table, "float32", "exr")
        return table

    return Job(out, spec, "exr", finish, storage_words)


def storage_words(table) -> str:
    """``"; storage float16 adds A 2.4e-04, B 8.9e-05"``: what the summary line says of storage."""
    report = table.meta.get("storage") or {}
    adds = ", ".join(f"{n} {c['storage_error']:.2g}" for n, c in report.get("channels", {}).items())
    return f"; storage {report.get('encoding', '?')} adds {adds or 'nothing'}"
