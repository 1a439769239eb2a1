"""Stability of every integration method in the regimes of SPEC section 5.

For each method of :data:`bsdf_tab.integrate.METHODS` at a small effort: no NaN/inf, values
in [0, 1], R + T <= 1, the correct limits (mirror alpha -> 0, the GGX closed forms, total
internal reflection), and honesty: where a method cannot reach the accuracy, its error channel
is large (|value - truth| <= error), never a small wrong number. Truth here is the adaptive
method at a tight tolerance (itself checked against the independent reference in
test_accuracy.py) or a closed form. Tiny grids keep this file well under a minute.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from bsdf_tab.errors import SpecError
from bsdf_tab.integrate import METHODS
from bsdf_tab.spec import normalize_spec

# small efforts: fast, and low enough that the hard regimes are out of reach
EFFORT = {"grid": 2048, "mc_cosine": 512, "mc_dcos": 512, "mc_vndf": 512, "qmc_vndf": 512, "vndf_gl": 256}
FIXED = sorted(EFFORT)
ALL = ["adaptive"] + FIXED

MU = np.array([0.0, 1e-6, 1e-4, 1e-2, 0.5, 1.0])
ALPHA = np.array([0.0, 1e-6, 1e-4, 1e-3, 0.3, 1.0, 2.0])
ETA = [1 - 1e-4, 1.0, 1 + 1e-6, 1.01, 1.5, 1 / 1.5]


def _run(method, mode, mu, alpha, eta=None, dist=0, shadowing=1, **kw):
    kw = dict(kw)
    if method == "adaptive":
        kw.setdefault("tol", 1e-5)
    else:
        kw.setdefault("effort", EFFORT[method])
    return METHODS[method](mode, mu, alpha, eta, dist=dist, shadowing=shadowing, **kw)


def _grid(eta=None):
    m, a = np.meshgrid(MU, ALPHA, indexing="ij")
    n = m.size
    return m.ravel(), a.ravel(), None if eta is None else np.full(n, eta)


@pytest.fixture(scope="module")
def truth():
    """Adaptive at tol 1e-8 on the same texels (cached per (mode, dist, shadowing, eta))."""
    cache = {}

    def get(mode, dist, shadowing, eta=None):
        key = (mode, dist, shadowing, eta)
        if key not in cache:
            mu, alpha, etas = _grid(eta)
            cache[key] = METHODS["adaptive"](mode, mu, alpha, etas, dist=dist, shadowing=shadowing, tol=1e-8)
        return cache[key]

    return get


def _check_basic(v, e, dielectric):
    assert np.isfinite(v).all() and np.isfinite(e).all()
    assert (v >= 0).all() and (v <= 1).all()
    assert (e >= 0).all()
    if dielectric:
        assert (v.sum(axis=1) <= 1 + 1e-12).all()


def _check_honest(v, e, tv, te, nch, what):
    bad = np.abs(v[:, :nch] - tv[:, :nch]) > e[:, :nch] + te[:, :nch] + 1e-9
    assert not bad.any(), f"{what}: {int(bad.sum())} texels with a small wrong value: " + str(
        [(float(v[k, c]), float(tv[k, c]), float(e[k, c])) for k, c in zip(*np.nonzero(bad))][:4])


@pytest.mark.parametrize("method", FIXED)
@pytest.mark.parametrize("dist", [0, 1])
def test_albedo_regimes(method, dist, truth):
    """Grazing mu, near-mirror and very rough alpha, both shadowing modes."""
    for shad in (0, 1):
        mu, alpha, _ = _grid()
        v, e = _run(method, "reflect", mu, alpha, dist=dist, shadowing=shad)
        _check_basic(v, e, False)
        tv, te = truth("reflect", dist, shad)
        _check_honest(v, e, tv, te, 1, f"{method} albedo dist={dist} shad={shad}")
        # alpha = 0 is the mirror: E = F = 1 exactly (for mu > 0)
        mirror = (alpha == 0) & (mu > 0)
        assert np.allclose(v[mirror, 0], 1.0) and (e[mirror] == 0).all()


@pytest.mark.parametrize("method", FIXED)
@pytest.mark.parametrize("eta", ETA)
def test_dielectric_regimes(method, eta, truth):
    """eta near 1 (half-vector singularity), TIR (eta < 1), grazing, near-mirror."""
    mu, alpha, etas = _grid(eta)
    v, e = _run(method, "dielectric", mu, alpha, etas, dist=0, shadowing=1)
    _check_basic(v, e, True)
    tv, te = truth("dielectric", 0, 1, eta)
    _check_honest(v, e, tv, te, 2, f"{method} dielectric eta={eta}")


@pytest.mark.parametrize("method", ALL)
def test_total_internal_reflection(method):
    """eta < 1 beyond the critical angle, smooth-ish surface: T = 0, R = 1 - shadowing loss."""
    eta = 1 / 1.5
    mu = np.array([0.2, 0.5])  # both beyond the critical cosine sqrt(1 - eta^2) = 0.745
    alpha = np.array([1e-3, 1e-3])
    v, e = _run(method, "dielectric", mu, alpha, np.full(2, eta))
    # T is not exactly 0 for a rough surface (tilted facets), but tiny; R close to 1
    assert (v[:, 1] <= e[:, 1] + 1e-4).all()
    assert (np.abs(v[:, 0] - 1.0) <= e[:, 0] + 5e-3).all()


@pytest.mark.parametrize("method", ALL)
def test_closed_forms_ggx(method):
    """GGX, F = 1: E(1, 1) = 1 - ln 2 (both modes); separable E(mu -> 0, 1) -> 2 - 2 ln 2."""
    exact = 1.0 - math.log(2.0)
    for shad in (0, 1):
        v, e = _run(method, "reflect", np.array([1.0]), np.array([1.0]), shadowing=shad)
        assert abs(v[0, 0] - exact) <= e[0, 0] + 1e-9
        assert e[0, 0] < 0.1  # and the method does get close here
    v, e = _run(method, "reflect", np.array([1e-6]), np.array([1.0]), shadowing=0)
    assert abs(v[0, 0] - (2.0 - 2.0 * math.log(2.0))) <= e[0, 0] + 1e-4


@pytest.mark.parametrize("method", FIXED)
def test_dfg_sums_to_albedo(method):
    """A + B = E (F = 1) within the reported errors; both in [0, 1]."""
    mu = np.array([0.05, 0.5, 1.0])
    alpha = np.array([0.2, 0.5, 0.8])
    ab, eab = _run(method, "dfg", mu, alpha)
    ev, ee = _run(method, "reflect", mu, alpha)
    _check_basic(ab, eab, False)
    assert (np.abs(ab.sum(axis=1) - ev[:, 0]) <= eab.sum(axis=1) + ee[:, 0] + 1e-9).all()


@pytest.mark.parametrize("method", ["mc_cosine", "mc_dcos", "mc_vndf", "qmc_vndf"])
def test_monte_carlo_is_deterministic_and_chunk_independent(method):
    mu = np.linspace(0.1, 1.0, 9)
    alpha = np.full(9, 0.4)
    v1, e1 = _run(method, "reflect", mu, alpha, workers=1)
    v2, e2 = _run(method, "reflect", mu, alpha, workers=2)
    v3, _ = _run(method, "reflect", mu[3:4], alpha[3:4])  # other chunking, other texel index
    assert np.array_equal(v1, v2) and np.array_equal(e1, e2)
    assert abs(v3[0, 0] - v1[3, 0]) <= e1[3, 0] + 1e-9  # another stream: agrees within the error


@pytest.mark.parametrize("method", FIXED)
def test_more_effort_is_more_accurate(method):
    mu = np.array([0.3, 0.7])
    alpha = np.array([0.3, 0.5])
    tv, _ = METHODS["adaptive"]("reflect", mu, alpha, tol=1e-9)
    lo = _run(method, "reflect", mu, alpha, effort=EFFORT[method])
    hi = _run(method, "reflect", mu, alpha, effort=16 * EFFORT[method])
    assert hi[1][:, 0].max() < lo[1][:, 0].max()
    assert np.abs(hi[0][:, 0] - tv[:, 0]).max() <= hi[1][:, 0].max()


# ------------------------------------------------------------------------------ spec


def test_spec_effort_normalizes_idempotently():
    spec = {"table": "albedo", "method": "mc_vndf", "effort": 4096, "axes": {"mu": [0.5], "alpha": [0.3]}}
    n = normalize_spec(spec)
    assert n["method"] == "mc_vndf" and n["effort"] == 4096
    assert normalize_spec(n) == n
    # absent effort stays absent (the method's default), so existing spec hashes do not change
    n2 = normalize_spec({"table": "albedo", "method": "grid"})
    assert "effort" not in n2 and normalize_spec(n2) == n2
    assert "effort" not in normalize_spec({"table": "albedo"})


@pytest.mark.parametrize(
    "spec",
    [
        {"table": "albedo", "effort": 1024},  # adaptive is error-controlled
        {"table": "albedo", "method": "mc_vndf", "effort": 0},
        {"table": "albedo", "method": "mc_vndf", "effort": 10.5},
        {"table": "albedo", "method": "mc_vndf", "effort": True},
        {"table": "albedo", "method": "nope"},
    ],
)
def test_spec_effort_errors(spec):
    with pytest.raises(SpecError):
        normalize_spec(spec)


def test_every_spec_method_is_registered():
    from bsdf_tab.spec import METHODS as SPEC_METHODS

    assert set(ALL) <= set(SPEC_METHODS) and set(ALL) <= set(METHODS)


def test_tabulate_with_a_fixed_effort_method():
    import bsdf_tab

    t = bsdf_tab.tabulate({"table": "albedo", "method": "qmc_vndf", "effort": 512,
                           "axes": {"mu": [0.2, 1.0], "alpha": [0.0, 0.5]}})
    assert np.isfinite(t.channels["E"]).all() and (t.channels["E_err"] > 0).any()
    assert np.allclose(t.channels["E"][:, 0], 1.0)


def test_benchmark_helpers():
    from bsdf_tab.benchmarks.accuracy import aggregate, pareto

    assert pareto([(1.0, 1e-2), (2.0, 1e-3), (3.0, 1e-2), (0.5, 1.0)]) == [3, 0, 1]
    rows = [{"method": "m", "effort": 1, "case": c, "time_s": 1.0, "n_texels": 10, "evals_per_texel": 4.0,
             "max_abs_err": x, "mean_abs_err": x / 10, "honesty": 1.0, "n_dishonest": 0, "invalid_values": False}
            for c, x in (("a", 1e-3), ("b", 1e-2))]
    (s,) = aggregate(rows)
    assert s["max_abs_err"] == 1e-2 and s["time_per_1k_texels_s"] == pytest.approx(100.0)
