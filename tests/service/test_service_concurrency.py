"""Service concurrency: one computation for N simultaneous requests; the event loop stays free."""

from __future__ import annotations

import asyncio
import threading
import time

import pytest

httpx = pytest.importorskip("httpx")

import service.compute  # noqa: E402
from bsdf_tab.errors import SpecError  # noqa: E402
from service.app import create_app  # noqa: E402
from service.settings import Settings  # noqa: E402
from tests.service.held import asgi_client, started  # noqa: E402


def _hold(monkeypatch, which=lambda spec: True, reporting: bool = False) -> dict:
    """tabulate that records its calls and holds those ``which`` selects until ``release`` (or 10 s):
    without a progress call (nothing can stop it early), or ``reporting`` progress every 20 ms."""
    real = service.compute.tabulate
    state = {"calls": 0, "threads": set(), "tables": [], "release": threading.Event(), "started": threading.Event(),
             "stopped": []}

    def held(spec, progress=None, **kw):
        state["calls"] += 1
        state["threads"].add(threading.current_thread().name)
        state["tables"].append(spec["table"])
        if which(spec):
            state["started"].set()
            for i in range(500):
                if state["release"].wait(0.02 if reporting else 10):
                    break
                if reporting and progress is not None:
                    try:
                        progress(i, 500)
                    except BaseException as exc:
                        state["stopped"].append(str(exc))
                        raise
        return real(spec, **kw)

    monkeypatch.setattr(service.compute, "tabulate", held)
    return state


@pytest.fixture()
def slow_tabulate(monkeypatch):
    """Every computation held until ``release``."""
    return _hold(monkeypatch)


@pytest.fixture()
def held_dfg(monkeypatch):
    """dfg tables held until ``release``; the others computed as usual."""
    return _hold(monkeypatch, lambda spec: spec["table"] == "dfg")


def test_simultaneous_requests_compute_once(tmp_path, slow_tabulate):
    app = create_app(Settings(cache_dir=tmp_path, warmup=False, workers=1))
    url = "/tables/albedo?mu=0.25,0.75&alpha=0.1,0.4,0.9"
    n = 24

    async def main():
        async with asgi_client(app) as c:
            tasks = [asyncio.create_task(c.get(url + ("&format=npz" if i % 3 == 0 else ""))) for i in range(n)]
            await started(slow_tabulate)
            await asyncio.sleep(0.2)  # every request is now waiting on the one computation
            health = (await c.get("/healthz")).json()
            slow_tabulate["release"].set()
            return health, await asyncio.gather(*tasks)

    health, responses = asyncio.run(main())
    assert health["computing"] == 1 and health["in_flight"] >= 1
    assert slow_tabulate["calls"] == 1
    assert all(r.status_code == 200 for r in responses)
    exr = {r.content for i, r in enumerate(responses) if i % 3}
    npz = {r.content for i, r in enumerate(responses) if i % 3 == 0}
    assert len(exr) == 1 and len(npz) == 1  # identical bytes for everyone
    assert {r.headers["etag"] for i, r in enumerate(responses) if i % 3} == {responses[1].headers["etag"]}
    assert all(name.startswith("bsdf-tab-compute") for name in slow_tabulate["threads"])  # off the event loop
    assert app.state.store.computations == 1


def test_health_and_cached_tables_stay_fast_while_computing(tmp_path, slow_tabulate):
    app = create_app(Settings(cache_dir=tmp_path, warmup=False, workers=1, max_concurrent=1))
    cached = "/tables/albedo?mu=0.5,1&alpha=0.5"

    async def main():
        async with asgi_client(app) as c:
            slow_tabulate["release"].set()
            assert (await c.get(cached)).status_code == 200  # now cached
            slow_tabulate["release"].clear()
            slow_tabulate["started"].clear()
            big = asyncio.create_task(c.get("/tables/albedo?mu=0.1,0.5,1&alpha=0.1,0.5"))
            other = asyncio.create_task(c.get("/tables/albedo?mu=0.2,0.6&alpha=0.3"))  # queued behind it
            await started(slow_tabulate)
            timings = []
            for _ in range(5):
                t0 = time.perf_counter()
                h = await c.get("/healthz")
                r = await c.get(cached)
                timings.append(time.perf_counter() - t0)
                assert h.status_code == 200 and r.status_code == 200
            health = h.json()
            slow_tabulate["release"].set()
            results = await asyncio.gather(big, other)
            return timings, health, results

    timings, health, results = asyncio.run(main())
    assert max(timings) < 0.5, timings  # not blocked by the computation (held for up to 10 s)
    assert health["computing"] == 1 and health["queued"] == 1
    assert [r.status_code for r in results] == [200, 200]


def test_queue_full_is_503_with_retry_after(tmp_path, slow_tabulate):
    app = create_app(Settings(cache_dir=tmp_path, warmup=False, workers=1, max_concurrent=1, max_queued=0))

    async def main():
        async with asgi_client(app) as c:
            first = asyncio.create_task(c.get("/tables/albedo?mu=0.5&alpha=0.5"))
            await started(slow_tabulate)
            busy = await c.get("/tables/albedo?mu=0.5&alpha=0.6")
            slow_tabulate["release"].set()
            return busy, await first

    busy, first = asyncio.run(main())
    assert busy.status_code == 503 and busy.headers["retry-after"] and busy.json()["error"]["code"] == "busy"
    assert first.status_code == 200


def test_a_failed_computation_reaches_every_waiter_then_is_retried(tmp_path, monkeypatch):
    calls = []
    gate = threading.Event()

    def failing(spec, **kw):
        calls.append(1)
        gate.wait(5)
        raise SpecError("axes.eta", "the integrator refused this texel")

    monkeypatch.setattr(service.compute, "tabulate", failing)
    app = create_app(Settings(cache_dir=tmp_path, warmup=False, workers=1))

    async def main():
        async with asgi_client(app) as c:
            tasks = [asyncio.create_task(c.get("/tables/albedo?mu=0.5&alpha=0.5")) for _ in range(6)]
            await asyncio.sleep(0.2)
            gate.set()
            rs = await asyncio.gather(*tasks)
            again = await c.get("/tables/albedo?mu=0.5&alpha=0.5")
            return rs, again

    rs, again = asyncio.run(main())
    assert [r.status_code for r in rs] == [400] * 6
    assert rs[0].json()["error"]["param"] == "axes.eta"
    assert len(calls) == 2 and again.status_code == 400


def test_scenes_go_through_the_same_door(tmp_path, monkeypatch):
    """POST /scenes: the same queue limit, 503 + Retry-After, slots and counters as tables (issue 12)."""
    import service.routes.scenes as scenes_route

    real = scenes_route.plan_scene
    state = {"started": threading.Event(), "release": threading.Event(), "calls": 0}

    def slow_plan(*args, **kwargs):
        state["calls"] += 1
        state["started"].set()
        state["release"].wait(10)
        return real(*args, **kwargs)

    monkeypatch.setattr(scenes_route, "plan_scene", slow_plan)
    app = create_app(Settings(cache_dir=tmp_path, warmup=False, workers=1, max_concurrent=1, max_queued=0))
    scene = {"tolerance": 0.05, "materials": [{"type": "conductor", "eta": 2.5, "k": 3.0, "alpha": 0.3}]}

    async def main():
        async with asgi_client(app) as c:
            first = asyncio.create_task(c.post("/scenes", json=scene))
            await started(state)
            health = (await c.get("/healthz")).json()
            others = [await c.post("/scenes", params={"tol": str(0.05 + i / 1000)}, json=scene) for i in range(1, 4)]
            table = await c.get("/tables/albedo?mu=0.5&alpha=0.6")
            state["release"].set()
            return health, others, table, await first, (await c.get("/healthz")).json()

    health, others, table, first, after = asyncio.run(main())
    assert health["computing"] == 1 and health["in_flight"] == 1 and health["queued"] == 0
    assert health["running"][0]["name"].endswith(".scene")
    assert all(r.status_code == 503 and r.headers["retry-after"] for r in others), [r.status_code for r in others]
    assert table.status_code == 503  # one door for tables and scenes
    assert first.status_code == 200 and state["calls"] == 1
    assert after["computations"] == 1 and after["scenes"] == 1 and after["busy"] == 4 and after["computing"] == 0


def test_a_running_job_never_holds_the_synchronous_slot(tmp_path, held_dfg):
    """Jobs compute in a lane of their own: with one synchronous slot, a table is still answered
    while a job runs (the audit: one allowed job stalled every synchronous request)."""
    app = create_app(Settings(cache_dir=tmp_path, warmup=False, workers=1, max_concurrent=1, max_compute_seconds=5))

    async def main():
        async with asgi_client(app) as c:
            job = await c.post("/jobs", json={"spec": {"table": "dfg", "axes": {"mu": [0.5], "roughness": [0.5]}}})
            await started(held_dfg)
            t0 = time.monotonic()
            table = await c.get("/tables/albedo?mu=0.5&alpha=0.6")
            took = time.monotonic() - t0
            health = (await c.get("/healthz")).json()
            held_dfg["release"].set()
            for _ in range(500):
                status = (await c.get(f"/jobs/{job.json()['id']}")).json()["status"]
                if status == "done":
                    break
                await asyncio.sleep(0.02)
            return job, table, took, health, status

    job, table, took, health, status = asyncio.run(main())
    assert job.status_code == 202, job.text
    assert table.status_code == 200 and took < 4.0, (table.status_code, took)
    assert [r["name"].endswith(".npz") for r in health["running"]] == [True]  # the job's computation
    assert health["limits"]["max_concurrent_jobs"] == 1 and status == "done"


def test_a_request_queued_past_its_limit_is_busy_and_never_runs(tmp_path, held_dfg):
    """A synchronous request whose computation is still queued when its limit passes gets 503
    busy (Retry-After) at the limit, not a time_limit once the slot frees; its computation is
    dropped unstarted."""
    app = create_app(Settings(cache_dir=tmp_path, warmup=False, workers=1, max_concurrent=1, max_compute_seconds=1))

    async def main():
        async with asgi_client(app) as c:
            first = asyncio.create_task(c.get("/tables/dfg?mu=0.5&roughness=0.5"))
            await started(held_dfg)
            t0 = time.monotonic()
            queued = await c.get("/tables/albedo?mu=0.5&alpha=0.6")
            took = time.monotonic() - t0
            held_dfg["release"].set()
            held = await first
            await asyncio.sleep(0.3)  # the slot frees; the queued computation is dropped at its start
            return queued, took, held, (await c.get("/healthz")).json()

    queued, took, held, health = asyncio.run(main())
    assert queued.status_code == 503 and queued.json()["error"]["code"] == "busy", queued.text
    assert queued.headers["retry-after"] and "compute slot" in queued.json()["error"]["message"]
    assert 0.9 < took < 3.0, took
    assert held.status_code == 503 and held.json()["error"]["code"] == "time_limit"  # it ran past its limit
    assert held_dfg["tables"] == ["dfg"]  # the queued albedo never ran
    assert health["queue_timeout"] == 1 and health["computing"] == 0 and health["running"] == []


@pytest.mark.parametrize("path", ["/tables", "/check", "/jobs", "/scenes?tol=1e-3"])
def test_a_body_that_stalls_is_408_at_the_body_timeout(tmp_path, path):
    """The audit: a client that declared a body and sent one byte held its request forever
    (uvicorn bounds the headers, not the body)."""
    app = create_app(Settings(cache_dir=tmp_path, warmup=False, workers=1, body_timeout=0.3))

    async def stalled():
        yield b"{"
        await asyncio.sleep(5)  # never reached: the service answers first
        yield b"}"

    async def main():
        async with asgi_client(app) as c:
            t0 = time.monotonic()
            r = await c.post(path, content=stalled(), headers={"content-type": "application/json"})
            return r, time.monotonic() - t0

    r, took = asyncio.run(main())
    assert r.status_code == 408 and r.json()["error"]["param"] == "body", r.text
    assert "within 0.3 s" in r.json()["error"]["message"] and r.headers["connection"] == "close"
    assert took < 2.0, took



def test_jobs_never_fill_the_synchronous_queue(tmp_path, held_dfg):
    """The review: jobs counted in the one queue, so queued jobs turned synchronous requests away
    (503 busy with the synchronous lane idle) and a job that met a full queue failed for good."""
    app = create_app(Settings(cache_dir=tmp_path, warmup=False, workers=1, max_concurrent=1, max_queued=0))

    async def main():
        async with asgi_client(app) as c:
            ids = [(await c.post("/jobs", json={"spec": {"table": "dfg", "axes": {"mu": [m], "roughness": [0.5]}}})).json()["id"]
                   for m in (0.2, 0.4, 0.6)]
            await started(held_dfg)
            table = await c.get("/tables/albedo?mu=0.5&alpha=0.6")
            statuses = [(await c.get(f"/jobs/{i}")).json()["status"] for i in ids]
            held_dfg["release"].set()
            for _ in range(500):
                done = [(await c.get(f"/jobs/{i}")).json()["status"] for i in ids]
                if all(x == "done" for x in done):
                    break
                await asyncio.sleep(0.02)
            return table, statuses, done, (await c.get("/healthz")).json()

    table, statuses, done, health = asyncio.run(main())
    assert table.status_code == 200, table.text
    assert "failed" not in statuses and done == ["done"] * 3, (statuses, done)
    assert health["busy"] == 0 and health["computing"] == 0 and health["running"] == []


def test_a_job_joining_a_request_s_computation_is_not_stopped_by_the_request_s_limit(tmp_path, monkeypatch):
    """The review: a job for the table a synchronous request was computing joined that flight and
    was killed by the request's 1 s limit. The waiters' largest limit now bounds the computation."""
    held = _hold(monkeypatch, lambda spec: spec["table"] == "dfg", reporting=True)
    app = create_app(Settings(cache_dir=tmp_path, warmup=False, workers=1, max_compute_seconds=1, job_max_seconds=60))

    async def main():
        async with asgi_client(app) as c:
            sync = asyncio.create_task(c.get("/tables/dfg?mu=0.5&roughness=0.5"))
            await started(held)
            job = (await c.post("/jobs", json={"spec": {"table": "dfg", "axes": {"mu": [0.5], "roughness": [0.5]}}})).json()
            request = await sync  # leaves at its own limit; the job still waits
            await asyncio.sleep(0.5)
            held["release"].set()
            for _ in range(500):
                status = (await c.get(f"/jobs/{job['id']}")).json()
                if status["status"] not in ("queued", "running"):
                    break
                await asyncio.sleep(0.02)
            return request, status

    request, status = asyncio.run(main())
    assert request.status_code == 503 and request.json()["error"]["code"] == "time_limit"
    assert status["status"] == "done", status
    assert held["stopped"] == [] and held["tables"] == ["dfg"]  # one computation, never stopped


def test_a_retry_after_busy_starts_afresh_and_an_abandoned_queued_table_frees_its_place(tmp_path, held_dfg):
    """The review: the retry joined the cancelled flight (503 cancelled), and an abandoned queued
    computation kept its place until a slot reached it (new requests refused)."""
    app = create_app(Settings(cache_dir=tmp_path, warmup=False, workers=1, max_concurrent=1, max_queued=1,
                              max_compute_seconds=1))

    async def main():
        async with asgi_client(app) as c:
            first = asyncio.create_task(c.get("/tables/dfg?mu=0.5&roughness=0.5"))
            await started(held_dfg)
            queued = await c.get("/tables/albedo?mu=0.5&alpha=0.6")  # queued behind dfg, leaves at 1 s
            await asyncio.sleep(0.1)  # its cancelled task unwinds on the loop's next turns
            health = (await c.get("/healthz")).json()
            other = await c.get("/tables/albedo?mu=0.4&alpha=0.6")  # admitted: the abandoned one left the queue
            held_dfg["release"].set()
            await first
            retry = await c.get("/tables/albedo?mu=0.5&alpha=0.6")
            return queued, health, other, retry

    queued, health, other, retry = asyncio.run(main())
    assert queued.status_code == 503 and queued.json()["error"]["code"] == "busy"
    assert [r["state"] for r in health["running"]] == ["running"] and health["queued"] == 0, health["running"]
    assert other.status_code == 503 and "waited 1 s for a compute slot" in other.json()["error"]["message"]
    assert retry.status_code == 200, retry.text
    assert held_dfg["tables"] == ["dfg", "albedo"]  # the abandoned ones never ran


def test_a_table_whose_waiters_left_while_it_was_looked_up_never_runs(tmp_path, monkeypatch, held_dfg):
    """The review: the last waiter left while the computation was still looking in the cache;
    it then began with no waiter, nobody cancelled it, and it ran to the end."""
    from service.cache import DiskCache
    from service.errors import ClientGone

    real_get = DiskCache.get

    def slow_get(self, name, validate=None):
        if name.endswith(".npz"):
            time.sleep(0.4)  # a busy disk
        return real_get(self, name, validate)

    monkeypatch.setattr(DiskCache, "get", slow_get)
    app = create_app(Settings(cache_dir=tmp_path, warmup=False, workers=1))

    async def main():
        store = app.state.store
        prep = store.prepare({"table": "dfg", "axes": {"mu": [0.5], "roughness": [0.5]}})

        async def gone():
            return True  # the client has left by the first poll

        with pytest.raises(ClientGone):
            await store.variant(prep, "exr", client=gone)
        await asyncio.sleep(1.5)  # past every slow lookup
        return store.health()

    health = asyncio.run(main())
    assert held_dfg["tables"] == [] and health["running"] == [] and health["computing"] == 0
    assert health["queued"] == 0 and health["in_flight"] == 0
