"""Jobs for big work: records in SQLite (WAL) in the cache folder, run in the background.

A job is a table spec or a scene (``{"spec": {...}}`` or ``{"scene": {...}, "tol": x}``),
validated and priced like a synchronous request but against ``max_job_cost_seconds``. Its id is
derived from the cache entry it produces, so an identical job already known gets the same id.

Records (table ``jobs`` in ``<cache folder>/jobs.sqlite3``, the standard library's ``sqlite3``
in WAL mode, so replicas on one folder share them): ``id, kind, request, entry, result, status
(queued | running | done | failed | cancelled), done, total, predicted_seconds, created,
started, finished, error, owner`` (``host:pid`` of the process running it).

Restarts: at start-up, and whenever a record is read, a job ``queued`` or ``running`` whose owner
process on this host no longer exists is taken over and run again (a computation is
deterministic and its finished tables are cached, so "resumed" means: computed, or found).
A job is therefore never lost and never left ``running`` by a dead process. A job of another
host whose owner died stays as it is until a process on that host starts (documented limit).

Cancellation: ``DELETE /jobs/{id}`` marks the record ``cancelled``; the owner (this process or
a replica, which sees the record change within a second) stops waiting, and the computation,
with no waiter left, stops between chunks.
"""

from __future__ import annotations

import asyncio
import hashlib
import json
import logging
import os
import socket
import sqlite3
import threading
import time
from pathlib import Path

from .compute import Prepared, TableStore
from .errors import ServiceError
from .scenes import parse_scene_request, parse_tol, scene_plan_bytes

__all__ = ["JobDB", "Jobs", "STATUSES"]

log = logging.getLogger("bsdf_tab.service")

STATUSES = ("queued", "running", "done", "failed", "cancelled")
#: seconds between two progress writes / looks at the record while a job runs
TICK_SECONDS = 0.5

_SCHEMA = """
CREATE TABLE IF NOT EXISTS jobs (
    id TEXT PRIMARY KEY, kind TEXT NOT NULL, request TEXT NOT NULL, entry TEXT NOT NULL,
    result TEXT NOT NULL, status TEXT NOT NULL, done INTEGER NOT NULL DEFAULT 0,
    total INTEGER NOT NULL DEFAULT 0, predicted_seconds REAL, created REAL NOT NULL,
    started REAL, finished REAL, error TEXT, owner TEXT
)
"""


def _owner() -> str:
    return f"{socket.gethostname()}:{os.getpid()}"


def _owner_dead(owner: str | None) -> bool:
    """True when ``owner`` is a process of this host that no longer exists (None: nobody runs it)."""
    if not owner:
        return True
    host, _, pid = owner.rpartition(":")
    if host != socket.gethostname() or not pid.isdigit():
        return False  # another host's process: not ours to judge
    try:
        os.kill(int(pid), 0)
    except ProcessLookupError:
        return True
    except PermissionError:  # exists, another user's
        return False
    return False


class JobDB:
    """The job records: one SQLite file, WAL mode, one connection guarded by a lock."""

    def __init__(self, folder: os.PathLike | str) -> None:
        self.path = Path(folder) / "jobs.sqlite3"
        self._conn: sqlite3.Connection | None = None
        self._lock = threading.Lock()

    def _db(self) -> sqlite3.Connection:
        if self._conn is None:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            conn = sqlite3.connect(self.path, timeout=10, isolation_level=None, check_same_thread=False)
            conn.row_factory = sqlite3.Row
            conn.execute("PRAGMA journal_mode=WAL")  # readers never block the writer; replicas share it
            conn.execute("PRAGMA synchronous=NORMAL")
            conn.execute(_SCHEMA)
            self._conn = conn
        return self._conn

    def _run(self, sql: str, args=()) -> list[dict]:
        with self._lock:
            cur = self._db().execute(sql, args)
            return [dict(r) for r in cur.fetchall()]

    def get(self, job_id: str) -> dict | None:
        rows = self._run("SELECT * FROM jobs WHERE id = ?", (job_id,))
        return rows[0] if rows else None

    def submit(self, job_id: str, kind: str, request: dict, entry: str, result: str, predicted: float) -> bool:
        """Insert a new job (queued); restart a failed or cancelled one. True when it must be run."""
        now = time.time()
        with self._lock:
            db = self._db()
            db.execute("BEGIN IMMEDIATE")  # one writer decides, across replicas
            try:
                row = db.execute("SELECT status FROM jobs WHERE id = ?", (job_id,)).fetchone()
                if row is None:
                    db.execute(
                        "INSERT INTO jobs (id, kind, request, entry, result, status, predicted_seconds, created)"
                        " VALUES (?, ?, ?, ?, ?, 'queued', ?, ?)",
                        (job_id, kind, json.dumps(request), entry, result, predicted, now))
                    fresh = True
                elif row["status"] in ("failed", "cancelled"):
                    db.execute("UPDATE jobs SET status = 'queued', error = NULL, done = 0, total = 0, owner = NULL,"
                               " started = NULL, finished = NULL WHERE id = ?", (job_id,))
                    fresh = True
                else:
                    fresh = False
                db.execute("COMMIT")
            except BaseException:
                db.execute("ROLLBACK")
                raise
        return fresh

    def claim(self, job_id: str, owner: str) -> bool:
        """Take a queued job, or one whose owner died; True when this process now runs it."""
        row = self.get(job_id)
        if row is None:
            return False
        if row["status"] == "running" and not _owner_dead(row["owner"]):
            return False
        if row["status"] not in ("queued", "running"):
            return False
        with self._lock:
            cur = self._db().execute(
                "UPDATE jobs SET status = 'running', owner = ?, started = ? WHERE id = ? AND status = ?"
                " AND (owner IS ? OR owner IS NULL)",
                (owner, time.time(), job_id, row["status"], row["owner"]))
            return cur.rowcount == 1

    def progress(self, job_id: str, done: int, total: int) -> None:
        self._run("UPDATE jobs SET done = ?, total = ? WHERE id = ? AND status = 'running'", (done, total, job_id))

    def finish(self, job_id: str, status: str, error: str | None = None) -> None:
        self._run("UPDATE jobs SET status = ?, error = ?, finished = ? WHERE id = ? AND status IN ('queued', 'running')",
                  (status, error, time.time(), job_id))

    def cancel(self, job_id: str) -> dict | None:
        self.finish(job_id, "cancelled", "cancelled by DELETE")
        return self.get(job_id)

    def orphans(self) -> list[dict]:
        rows = self._run("SELECT * FROM jobs WHERE status IN ('queued', 'running')")
        return [r for r in rows if _owner_dead(r["owner"]) or r["status"] == "queued"]

    def close(self) -> None:
        with self._lock:
            if self._conn is not None:
                self._conn.close()
                self._conn = None


class Jobs:
    """Submits, runs, reports and cancels jobs for one service process."""

    def __init__(self, store: TableStore) -> None:
        self.store = store
        self.settings = store.settings
        self.db = JobDB(self.settings.cache_dir)
        self.owner = _owner()
        self.tasks: dict[str, asyncio.Task] = {}
        self.counters = {"submitted": 0, "run": 0, "done": 0, "failed": 0, "cancelled": 0, "resumed": 0}

    # ------------------------------------------------------------------ requests

    def parse(self, body) -> tuple[str, str, dict, object]:
        """(id, kind, request, prepared) of a job body; 400 naming the parameter, 413 over the job limit."""
        if not isinstance(body, dict):
            raise ServiceError(400, "invalid_body", "the body must be a JSON object with 'spec' or 'scene'", param="body")
        unknown = sorted(set(body) - {"spec", "scene", "tol"})
        if unknown:
            raise ServiceError(400, "invalid_body", f"unknown key {unknown[0][:40]!r}", param=f"body.{unknown[0][:40]}",
                               allowed=["spec", "scene", "tol"])
        if ("spec" in body) == ("scene" in body):
            raise ServiceError(400, "invalid_body", "give exactly one of 'spec' and 'scene'", param="body",
                               allowed=["spec", "scene"])
        if "spec" in body:
            if "tol" in body:
                raise ServiceError(400, "invalid_body", "'tol' belongs to scene jobs (a spec has 'tolerance')",
                                   param="body.tol")
            if not isinstance(body["spec"], dict):
                raise ServiceError(400, "invalid_body", f"'spec' must be a JSON object, got {type(body['spec']).__name__}",
                                   param="spec")
            prep = self.store.prepare(body["spec"], max_cost=self.settings.max_job_cost_seconds)
            return _job_id("table", prep.key), "table", {"spec": prep.nspec}, prep
        if not isinstance(body["scene"], dict):
            raise ServiceError(400, "invalid_body", f"'scene' must be a JSON object, got {type(body['scene']).__name__}",
                               param="scene")
        tol = parse_tol(body.get("tol"), "tol")
        _parsed, name = parse_scene_request(body["scene"], tol)
        return _job_id("scene", name), "scene", {"scene": body["scene"], "tol": tol}, name

    async def submit(self, body) -> dict:
        job_id, kind, request, prepared = self.parse(body)
        if kind == "table":
            entry, result = prepared.key, f"/tables/by-key/{prepared.key}"
            predicted = prepared.cost.wall_seconds(self.settings.workers) if prepared.cost else None
        else:
            entry, result, predicted = prepared, f"/scenes/by-key/{prepared}", None
        loop = asyncio.get_running_loop()
        fresh = await loop.run_in_executor(self.store.io_pool, self.db.submit, job_id, kind, request, entry, result,
                                           predicted)
        if fresh:
            self.counters["submitted"] += 1
        self._start(job_id, kind, request, prepared)
        return await self.view(job_id)

    async def view(self, job_id: str) -> dict:
        """The public record of a job (404 if unknown); takes over a job whose owner died."""
        row = self._get(job_id)
        if row["status"] in ("queued", "running") and job_id not in self.tasks and _owner_dead(row["owner"]):
            self._resume(row)
            row = self._get(job_id)
        return _public(row)

    async def cancel(self, job_id: str) -> dict:
        row = self._get(job_id)
        if row["status"] in ("queued", "running"):
            self.db.cancel(job_id)
            task = self.tasks.get(job_id)
            if task is not None:
                task.cancel()
        return _public(self._get(job_id))

    def recover(self) -> int:
        """Run again the jobs a dead process left queued or running (at start-up)."""
        n = 0
        for row in self.db.orphans():
            if self._resume(row):
                n += 1
        return n

    def health(self) -> dict:
        return {**self.counters, "running_here": len(self.tasks)}

    async def shutdown(self) -> None:
        for task in list(self.tasks.values()):
            task.cancel()
        self.db.close()

    # ------------------------------------------------------------------ internals

    def _get(self, job_id: str) -> dict:
        if not (isinstance(job_id, str) and len(job_id) == 32 and all(c in "0123456789abcdef" for c in job_id)):
            raise ServiceError(404, "unknown_job", f"not a job id: {str(job_id)[:40]!r}", param="id")
        row = self.db.get(job_id)
        if row is None:
            raise ServiceError(404, "unknown_job", "no such job", param="id")
        return row

    def _resume(self, row: dict) -> bool:
        request = json.loads(row["request"])
        try:
            if row["kind"] == "table":
                prepared = self.store.prepare(request["spec"], max_cost=float("inf"))  # accepted when submitted
            else:
                prepared = parse_scene_request(request["scene"], request.get("tol"))[1]
        except Exception as exc:  # a record this release cannot read: failed, not left running
            self.db.finish(row["id"], "failed", f"cannot resume: {type(exc).__name__}: {exc}")
            return False
        self.counters["resumed"] += 1
        return self._start(row["id"], row["kind"], request, prepared)

    def _start(self, job_id: str, kind: str, request: dict, prepared) -> bool:
        if job_id in self.tasks:
            return False
        if not self.db.claim(job_id, self.owner):
            return False  # done already, or a live replica runs it
        task = asyncio.get_running_loop().create_task(self._run(job_id, kind, request, prepared))
        self.tasks[job_id] = task
        task.add_done_callback(lambda _t, job_id=job_id: self.tasks.pop(job_id, None))
        self.counters["run"] += 1
        return True

    async def _run(self, job_id: str, kind: str, request: dict, prepared) -> None:
        store = self.store
        if kind == "table":
            key = prepared.key
            work = store.master(prepared, limit_seconds=self.settings.job_max_seconds, lane="job")
        else:
            key = prepared
            settings = self.settings
            work = store.run_scene(prepared, lambda cp: scene_plan_bytes(request["scene"], request.get("tol"), settings, cp,
                                                                          max_cost=settings.max_job_cost_seconds,
                                                                          **store.cluster()),
                                   limit_seconds=self.settings.job_max_seconds, lane="job")
        task = asyncio.ensure_future(work)
        try:
            while True:
                done, _ = await asyncio.wait({task}, timeout=TICK_SECONDS)
                if done:
                    break
                progress = store.progress_of(key)
                if progress is not None:
                    self.db.progress(job_id, progress["done"], progress["total"])
                row = self.db.get(job_id)
                if row is None or row["status"] != "running":  # cancelled here or by a replica
                    task.cancel()
                    self.counters["cancelled"] += 1
                    return
            task.result()
            row = self.db.get(job_id)
            if kind == "table" and row is not None:
                self.db.progress(job_id, max(row["total"], prepared.texels), max(row["total"], prepared.texels))
            self.db.finish(job_id, "done")
            self.counters["done"] += 1
        except asyncio.CancelledError:
            task.cancel()
            self.counters["cancelled"] += 1
            raise
        except ServiceError as exc:
            status = "cancelled" if exc.code == "cancelled" else "failed"
            self.db.finish(job_id, status, exc.message)
            self.counters["failed" if status == "failed" else "cancelled"] += 1
        except Exception as exc:  # a failed computation is the job's result, reported, not raised
            log.warning("job %s failed: %s: %s", job_id, type(exc).__name__, exc)
            self.db.finish(job_id, "failed", f"{type(exc).__name__}: {exc}"[:500])
            self.counters["failed"] += 1


def _job_id(kind: str, entry: str) -> str:
    return hashlib.sha256(f"{kind}:{entry}".encode()).hexdigest()[:32]


def _public(row: dict) -> dict:
    """The record as ``GET /jobs/{id}`` shows it."""
    now = time.time()
    done, total = int(row["done"] or 0), int(row["total"] or 0)
    eta = None
    if row["status"] == "running":
        elapsed = now - (row["started"] or now)
        if 0 < done < total:
            eta = round(elapsed * (total - done) / done, 1)
        elif row["predicted_seconds"] is not None:
            eta = round(max(0.0, row["predicted_seconds"] - elapsed), 1)
    elif row["status"] == "queued" and row["predicted_seconds"] is not None:
        eta = round(row["predicted_seconds"], 1)
    elif row["status"] == "done":
        eta = 0.0
    return {
        "id": row["id"],
        "kind": row["kind"],
        "status": row["status"],
        "progress": {"done": done, "total": total},
        "eta_seconds": eta,
        "result": row["result"] if row["status"] == "done" else None,
        "error": row["error"],
        "created": row["created"],
        "started": row["started"],
        "finished": row["finished"],
    }
