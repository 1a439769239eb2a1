"""The decisive shading judge of bench/ltc.py (bench/ltc_judge.py): its quads follow the bench's
random-quad distribution, its delta and standard error are honest against brute force over that
distribution and over repeated seeds, and its exact integrals are within their error estimates
against the bench's independent cubature where the Warp rules are weakest (grazing needles)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from bench.ltc import exact_quads, random_quads
from bench.ltc_judge import decide, exact_with_error, mixture_quads, paired_judge
from bsdf_tab.ltc import polygon_integral
from bsdf_tab.ltc.exact import FINE_RULE, quad_integrals
from bsdf_tab.ltc.matrix import from_storage


def _features(quads):
    """Scalar features of quads (N, 4, 3): the centre's elevation, the solid-angle-free planar area, the
    centre's azimuth cosine."""
    c = quads.mean(axis=1)
    c = c / np.linalg.norm(c, axis=1, keepdims=True)
    area = 0.5 * np.linalg.norm(np.cross(quads[:, 2] - quads[:, 0], quads[:, 3] - quads[:, 1]), axis=1)
    return c[:, 2], area, c[:, 0] / np.maximum(np.hypot(c[:, 0], c[:, 1]), 1e-12)


@pytest.mark.parametrize("mu", [0.95, 0.3, 0.0008])
def test_mixture_quads_follow_random_quads(mu):
    # random_quads(mu (N,), 2): quad 0 of each texel is from the near stratum, quad 1 uniform
    ref = random_quads(np.full(1500, mu), 2, 7)
    rng = np.random.default_rng(11)
    for stratum, near in ((0, True), (1, False)):
        ours = mixture_quads(np.array([mu]), 1500, rng, near)[0]
        assert (ours[..., 2] > 0.01).all()
        n = np.cross(ours[:, 1] - ours[:, 0], ours[:, 2] - ours[:, 0])
        assert (np.einsum("nc,nc->n", n, ours[:, 0]) > 0).all()  # wound positive
        for a, b in zip(_features(ours), _features(ref[:, stratum])):
            assert stats.ks_2samp(a, b).pvalue > 1e-3


def _tables(mu, alpha):
    """Two LTC tables for texels (mu, alpha): one close to the lobe's shape, one wider and brighter."""
    T = mu.size
    m1 = from_storage(np.full(T, 1.0), np.zeros(T), -0.4 * np.sqrt(1 - mu ** 2), 1.0 / (alpha + 0.05))
    m2 = from_storage(np.full(T, 1.0), np.zeros(T), -0.2 * np.sqrt(1 - mu ** 2), 0.6 / (alpha + 0.05))
    return [(m1, np.full(T, 0.9)), (m2, np.full(T, 1.1))]


def test_judge_delta_against_brute_force():
    # the population delta by brute force over the bench's own generator (random_quads) and FINE_RULE
    mu, alpha = np.array([0.7, 0.15]), np.array([0.3, 0.5])
    tabs = _tables(mu, alpha)
    j = paired_judge(mu, alpha, tabs, seed=3, se_target=1e-6, pilot=256, max_quads=256, rounds=1)
    for t in range(2):
        q = random_quads(np.full(1500, mu[t]), 2, 100 + t).reshape(-1, 4, 3)
        exact = quad_integrals(q, mu[t], alpha[t], rule=FINE_RULE)
        d = [np.abs(amp[t] * polygon_integral(q, np.repeat(m[t][None], len(q), axis=0)) - exact) for m, amp in tabs]
        diff = d[0] - d[1]
        ref, ref_se = diff.mean(), diff.std(ddof=1) / math.sqrt(diff.size)
        assert abs(j["delta"][t] - ref) < 4.0 * math.hypot(j["se"][t], ref_se)
        assert j["quads"][t] == 256 and j["se"][t] > 0


def test_judge_standard_error_is_honest_over_seeds():
    # the spread of delta over independent seeds matches the reported standard errors (chi-square)
    mu, alpha = np.array([0.9, 0.5, 0.2, 0.05]), np.array([0.1, 0.4, 0.2, 0.6])
    tabs = _tables(mu, alpha)
    runs = [paired_judge(mu, alpha, tabs, seed=s, se_target=1e-9, pilot=64, max_quads=64, rounds=1) for s in range(12)]
    delta = np.array([r["delta"] for r in runs])
    se = np.array([r["se"] for r in runs])
    chi2 = np.sum((delta - delta.mean(axis=0)) ** 2 / (se ** 2).mean(axis=0), axis=0) / (len(runs) - 1)
    assert (chi2 > 0.2).all() and (chi2 < 3.0).all(), chi2


def test_judge_identical_tables_and_sequential_target():
    mu, alpha = np.array([0.6, 0.1]), np.array([0.2, 0.3])
    tabs = _tables(mu, alpha)
    same = paired_judge(mu, alpha, [tabs[0], tabs[0]], seed=1, rounds=2)
    assert (same["delta"] == 0).all() and (same["se"] == 0).all() and (same["quads"] == 64).all()
    j = paired_judge(mu, alpha, tabs, seed=1, se_target=5e-4, z_far=1e9, max_quads=4096, rounds=6)
    assert (j["se"] <= 5e-4).all() and (j["quads"] > 64).any()


def test_exact_with_error_against_cubature_at_grazing_needles():
    # the fine Warp rule is weakest at grazing needles (alpha <= 0.02): the estimate must cover its error
    rng = np.random.default_rng(4)
    for mu, alpha in ((0.093, 1e-5), (0.02, 4e-3)):
        q = np.concatenate([mixture_quads(np.array([mu]), 12, rng, True)[0],
                            mixture_quads(np.array([mu]), 4, rng, False)[0]])
        m, a = np.full(len(q), mu), np.full(len(q), alpha)
        exact, err = exact_with_error(q, m, a)
        cub, cub_err, _ = exact_quads(q, m, a, tol=1e-8)
        assert (np.abs(exact - cub) <= err + cub_err + 1e-9).all()


def test_decide_counts():
    j = {"delta": np.array([-2e-3, 5e-4, 1.5e-3, 1.2e-3]), "se": np.array([1e-4, 1e-4, 1e-4, 1e-4]),
         "bias": np.array([0.0, 0.0, 0.0, 1e-4]), "quads": np.array([64, 64, 128, 256])}
    r = decide(j)
    assert r["better"] == 0.25 and r["better_surely"] == 0.25
    assert r["worse_by_margin"] == 2 and r["worse_by_margin_surely"] == 1 and r["worse_by_margin_possibly"] == 2
    assert r["worst_texel"] == 2 and r["quads_total"] == 512


def test_shift_bound_covers_every_shift():
    # brute force: move the exact value over [-err, err] and take the largest change of d
    from bench.ltc_judge import shift_bound

    rng = np.random.default_rng(9)
    a, b, x = rng.normal(size=(3, 400)) * 1e-2
    err = np.abs(rng.normal(size=400)) * 1e-2
    bound = shift_bound(a, b, x, err)
    s = np.linspace(-1.0, 1.0, 2001)[:, None] * err
    d = np.abs(a - x - s) - np.abs(b - x - s)
    worst = np.max(np.abs(d - (np.abs(a - x) - np.abs(b - x))), axis=0)
    assert (worst <= bound + 1e-15).all() and np.mean(bound < 2.0 * err) > 0.3
    assert (shift_bound(a, a, x, err) == 0).all()
