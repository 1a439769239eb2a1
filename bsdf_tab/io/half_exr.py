"""``half-exr``: the layout of :mod:`bsdf_tab.io.exr` with HALF (16-bit float) channels.

Rounding to half adds an error of at most half a float16 ulp (2^-12 = 2.4e-4 for values in
[0.5, 1), 2^-11 at 1); for each value channel ``X`` it is measured exactly,
``max |float16(X) - X|`` over the finite texels, and

- added texel by texel to the error channel ``X_err``, which is then rounded *up* to half, so
  the stored error still bounds the stored value's error;
- reported in the header attribute ``bsdf_tab_half_error`` (JSON: channel -> max rounding
  error) and in ``meta["half_float"]``; ``meta["max_error"]`` includes it.

:func:`bsdf_tab.io.exr.read_exr` reads these files (as float32 arrays, widened exactly).
"""

from __future__ import annotations

import json
import tempfile
from pathlib import Path
from typing import Callable

import numpy as np

from .base import ERR_SUFFIX, Format, build, value_channels
from .exr import ATTR_PREFIX, header_attributes, image_shape, read_exr, read_exr_bytes, write_image
from .storage import check_range

__all__ = ["FORMAT", "HALF_MAX", "half_rounding", "to_half", "write_half_exr", "half_exr_bytes"]

#: The largest finite float16 (65504).
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


def to_half(table, factory: Callable | None = None):
    """The table as float16 channels with the rounding error added to the error channels.

    Parameters
    ----------
    table : table-like
        ``axes``, ``channels``, ``meta``.
    factory : callable, optional
        ``factory(axes, channels, meta)`` builds the half table (default
        :class:`~bsdf_tab.io.base.TableParts`).

    Returns
    -------
    (table, dict)
        The half table (float16 channel arrays in the table's channel order, meta with
        ``half_float`` and ``max_error``) and, per value channel, the max rounding error
        ``max |float16(x) - x|``.

    Raises
    ------
    ValueError
        If a finite value is beyond the half range (|x| > 65504): one line naming the
        channel and its largest magnitude (:func:`bsdf_tab.io.storage.check_range`).
    """
    check_range(table, "float16", "write float32 instead (.exr, --format exr)")
    channels: dict[str, np.ndarray] = {}
    rounding: dict[str, float] = {}
    for name in value_channels(table.channels):
        x = np.asarray(table.channels[name], dtype=np.float64)
        finite = np.isfinite(x)
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
    meta["max_error"] = {
        name: float(np.max(channels[name + ERR_SUFFIX].astype(np.float64)))
        for name in value_channels(channels)
        if name + ERR_SUFFIX in channels
    }
    return build(dict(table.axes), channels, meta, factory), rounding


def _as_stored(table, factory: Callable | None = None):
    return to_half(table, factory)[0]


def write_half_exr(table, path) -> dict[str, float]:
    """Write ``table`` as a half-float EXR atomically; returns the max rounding error per channel.

    The layout and header attributes are those of :mod:`bsdf_tab.io.exr` (layout words say
    ``float16 (HALF)``), plus ``bsdf_tab_half_error`` (JSON: channel -> max |float16(x) - x|).

    Raises
    ------
    FileNotFoundError
        If the destination folder does not exist.
    ValueError
        If the table has no channels or a value beyond the half range.
    """
    if not table.channels:
        raise ValueError("cannot write a table without channels to EXR")
    half, rounding = to_half(table)
    attributes = header_attributes(half.axes, half.channels, half.meta, sample="float16 (HALF)")
    attributes[ATTR_PREFIX + "half_error"] = json.dumps(rounding)
    height, width = image_shape(tuple(len(a) for a in half.axes.values()))
    pixels = {n: np.ascontiguousarray(v, dtype=np.float16).reshape(height, width) for n, v in half.channels.items()}
    write_image(path, attributes, pixels)
    return rounding


def _write(table, path) -> list[Path]:
    write_half_exr(table, path)
    return [Path(path)]


def half_exr_bytes(table) -> bytes:
    """The bytes of the file :func:`write_half_exr` writes for ``table``."""
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "table.half.exr"
        write_half_exr(table, path)
        return path.read_bytes()


FORMAT = Format(
    name="half-exr",
    suffixes=(".half.exr",),
    description="OpenEXR, HALF channels; the measured rounding added to the error channels",
    write=_write,
    media_type="image/x-exr",
    to_bytes=half_exr_bytes,
    read=read_exr,
    from_bytes=read_exr_bytes,
    as_stored=_as_stored,
)
