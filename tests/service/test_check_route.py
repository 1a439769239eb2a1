"""``POST /check`` (service/routes/check.py): the doctor's report over HTTP, and its 4xx errors."""

from __future__ import annotations

import base64
import io

import numpy as np
import pytest

pytest.importorskip("fastapi")
from fastapi.testclient import TestClient  # noqa: E402

import bsdf_tab  # noqa: E402
from service.app import create_app  # noqa: E402
from service.routes.check import MAX_LUT_BYTES  # noqa: E402
from service.settings import Settings  # noqa: E402


@pytest.fixture(scope="module")
def client(tmp_path_factory):
    settings = Settings(cache_dir=tmp_path_factory.mktemp("svc-check"), warmup=False, max_texels=64, workers=2)
    app = create_app(settings)
    with TestClient(app) as c:
        yield c


@pytest.fixture(scope="module")
def flipped_npy() -> bytes:
    t = bsdf_tab.tabulate({"table": "dfg", "tolerance": 1e-6, "axes": {"mu": {"size": 16}, "roughness": {"size": 16}}})
    buf = io.BytesIO()
    np.save(buf, np.stack([t.channels["A"], t.channels["B"]], axis=-1)[::-1])
    return buf.getvalue()


def err(r, status, param):
    assert r.status_code == status, r.text
    body = r.json()["error"]
    assert body["param"] == param and body["message"] and "Traceback" not in r.text
    return body


def test_report(client, flipped_npy):
    r = client.post("/check?heatmap=1", content=flipped_npy, headers={"content-type": "application/octet-stream"})
    assert r.status_code == 200, r.text
    rep = r.json()
    assert (rep["table"], rep["distribution"], rep["shadowing"]) == ("dfg", "ggx", "correlated")
    assert rep["channels"] == {"0": "A", "1": "B"}
    assert rep["axes"][0]["name"] == "mu" and rep["axes"][0]["reversed"] is True
    assert any("Y flipped" in f for f in rep["findings"]) and rep["max_error"] < 1e-5
    assert base64.b64decode(rep["heatmap_png"])[:4] == b"\x89PNG"


def test_array_file_with_shape(client):
    values = ", ".join(f"{v:.6f}" for v in np.linspace(0.1, 0.9, 16))
    r = client.post("/check?name=lut.h", content=f"float lut[4][4] = {{{values}}};".encode())
    err(r, 400, "shape")
    r = client.post("/check?shape=4,x", content=b"float lut[1] = {0};")
    err(r, 400, "shape")


def test_3d_glass_table_and_its_axes(client):
    """A 3-D R + T table [ior, mu, roughness] (Cycles' z axis, written here) is identified over HTTP."""
    z = np.clip(np.arange(6) / 5, 1e-4, 0.99)
    ior = (1 + z**2) / (1 - z**2)
    u = np.arange(6) / 5
    t = bsdf_tab.tabulate({"table": "dielectric", "tolerance": 1e-6, "shadowing": "correlated",
                           "axes": {"mu": [float(x) for x in u], "roughness": [float(x) for x in u],
                                    "eta": [float(x) for x in ior]}})
    rt = np.transpose(np.asarray(t.channels["R"]) + np.asarray(t.channels["T"]), (2, 0, 1))
    buf = io.BytesIO()
    np.save(buf, rt)
    r = client.post("/check?axes=ior,mu,roughness", content=buf.getvalue())
    assert r.status_code == 200, r.text
    rep = r.json()
    assert (rep["table"], rep["quantity"], rep["eta"][:7]) == ("dielectric", "R+T", "eta > 1")
    assert [a["name"] for a in rep["axes"]] == ["ior", "mu", "roughness"] and rep["findings"] == []
    err(client.post("/check?axes=ior,mu", content=buf.getvalue()), 400, "axes")


@pytest.mark.parametrize("query,param", [("array_values=int", "array_values"), ("axes=mu", "axes"),
                                         ("axes=a,b,c,d", "axes"), ("array_name=a%3Bb", "array_name"),
                                         ("heatmap=maybe", "heatmap"), ("color=1", "color"),
                                         ("shape=%EF%BC%91,2", "shape"), ("array_name=%C3%A9", "array_name")])
def test_bad_parameters(client, flipped_npy, query, param):
    err(client.post(f"/check?{query}", content=flipped_npy), 400, param)


def test_bad_bodies(client):
    err(client.post("/check", content=b""), 400, "body")
    err(client.post("/check", content=b"\x89PNG\r\n\x1a\nbroken"), 400, "body")
    big = b"0" * (MAX_LUT_BYTES + 1)
    err(client.post("/check", content=big), 413, "body")


def test_checks_go_through_the_tables_door(tmp_path, flipped_npy, monkeypatch):
    """The audit: abandoned /check requests ran unseen in the compute slot with no admission.
    Now a check is admitted like a table (503 busy when the queue is full), listed in /healthz
    while it runs, and counted."""
    import asyncio
    import threading

    import service.routes.check as check_route
    from tests.service.held import asgi_client, started

    real = check_route.check_payload
    state = {"started": threading.Event(), "release": threading.Event(), "calls": 0}

    def held(*args, **kwargs):
        state["calls"] += 1
        state["started"].set()
        state["release"].wait(10)
        return real(*args, **kwargs)

    monkeypatch.setattr(check_route, "check_payload", held)
    app = create_app(Settings(cache_dir=tmp_path, warmup=False, workers=1, max_concurrent=1, max_queued=0))

    async def main():
        async with asgi_client(app) as c:
            first = asyncio.create_task(c.post("/check", content=flipped_npy))
            await started(state)
            health = (await c.get("/healthz")).json()
            second = await c.post("/check", content=flipped_npy)
            table = await c.get("/tables/albedo?mu=0.5&alpha=0.6")
            state["release"].set()
            return health, second, table, await first, (await c.get("/healthz")).json()

    health, second, table, first, after = asyncio.run(main())
    assert [(r["name"][:6], r["state"]) for r in health["running"]] == [("check-", "running")]
    assert health["computing"] == 1
    assert second.status_code == 503 and second.json()["error"]["code"] == "busy" and second.headers["retry-after"]
    assert table.status_code == 503  # one door for tables and checks
    assert first.status_code == 200 and first.json()["table"] == "dfg" and state["calls"] == 1
    assert after["checks"] == 2 and after["computations"] == 1 and after["computing"] == 0 and after["running"] == []
