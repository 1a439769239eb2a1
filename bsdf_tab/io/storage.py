"""Storage encodings of texture files and the error each adds to a table, measured.

A GPU texture stores a table's value channels in one *encoding* (the ``--precision`` of
``bsdf-tab bake``):

============  =====================================================  ======================
encoding      stored value q(x)                                      worst case for x in [0, 1]
============  =====================================================  ======================
``float32``   IEEE binary32 rounding (round to nearest even)         2^-25 (3.0e-8)
``float16``   IEEE binary16 rounding                                 2^-12 (2.4e-4) in [0.5, 1)
``unorm16``   ``round(clamp(x, 0, 1) * 65535) / 65535``              1 / 131070 (7.6e-6)
``unorm10``   ``round(clamp(x, 0, 1) * 1023) / 1023``                1 / 2046 (4.9e-4)
``unorm8``    ``round(clamp(x, 0, 1) * 255) / 255``                  1 / 510 (2.0e-3)
============  =====================================================  ======================

For every value channel ``X`` the error the storage adds is measured texel by texel,
``|q(x) - x|`` (the clamp to [0, 1] of the UNORM encodings included, and reported apart), and
set next to the integration error (the max of ``X_err``): :func:`storage_report`. The stored
table's error bound is their texel-wise sum, ``max(X_err + |q(x) - x|)``
(:func:`as_encoded` puts it in the error channels). :func:`choose_encoding` picks the
smallest encoding (bytes per texel) whose bound stays within a tolerance
(``--precision auto``).

A float encoding never stores a finite value as an infinity: :func:`check_range` refuses a
channel with a finite value beyond the largest finite float16 (65504) or float32, and every
writer of a float encoding (``ktx2``, ``dds``, :func:`as_encoded`; ``half-exr`` alike) calls it
first. :func:`storage_report` still measures such a channel (its storage error is ``inf``, so
:func:`choose_encoding` never picks that encoding).

The report is what ``meta["storage"]`` holds in every file ``bsdf-tab bake`` writes, what
``bsdf-tab info`` prints and what the service's info returns
(:func:`storage_report_for_format` for a registry format name).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from .base import ERR_SUFFIX, build, value_channels

__all__ = [
    "ENCODINGS",
    "Encoding",
    "FORMAT_STORAGE",
    "as_encoded",
    "bytes_per_texel",
    "check_range",
    "choose_encoding",
    "encode",
    "get_encoding",
    "requested_encoding",
    "storage_report",
    "storage_report_for_format",
]


@dataclass(frozen=True)
class Encoding:
    """One storage encoding.

    Attributes
    ----------
    name : str
        ``float32``, ``float16``, ``unorm16``, ``unorm10`` or ``unorm8``.
    bits : int
        Bits per channel.
    kind : str
        ``"float"`` or ``"unorm"``.
    """

    name: str
    bits: int
    kind: str

    @property
    def levels(self) -> int:
        """For UNORM: the largest code, 2^bits - 1."""
        return (1 << self.bits) - 1

    def quantize(self, values) -> np.ndarray:
        """The stored values q(x) as float64 (NaN stays NaN for floats, is stored as 0 in UNORM)."""
        x = np.asarray(values, dtype=np.float64)
        if self.kind == "float":
            dtype = np.float32 if self.bits == 32 else np.float16
            with np.errstate(over="ignore", invalid="ignore"):
                return x.astype(dtype).astype(np.float64)
        return self.codes(x).astype(np.float64) / self.levels

    def codes(self, values) -> np.ndarray:
        """UNORM integer codes ``round(clamp(x, 0, 1) * (2^bits - 1))`` (uint32; NaN -> 0)."""
        x = np.nan_to_num(np.asarray(values, dtype=np.float64), nan=0.0)
        return np.rint(np.clip(x, 0.0, 1.0) * self.levels).astype(np.uint32)


#: name -> encoding, from the smallest to the largest.
ENCODINGS: dict[str, Encoding] = {
    e.name: e
    for e in (
        Encoding("unorm8", 8, "unorm"),
        Encoding("unorm10", 10, "unorm"),
        Encoding("float16", 16, "float"),
        Encoding("unorm16", 16, "unorm"),
        Encoding("float32", 32, "float"),
    )
}

#: What each registry format stores, the first the default: the texture formats can choose.
FORMAT_STORAGE: dict[str, tuple[str, ...]] = {
    "exr": ("float32",),
    "half-exr": ("float16",),
    "npz": ("float64",),
    "npy": ("float64",),
    "npy-channels": ("float32",),
    "json": ("float64",),
    "h": ("float32",),
    "ktx2": ("float16", "float32", "unorm16", "unorm10", "unorm8"),
    "dds": ("float16", "float32", "unorm16", "unorm10", "unorm8"),
    "png": ("unorm16", "unorm8"),
}


def check_range(table, encoding: str, remedy: str | None = None) -> None:
    """Refuse a table that ``encoding`` cannot store without turning a finite value into an infinity.

    For ``float16`` and ``float32``: every finite value of every value channel must be within
    the largest finite value of the encoding (65504 for float16). UNORM encodings clamp (the
    clamp is measured and reported, :func:`storage_report`), so nothing is refused.

    Parameters
    ----------
    remedy : str, optional
        What the message suggests (default: store float32 with ``--precision float32``).

    Raises
    ------
    ValueError
        One line naming the channel, its largest magnitude and the remedy.
    """
    enc = get_encoding(encoding)
    if enc.kind != "float":
        return
    limit = float(np.finfo(np.float16 if enc.bits == 16 else np.float32).max)
    if remedy is None:
        remedy = ("store float32 (--precision float32, or a float32 format: exr)" if enc.bits == 16
                  else "rescale the channel (float32 holds |x| <= 3.4e38)")
    for name in value_channels(table.channels):
        x = np.asarray(table.channels[name], dtype=np.float64)
        finite = x[np.isfinite(x)]
        big = float(np.max(np.abs(finite))) if finite.size else 0.0
        if big > limit:
            raise ValueError(f"channel {name}: values beyond the {encoding} range "
                             f"(max |x| {big:.6g} > {limit:g}); {remedy}")


def get_encoding(name: str) -> Encoding:
    """The encoding ``name``; ValueError listing the known ones."""
    try:
        return ENCODINGS[name]
    except (KeyError, TypeError):
        raise ValueError(f"unknown storage encoding {name!r}; choose one of: {', '.join(ENCODINGS)}") from None


def requested_encoding(table, fmt: str) -> str:
    """The encoding a ``fmt`` file of ``table`` uses: ``meta["storage"]["encoding"]`` if that
    format can store it, else the format's default."""
    choices = FORMAT_STORAGE[fmt]
    storage = table.meta.get("storage") if isinstance(table.meta, dict) else None
    wanted = storage.get("encoding") if isinstance(storage, dict) else None
    return wanted if wanted in choices else choices[0]


def bytes_per_texel(encoding: str, n_channels: int) -> int:
    """Bytes per texel of ``n_channels`` channels stored as ``encoding`` (GPU formats: 1, 2 or 4 components)."""
    if encoding == "unorm10":  # A2B10G10R10: up to 3 channels in 32 bits
        return 4 * -(-n_channels // 3)
    if encoding == "float64":
        return 8 * n_channels
    # GPU formats have 1, 2 or 4 components
    comps = n_channels if n_channels <= 2 else 4 * -(-n_channels // 4)
    return comps * ENCODINGS[encoding].bits // 8


def _channel_report(values: np.ndarray, errors: np.ndarray | None, enc: Encoding | None) -> dict:
    x = np.asarray(values, dtype=np.float64)
    finite = np.isfinite(x)
    integ = float(np.max(errors)) if errors is not None and errors.size else None
    if enc is None:  # float64: exact
        stored = np.zeros_like(x)
        clamp = 0.0
    else:
        with np.errstate(invalid="ignore"):
            stored = np.where(finite, np.abs(enc.quantize(x) - x), np.inf)
        if enc.kind == "unorm":
            clamp = float(np.max(np.abs(np.clip(x[finite], 0.0, 1.0) - x[finite]), initial=0.0))
        else:
            clamp = 0.0
    total = stored + (np.asarray(errors, dtype=np.float64) if errors is not None else 0.0)
    return {
        "integration_error": integ,
        "storage_error": float(np.max(stored)) if stored.size else 0.0,
        "clamp_error": clamp,
        "total_error": float(np.max(total)) if total.size else 0.0,
        "min": float(np.min(x[finite])) if finite.any() else None,
        "max": float(np.max(x[finite])) if finite.any() else None,
    }


def storage_report(table, encoding: str, fmt: str | None = None) -> dict:
    """Per value channel: the integration error, the error ``encoding`` adds, and their sum.

    Parameters
    ----------
    table : table-like
        ``axes``, ``channels`` (value channels ``X`` and error channels ``X_err``), ``meta``.
    encoding : str
        A name of :data:`ENCODINGS`, or ``"float64"`` (exact).
    fmt : str, optional
        The file format, recorded in the report.

    Returns
    -------
    dict
        ``{"encoding", "format", "bytes_per_texel", "channels": {X: {"integration_error"
        (max X_err, None without an error channel), "storage_error" (max |q(x) - x|, clamp
        included), "clamp_error" (max |clamp(x, 0, 1) - x|, UNORM only), "total_error"
        (max over texels of X_err + |q(x) - x|), "min", "max"}}, "max_total_error"}``.
    """
    enc = None if encoding == "float64" else get_encoding(encoding)
    names = value_channels(table.channels)
    channels = {}
    for name in names:
        err = table.channels.get(name + ERR_SUFFIX)
        channels[name] = _channel_report(table.channels[name], None if err is None else np.asarray(err), enc)
    totals = [c["total_error"] for c in channels.values()]
    return {
        "encoding": encoding,
        "format": fmt,
        "bytes_per_texel": bytes_per_texel(encoding, len(names)),
        "channels": channels,
        "max_total_error": max(totals) if totals else 0.0,
    }


def storage_report_for_format(table, fmt: str, encoding: str | None = None) -> dict:
    """:func:`storage_report` for the registry format ``fmt`` (its default encoding unless given).

    The function the service's info calls: ``storage_report_for_format(table, "exr")``.

    Raises
    ------
    ValueError
        If ``fmt`` is unknown or cannot store ``encoding``.
    """
    if fmt not in FORMAT_STORAGE:
        raise ValueError(f"unknown format {fmt!r}; choose one of: {', '.join(FORMAT_STORAGE)}")
    choices = FORMAT_STORAGE[fmt]
    encoding = encoding or choices[0]
    if encoding not in choices:
        raise ValueError(f"format {fmt} stores {', '.join(choices)}, not {encoding}")
    return storage_report(table, encoding, fmt)


def choose_encoding(table, fmt: str, tol: float) -> tuple[str, dict]:
    """The smallest encoding of ``fmt`` that keeps every stored value within ``tol``.

    Candidates are ordered by bytes per texel, then by measured error; the first whose
    ``max_total_error`` (integration + storage, texel by texel) is <= ``tol`` wins.

    Returns
    -------
    (str, dict)
        The encoding and its :func:`storage_report`.

    Raises
    ------
    ValueError
        If none does (naming the best one and its error).
    """
    reports = [storage_report(table, e, fmt) for e in FORMAT_STORAGE[fmt]]
    reports.sort(key=lambda r: (r["bytes_per_texel"], r["max_total_error"]))
    for report in reports:
        if report["max_total_error"] <= tol:
            return report["encoding"], report
    best = min(reports, key=lambda r: r["max_total_error"])
    raise ValueError(
        f"no {fmt} storage keeps the table within {tol:g}: the best, {best['encoding']}, "
        f"gives {best['max_total_error']:.3g}"
    )


def encode(table, encoding: str) -> dict[str, np.ndarray]:
    """Value channel -> stored values q(x) (float64), in the table's channel order; a float
    ``encoding`` that cannot hold a finite value is refused here, for every writer
    (:func:`check_range`)."""
    enc = get_encoding(encoding)
    check_range(table, encoding)
    return {n: enc.quantize(table.channels[n]) for n in value_channels(table.channels)}


def as_encoded(table, encoding: str, fmt: str, factory: Callable | None = None):
    """The table as a file storing ``encoding`` holds it.

    Value channels become q(x); each error channel ``X_err`` becomes ``X_err + |q(x) - x|`` (a
    bound on the stored value's error); ``meta["storage"]`` is the :func:`storage_report` and
    ``meta["max_error"]`` the stored bounds.

    Raises
    ------
    ValueError
        If a finite value is beyond the range of a float ``encoding`` (:func:`check_range`).
    """
    enc = get_encoding(encoding)
    check_range(table, encoding)
    channels = {}
    for name, arr in table.channels.items():
        channels[name] = np.asarray(arr, dtype=np.float64)
    for name in value_channels(table.channels):
        x = channels[name]
        q = enc.quantize(x)
        channels[name] = q
        if name + ERR_SUFFIX in channels:
            with np.errstate(invalid="ignore"):
                channels[name + ERR_SUFFIX] = channels[name + ERR_SUFFIX] + np.abs(q - x)
    meta = dict(table.meta)
    meta["storage"] = storage_report(table, encoding, fmt)
    meta["max_error"] = {n: float(np.max(channels[n + ERR_SUFFIX])) for n in value_channels(channels)
                         if n + ERR_SUFFIX in channels}
    return build(dict(table.axes), channels, meta, factory)
