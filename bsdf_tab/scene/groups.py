"""The planned tables of one scene, searched at the same time, with the outcome of one after the other.

A scene's groups (one planned table each) share nothing: each has its own texel families
(kind, distribution, shadowing, Fresnel), its own search and its own texel store, so their
results do not depend on the order they run in. :func:`run_groups` runs them on a few threads
(the planner's tabulations are small, most of them tens of texels: one at a time they leave
cores idle) and gives what running them in order would give:

- the results in group order;
- the progress lines in group order: the earliest unfinished group's lines as they come, the
  others' as soon as every group before them is done (:class:`OrderedLog`);
- on failure, the exception of the earliest failing group. A failing group stops the groups
  after it (at their next tabulation: in order they would not have run), never those before it
  (one of them may fail first, in order, with its own exception);
- the pre-compute hook (``before``: the service's cost budget) is called by one thread at a
  time; it sees the same tabulations, interleaved across groups.

Warp loads a kernel module on its first launch; the first tabulation of each table kind runs
alone (``first_of_kind``), so two threads never load one module at the same time.
"""

from __future__ import annotations

import threading
from concurrent.futures import ThreadPoolExecutor
from typing import Any, Callable

__all__ = ["GroupStopped", "OrderedLog", "run_groups"]


class GroupStopped(Exception):
    """A group stopped because an earlier group failed (never seen by the caller)."""


class OrderedLog:
    """Lines of ``n`` groups passed to ``log`` in group order (see the module docstring)."""

    def __init__(self, log: Callable[[str], None], n: int):
        self.log, self.n = log, n
        self.lock = threading.Lock()
        self.current = 0
        self.buffers: list[list[str]] = [[] for _ in range(n)]
        self.done = [False] * n

    def line(self, group: int, text: str) -> None:
        with self.lock:
            if group == self.current:
                self.log(text)
            else:
                self.buffers[group].append(text)

    def finish(self, group: int) -> None:
        """Group ``group`` is done: pass on the lines of the groups that are now first."""
        with self.lock:
            self.done[group] = True
            while self.current < self.n and self.done[self.current]:
                self.current += 1
                if self.current < self.n:
                    lines, self.buffers[self.current] = self.buffers[self.current], []
                    for text in lines:
                        self.log(text)


class _Gate:
    """What the groups' threads share: the stop index, the hook's lock, the first tabulations."""

    def __init__(self, before: Callable[[dict], None] | None):
        self.before = before
        self.stop_after = None  # groups with a larger index stop at their next tabulation
        self.lock = threading.Lock()  # the hook, the stop index
        self.first = threading.Lock()  # the first tabulation of a kind runs alone
        self.kinds: set = set()

    def check(self, group: int, spec: dict) -> None:
        with self.lock:
            if self.stop_after is not None and group > self.stop_after:
                raise GroupStopped()
            if self.before is not None:
                self.before(spec)

    def failed(self, group: int) -> None:
        with self.lock:
            self.stop_after = group if self.stop_after is None else min(self.stop_after, group)

    def compute(self, kind: Any, run: Callable[[], Any]) -> Any:
        if kind not in self.kinds:
            with self.first:
                if kind not in self.kinds:  # still the first: run it alone
                    out = run()
                    self.kinds.add(kind)
                    return out
        return run()


def run_groups(tasks: list[Callable], threads: int, log: Callable[[str], None] | None,
               before: Callable[[dict], None] | None) -> list:
    """Run ``tasks`` (group order) on up to ``threads`` threads; their results in order.

    Each task is called as ``task(log, before, first_of_kind)``: ``log(line)`` its progress
    lines (None when ``log`` is None), ``before(spec)`` to call before each tabulation (it
    raises :class:`GroupStopped` once an earlier group failed, and calls the caller's hook),
    ``first_of_kind(kind, run)`` to run a tabulation (the first of each kind alone).
    ``threads`` <= 1: one after the other in the calling thread, exactly as a loop would.
    """
    if threads <= 1 or len(tasks) <= 1:
        return [task(log, before, lambda kind, run: run()) for task in tasks]
    gate = _Gate(before)
    ordered = OrderedLog(log, len(tasks)) if log is not None else None

    def one(i: int, task: Callable):
        try:
            out = task(None if ordered is None else (lambda text: ordered.line(i, text)),
                       lambda spec: gate.check(i, spec), gate.compute)
            if ordered is not None:
                ordered.finish(i)
            return out
        except BaseException:
            gate.failed(i)
            raise

    with ThreadPoolExecutor(max_workers=min(threads, len(tasks)), thread_name_prefix="bsdf-tab-plan") as pool:
        futures = [pool.submit(one, i, task) for i, task in enumerate(tasks)]
        try:
            errors = [f.exception() for f in futures]
        except BaseException:  # interrupted while waiting (Ctrl-C): stop every group
            gate.failed(-1)
            raise
    for error in errors:
        if error is not None and not isinstance(error, GroupStopped):
            raise error
    return [f.result() for f in futures]
