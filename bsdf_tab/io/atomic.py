"""The one atomic file write of bsdf-tab.

A file is written to a fresh temporary name in the destination's own folder
(``.<name>.<pid>.<random>.tmp``: hidden, unique, on the same file system), flushed to disk
(``fsync``), then renamed onto its name with :func:`os.replace`, and the folder is synced so
the rename itself survives a crash. Readers see the old file or the new one, never a partial
one; if the writer raises, the temporary is removed and the destination is untouched.

Every writer uses it: the format modules of :mod:`bsdf_tab.io`, the streaming writer
(:mod:`bsdf_tab.io.stream`) and the service's cache (which adds its own header and checksum
around the payload). Left-over temporaries of a crash end in :data:`TMP_SUFFIX`, so a folder
owner (the cache) can recognize and remove them.

The temporary is created with the usual permissions (``0o666`` less the umask), not the
``0o600`` of :func:`tempfile.mkstemp`: a table written for others stays readable by them.
"""

from __future__ import annotations

import contextlib
import os
import uuid
from pathlib import Path
from typing import IO, Iterator

from .base import check_folder

__all__ = ["TMP_SUFFIX", "temp_path", "atomic_path", "atomic_open", "write_bytes", "write_text"]

#: Ending of every temporary file (a crash leaves files ``.<name>.<pid>.<hex>.tmp``).
TMP_SUFFIX = ".tmp"


def temp_path(path, ending: str = TMP_SUFFIX) -> Path:
    """A fresh hidden name next to ``path``: ``.<name>.<pid>.<random hex><ending>``."""
    path = Path(path)
    return path.with_name(f".{path.name}.{os.getpid()}.{uuid.uuid4().hex}{ending}")


def _fsync_file(path: Path) -> None:
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _fsync_folder(folder: Path) -> None:
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:  # pragma: no cover - a platform without directory handles
        return
    try:
        os.fsync(fd)
    except OSError:  # pragma: no cover - some file systems refuse to sync a directory
        pass
    finally:
        os.close(fd)


def _remove(path: Path) -> None:
    try:
        os.unlink(path)
    except FileNotFoundError:
        pass


@contextlib.contextmanager
def atomic_path(path) -> Iterator[Path]:
    """A temporary path to write ``path`` through, for writers that take a file name.

    The caller (or a library such as OpenEXR) creates and writes the temporary file; when
    the ``with`` block ends normally it is synced and renamed onto ``path``.

    Parameters
    ----------
    path : str or os.PathLike
        The destination. Its folder must exist.

    Yields
    ------
    Path
        The temporary file name (not yet created).

    Raises
    ------
    FileNotFoundError
        If the destination folder does not exist.
    OSError
        If the block ends without having created the temporary file.

    Examples
    --------
    >>> with atomic_path("out.exr") as tmp:          # doctest: +SKIP
    ...     exr_file.write(str(tmp))
    """
    path = Path(path)
    folder = check_folder(path)
    tmp = temp_path(path)
    try:
        yield tmp
        if not tmp.is_file():
            raise OSError(f"cannot write {path}: the writer created no file")
        _fsync_file(tmp)
        os.replace(tmp, path)
        _fsync_folder(folder)
    finally:
        _remove(tmp)


@contextlib.contextmanager
def atomic_open(path, mode: str = "wb", encoding: str | None = None) -> Iterator[IO]:
    """An open file that becomes ``path`` when the ``with`` block ends without an error.

    Parameters
    ----------
    path : str or os.PathLike
        The destination. Its folder must exist.
    mode : {"wb", "w"}
        Binary or text.
    encoding : str, optional
        Text mode only (default UTF-8).

    Yields
    ------
    file object
        The temporary file, opened exclusively (never an existing file).
    """
    if mode not in ("wb", "w"):
        raise ValueError(f"atomic_open: mode must be 'wb' or 'w', got {mode!r}")
    with atomic_path(path) as tmp:
        if mode == "w":
            fh = open(tmp, "x", encoding=encoding or "utf-8", newline="")
        else:
            fh = open(tmp, "xb")
        with fh:
            yield fh


def write_bytes(path, data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically; returns ``Path(path)``."""
    with atomic_open(path, "wb") as fh:
        fh.write(data)
    return Path(path)


def write_text(path, text: str, encoding: str = "utf-8") -> Path:
    """Write ``text`` to ``path`` atomically (no newline translation); returns ``Path(path)``."""
    with atomic_open(path, "w", encoding=encoding) as fh:
        fh.write(text)
    return Path(path)


def bytes_writer(to_bytes):
    """``write(table, path) -> [path]`` for a format whose file is its ``to_bytes(table)``, atomically."""

    def write(table, path) -> list[Path]:
        return [write_bytes(path, to_bytes(table))]

    return write


def bytes_reader(from_bytes):
    """``read(path, factory=None)`` for a format read by ``from_bytes(data, factory, source=...)``."""

    def read(path, factory=None):
        path = Path(path)
        if not path.is_file():
            raise FileNotFoundError(f"no such file: {path}")
        return from_bytes(path.read_bytes(), factory, source=str(path))

    return read
