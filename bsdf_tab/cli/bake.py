"""``bsdf-tab bake``: one spec file, the default set, an engine preset, or a scene's tables.

``bake SPEC.json [-o FILE]`` writes one table (the format from the output name or
``--format``); ``bake`` alone writes the default set (:func:`bsdf_tab.presets.default_specs`)
into ``luts/``; ``bake --preset NAME -o DIR`` an engine layout; ``bake SCENE --tol T -o DIR``
the tables a scene needs (:mod:`.plan`). Every table goes spec -> ``bsdf_tab.api`` -> a writer
of :mod:`bsdf_tab.io`.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from .. import io
from ..spec import texel_count
from .common import PROG, CliError, check_workers, load_spec_file, output_folder, quiet_warp, summary
from .plan import bake_scene, is_scene_file

NAME = "bake"
HELP = "bake a spec file (or the default set) to EXR"


def configure(parser: argparse.ArgumentParser) -> None:
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
        help="file format (a spec file: default from the -o name, else exr; --preset: default exr)",
    )
    parser.add_argument("--tol", type=float, default=None, help="a scene file: max lookup error (docs/scenes.md)")


def run(args: argparse.Namespace) -> int:
    """Bake one spec file, or the default set when no spec is given, or a preset, or a scene."""
    check_workers(args)
    if args.spec and args.preset is None and is_scene_file(args.spec):
        if args.format is not None:
            raise CliError("--format: a scene is baked as EXR tables and manifest.json")
        return bake_scene(args)
    if args.tol is not None:
        raise CliError("--tol applies to a scene file (a JSON object with a 'materials' list)")
    if args.preset is not None:
        return _bake_preset(args)
    if args.format is not None and not args.spec:
        raise CliError("--format applies to a spec file or --preset (the default set is baked as exr)")
    return _bake_one(args) if args.spec else _bake_default_set(args)


def _output_format(out: Path, fmt: str | None) -> str:
    """The format of output file ``out``: from its ending, checked against ``--format``."""
    try:
        found = io.format_for(out)
    except ValueError:
        raise CliError(f"output {out}: the name must end in {', '.join(io.ENDINGS)}") from None
    if fmt is not None and fmt != found.name:
        raise CliError(f"--format {fmt} does not match the output {out.name} ({found.name}); "
                       f"use a name ending in {io.get_format(fmt).suffixes[0]}")
    return found.name


def _bake_one(args: argparse.Namespace) -> int:
    from .. import api

    spec_path = Path(args.spec)
    spec = load_spec_file(spec_path)
    ending = io.get_format(args.format).suffixes[0] if args.format else ".exr"
    out = Path(args.output) if args.output else spec_path.with_name(spec_path.stem + ending)
    if out.is_dir():
        out = out / (spec_path.stem + ending)
    fmt = _output_format(out, args.format)
    if not out.parent.is_dir():
        raise CliError(f"output folder does not exist: {out.parent}")
    quiet_warp(args)
    if io.can_stream(fmt) and api.streams(spec):
        # directional tables can be large: computed and written in blocks (bounded memory)
        blocks = api.iter_blocks(spec, device=args.device, workers=args.workers, progress=not args.quiet)
        table = io.write_stream(blocks, out, fmt)
        print(summary(out, table))
        return 0
    table = api.tabulate(spec, device=args.device, workers=args.workers, progress=not args.quiet)
    _write(table, out, fmt)
    print(summary(out, table.as_stored(fmt)))
    return 0


def _write(table, out: Path, fmt: str) -> None:
    try:
        io.write(table, out, fmt)
    except FileNotFoundError:
        raise
    except ValueError as exc:  # e.g. values beyond the float16 range (a FormatError is one too)
        raise CliError(f"output {out}: {exc}") from None


def _progress_bar(total: int, quiet: bool):
    from tqdm import tqdm

    return tqdm(total=total, unit="texel", unit_scale=True, file=sys.stderr, disable=quiet, desc=PROG)


def _bake_default_set(args: argparse.Namespace) -> int:
    from .. import api
    from ..presets import default_specs
    from ..spec import normalize_spec

    out_dir = output_folder(args.output, "no spec")
    specs = [(name, normalize_spec(spec)) for name, spec in default_specs()]
    quiet_warp(args)
    with _progress_bar(sum(texel_count(s) for _, s in specs), args.quiet) as bar:
        for name, spec in specs:
            start = bar.n
            bar.set_postfix_str(name, refresh=False)

            def advance(done, total, start=start, n=texel_count(spec)):
                # the callback counts the integrator's own work items (the *_avg tables integrate
                # several mu per texel): scale them onto this table's share of the bar
                bar.update(max(0, start + int(n * done / total if total else 0) - bar.n))

            table = api.tabulate(spec, device=args.device, workers=args.workers, progress=advance)
            bar.update(start + texel_count(spec) - bar.n)
            out = out_dir / name
            io.write(table, out, "exr")
            bar.write(summary(out, table), file=sys.stdout)
    return 0


def _bake_preset(args: argparse.Namespace) -> int:
    from ..presets import build_preset, expand_preset

    if args.spec:
        raise CliError("give either a spec file or --preset, not both")
    try:
        names = expand_preset(args.preset)
    except ValueError as exc:
        raise CliError(str(exc)) from None
    fmt = args.format or "exr"
    out_dir = output_folder(args.output, "--preset")
    quiet_warp(args)
    for name in names:
        table = build_preset(name, device=args.device, workers=args.workers, progress=not args.quiet)
        out = io.output_path(out_dir, name.replace("-", "_"), fmt)
        _write(table, out, fmt)
        print(summary(out, table.as_stored(fmt)))
    return 0
