"""The adaptive method's two-stage inner rule (issue 14, fourth round) and loose floor (round 6).

Each inner G7-K15 application first evaluates the 7 Gauss nodes and accepts G7 with the error
first_safety |G7 - I5| = 4 |G7 - I5| (:func:`bsdf_tab.integrate.quadrature.first_stage`; I5 the
interpolatory rule on 5 of the Gauss nodes) where that fits the interval's share of the
tolerance; otherwise it adds the 8 Kronrod nodes. Checked here, against computations written
apart from the code under test:

* the rules' weights: exactness degrees from exact monomial integrals (G7 13, I5 5, I3 3) and
  G7 against NumPy's Gauss-Legendre rule;
* the device first stage on smooth and non-smooth functions: its G7 is NumPy's, and its error
  covers |G7 - exact integral| (closed forms);
* whole texels at loose and tight tolerances: reported errors cover the true errors against the
  independent reference (``tests/reference/microfacet_ref.py``, method B), and the rule costs
  fewer evaluations than K15 always (``inner_first=0``), by more at loose tolerances;
* single inner phi integrals from a review (SciPy ``quad`` references): three that the plain
  |G7 - I5| under-reports are honest with the factor 4 (and the test checks that the plain
  estimate fails them), two are strict-xfail documented limits (the 7 values do not resolve the
  integrand; the texel stays honest through the outer level);
* the margin: with the heuristic estimates alone (``bound_share=0``) the worst true / reported
  ratio on the texels above stays <= 0.1 (1e-2, 1e-3) and 0.3 (5e-7), bounds that the estimate
  scaled by 0.1 exceeds;
* the coarser initial floor at tolerances >= 1e-4 (pieces <= 1/2 in v; the fourth round's floor
  for rough texels, alpha >= 0.3, which the sixth round's map made dishonest and then every
  texel's): honest against the reference on rough texels of every family, grazing and normal
  incidence included, and cheaper than pieces <= 1/4.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import warp as wp

from scipy.integrate import quad

from bsdf_tab.integrate import adaptive, integrate_texels
from bsdf_tab.integrate.inner import inner_integral
from bsdf_tab.integrate.integrand import MODE_DIELECTRIC, MODE_REFLECT, integrand_phi, make_texel
from bsdf_tab.integrate.quadrature import GK_X, WG7, WI3, WI5, XGK, first_stage, vec16d
from tests.integrate.honesty import assert_honest, reference_set
from tests.reference.sampling import sample_texels


def _full(w):
    # QUADPACK layout (positive half, centre last) -> the 15 nodes' order of GK_X
    return np.concatenate([w, w[:7]])


@pytest.mark.parametrize("name, w, degree", [("G7", WG7, 13), ("I5", WI5, 5), ("I3", WI3, 3)])
def test_rule_exactness_degrees(name, w, degree):
    wf = _full(w)
    for k in range(degree + 3):
        exact = 2.0 / (k + 1) if k % 2 == 0 else 0.0
        q = float(np.sum(wf * GK_X**k))
        if k <= degree:
            assert abs(q - exact) < 1e-14, (name, k, q, exact)
        elif k == degree + 1:
            # the first even degree beyond: not exact (a rule that were would be a different one)
            assert abs(q - exact) > 1e-4, (name, k, q, exact)
    # the subsets use only the Gauss nodes, with positive weights
    assert np.all(wf[(wf != 0)] > 0)
    assert np.all(w[[0, 2, 4, 6]] == 0.0)


def test_g7_weights_are_gauss_legendre():
    x, w = np.polynomial.legendre.leggauss(7)
    got = sorted(zip(np.concatenate([XGK[[1, 3, 5]], -XGK[[1, 3, 5]], [0.0]]),
                     np.concatenate([WG7[[1, 3, 5]], WG7[[1, 3, 5]], [WG7[7]]])))
    assert np.allclose([g[0] for g in got], x, atol=1e-15)
    assert np.allclose([g[1] for g in got], w, atol=1e-15)


@wp.func
def node_values(f: wp.array2d(dtype=wp.float64), k: wp.int32):
    # row k's 15 values as channel 0, and -2 times them as channel 1
    f0 = vec16d()
    f1 = vec16d()
    for j in range(15):
        f0[j] = f[k, j]
        f1[j] = -wp.float64(2.0) * f[k, j]
    return f0, f1


@wp.kernel
def _first_kernel(f: wp.array2d(dtype=wp.float64), hl: wp.float64, which: wp.int32, out: wp.array2d(dtype=wp.float64)):
    k = wp.tid()
    f0, f1 = node_values(f, k)
    g, e = first_stage(f0, f1, hl, which, wp.float64(1.0))
    out[k, 0] = g[0]
    out[k, 1] = g[1]
    out[k, 2] = e[0]
    out[k, 3] = e[1]


# functions on [0, 2] (hl = 1 around the centre 1) with closed-form integrals
FUNCS = [
    (lambda x: np.exp(3.0 * x), (math.exp(6.0) - 1.0) / 3.0),
    (lambda x: np.cos(5.0 * x), math.sin(10.0) / 5.0),
    (lambda x: np.sqrt(x), 2.0 / 3.0 * 2.0**1.5),
    (lambda x: np.abs(x - 0.7), 0.5 * 0.7**2 + 0.5 * 1.3**2),
    (lambda x: 1.0 / (1.0 + 25.0 * (x - 1.0) ** 2), 2.0 * math.atan(5.0) / 5.0),
    (lambda x: x**3 - x, 4.0 - 2.0),
]


@pytest.mark.parametrize("which", [5, 3])
def test_first_stage_is_g7_and_its_error_covers_it(which):
    x = 1.0 + GK_X
    f = np.stack([fn(x) for fn, _ in FUNCS])
    out = wp.zeros((len(FUNCS), 4), dtype=wp.float64, device="cpu")
    wp.launch(_first_kernel, dim=len(FUNCS), inputs=[wp.array(f, dtype=wp.float64, device="cpu"), 1.0, which, out],
              device="cpu")
    out = out.numpy()
    xg, wg = np.polynomial.legendre.leggauss(7)
    for k, (fn, exact) in enumerate(FUNCS):
        g7 = float(np.sum(wg * fn(1.0 + xg)))
        assert abs(out[k, 0] - g7) <= 1e-13 * max(1.0, abs(g7)), (k, out[k, 0], g7)
        assert abs(out[k, 1] + 2.0 * g7) <= 2e-13 * max(1.0, abs(g7))
        assert out[k, 2] >= abs(g7 - exact), (k, out[k, 2], g7 - exact)
        assert out[k, 3] >= 2.0 * abs(g7 - exact)
    # a cubic is exact for both rules: the error is the 50 ulp floor
    assert out[-1, 2] <= 1e-13 * abs(out[-1, 0]) + 1e-15


def _texels():
    mu, alpha, _ = sample_texels(7001, 10)
    mu_t, alpha_t, eta_t = sample_texels(7002, 10, eta="<1")
    mu_g, alpha_g, eta_g = sample_texels(7003, 6, eta=">1")
    return [
        reference_set("reflect", "ggx", "correlated", mu, alpha),
        reference_set("dielectric", "beckmann", "separable", mu_t, alpha_t, eta_t),
        reference_set("dielectric", "ggx", "correlated", mu_g, alpha_g, eta_g),
    ]


@pytest.fixture(scope="module")
def texels():
    return _texels()


def _honest_and_counted(texel_sets, tol, baseline, *also):
    """Every texel's value within its reported error and the tolerance of the reference (with the
    shipped method, and with each keyword set of ``also`` too); returns the summed evaluations of
    the shipped method and of the ``baseline`` keywords."""
    total_new, total_old = 0, 0
    for mode, kw, mu, alpha, eta, refs in texel_sets:
        v, e, c = integrate_texels(mode, mu, alpha, eta, tol=tol, return_cost=True, **kw)
        runs = [(v, e)] + [integrate_texels(mode, mu, alpha, eta, tol=tol, **extra, **kw) for extra in also]
        _, _, c0 = integrate_texels(mode, mu, alpha, eta, tol=tol, return_cost=True, **baseline, **kw)
        total_new += int(c.sum())
        total_old += int(c0.sum())
        for vv, ee in runs:
            assert_honest(vv, ee, refs, tol, (mode, kw, tol))
    return total_new, total_old


@pytest.mark.parametrize("tol", [1e-2, 1e-3, 5e-7])
def test_two_stage_is_honest_and_cheaper(texels, tol):
    total_new, total_old = _honest_and_counted(texels, tol, {"inner_first": 0})
    # measured on these 26 texels: 0.69 / 0.80 / 0.95 of the evaluations of K15 always (0.62 /
    # 0.75 / 0.94 with the plain |G7 - I5|, first_safety 1); 0.78 / 0.86 / 0.95 after issue 14 round 6;
    # 0.82 / 0.90 / 0.97 with round 7's outer first stage (fewer outer nodes on both sides), 0.62 /
    # 0.67 / 0.95 with its inner end maps and carry 2 (pieces no longer mapped at phi = 0 or pi)
    limit = {1e-2: 0.7, 1e-3: 0.75, 5e-7: 0.97}[tol]
    assert total_new <= limit * total_old, (tol, total_new, total_old)


def test_first_share_zero_is_k15_always(texels):
    # an accepted first stage would need |G7 - I5| <= 0, below its 50 ulp floor, or G7 = 0,
    # which goes to K15 (7 zeros may miss a support between the nodes): bit for bit the old rule
    for mode, kw, mu, alpha, eta, _ in texels[:2]:
        v0, e0, c0 = integrate_texels(mode, mu, alpha, eta, tol=1e-3, return_cost=True, inner_first=0, **kw)
        v1, e1, c1 = integrate_texels(mode, mu, alpha, eta, tol=1e-3, return_cost=True, first_share=0.0, **kw)
        assert np.array_equal(c0, c1)
        assert np.array_equal(v0, v1) and np.array_equal(e0, e1)


def _rough_texels():
    rng = np.random.default_rng(7010)
    # SPEC section 5: grazing and normal incidence, alpha up to 2 (the reference's validated range)
    mu = np.concatenate([[1e-4, 0.02, 1.0, 0.999, 0.05, 0.6], rng.uniform(0.0, 1.0, 6)])
    alpha = np.concatenate([[0.3, 1.0, 0.3, 0.7, 2.0, 1.5], rng.uniform(0.3, 1.0, 6)])
    eta = np.concatenate([[1.5, 1.0 / 1.5, 1.01, 3.0, 0.7, 1.5], 1.0 / rng.uniform(1.01, 4.0, 3),
                          rng.uniform(1.01, 4.0, 3)])
    return [
        reference_set("reflect", "beckmann", "separable", mu, alpha),
        reference_set("reflect", "ggx", "correlated", mu, alpha, fresnel=("dielectric", 0.6)),
        reference_set("dielectric", "ggx", "correlated", mu, alpha, eta),
    ]


@pytest.fixture(scope="module")
def rough_texels():
    return _rough_texels()


@pytest.mark.parametrize("tol", [1e-2, 1e-3, 1e-4])
def test_loose_floor_is_honest_and_cheaper(rough_texels, tol):
    # pieces <= 1/2 in v at tolerances >= 1e-4 (issue 14 round 6, with the outer map), on rough,
    # grazing and normal-incidence texels, also with the heuristic estimates alone (no D tail left
    # out under its bound); measured 0.84 / 0.84 / 0.86 of the evaluations with pieces <= 1/4.
    # The floor itself (ramp_cut 0): at tolerances >= 1e-3 the default replaces it by the G1 ramp
    # cuts (issue 14 round 9, tested in test_integrate_outer.py)
    on_floor = [(mode, {**kw, "ramp_cut": 0.0}, mu, alpha, eta, refs) for mode, kw, mu, alpha, eta, refs in rough_texels]
    total_new, total_old = _honest_and_counted(on_floor, tol, {"max_piece": 0.25}, {"bound_share": 0.0})
    # and the default start (the ramp cuts at >= 1e-3) honest on the same texels
    _honest_and_counted(rough_texels, tol, {}, {"bound_share": 0.0})
    limit = {1e-2: 0.88, 1e-3: 0.88, 1e-4: 0.9}[tol]
    assert total_new <= limit * total_old, (tol, total_new, total_old)


def test_bit_identical_across_workers_at_loose_tolerance():
    # the two-stage rule, the outer map and the floor are per texel: any worker count and chunking
    # gives the same bits (rough and smooth texels, both families, loose tolerances)
    mu, alpha, eta = sample_texels(7020, 40, eta="<1")
    alpha[::2] = 0.3 + alpha[::2]
    for mode in ("reflect", "dielectric"):
        for tol in (1e-2, 1e-4):
            ref_v, ref_e = integrate_texels(mode, mu, alpha, eta, tol=tol, workers=1)
            for workers in (2, 3):
                v, e = integrate_texels(mode, mu, alpha, eta, tol=tol, workers=workers)
                assert np.array_equal(v, ref_v) and np.array_equal(e, ref_e), (mode, tol, workers)
            rev = slice(None, None, -1)
            v, e = integrate_texels(mode, mu[rev], alpha[rev], eta[rev], tol=tol, workers=2)
            assert np.array_equal(v[rev], ref_v) and np.array_equal(e[rev], ref_e), (mode, tol)


# --- issue 14 review: what the first stage's estimate misses, at the inner level and in margin ---
# |G7 - I5| is the degree-6 term of the 7 values' interpolant: where those values do not resolve
# the integrand (a ramp or kink narrower than the node spacing) it can be far below G7's true
# error, and the inner phi integral then under-reports. The cases below are a review's
# (the sampling of bench/inner_honesty.py, seed 3): single inner integrals (one theta_m) whose reported error
# was below the true one only with the first stage; the reference is SciPy's QUADPACK on the
# same integrand over [0, pi] (no breakpoints given), independent of this quadrature.

@wp.kernel
def _inner_kernel(mode: wp.int32, dist: wp.int32, shad: wp.int32, ftype: wp.int32, fp0: wp.float64,
                  mu: wp.float64, alpha: wp.float64, eta: wp.float64, theta: wp.float64, tol: wp.float64,
                  safety: wp.float64, out: wp.array(dtype=wp.float64)):
    p = make_texel(mode, dist, shad, ftype, fp0, wp.float64(0.0), mu, alpha, eta)
    # the texel kernel's settings (integrate_texels' defaults), bound_share irrelevant here
    p.err_model = 1
    p.err_model_inner = 2
    p.err_safety = wp.float64(1.0)
    p.err_power = wp.float64(3.0)
    p.inner_first = 5
    p.first_share = wp.float64(1.0)
    p.first_safety = safety
    cm = wp.cos(theta)
    sm = wp.sin(theta)
    r, e, used, used_ref = inner_integral(p, cm, sm, sm / cm, tol, 50)
    out[0] = r[0]
    out[1] = r[1]
    out[2] = e[0]
    out[3] = e[1]


@wp.kernel
def _phi_kernel(mode: wp.int32, dist: wp.int32, shad: wp.int32, ftype: wp.int32, fp0: wp.float64,
                mu: wp.float64, alpha: wp.float64, eta: wp.float64, theta: wp.float64,
                phi: wp.array(dtype=wp.float64), out: wp.array2d(dtype=wp.float64)):
    k = wp.tid()
    p = make_texel(mode, dist, shad, ftype, fp0, wp.float64(0.0), mu, alpha, eta)
    cm = wp.cos(theta)
    sm = wp.sin(theta)
    f = integrand_phi(p, cm, sm, sm / cm, phi[k])
    out[k, 0] = f[0]
    out[k, 1] = f[1]


def _inner_reference(args, ch):
    """int_0^pi of the integrand over phi by scipy.integrate.quad (QUADPACK qags, its own
    bisection and extrapolation at the kinks), to 1e-12."""
    out = wp.zeros((1, 2), dtype=wp.float64, device="cpu")

    def f(x):
        wp.launch(_phi_kernel, dim=1, inputs=[*args, wp.array([x], dtype=wp.float64, device="cpu"), out], device="cpu")
        return float(out.numpy()[0, ch])

    val, err = quad(f, 0.0, math.pi, limit=2000, epsabs=1e-12, epsrel=1e-12)
    return val, err


def _inner_run(args, tol, safety):
    out = wp.zeros(4, dtype=wp.float64, device="cpu")
    wp.launch(_inner_kernel, dim=1, inputs=[*args, float(tol), float(safety), out], device="cpu")
    return out.numpy()


# (family, (mode, dist, shadowing, ftype, fp0), mu, alpha, eta, theta_m, inner tolerance);
# the review's true / reported ratios with the plain |G7 - I5| (first_safety 1) in the comments
_REFLECT, _DIELECTRIC = int(MODE_REFLECT), int(MODE_DIELECTRIC)
INNER_FIXED = [
    # 215x: a Fresnel kink (dielectric Fresnel of eta 0.6) next to a near-mirror lobe
    ("reflect Beckmann sep F diel 0.6", (_REFLECT, 1, 0, 2, 0.6), 0.11277485525312887, 0.0015844023589694834, 1.0,
     0.11284791296268344, 5.6232712338668181e-06),
    # 23.5x
    ("dielectric Beckmann sep eta>1", (_DIELECTRIC, 1, 0, 0, 0.0), 0.11482999627418791, 0.006055113501053931,
     1.4962364390322505, 0.81155401709014185, 8.1838269512167302e-05),
    # 21.3x
    ("dielectric GGX corr eta<1", (_DIELECTRIC, 0, 1, 0, 0.0), 0.088469153142784362, 0.0047783195992802622,
     0.75936384228852971, 0.46358414632174377, 2.4496254876416844e-05),
]
# documented limits: still under-reported at the inner level with first_safety 4 and 8 (the texel
# stays honest: the outer K15 / G7 comparison sees the miss, measured, not proven)
INNER_LIMITS = [
    # 120x with the plain estimate, 30x with first_safety 4, 15x with 8 (the review's example)
    ("dielectric GGX corr eta<1", (_DIELECTRIC, 0, 1, 0, 0.0), 0.03043844495827952, 0.010415639288117227,
     0.56192275940216563, 0.015230819634039047, 0.00048996236115669855),
    # 69x -> 17x (4) -> 8.6x (8)
    ("dielectric Beckmann sep eta>1", (_DIELECTRIC, 1, 0, 0, 0.0), 0.26927840536352821, 0.066820232340004726,
     2.3400476395048466, 0.11450921512244226, 0.058800391168301533),
]


def _inner_worst(case, safety):
    _, fam, mu, alpha, eta, theta, tol = case
    args = [*fam, float(mu), float(alpha), float(eta), float(theta)]
    out = _inner_run(args, tol, safety)
    worst = 0.0
    for ch in range(2):
        val, qerr = _inner_reference(args, ch)
        assert qerr < 1e-9  # the reference converged far below the errors in question
        worst = max(worst, (abs(out[ch] - val) - qerr) / out[2 + ch])
    return worst


@pytest.mark.parametrize("case", INNER_FIXED, ids=[c[0] for c in INNER_FIXED])
def test_inner_first_stage_honest_with_safety(case):
    # the shipped factor covers these inner misses; the plain |G7 - I5| does not (the test's power)
    assert _inner_worst(case, adaptive.FIRST_SAFETY) <= 1.0
    assert _inner_worst(case, 1.0) > 1.0


@pytest.mark.parametrize("case", INNER_LIMITS, ids=[c[0] for c in INNER_LIMITS])
@pytest.mark.xfail(strict=True, reason="documented limit: the 7 values do not resolve the integrand (docs/methods.md)")
def test_inner_first_stage_limits(case):
    assert _inner_worst(case, adaptive.FIRST_SAFETY) <= 1.0


@pytest.mark.parametrize("tol", [1e-2, 1e-3, 5e-7])
def test_first_stage_margin(texels, tol):
    # the heuristic estimates alone (bound_share 0: no D tail left out under its rigorous bound):
    # the worst (|true error| - reference bound) / reported error on these 26 texels, measured
    # 0.012 / 0.004 / 0.392 with the outer map, the inner estimates carried at 4x and parts <=
    # pi/8 at 5e-7 (issue 14 round 6; 0.067 at 5e-7 with pi/16; 0.030 / 0.023 / 0.142 before the
    # round). The power: the first stage scaled by 0.05 (first_safety 0.4) with the carry removed
    # gives 0.157 / 0.101 at 1e-2 / 1e-3, scaled by 0.0125 (0.1) 0.597 at 5e-7; the carry alone
    # absorbs the scaled first stage (0.039 / 0.065 at 0.4). With round 7's outer first stage:
    # 0.017 / 0.009 / 0.392, and the scaled inner stage 0.132 (0.0125) / 0.156 (0.05) / 0.587 (0.0125);
    # with its inner end maps and carry 2: 0.047 / 0.063 / 0.105, scaled 0.086 (0.0125) / 0.183
    # (0.005) / 0.449 (0.002); round 11 (outer first stage at 128, the inner second stage at 16,
    # R and T sharing the larger estimate): 0.010 / 0.010 / 0.063, both inner stages scaled with
    # the outer factor at round 7's 32: 0.086 (0.0125) / 0.098 (0.005) / 2.47 (0.002); at 128 the
    # outer level absorbs the scaled inner stages at 1e-2 (0.022)
    def worst(**kw):
        w = 0.0
        for mode, k2, mu, alpha, eta, refs in texels:
            v, e = integrate_texels(mode, mu, alpha, eta, tol=tol, bound_share=0.0, **kw, **k2)
            for k, r in enumerate(refs):
                for ch, rr in enumerate(r):
                    w = max(w, (abs(v[k, ch] - rr.value) - rr.err) / e[k, ch])
        return w

    bound = {1e-2: 0.03, 1e-3: 0.03, 5e-7: 0.1}[tol]
    scale = {1e-2: 0.0125, 1e-3: 0.005, 5e-7: 0.002}[tol]
    assert worst() <= bound
    # the power on the floor's start (ramp_cut 0: the measurements above); from round 9's G1
    # ramp cuts (the default at >= 1e-3) the same scaled stage stays below 0.06 at 1e-2 (0.047)
    # (round 12's floors off too: they floor the scaled stages' differences, 0.0098 at 1e-2 with them)
    assert worst(first_safety=scale * adaptive.FIRST_SAFETY, second_safety=scale * adaptive.SECOND_SAFETY,
                 inner_carry=1.0, ramp_cut=0.0, outer_first_safety=32.0, outer_first_tail=0.0, second_tail=0.0,
                 outer_tail=0.0) > bound


@pytest.mark.parametrize("bad", [{"inner_first": 4}, {"inner_first": 7}, {"inner_first": True}, {"first_share": 1.5},
                                 {"first_share": float("nan")}, {"first_safety": 0.0}, {"first_safety": float("inf")},
                                 {"err_power": 0.0}, {"err_power": -1.0}, {"err_safety": 0.0}, {"err_safety": float("nan")},
                                 {"normal_split": -0.1}, {"normal_split": float("nan")}, {"normal_split": True},
                                 {"normal_map": float("inf")}, {"outer_near0": -1.0}])
def test_estimate_keywords_are_validated(bad):
    # 4 or 7 used to mean I3 silently (the kernel's "else"), NaN shares and zero factors to run;
    # a power <= 0 made the pow-free branch of gk_error_decay report the floor for a zero ratio
    with pytest.raises(ValueError, match=next(iter(bad))):
        integrate_texels("reflect", [0.5], [0.3], tol=1e-3, **bad)
