"""Stability of every integration method in the regimes of SPEC section 5.

For each method of :data:`bsdf_tab.integrate.METHODS` at a small effort: no NaN/inf, values
in [0, 1], R + T <= 1, the correct limits (mirror alpha -> 0, the GGX closed forms, total
internal reflection), and honesty: where a method cannot reach the accuracy, its error channel
is large (|value - truth| <= error), never a small wrong number. Truth here is independent of
bsdf_tab: the float64 NumPy/SciPy reference of tests/reference/ (the exact mirror limit at
alpha = 0) or a closed form. Tiny grids keep this file well under a minute. Distributions and
shadowing modes come from the model's registries.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from bsdf_tab.errors import SpecError
from bsdf_tab.integrate import METHODS
from bsdf_tab.integrate.integrand import MIRROR_ROUNDING
from bsdf_tab.model import DISTRIBUTIONS, SHADOWINGS
from bsdf_tab.spec import normalize_spec
from tests.reference import microfacet_ref as ref

# small efforts: fast, and low enough that the hard regimes are out of reach
EFFORT = {"grid": 2048, "mc_cosine": 512, "mc_dcos": 512, "mc_vndf": 512, "qmc_vndf": 512, "vndf_gl": 256}
FIXED = sorted(EFFORT)
ALL = ["adaptive"] + FIXED

MU = np.array([0.0, 1e-6, 1e-4, 1e-2, 0.5, 1.0])
ALPHA = np.array([0.0, 1e-6, 1e-4, 1e-3, 0.3, 1.0, 2.0])
ETA = [1 - 1e-4, 1.0, 1 + 1e-6, 1.01, 1.5, 1 / 1.5]


def _run(method, mode, mu, alpha, eta=None, dist=DISTRIBUTIONS["ggx"], shadowing=SHADOWINGS["correlated"], **kw):
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


DISTS = {i: name for name, i in DISTRIBUTIONS.items()}
SHADS = {i: name for name, i in SHADOWINGS.items()}
# the reference is validated (its two quadratures agree to ~1e-10) for alpha in [1e-4, 2]
REF_MIN_ALPHA = 1e-4


def _closed_form(mode, mu, alpha, eta, dist, shadowing):
    """The texels with an exact value, or None. alpha = 0: the mirror, E = F(mu) = 1 and
    R = F_dielectric(mu), T = 1 - R, mu = 0 included as the limit mu -> 0+ (the convention of
    every alpha > 0 texel, and of the reference there; at exactly mu = alpha = 0 the reference
    returns 0 instead). eta = 1: no interface, R = 0 and T = G(i, -i) / G1(i), i.e.
    (1 + Lambda) / (1 + 2 Lambda) correlated, 1 / (1 + Lambda) separable (-> 1/2 resp. 0 at
    mu = 0, where the reference's micro-normal integral is degenerate: o = -i is grazing too)."""
    if mode == "dielectric" and eta == 1.0:
        lam = float(ref.Lambda(DISTS[dist], mu, alpha))
        if math.isinf(lam):
            t = 0.5 if shadowing == 1 else 0.0
        else:
            t = (1.0 + lam) / (1.0 + 2.0 * lam) if shadowing == 1 else 1.0 / (1.0 + lam)
        return (0.0, t)
    if alpha == 0:
        if mode == "reflect":
            return (1.0,)
        f = float(ref.F_dielectric(mu, eta))  # 1 at mu = 0 (grazing limit, eta != 1)
        return (f, 1.0 - f)
    return None


def _ref_texel(mode, mu, alpha, eta, dist, shadowing):
    """(values, bounds) of one texel: a closed form where there is one, else the reference's
    method B (composite Gauss-Legendre at two resolutions; its bound is their difference):
    ~20 ms a texel, where the full two-method reference costs 0.3-4 s. Method A is checked
    against B in test_accuracy.py and tests/reference/README.md."""
    exact = _closed_form(mode, mu, alpha, eta, dist, shadowing)
    if exact is not None:
        return exact, (0.0,) * len(exact)
    if mode == "reflect":
        refs = (ref.albedo(mu, alpha, DISTS[dist], SHADS[shadowing], ("one",), True, "B"),)
    else:
        refs = ref.dielectric(mu, alpha, eta, DISTS[dist], SHADS[shadowing], True, "B")
    extra = _roundoff_bound(alpha, dist, shadowing)
    return tuple(r.value for r in refs), tuple(r.err + extra for r in refs)


def _roundoff_bound(alpha, dist, shadowing):
    """Extra bound for the reference below its validated range. At alpha = 1e-6 the micro-normals
    that matter have cos(theta_m) within ~1e-12 of 1, so the reference's D(cos theta_m) loses
    ~1e-4 relative precision to the cancellation in 1 - cos^2 (its two quadratures then differ by
    ~1e-5). That bias is measured on a closed form: at mu = 1 with F = 1, E = 1 - O(alpha^2)
    (~1e-12 at alpha = 1e-6), so |E_ref(1) - 1| is the reference's own normalization error;
    three times it bounds the texels of other mu (checked against method A: |A - B| <= 1.1e-5
    where this bound is ~3e-5, still far below the fixed methods' errors at this alpha)."""
    if alpha >= REF_MIN_ALPHA:
        return 0.0
    bias = abs(ref.albedo(1.0, alpha, DISTS[dist], SHADS[shadowing], ("one",), True, "B").value - 1.0)
    assert bias < 1e-4, f"reference normalization error {bias:.3g} at alpha={alpha}: not usable as truth"
    return 3.0 * bias


@pytest.fixture(scope="module")
def truth():
    """Independent reference (tests/reference/microfacet_ref.py, float64 NumPy/SciPy) on the same
    texels, as (values, bounds) of shape (N, channels); cached per (mode, dist, shadowing, eta)."""
    cache = {}

    def get(mode, dist, shadowing, eta=None):
        key = (mode, dist, shadowing, eta)
        if key not in cache:
            mu, alpha, _ = _grid(eta)
            nch = 1 if mode == "reflect" else 2
            tv = np.zeros((mu.size, nch))
            te = np.zeros((mu.size, nch))
            for k, (m, a) in enumerate(zip(mu, alpha)):
                vals, errs = _ref_texel(mode, float(m), float(a), eta, dist, shadowing)
                tv[k] = vals
                te[k] = errs
            cache[key] = tv, te
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
@pytest.mark.parametrize("dist", list(DISTS))
def test_albedo_regimes(method, dist, truth):
    """Grazing mu, near-mirror and very rough alpha, both shadowing modes."""
    for shad in SHADS:
        mu, alpha, _ = _grid()
        v, e = _run(method, "reflect", mu, alpha, dist=dist, shadowing=shad)
        _check_basic(v, e, False)
        tv, te = truth("reflect", dist, shad)
        _check_honest(v, e, tv, te, 1, f"{method} albedo dist={dist} shad={shad}")
        # alpha = 0 is the mirror: E = F = 1 exactly (for mu > 0), reported with the closed
        # forms' rounding bound
        mirror = (alpha == 0) & (mu > 0)
        assert np.allclose(v[mirror, 0], 1.0) and (e[mirror] <= MIRROR_ROUNDING).all()


@pytest.mark.parametrize("method", FIXED)
@pytest.mark.parametrize("eta", ETA)
def test_dielectric_regimes(method, eta, truth):
    """eta near 1 (half-vector singularity), TIR (eta < 1), grazing, near-mirror."""
    mu, alpha, etas = _grid(eta)
    v, e = _run(method, "dielectric", mu, alpha, etas, dist=DISTRIBUTIONS["ggx"], shadowing=SHADOWINGS["correlated"])
    _check_basic(v, e, True)
    tv, te = truth("dielectric", DISTRIBUTIONS["ggx"], SHADOWINGS["correlated"], eta)
    _check_honest(v, e, tv, te, 2, f"{method} dielectric eta={eta}")


def _check_within(v, e, nch):
    # finite, and in [0, 1] up to the reported error (at mu = 0 a loose tolerance gives E = 1 + a
    # few ulp, as the floor's start gave 1 + 1e-9 there: both within their error channels)
    assert np.isfinite(v).all() and np.isfinite(e).all() and (e >= 0).all()
    assert (v[:, :nch] >= -e[:, :nch]).all() and (v[:, :nch] <= 1 + e[:, :nch]).all()
    assert (v[:, :nch].sum(axis=1) <= 1 + e[:, :nch].sum(axis=1) + 1e-12).all()


@pytest.mark.parametrize("tol", [1e-2, 1e-3])
def test_adaptive_loose_start_regimes(tol, truth):
    """The adaptive method's start at tolerances >= 1e-3 (the G1 ramp cuts instead of the floor,
    issue 14 round 9; ``ramp_cut=0`` is the floor) on the same regimes: honest, and no more than
    the tolerance reported where the reference is validated."""
    for dist in DISTS:
        for shad in SHADS:
            mu, alpha, _ = _grid()
            v, e = _run("adaptive", "reflect", mu, alpha, dist=dist, shadowing=shad, tol=tol)
            _check_within(v, e, 1)
            tv, te = truth("reflect", dist, shad)
            _check_honest(v, e, tv, te, 1, f"adaptive tol={tol} albedo dist={dist} shad={shad}")
            assert (e[alpha >= REF_MIN_ALPHA, 0] <= tol).all()
    for eta in ETA:
        mu, alpha, etas = _grid(eta)
        v, e = _run("adaptive", "dielectric", mu, alpha, etas, tol=tol)
        _check_within(v, e, 2)
        tv, te = truth("dielectric", DISTRIBUTIONS["ggx"], SHADOWINGS["correlated"], eta)
        _check_honest(v, e, tv, te, 2, f"adaptive tol={tol} dielectric eta={eta}")
        assert (e[alpha >= REF_MIN_ALPHA] <= tol).all()


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
    for shad in SHADS:
        v, e = _run(method, "reflect", np.array([1.0]), np.array([1.0]), shadowing=shad)
        assert abs(v[0, 0] - exact) <= e[0, 0] + 1e-9
        assert e[0, 0] < 0.1  # and the method does get close here
    v, e = _run(method, "reflect", np.array([1e-6]), np.array([1.0]), shadowing=SHADOWINGS["separable"])
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
    # the full reference (both quadratures, strict agreement): GGX, correlated, F = 1
    refs = [ref.albedo(float(m), float(a), "ggx", "correlated") for m, a in zip(mu, alpha)]
    tv = np.array([r.value for r in refs])
    te = np.array([r.err for r in refs])
    lo = _run(method, "reflect", mu, alpha, effort=EFFORT[method])
    hi = _run(method, "reflect", mu, alpha, effort=16 * EFFORT[method])
    assert hi[1][:, 0].max() < lo[1][:, 0].max()
    assert np.abs(hi[0][:, 0] - tv).max() <= hi[1][:, 0].max() + te.max()


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


def test_vndf_gl_floor_covers_the_total_internal_reflection_jump():
    # the accuracy sweep's two dishonest vndf_gl texels (4096 nodes, GGX correlated, eta 1/1.5):
    # the weight jumps at total internal reflection, where two Gauss-Legendre orders can agree by
    # chance; with a floor of one coarse cell they reported 9.77e-4 for true errors of 9.79e-4
    # and 1.04e-3 (0.9987 of the sweep honest); the floor is two cells now
    from bsdf_tab.integrate import vndf_gl

    mu, alpha = np.array([0.45, 1.0]), np.array([0.2, 0.75])
    eta = np.full(2, 1.0 / 1.5)
    v, e = vndf_gl.integrate_texels("dielectric", mu, alpha, eta, dist=DISTRIBUTIONS["ggx"],
                                    shadowing=SHADOWINGS["correlated"], effort=4096)
    for k in range(2):
        r = ref.dielectric(mu[k], alpha[k], eta[k], "ggx", "correlated", methods="B")
        assert abs(v[k, 0] - r[0].value) > 9e-4  # the regime: an error the size of the floor
        for ch in range(2):
            assert abs(v[k, ch] - r[ch].value) <= e[k, ch] + r[ch].err, (k, ch, v[k], e[k])
