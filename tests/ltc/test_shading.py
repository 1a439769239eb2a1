"""The shading polish: the Warp integral of the true lobe over quads, the fit's quad lights, the polish
objective, and the ``amplitude: shading`` table against quadrature written here.

Truth: a dense composite Gauss-Legendre rule over the quad's two triangles (written here) of the
reference BRDF of tests/reference (never the code under test), and limits (a near-mirror lobe
inside a large quad carries its whole albedo, at most 1).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import bsdf_tab
from bsdf_tab.ltc import density, l1_metric, polygon_integral
from bsdf_tab.ltc.exact import COARSE_RULE, quad_integrals
from bsdf_tab.ltc.lobe import lobe_nodes
from bsdf_tab.ltc.matrix import clipped_l1_metric, from_storage, upper_mass
from bsdf_tab.ltc.shading import ShadingObjective, fit_quads
from tests.reference import microfacet_ref as ref


def _gl(n, panels):
    x, w = np.polynomial.legendre.leggauss(n)
    e = np.linspace(0.0, 1.0, panels + 1)
    h = 0.5 * np.diff(e)[:, None]
    return ((0.5 * (e[:-1] + e[1:]))[:, None] + h * x).ravel(), (h * w).ravel()


def reference_quad(quad, mu, alpha, dist="ggx", shadowing="correlated", n=12, panels=12):
    """int over the planar quad of f_r cos dw: Duffy-mapped product Gauss-Legendre on two triangles."""
    wi = ref.wi_of_mu(mu)
    u, wu = _gl(n, panels)
    v, wv = _gl(n, panels)
    U, Vv = np.meshgrid(u, v, indexing="ij")
    W = np.outer(wu, wv) * U  # (u, v) -> (u, u v): Jacobian u
    total = 0.0
    for a, b, c in ((quad[0], quad[1], quad[2]), (quad[0], quad[2], quad[3])):
        x = a + U[..., None] * ((b - a) + Vv[..., None] * (c - b))
        cr = np.cross(b - a, c - a)
        area2 = np.linalg.norm(cr)
        r = np.linalg.norm(x, axis=-1)
        d = (x / r[..., None]).reshape(-1, 3)
        f = ref.f_r(wi, d, alpha, dist, shadowing) * d[:, 2]
        total += area2 * np.sum(W.ravel() * f * abs(cr @ a) / area2 / r.ravel() ** 3)
    return total


QUADS = np.array([
    [[-1.2, -0.5, 1.0], [-0.1, -0.5, 1.0], [-0.1, 0.5, 1.0], [-1.2, 0.5, 1.0]],  # over the mirror of mu 0.5 .. 0.9
    [[0.2, 0.4, 0.6], [0.9, 0.5, 0.9], [0.8, 1.3, 1.0], [0.1, 1.1, 0.7]],  # off to the side, tilted
    [[-1.0, -0.2, 0.15], [-0.6, -0.2, 0.35], [-0.6, 0.3, 0.35], [-1.0, 0.3, 0.15]],  # low, toward grazing mirrors
])


@pytest.mark.parametrize("dist,shadowing,mu,alpha", [("ggx", "correlated", 0.5, 0.3), ("ggx", "correlated", 0.9, 0.08),
                                                      ("ggx", "correlated", 0.2, 0.6), ("beckmann", "separable", 0.6, 0.2)])
def test_quad_integrals_against_quadrature(dist, shadowing, mu, alpha):
    quads = np.concatenate([QUADS, fit_quads([mu], 4)[0]])
    got = quad_integrals(quads, mu, alpha, dist, shadowing)
    coarse = quad_integrals(quads, mu, alpha, dist, shadowing, rule=COARSE_RULE)
    want = np.array([reference_quad(q, mu, alpha, dist, shadowing) for q in quads])
    assert want.max() > 0.05  # some quad sees the lobe
    np.testing.assert_allclose(got, want, rtol=0, atol=2e-7)
    np.testing.assert_allclose(coarse, want, rtol=0, atol=2e-5)


def test_quad_integrals_near_mirror_limit():
    # alpha = 1e-4: the lobe is a needle at the mirror direction; a large quad around it holds the albedo
    # (at most 1, within ~alpha of it), a quad away from it only the tail (the dense rule resolves it there)
    mu = 0.7
    s = math.sqrt(1 - mu * mu)
    big = np.array([[-s - 0.5, -0.5, mu], [-s + 0.5, -0.5, mu], [-s + 0.5, 0.5, mu], [-s - 0.5, 0.5, mu]]) / mu
    got = quad_integrals(np.stack([big, QUADS[1]]), mu, 1e-4)
    assert 1.0 - 1e-3 < got[0] <= 1.0
    assert got[1] == pytest.approx(reference_quad(QUADS[1], mu, 1e-4), rel=1e-6, abs=1e-14)


def test_fit_quads_deterministic_above_horizon_and_wound():
    mu = np.array([1.0, 0.5, 0.05, 0.0])
    q = fit_quads(mu, 32)
    assert q.shape == (4, 32, 4, 3)
    np.testing.assert_array_equal(q, fit_quads(mu, 32))
    assert q[..., 2].min() >= 0.01 - 1e-12
    n = np.cross(q[..., 1, :] - q[..., 0, :], q[..., 2, :] - q[..., 0, :])
    assert (np.einsum("...c,...c->...", n, q[..., 0, :]) > 0).all()  # wound positive seen from the origin
    assert (polygon_integral(q.reshape(-1, 4, 3)) > 0).all()
    # the first half about the mirror direction, the second spread over the hemisphere
    c = q.mean(axis=2)
    c /= np.linalg.norm(c, axis=-1, keepdims=True)
    R = np.stack([-np.sqrt(1 - mu**2), 0 * mu, mu], axis=-1)
    cos_near = np.einsum("bqc,bc->bq", c[:, :16], R)
    assert np.median(cos_near[1]) > 0.8 and c[:, 16:, 0].min() < -0.5 and c[:, 16:, 0].max() > 0.5


def test_polish_objective_kernel_matches_numpy():
    mu, alpha = np.array([0.3, 0.8]), np.array([0.4, 0.15])
    nodes = lobe_nodes("ggx", "correlated", mu, alpha, 16, 10)
    E = np.array([0.9, 0.95])
    obj = ShadingObjective("ggx", "correlated", mu, alpha, E, nodes, 50.0, True, 8, l1_weight=2.0)
    rng = np.random.default_rng(3)
    X = np.array([[0.6, -0.2, 0.3, 0.7, 0.05], [0.9, 0.1, -0.1, 0.5, -0.1]]) + 0.02 * rng.normal(size=(2, 5))
    got = obj(np.arange(2), X)
    L, f, w = nodes
    mass = w.sum(axis=1)
    minv = from_storage(*X[:, :4].T)
    d = density(minv, L)
    amp = np.exp(X[:, 4]) / upper_mass(minv)
    T = np.array([[reference_quad(q, m, a) for q in fit_quads([m], 8)[0]] for m, a in zip(mu, alpha)]) / E[:, None]
    est = amp[:, None] * polygon_integral(fit_quads(mu, 8), minv[:, None])
    want = (clipped_l1_metric(d, f, w, mass, amp, upper_mass(minv)) + 2.0 * l1_metric(d, f, w, mass)
            + 50.0 * np.mean(np.abs(est - T), axis=1))
    np.testing.assert_allclose(got, want, rtol=1e-6)
    # the soft constraint: + penalty x max(fit_l1 on its own nodes - limit, 0), the limit met at one texel only
    cnodes = lobe_nodes("ggx", "correlated", mu, alpha, 16, 12, 2, 2)
    Lc, fc, wc = cnodes
    sphere = l1_metric(density(minv, Lc), fc, wc, wc.sum(axis=1))
    limit = np.array([0.9 * sphere[0], 1.1 * sphere[1]])
    cons = ShadingObjective("ggx", "correlated", mu, alpha, E, nodes, 50.0, True, 8, l1_weight=2.0,
                            constraint=(cnodes, limit, 300.0))
    np.testing.assert_allclose(cons(np.arange(2), X), want + 300.0 * np.maximum(sphere - limit, 0.0), rtol=1e-6)
    assert cons(np.arange(2), X)[0] > got[0] + 1.0 and cons(np.arange(2), X)[1] == pytest.approx(got[1], rel=1e-12)


def test_shading_polish_keeps_fit_l1_within_its_slack():
    """Above the grazing rows the polish may raise the sphere metric by at most SHADING["l1_slack"] (relative)
    over the horizon fit's: the tied texels near normal incidence and at high roughness, where the fit metric
    goal is decided by 1e-4 (docs/ltc.md). Checked on the table's own metric rule (not the constraint's)."""
    from bsdf_tab.ltc.fit import SHADING

    spec = {"table": "ltc", "axes": {"mu": [0.5, 0.9, 0.99], "roughness": [0.3, 0.6, 0.95]}}
    pol = bsdf_tab.tabulate({**spec, "amplitude": "shading"}).channels
    hor = bsdf_tab.tabulate(spec).channels
    rel = (pol["fit_l1"] - hor["fit_l1"]) / hor["fit_l1"]
    tol = (pol["fit_l1_err"] + hor["fit_l1_err"]) / hor["fit_l1"]
    assert (rel <= SHADING["l1_slack"] + tol).all(), rel
    assert (rel <= 2.0 * SHADING["l1_slack"]).all(), rel


def test_shading_amplitude_shades_independent_quads_better_within_its_bound():
    spec = {"table": "ltc", "axes": {"mu": [0.2, 0.6], "roughness": [0.55, 0.75]}}
    pol = bsdf_tab.tabulate({**spec, "amplitude": "shading"}).channels
    hor = bsdf_tab.tabulate(spec).channels
    rng = np.random.default_rng(2016)  # quads of this test, not the fit's
    for i, mu in enumerate((0.2, 0.6)):
        s = math.sqrt(1 - mu * mu)
        quads = []
        # 32 quads: at mu = 0.6 the constrained polish stays near the L1 fit, and the mean of 8 quads does
        # not resolve its gain (docs/ltc.md: a 4-quad judge's noise)
        for k in range(32):
            c = np.array([-s, 0.0, mu]) + 0.35 * rng.normal(size=3) if k % 2 == 0 else rng.normal(size=3)
            c[2] = max(abs(c[2]), 0.3)
            c /= np.linalg.norm(c)
            e1 = np.cross(c, [0.0, 0.0, 1.0])
            e1 /= np.linalg.norm(e1)
            e2 = np.cross(c, e1)
            hx, hy = rng.uniform(0.1, 0.3, size=2)
            quads.append([c + hx * e1 + hy * e2, c - hx * e1 + hy * e2, c - hx * e1 - hy * e2, c + hx * e1 - hy * e2])
        quads = np.array(quads)
        quads[np.einsum("qc,qc->q", np.cross(quads[:, 1] - quads[:, 0], quads[:, 2] - quads[:, 0]), quads[:, 0]) < 0] \
            = quads[np.einsum("qc,qc->q", np.cross(quads[:, 1] - quads[:, 0], quads[:, 2] - quads[:, 0]), quads[:, 0]) < 0][:, ::-1]
        for j, rough in enumerate((0.55, 0.75)):
            exact = np.array([reference_quad(q, mu, rough**2) for q in quads])
            err = {}
            for name, ch in (("shading", pol), ("horizon", hor)):
                minv = from_storage(ch["Minv_00"][i, j], ch["Minv_20"][i, j], ch["Minv_02"][i, j], ch["Minv_22"][i, j])
                err[name] = ch["magnitude"][i, j] * polygon_integral(quads, minv) - exact
            assert np.mean(np.abs(err["shading"])) < np.mean(np.abs(err["horizon"]))
            # the stated bound with a general amplitude: E (fit_l1_clipped + |s - 1|) / 2, s = magnitude m_up / E
            E = pol["E"][i, j]
            s_rel = pol["magnitude"][i, j] * pol["horizon"][i, j] / E
            bound = E * (pol["fit_l1_clipped"][i, j] + pol["fit_l1_clipped_err"][i, j] + abs(s_rel - 1.0)) / 2
            assert np.abs(err["shading"]).max() <= bound + 1e-7


def test_shading_amplitude_deterministic_across_workers_and_blocks():
    # 34 alphas: two column blocks (BLOCK = 32) on two threads against one; normal incidence included
    spec = {"table": "ltc", "amplitude": "shading",
            "axes": {"mu": [0.3, 1.0], "roughness": {"size": 34, "range": [0.05, 1.0]}}}
    a = bsdf_tab.tabulate(spec, workers=1).channels
    b = bsdf_tab.tabulate(spec, workers=2).channels
    for name in a:
        np.testing.assert_array_equal(a[name], b[name])
    # normal incidence stays isotropic (the polish moves only Minv_22 and s there)
    np.testing.assert_array_equal(a["Minv_20"][1], 0.0)
    np.testing.assert_array_equal(a["Minv_02"][1], 0.0)
    np.testing.assert_array_equal(a["Minv_00"][1], 1.0)


def test_shading_amplitude_in_the_spec_regimes():
    """SPEC section 5 for the presets' amplitude: mu in {0, 1e-6, 1e-4, 1e-2, 1}, alpha in {0, 1e-6, 1e-4,
    1e-3, 2}. Finite everywhere, the metrics in [0, 2] with the Dirac lobe (alpha = 0) flagged 2, E the
    reference albedo, the amplitude s = magnitude m_up / E near 1 and the mirror limit E -> 1."""
    mu, alpha = [0.0, 1e-6, 1e-4, 1e-2, 1.0], [0.0, 1e-6, 1e-4, 1e-3, 0.3, 2.0]
    ch = bsdf_tab.tabulate({"table": "ltc", "amplitude": "shading", "axes": {"mu": mu, "alpha": alpha}}).channels
    for name, v in ch.items():
        assert np.isfinite(v).all(), name
    for name in ("fit_l1", "fit_l1_clipped"):
        assert ((ch[name] >= 0.0) & (ch[name] <= 2.0)).all(), name
        assert (ch[f"{name}_err"][:, 0] == 2.0).all(), name
    np.testing.assert_allclose(ch["E"][1:, 0], 1.0, atol=1e-6)  # mirror limit (F = 1), mu > 0
    for i, j in [(3, 4), (4, 4), (4, 5), (2, 3)]:
        E = ref.albedo(mu[i], alpha[j], "ggx", "correlated")
        assert ch["E"][i, j] == pytest.approx(E.value, abs=ch["E_err"][i, j] + E.err + 1e-9)
    pos = ch["E"] > 1e-12  # the amplitude is meaningful where there is light to shade
    s = ch["magnitude"][pos] * ch["horizon"][pos] / ch["E"][pos]
    assert ((s > 0.5) & (s < 2.0)).all(), s
