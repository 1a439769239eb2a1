"""What every subcommand shares: the one-line error type, the Warp quieting, the summary line."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from .. import jsontext
from ..errors import SpecError

PROG = "bsdf-tab"
DEFAULT_OUT_DIR = "luts"
#: The most texels one table computed in memory may have (2^26: e.g. 4096 x 4096 x 4). A larger
#: table (float64 values and errors, several channels) does not fit in memory; a directional
#: ``bsdf`` table written to a streaming format is computed in blocks and has no such limit.
MAX_TABLE_TEXELS = 1 << 26


class CliError(Exception):
    """A user-facing error: printed as one line, exit code 2."""


class OneLineParser(argparse.ArgumentParser):
    """An argument parser whose usage errors are one line (``bsdf-tab bake: error: argument
    --workers: invalid int value: 'abc'``, exit 2) rather than the usage block and the error."""

    def error(self, message: str):
        self.exit(2, f"{self.prog}: error: {' '.join(message.split())}\n")


def quiet_warp(args: argparse.Namespace) -> None:
    """Keep Warp's start-up and module-load messages off stdout (unless ``--debug``)."""
    if getattr(args, "debug", False):
        return
    from ..api import quiet_warp as quiet

    quiet()


def check_workers(args: argparse.Namespace) -> None:
    """``--workers`` must be a positive count (None: all cores)."""
    if getattr(args, "workers", None) is not None and args.workers < 1:
        raise CliError("--workers must be >= 1")


def check_device(args: argparse.Namespace, scheduler: str | None = None) -> None:
    """``--device`` must name a Warp device of this machine (one CliError line); with a
    ``scheduler`` the workers resolve it, so it is not checked here."""
    device = getattr(args, "device", None)
    if device is None or scheduler:
        return
    from ..integrate.runtime import resolve_device

    try:
        resolve_device(device)
    except ValueError as exc:  # resolve_device's documented error: an unknown or unavailable device
        raise CliError(f"--device: {exc}") from None


def load_spec_file(path: Path) -> dict:
    """The normalized spec in a JSON file; every failure is one :class:`CliError` line."""
    from ..spec import normalize_spec  # at call time: the spec loads the table catalog (and Warp)

    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise CliError(f"spec file not found: {path}") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise CliError(f"cannot read spec file {path}: {exc}") from None
    try:
        spec = jsontext.loads(text)
    except json.JSONDecodeError as exc:
        raise CliError(f"{path}: invalid JSON: {exc}") from None
    except SpecError as exc:  # a duplicate key
        raise CliError(f"{path}: {exc}") from None
    if not isinstance(spec, dict):  # "albedo" is valid JSON but no spec (normalize_spec would parse it again)
        raise CliError(f"{path}: a spec must be a JSON object, got a JSON {_json_type(spec)}")
    try:
        return normalize_spec(spec)
    except SpecError as exc:
        raise CliError(f"{path}: {exc}") from None


def _json_type(value) -> str:
    names = {str: "string", bool: "boolean", int: "number", float: "number", list: "array", type(None): "null"}
    return names.get(type(value), type(value).__name__)


def check_texels(spec: dict, what: str) -> None:
    """A table computed in memory must have at most :data:`MAX_TABLE_TEXELS` texels: one
    CliError line before anything is allocated (not a MemoryError after)."""
    from ..spec import texel_count

    n = texel_count(spec)
    if n > MAX_TABLE_TEXELS:  # float64 values and errors of this many texels do not fit in memory
        sizes = " x ".join(f"{name} {len(a['values']) if 'values' in a else a['size']}"
                           for name, a in spec["axes"].items())
        raise CliError(f"{what}: the {spec['table']} table has {n:,} texels ({sizes}); at most "
                       f"{MAX_TABLE_TEXELS:,} fit in memory as one table: use fewer nodes")


def refuse_file_name(path: str | None, what: str) -> None:
    """``-o`` names a folder where several files are written: a table file name is a mistake
    (``-o x.exr`` would create a folder called ``x.exr``)."""
    if path is None or Path(path).is_dir():
        return
    from .. import io

    name = Path(path).name.lower()
    ending = next((e for e in io.ENDINGS if name.endswith(e)), None)
    if ending is not None:  # a table file's ending: the user meant one file, but this writes several
        raise CliError(f"-o {path}: {what} writes several files into a folder; give a folder name "
                       f"(not a {ending} file)")


def output_folder(path: str | None, what: str) -> Path:
    """The output folder of a multi-table bake (created), ``luts/`` by default."""
    refuse_file_name(path, f"a bake with {what}")
    out_dir = Path(path or DEFAULT_OUT_DIR)
    if out_dir.exists() and not out_dir.is_dir():
        raise CliError(f"output {out_dir} exists and is not a folder (with {what}, -o names a folder)")
    out_dir.mkdir(parents=True, exist_ok=True)
    return out_dir


def summary(out: Path, table) -> str:
    """One line per written table: file, kind, axes and the stored table's max error."""
    axes = " x ".join(f"{name} {len(values)}" for name, values in table.axes.items())
    errors = ", ".join(f"{name} {err:.3g}" for name, err in table.max_error().items()) or "n/a"
    kind = table.kind or "table"
    return f"{out}: {kind} {axes}; max error {errors}"
