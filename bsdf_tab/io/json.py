"""``json``: the whole table as one JSON object (strict JSON: no NaN or Infinity).

::

    {"axes": {name: [values...]}, "shape": [n0, n1, ...],
     "channels": {name: nested lists shaped by the axes}, "meta": {...}}

Axes and channels keep their order. Numbers are written with ``repr`` (exact float64);
non-finite values (channel texels, or numbers in the metadata) become ``null``, and the
reader turns a ``null`` texel into NaN. The same compact bytes in the CLI and the service.
"""

from __future__ import annotations

import json
import math
from typing import Any, Callable

import numpy as np

from .atomic import bytes_reader, bytes_writer
from .base import Format, build, json_default, shape_of

__all__ = ["FORMAT", "to_json_dict", "json_bytes", "json_from_bytes", "write_json", "read_json", "finite_json"]


def _finite_or_none(values) -> list:
    values = np.asarray(values)
    if np.isfinite(values).all():
        return values.tolist()
    obj = values.astype(object)
    obj[~np.isfinite(values)] = None
    return obj.tolist()


def finite_json(obj: Any) -> Any:
    """A JSON value (from :func:`json.loads`) with every non-finite float replaced by None."""
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {k: finite_json(v) for k, v in obj.items()}
    if isinstance(obj, list):
        return [finite_json(v) for v in obj]
    return obj


def to_json_dict(table) -> dict:
    """The table as a JSON-serializable dict (see the module doc).

    Returns
    -------
    dict
        ``{"axes", "shape", "channels", "meta"}``; non-finite values are ``None``.
    """
    return {
        "axes": {n: np.asarray(a, dtype=np.float64).tolist() for n, a in table.axes.items()},
        "shape": list(shape_of(table)),
        "channels": {n: _finite_or_none(c) for n, c in table.channels.items()},
        "meta": finite_json(json.loads(json.dumps(table.meta, default=json_default))),
    }


def json_bytes(table) -> bytes:
    """The bytes of the JSON file: :func:`to_json_dict`, compact, UTF-8."""
    return json.dumps(to_json_dict(table), allow_nan=False, separators=(",", ":")).encode("utf-8")


def json_from_bytes(data: bytes, factory: Callable | None = None, *, source: str = "JSON data"):
    """The table held by a JSON document of :func:`json_bytes` (channels as float64).

    Raises
    ------
    ValueError
        If the data is not JSON or not a bsdf-tab table object.
    """
    try:
        doc = json.loads(data)
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise ValueError(f"{source}: not valid JSON ({exc})") from None
    if not isinstance(doc, dict) or not {"axes", "channels", "meta"} <= set(doc):
        raise ValueError(f"{source}: not a bsdf-tab table (a JSON object with axes, channels and meta)")
    try:
        axes = {str(n): np.asarray(v, dtype=np.float64) for n, v in doc["axes"].items()}
        # numpy reads a null (None) as NaN in a float array
        channels = {str(n): np.asarray(v, dtype=np.float64) for n, v in doc["channels"].items()}
    except (AttributeError, TypeError, ValueError) as exc:
        raise ValueError(f"{source}: malformed axes or channels ({exc})") from None
    if not isinstance(doc["meta"], dict):
        raise ValueError(f"{source}: meta is not a JSON object")
    return build(axes, channels, doc["meta"], factory)


#: atomic write and read of the whole file (:mod:`.atomic`)
write_json = bytes_writer(json_bytes)
read_json = bytes_reader(json_from_bytes)


FORMAT = Format(
    name="json",
    suffixes=(".json",),
    description="one JSON object: axes, shape, channels (nested lists, null for non-finite), meta",
    write=write_json,
    media_type="application/json",
    media_aliases=("text/json",),
    to_bytes=json_bytes,
    read=read_json,
    from_bytes=json_from_bytes,
)
