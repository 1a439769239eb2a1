"""The Warp model functions, called from a user's own kernel module (tests/model/user_kernels.py),
against the independent float64 reference point functions, in float64 and float32.

Parametrized over the model's registries (distributions, shadowing modes, Fresnel types): a
newly registered distribution is tested here as soon as the reference knows it."""

import math

import numpy as np
import pytest

from bsdf_tab.model import DISTRIBUTIONS, FRESNELS, SHADOWINGS
from tests.model import user_kernels as uk
from tests.reference import microfacet_ref as ref

DISTS = {i: name for name, i in DISTRIBUTIONS.items()}
SHADS = {i: name for name, i in SHADOWINGS.items()}
COMBOS = [(d, s) for d in DISTS for s in SHADS]
F64, F32 = np.float64, np.float32


def _dirs(z, phi):
    s = np.sqrt(np.maximum(0.0, 1.0 - z * z))
    return np.stack([s * np.cos(phi), s * np.sin(phi), z], axis=-1)


def _point_inputs(seed, n=400):
    rng = np.random.default_rng(seed)
    cos_v = np.concatenate([rng.uniform(0.0, 1.0, n - n // 4), 10 ** rng.uniform(-6, 0, n // 4)])
    cos_o = rng.uniform(0.0, 1.0, n)
    alpha = 10 ** rng.uniform(-3, math.log10(2.0), n)
    v = _dirs(cos_v, np.zeros(n))
    m = _dirs(rng.uniform(0.0, 1.0, n), rng.uniform(0, 2 * math.pi, n))
    eta = 10 ** rng.uniform(math.log10(0.25), math.log10(4.0), n)
    k = rng.uniform(0.0, 6.0, n)
    return cos_v, cos_o, alpha, v, m, eta, k


def _ref_columns(cos_v, cos_o, alpha, v, m, eta, k, dist, shad):
    n = len(cos_v)
    cols = np.zeros((n, 13))
    dn = DISTS[dist]
    for j in range(n):
        a = alpha[j]
        cols[j, 0] = ref.D(dn, cos_v[j], a)
        cols[j, 1] = ref.Lambda(dn, cos_v[j], a)
        cols[j, 2] = ref.lambda_cos(dn, cos_v[j], a)
        cols[j, 3] = ref.G1(dn, v[j], m[j], a)
        # smith_G has no chi+ terms: reference G with both directions above, m = n
        wi = _dirs(np.array(cos_v[j]), np.array(0.0))
        wo = _dirs(np.array(cos_o[j]), np.array(1.0))
        cols[j, 4] = ref.G(dn, SHADS[shad], wi, wo, np.array([0.0, 0.0, 1.0]), a) if cos_v[j] > 0 and cos_o[j] > 0 else np.nan
        cols[j, 5] = ref.F_schlick(cos_v[j], eta[j])
        cols[j, 6] = ref.F_dielectric(cos_v[j], eta[j])
        cols[j, 7] = ref.F_conductor(cos_v[j], eta[j], k[j])
        cols[j, 8] = 1.0
        cols[j, 9] = cols[j, 6]
        cols[j, 10] = cols[j, 7]
        cols[j, 11] = cols[j, 5]
        cols[j, 12] = ref.pdf_vndf(v[j], m[j], a, dn)
    return cols


@pytest.mark.parametrize("dist,shad", COMBOS)
def test_point_functions_match_reference(dist, shad):
    inputs = _point_inputs(10 + 2 * dist + shad)
    cos_v, cos_o, alpha, v, m, eta, k = inputs
    want = _ref_columns(*inputs, dist, shad)
    names = ["D", "Lambda", "lambda_cos", "G1", "G", "schlick", "dielectric", "conductor",
             "fresnel(ONE)", "fresnel(DIELECTRIC)", "fresnel(CONDUCTOR)", "fresnel(SCHLICK)", "pdf_vndf"]
    got64 = uk.run_point(F64, cos_v, alpha, v, m, cos_o, eta, k, dist, shad)
    got32 = uk.run_point(F32, cos_v, alpha, v, m, cos_o, eta, k, dist, shad)
    # float32 inputs are rounded: compare float32 against float64 evaluated on the same rounded inputs
    r32 = [np.asarray(x, dtype=F32).astype(F64) for x in inputs]
    got64r = uk.run_point(F64, r32[0], r32[2], r32[3], r32[4], r32[1], r32[5], r32[6], dist, shad)
    for c, name in enumerate(names):
        w, g = want[:, c], got64[:, c]
        ok = np.isfinite(w)
        # both infinite (Lambda at grazing) is agreement
        both_inf = np.isinf(w) & np.isinf(g)
        sel = ok & ~both_inf
        # 1e-12 relative; Lambda and lambda_cos for Beckmann sit on cancellations (erfc) of a
        # few hundred ulps where they are tiny, hence the absolute floor
        rtol = 1e-12 if name not in ("Lambda", "lambda_cos", "G1", "G", "pdf_vndf") else 1e-11
        np.testing.assert_allclose(g[sel], w[sel], rtol=rtol, atol=1e-14, err_msg=f"float64 {name}")
        assert np.all(~np.isnan(got32[:, c])), f"float32 {name} NaN"
        f = np.isfinite(got64r[:, c])
        assert np.all(np.isfinite(got32[f, c])), f"float32 {name} Inf where float64 is finite"
        np.testing.assert_allclose(got32[f, c], got64r[f, c], rtol=2e-4, atol=2e-6, err_msg=f"float32 {name}")


def _random_pairs(seed, n, lower=False):
    rng = np.random.default_rng(seed)
    wi = _dirs(rng.uniform(1e-3, 1.0, n), np.zeros(n))
    zo = rng.uniform(1e-3, 1.0, n)
    wo = _dirs(-zo if lower else zo, rng.uniform(0, 2 * math.pi, n))
    alpha = 10 ** rng.uniform(-2, 0, n)
    return wi, wo, alpha


FRESNEL_CASES = [
    (FRESNELS["one"], 0.0, 0.0, ("one",)),
    (FRESNELS["schlick"], 0.04, 0.0, ("schlick", 0.04)),
    (FRESNELS["dielectric"], 1.5, 0.0, ("dielectric", 1.5)),
    (FRESNELS["dielectric"], 0.7, 0.0, ("dielectric", 0.7)),
    (FRESNELS["conductor"], 0.2, 3.9, ("conductor", 0.2, 3.9)),
]


@pytest.mark.parametrize("dist,shad", COMBOS)
def test_brdf_btdf_match_reference(dist, shad):
    n = 300
    wi, wo, alpha = _random_pairs(20 + dist, n)
    for ftype, p0, p1, spec in FRESNEL_CASES:
        got = uk.run_bsdf(F64, wi, wo, alpha, np.full(n, p0), np.full(n, p1), dist, shad, ftype)[:, 0]
        want = np.array([ref.f_r(wi[j], wo[j], alpha[j], DISTS[dist], SHADS[shad], spec) for j in range(n)])
        np.testing.assert_allclose(got, want, rtol=1e-11, atol=1e-13, err_msg=f"brdf {spec}")
    wi, wo, alpha = _random_pairs(30 + dist, n, lower=True)
    for eta in (1.5, 1 / 1.5, 3.0, 1.01):
        got = uk.run_bsdf(F64, wi, wo, alpha, np.full(n, eta), np.zeros(n), dist, shad, 0)[:, 1]
        want = np.array([ref.f_t(wi[j], wo[j], alpha[j], DISTS[dist], SHADS[shad], eta) for j in range(n)])
        np.testing.assert_allclose(got, want, rtol=1e-10, atol=1e-13, err_msg=f"btdf eta={eta}")
        got32 = uk.run_bsdf(F32, wi, wo, alpha, np.full(n, eta), np.zeros(n), dist, shad, 0)[:, 1]
        assert np.all(np.isfinite(got32))


def test_brdf_reciprocity():
    n = 300
    wi, wo, alpha = _random_pairs(40, n)
    for dist in DISTS:
        for shad in SHADS:
            for ftype, p0, p1, _ in FRESNEL_CASES:
                a = uk.run_bsdf(F64, wi, wo, alpha, np.full(n, p0), np.full(n, p1), dist, shad, ftype)[:, 0]
                b = uk.run_bsdf(F64, wo, wi, alpha, np.full(n, p0), np.full(n, p1), dist, shad, ftype)[:, 0]
                np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-300)


def test_btdf_generalized_reciprocity():
    """f_t(i -> o) / eta_o^2 = f_t(o -> i) / eta_i^2 (Walter 2007 sec. 5.2).

    btdf(wi, wo, eta) takes light arriving from the upper side (IOR 1) into the lower side (IOR
    eta). To evaluate the reverse path "light arrives along o from the lower medium and leaves
    along i", flip the frame (z -> -z) so that o's side is on top: o' = flip(o) (now above),
    i' = flip(i) (now below), and the relative IOR seen from o's side is eta_i / eta_o = 1/eta.
    The BTDF is invariant under the mirror flip, so f_t(o -> i) = btdf(o', i', 1/eta), and with
    eta_i = 1, eta_o = eta: btdf(i, o, eta) / eta^2 = btdf(o', i', 1/eta)."""
    n = 300
    wi, wo, alpha = _random_pairs(50, n, lower=True)
    flip = np.array([1.0, 1.0, -1.0])
    for dist in DISTS:
        for shad in SHADS:
            for eta in (1.5, 1 / 1.5, 2.4):
                fwd = uk.run_bsdf(F64, wi, wo, alpha, np.full(n, eta), np.zeros(n), dist, shad, 0)[:, 1]
                rev = uk.run_bsdf(F64, wo * flip, wi * flip, alpha, np.full(n, 1 / eta), np.zeros(n), dist, shad, 0)[:, 1]
                assert np.count_nonzero(fwd) > n // 10
                np.testing.assert_allclose(fwd / eta**2, rev, rtol=1e-10, atol=1e-300)


def _graded_theta(alpha, n=24):
    """Gauss-Legendre nodes on [0, pi/2], panels at tan t = alpha 2^k."""
    bps = [0.0, math.pi / 2] + [math.atan(alpha * 2.0**k) for k in range(-6, 80) if alpha * 2.0**k < 1e9]
    bps = np.unique(bps)
    x, w = np.polynomial.legendre.leggauss(n)
    ts, ws = [], []
    for a, b in zip(bps[:-1], bps[1:]):
        ts.append(a + (b - a) * 0.5 * (x + 1))
        ws.append((b - a) * 0.5 * w)
    return np.concatenate(ts), np.concatenate(ws)


@pytest.mark.parametrize("dist", list(DISTS))
@pytest.mark.parametrize("alpha", [1e-3, 0.05, 0.5, 1.0, 1.5])
def test_D_normalization(dist, alpha):
    """int D(m) (m.n) dw_m = 2 pi int D(t) cos t sin t dt = 1, with the Warp D."""
    t, w = _graded_theta(alpha)
    n = len(t)
    z = np.cos(t)
    cols = uk.run_point(F64, z, np.full(n, alpha), _dirs(z, 0 * z), _dirs(z, 0 * z), z, np.ones(n), np.zeros(n), dist, 0)
    total = 2 * math.pi * np.sum(cols[:, 0] * z * np.sin(t) * w)
    assert abs(total - 1.0) < 1e-10, total
    # and the visible normals: int pdf_vndf dw = 1 for a few incidences (D and Lambda agree)
    for mu in (0.05, 0.5, 1.0):
        wi = ref.wi_of_mu(mu)
        ph_x, ph_w = np.polynomial.legendre.leggauss(64)
        ph = math.pi * 0.5 * (ph_x + 1)
        pw = math.pi * 0.5 * ph_w
        T, P = np.meshgrid(t, ph, indexing="ij")
        m = _dirs(np.cos(T).ravel(), P.ravel())
        nn = len(m)
        vv = np.broadcast_to(wi, m.shape)
        c = uk.run_point(F64, m[:, 2], np.full(nn, alpha), vv, m, m[:, 2], np.ones(nn), np.zeros(nn), dist, 0)[:, 12]
        tot = 2 * np.sum(c.reshape(T.shape) * np.sin(T) * w[:, None] * pw[None, :])
        # the azimuthal integrand has a kink where wi.m = 0: a looser bound
        assert abs(tot - 1.0) < 2e-4, (mu, tot)


@pytest.mark.parametrize("dist", list(DISTS))
@pytest.mark.parametrize("dtype", [F64, F32])
def test_vndf_sampling_density(dist, dtype):
    """Histogram of sampled micro-normals vs the integral of the reference pdf_vndf over bins
    (stretched polar radius u = tan(theta_m)/alpha x azimuth); chi-square with a fixed seed."""
    from scipy.stats import chi2

    n = 200_000
    for mu, alpha in ((0.9, 0.3), (0.3, 0.1), (0.05, 0.7)):
        wi = ref.wi_of_mu(mu)
        m, pdf = uk.run_sample(dtype, wi, alpha, dist, n, seed=77 + dist)
        assert np.all(np.isfinite(m)) and np.all(np.isfinite(pdf))
        assert np.all(np.abs(np.linalg.norm(m, axis=1) - 1) < (1e-5 if dtype == F32 else 1e-12))
        assert np.all(m[:, 2] >= 0) and np.all(m @ wi >= -1e-6)
        # the returned pdf equals the reference pdf at the sample
        want = ref.pdf_vndf(np.broadcast_to(wi, m.shape), m, alpha, DISTS[dist])
        good = want > 1e-3 * want.max()
        np.testing.assert_allclose(pdf[good], want[good], rtol=1e-3 if dtype == F32 else 1e-9)
        u_edges = np.array([0.0, 0.3, 0.6, 1.0, 1.5, 2.5, np.inf])
        p_edges = np.array([0.0, math.pi / 4, math.pi / 2, 3 * math.pi / 4, math.pi])
        u = np.sqrt(m[:, 0] ** 2 + m[:, 1] ** 2) / np.maximum(m[:, 2], 1e-300) / alpha
        p = np.abs(np.arctan2(m[:, 1], m[:, 0]))
        counts, _, _ = np.histogram2d(u, p, bins=[u_edges, p_edges])
        expected = np.zeros_like(counts)
        x, w = np.polynomial.legendre.leggauss(48)
        for a in range(len(u_edges) - 1):
            ta, tb = math.atan(alpha * u_edges[a]), math.atan(alpha * u_edges[a + 1])
            tt = ta + (tb - ta) * 0.5 * (x + 1)
            tw = (tb - ta) * 0.5 * w
            for b in range(len(p_edges) - 1):
                pa, pb = p_edges[b], p_edges[b + 1]
                pp = pa + (pb - pa) * 0.5 * (x + 1)
                pw = (pb - pa) * 0.5 * w
                T, P = np.meshgrid(tt, pp, indexing="ij")
                mm = _dirs(np.cos(T), P)
                val = ref.pdf_vndf(np.broadcast_to(wi, mm.shape), mm, alpha, DISTS[dist])
                expected[a, b] = 2 * np.sum(val * np.sin(T) * tw[:, None] * pw[None, :]) * n
        assert abs(expected.sum() / n - 1) < 2e-3
        sel = expected > 20
        stat = np.sum((counts[sel] - expected[sel]) ** 2 / expected[sel])
        pval = chi2.sf(stat, sel.sum() - 1)
        assert pval > 1e-4, (mu, alpha, stat, sel.sum(), counts, expected)


@pytest.mark.parametrize("dtype", [F64, F32])
def test_edge_inputs_are_nan_free(dtype):
    """mu = 0, alpha = 0, eta = 1, w_i = w_o, the mirror direction, phi_d in {0, pi}, grazing o."""
    cases = []
    for mu in (0.0, 1e-7, 0.5, 1.0):
        wi = ref.wi_of_mu(mu)
        mirror = np.array([-wi[0], 0.0, wi[2]])
        for wo in (wi, mirror, np.array([wi[0], 0, -wi[2]]), -wi, _dirs(np.array(0.0), np.array(math.pi)),
                   _dirs(np.array(0.3), np.array(0.0)), _dirs(np.array(0.3), np.array(math.pi)),
                   _dirs(np.array(-0.3), np.array(math.pi)), np.array([0.0, 0.0, 1.0]), np.array([0.0, 0.0, -1.0])):
            for alpha in (0.0, 1e-7, 0.3, 2.0):
                for eta in (1.0, 1.5, 1 / 1.5, 1 + 1e-7):
                    cases.append((wi, wo, alpha, eta))
    wi = np.array([c[0] for c in cases])
    wo = np.array([c[1] for c in cases])
    alpha = np.array([c[2] for c in cases])
    eta = np.array([c[3] for c in cases])
    n = len(cases)
    for dist in DISTS:
        for shad in SHADS:
            for ftype in FRESNELS.values():
                out = uk.run_bsdf(dtype, wi, wo, alpha, eta, np.full(n, 2.0), dist, shad, ftype)
                assert np.all(np.isfinite(out)), [cases[j] for j in np.nonzero(~np.isfinite(out).all(1))[0][:5]]
                assert np.all(out >= 0)
            cols = uk.run_point(dtype, wi[:, 2], alpha, wi, wo, np.abs(wo[:, 2]), eta, np.zeros(n), dist, shad)
            # Lambda is +inf at grazing by definition; everything else finite
            finite_cols = [0, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12]
            assert np.all(np.isfinite(cols[:, finite_cols])), dist
            assert not np.any(np.isnan(cols[:, 1]))
            for j in range(4):
                m, pdf = uk.run_sample(dtype, wi[j * 40], 0.3 if j % 2 else 0.0, dist, 64)
                assert np.all(np.isfinite(m)) and np.all(np.isfinite(pdf))
