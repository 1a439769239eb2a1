"""Writers besides float EXR: NumPy ``.npy``, a C/C++ header, and half-float EXR.

NumPy (:func:`write_npy`)
-------------------------
Per channel (default), for a table written with stem ``S`` into folder ``D``:

- ``D/S.<channel>.npy``: one array per channel (values ``E`` and errors ``E_err`` alike),
  float32, shape = the axis lengths in axis order, C order;
- ``D/S.axis.<name>.npy``: each axis, float64 (exact);
- ``D/S.meta.json``: ``{"axis_order", "channel_order", "shape", "layout", "files", "meta"}``.

Stacked (``stacked=True``): ``D/S.npy`` holds all channels in one float32 array of shape
``(*axis lengths, n_channels)`` (channels last, in ``channel_order``), with the same axis files
and ``S.meta.json``. Load with ``numpy.load`` (no pickles).

C/C++ header (:func:`write_header`)
-----------------------------------
One self-contained header with an include guard, valid C99 and C++:

- a comment block with the conventions, the layout, the error estimates and the metadata;
- ``#define <P>_NDIM``, ``#define <P>_SIZE_<AXIS>`` for each axis, ``#define <P>_NUM_CHANNELS``;
- ``static const double <P>_axis_<name>[n]``: the axis values (exact, 17 digits);
- ``static const float <P>_<channel>[n0][n1]...``: each channel as a row-major C array indexed
  in axis order (``<P>_E[i_mu][i_roughness]``), values written with 9 significant digits so
  they round-trip float32 exactly.

``<P>`` is the identifier prefix (the ``name`` argument, sanitized to ``[A-Za-z0-9_]``).

Half-float EXR (:func:`write_half_exr`)
---------------------------------------
The layout of :mod:`bsdf_tab.exr` with HALF (16-bit) channels. Rounding to half adds an error
of at most half a float16 ulp (2^-12 = 2.4e-4 for values in [0.5, 1), 2^-11 at 1); for each
value channel ``X`` it is measured exactly, ``max |float16(X) - X|`` over texels, and

- added texel by texel to the error channel ``X_err`` (which is then rounded *up* to half, so
  the stored error still bounds the stored value's error);
- reported in the header attribute ``bsdf_tab_half_error`` (JSON: channel -> max rounding
  error) and in ``meta["half_float"]``; ``meta["max_error"]`` includes it.

:func:`bsdf_tab.read_exr` reads these files (as float32 arrays).
"""

from __future__ import annotations

import json
import math
import os
import re
import uuid
from pathlib import Path

import numpy as np

from .table import ERR_SUFFIX, Table, json_default

__all__ = [
    "write_npy",
    "read_npy",
    "write_header",
    "header_text",
    "c_identifier",
    "half_rounding",
    "to_half_table",
    "write_half_exr",
]


def _folder(path: Path) -> None:
    folder = path.parent if str(path.parent) else Path(".")
    if not folder.is_dir():
        raise FileNotFoundError(f"cannot write {path}: folder {folder} does not exist")


def _layout_words(table: Table) -> str:
    names = list(table.axes)
    sizes = [len(a) for a in table.axes.values()]
    index = "".join(f"[i_{n}]" for n in names)
    dims = " x ".join(f"{n} {s}" for n, s in zip(names, sizes))
    return f"row-major (C order) over the axes in order: {dims}; value = channel{index}"


# --------------------------------------------------------------------------- npy


def write_npy(table: Table, out_dir, stem: str, *, stacked: bool = False, dtype=np.float32) -> list[Path]:
    """Write ``table`` as ``.npy`` files into ``out_dir`` (see the module doc for the layout).

    Returns
    -------
    list of Path
        The files written; the first is the main array (``S.npy`` when stacked, else the first
        channel's file), the last is ``S.meta.json``.
    """
    out_dir = Path(out_dir)
    if not out_dir.is_dir():
        raise FileNotFoundError(f"output folder does not exist: {out_dir}")
    written: list[Path] = []
    channels = list(table.channels)
    if stacked:
        path = out_dir / f"{stem}.npy"
        np.save(path, np.stack([np.asarray(table.channels[c], dtype=dtype) for c in channels], axis=-1))
        written.append(path)
    else:
        for name in channels:
            path = out_dir / f"{stem}.{name}.npy"
            np.save(path, np.ascontiguousarray(table.channels[name], dtype=dtype))
            written.append(path)
    for name, values in table.axes.items():
        path = out_dir / f"{stem}.axis.{name}.npy"
        np.save(path, np.asarray(values, dtype=np.float64))
        written.append(path)
    layout = _layout_words(table)
    if stacked:
        layout += f"; stacked: last index = channel, in channel_order ({len(channels)})"
    info = {
        "axis_order": list(table.axes),
        "channel_order": channels,
        "shape": list(table.shape),
        "dtype": np.dtype(dtype).name,
        "stacked": stacked,
        "layout": layout,
        "files": [p.name for p in written],
        "meta": table.meta,
    }
    meta_path = out_dir / f"{stem}.meta.json"
    meta_path.write_text(json.dumps(info, indent=1, default=json_default), encoding="utf-8")
    written.append(meta_path)
    return written


def read_npy(out_dir, stem: str) -> Table:
    """Read a table written by :func:`write_npy` (either layout)."""
    out_dir = Path(out_dir)
    info = json.loads((out_dir / f"{stem}.meta.json").read_text(encoding="utf-8"))
    axes = {n: np.load(out_dir / f"{stem}.axis.{n}.npy", allow_pickle=False) for n in info["axis_order"]}
    if info["stacked"]:
        data = np.load(out_dir / f"{stem}.npy", allow_pickle=False)
        channels = {c: data[..., k] for k, c in enumerate(info["channel_order"])}
    else:
        channels = {c: np.load(out_dir / f"{stem}.{c}.npy", allow_pickle=False) for c in info["channel_order"]}
    return Table(axes, channels, info["meta"])


# --------------------------------------------------------------------------- C header


def c_identifier(name: str) -> str:
    """``name`` as a C identifier: non-alphanumerics become ``_``; a leading digit gets ``_``."""
    ident = re.sub(r"[^A-Za-z0-9_]", "_", str(name)) or "_"
    return "_" + ident if ident[0].isdigit() else ident


def _c_float(x: float) -> str:
    x = float(np.float32(x))
    if math.isnan(x):
        return "NAN"
    if math.isinf(x):
        return "INFINITY" if x > 0 else "-INFINITY"
    text = "%.9g" % x
    if "." not in text and "e" not in text and "n" not in text:
        text += ".0"
    return text + "f"


def _c_double(x: float) -> str:
    text = "%.17g" % float(x)
    if "." not in text and "e" not in text:
        text += ".0"
    return text


def _comment(text: str) -> str:
    return str(text).replace("*/", "* /")


def _initializer(values: np.ndarray, indent: int = 1, per_line: int = 8) -> str:
    pad = "    " * indent
    if values.ndim == 1:
        items = [_c_float(v) for v in values]
        lines = [", ".join(items[k : k + per_line]) for k in range(0, len(items), per_line)]
        return "{\n" + ",\n".join(pad + line for line in lines) + "\n" + "    " * (indent - 1) + "}"
    inner = [_initializer(v, indent + 1, per_line) for v in values]
    return "{\n" + ",\n".join(pad + s for s in inner) + "\n" + "    " * (indent - 1) + "}"


def _meta_comment_lines(table: Table) -> list[str]:
    lines = []
    preset = table.meta.get("preset") if isinstance(table.meta.get("preset"), dict) else None
    if preset:
        lines.append(f"preset: {preset.get('name')} ({preset.get('peer')})")
        lines.append(f"  {preset.get('description')}")
    conv = table.meta.get("conventions")
    if isinstance(conv, dict):
        lines.append("conventions:")
        lines += [f"  {k}: {json.dumps(v, default=json_default) if isinstance(v, (dict, list)) else v}" for k, v in conv.items()]
    if preset and preset.get("notes"):
        lines.append("notes:")
        lines += [f"  {n}" for n in preset["notes"]]
    errors = table.max_error()
    if errors:
        lines.append("max error estimate: " + ", ".join(f"{k} {v:.3g}" for k, v in errors.items()))
    if "half_float" in table.meta:
        lines.append(f"half-float rounding: {json.dumps(table.meta['half_float'], default=json_default)}")
    lines.append(f"version: bsdf-tab {table.meta.get('version', 'unknown')}")
    return lines


def header_text(table: Table, name: str = "bsdf_tab_table") -> str:
    """The text of the C/C++ header for ``table`` (see the module doc)."""
    prefix = c_identifier(name)
    guard = c_identifier(prefix.upper() + "_H")
    if not guard.startswith("BSDF_TAB"):
        guard = "BSDF_TAB_" + guard
    names = list(table.axes)
    sizes = [len(a) for a in table.axes.values()]
    index = "".join(f"[i_{n}]" for n in names)
    out = [f"/* {prefix}.h: generated by bsdf-tab. Do not edit."]
    out.append(" *")
    out.append(f" * layout: {_comment(_layout_words(table))}")
    out.append(f" *   float {prefix}_<channel>{''.join(f'[{s}]' for s in sizes)}, indexed {prefix}_<channel>{index};")
    out.append(f" *   axis values: double {prefix}_axis_<name>[size]; channels: {', '.join(table.channels)}")
    out.append(" *   <X>_err is the estimated absolute error of <X> at each texel.")
    for line in _meta_comment_lines(table):
        out.append(" * " + _comment(line))
    out.append(" * metadata (JSON):")
    meta_json = json.dumps(table.meta, default=json_default, sort_keys=True)
    out += [" *   " + _comment(meta_json[k : k + 100]) for k in range(0, len(meta_json), 100)]
    out.append(" */")
    out.append(f"#ifndef {guard}")
    out.append(f"#define {guard}")
    finite = all(np.isfinite(np.asarray(c, dtype=np.float32)).all() for c in table.channels.values())
    if not finite:
        out.append("#include <math.h> /* NAN, INFINITY */")
    out.append("")
    out.append(f"#define {prefix.upper()}_NDIM {len(names)}")
    for n, s in zip(names, sizes):
        out.append(f"#define {prefix.upper()}_SIZE_{c_identifier(n).upper()} {s}")
    out.append(f"#define {prefix.upper()}_NUM_CHANNELS {len(table.channels)}")
    out.append("")
    for n, values in table.axes.items():
        body = ", ".join(_c_double(v) for v in values)
        out.append(f"static const double {prefix}_axis_{c_identifier(n)}[{len(values)}] = {{{body}}};")
    out.append("")
    for cname, values in table.channels.items():
        dims = "".join(f"[{s}]" for s in sizes)
        init = _initializer(np.asarray(values, dtype=np.float32))
        out.append(f"static const float {prefix}_{c_identifier(cname)}{dims} = {init};")
        out.append("")
    out.append(f"#endif /* {guard} */")
    return "\n".join(out) + "\n"


def write_header(table: Table, path, name: str | None = None) -> Path:
    """Write ``table`` as a C/C++ header; ``name`` (default: the file stem) prefixes every identifier."""
    path = Path(path)
    _folder(path)
    text = header_text(table, name or path.name.split(".")[0])
    tmp = path.with_name(f".{path.name}.{os.getpid()}.{uuid.uuid4().hex}.tmp")
    try:
        tmp.write_text(text, encoding="utf-8")
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()
    return path


# --------------------------------------------------------------------------- half EXR

HALF_MAX = float(np.finfo(np.float16).max)


def half_rounding(values) -> np.ndarray:
    """|float16(x) - x| per texel (computed in float64)."""
    x = np.asarray(values, dtype=np.float64)
    return np.abs(x.astype(np.float16).astype(np.float64) - x)


def _half_up(values: np.ndarray) -> np.ndarray:
    """float16 values >= ``values`` (rounded up), so a stored error bound stays a bound."""
    x = np.asarray(values, dtype=np.float64)
    h = x.astype(np.float16)
    low = h.astype(np.float64) < x
    h[low] = np.nextafter(h[low], np.float16(np.inf))
    return h


def to_half_table(table: Table) -> tuple[Table, dict[str, float]]:
    """The table as float16 channels with the rounding error added to the error channels.

    Returns
    -------
    (Table, dict)
        The half table (float16 channel arrays, updated meta) and, per value channel, the
        max rounding error ``max |float16(x) - x|``.

    Raises
    ------
    ValueError
        If a finite value is beyond the half range (|x| > 65504).
    """
    channels: dict[str, np.ndarray] = {}
    rounding: dict[str, float] = {}
    for name in table.value_channels:
        x = np.asarray(table.channels[name], dtype=np.float64)
        finite = np.isfinite(x)
        if (np.abs(x[finite]) > HALF_MAX).any():
            raise ValueError(f"channel {name}: values beyond the float16 range (|x| > {HALF_MAX:g})")
        err = np.where(finite, half_rounding(x), 0.0)
        rounding[name] = float(err.max()) if err.size else 0.0
        channels[name] = x.astype(np.float16)
        err_name = name + ERR_SUFFIX
        if err_name in table.channels:
            channels[err_name] = _half_up(np.asarray(table.channels[err_name], dtype=np.float64) + err)
    for name in table.channels:  # error channels without a value channel keep their values
        if name not in channels:
            channels[name] = _half_up(np.asarray(table.channels[name], dtype=np.float64))
    channels = {name: channels[name] for name in table.channels}  # keep the table's order
    meta = dict(table.meta)
    meta["half_float"] = {
        "storage": "OpenEXR HALF (IEEE 754 binary16)",
        "max_abs_rounding_error": rounding,
        "error_channels": "include |float16(x) - x| per texel and are rounded up to half",
    }
    half = Table(dict(table.axes), channels, meta)
    half.meta["max_error"] = {k: float(np.max(v.astype(np.float64))) for k, v in
                              ((n, channels[n + ERR_SUFFIX]) for n in half.value_channels if n + ERR_SUFFIX in channels)}
    return half, rounding


def write_half_exr(table: Table, path) -> dict[str, float]:
    """Write ``table`` as a half-float (HALF channels) EXR; returns the max rounding error per channel.

    The layout and header attributes are those of :mod:`bsdf_tab.exr`, plus
    ``bsdf_tab_half_error`` (JSON: channel -> max |float16(x) - x|).
    """
    import OpenEXR

    from .exr import ATTR_PREFIX, _header, _image_shape

    path = Path(path)
    _folder(path)
    half, rounding = to_half_table(table)
    header = _header(half)
    header[ATTR_PREFIX + "layout"] = header[ATTR_PREFIX + "layout"].replace("float32", "float16 (HALF)", 1)
    header[ATTR_PREFIX + "half_error"] = json.dumps(rounding)
    height, width = _image_shape(half.shape)
    pixels = {n: np.ascontiguousarray(v, dtype=np.float16).reshape(height, width) for n, v in half.channels.items()}
    tmp = str(path.parent / f".{path.name}.{os.getpid()}.{uuid.uuid4().hex}.tmp")
    try:
        with OpenEXR.File(header, pixels) as exr:
            exr.write(tmp)
        os.replace(tmp, path)
    except RuntimeError as exc:
        raise OSError(f"cannot write {path}: {exc}") from None
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
    return rounding
