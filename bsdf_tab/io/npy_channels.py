"""``npy-channels``: a set of ``.npy`` files, one per channel, with the axes and a JSON sidecar.

For a table written with stem ``S`` into folder ``D`` (the registry's name for the set is its
sidecar, ``D/S.meta.json``):

- ``D/S.<channel>.npy``: one array per channel (values ``E`` and errors ``E_err`` alike),
  float32, shape = the axis lengths in axis order, C order;
- ``D/S.axis.<name>.npy``: each axis, float64 (exact);
- ``D/S.meta.json``: ``{"axis_order", "channel_order", "shape", "dtype", "stacked",
  "layout", "files", "meta"}``, written last, so a complete sidecar means a complete set.

Stacked (``stacked=True``, Python only): ``D/S.npy`` holds all channels in one float32 array
of shape ``(*axis lengths, n_channels)`` (channels last, in ``channel_order``), with the same
axis files and ``S.meta.json``. Every file is written atomically; load them with
``numpy.load`` (no pickles). This is the layout engines such as Cycles ship their own tables
in (one array per quantity).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Callable

import numpy as np

from .atomic import atomic_open, write_text
from .base import Format, build, json_default, layout_words, shape_of

__all__ = ["FORMAT", "SIDECAR", "write_npy_channels", "read_npy_channels"]

#: Ending of the sidecar that names the set.
SIDECAR = ".meta.json"


def _save(path: Path, arr: np.ndarray) -> Path:
    with atomic_open(path, "wb") as fh:
        np.save(fh, arr, allow_pickle=False)
    return path


def write_npy_channels(table, out_dir, stem: str, *, stacked: bool = False, dtype=np.float32) -> list[Path]:
    """Write ``table`` as ``.npy`` files into ``out_dir`` (see the module doc for the layout).

    Parameters
    ----------
    table : table-like
        ``axes``, ``channels``, ``meta``.
    out_dir : str or os.PathLike
        An existing folder.
    stem : str
        The file name stem ``S``.
    stacked : bool
        One ``S.npy`` with the channels last instead of one file per channel.
    dtype : numpy dtype
        The channel dtype (default float32).

    Returns
    -------
    list of Path
        The files written; the first is the main array (``S.npy`` when stacked, else the
        first channel's file), the last is ``S.meta.json``.

    Raises
    ------
    FileNotFoundError
        If ``out_dir`` does not exist.
    """
    out_dir = Path(out_dir)
    if not out_dir.is_dir():
        raise FileNotFoundError(f"output folder does not exist: {out_dir}")
    written: list[Path] = []
    channels = list(table.channels)
    if stacked:
        data = np.stack([np.asarray(table.channels[c], dtype=dtype) for c in channels], axis=-1)
        written.append(_save(out_dir / f"{stem}.npy", data))
    else:
        for name in channels:
            written.append(_save(out_dir / f"{stem}.{name}.npy", np.ascontiguousarray(table.channels[name], dtype=dtype)))
    for name, values in table.axes.items():
        written.append(_save(out_dir / f"{stem}.axis.{name}.npy", np.asarray(values, dtype=np.float64)))
    layout = layout_words(table.axes)
    if stacked:
        layout += f"; stacked: last index = channel, in channel_order ({len(channels)})"
    info = {
        "axis_order": list(table.axes),
        "channel_order": channels,
        "shape": list(shape_of(table)),
        "dtype": np.dtype(dtype).name,
        "stacked": stacked,
        "layout": layout,
        "files": [p.name for p in written],
        "meta": table.meta,
    }
    meta_path = out_dir / f"{stem}{SIDECAR}"
    written.append(write_text(meta_path, json.dumps(info, indent=1, default=json_default)))
    return written


def read_npy_channels(out_dir, stem: str, factory: Callable | None = None):
    """Read a table written by :func:`write_npy_channels` (either layout).

    Raises
    ------
    FileNotFoundError
        If the sidecar or one of the files it lists is missing.
    ValueError
        If the sidecar is not the JSON this module writes.
    """
    out_dir = Path(out_dir)
    sidecar = out_dir / f"{stem}{SIDECAR}"
    if not sidecar.is_file():
        raise FileNotFoundError(f"no such file: {sidecar}")
    try:
        info = json.loads(sidecar.read_text(encoding="utf-8"))
        axis_order, channel_order, stacked, meta = info["axis_order"], info["channel_order"], info["stacked"], info["meta"]
    except (json.JSONDecodeError, KeyError, TypeError) as exc:
        raise ValueError(f"{sidecar}: not a bsdf-tab npy-channels sidecar ({exc})") from None
    axes = {n: np.load(out_dir / f"{stem}.axis.{n}.npy", allow_pickle=False) for n in axis_order}
    if stacked:
        data = np.load(out_dir / f"{stem}.npy", allow_pickle=False)
        channels = {c: data[..., k] for k, c in enumerate(channel_order)}
    else:
        channels = {c: np.load(out_dir / f"{stem}.{c}.npy", allow_pickle=False) for c in channel_order}
    return build(axes, channels, meta, factory)


def _stem(path: Path) -> str:
    name = path.name
    return name[: -len(SIDECAR)] if name.lower().endswith(SIDECAR) else name


def _write(table, path) -> list[Path]:
    path = Path(path)
    return write_npy_channels(table, path.parent if str(path.parent) else Path("."), _stem(path))


def _read(path, factory: Callable | None = None):
    path = Path(path)
    return read_npy_channels(path.parent if str(path.parent) else Path("."), _stem(path), factory)


FORMAT = Format(
    name="npy-channels",
    suffixes=(SIDECAR,),
    description="one float32 .npy per channel, float64 .npy per axis, and S.meta.json",
    write=_write,
    read=_read,
    files="several",
)
