"""The :class:`Table`: axes, value and error channels, and metadata.

A table of a kind with axes ``(a0, a1, ...)`` holds, for each value channel
``X`` (for example ``E``), an array ``channels["X"]`` of shape
``(len(a0), len(a1), ...)`` and, normally, an error channel ``X_err`` of the
same shape: the estimated absolute integration error of each texel.

No format code lives here: reading and writing are :mod:`bsdf_tab.io`'s, and the methods
below (:meth:`Table.write`, :meth:`Table.read`, :meth:`Table.write_exr`, ...) delegate to it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from . import io as formats
from .io import exr as _exr_format
from .io import json as _json_format
from .io import npz as _npz_format
from .io.base import ERR_SUFFIX, json_default, max_error, value_channels

__all__ = ["Table", "ERR_SUFFIX", "json_default", "read_exr", "write_exr"]


def _as_axis(name: Any, values: Any) -> np.ndarray:
    if not isinstance(name, str) or not name:
        raise ValueError(f"axis names must be non-empty strings, got {name!r}")
    arr = np.asarray(values, dtype=np.float64)
    if arr.ndim != 1 or arr.size == 0:
        raise ValueError(f"axis {name!r} must be a non-empty 1-D array, got shape {arr.shape}")
    return arr


def _as_channel(name: Any, values: Any, shape: tuple[int, ...]) -> np.ndarray:
    if not isinstance(name, str) or not name:
        raise ValueError(f"channel names must be non-empty strings, got {name!r}")
    arr = np.asarray(values)
    if arr.dtype.kind != "f":
        arr = arr.astype(np.float64)
    if arr.shape != shape:
        raise ValueError(f"channel {name!r} has shape {arr.shape}, but the axes give shape {shape}")
    return arr


@dataclass(eq=False)
class Table:
    """A computed lookup table.

    Parameters
    ----------
    axes : dict[str, numpy.ndarray]
        Ordered axis name -> 1-D float64 values (for example ``mu``, ``alpha``).
    channels : dict[str, numpy.ndarray]
        Channel name -> array shaped ``tuple(len(a) for a in axes.values())``.
        Value channels (``E``) and their error channels (``E_err``).
    meta : dict
        JSON-serializable metadata: ``spec`` (normalized), ``conventions``,
        ``method``, ``version``, ``max_error``, ...

    Raises
    ------
    ValueError
        If an axis is not a non-empty 1-D array or a channel's shape does
        not match the axes.
    """

    axes: dict[str, np.ndarray]
    channels: dict[str, np.ndarray]
    meta: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not self.axes:
            raise ValueError("a table needs at least one axis")
        self.axes = {name: _as_axis(name, values) for name, values in self.axes.items()}
        shape = self.shape
        self.channels = {name: _as_channel(name, v, shape) for name, v in self.channels.items()}
        if self.meta is None:
            self.meta = {}

    @property
    def shape(self) -> tuple[int, ...]:
        """Table shape: the axis lengths in axis order."""
        return tuple(len(a) for a in self.axes.values())

    @property
    def value_channels(self) -> list[str]:
        """Names of the value channels (those not ending in ``_err``), in order."""
        return value_channels(self.channels)

    @property
    def error_channels(self) -> list[str]:
        """Names of the error channels (ending in ``_err``), in order."""
        return [name for name in self.channels if name.endswith(ERR_SUFFIX)]

    @property
    def kind(self) -> str | None:
        """Table kind from ``meta["spec"]["table"]``, or None if unknown."""
        spec = self.meta.get("spec")
        return spec.get("table") if isinstance(spec, dict) else None

    def max_error(self) -> dict[str, float]:
        """Largest error estimate of each value channel that has an error channel.

        Returns
        -------
        dict[str, float]
            Value channel name (``"E"``, not ``"E_err"``) -> max of its
            error channel. NaN errors propagate (a NaN result means a bad texel).
        """
        return max_error(self.channels)

    # ------------------------------------------------------------------ formats (bsdf_tab.io)

    def write(self, path, fmt: str | None = None) -> list[Path]:
        """Write the table atomically as ``fmt`` or as the ending of ``path`` says.

        See :func:`bsdf_tab.io.write` (formats: :mod:`bsdf_tab.io`). Returns the files written.
        """
        return formats.write(self, path, fmt)

    @classmethod
    def read(cls, path, fmt: str | None = None) -> "Table":
        """Read a table file (format from its ending unless ``fmt``); see :func:`bsdf_tab.io.read`."""
        return formats.read(path, fmt, factory=cls)

    def to_bytes(self, fmt: str) -> bytes:
        """The bytes of the ``fmt`` file of the table (see :func:`bsdf_tab.io.to_bytes`)."""
        return formats.to_bytes(self, fmt)

    @classmethod
    def from_bytes(cls, data: bytes, fmt: str) -> "Table":
        """The table held by the bytes of a ``fmt`` file (see :func:`bsdf_tab.io.from_bytes`)."""
        return formats.from_bytes(data, fmt, factory=cls)

    def as_stored(self, fmt: str) -> "Table":
        """The table as a ``fmt`` file holds it: ``self`` unless the format changes values
        (``half-exr``: float16 values, the rounding in the error channels and ``max_error``).
        See :func:`bsdf_tab.io.as_stored`."""
        return formats.as_stored(self, fmt, factory=type(self))

    def write_exr(self, path) -> None:
        """Write the table to an OpenEXR file (see :mod:`bsdf_tab.io.exr`)."""
        _exr_format.write_exr(self, path)

    def to_exr_bytes(self) -> bytes:
        """The table as the bytes of an OpenEXR file."""
        return _exr_format.exr_bytes(self)

    def to_npz_bytes(self) -> bytes:
        """The table as the bytes of a NumPy ``.npz`` archive (no pickles).

        Keys: ``axis_order`` (array of names), ``axis/<name>`` (float64),
        ``channel/<name>``, ``channel_order`` and ``meta`` (a JSON string); see
        :mod:`bsdf_tab.io.npz`. Read it back with :meth:`from_npz_bytes`.
        """
        return _npz_format.npz_bytes(self)

    @classmethod
    def from_npz_bytes(cls, data: bytes) -> "Table":
        """Inverse of :meth:`to_npz_bytes`."""
        return _npz_format.npz_from_bytes(data, cls)

    def to_json_dict(self) -> dict:
        """The table as a JSON-serializable dict (see :mod:`bsdf_tab.io.json`).

        Returns
        -------
        dict
            ``{"axes": {name: [...]}, "shape": [...], "channels": {name:
            nested lists}, "meta": {...}}``; axes and channels keep their
            order. Non-finite values become ``None``.
        """
        return _json_format.to_json_dict(self)

    def __repr__(self) -> str:
        axes = " x ".join(f"{n}[{len(a)}]" for n, a in self.axes.items())
        return f"Table({self.kind or 'table'}: {axes}; channels {', '.join(self.channels)})"



def read_exr(path) -> Table:
    """Read a table written by :func:`write_exr` (or the half-float writer).

    Returns
    -------
    Table
        Axes as float64 exactly as written, channels as float32 arrays shaped by the
        axes, meta from the JSON header (see :func:`bsdf_tab.io.exr.read_exr`).

    Raises
    ------
    FileNotFoundError
        If ``path`` does not exist.
    ValueError
        If the file is not an OpenEXR file or not a bsdf-tab table.
    """
    return _exr_format.read_exr(path, Table)


def write_exr(table, path) -> None:
    """Write ``table`` to the OpenEXR file ``path`` atomically (see :mod:`bsdf_tab.io.exr`)."""
    _exr_format.write_exr(table, path)
