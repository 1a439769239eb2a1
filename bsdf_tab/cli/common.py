"""What every subcommand shares: the one-line error type, the Warp quieting, the summary line."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from ..errors import SpecError

PROG = "bsdf-tab"
DEFAULT_OUT_DIR = "luts"


class CliError(Exception):
    """A user-facing error: printed as one line, exit code 2."""


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
        spec = json.loads(text)
    except json.JSONDecodeError as exc:
        raise CliError(f"{path}: invalid JSON: {exc}") from None
    try:
        return normalize_spec(spec)
    except SpecError as exc:
        raise CliError(f"{path}: {exc}") from None


def output_folder(path: str | None, what: str) -> Path:
    """The output folder of a multi-table bake (created), ``luts/`` by default."""
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
