"""``npz``: a NumPy ``.npz`` archive (no pickles), lossless: the service's master format.

Members, in this order (:func:`head_members`, the channels, :func:`tail_members`):

- ``axis_order``: array of the axis names (unicode);
- ``axis/<name>``: each axis, float64;
- ``channel/<name>``: each channel, in the table's own dtype (float64 from ``tabulate``),
  shaped by the axes in axis order;
- ``channel_order``: array of the channel names;
- ``meta``: a 0-d unicode array holding the JSON of the metadata.

``numpy.load(path, allow_pickle=False)`` reads it; :func:`read_npz` / :func:`npz_from_bytes`
give the table back exactly. The streaming writer (:mod:`bsdf_tab.io.stream`) writes the same
members.
"""

from __future__ import annotations

import io
import json
import zipfile
from typing import Callable

import numpy as np

from .atomic import bytes_reader, bytes_writer
from .base import Format, build, json_default

__all__ = ["FORMAT", "head_members", "tail_members", "npz_bytes", "npz_from_bytes", "write_npz", "read_npz"]


def head_members(axes: dict) -> dict[str, np.ndarray]:
    """The members before the channels: ``axis_order`` and ``axis/<name>`` (float64)."""
    members = {"axis_order": np.array(list(axes), dtype=str)}
    members.update({f"axis/{n}": np.asarray(a, dtype=np.float64) for n, a in axes.items()})
    return members


def tail_members(channel_names, meta: dict) -> dict[str, np.ndarray]:
    """The members after the channels: ``channel_order`` and ``meta`` (JSON string)."""
    return {
        "channel_order": np.array(list(channel_names), dtype=str),
        "meta": np.array(json.dumps(meta, default=json_default)),
    }


def npz_bytes(table) -> bytes:
    """The table as the bytes of a compressed ``.npz`` archive (see the module doc)."""
    arrays = head_members(table.axes)
    arrays.update({f"channel/{n}": np.asarray(c) for n, c in table.channels.items()})
    arrays.update(tail_members(table.channels, table.meta))
    buf = io.BytesIO()
    np.savez_compressed(buf, **arrays)
    return buf.getvalue()


def npz_from_bytes(data: bytes, factory: Callable | None = None, *, source: str = "npz data"):
    """The table held by the bytes of a bsdf-tab ``.npz`` archive.

    Parameters
    ----------
    data : bytes
        The archive.
    factory : callable, optional
        ``factory(axes, channels, meta)`` (default :class:`~bsdf_tab.io.base.TableParts`).
    source : str
        What to call the data in an error message (a file name).

    Raises
    ------
    ValueError
        If the data is not a bsdf-tab npz archive.
    """
    try:
        with np.load(io.BytesIO(data), allow_pickle=False) as npz:
            axes = {str(n): npz[f"axis/{n}"] for n in npz["axis_order"]}
            channels = {str(n): npz[f"channel/{n}"] for n in npz["channel_order"]}
            meta = json.loads(str(npz["meta"]))
    except KeyError as exc:
        raise ValueError(f"{source}: not a bsdf-tab npz archive (no member {exc})") from None
    except (zipfile.BadZipFile, OSError, ValueError, EOFError) as exc:
        raise ValueError(f"{source}: not a bsdf-tab npz archive ({exc})") from None
    return build(axes, channels, meta, factory)


#: atomic write and read of the whole file (:mod:`.atomic`)
write_npz = bytes_writer(npz_bytes)
read_npz = bytes_reader(npz_from_bytes)


FORMAT = Format(
    name="npz",
    suffixes=(".npz",),
    description="NumPy .npz archive: axes (float64), channels, meta JSON; lossless",
    write=write_npz,
    media_type="application/x-npz",
    media_aliases=("application/zip",),
    to_bytes=npz_bytes,
    read=read_npz,
    from_bytes=npz_from_bytes,
)
