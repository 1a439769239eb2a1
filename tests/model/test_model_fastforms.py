"""The model's fused forms of issue 14 against mpmath, over the whole domain.

* ``beckmann_ierfc_scaled`` (piecewise polynomials, no erfc) and the Beckmann ``lambda_cos``
  built on it: a -> 0, the interval ends, a -> inf (where the old two-term form cancelled);
* ``smith_G_over_cos_i_to`` (GGX: one root and one division) for both Smith forms;
* ``fresnel_dielectric_refract`` (F and the refraction coefficient from one root and one
  division): eta near 1, eta = 1, total internal reflection, grazing.

References are evaluated by mpmath at 40 digits from the exact double inputs, written here
from the papers' formulas (Walter et al. 2007 eqs. 22, 27, 40; Heitz 2014), not from the code.
"""

import math

import mpmath as mp
import numpy as np
import pytest
import warp as wp

from bsdf_tab.model.beckmann import beckmann_ierfc_scaled, beckmann_lambda_cos
from bsdf_tab.model.distribution import DISTRIBUTIONS
from bsdf_tab.model.fresnel import fresnel_dielectric_refract
from bsdf_tab.model.shadowing import SHADOWINGS, smith_G_over_cos_i_to

EPS = 2.0**-52
mp.mp.dps = 40


@wp.kernel
def _k_h(a: wp.array(dtype=wp.float64), out: wp.array(dtype=wp.float64)):
    i = wp.tid()
    out[i] = beckmann_ierfc_scaled(a[i])


@wp.kernel
def _k_h32(a: wp.array(dtype=wp.float32), out: wp.array(dtype=wp.float32)):
    i = wp.tid()
    out[i] = beckmann_ierfc_scaled(a[i])


@wp.kernel
def _k_lc(z: wp.array(dtype=wp.float64), al: wp.array(dtype=wp.float64), out: wp.array(dtype=wp.float64)):
    i = wp.tid()
    out[i] = beckmann_lambda_cos(z[i], al[i])


@wp.kernel
def _k_g(zi: wp.array(dtype=wp.float64), li: wp.array(dtype=wp.float64), zo: wp.array(dtype=wp.float64),
         al: wp.array(dtype=wp.float64), dist: wp.int32, shad: wp.int32, out: wp.array(dtype=wp.float64)):
    i = wp.tid()
    out[i] = smith_G_over_cos_i_to(zi[i], li[i], zo[i], al[i], dist, shad)


@wp.kernel
def _k_f(c: wp.array(dtype=wp.float64), eta: wp.array(dtype=wp.float64), out: wp.array2d(dtype=wp.float64)):
    i = wp.tid()
    f, d, ok = fresnel_dielectric_refract(c[i], eta[i])
    out[i, 0] = f
    out[i, 1] = d
    out[i, 2] = wp.where(ok, wp.float64(1.0), wp.float64(0.0))


def _run(kernel, n, *inputs, shape=None, dtype=wp.float64):
    arrs = [wp.array(np.asarray(x), dtype=dtype, device="cpu") if isinstance(x, np.ndarray) else x for x in inputs]
    out = wp.zeros(shape or n, dtype=dtype, device="cpu")
    wp.launch(kernel, dim=n, inputs=[*arrs, out], device="cpu")
    return out.numpy()


def _h_ref(a):
    # exp(a^2) ierfc(a), ierfc(a) = exp(-a^2) / sqrt(pi) - a erfc(a) (the integral of erfc)
    a = mp.mpf(a)
    if a > 1e6:
        # the asymptotic series (Abramowitz and Stegun 7.1.23 integrated), error < 15 / (4 a^6)
        return (1 - mp.mpf(3) / (2 * a * a)) / (2 * mp.sqrt(mp.pi) * a * a)
    return 1 / mp.sqrt(mp.pi) - a * mp.erfc(a) * mp.exp(a * a)


def _lambda_ggx(z, alpha):
    z, alpha = mp.mpf(z), mp.mpf(alpha)
    if z == 0:
        return mp.inf
    t2 = (1 - z * z) / (z * z)
    return (-1 + mp.sqrt(1 + alpha * alpha * t2)) / 2


def _lambda_beckmann(z, alpha):
    z, alpha = mp.mpf(z), mp.mpf(alpha)
    if z == 0:
        return mp.inf
    s = mp.sqrt(1 - z * z)
    if s == 0:
        return mp.mpf(0)
    a = z / (alpha * s)
    # Walter et al. 2007 eq. 27, exact, with erf(a) - 1 = -erfc(a) (40 digits absorb the cancellation)
    return -mp.erfc(a) / 2 + mp.exp(-a * a) / (2 * a * mp.sqrt(mp.pi))


def _h_points():
    rng = np.random.default_rng(7)
    ends = np.array([k / 4 for k in range(13)])
    near = np.concatenate([np.nextafter(ends, -1.0), ends, np.nextafter(ends, 4.0)])
    return np.concatenate([
        [0.0, 5e-324, 1e-300, 1e-17, 1e-8, 1e-3, 4.0, 6.0, 8.0, 26.0, 27.5, 1e3, 1e8, 1e150],
        near[near >= 0.0],
        rng.uniform(0.0, 3.0, 3000),
        np.exp(rng.uniform(math.log(3.0), math.log(1e9), 1500)),
    ])


def test_ierfc_scaled_within_3_ulp_of_mpmath():
    a = _h_points()
    got = _run(_k_h, a.size, a)
    ref = np.array([float(_h_ref(x)) for x in a])
    rel = np.abs(got - ref) / ref
    worst = int(np.argmax(rel))
    # a < 3: the polynomials (interpolation error < 3.7e-17); a >= 3 adds u = 1 / a^2's two roundings
    assert rel.max() <= 3.0 * EPS, f"h({a[worst]!r}) = {got[worst]!r}, mpmath {ref[worst]!r}: {rel.max() / EPS:.2f} ulp"


def test_ierfc_scaled_limits():
    a = np.array([0.0, np.inf, 1e200])
    got = _run(_k_h, a.size, a)
    assert got[0] == pytest.approx(1.0 / math.sqrt(math.pi), rel=EPS)
    assert got[1] == 0.0
    # h ~ 1 / (2 sqrt(pi) a^2): underflows to 0 far beyond float64's use of it, never nan
    assert got[2] == 0.0


def test_ierfc_scaled_float32():
    a = np.concatenate([np.linspace(0.0, 3.0, 301), np.geomspace(3.0, 1e19, 200), [np.float32(np.inf)]]).astype(np.float32)
    got = _run(_k_h32, a.size, a, dtype=wp.float32)
    ref = np.array([float(_h_ref(float(x))) if np.isfinite(x) else 0.0 for x in a])
    assert np.all(np.isfinite(got))
    np.testing.assert_allclose(got, ref, rtol=2e-6, atol=1e-37)


def test_beckmann_lambda_cos_against_eq27():
    rng = np.random.default_rng(11)
    n = 1500
    z = np.concatenate([rng.uniform(0.0, 1.0, n), 10 ** rng.uniform(-6, 0, n // 3), [0.0, 1e-6, 1.0, 1 - 1e-12]])
    al = np.concatenate([10 ** rng.uniform(-6, math.log10(4.0), z.size - 4), [0.3, 4.0, 0.5, 1e-6]])
    # the SPEC section 5 regimes: alpha -> 0, alpha = 4, grazing 0 / 1e-6, normal incidence
    z = np.concatenate([z, [0.0, 1e-6, 0.5, 0.99]])
    al = np.concatenate([al, [4.0, 4.0, 1e-6, 1e-6]])
    got = _run(_k_lc, z.size, z, al)
    for zj, aj, gj in zip(z, al, got):
        s = mp.sqrt(1 - mp.mpf(zj) ** 2)
        if zj == 0.0:
            exact = mp.mpf(aj) / (2 * mp.sqrt(mp.pi))  # the grazing limit
        else:
            exact = mp.mpf(zj) * _lambda_beckmann(zj, aj)
        if exact == 0 or s == 0:
            assert gj == 0.0
            continue
        a = float(mp.mpf(zj) / (mp.mpf(aj) * s))
        if exact < mp.mpf(2.0) ** -1000:
            # exp(-a^2) reaches the subnormals: absolute accuracy only
            assert abs(gj - float(exact)) <= 2.0**-1000
            continue
        # the rounding of a = z / (alpha s), s = sqrt(1 - z^2) (relative 3 + z^2 / (1 - z^2) eps: the
        # cancellation in 1 - z^2), moves the value by (2 a^2 + 2) times it (the condition number)
        da = 3.0 + zj * zj / (1.0 - zj * zj)
        assert abs(gj - float(exact)) <= float(exact) * EPS * (8.0 + (2.0 * a * a + 2.0) * da), (zj, aj, gj, float(exact))


def _g_ref(dist, shad, zi, zo, alpha):
    # G / zi with zi Lambda_i and zo Lambda_o (finite at grazing): correlated
    # 1 / (zi (1 + L_i + L_o)) = zo / (zi zo + lc_i zo + lc_o zi), separable
    # 1 / (zi (1 + L_i)(1 + L_o)) = zo / ((zi + lc_i)(zo + lc_o))
    zi_, zo_ = mp.mpf(zi), mp.mpf(zo)
    lci, lco = _lc_ref(dist, zi, alpha), _lc_ref(dist, zo, alpha)
    if shad == "correlated":
        return zo_ / (zi_ * zo_ + lci * zo_ + lco * zi_)
    return zo_ / ((zi_ + lci) * (zo_ + lco))


def _lc_ref(dist, z, alpha):
    if z == 0:
        if dist == "ggx":
            return mp.mpf(alpha) / 2
        return mp.mpf(alpha) / (2 * mp.sqrt(mp.pi))
    lam = _lambda_ggx if dist == "ggx" else _lambda_beckmann
    return mp.mpf(z) * lam(z, alpha)


@pytest.mark.parametrize("dist", sorted(DISTRIBUTIONS))
@pytest.mark.parametrize("shad", sorted(SHADOWINGS))
def test_smith_G_over_cos_i_to_against_lambda(dist, shad):
    rng = np.random.default_rng(5)
    n = 400
    zi = np.concatenate([rng.uniform(0.0, 1.0, n), [0.0, 1e-6, 1.0, 0.5, 0.5, 1e-6]])
    zo = np.concatenate([rng.uniform(0.0, 1.0, n // 2), 10 ** rng.uniform(-6, 0, n - n // 2), [0.5, 0.5, 1e-6, 0.0, 1.0, 1e-6]])
    al = np.concatenate([10 ** rng.uniform(-6, math.log10(4.0), n), [4.0, 1e-6, 4.0, 0.2, 1e-6, 4.0]])
    # around Beckmann's a = zo / (alpha sin_o) = 6, where the integrand's form stops forming Lambda_o
    for alpha in (0.01, 0.3, 2.0):
        z6 = 6.0 * alpha / math.sqrt(1.0 + 36.0 * alpha * alpha)
        zo = np.concatenate([zo, [np.nextafter(z6, 0.0), z6, np.nextafter(z6, 1.0), 0.999 * z6, 1.001 * z6]])
        zi = np.concatenate([zi, [0.3, 0.7, 1e-3, 1.0, 0.05]])
        al = np.concatenate([al, [alpha] * 5])
    li = np.array([float(_lc_ref(dist, a, b)) for a, b in zip(zi, al)])
    got = _run(_k_g, zi.size, zi, li, zo, al, DISTRIBUTIONS[dist], SHADOWINGS[shad])
    for j in range(zi.size):
        exact = _g_ref(dist, shad, zi[j], zo[j], al[j])
        # li is rounded (1/2 ulp); both lambda_cos read s = sqrt(1 - zo^2) (the cancellation in
        # 1 - zo^2), the Beckmann one with its condition number 2 a^2 + 2 in a = zo / (alpha s)
        da = 3.0 + zo[j] ** 2 / (1.0 - zo[j] ** 2) if zo[j] < 1.0 else 3.0
        cond = 1.0
        if dist == "beckmann" and 0.0 < zo[j] < 1.0:
            cond = 2.0 * zo[j] ** 2 / (al[j] ** 2 * (1.0 - zo[j] ** 2)) + 2.0
        tol = EPS * (8.0 + cond * da) * abs(float(exact))
        assert abs(got[j] - float(exact)) <= tol, (dist, shad, zi[j], zo[j], al[j], got[j], float(exact))


def _fresnel_ref(c, eta):
    c, eta = mp.mpf(c), mp.mpf(eta)
    g2 = eta * eta - 1 + c * c
    if g2 <= 0:
        return mp.mpf(1), mp.mpf(0), False
    g = mp.sqrt(g2)
    f = (g - c) ** 2 / (2 * (g + c) ** 2) * (1 + ((c * (g + c) - 1) / (c * (g - c) + 1)) ** 2)
    # o_t = (c / eta - sqrt(1 - (1 - c^2) / eta^2)) m - i / eta (Walter eq. 40); d = eta times the first
    d = eta * (c / eta - mp.sqrt(1 - (1 - c * c) / (eta * eta)))
    return f, d, True


def test_fresnel_dielectric_refract_against_eq22():
    rng = np.random.default_rng(3)
    n = 1500
    c = np.concatenate([rng.uniform(0.0, 1.0, n), 10 ** rng.uniform(-8, 0, n // 3)])
    eta = np.concatenate([10 ** rng.uniform(math.log10(0.25), math.log10(4.0), n), 1.0 + rng.choice([-1, 1], n // 3)
                          * 10 ** rng.uniform(-12, -2, n // 3)])
    # eta near 1 at every c, the critical angle's neighbourhood, grazing, normal incidence
    c = np.concatenate([c, [1.0, 1.0, 1e-8, 0.5, math.sqrt(1 - 0.5**2), np.nextafter(math.sqrt(0.75), 1.0), 0.3]])
    eta = np.concatenate([eta, [1.5, 1 / 1.5, 1 + 1e-6, 1 - 1e-6, 0.5, 0.5, 4.0]])
    got = _run(_k_f, c.size, c, eta, shape=(c.size, 3))
    for j in range(c.size):
        f, d, ok = _fresnel_ref(c[j], eta[j])
        g2 = float(mp.mpf(eta[j]) ** 2 - 1 + mp.mpf(c[j]) ** 2)
        if abs(g2) <= 4 * EPS:
            # within the rounding of e + c^2 of the critical angle: either side is right
            continue
        assert bool(got[j, 2]) == ok, (c[j], eta[j])
        if not ok:
            assert got[j, 0] == 1.0 and got[j, 1] == 0.0
            continue
        # g = sqrt(e + c^2) amplifies the rounding of e + c^2 near the critical angle: by c^2 / g^2
        # in g, c / g in F (dF / dg is bounded)
        amp = 1.0 + c[j] ** 2 / g2
        # no cancellation near eta = 1: relative accuracy of F even where F ~ (eta - 1)^2
        tol_f = 16 * EPS * (1.0 + c[j] / math.sqrt(g2)) * float(f)
        assert abs(got[j, 0] - float(f)) <= tol_f + 1e-320, (c[j], eta[j], got[j, 0], float(f))
        assert abs(got[j, 1] - float(d)) <= 8 * EPS * amp * abs(float(d)) + 1e-320, (c[j], eta[j], got[j, 1], float(d))


def test_fresnel_dielectric_refract_eta_one():
    c = np.array([1e-8, 0.3, 1.0])
    got = _run(_k_f, c.size, c, np.ones(3), shape=(3, 3))
    np.testing.assert_array_equal(got[:, 0], 0.0)
    np.testing.assert_array_equal(got[:, 1], 0.0)
    np.testing.assert_array_equal(got[:, 2], 1.0)
