"""``bsdf-tab bake --scheduler``: one-line errors fast, and a bake through local:1 equal to in-process."""

from __future__ import annotations

import json
import time

import numpy as np
import pytest

pytest.importorskip("distributed")

from bsdf_tab import cli, read_exr, tabulate  # noqa: E402


def one_line(capsys):
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("bsdf-tab: error: "), err
    return err[0]


def test_unreachable_or_malformed_scheduler_is_one_line_exit_2(tmp_path, capsys, monkeypatch):
    spec = tmp_path / "s.json"
    spec.write_text(json.dumps({"table": "albedo", "axes": {"mu": [1.0], "alpha": [0.5]}}))
    t0 = time.monotonic()
    assert cli.main(["bake", str(spec), "--scheduler", "tcp://127.0.0.1:9", "-q"]) == 2
    assert "not reachable" in one_line(capsys) and time.monotonic() - t0 < 20
    assert cli.main(["bake", str(spec), "--scheduler", "local:0", "-q"]) == 2
    assert "local:N" in one_line(capsys)
    monkeypatch.setenv("BSDF_TAB_SCHEDULER", "bogus")
    assert cli.main(["bake", str(spec), "-q"]) == 2
    assert "scheduler" in one_line(capsys)


def test_bake_on_local_cluster_equals_in_process(tmp_path, capsys):
    spec = {"table": "dielectric", "axes": {"mu": {"size": 4}, "alpha": {"size": 3}, "eta": [0.8, 1.4]}}
    path = tmp_path / "d.json"
    path.write_text(json.dumps(spec))
    assert cli.main(["bake", str(path), "-o", str(tmp_path / "d.exr"), "--scheduler", "local:1", "-q"]) == 0
    assert "1 workers" in capsys.readouterr().err
    got, want = read_exr(tmp_path / "d.exr"), tabulate(spec, device="cpu")
    for c in want.channels:
        assert np.array_equal(got.channels[c], want.channels[c].astype(np.float32)), c
