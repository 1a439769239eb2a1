"""bsdf_tab.scene.groups: the groups of a scene planned on several threads give what planning
them one after the other gives: the same plan (bit for bit), the same progress lines in the
same order, the same tabulations, and on failure the exception of the earliest failing group."""

from __future__ import annotations

import json
import random
import threading
import time

import pytest

import bsdf_tab.api
import bsdf_tab.scene.plan as plan_module
from bsdf_tab.io import json_default
from bsdf_tab.scene import plan_scene
from bsdf_tab.scene.groups import GroupStopped, OrderedLog, run_groups

SCENE = {
    "materials": [
        {"name": "gold", "type": "conductor", "eta": 0.18, "k": 3.42, "roughness": {"range": [0.3, 0.6]}},
        {"name": "copper", "type": "conductor", "ior": [0.27, 3.61], "roughness": 0.4},
        {"name": "plastic", "type": "schlick", "f0": 0.04, "alpha": {"range": [0.05, 0.3]}},
        {"name": "glass", "type": "dielectric", "eta": [1.5, 0.6666667], "alpha": 0.05},
    ]
}


def _run(monkeypatch, threads, tol=1e-2):
    monkeypatch.setattr(plan_module, "GROUP_THREADS", threads)
    specs, names, lines = [], set(), []
    real = bsdf_tab.api.tabulate

    def counting(spec, **kw):
        specs.append(json.dumps(spec, sort_keys=True))
        names.add(threading.current_thread().name)
        return real(spec, **kw)

    monkeypatch.setattr(bsdf_tab.api, "tabulate", counting)
    plan = plan_scene(SCENE, tol, log=lines.append)
    monkeypatch.undo()
    return plan, specs, names, lines


def test_groups_on_threads_give_the_plan_of_a_loop(monkeypatch):
    serial, s_specs, s_threads, s_lines = _run(monkeypatch, 1)
    threaded, t_specs, t_threads, t_lines = _run(monkeypatch, 4)
    assert len(serial.tables) == 4
    # the plan, bit for bit (values of every baked table included)
    dump = lambda p: json.dumps(p.to_dict(), default=json_default, sort_keys=True)  # noqa: E731
    assert dump(threaded) == dump(serial)
    for a, b in zip(serial.tables, threaded.tables):
        for ch in a.table.channels:
            assert a.table.channels[ch].tobytes() == b.table.channels[ch].tobytes()
    # the same lines in the same order, the same tabulations (in another interleaving)
    assert t_lines == s_lines and len(s_lines) > 8
    assert sorted(t_specs) == sorted(s_specs)
    counters = lambda p: (p.tabulate_calls, p.texels_computed, p.texels_requested,  # noqa: E731
                          p.candidates_certified, p.line_probes)
    assert counters(threaded) == counters(serial)
    # and the threaded run did run on several threads
    assert len(s_threads) == 1 and len({n for n in t_threads if n.startswith("bsdf-tab-plan")}) >= 2, t_threads


def test_ordered_log_keeps_group_order():
    got = []
    log = OrderedLog(got.append, 3)
    log.line(1, "b1")
    log.line(0, "a1")
    log.line(2, "c1")
    log.finish(1)  # group 1 done before group 0: its lines wait
    assert got == ["a1"]
    log.line(0, "a2")
    log.finish(0)  # 0 done: 1's lines, then 2 is first: its lines so far
    assert got == ["a1", "a2", "b1", "c1"]
    log.line(2, "c2")
    assert got[-1] == "c2"


def _task(i, seconds, fail=None, seen=None):
    def run(log, before, first_of_kind):
        for step in range(3):
            before({"group": i, "step": step})
            first_of_kind("kind", lambda: time.sleep(seconds * random.random()))
            if log is not None:
                log(f"{i}:{step}")
            if fail is not None and step == 1:
                raise fail
        return i

    return run


def test_run_groups_results_lines_and_hook_like_a_loop():
    random.seed(5)
    inside, overlaps, calls = [0], [0], []
    lock = threading.Lock()

    def hook(spec):
        with lock:
            inside[0] += 1
            overlaps[0] = max(overlaps[0], inside[0])
        time.sleep(0.002)
        calls.append((spec["group"], spec["step"]))
        with lock:
            inside[0] -= 1

    lines = []
    out = run_groups([_task(i, 0.01) for i in range(5)], 3, lines.append, hook)
    assert out == [0, 1, 2, 3, 4]
    assert lines == [f"{i}:{s}" for i in range(5) for s in range(3)]
    assert sorted(calls) == [(i, s) for i in range(5) for s in range(3)] and overlaps[0] == 1


def test_run_groups_raises_the_earliest_failure_and_stops_later_groups():
    class Boom(Exception):
        pass

    ran = []

    def hook(spec):
        ran.append(spec["group"])

    # group 3 fails at once, group 1 later (it sleeps first): a loop would raise group 1's error
    tasks = [_task(0, 0.01), _task(1, 0.05, fail=Boom("one")), _task(2, 0.01), _task(3, 0.0, fail=Boom("three")),
             _task(4, 0.2)]
    with pytest.raises(Boom, match="one"):
        run_groups(tasks, 5, None, hook)
    # group 0 (before the failures) ran to its end; group 4 stopped at its next tabulation
    assert ran.count(0) == 3 and ran.count(4) < 3


def test_group_stopped_is_never_what_the_caller_sees():
    class Boom(Exception):
        pass

    with pytest.raises(Boom):
        run_groups([_task(0, 0.0, fail=Boom()), _task(1, 0.1), _task(2, 0.1)], 3, None, None)
    assert issubclass(GroupStopped, Exception)


def test_first_tabulation_of_a_kind_runs_alone():
    state = {"inside": 0, "max": 0, "first_done": False, "before_first": 0}
    lock = threading.Lock()

    def task(i):
        def run(log, before, first_of_kind):
            def tab():
                with lock:
                    state["inside"] += 1
                    state["max"] = max(state["max"], state["inside"])
                    if not state["first_done"] and state["inside"] > 1:
                        state["before_first"] += 1
                time.sleep(0.05)
                with lock:
                    state["inside"] -= 1
                    state["first_done"] = True

            first_of_kind(("albedo", None), tab)
            first_of_kind(("albedo", None), tab)
            return i

        return run

    assert run_groups([task(i) for i in range(3)], 3, None, None) == [0, 1, 2]
    # the first one ran alone; later ones of the warmed kind overlapped
    assert state["before_first"] == 0 and state["max"] >= 2


def test_core_share_splits_the_workers_among_the_running_groups():
    share = plan_module._CoreShare(4)
    assert share.now() == 4  # no group running yet: all of them
    share.enter()
    assert share.now() == 4  # one group alone: all of them
    share.enter()
    assert share.now() == 2
    share.enter()
    assert share.now() == 1  # 4 // 3
    for _ in range(3):
        share.leave()
    assert share.running == 0 and share.now() == 4
    alone = plan_module._CoreShare(None)  # None: all cores, passed on as None when alone
    assert alone.now() is None
    alone.enter(), alone.enter()
    assert alone.now() == max(1, plan_module._cores() // 2)


def test_tabulations_use_one_worker_each_while_two_groups_run(monkeypatch):
    """Two groups on threads (two cores' worth of workers): a tabulation of 32 texels or more
    gets one worker while the other group runs, both when it runs alone; the plan is the one
    of the groups one after the other (values do not depend on the worker count)."""
    monkeypatch.setattr(plan_module, "_cores", lambda: 2)
    seen = []
    real = bsdf_tab.api.tabulate

    def recording(spec, **kw):
        texels = 1
        for v in spec["axes"].values():
            texels *= len(v)
        seen.append((texels, kw.get("workers")))
        return real(spec, **kw)

    monkeypatch.setattr(plan_module, "GROUP_THREADS", 2)
    monkeypatch.setattr(bsdf_tab.api, "tabulate", recording)
    threaded = plan_scene(SCENE, 1e-2)
    big = [w for n, w in seen if n >= plan_module.SMALL_BLOCK]
    assert all(w == 1 for n, w in seen if n < plan_module.SMALL_BLOCK)
    assert 1 in big, seen  # some while the other group ran
    assert set(big) <= {1, None}, seen  # None: all cores, a group alone
    seen.clear()
    monkeypatch.setattr(plan_module, "GROUP_THREADS", 1)
    serial = plan_scene(SCENE, 1e-2)
    assert {w for n, w in seen if n >= plan_module.SMALL_BLOCK} <= {None}, seen  # one group at a time
    dump = lambda p: json.dumps(p.to_dict(), default=json_default, sort_keys=True)  # noqa: E731
    assert dump(threaded) == dump(serial)
