"""The service on a cluster (BSDF_TAB_SCHEDULER): the same tables, and a 503 naming an unreachable scheduler."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("distributed")
from fastapi.testclient import TestClient  # noqa: E402

import bsdf_tab  # noqa: E402
from bsdf_tab.table import Table  # noqa: E402
from service.app import create_app  # noqa: E402
from service.settings import Settings  # noqa: E402

Q = "mu=0.25,0.5,1&alpha=0.2,0.6&eta=0.7,1.5"


def test_unreachable_scheduler_is_a_503_naming_it(tmp_path):
    app = create_app(Settings(cache_dir=tmp_path, warmup=False, scheduler="tcp://127.0.0.1:9"))
    with TestClient(app) as client:
        r = client.get(f"/tables/dielectric?{Q}")
    assert r.status_code == 503
    err = r.json()["error"]
    assert err["param"] == "scheduler" and "127.0.0.1:9" in err["message"]


def test_tables_computed_on_a_local_cluster_equal_in_process(tmp_path):
    app = create_app(Settings(cache_dir=tmp_path, warmup=False, scheduler="local:1"))
    with TestClient(app) as client:
        r = client.get(f"/tables/dielectric?{Q}&format=npz")
        assert r.status_code == 200, r.text
        got = Table.from_bytes(r.content, "npz")
        app.state.store.shutdown_cluster()
    want = bsdf_tab.tabulate({"table": "dielectric", "axes": {"mu": [0.25, 0.5, 1.0], "alpha": [0.2, 0.6],
                                                            "eta": [0.7, 1.5]}}, device="cpu")
    for c in want.channels:
        assert np.array_equal(got.channels[c], want.channels[c]), c
