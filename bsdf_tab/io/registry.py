"""The registry of formats: name, file name endings and media type -> writer and reader.

The only place that knows format names, endings and media types. Adding a format is one
module in :mod:`bsdf_tab.io` with a ``FORMAT`` record and one line in :data:`FORMATS`.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Callable, Iterable

from . import c_header, dds, exr, half_exr, ktx2, npy, npy_channels, npz, png
from . import json as json_format
from .base import Format, FormatError

__all__ = [
    "FORMATS",
    "FILE_FORMATS",
    "ENDINGS",
    "names",
    "get_format",
    "endings",
    "format_for",
    "format_for_media",
    "media_types",
    "accept_types",
    "output_path",
    "write",
    "to_bytes",
    "read",
    "from_bytes",
    "as_stored",
]

#: name -> format, in the order help texts list them.
FORMATS: dict[str, Format] = {
    f.name: f
    for f in (
        exr.FORMAT,
        half_exr.FORMAT,
        npz.FORMAT,
        npy.FORMAT,
        npy_channels.FORMAT,
        json_format.FORMAT,
        c_header.FORMAT,
        ktx2.FORMAT,
        dds.FORMAT,
        png.FORMAT,
    )
}


def _all_endings() -> tuple[str, ...]:
    return tuple(e for f in FORMATS.values() for e in f.suffixes)


#: Every format name, in registry order (the choices of a ``--format`` option).
FILE_FORMATS: tuple[str, ...] = tuple(FORMATS)
#: Every file name ending, in registry order (``.exr``, ``.half.exr``, ...).
ENDINGS: tuple[str, ...] = _all_endings()


def names(*, readable: bool | None = None, single_file: bool | None = None) -> list[str]:
    """Format names, in registry order, optionally only those that can be read back / are one file."""
    out = []
    for f in FORMATS.values():
        if readable is not None and f.readable != readable:
            continue
        if single_file is not None and (f.files == "one") != single_file:
            continue
        out.append(f.name)
    return out


def get_format(name: str) -> Format:
    """The format called ``name``.

    Raises
    ------
    FormatError
        Naming the unknown format and the known ones (``param`` is ``"format"``).
    """
    try:
        return FORMATS[name]
    except (KeyError, TypeError):
        raise FormatError("format", f"unknown format {name!r}; choose one of: {', '.join(FORMATS)}") from None


def _by_ending(name: str) -> Format | None:
    lower = name.lower()
    best, best_len = None, 0
    for f in FORMATS.values():
        for ending in f.suffixes:
            if lower.endswith(ending) and len(ending) > best_len:
                best, best_len = f, len(ending)
    return best


def endings(formats: Iterable[str] | None = None) -> list[str]:
    """The file name endings of ``formats`` (default: all), in registry order."""
    chosen = [get_format(n) for n in formats] if formats is not None else list(FORMATS.values())
    return [e for f in chosen for e in f.suffixes]


def _endings() -> str:
    return ", ".join(endings())


def format_for(path_or_name) -> Format:
    """The format of a format name (``"half-exr"``) or of a file name by its ending.

    The longest matching ending wins (``lut.half.exr`` is ``half-exr``, ``lut.exr`` is
    ``exr``; ``lut.meta.json`` is ``npy-channels``, other ``.json`` files ``json``). Endings
    are matched case-insensitively.

    Parameters
    ----------
    path_or_name : str, os.PathLike or Format
        A registered name, a path, or a :class:`Format` (returned as is).

    Raises
    ------
    FormatError
        Naming the unknown name or ending and listing the known ones.
    """
    if isinstance(path_or_name, Format):
        return path_or_name
    if isinstance(path_or_name, str) and path_or_name in FORMATS:
        return FORMATS[path_or_name]
    if not isinstance(path_or_name, (str, os.PathLike)):
        raise FormatError("format", f"expected a format name or a file name, got {type(path_or_name).__name__}")
    name = Path(path_or_name).name
    found = _by_ending(name)
    if found is not None:
        return found
    if "." not in name:
        raise FormatError("format", f"unknown format {name!r}; choose one of: {', '.join(FORMATS)}")
    raise FormatError("path", f"{path_or_name}: unknown file name ending {Path(name).suffix!r}; "
                              f"use one of: {_endings()}")


def format_for_media(media_type: str) -> Format | None:
    """The format served as ``media_type`` (its own type or an alias), or None.

    A media type two formats share (``image/x-exr``: ``exr`` and ``half-exr``) means the
    first registered (``exr``).
    """
    media_type = media_type.strip().lower()
    for f in FORMATS.values():
        if f.media_type == media_type or media_type in f.media_aliases:
            return f
    return None


def media_types(formats: Iterable[str] | None = None) -> dict[str, str]:
    """name -> media type of ``formats`` (default: every format that has one), in that order."""
    chosen = [get_format(n) for n in formats] if formats is not None else list(FORMATS.values())
    out = {}
    for f in chosen:
        if f.media_type is None:
            raise FormatError("format", f"{f.name} has no media type (it is {f.files} files)")
        out[f.name] = f.media_type
    return out


def accept_types(formats: Iterable[str]) -> dict[str, str]:
    """media type -> name, for an ``Accept`` header: each format's own type and its aliases.

    The first of ``formats`` wins a media type they share.
    """
    out: dict[str, str] = {}
    for n in formats:
        f = get_format(n)
        for media in (f.media_type, *f.media_aliases):
            if media is not None:
                out.setdefault(media, f.name)
    return out


def output_path(folder, stem: str, fmt: str) -> Path:
    """``folder / (stem + ending)``: where a table named ``stem`` is written as ``fmt``."""
    return get_format(fmt).path_for(folder, stem)


def write(table, path, fmt: str | None = None) -> list[Path]:
    """Write ``table`` to ``path`` atomically, as ``fmt`` or as the ending of ``path`` says.

    Parameters
    ----------
    table : table-like
        ``axes``, ``channels``, ``meta`` (a :class:`bsdf_tab.Table`).
    path : str or os.PathLike
        Destination; its folder must exist.
    fmt : str, optional
        A format name (``exr``, ``half-exr``, ``npz``, ``npy``, ``npy-channels``, ``json``,
        ``h``); default from the ending of ``path``.

    Returns
    -------
    list of Path
        The files written, the main one first.

    Raises
    ------
    FormatError
        If the format or the ending is unknown.
    FileNotFoundError
        If the destination folder does not exist.
    ValueError
        If the table cannot be stored in the format (no channels, beyond the half range).
    """
    return get_format(fmt).write(table, path) if fmt is not None else format_for(path).write(table, path)


def to_bytes(table, fmt: str) -> bytes:
    """The bytes of the file ``fmt`` writes for ``table``.

    Raises
    ------
    FormatError
        If ``fmt`` is unknown or is several files (``npy-channels``).
    """
    f = get_format(fmt)
    if f.to_bytes is None:
        raise FormatError("format", f"{f.name} is {f.files} files, not one byte string")
    return f.to_bytes(table)


def _reader(f: Format, what: str) -> Callable:
    reader = f.read if what == "read" else f.from_bytes
    if reader is None:
        readable = ", ".join(names(readable=True))
        raise FormatError("format", f"{f.name} files cannot be read back into a table "
                                    f"(they hold no axes or metadata); readable: {readable}")
    return reader


def read(path, fmt: str | None = None, *, factory: Callable | None = None):
    """Read a table from ``path`` (format from its ending unless ``fmt`` is given).

    Parameters
    ----------
    path : str or os.PathLike
        The file (for ``npy-channels``, its ``.meta.json`` sidecar).
    fmt : str, optional
        A readable format name.
    factory : callable, optional
        ``factory(axes, channels, meta)`` builds the result (``bsdf_tab.Table``); default
        :class:`~bsdf_tab.io.base.TableParts`.

    Raises
    ------
    FormatError
        If the format is unknown or cannot be read back (``npy``, ``h``).
    FileNotFoundError
        If the file does not exist.
    ValueError
        If the file is not a bsdf-tab table of that format.
    """
    f = get_format(fmt) if fmt is not None else format_for(path)
    return _reader(f, "read")(path, factory)


def from_bytes(data: bytes, fmt: str, *, factory: Callable | None = None):
    """The table held by ``data``, the bytes of a ``fmt`` file (see :func:`read`)."""
    return _reader(get_format(fmt), "from_bytes")(data, factory)


def as_stored(table, fmt: str, *, factory: Callable | None = None):
    """The table as a ``fmt`` file holds it: ``table`` itself unless the format changes values.

    ``half-exr`` gives the float16 table with the rounding in its error channels (its
    ``max_error`` is that of the file); every other format gives ``table`` unchanged.
    """
    f = get_format(fmt)
    return table if f.as_stored is None else f.as_stored(table, factory)
