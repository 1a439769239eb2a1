"""PTX compiles in a background process, so that they overlap the rest of the suite.

The CUDA compile check (test_integrate_cuda_compile.py) compiles every kernel module of the
package to PTX with NVRTC: about 100 s of one core, while most of the suite leaves the second
core idle. tests/conftest.py starts one worker process (this file run as a script) right after
collection, with the modules the selected tests need, and the tests collect its results.

Worker: ``python3 ptx_background.py OUT_DIR MODULE [MODULE ...]``. For each module in turn it
writes ``OUT_DIR/MODULE.start`` (when it began), compiles the module as defined (its own
options: the source a first GPU run compiles) with ``wp.compile_aot_module(arch=90,
use_ptx=True)`` into ``OUT_DIR/MODULE/`` and writes ``OUT_DIR/MODULE.json``: ``ok``, the
artifact ``paths`` or the ``error`` (traceback), the compiler's own output ``log`` (NVRTC
prints its diagnostics on file descriptor 2, not in the exception) and its CPU ``seconds``.
It runs at a lower priority, so that it takes only what the foreground tests leave.

Parent (``BackgroundCompiles``): ``result(name)`` waits for a module's result, bounded. A worker
that died while compiling a module (a crash: no ``.json`` after its ``.start``) fails that
module with the exit status and the output so far, and a new worker goes on with the rest; a
module that runs longer than ``module_timeout`` seconds of waiting (the time the waiting test
spends, not the time the worker was starved by the foreground) gets its worker killed by PID and
fails with a timeout. ``stop()`` kills the worker by its PID (its own process group).
"""

from __future__ import annotations

import importlib
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import traceback
from pathlib import Path

LOG_TAIL = 8000  # characters of the compiler's output kept in a result
MODULE_TIMEOUT = float(os.environ.get("BSDF_TAB_PTX_TIMEOUT", "300"))  # s of waiting per module


# ---------------------------------------------------------------- worker (a separate process)

def _write_json(path: Path, data: dict) -> None:
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(json.dumps(data), encoding="utf-8")
    os.replace(tmp, path)  # the parent never reads half a file


def _compile_one(name: str, out: Path) -> dict:
    import warp as wp

    log = out / f"{name}.log"
    fd = os.open(log, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
    sys.stdout.flush()
    sys.stderr.flush()
    saved = os.dup(1), os.dup(2)
    os.dup2(fd, 1)  # native code (NVRTC's log) writes to the descriptors, not to sys.stderr
    os.dup2(fd, 2)
    t0 = time.process_time()
    try:
        module = importlib.import_module(name)
        paths = wp.compile_aot_module(module, arch=90, use_ptx=True, module_dir=out / name)
        result = {"ok": True, "paths": [str(p) for p in paths]}
    except Exception:
        result = {"ok": False, "error": traceback.format_exc()}
    finally:
        sys.stdout.flush()
        sys.stderr.flush()
        os.dup2(saved[0], 1)
        os.dup2(saved[1], 2)
        for f in (fd, *saved):
            os.close(f)
    result["seconds"] = time.process_time() - t0
    result["log"] = log.read_text(encoding="utf-8", errors="replace")[-LOG_TAIL:]
    return result


def worker_main(argv: list[str]) -> int:
    if len(argv) < 2:
        print("usage: ptx_background.py OUT_DIR MODULE [MODULE ...]", file=sys.stderr)
        return 2
    out = Path(argv[0])
    try:
        os.nice(10)
    except (AttributeError, OSError):  # no nice() here: run at normal priority
        pass
    import warp as wp

    wp.config.quiet = True
    wp.init()  # its banner and warnings go to the worker's own output, not a module's log
    parent = os.getppid()
    for name in argv[1:]:
        if os.getppid() != parent:  # the test session is gone (killed): no one reads the rest
            return 3
        _write_json(out / f"{name}.start", {"pid": os.getpid(), "time": time.time()})
        _write_json(out / f"{name}.json", _compile_one(name, out))
    return 0


# ---------------------------------------------------------------- parent (the pytest process)

def _tail(path: Path, n: int = LOG_TAIL) -> str:
    try:
        return path.read_text(encoding="utf-8", errors="replace")[-n:]
    except OSError:
        return ""


class BackgroundCompiles:
    """One worker at a time, compiling the queued modules in order; results on disk."""

    def __init__(self, names=(), *, module_timeout: float = MODULE_TIMEOUT, env: dict | None = None,
                 out_dir: Path | None = None, poll: float = 0.1):
        self.out = Path(out_dir) if out_dir is not None else Path(tempfile.mkdtemp(prefix="bsdf-tab-ptx-"))
        self._own_dir = out_dir is None
        self.module_timeout = module_timeout
        self.env = env
        self.poll = poll
        self.queue: list[str] = []
        self.proc: subprocess.Popen | None = None
        self.pids: list[int] = []  # every worker started (for tests of this class)
        self._stderr = None
        self._given: list[str] = []
        self._n = 0
        self.add(names)

    # -- files
    def _read(self, name: str, suffix: str) -> dict | None:
        try:
            return json.loads((self.out / f"{name}{suffix}").read_text(encoding="utf-8"))
        except (OSError, ValueError):
            return None

    def _done(self, name: str) -> bool:
        return (self.out / f"{name}.json").exists()

    def _started(self, name: str) -> bool:
        return (self.out / f"{name}.start").exists()

    def _current(self) -> str | None:
        """The module the worker is compiling (begun, no result yet)."""
        return next((n for n in self.queue if self._started(n) and not self._done(n)), None)

    def _fail(self, name: str, error: str, log: str = "") -> None:
        _write_json(self.out / f"{name}.json", {"ok": False, "error": error, "log": log, "paths": []})

    # -- the worker
    def add(self, names) -> None:
        self.queue.extend(n for n in names if n not in self.queue)

    def start(self) -> None:
        """Start a worker for the queued modules not begun yet (if none is running)."""
        if self.proc is not None and self.proc.poll() is None:
            return
        todo = [n for n in self.queue if not self._started(n)]
        if not todo:
            return
        self._n += 1
        self._given = todo
        err = self.out / f"worker{self._n}.stderr"
        self._stderr = err
        # NVRTC leaves a precompiled header (~80 MB) under TMPDIR per process: keep it in ours
        tmp = self.out / "tmp"
        tmp.mkdir(exist_ok=True)
        env = dict(os.environ if self.env is None else self.env, TMPDIR=str(tmp))
        with open(err, "wb") as f:
            self.proc = subprocess.Popen(
                [sys.executable, str(Path(__file__).resolve()), str(self.out), *todo],
                stdin=subprocess.DEVNULL, stdout=f, stderr=subprocess.STDOUT,
                env=env, start_new_session=True)  # its own group: stop() reaches all of it
        self.pids.append(self.proc.pid)

    def _kill(self) -> None:
        proc, self.proc = self.proc, None
        if proc is None:
            return
        if proc.poll() is None:
            try:
                os.killpg(proc.pid, signal.SIGKILL)  # the group led by this worker's PID
            except (ProcessLookupError, PermissionError):
                proc.kill()
        try:
            proc.wait(timeout=30)
        except subprocess.TimeoutExpired:  # unkillable (D state): leave it, do not hang here
            pass

    def result(self, name: str) -> dict:
        """The result of ``name`` (queued and started if needed); never waits unbounded."""
        self.add([name])
        waiting_since = time.monotonic()
        while True:
            r = self._read(name, ".json")
            if r is not None:
                return r
            if self.proc is None:
                self.start()
                if self.proc is None:  # nothing left to start yet no result: cannot happen
                    self._fail(name, "the background compile never started this module")
                continue
            rc = self.proc.poll()
            if rc is not None:
                current = self._current()
                if current is not None:  # died in a module: that module fails, the rest go on
                    self._fail(current, f"the PTX worker (PID {self.proc.pid}) exited with status {rc} "
                                        f"while compiling {current}",
                               _tail(self.out / f"{current}.log") + _tail(self._stderr))
                else:  # stopped between modules (e.g. at start-up): what it never began fails
                    for n in self._given:
                        if not self._started(n):
                            self._fail(n, f"the PTX worker (PID {self.proc.pid}) exited with status {rc} "
                                          f"before compiling {n}", _tail(self._stderr))
                self.proc = None
                continue
            current = self._current()
            if current is not None:
                began = (self._read(current, ".start") or {}).get("time", time.time())
                # time counts from when this wait began or the module began, whichever is later:
                # the worker runs at low priority and may be starved while the foreground runs
                waited = time.monotonic() - waiting_since
                elapsed = min(waited, time.time() - began)
                if elapsed > self.module_timeout:
                    pid = self.proc.pid
                    self._kill()
                    self._fail(current, f"the PTX compile of {current} ran over {self.module_timeout:g} s; "
                                        f"its worker (PID {pid}) was killed",
                               _tail(self.out / f"{current}.log"))
                    waiting_since = time.monotonic()  # the next module gets its own time
                    continue
            time.sleep(self.poll)

    def stop(self) -> None:
        """Kill the worker (by PID) and remove its files (all of them if the directory is ours)."""
        self._kill()
        shutil.rmtree(self.out / "tmp", ignore_errors=True)  # NVRTC's header, in any case
        if self._own_dir:
            shutil.rmtree(self.out, ignore_errors=True)


def failure_message(name: str, result: dict) -> str:
    """What a failed result says: the error, then the compiler's output."""
    log = (result.get("log") or "").strip()
    return f"{name} does not compile to PTX:\n{result.get('error', '')}" + (f"\ncompiler output:\n{log}" if log else "")


if __name__ == "__main__":
    sys.exit(worker_main(sys.argv[1:]))
