"""The accuracy sweep's handling of its Mitsuba peer: disabled, unavailable or failing, the
sweep keeps its result and records why the peer did not run."""

from __future__ import annotations

from bench import accuracy_sweep, mitsuba_peer, mitsuba_run

RESULT = {"quick": True, "axes": {"mu": [0.5, 1.0], "alpha": [0.2]}, "efforts": {"adaptive": [1e-3]}}


def test_disabled_peer_is_recorded():
    out = accuracy_sweep.mitsuba_peer(RESULT, None, enabled=False)
    assert out == {"available": False, "ran": False, "note": "skipped: disabled (--no-mitsuba)"}


def test_unavailable_peer_is_recorded(monkeypatch):
    monkeypatch.setattr(mitsuba_run, "setup", lambda variant=None: {"available": False, "note": "skipped: test"})
    out = accuracy_sweep.mitsuba_peer(RESULT, None, log=lambda line: None)
    assert out["ran"] is False and out["note"] == "skipped: test"


def test_a_failing_peer_does_not_lose_the_sweep(monkeypatch):
    seen = {}

    def boom(quick, mu, alpha, **kw):
        seen.update(quick=quick, n=len(mu), same=kw["same_case_efforts"])
        raise RuntimeError("no LLVM")

    monkeypatch.setattr(mitsuba_run, "peer_run", boom)
    out = accuracy_sweep.mitsuba_peer(RESULT, None)
    assert out == {"available": True, "ran": False, "note": "failed: RuntimeError: no LLVM"}
    # the sweep's texels, and only the methods the sweep ran, at the quick ladder
    assert seen == {"quick": True, "n": 2, "same": {"adaptive": mitsuba_run.SAME_CASE_EFFORTS_QUICK["adaptive"]}}


def test_peer_cases_are_separable_and_the_estimator_is_lazy():
    cases = mitsuba_run.peer_cases()
    assert cases and all(c.shadowing == "separable" for c in cases)
    assert {c.mode for c in cases} == {"reflect", "dielectric"}
    assert not hasattr(mitsuba_peer, "mi")  # Mitsuba is imported by setup(), not at import
