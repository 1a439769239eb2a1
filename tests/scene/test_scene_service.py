"""POST /scenes (service/routes/scenes.py) through TestClient: the plan and its tables,
cached with an ETag, 400 naming the parameter, 413 before computing above the texel limit."""

from __future__ import annotations

import base64

import pytest
from scene_cases import TINY

from bsdf_tab import read_exr

pytest.importorskip("fastapi")
from fastapi.testclient import TestClient  # noqa: E402

from service.app import create_app  # noqa: E402
from service.settings import Settings  # noqa: E402


def test_service_post_scenes(tmp_path):
    app = create_app(Settings(cache_dir=tmp_path / "cache", warmup=False, workers=2))
    with TestClient(app) as client:
        r = client.post("/scenes", params={"tol": "2e-3"}, json=TINY)
        assert r.status_code == 200, r.text
        body = r.json()
        assert body["plan"]["bytes"] < body["plan"]["fixed_bytes"] and body["plan"]["lookup_tol"] == 2e-3
        (name, item), = body["tables"].items()
        data = base64.b64decode(item["data"])
        assert len(data) == item["bytes"]
        (tmp_path / name).write_bytes(data)
        assert "E" in read_exr(tmp_path / name).channels
        bad = client.post("/scenes", params={"tol": "2e-3"}, json={"materials": [{"type": "x", "alpha": 0.1}]})
        assert bad.status_code == 400 and bad.json()["error"]["param"] == "materials[0].type"
        for body in ([TINY], "x", None):  # not an object: the body is named, not one of its keys
            r = client.post("/scenes", params={"tol": "2e-3"}, json=body)
            assert r.status_code == 400 and r.json()["error"]["param"] == "body", r.text
        r = client.post("/scenes", params={"tol": "2e-3"}, json={"materials": "x"})
        assert r.status_code == 400 and r.json()["error"]["param"] == "materials"
        assert client.post("/scenes", params={"tol": "abc"}, json=TINY).status_code == 400
        assert client.post("/scenes", params={"bogus": "1"}, json=TINY).status_code == 400
        assert client.post("/scenes", json={"table": "albedo"}).status_code == 400
        notol = client.post("/scenes", json=TINY)
        assert notol.status_code == 400 and notol.json()["error"]["param"] == "tol"
        for tol in ("nan", "inf", "-inf", "0", "1e-9", "0.5"):
            r = client.post("/scenes", params={"tol": tol}, json=TINY)
            assert r.status_code == 400 and r.json()["error"]["param"] == "tol", (tol, r.text)


def test_service_scene_above_the_texel_limit_is_413_before_computing(tmp_path, monkeypatch):
    import bsdf_tab.api

    computed = []
    real = bsdf_tab.api.tabulate
    monkeypatch.setattr(bsdf_tab.api, "tabulate", lambda spec, **kw: computed.append(spec) or real(spec, **kw))
    # a range of roughness needs more than 3 texels along mu x alpha: every candidate is too big
    scene = {"materials": [{"name": "m", "type": "conductor", "eta": 2.5, "k": 3.0, "alpha": {"range": [0.2, 0.6]}}]}
    with TestClient(create_app(Settings(cache_dir=tmp_path / "cache", warmup=False, workers=1, max_texels=3))) as client:
        r = client.post("/scenes", params={"tol": "1e-3"}, json=scene)
    assert r.status_code == 413, r.text
    err = r.json()["error"]
    assert err["param"] == "tol" and err["allowed"] == {"max_texels": 3} and "3 texels" in err["message"]
    assert computed == []  # skipped before anything was tabulated


def test_service_scene_answers_are_cached_with_etag(tmp_path, monkeypatch):
    import service.routes.scenes as scenes_route

    calls = []
    real = scenes_route.plan_scene

    def counting(*args, **kwargs):
        calls.append(1)
        return real(*args, **kwargs)

    monkeypatch.setattr(scenes_route, "plan_scene", counting)
    app = create_app(Settings(cache_dir=tmp_path / "cache", warmup=False, workers=2))
    with TestClient(app) as client:
        first = client.post("/scenes", params={"tol": "2e-3"}, json=TINY)
        assert first.status_code == 200 and len(calls) == 1
        etag = first.headers["etag"]
        # the same scene spelled differently (key order, explicit defaults) is the same entry
        respelled = {"materials": [{"alpha": 0.3, "k": 3.0, "eta": 2.5, "type": "conductor", "name": "steel",
                                    "shadowing": "correlated", "distribution": "ggx"}]}
        again = client.post("/scenes", params={"tol": "2e-3"}, json=respelled)
        assert again.status_code == 200 and again.content == first.content and len(calls) == 1
        assert again.headers["etag"] == etag
        not_modified = client.post("/scenes", params={"tol": "2e-3"}, json=TINY, headers={"If-None-Match": etag})
        assert not_modified.status_code == 304 and not not_modified.content and len(calls) == 1
        other_tol = client.post("/scenes", params={"tol": "3e-3"}, json=TINY)
        assert other_tol.status_code == 200 and other_tol.headers["etag"] != etag and len(calls) == 2
    # a new app on the same cache folder serves the stored answer without planning
    with TestClient(create_app(Settings(cache_dir=tmp_path / "cache", warmup=False, workers=2))) as client:
        assert client.post("/scenes", params={"tol": "2e-3"}, json=TINY).content == first.content
    assert len(calls) == 2


def test_service_scene_cost_guard_stops_at_the_predicted_limit(tmp_path, monkeypatch):
    """The cost model prices every tabulation before it runs (service.scenes.SceneBudget): the
    one that would take the predicted total above max_cost_seconds is refused (413 too_costly,
    param tol), and the tabulations that did run stay within the limit."""
    import bsdf_tab.api
    from bsdf_tab.cost import estimate

    computed = []
    real = bsdf_tab.api.tabulate
    monkeypatch.setattr(bsdf_tab.api, "tabulate", lambda spec, **kw: computed.append(spec) or real(spec, **kw))
    scene = {"materials": [{"name": "m", "type": "conductor", "eta": 2.5, "k": 3.0, "alpha": {"range": [0.2, 0.6]}}]}
    limit = 0.05  # below the 1e-3 plan's predicted cost (0.082 core-s since issue 14 round 7), above the 3e-2 one's (0.0025)
    settings = Settings(cache_dir=tmp_path / "cache", warmup=False, workers=1, max_cost_seconds=limit)
    with TestClient(create_app(settings)) as client:
        r = client.post("/scenes", params={"tol": "1e-3"}, json=scene)
        assert r.status_code == 413, r.text[:300]
        err = r.json()["error"]
        assert err["code"] == "too_costly" and err["param"] == "tol" and err["allowed"]["max_cost_seconds"] == limit
        assert computed, "the guard stopped a running plan, not only refused it up front"
        predicted = sum(estimate(s).seconds for s in computed)
        assert predicted <= limit, predicted
        # the same scene at a looser tolerance is within the limit and planned
        computed.clear()
        ok = client.post("/scenes", params={"tol": "3e-2"}, json=scene)
        assert ok.status_code == 200, ok.text[:300]
        assert sum(estimate(s).seconds for s in computed) <= limit


def test_scene_budget_refuses_exactly_the_tabulation_that_exceeds_the_limit():
    from bsdf_tab.cost import CostLimitError, estimate
    from service.scenes import SceneBudget

    specs = [{"table": "dfg", "axes": {"mu": {"size": n}, "alpha": [0.3]}, "tolerance": 5e-5} for n in (3, 5, 9, 17, 33)]
    costs = [estimate(s).seconds for s in specs]
    limit = sum(costs[:3]) + 0.5 * costs[3]  # the fourth would exceed it
    budget = SceneBudget(limit, tol=1e-3)
    for s in specs[:3]:
        budget(s)
    with pytest.raises(CostLimitError) as info:
        budget(specs[3])
    assert info.value.param == "tol" and info.value.limit == limit and "tol=0.001" in info.value.message
    assert budget.tabulations == 3 and abs(budget.spent - sum(costs[:3])) <= 1e-12
