"""The ``bsdf-tab`` command line: a thin shell over the library.

Subcommands
-----------
``bake [SPEC.json] [-o OUT] [--device DEV] [--workers N] [--quiet]``
    Bake one spec file to EXR (or ``.npz`` / ``.json`` by the output suffix),
    or, with no spec, the default set of tables (:func:`default_specs`) into
    the folder ``luts/`` (or ``-o DIR``).
``info FILE.exr``
    Describe a table file: kind, axes, channels, conventions, method, error.

Errors are one line on stderr, ``bsdf-tab: error: <message>``, exit code 2
(1 for unexpected internal errors; ``--debug`` shows their traceback);
Ctrl-C exits with 130. More subcommands register with :func:`register_command`.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Callable

from .errors import SpecError
from .spec import AXIS_DEFAULTS, normalize_spec, resolve_axis, texel_count

__all__ = ["main", "default_specs", "register_command", "COMMANDS", "CliError"]

PROG = "bsdf-tab"
DEFAULT_OUT_DIR = "luts"


class CliError(Exception):
    """A user-facing error: printed as one line, exit code 2."""


#: Subcommand name -> (help text, configure(parser), handler(args) -> int).
COMMANDS: dict[str, tuple[str, Callable[[argparse.ArgumentParser], None], Callable[[argparse.Namespace], int]]] = {}


def register_command(name: str, help: str, configure: Callable, handler: Callable) -> None:
    """Add a subcommand (``serve``, ``bench``, ``presets``, ...).

    Parameters
    ----------
    name : str
        Subcommand name.
    help : str
        One-line help text.
    configure : callable
        ``configure(parser)`` adds the subcommand's arguments.
    handler : callable
        ``handler(args) -> int`` runs it and returns the exit code.
    """
    COMMANDS[name] = (help, configure, handler)


# --------------------------------------------------------------------------- default set


def _reciprocal_default_eta() -> list[float]:
    eta = resolve_axis("eta", dict(AXIS_DEFAULTS["eta"]))
    return sorted(float(1.0 / x) for x in eta)


def default_specs() -> list[tuple[str, dict]]:
    """The tables ``bsdf-tab bake`` writes when given no spec.

    Returns
    -------
    list of (str, dict)
        (file name, spec): GGX and Beckmann ``albedo`` 32x32 and
        ``albedo_avg`` 32 (correlated shadowing, F = 1); GGX ``dielectric``
        16^3 for eta > 1 (the default eta axis) and for eta < 1 (the sorted
        reciprocals of the default eta axis); GGX ``dfg`` 128x128 on cell
        centers in mu and roughness.
    """
    specs: list[tuple[str, dict]] = []
    for dist in ("ggx", "beckmann"):
        common = {"distribution": dist, "shadowing": "correlated", "fresnel": {"type": "one"}}
        specs.append((f"{dist}_albedo.exr", {"table": "albedo", **common, "axes": {"mu": {"size": 32}, "alpha": {"size": 32}}}))
        specs.append((f"{dist}_albedo_avg.exr", {"table": "albedo_avg", **common, "axes": {"alpha": {"size": 32}}}))
    glass = {"table": "dielectric", "distribution": "ggx", "shadowing": "correlated", "fresnel": {"type": "dielectric"}}
    grid = {"mu": {"size": 16}, "alpha": {"size": 16}}
    specs.append(("ggx_dielectric_eta_gt1.exr", {**glass, "axes": {**grid, "eta": {"size": 16}}}))
    specs.append(("ggx_dielectric_eta_lt1.exr", {**glass, "axes": {**grid, "eta": _reciprocal_default_eta()}}))
    centers = {"size": 128, "nodes": "centers"}
    dfg_axes = {"mu": dict(centers), "roughness": dict(centers)}
    specs.append(("ggx_dfg.exr", {"table": "dfg", "distribution": "ggx", "shadowing": "correlated", "axes": dfg_axes}))
    return specs


# --------------------------------------------------------------------------- bake


def _load_spec_file(path: Path) -> dict:
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise CliError(f"spec file not found: {path}") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise CliError(f"cannot read spec file {path}: {exc}") from None
    try:
        spec = json.loads(text)
    except json.JSONDecodeError as exc:
        raise CliError(f"{path}: invalid JSON: {exc}") from None
    try:
        return normalize_spec(spec)
    except SpecError as exc:
        raise CliError(f"{path}: {exc}") from None


def _tabulate(args: argparse.Namespace):
    _quiet_warp(args)  # before the import: the integrators may initialize Warp on import
    try:
        from .api import tabulate
    except ImportError as exc:
        raise CliError(f"the tabulation API is not available: {exc}") from None
    return tabulate


def _quiet_warp(args: argparse.Namespace) -> None:
    """Keep Warp's start-up and module-load messages off stdout (unless --debug)."""
    if getattr(args, "debug", False):
        return
    try:
        import warp
    except ImportError:
        return
    warp.config.log_level = getattr(warp, "LOG_WARNING", 30)  # Warp >= 1.1x: logging threshold
    warp.config.quiet = True  # older Warp releases


def _save(table, out: Path) -> None:
    suffix = out.suffix.lower()
    if suffix == ".npz":
        out.write_bytes(table.to_npz_bytes())
    elif suffix == ".json":
        out.write_text(json.dumps(table.to_json_dict()), encoding="utf-8")
    else:
        table.write_exr(out)


def _summary(out: Path, table) -> str:
    axes = " x ".join(f"{name} {len(values)}" for name, values in table.axes.items())
    errors = ", ".join(f"{name} {err:.3g}" for name, err in table.max_error().items()) or "n/a"
    kind = table.kind or "table"
    return f"{out}: {kind} {axes}; max error {errors}"


#: output formats of a spec file, by file name ending (``.half.exr`` before ``.exr``)
SPEC_FORMATS = {".half.exr": "half-exr", ".exr": "exr", ".npz": "npz", ".json": "json", ".npy": "npy", ".h": "h"}


def _output_format(out: Path, fmt: str | None) -> tuple[str, str]:
    """(format, stem) of output file ``out``: from its ending, checked against ``--format``."""
    name = out.name.lower()
    for ending, kind in SPEC_FORMATS.items():
        if name.endswith(ending):
            if fmt is not None and fmt != kind:
                raise CliError(f"--format {fmt} does not match the output {out.name} ({kind}); "
                               f"use a name ending in {_ending(fmt)}")
            return kind, out.name[: -len(ending)]
    raise CliError(f"output {out}: the name must end in {', '.join(SPEC_FORMATS)}")


def _ending(fmt: str) -> str:
    return next(e for e, k in SPEC_FORMATS.items() if k == fmt)


def _stored(table, fmt: str):
    """The table as the file holds it (half-exr: float16 values, rounding in the error channels)."""
    if fmt != "half-exr":
        return table
    from .export import to_half_table

    return to_half_table(table)[0]


def _bake_one(args: argparse.Namespace) -> int:
    spec_path = Path(args.spec)
    spec = _load_spec_file(spec_path)
    ending = _ending(args.format) if args.format else ".exr"
    out = Path(args.output) if args.output else spec_path.with_name(spec_path.stem + ending)
    if out.is_dir():
        out = out / (spec_path.stem + ending)
    fmt, stem = _output_format(out, args.format)
    if not out.parent.is_dir():
        raise CliError(f"output folder does not exist: {out.parent}")
    tabulate = _tabulate(args)
    if spec["table"] == "bsdf" and fmt in ("exr", "npz"):
        # directional tables can be large: computed and written in slices (bounded memory)
        from .tables.bsdf import bake_bsdf_streaming

        table = bake_bsdf_streaming(spec, out, device=args.device, workers=args.workers, progress=not args.quiet)
        print(_summary(out, table))
        return 0
    table = tabulate(spec, device=args.device, workers=args.workers, progress=not args.quiet)
    if fmt in ("exr", "npz", "json"):
        _save(table, out)
    else:
        from .presets import write_table

        try:
            out = write_table(table, out.parent, stem, fmt)[0]
        except ValueError as exc:  # e.g. values beyond the float16 range
            raise CliError(f"output {out}: {exc}") from None
    print(_summary(out, _stored(table, fmt)))
    return 0


def _progress_bar(total: int, quiet: bool):
    from tqdm import tqdm

    return tqdm(total=total, unit="texel", unit_scale=True, file=sys.stderr, disable=quiet, desc=PROG)


def _bake_default_set(args: argparse.Namespace) -> int:
    out_dir = Path(args.output or DEFAULT_OUT_DIR)
    if out_dir.exists() and not out_dir.is_dir():
        raise CliError(f"output {out_dir} exists and is not a folder (with no spec, -o names a folder)")
    out_dir.mkdir(parents=True, exist_ok=True)
    specs = [(name, normalize_spec(spec)) for name, spec in default_specs()]
    tabulate = _tabulate(args)
    with _progress_bar(sum(texel_count(s) for _, s in specs), args.quiet) as bar:
        for name, spec in specs:
            start = bar.n
            bar.set_postfix_str(name, refresh=False)

            def advance(done, total, start=start, n=texel_count(spec)):
                # the callback counts the integrator's own work items (the *_avg tables integrate
                # several mu per texel): scale them onto this table's share of the bar
                bar.update(max(0, start + int(n * done / total if total else 0) - bar.n))

            table = tabulate(spec, device=args.device, workers=args.workers, progress=advance)
            bar.update(start + texel_count(spec) - bar.n)
            out = out_dir / name
            _save(table, out)
            bar.write(_summary(out, table), file=sys.stdout)
    return 0


def _configure_bake(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "spec", nargs="?", help="spec JSON file, or a scene file (JSON or .toml); without it, bake the default set"
    )
    parser.add_argument(
        "-o", "--output",
        help="output file (.exr, .half.exr, .npz, .json, .npy, .h); with no spec or --preset, the output folder "
             "(default: luts/)",
    )
    parser.add_argument("--device", default=None, help="Warp device, for example cpu or cuda:0 (default: Warp's)")
    parser.add_argument("--workers", type=int, default=None, help="number of parallel workers")
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    parser.add_argument("--preset", default=None, help="bake an engine preset or group (see `bsdf-tab presets`) into -o DIR")
    parser.add_argument(
        "--format", default=None, choices=("exr", "half-exr", "npz", "json", "npy", "h"),
        help="file format (a spec file: default from the -o name, else exr; --preset: exr, half-exr, npy or h)",
    )
    parser.add_argument("--tol", type=float, default=None, help="a scene file: max lookup error (docs/scenes.md)")


def cmd_bake(args: argparse.Namespace) -> int:
    """Bake one spec file, or the default set when no spec is given, or a preset."""
    if args.workers is not None and args.workers < 1:
        raise CliError("--workers must be >= 1")
    if args.spec and getattr(args, "preset", None) is None and _is_scene_file(args.spec):
        from .scene import cmd_bake_scene

        if getattr(args, "format", None) is not None:
            raise CliError("--format: a scene is baked as EXR tables and manifest.json")
        return cmd_bake_scene(args)
    if getattr(args, "tol", None) is not None:
        raise CliError("--tol applies to a scene file (a JSON object with a 'materials' list)")
    if getattr(args, "preset", None) is not None:
        return _bake_preset(args)
    if getattr(args, "format", None) is not None and not args.spec:
        raise CliError("--format applies to a spec file or --preset (the default set is baked as exr)")
    return _bake_one(args) if args.spec else _bake_default_set(args)


def _bake_preset(args: argparse.Namespace) -> int:
    from .presets import build_preset, expand_preset, write_table

    if args.spec:
        raise CliError("give either a spec file or --preset, not both")
    try:
        names = expand_preset(args.preset)
    except ValueError as exc:
        raise CliError(str(exc)) from None
    out_dir = Path(args.output or DEFAULT_OUT_DIR)
    if out_dir.exists() and not out_dir.is_dir():
        raise CliError(f"output {out_dir} exists and is not a folder (with --preset, -o names a folder)")
    out_dir.mkdir(parents=True, exist_ok=True)
    fmt = args.format or "exr"
    if fmt not in ("exr", "half-exr", "npy", "h"):
        raise CliError(f"--format {fmt}: a preset is written as exr, half-exr, npy or h")
    tabulate = _tabulate(args)
    for name in names:
        table = build_preset(name, device=args.device, workers=args.workers, progress=not args.quiet, tabulate=tabulate)
        paths = write_table(table, out_dir, name.replace("-", "_"), fmt)
        print(_summary(paths[0], _stored(table, fmt)))
    return 0


def cmd_presets(args: argparse.Namespace) -> int:
    """List the engine presets and groups."""
    from .presets import GROUPS, PRESETS, describe

    for preset in PRESETS.values():
        print(describe(preset))
    for group, members in GROUPS.items():
        print(f"{group:<31} group: {', '.join(members)}")
    return 0


# --------------------------------------------------------------------------- info


def _text(value) -> str:
    return json.dumps(value) if isinstance(value, (dict, list)) else str(value)


def _format_mapping(value) -> list[str]:
    if isinstance(value, dict):
        return [f"  {k}: {_text(v)}" for k, v in value.items()]
    return [f"  {value}"]


def _info_lines(path: Path, table) -> list[str]:
    meta = table.meta
    spec = meta.get("spec") if isinstance(meta.get("spec"), dict) else {}
    lines = [f"file: {path}", f"table: {spec.get('table', 'unknown')}"]
    for key in ("distribution", "shadowing", "fresnel", "tolerance"):
        if key in spec:
            lines.append(f"{key}: {json.dumps(spec[key]) if isinstance(spec[key], dict) else spec[key]}")
    lines.append(f"shape: {' x '.join(str(n) for n in table.shape)}")
    lines.append("axes:")
    for name, values in table.axes.items():
        lines.append(f"  {name:<10} size {len(values):<5} min {values.min():.6g}  max {values.max():.6g}")
    lines.append(f"channels: {', '.join(table.channels)}")
    lines.append("conventions:")
    lines.extend(_format_mapping(meta.get("conventions", "not recorded")))
    method = meta.get("method", spec.get("method", "not recorded"))
    if isinstance(method, dict):
        lines.append(f"method: {method.get('name', '')}".rstrip())
        lines.extend(_format_mapping({k: v for k, v in method.items() if k != "name"}))
    else:
        lines.append(f"method: {method}")
    errors = table.max_error()
    lines.append("max error:")
    lines.extend([f"  {name}: {err:.3g}" for name, err in errors.items()] or ["  no error channels"])
    lines.append(f"version: {meta.get('version', 'not recorded')}")
    return lines


def _configure_info(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("file", help="a table file written by bsdf-tab (.exr)")


def cmd_info(args: argparse.Namespace) -> int:
    """Print a description of a table file."""
    from .exr import read_exr

    path = Path(args.file)
    print("\n".join(_info_lines(path, read_exr(path))))
    return 0


register_command("bake", "bake a spec file (or the default set) to EXR", _configure_bake, cmd_bake)
register_command("info", "describe a table file", _configure_info, cmd_info)
register_command("presets", "list the engine presets (bake one with bake --preset NAME)", lambda parser: None, cmd_presets)


def _is_scene_file(path: str) -> bool:
    """A spec path that holds a scene (top-level 'materials'; JSON or .toml), not one table's spec."""
    from .scene import is_scene, load_scene_file

    if Path(path).suffix.lower() == ".toml":
        return True  # table specs are JSON; the scene loader reports what is wrong with it
    try:
        return is_scene(load_scene_file(path))
    except SpecError:
        return False  # the spec loader reports it


def _configure_plan(parser: argparse.ArgumentParser) -> None:
    from .scene import configure_plan

    configure_plan(parser)


def _cmd_plan(args: argparse.Namespace) -> int:
    from .scene import cmd_plan

    return cmd_plan(args)


register_command("plan", "plan the minimal tables of a scene file for a lookup error (--tol T)", _configure_plan, _cmd_plan)


def _configure_bench(parser: argparse.ArgumentParser) -> None:
    from .benchmarks.accuracy import configure_parser

    sub = parser.add_subparsers(dest="bench", metavar="BENCH")
    acc = sub.add_parser(
        "accuracy",
        help="every integration method: error against time, Pareto front, heatmaps, honesty",
        description="Accuracy against speed of every integration method, judged by the independent "
        "reference (needs a source checkout); writes JSON and PNGs (default: bench/out/).",
    )
    configure_parser(acc)


def cmd_bench(args: argparse.Namespace) -> int:
    """Run a benchmark (``accuracy``)."""
    if getattr(args, "bench", None) != "accuracy":
        raise CliError("choose a benchmark: bsdf-tab bench accuracy [--quick]")
    _quiet_warp(args)
    from .benchmarks.accuracy import main_from_args

    try:
        return main_from_args(args)
    except RuntimeError as exc:
        raise CliError(str(exc)) from None


register_command("bench", "run a benchmark (accuracy: every method, error against time)", _configure_bench, cmd_bench)
try:  # the HTTP service registers `serve` (service/cli.py); absent in a library-only install
    from service.cli import register as _register_serve
except ImportError:
    pass
else:
    _register_serve(register_command)


# --------------------------------------------------------------------------- main


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with every registered subcommand."""
    parser = argparse.ArgumentParser(prog=PROG, description="Microfacet BSDF lookup tables with error estimates.")
    parser.add_argument("--debug", action="store_true", help="show tracebacks of internal errors")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, (help_text, configure, handler) in COMMANDS.items():
        sp = sub.add_parser(name, help=help_text, description=help_text)
        configure(sp)
        sp.set_defaults(handler=handler)
    return parser


def _one_line(message: str) -> str:
    return " ".join(str(message).split()) or "unknown error"


def _error(message: str, code: int) -> int:
    print(f"{PROG}: error: {_one_line(message)}", file=sys.stderr)
    return code


def _os_message(exc: OSError) -> str:
    if exc.strerror and exc.filename:
        return f"{exc.strerror}: {exc.filename}"
    return str(exc)


def _silence_stdout() -> None:
    import os

    try:
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
    except (OSError, ValueError, AttributeError):  # stdout is not a real file (tests)
        pass


def main(argv: list[str] | None = None) -> int:
    """Run the ``bsdf-tab`` command.

    Parameters
    ----------
    argv : list of str, optional
        Arguments without the program name (default: ``sys.argv[1:]``).

    Returns
    -------
    int
        Exit code: 0 success, 2 usage or input error, 1 internal error,
        130 interrupted.
    """
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # argparse: --help (0) or a usage error (2)
        return int(exc.code or 0)
    if not getattr(args, "handler", None):
        parser.print_help(sys.stderr)
        return 2
    try:
        return int(args.handler(args) or 0)
    except KeyboardInterrupt:
        print(f"{PROG}: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # output piped into `head` and the like: stop quietly
        _silence_stdout()
        return 0
    except (CliError, SpecError, ValueError) as exc:
        return _error(str(exc), 2)
    except OSError as exc:
        return _error(_os_message(exc), 2)
    except Exception as exc:  # noqa: BLE001 - the CLI never shows a traceback by default
        if args.debug:
            raise
        return _error(f"internal error: {type(exc).__name__}: {exc} (run with --debug for details)", 1)


if __name__ == "__main__":
    sys.exit(main())
