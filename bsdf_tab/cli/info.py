"""``bsdf-tab info FILE``: axes, channels, conventions, method, max error and storage of a table file.

Any readable format of :mod:`bsdf_tab.io` (``.exr``, ``.half.exr``, ``.npz``, ``.json``,
``.meta.json``, ``.ktx2``, ``.png``). The storage section is ``meta["storage"]``
(:mod:`bsdf_tab.io.storage`): per channel the integration error, the error the file's storage
adds (float16 rounding, quantization, the clamp to [0, 1]) and the stored bound.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from .common import CliError

NAME = "info"
HELP = "describe a table file"


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("file", help="a table file written by bsdf-tab (.exr, .half.exr, .npz, .json, .ktx2, .png, ...)")


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
    storage = meta.get("storage") if isinstance(meta.get("storage"), dict) else {}
    rebuilt = _rebuilt_error_channels(path, table)
    if rebuilt:
        stored = [n for n in table.channels if n not in rebuilt]
        lines.append(f"channels: {', '.join(stored)}; {', '.join(rebuilt)} not stored, rebuilt from the "
                     "storage bound in the metadata (the max over texels, the same at every texel)")
    else:
        lines.append(f"channels: {', '.join(table.channels)}")
    lines.append("conventions:")
    lines.extend(_format_mapping(meta.get("conventions", "not recorded")))
    method = meta.get("method", spec.get("method", "not recorded"))
    if isinstance(method, dict):
        lines.append(f"method: {method.get('name', '')}".rstrip())
        details = {k: v for k, v in method.items() if k != "name"}
        if "precision" in details and storage.get("encoding"):
            details["precision"] = _stored_precision(details["precision"], storage)
        lines.extend(_format_mapping(details))
    else:
        lines.append(f"method: {method}")
    errors = table.max_error()
    lines.append("max error (stored bound, from the metadata):" if rebuilt else "max error:")
    lines.extend([f"  {name}: {err:.3g}" for name, err in errors.items()] or ["  no error channels"])
    lines.extend(storage_lines(meta.get("storage")))
    lines.append(f"version: {meta.get('version', 'not recorded')}")
    return lines


def _rebuilt_error_channels(path: Path, table) -> list[str]:
    """The error channels of ``table`` that its file (a GPU texture) does not store."""
    from ..io import format_for
    from ..io.texture import TEXTURE_FORMATS

    try:
        fmt = format_for(path).name
    except ValueError:
        return []
    if fmt not in TEXTURE_FORMATS:
        return []
    return [n for n in table.channels if n.endswith("_err")]


def _stored_precision(computed, storage: dict) -> str:
    """``float64 (stored as float16, ktx2)``: the method's computing precision and the file's storage."""
    head = str(computed).split(" (stored as", 1)[0]
    where = f", {storage['format']}" if storage.get("format") else ""
    return f"{head} (stored as {storage['encoding']}{where})"


def _num(value) -> str:
    return "n/a" if value is None else f"{value:.3g}"


def storage_lines(storage) -> list[str]:
    """The storage section of ``bsdf-tab info``: the encoding and, per channel, its errors."""
    if not isinstance(storage, dict) or "encoding" not in storage:
        return ["storage: not recorded"]
    where = ", ".join(str(x) for x in (storage.get("format"), storage.get("vk_format")) if x)
    lines = [f"storage: {storage['encoding']}" + (f" ({where})" if where else "")
             + f", {storage.get('bytes_per_texel', '?')} bytes per texel"]
    for name, c in storage.get("channels", {}).items():
        clamp = f", clamp {_num(c.get('clamp_error'))}" if c.get("clamp_error") else ""
        lines.append(f"  {name}: integration {_num(c.get('integration_error'))}, storage "
                     f"{_num(c.get('storage_error'))}{clamp}, stored {_num(c.get('total_error'))}")
    return lines


def run(args: argparse.Namespace) -> int:
    """Print a description of a table file."""
    from .. import io
    from ..table import Table

    path = Path(args.file)
    try:
        table = io.read(path, factory=Table)
    except FileNotFoundError:
        raise CliError(f"no such file: {path}") from None
    except ValueError as exc:  # a FormatError (unknown ending, write-only format) is one too
        raise CliError(str(exc)) from None
    print("\n".join(info_lines(path, table)))
    return 0
