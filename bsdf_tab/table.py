"""The :class:`Table`: axes, value and error channels, and metadata.

A table of a kind with axes ``(a0, a1, ...)`` holds, for each value channel
``X`` (for example ``E``), an array ``channels["X"]`` of shape
``(len(a0), len(a1), ...)`` and, normally, an error channel ``X_err`` of the
same shape: the estimated absolute integration error of each texel.
"""

from __future__ import annotations

import io
import json
from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = ["Table", "ERR_SUFFIX", "json_default"]

ERR_SUFFIX = "_err"


def json_default(obj: Any) -> Any:
    """``json.dumps`` hook that turns NumPy scalars and arrays into Python values."""
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    raise TypeError(f"{type(obj).__name__} is not JSON serializable")


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
        return [name for name in self.channels if not name.endswith(ERR_SUFFIX)]

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
        out = {}
        for name in self.value_channels:
            err = self.channels.get(name + ERR_SUFFIX)
            if err is not None:
                out[name] = float(np.max(err))
        return out

    def write_exr(self, path) -> None:
        """Write the table to an OpenEXR file (see :mod:`bsdf_tab.exr`)."""
        from .exr import write_exr

        write_exr(self, path)

    def to_exr_bytes(self) -> bytes:
        """The table as the bytes of an OpenEXR file."""
        from .exr import exr_bytes

        return exr_bytes(self)

    def to_npz_bytes(self) -> bytes:
        """The table as the bytes of a NumPy ``.npz`` archive (no pickles).

        Keys: ``axis_order`` (array of names), ``axis/<name>`` (float64),
        ``channel/<name>`` and ``meta`` (a JSON string). Read it back with
        :meth:`from_npz_bytes`.
        """
        arrays = {"axis_order": np.array(list(self.axes), dtype=str)}
        arrays.update({f"axis/{n}": a for n, a in self.axes.items()})
        arrays.update({f"channel/{n}": c for n, c in self.channels.items()})
        arrays["channel_order"] = np.array(list(self.channels), dtype=str)
        arrays["meta"] = np.array(json.dumps(self.meta, default=json_default))
        buf = io.BytesIO()
        np.savez_compressed(buf, **arrays)
        return buf.getvalue()

    @classmethod
    def from_npz_bytes(cls, data: bytes) -> "Table":
        """Inverse of :meth:`to_npz_bytes`."""
        with np.load(io.BytesIO(data), allow_pickle=False) as npz:
            axes = {str(n): npz[f"axis/{n}"] for n in npz["axis_order"]}
            channels = {str(n): npz[f"channel/{n}"] for n in npz["channel_order"]}
            meta = json.loads(str(npz["meta"]))
        return cls(axes, channels, meta)

    def to_json_dict(self) -> dict:
        """The table as a JSON-serializable dict.

        Returns
        -------
        dict
            ``{"axes": {name: [...]}, "shape": [...], "channels": {name:
            nested lists}, "meta": {...}}``; axes and channels keep their
            order. Non-finite channel values become ``None``.
        """
        return {
            "axes": {n: a.tolist() for n, a in self.axes.items()},
            "shape": list(self.shape),
            "channels": {n: _finite_or_none(c) for n, c in self.channels.items()},
            "meta": json.loads(json.dumps(self.meta, default=json_default)),
        }

    def __repr__(self) -> str:
        axes = " x ".join(f"{n}[{len(a)}]" for n, a in self.axes.items())
        return f"Table({self.kind or 'table'}: {axes}; channels {', '.join(self.channels)})"


def _finite_or_none(values: np.ndarray) -> list:
    if np.isfinite(values).all():
        return values.tolist()
    obj = values.astype(object)
    obj[~np.isfinite(values)] = None
    return obj.tolist()
