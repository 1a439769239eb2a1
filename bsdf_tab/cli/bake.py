"""``bsdf-tab bake``: one spec file, the default set, an engine preset, or a scene's tables.

``bake SPEC.json [-o FILE]`` writes one table (the format from the output name or
``--format``); ``bake`` alone writes the default set (:func:`bsdf_tab.presets.default_specs`)
into ``luts/``; ``bake --preset NAME -o DIR`` an engine layout; ``bake SCENE --tol T -o DIR``
the tables a scene needs (:mod:`.plan`). Every table goes spec -> ``bsdf_tab.api`` -> a writer
of :mod:`bsdf_tab.io`.

Storage: every file's ``meta["storage"]`` reports, per channel, the integration error and the
error its storage adds (:mod:`bsdf_tab.io.storage`). The texture formats (``ktx2``, ``dds``,
``png``) take ``--precision float32|float16|unorm16|unorm10|unorm8`` (a preset: its engine's
encoding) or ``--precision auto --store-tol T``: the smallest encoding whose stored values stay
within T of the exact ones (integration + storage error, texel by texel). ``--tol`` means the
lookup error for a scene file and, with ``--precision auto`` and any other input, the same as
``--store-tol``.

``--emit glsl,hlsl,wgsl,c,warp`` also writes lookup code beside the table
(:func:`bsdf_tab.lookup.emit_files`).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from .common import (
    CliError,
    check_device,
    check_texels,
    check_workers,
    load_spec_file,
    output_folder,
    quiet_warp,
    refuse_file_name,
    summary,
)
from .many import (
    Job,
    add_cluster_arguments,
    bake_library,
    bake_specs,
    check_cost,
    exr_job,
    is_library_file,
    scheduler_of,
)
from .plan import bake_scene, is_scene_file

# The formats (bsdf_tab.io, NumPy) are imported where they are used: building the parser of
# another command, or `bsdf-tab --help`, does not load them.
EMIT_LANGS = ("glsl", "hlsl", "wgsl", "c", "warp")

NAME = "bake"
#: what the handler imports (``main.preload``: with the garbage collector paused)
IMPORTS = ("bsdf_tab.io", "bsdf_tab.spec", "bsdf_tab.api", "bsdf_tab.scene")
HELP = "bake a spec file (or the default set) to EXR"


def configure(parser: argparse.ArgumentParser) -> None:
    from .. import io
    from ..io.storage import ENCODINGS

    parser.add_argument(
        "spec", nargs="?", help="spec JSON file, or a scene file (JSON or .toml); without it, bake the default set"
    )
    parser.add_argument(
        "-o", "--output",
        help=f"output file ({', '.join(io.ENDINGS)}); with no spec or --preset, the output folder "
             "(default: luts/)",
    )
    parser.add_argument("--device", default=None, help="Warp device, for example cpu or cuda:0 (default: Warp's)")
    parser.add_argument("--workers", type=int, default=None, help="number of parallel workers")
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    parser.add_argument("--preset", default=None, help="bake an engine preset or group (see `bsdf-tab presets`) into -o DIR")
    parser.add_argument(
        "--format", default=None, choices=io.FILE_FORMATS,
        help="file format (a spec file: default from the -o name, else exr; --preset: the engine's, else exr)",
    )
    parser.add_argument(
        "--tol", type=float, default=None,
        help="a scene file: max lookup error (docs/scenes.md); otherwise, with --precision auto, as --store-tol",
    )
    parser.add_argument(
        "--precision", default=None, choices=("auto", *ENCODINGS),
        help="storage of a ktx2 / dds / png file (default: the preset's, else float16 / unorm16); "
             "auto: the smallest within --store-tol",
    )
    parser.add_argument("--store-tol", type=float, default=None,
                        help="with --precision auto: max error of the stored values (integration + storage)")
    parser.add_argument("--emit", action="append", default=None, metavar="LANG[,LANG]",
                        help=f"also write lookup code beside the table: {', '.join(EMIT_LANGS)} (repeat or comma-separate)")
    add_cluster_arguments(parser)


def run(args: argparse.Namespace) -> int:
    """Bake one spec file, or the default set when no spec is given, or a preset, or a scene."""
    check_workers(args)
    args.emit_langs = _emit_langs(args.emit)
    if args.spec and args.preset is None and is_library_file(args.spec):
        if args.format is not None or args.precision is not None or args.emit_langs or args.tol is not None:
            raise CliError("--format, --precision, --emit and --tol do not apply to a material library (EXR tables)")
        return bake_library(args)
    if args.spec and args.preset is None and is_scene_file(args.spec):
        if args.format is not None:
            raise CliError("--format: a scene is baked as EXR tables and manifest.json")
        if args.precision is not None or args.store_tol is not None or args.emit_langs:
            raise CliError("--precision, --store-tol and --emit apply to a spec file or --preset, not a scene")
        if args.resume:
            raise CliError("--resume applies to a spec file, --preset, a library or the default set")
        if args.max_seconds is not None:  # the planner's tabulations are not predicted by the cost model
            raise CliError("--max-seconds applies to a spec file, --preset, a library or the default set, "
                           "not a scene (its planning cost is not predicted)")
        refuse_file_name(args.output, "a scene bake (its tables and manifest.json)")
        return bake_scene(args)
    _check_storage_options(args)
    if args.preset is not None:
        return _bake_preset(args)
    if args.format is not None and not args.spec:
        raise CliError("--format applies to a spec file or --preset (the default set is baked as exr)")
    return _bake_one(args) if args.spec else _bake_default_set(args)


def _output_format(out: Path, fmt: str | None) -> str:
    """The format of output file ``out``: from its ending, checked against ``--format``."""
    from .. import io

    try:
        found = io.format_for(out)
    except ValueError:
        raise CliError(f"output {out}: the name must end in {', '.join(io.ENDINGS)}") from None
    if fmt is not None and fmt != found.name:
        raise CliError(f"--format {fmt} does not match the output {out.name} ({found.name}); "
                       f"use a name ending in {io.get_format(fmt).suffixes[0]}")
    return found.name


def _bake_one(args: argparse.Namespace) -> int:
    spec_path = Path(args.spec)
    from .. import io

    spec = load_spec_file(spec_path)
    ending = io.get_format(args.format).suffixes[0] if args.format else ".exr"
    out = Path(args.output) if args.output else spec_path.with_name(spec_path.stem + ending)
    if out.is_dir():
        out = out / (spec_path.stem + ending)
    fmt = _output_format(out, args.format)
    if not out.parent.is_dir():
        raise CliError(f"output folder does not exist: {out.parent}")
    if args.resume and out.exists():
        print(f"{out}: exists, skipped (--resume)")
        return 0
    from .. import api

    if not (io.can_stream(fmt) and api.streams(spec)):  # a streamed bake is computed in blocks
        check_texels(spec, str(spec_path))
    check_cost(args, [spec])
    quiet_warp(args)
    scheduler = scheduler_of(args)
    check_device(args, scheduler)
    client, owned = (None, False)
    if scheduler is not None:
        from .many import connect_cluster

        client, owned = connect_cluster(scheduler)
    try:
        return _compute_and_write(args, spec, out, fmt, client)
    finally:
        if owned:
            from ..cluster import close

            close(client)


def _compute_and_write(args: argparse.Namespace, spec: dict, out: Path, fmt: str, client) -> int:
    from .. import api, io

    if io.can_stream(fmt) and api.streams(spec):
        # directional tables can be large: computed and written in blocks (bounded memory)
        if args.precision is not None or args.emit_langs:
            raise CliError(f"--precision and --emit do not apply to a streamed {fmt} bake (a directional table)")
        blocks = api.iter_blocks(spec, device=args.device, workers=args.workers, progress=not args.quiet,
                                 scheduler=client)
        table = io.write_stream(blocks, out, fmt)
        storage = table.meta.get("storage")
        print(summary(out, table) + (storage_words(storage) if isinstance(storage, dict) else ""))
        return 0
    table = api.tabulate(spec, device=args.device, workers=args.workers, progress=not args.quiet,
                         scheduler=client)
    _with_storage(table, fmt, args, None)
    _write(table, out, fmt)
    stored = table.as_stored(fmt)
    print(summary(out, stored) + storage_words(table.meta["storage"]))
    _emit(stored, out, args.emit_langs)
    return 0


def storage_words(report: dict) -> str:
    """``"; storage float16 adds A 2.4e-04, B 8.9e-05"``: what the summary line says of storage."""
    adds = ", ".join(f"{n} {c['storage_error']:.2g}" for n, c in report.get("channels", {}).items())
    return f"; storage {report['encoding']} adds {adds or 'nothing'}"


def _emit_langs(values: list[str] | None) -> list[str]:
    """The ``--emit`` languages, in order, each once; CliError naming an unknown one."""
    langs: list[str] = []
    for value in values or []:
        for lang in (v.strip().lower() for v in value.split(",")):
            if lang not in EMIT_LANGS:
                raise CliError(f"--emit: unknown language {lang!r}; choose from {', '.join(EMIT_LANGS)}")
            if lang not in langs:
                langs.append(lang)
    return langs


def _check_storage_options(args: argparse.Namespace) -> None:
    """``--tol`` / ``--store-tol`` / ``--precision`` outside a scene: consistent, or one CliError line."""
    if args.tol is not None:
        if args.precision != "auto":
            raise CliError("--tol applies to a scene file (a JSON object with a 'materials' list), "
                           "or with --precision auto to the stored values")
        if args.store_tol is not None and args.store_tol != args.tol:
            raise CliError("give --store-tol or --tol, not both")
        args.store_tol = args.tol
    if args.precision == "auto" and args.store_tol is None:
        raise CliError("--precision auto needs --store-tol T (the max error of the stored values)")
    if args.store_tol is not None:
        if args.precision != "auto":
            raise CliError("--store-tol applies to --precision auto")
        if not args.store_tol > 0:
            raise CliError("--store-tol must be > 0")
    if args.precision is not None and not args.spec and args.preset is None:
        raise CliError("--precision applies to a spec file or --preset")


def _with_storage(table, fmt: str, args: argparse.Namespace, preset_encoding: str | None) -> None:
    """Set ``table.meta["storage"]``: the encoding the ``fmt`` file uses and its measured errors."""
    from ..io.storage import FORMAT_STORAGE, choose_encoding, storage_report

    choices = FORMAT_STORAGE[fmt]
    precision = args.precision
    if precision == "auto":
        if len(choices) == 1:
            raise CliError(f"--precision auto: {fmt} stores only {choices[0]}; "
                           "choose a texture format (ktx2, dds, png) to pick a storage")
        try:
            encoding, report = choose_encoding(table, fmt, args.store_tol)
        except ValueError as exc:
            raise CliError(f"--precision auto: {exc}") from None
    else:
        encoding = precision or (preset_encoding if preset_encoding in choices else choices[0])
        if encoding not in choices:
            raise CliError(f"--precision {encoding}: {fmt} stores {', '.join(choices)}")
        try:
            report = storage_report(table, encoding, fmt)
        except ValueError as exc:
            raise CliError(f"output {fmt}: {exc}") from None
    table.meta["storage"] = report


def _emit(table, out: Path, langs: list[str]) -> None:
    """Write the lookup code of ``table`` beside ``out`` for each of ``langs``; print each file."""
    if not langs:
        return
    try:
        from ..lookup import emit_files
    except ImportError:
        raise CliError("lookup code generation is not available") from None
    try:
        paths = emit_files(table, out, langs)
    except ValueError as exc:
        raise CliError(f"--emit: {exc}") from None
    for path in paths:
        print(f"{path}: lookup code")


def _write(table, out: Path, fmt: str) -> None:
    from .. import io
    from ..api import check_finite

    check_finite(table.channels, f"output {out}")  # the last guard: never a file with NaN values
    try:
        io.write(table, out, fmt)
    except FileNotFoundError:
        raise
    except ValueError as exc:  # e.g. values beyond the float16 range (a FormatError is one too)
        raise CliError(f"output {out}: {exc}") from None


def _bake_default_set(args: argparse.Namespace) -> int:
    from ..presets import default_specs
    from ..spec import normalize_spec

    out_dir = output_folder(args.output, "no spec")
    return bake_specs(args, [exr_job(out_dir / name, normalize_spec(spec)) for name, spec in default_specs()])


def _bake_preset(args: argparse.Namespace) -> int:
    from .. import io
    from ..presets import expand_preset, prepare_preset

    if args.spec:
        raise CliError("give either a spec file or --preset, not both")
    try:
        names = expand_preset(args.preset)
    except ValueError as exc:
        raise CliError(str(exc)) from None
    out_dir = output_folder(args.output, "--preset")
    jobs = []
    for name in names:
        job = prepare_preset(name)
        fmt = args.format or job.preset.file_format or "exr"
        jobs.append(Job(io.output_path(out_dir, name.replace("-", "_"), fmt), job.spec, fmt,
                        _preset_finish(job, fmt, args), lambda t: storage_words(t.meta["storage"]),
                        _emitter(fmt, args.emit_langs)))
    return bake_specs(args, jobs)


def _preset_finish(job, fmt: str, args: argparse.Namespace):
    def finish(source_table):
        table = job.finish(source_table)
        _with_storage(table, fmt, args, job.preset.storage)
        return table

    return finish


def _emitter(fmt: str, langs: list[str]):
    def after(table, out: Path) -> None:
        _emit(table.as_stored(fmt), out, langs)

    return after
