"""The table cache: content-addressed, atomic, checksummed, size-capped (LRU), single-flight.

Keys
----
A table's key is ``<package version>-<spec_hash(normalized spec)>`` (:func:`table_key`), so a
new release never serves an old release's numbers. One table has several *entries*: the
``npz`` master (float64, lossless, what the integrator produced) and derived representations
(``exr``, ``npy``, ``json``, ``info``, preview ``png`` variants) made from the master. An
entry's file is ``<key>.<variant>`` in the cache folder.

File format and where corruption is decided
-------------------------------------------
Every entry file is one header line and the payload::

    BSDFTAB-CACHE 2 <sha256 hex of payload> <payload length> <entry name>\n<payload>

The entry name (``<key>.<variant>``: spec hash, variant, package version) is inside the
header, so a file copied or renamed onto another entry's name is not that entry.
:meth:`DiskCache.get` reads the file and checks the magic, the name, the length and the
SHA-256, then the caller's ``validate(payload)`` (the service checks that the payload *is*
what the variant says: an npz master holds a table of that very spec hash, an EXR parses, a
JSON document loads, a PNG has its signature). Any mismatch (truncated, bit-flipped,
half-written, foreign, renamed or mislabelled file) counts as a miss (``corrupt`` or
``invalid``), the file is deleted and the caller recomputes. Such a file is never served.

Writes are atomic (:mod:`bsdf_tab.io.atomic`, the library's one atomic write): the entry is
written to a unique temporary file in the same folder, flushed and fsync'ed, then
``os.replace``-d onto its name; readers see the old file or the new one, never a partial one.
Left-over temporaries (a crash mid-write) are removed at start-up.

Replicas
--------
Several processes may share one folder (``bsdf-tab serve`` replicas, uvicorn workers).
:meth:`DiskCache.key_lock` is an inter-process lock per key (``fcntl.flock`` on
``locks/<name>.lock``): the one process that holds it computes, the others poll the cache
until the entry appears. A lock file exists only while its key is being computed (the holder
unlinks it on release), so the folder does not grow with the cache. The folder must be a local
disk, or NFS with working locks (``flock`` over NFSv4 / lockd); atomic ``rename`` within the
folder is required.

Size cap
--------
An in-memory index (name -> size, last use) is built by scanning the folder on first use
(last use = the file's mtime) and kept up to date; every hit touches the file's mtime so the
order survives restarts. After each write, least-recently-used entries are deleted until the
total is under ``max_bytes``.

Single flight
-------------
:class:`SingleFlight` runs one coroutine per key at a time: concurrent callers of the same
key await the same task, so N simultaneous requests for one uncached table cause one
computation and all get the same bytes.
"""

from __future__ import annotations

import asyncio
import hashlib
import os
import re
import threading
import uuid
from collections import OrderedDict
from pathlib import Path
from typing import Awaitable, Callable, TypeVar

from bsdf_tab.io.atomic import TMP_SUFFIX, write_bytes

__all__ = ["DiskCache", "KeyLock", "MemoryLRU", "SingleFlight", "table_key", "MAGIC"]

MAGIC = b"BSDFTAB-CACHE 2 "
_HEADER_MAX = len(MAGIC) + 64 + 1 + 20 + 1 + 202 + 1
_NAME_RE = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._+-]{0,200}$")
_TMP_SUFFIX = TMP_SUFFIX  # what a write that never finished leaves: ".<name>.<pid>.<hex>.tmp"

T = TypeVar("T")


def table_key(spec_hash: str, version: str) -> str:
    """Cache key of a table: package version + canonical spec hash (safe as a file name)."""
    safe_version = re.sub(r"[^A-Za-z0-9.+]", "_", version)
    return f"v{safe_version}-{spec_hash}"


def _encode(payload: bytes, name: str) -> bytes:
    digest = hashlib.sha256(payload).hexdigest().encode()
    return MAGIC + digest + b" " + str(len(payload)).encode() + b" " + name.encode() + b"\n" + payload


def _decode(data: bytes, name: str) -> bytes | None:
    """The payload of entry file ``name``, or None when the file is not intact or not that entry."""
    if not data.startswith(MAGIC):
        return None
    end = data.find(b"\n", 0, _HEADER_MAX)
    if end < 0:
        return None
    fields = data[len(MAGIC) : end].split(b" ")
    if len(fields) != 3 or len(fields[0]) != 64 or not fields[1].isdigit():
        return None
    if fields[2] != name.encode():  # another entry's file under this name: not this entry
        return None
    payload = data[end + 1 :]
    if len(payload) != int(fields[1]):
        return None
    if hashlib.sha256(payload).hexdigest().encode() != fields[0]:
        return None
    return payload


class DiskCache:
    """Checksummed entry files in one folder, with a size cap and LRU eviction.

    Parameters
    ----------
    folder : path
        The cache folder (created on first use).
    max_bytes : int
        Size cap of all entry files together; 0 disables storing.

    Thread-safe: the index is guarded by a lock; file reads and writes happen outside it.
    """

    def __init__(self, folder: os.PathLike | str, max_bytes: int) -> None:
        self.folder = Path(folder)
        self.max_bytes = int(max_bytes)
        self._lock = threading.Lock()
        self._index: OrderedDict[str, int] | None = None  # name -> size, least recently used first
        self._total = 0
        self.stats = {"hits": 0, "misses": 0, "corrupt": 0, "invalid": 0, "writes": 0, "evictions": 0}

    # ------------------------------------------------------------------ index

    def _ensure_index(self) -> OrderedDict[str, int]:
        if self._index is not None:
            return self._index
        with self._lock:
            if self._index is not None:
                return self._index
            self.folder.mkdir(parents=True, exist_ok=True)
            found = []
            for entry in os.scandir(self.folder):
                if not entry.is_file(follow_symlinks=False):
                    continue
                if entry.name.endswith(_TMP_SUFFIX):  # a write that never finished
                    _unlink(entry.path)
                    continue
                if not _NAME_RE.match(entry.name):
                    continue
                st = entry.stat(follow_symlinks=False)
                found.append((st.st_mtime, entry.name, st.st_size))
            found.sort()
            self._index = OrderedDict((name, size) for _, name, size in found)
            self._total = sum(self._index.values())
            return self._index

    def _path(self, name: str) -> Path:
        if not _NAME_RE.match(name):
            raise ValueError(f"bad cache entry name {name!r}")
        return self.folder / name

    # ------------------------------------------------------------------ public

    def get(self, name: str, validate: Callable[[bytes], bool] | None = None) -> bytes | None:
        """The payload of entry ``name``, or None if absent, not intact or not valid (then it is deleted).

        ``validate(payload) -> bool`` checks that an intact payload is what the entry claims to
        be; False (or an exception) deletes the file and counts it as ``invalid``.
        """
        index = self._ensure_index()
        path = self._path(name)
        try:
            data = path.read_bytes()
        except (FileNotFoundError, IsADirectoryError, PermissionError):
            with self._lock:
                self._forget(name)
                self.stats["misses"] += 1
            return None
        payload = _decode(data, name)
        problem = "corrupt" if payload is None else None
        if problem is None and validate is not None:
            try:
                ok = validate(payload)
            except Exception:  # a payload that does not even parse is not a valid entry
                ok = False
            problem = None if ok else "invalid"
        if problem is not None:
            _unlink(path)
            with self._lock:
                self._forget(name)
                self.stats[problem] += 1
                self.stats["misses"] += 1
            return None
        with self._lock:
            if name not in index:  # written by another process sharing the folder
                index[name] = len(data)
                self._total += len(data)
            index.move_to_end(name)
            self.stats["hits"] += 1
        try:
            os.utime(path)
        except OSError:
            pass
        return payload

    def put(self, name: str, payload: bytes) -> None:
        """Store ``payload`` as entry ``name`` atomically, then evict down to the size cap."""
        index = self._ensure_index()
        data = _encode(payload, name)
        if self.max_bytes <= 0 or len(data) > self.max_bytes:
            return
        write_bytes(self._path(name), data)  # temp file in the folder, fsync, os.replace
        with self._lock:
            self._forget(name)
            index[name] = len(data)
            self._total += len(data)
            self.stats["writes"] += 1
            victims = []
            while self._total > self.max_bytes and len(index) > 1:
                victim, size = index.popitem(last=False)
                self._total -= size
                victims.append(victim)
            self.stats["evictions"] += len(victims)
        for victim in victims:
            _unlink(self.folder / victim)

    def key_lock(self, name: str) -> "KeyLock":
        """The inter-process lock of entry ``name`` (not yet acquired)."""
        self._path(name)  # the same name rules as entries
        return KeyLock(self.folder / "locks" / f"{name}.lock")

    def delete(self, name: str) -> None:
        """Remove entry ``name`` if present."""
        self._ensure_index()
        _unlink(self._path(name))
        with self._lock:
            self._forget(name)

    def _forget(self, name: str) -> None:  # call with the lock held
        size = self._index.pop(name, None) if self._index is not None else None
        if size is not None:
            self._total -= size

    @property
    def total_bytes(self) -> int:
        self._ensure_index()
        return self._total

    def __len__(self) -> int:
        return len(self._ensure_index())

    def __contains__(self, name: str) -> bool:
        return name in self._ensure_index()

    def summary(self) -> dict:
        """Entries, bytes, cap and hit/miss counters (for /healthz).

        Never scans the folder (a liveness probe must not block on, or fail with, the disk):
        before the first cache access ``entries`` and ``bytes`` are None.
        """
        with self._lock:
            index = self._index
            return {
                "entries": None if index is None else len(index),
                "bytes": None if index is None else self._total,
                "max_bytes": self.max_bytes,
                **self.stats,
            }

    def check_folder(self) -> None:
        """Create the cache folder if needed and make sure entries can be written there.

        Raises
        ------
        ValueError
            One line naming the folder and the reason (a file in the way, no permission).
        """
        try:
            if self.folder.exists() and not self.folder.is_dir():
                raise ValueError(f"{self.folder} exists and is not a folder")
            self.folder.mkdir(parents=True, exist_ok=True)
            probe = self.folder / f".write-check.{os.getpid()}.{uuid.uuid4().hex}{_TMP_SUFFIX}"
            probe.write_bytes(b"")
            _unlink(probe)
        except OSError as exc:
            raise ValueError(f"cannot use {self.folder} as the cache folder: {exc.strerror or exc}") from None


def _unlink(path) -> None:
    try:
        os.unlink(path)
    except FileNotFoundError:
        pass
    except OSError:
        pass


class KeyLock:
    """An exclusive inter-process lock on one file (``fcntl.flock``), taken without blocking.

    :meth:`try_acquire` returns True when this process now holds it; :meth:`release` frees it.
    A crashed holder's lock is freed by the kernel with its file descriptors.

    The lock file lives only while it is held: :meth:`release` unlinks it before unlocking, so
    the ``locks/`` folder does not grow with every key ever computed. An acquirer therefore
    checks, after ``flock`` succeeds, that the path still names the inode it locked (a file it
    opened just before the holder unlinked it is stale: it retries on a fresh file). A crashed
    holder leaves its file behind; the next holder of that key removes it.
    """

    def __init__(self, path: Path) -> None:
        self.path = path
        self._fd: int | None = None

    def try_acquire(self) -> bool:
        import fcntl

        if self._fd is not None:
            return True
        self.path.parent.mkdir(parents=True, exist_ok=True)
        for _ in range(_LOCK_RETRIES):  # each retry means a holder released between open and flock
            fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:  # another process computes this key
                os.close(fd)
                return False
            except OSError:  # a folder without locks (some network mounts): say so, do not guess
                os.close(fd)
                raise
            if _names_inode(self.path, fd):
                self._fd = fd
                return True
            os.close(fd)  # we locked a file its holder had already unlinked: try the new one
        return False  # keys released and retaken this fast are held: the caller polls again

    def release(self) -> None:
        import fcntl

        if self._fd is None:
            return
        fd, self._fd = self._fd, None
        try:
            _unlink(self.path)  # while still held: nobody can take this inode after us
            fcntl.flock(fd, fcntl.LOCK_UN)
        finally:
            os.close(fd)


#: how often :meth:`KeyLock.try_acquire` retries after locking an already unlinked lock file
_LOCK_RETRIES = 8


def _names_inode(path: Path, fd: int) -> bool:
    """Whether ``path`` still refers to the open file ``fd`` (same device and inode)."""
    try:
        st = os.stat(path)
    except FileNotFoundError:  # unlinked by its holder after our open
        return False
    fst = os.fstat(fd)
    return (st.st_dev, st.st_ino) == (fst.st_dev, fst.st_ino)


class MemoryLRU:
    """Recently served, verified entries in memory, bounded in bytes (entries are immutable).

    Thread-safe; a lookup is a dict access under a lock, so the event loop serves memory hits
    without a thread hop.
    """

    def __init__(self, max_bytes: int) -> None:
        self.max_bytes = int(max_bytes)
        self._items: OrderedDict[str, bytes] = OrderedDict()
        self._total = 0
        self._lock = threading.Lock()
        self.hits = 0

    def get(self, name: str) -> bytes | None:
        with self._lock:
            data = self._items.get(name)
            if data is not None:
                self._items.move_to_end(name)
                self.hits += 1
            return data

    def put(self, name: str, data: bytes) -> None:
        if len(data) > self.max_bytes // 4:  # one huge table must not flush everything else
            return
        with self._lock:
            old = self._items.pop(name, None)
            if old is not None:
                self._total -= len(old)
            self._items[name] = data
            self._total += len(data)
            while self._total > self.max_bytes and self._items:
                _, victim = self._items.popitem(last=False)
                self._total -= len(victim)

    def discard(self, name: str) -> None:
        with self._lock:
            old = self._items.pop(name, None)
            if old is not None:
                self._total -= len(old)

    def summary(self) -> dict:
        with self._lock:
            return {"entries": len(self._items), "bytes": self._total, "max_bytes": self.max_bytes, "hits": self.hits}


class SingleFlight:
    """At most one running task per key; concurrent callers share its result.

    The task is shielded from the callers' cancellation (a client that disconnects does not
    cancel the computation others wait for). Results are not kept: once the task is done the
    key is free again, and the next call starts afresh (normally a cache hit).
    """

    def __init__(self) -> None:
        self._tasks: dict[str, asyncio.Task] = {}
        self.started = 0

    def __len__(self) -> int:
        return len(self._tasks)

    def pending(self, key: str) -> bool:
        return key in self._tasks

    async def run(self, key: str, factory: Callable[[], Awaitable[T]]) -> T:
        task = self._tasks.get(key)
        if task is None:
            task = asyncio.ensure_future(factory())
            self.started += 1
            self._tasks[key] = task
            task.add_done_callback(lambda t, key=key: self._done(key, t))
        return await asyncio.shield(task)

    def forget(self, match: Callable[[str], bool]) -> list[asyncio.Task]:
        """Drop the keys ``match`` selects (their next call starts afresh); their tasks, to cancel or not."""
        keys = [k for k in self._tasks if match(k)]
        return [self._tasks.pop(k) for k in keys]

    def _done(self, key: str, task: asyncio.Task) -> None:
        if self._tasks.get(key) is task:
            del self._tasks[key]
        if not task.cancelled():
            task.exception()  # mark retrieved: every waiter already got it
