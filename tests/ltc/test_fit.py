"""The LTC lobe, the L1 metric and the fit, against independent quadrature written here.

Truth comes from quadrature written in this file (product Gauss-Legendre rules on the sphere,
SciPy's quad for the sphere term) of formulas written in this file (the LTC lobe), and from the
float64 reference of tests/reference (the BRDF, its albedo and split-sum terms), never from the
code under test.
"""

from __future__ import annotations

import functools
import math

import numpy as np
import pytest
from scipy import integrate

import bsdf_tab
from bsdf_tab.ltc import density, l1_metric, sphere_term
from bsdf_tab.ltc.fit import fit_lobe
from bsdf_tab.ltc.matrix import from_storage
from tests.reference import microfacet_ref as ref


def lobe(minv, L):
    """D(L) = max(0, (Minv L)_z) |det Minv| / (pi |Minv L|^4), written from Heitz et al. 2016."""
    l = np.asarray(L) @ np.asarray(minv).T
    n2 = np.sum(l * l, axis=-1)
    return np.maximum(l[..., 2], 0.0) * abs(np.linalg.det(minv)) / (math.pi * n2 * n2)


def direction(t, p):
    return np.stack(np.broadcast_arrays(np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)), axis=-1)


def gl(n, a, b, panels=1):
    """Composite Gauss-Legendre nodes and weights on [a, b] (written here, not the package's)."""
    x, w = np.polynomial.legendre.leggauss(n)
    e = np.linspace(a, b, panels + 1)
    h = 0.5 * np.diff(e)[:, None]
    return ((0.5 * (e[:-1] + e[1:]))[:, None] + h * x).ravel(), (h * w).ravel()


def sphere_grid(pole=(0.0, 0.0, 1.0), hemisphere=False, n=20, panels=30):
    """Directions and weights of a product rule in polar coordinates about ``pole``."""
    pole = np.asarray(pole, dtype=np.float64) / np.linalg.norm(pole)
    t, wt = gl(n, 0.0, 0.5 * math.pi if hemisphere else math.pi, panels)
    p, wp = gl(n, 0.0, 2.0 * math.pi, 2 * panels)
    T, P = np.meshgrid(t, p, indexing="ij")
    d = direction(T, P)
    helper = np.array([1.0, 0.0, 0.0]) if abs(pole[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = np.cross(pole, helper)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(pole, e1)
    d = d[..., 0:1] * e1 + d[..., 1:2] * e2 + d[..., 2:3] * pole
    return d.reshape(-1, 3), (np.outer(wt, wp) * np.sin(T)).ravel()


MINVS = [np.eye(3), np.array([[0.8, 0.0, -0.3], [0.0, 1.0, 0.0], [0.2, 0.0, 0.9]]),
         np.array([[1.9, 0.0, 0.7], [0.0, 1.3, 0.0], [-0.5, 0.0, 0.8]])]


@pytest.mark.parametrize("k", range(len(MINVS)))
def test_ltc_lobe_integrates_to_one(k):
    m = MINVS[k]
    # the lobe vanishes where (Minv L)_z < 0: integrate the smooth part, the hemisphere about Minv's row 2
    d, w = sphere_grid(pole=m[2], hemisphere=True)
    assert np.sum(w * lobe(m, d)) == pytest.approx(1.0, abs=1e-9)
    # the package's density is the same function
    L = direction(0.3 + 0.4 * np.arange(5), 0.7 * np.arange(5))
    np.testing.assert_allclose(density(m, L[None])[0], lobe(m, L), rtol=1e-13)


def cosine_nodes(n=24):
    """Quadrature of the cosine lobe cos/pi on the phi in [0, pi] half (weights of f dw)."""
    x, wx = np.polynomial.legendre.leggauss(n)
    u, wu = 0.5 * (x + 1.0), 0.5 * wx  # u = cos^2(theta): cos/pi dw = du dphi / (2 pi)
    p, wp = 0.5 * math.pi * (x + 1.0), 0.5 * math.pi * wx
    U, P = np.meshgrid(u, p, indexing="ij")
    c, s = np.sqrt(U), np.sqrt(1.0 - U)
    L = np.stack([s * np.cos(P), s * np.sin(P), c], axis=-1).reshape(1, -1, 3)
    f = (c / math.pi).reshape(1, -1)
    w = (np.outer(wu, wp) / math.pi).reshape(1, -1)  # 2 (phi symmetry) / (2 pi)
    return L, f, w


def test_identity_fit_of_a_cosine_brdf_has_zero_metric():
    L, f, w = cosine_nodes()
    assert w.sum() == pytest.approx(1.0, abs=1e-13)
    assert l1_metric(density(np.eye(3), L), f, w, np.ones(1))[0] == pytest.approx(0.0, abs=1e-13)
    # from a bad start, the fit returns to the identity (up to the scale an LTC ignores)
    e = fit_lobe(L, f, w, np.array([[1.6, 0.3, -0.4, 0.7]]))
    m = from_storage(*e[0])
    m = m / m[1, 1]
    np.testing.assert_allclose(m, np.eye(3), atol=2e-3)
    assert l1_metric(density(m, L), f, w, np.ones(1))[0] < 1e-3


def test_l1_metric_matches_quadrature_for_a_wrong_lobe():
    """L1 = 2 int max(T - D, 0) (both normalized): checked against int |D - T| over the sphere."""
    m = MINVS[1]
    L, f, w = cosine_nodes(48)
    got = l1_metric(density(m, L), f, w, np.ones(1))[0]
    d, wd = sphere_grid(n=16, panels=120)  # kinked integrand: many panels
    want = np.sum(wd * np.abs(lobe(m, d) - np.maximum(d[:, 2], 0.0) / math.pi))
    assert got == pytest.approx(want, abs=2e-5)


@functools.lru_cache(maxsize=8)
def _true_lobe(mu, alpha, dist, shadowing, E):
    """Nodes, weights and f_r cos / E of the upper hemisphere's fine product rule (independent of
    the matrix, so computed once per texel: the reference BRDF is the expensive part)."""
    wi = ref.wi_of_mu(mu)
    d, w = sphere_grid(hemisphere=True, n=16, panels=100)
    return d, w, ref.f_r(wi, d, alpha, dist, shadowing) * d[:, 2] / E


def brdf_lobe_l1(minv, mu, alpha, dist, shadowing, E):
    """int |D_ltc - f_r cos / E| over the sphere: the upper hemisphere by a fine product rule, the
    lower part is the LTC mass below the horizon (1 - its upper mass)."""
    d, w, T = _true_lobe(mu, alpha, dist, shadowing, E)
    D = lobe(minv, d)
    return np.sum(w * np.abs(D - T)) + (1.0 - np.sum(w * D))


@pytest.mark.parametrize("dist,shadowing,mu,alpha", [
    ("ggx", "correlated", 0.7, 0.45),
    ("beckmann", "separable", 0.3, 0.35),
])
def test_fit_metric_channel_against_quadrature(dist, shadowing, mu, alpha):
    t = bsdf_tab.tabulate({"table": "ltc", "distribution": dist, "shadowing": shadowing,
                           "axes": {"mu": [mu], "alpha": [alpha]}})
    c = {k: float(v[0, 0]) for k, v in t.channels.items()}
    minv = from_storage(c["Minv_00"], c["Minv_20"], c["Minv_02"], c["Minv_22"])
    E = ref.albedo(mu, alpha, dist, shadowing)
    assert c["E"] == pytest.approx(E.value, abs=c["E_err"] + E.err + 1e-9)
    want = brdf_lobe_l1(minv, mu, alpha, dist, shadowing, E.value)
    assert abs(c["fit_l1"] - want) <= c["fit_l1_err"] + 1e-5
    assert c["fit_l1_err"] < 0.02 and 0.0 < c["fit_l1"] <= 2.0
    # the fit is a minimum of what it minimizes (the clipped metric, the default horizon amplitude):
    # perturbing the matrix makes it worse
    from bsdf_tab.ltc.matrix import upper_mass

    clipped = clipped_l1_ref(minv, 1.0 / float(upper_mass(minv)), mu, alpha, dist, shadowing, E.value)
    assert abs(c["fit_l1_clipped"] - clipped) <= c["fit_l1_clipped_err"] + 1e-5
    assert c["fit_l1_clipped_err"] < 0.02 and 0.0 < c["fit_l1_clipped"] < 0.5
    for p in (np.diag([1.1, 1.0, 1.0]), np.diag([1.0, 1.0, 1.1])):
        worse = minv @ p
        assert clipped_l1_ref(worse, 1.0 / float(upper_mass(worse)), mu, alpha, dist, shadowing, E.value) > clipped


MU = [0.0, 1e-6, 1e-4, 1e-2, 0.5, 1.0]
ALPHA = [0.0, 1e-6, 1e-4, 1e-3, 0.3, 1.0, 2.0]


@pytest.fixture(scope="module")
def limits_table():
    return bsdf_tab.tabulate({"table": "ltc", "distribution": "ggx", "shadowing": "separable",
                              "axes": {"mu": MU, "alpha": ALPHA}})


def test_limits_finite_and_in_range(limits_table):
    ch = limits_table.channels
    for name, v in ch.items():
        assert np.isfinite(v).all(), name
    assert ((ch["fit_l1"] >= 0.0) & (ch["fit_l1"] <= 2.0)).all()
    # alpha = 0: a Dirac lobe has no density; the error channel says the metric means nothing there
    assert (ch["fit_l1_err"][:, 0] == 2.0).all()
    assert (ch["fit_l1_err"][:, 1:] < 2.0).all()
    # mirror limit: E -> 1 (F = 1)
    np.testing.assert_allclose(ch["E"][1:, 0], 1.0, atol=1e-6)
    assert ((ch["horizon"] > 0.0) & (ch["horizon"] <= 1.0)).all()
    np.testing.assert_allclose(ch["magnitude"], ch["E"] / ch["horizon"], rtol=1e-15)
    # grazing is continuous: mu = 0 and mu = 1e-6 give nearly the same fit quality where alpha >> 1e-6
    # (at alpha = 1e-6 the two views differ on the lobe's own scale); near the mirror (alpha 1e-4, 1e-3:
    # a lobe cut in half by the horizon, metric error channels ~0.03) within the metrics' error channels
    for name in ("fit_l1", "fit_l1_clipped"):
        np.testing.assert_allclose(ch[name][0, 4:], ch[name][1, 4:], atol=2e-3)
        assert (np.abs(ch[name][0, 2:4] - ch[name][1, 2:4]) <= ch[f"{name}_err"][0, 2:4] + ch[f"{name}_err"][1, 2:4]).all()


def test_limits_albedo_and_fresnel_against_reference(limits_table):
    ch = limits_table.channels
    for i, j in [(3, 4), (4, 5), (5, 6), (4, 3)]:
        E = ref.albedo(MU[i], ALPHA[j], "ggx", "separable")
        A, B = ref.dfg(MU[i], ALPHA[j], "ggx", "separable")
        assert ch["E"][i, j] == pytest.approx(E.value, abs=ch["E_err"][i, j] + E.err + 1e-9)
        assert ch["fresnel"][i, j] == pytest.approx(B.value, abs=ch["fresnel_err"][i, j] + B.err + 1e-9)


@pytest.mark.parametrize("j", [2, 3])
def test_near_mirror_lobe_concentrates(limits_table, j):
    """alpha -> 0: the fitted lobe's mass lies within a few alpha of the mirror direction."""
    ch = limits_table.channels
    i = MU.index(0.5)
    minv = from_storage(ch["Minv_00"][i, j], ch["Minv_20"][i, j], ch["Minv_02"][i, j], ch["Minv_22"][i, j])
    alpha = ALPHA[j]
    mirror = np.array([-math.sqrt(1 - 0.25), 0.0, 0.5])
    e1 = np.array([0.5, 0.0, math.sqrt(0.75)])
    e2 = np.array([0.0, 1.0, 0.0])
    cone = 30.0 * alpha
    t, wt = gl(20, 0.0, cone, 20)
    p, wp = gl(20, 0.0, 2.0 * math.pi, 4)
    T, P = np.meshgrid(t, p, indexing="ij")
    d = (np.cos(T)[..., None] * mirror + np.sin(T)[..., None] * (np.cos(P)[..., None] * e1 + np.sin(P)[..., None] * e2))
    mass = np.sum(np.outer(wt, wp) * np.sin(T) * lobe(minv, d))
    assert mass > 0.9
    assert ch["fit_l1"][i, j] < 0.05


def test_deterministic_and_independent_of_workers():
    spec = {"table": "ltc", "axes": {"mu": [0.05, 0.4, 0.9], "roughness": [0.1, 0.5, 0.9]}}
    a = bsdf_tab.tabulate(spec, workers=1).channels
    b = bsdf_tab.tabulate(spec, workers=2).channels
    for name in a:
        np.testing.assert_array_equal(a[name], b[name])


@pytest.mark.parametrize("z,l", [(0.9, 0.1), (0.2, 0.5), (-0.1, 0.3), (0.5, 0.95), (-0.6, 0.7)])
def test_sphere_term_against_cap_quadrature(z, l):
    """Cap of half-angle sigma about polar angle omega: in cap coordinates (b, g) the height is
    cos b cos omega - sin b sin omega cos g; its positive part integrates over g in closed form
    (2 (c (pi - gm) + s sin gm), gm = acos(clip(c / s))) and the outer integral is SciPy's quad."""
    omega, sigma = math.acos(z), math.asin(math.sqrt(l))

    def inner(b):
        c, s = math.cos(b) * math.cos(omega), math.sin(b) * math.sin(omega)
        if s <= 0.0:
            return 2.0 * math.pi * max(c, 0.0) * math.sin(b)
        gm = math.acos(min(1.0, max(-1.0, c / s)))  # positive for g in [gm, 2 pi - gm]
        return 2.0 * (c * (math.pi - gm) + s * math.sin(gm)) * math.sin(b)

    kinks = [b for b in (abs(0.5 * math.pi - omega),) if 0.0 < b < sigma]
    val, _ = integrate.quad(inner, 0.0, sigma, points=kinks or None, epsabs=1e-13, epsrel=1e-12, limit=200)
    assert float(sphere_term(z, l)) == pytest.approx(val / (math.pi * l), abs=1e-9)
    assert float(sphere_term(z, 0.0)) == max(z, 0.0)


@pytest.mark.parametrize("dist", ["ggx", "beckmann"])
@pytest.mark.parametrize("shadowing", ["separable", "correlated"])
def test_lobe_value_matches_reference_brdf(dist, shadowing):
    from bsdf_tab.ltc import lobe_value

    rng = np.random.default_rng(3)
    L = rng.normal(size=(300, 3))
    L /= np.linalg.norm(L, axis=1, keepdims=True)
    for mu, alpha in [(0.3, 0.2), (0.9, 0.7), (0.05, 1.5), (1.0, 0.01)]:
        want = ref.f_r(ref.wi_of_mu(mu), L, alpha, dist, shadowing) * np.maximum(L[:, 2], 0.0)
        np.testing.assert_allclose(lobe_value(dist, shadowing, mu, alpha, L), want, rtol=1e-12, atol=1e-300)


#: the upper hemisphere as four spherical triangles (zenith and two horizon points each, wound outward)
OCTANTS = np.array([[[0.0, 0.0, 1.0], [c, s, 0.0], [-s, c, 0.0]] for c, s in ((1, 0), (0, 1), (-1, 0), (0, -1))])


def test_upper_mass_closed_form_against_quadrature():
    """m_up = (1 + n_z) / 2 (n along M's row 2) against the lobe integrated over L_z > 0 here."""
    from bsdf_tab.ltc import polygon_integral
    from bsdf_tab.ltc.matrix import storage, upper_mass, upper_mass_entries

    flipped = np.array([[-0.7, 0.0, 0.4], [0.0, 1.0, 0.0], [0.6, 0.0, 0.5]])  # det < 0
    d, w = sphere_grid(hemisphere=True, n=16, panels=100)  # the kink (Minv L)_z = 0: many panels
    for m in MINVS + [flipped]:
        want = np.sum(w * lobe(m, d))
        assert float(upper_mass(m)) == pytest.approx(want, abs=2e-5)
        # the same mass from Lambert's edge sums over the four octant triangles of the upper hemisphere
        # (a Minv with det < 0 reverses the winding: abs)
        assert float(upper_mass(m)) == pytest.approx(abs(float(polygon_integral(OCTANTS, m[None]).sum())), abs=1e-12)
        e, _ = storage(m)
        assert float(upper_mass_entries(e)) == pytest.approx(float(upper_mass(m)), abs=1e-14)
    assert float(upper_mass(np.eye(3))) == 1.0
    assert max(float(upper_mass(m)) for m in MINVS[1:] + [flipped]) < 0.99  # lobes with mass below the horizon


def clipped_l1_ref(minv, amp, mu, alpha, dist, shadowing, E):
    """int over L_z > 0 of |amp D_ltc - f_r cos / E| by a fine product rule, written here."""
    d, w, T = _true_lobe(mu, alpha, dist, shadowing, E)
    return np.sum(w * np.abs(amp * lobe(minv, d) - T))


@pytest.mark.parametrize("amplitude", ["horizon", "albedo"])
def test_amplitude_and_clipped_metric_against_quadrature(amplitude):
    from bsdf_tab.ltc import polygon_integral

    mu, alpha, dist, shadowing = 0.2, 0.5, "ggx", "correlated"
    t = bsdf_tab.tabulate({"table": "ltc", "distribution": dist, "shadowing": shadowing, "amplitude": amplitude,
                           "axes": {"mu": [mu], "alpha": [alpha]}})
    c = {k: float(v[0, 0]) for k, v in t.channels.items()}
    minv = from_storage(c["Minv_00"], c["Minv_20"], c["Minv_02"], c["Minv_22"])
    E = ref.albedo(mu, alpha, dist, shadowing)
    whole = c["magnitude"] * float(polygon_integral(OCTANTS, minv[None]).sum())  # the whole upper hemisphere as the light
    if amplitude == "horizon":
        # the horizon-mass amplitude shades the whole-hemisphere light exactly: E (the reference albedo)
        assert whole == pytest.approx(E.value, abs=c["magnitude_err"] + E.err + 1e-9)
        assert c["horizon"] < 1.0 - 1e-4  # this texel's lobe has mass below the horizon (the test means something)
    else:
        assert c["magnitude"] == c["E"]
        assert c["magnitude_fresnel"] == c["fresnel"]
        assert whole == pytest.approx(c["horizon"] * E.value, rel=1e-9)
    rel = c["magnitude"] / E.value
    want = clipped_l1_ref(minv, rel, mu, alpha, dist, shadowing, E.value)
    assert abs(c["fit_l1_clipped"] - want) <= c["fit_l1_clipped_err"] + 1e-5
    # the fit minimizes the clipped metric with the horizon amplitude (and fit_l1 with the albedo one)
    worse = minv @ np.diag([1.1, 1.0, 1.0])
    if amplitude == "horizon":
        from bsdf_tab.ltc.matrix import upper_mass

        assert clipped_l1_ref(worse, 1.0 / float(upper_mass(worse)), mu, alpha, dist, shadowing, E.value) > want
    else:
        assert brdf_lobe_l1(worse, mu, alpha, dist, shadowing, E.value) > brdf_lobe_l1(minv, mu, alpha, dist,
                                                                                      shadowing, E.value)


def test_amplitude_key_is_validated():
    with pytest.raises(bsdf_tab.SpecError, match="amplitude"):
        bsdf_tab.tabulate({"table": "ltc", "amplitude": "energy", "axes": {"mu": [0.5], "alpha": [0.5]}})
    with pytest.raises(bsdf_tab.SpecError, match="amplitude"):
        bsdf_tab.tabulate({"table": "dfg", "amplitude": "horizon", "axes": {"mu": [0.5], "alpha": [0.5]}})


def test_clipped_objective_kernel_matches_numpy():
    from bsdf_tab.ltc.fit import Objective

    mu, alpha = np.array([0.05, 0.5, 0.95]), np.array([0.3, 0.6, 0.9])
    X = np.array([[1.2, 0.3, -0.5, 0.8], [0.7, -0.6, 0.2, 1.1], [-0.9, 0.4, 0.3, 0.6]])  # the last: det < 0
    idx = np.arange(3)
    for clipped in (False, True):
        a = Objective("ggx", "correlated", mu, alpha, clipped=clipped)(idx, X)
        b = Objective("ggx", "correlated", mu, alpha, backend="numpy", clipped=clipped)(idx, X)
        np.testing.assert_allclose(a, b, rtol=1e-12)


def test_polish_tasks_overlap_the_fit_chains():
    """fit_table queues each row's polish as its own task while the block's chain goes on
    (fit._run_chained): a queued task runs on a free thread before the task that queued it ends;
    every queued task runs; with one worker each runs right after the task that queued it; the
    first exception is raised and the tasks still queued behind it are cancelled."""
    import threading

    from bsdf_tab.ltc.fit import _run_chained

    ran = []

    def chain(submit):
        done = threading.Event()
        submit(lambda: (ran.append("polish"), done.set()))
        # with two workers the queued task runs on the other thread while this one waits
        assert done.wait(10.0), "the queued task did not run while its chain was still running"
        ran.append("chain")

    _run_chained([chain], workers=2)
    assert ran == ["polish", "chain"]

    order = []
    _run_chained([lambda s, k=k: (order.append(f"fit{k}"), s(lambda k=k: order.append(f"polish{k}"))) for k in range(3)],
                 workers=1)
    assert order == ["fit0", "polish0", "fit1", "polish1", "fit2", "polish2"]

    count = []
    _run_chained([lambda s: [s(lambda: count.append(1)) for _ in range(50)] for _ in range(4)], workers=2)
    assert len(count) == 200

    started = []
    gate = threading.Event()

    def failing_chain(submit):
        def boom():
            raise ValueError("polish failed")
        submit(boom)
        for _ in range(100):
            submit(lambda: (gate.wait(0.01), started.append(1)))

    with pytest.raises(ValueError, match="polish failed"):
        _run_chained([failing_chain], workers=2)
    gate.set()
    assert len(started) < 100  # the rest of the queue was cancelled, not run
