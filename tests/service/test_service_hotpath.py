"""The hot path (service/hotpath.py): a repeated GET is answered from memory with the route's exact answer."""

from __future__ import annotations

import pytest

pytest.importorskip("fastapi")
from fastapi.testclient import TestClient  # noqa: E402

from service.app import create_app  # noqa: E402
from service.settings import Settings  # noqa: E402

URL = "/tables/albedo?mu=0.2,0.7&alpha=0.3,0.5"


def test_repeated_gets_are_served_by_the_hot_path_identically(tmp_path):
    with TestClient(create_app(Settings(cache_dir=tmp_path, warmup=False, workers=1))) as client:
        first = client.get(URL)
        assert first.status_code == 200
        assert client.get("/healthz").json()["hot_path"]["hits"] == 0
        second = client.get(URL)
        assert client.get("/healthz").json()["hot_path"]["hits"] == 1
        assert second.status_code == 200 and second.content == first.content
        assert list(second.headers.items()) == list(first.headers.items())
        # Accept is part of the request's identity (Vary: Accept)
        as_json = client.get(URL, headers={"Accept": "application/json"})
        assert as_json.headers["content-type"] == "application/json"
        assert client.get(URL, headers={"Accept": "application/json"}).content == as_json.content
        # conditional requests stay with the route (304), and HEAD too
        assert client.get(URL, headers={"If-None-Match": first.headers["etag"]}).status_code == 304
        assert client.head(URL).status_code == 200
        # a bad query is never remembered
        assert client.get(URL + "&mu_size=3").status_code == 400
        assert client.get(URL + "&mu_size=3").status_code == 400
        assert client.get("/healthz").json()["hot_path"]["hits"] == 2


def test_evicted_bytes_fall_through_to_the_route(tmp_path):
    settings = Settings(cache_dir=tmp_path, warmup=False, workers=1, memory_cache_bytes=0)
    with TestClient(create_app(settings)) as client:
        first = client.get(URL)
        again = client.get(URL)
        assert again.content == first.content
        assert client.get("/healthz").json()["hot_path"]["hits"] == 0  # nothing in memory: the disk entry


def test_several_accept_lines_are_one_header_and_never_file_an_answer_under_another(tmp_path):
    """The audit's poisoning: two Accept lines, the route reading the first and the hot path the
    last, filed a JSON answer under ``Accept: image/x-exr``; later EXR requests got JSON."""
    exr = "image/x-exr"
    with TestClient(create_app(Settings(cache_dir=tmp_path, warmup=False, workers=1))) as client:
        both = client.get(URL, headers=[("Accept", "application/json"), ("Accept", exr)])
        # combined as RFC 9110 combines field lines: "application/json, image/x-exr", the first of equal q
        assert both.status_code == 200 and both.headers["content-type"] == "application/json"
        later = client.get(URL, headers={"Accept": exr})
        assert later.headers["content-type"] == exr and later.content[:4] == b"v/1\x01"
        again = client.get(URL, headers={"Accept": exr})
        assert again.headers["content-type"] == exr and again.content == later.content
        # q-values across lines: the second line's higher q wins, as within one line
        weighted = client.get(URL, headers=[("Accept", "application/json;q=0.5"), ("Accept", exr)])
        assert weighted.headers["content-type"] == exr
        assert client.get("/healthz").json()["hot_path"]["hits"] == 1  # only the repeated single-line request
