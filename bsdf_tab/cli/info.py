"""``bsdf-tab info FILE``: axes, channels, conventions, method and max error of a table file."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

NAME = "info"
HELP = "describe a table file"


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("file", help="a table file written by bsdf-tab (.exr)")


def _text(value) -> str:
    return json.dumps(value) if isinstance(value, (dict, list)) else str(value)


def _format_mapping(value) -> list[str]:
    if isinstance(value, dict):
        return [f"  {k}: {_text(v)}" for k, v in value.items()]
    return [f"  {value}"]


def info_lines(path: Path, table) -> list[str]:
    """The lines ``bsdf-tab info`` prints for ``table`` read from ``path``."""
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


def run(args: argparse.Namespace) -> int:
    """Print a description of a table file."""
    from .. import read_exr

    path = Path(args.file)
    print("\n".join(info_lines(path, read_exr(path))))
    return 0
