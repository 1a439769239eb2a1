"""What every format module shares: the table-like protocol, the format record, JSON helpers.

The format modules never import :mod:`bsdf_tab.table` (which imports this package): a writer
accepts any *table-like* object, and a reader returns :class:`TableParts` or whatever a
``factory(axes, channels, meta)`` builds (``bsdf_tab.Table`` is such a factory).

Table-like
----------
An object with

- ``axes``: ordered dict, axis name -> 1-D array of float64 values;
- ``channels``: ordered dict, channel name -> array shaped ``tuple(len(a) for a in axes)``;
  a channel ``X_err`` (:data:`ERR_SUFFIX`) is the absolute error estimate of channel ``X``;
- ``meta``: JSON-serializable dict (``spec``, ``conventions``, ``method``, ``version``, ...).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, NamedTuple

import numpy as np

from ..errors import SpecError

__all__ = [
    "ERR_SUFFIX",
    "TableParts",
    "Format",
    "FormatError",
    "json_default",
    "shape_of",
    "value_channels",
    "max_error",
    "build",
    "check_folder",
    "layout_words",
]

#: A channel named ``X + ERR_SUFFIX`` holds the absolute error estimate of channel ``X``.
ERR_SUFFIX = "_err"


class FormatError(SpecError):
    """An unknown format name or file name ending, or a format that cannot do what was asked.

    A :class:`~bsdf_tab.errors.SpecError` (so the CLI prints one line and the service answers
    400), with ``param`` ``"format"`` (a format name) or ``"path"`` (a file name ending).
    """


class TableParts(NamedTuple):
    """What a reader returns without a factory: the three parts of a table."""

    axes: dict
    channels: dict
    meta: dict


def json_default(obj: Any) -> Any:
    """``json.dumps`` hook that turns NumPy scalars and arrays into Python values.

    Raises
    ------
    TypeError
        For any other type that JSON cannot hold.
    """
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    raise TypeError(f"{type(obj).__name__} is not JSON serializable")


def shape_of(table) -> tuple[int, ...]:
    """Shape of a table-like object: its axis lengths in axis order."""
    return tuple(len(a) for a in table.axes.values())


def value_channels(channels) -> list[str]:
    """Names of the value channels (those not ending in :data:`ERR_SUFFIX`), in order."""
    return [name for name in channels if not name.endswith(ERR_SUFFIX)]


def max_error(channels) -> dict[str, float]:
    """Largest error estimate of each value channel that has an error channel.

    Returns
    -------
    dict[str, float]
        Value channel name (``"E"``) -> max of ``E_err``; a NaN error propagates.
    """
    out = {}
    for name in value_channels(channels):
        err = channels.get(name + ERR_SUFFIX)
        if err is not None:
            out[name] = float(np.max(err))
    return out


def build(axes: dict, channels: dict, meta: dict, factory: Callable | None = None):
    """``factory(axes, channels, meta)``, or :class:`TableParts` when ``factory`` is None."""
    if factory is None:
        return TableParts(axes, channels, meta)
    return factory(axes, channels, meta)


def check_folder(path: Path) -> Path:
    """The folder of ``path`` (``.`` if none); FileNotFoundError naming it if it does not exist."""
    folder = path.parent if str(path.parent) else Path(".")
    if not folder.is_dir():
        raise FileNotFoundError(f"cannot write {path}: folder {folder} does not exist")
    return folder


def layout_words(axes: dict) -> str:
    """The array layout of a table with ``axes`` in words (row-major over the axes)."""
    names = list(axes)
    sizes = [len(a) for a in axes.values()]
    index = "".join(f"[i_{n}]" for n in names)
    dims = " x ".join(f"{n} {s}" for n, s in zip(names, sizes))
    return f"row-major (C order) over the axes in order: {dims}; value = channel{index}"


@dataclass(frozen=True)
class Format:
    """One entry of the format registry (:data:`bsdf_tab.io.FORMATS`).

    Parameters
    ----------
    name : str
        The one name of the format, in the CLI (``--format``), presets and the service
        (``format=``).
    suffixes : tuple of str
        File name endings, lower case, the first the one writers use (``.half.exr``); a path
        is matched by the longest ending first.
    description : str
        One line: what the file holds.
    write : callable
        ``write(table, path) -> list[Path]``: writes atomically; returns the files written,
        the main file first.
    media_type : str or None
        The HTTP media type, None for formats that are more than one file.
    media_aliases : tuple of str
        Other media types an ``Accept`` header may name for this format.
    to_bytes : callable or None
        ``to_bytes(table) -> bytes``: the file's bytes, for formats that are one file.
    read : callable or None
        ``read(path, factory=None)``: the table back (see :func:`build`); None if the format
        does not hold everything a table has (``npy`` holds no axes and no metadata).
    from_bytes : callable or None
        ``from_bytes(data, factory=None)``: as ``read``, from the file's bytes.
    as_stored : callable or None
        ``as_stored(table, factory=None)``: the table as the file holds it when that differs
        in value (``half-exr``: float16 values, the rounding added to the error channels).
    files : str
        ``"one"``, or ``"several"`` when ``write`` makes a set of files next to each other.
    """

    name: str
    suffixes: tuple[str, ...]
    description: str
    write: Callable
    media_type: str | None = None
    media_aliases: tuple[str, ...] = ()
    to_bytes: Callable | None = None
    read: Callable | None = None
    from_bytes: Callable | None = None
    as_stored: Callable | None = None
    files: str = "one"

    @property
    def suffix(self) -> str:
        """The file name ending writers use."""
        return self.suffixes[0]

    @property
    def readable(self) -> bool:
        """Whether a file of this format can be read back into a table."""
        return self.read is not None

    def path_for(self, folder, stem: str) -> Path:
        """``folder / (stem + suffix)``: the main file of a table named ``stem``."""
        return Path(folder) / f"{stem}{self.suffix}"

    def stem_of(self, path) -> str:
        """The file name of ``path`` without this format's ending (``lut.half.exr`` -> ``lut``)."""
        name = Path(path).name
        for ending in self.suffixes:
            if name.lower().endswith(ending):
                return name[: -len(ending)]
        return name
