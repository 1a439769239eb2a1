"""Beckmann's first inner piece in halves near o_r = n (issue 14, thirteenth round).

Near theta_m = theta_i / 2 Beckmann's inner phi integrand has the point o_r = n at phi = i y0
(Lambda is not analytic there): over the piece from phi = 0 one K15 is accurate (~1e-12 at mu 0.571,
alpha 0.714, theta_m 0.21) but its estimate is not (the Legendre pairs plateau before they fall:
7.0e-7, ~3e-7 of the integral), so at tight tolerances it is rejected and the piece bisected.
Where y0 < ``normal_split`` (0.3) times the piece, alpha > 0.5, the inner tolerance is below 3e-7
of the outer rule's previous inner integral and Lambda_o has weight in G (correlated: G1(i) > 0.1),
the piece starts in halves. Checked here:

* one such inner integral: the same value within its tolerance of dense Gauss-Legendre, with 30
  evaluations instead of 45, and only when the neighbour's size makes the tolerance tight;
* the Beckmann albedo: fewer evaluations at 5e-7, the same counts at 1e-3 (no split there), and
  texels of the band honest against the independent reference (tests/reference) at 5e-7 and 1e-7;
* GGX does not see it, nor a correlated texel at grazing incidence (values and counts bit for bit).
"""

from __future__ import annotations

import numpy as np
import warp as wp

from bsdf_tab.integrate import integrate_texels
from bsdf_tab.integrate.inner import inner_integral_scaled
from bsdf_tab.integrate.integrand import MODE_REFLECT, integrand_phi, make_texel
from tests.reference import microfacet_ref as ref

MU, ALPHA, THETA_M = 0.571, 0.714, 0.21


@wp.kernel
def _inner(scale: wp.array(dtype=wp.float64), split: wp.float64, out: wp.array2d(dtype=wp.float64)):
    k = wp.tid()
    p = make_texel(MODE_REFLECT, 1, 1, 0, wp.float64(0.0), wp.float64(0.0), wp.float64(MU), wp.float64(ALPHA),
                   wp.float64(1.0))
    # the method's inner settings (integrate_texels' defaults at 5e-7)
    p.err_model_inner = 2
    p.err_safety = wp.float64(1.0)
    p.err_power = wp.float64(3.0)
    p.inner_first = 5
    p.first_safety = wp.float64(8.0)
    p.second_safety = wp.float64(64.0)
    p.second_tail = wp.float64(0.1)
    p.first_share = wp.float64(1.0)
    p.inner_map = 1
    p.normal_map = wp.float64(0.03)
    p.normal_split = split
    cm = wp.cos(wp.float64(THETA_M))
    sm = wp.sin(wp.float64(THETA_M))
    r, e, used, used_ref = inner_integral_scaled(p, cm, sm, sm / cm, wp.float64(5e-7), 200, scale[k])
    out[k, 0] = r[0]
    out[k, 1] = e[0]
    out[k, 2] = wp.float64(used)


@wp.kernel
def _phi_values(phi: wp.array(dtype=wp.float64), out: wp.array(dtype=wp.float64)):
    k = wp.tid()
    p = make_texel(MODE_REFLECT, 1, 1, 0, wp.float64(0.0), wp.float64(0.0), wp.float64(MU), wp.float64(ALPHA),
                   wp.float64(1.0))
    cm = wp.cos(wp.float64(THETA_M))
    sm = wp.sin(wp.float64(THETA_M))
    out[k] = integrand_phi(p, cm, sm, sm / cm, phi[k])[0]


def _dense_reference():
    # the integrand is smooth on [0, pi] here (no cut: the horizon is not reached at this theta_m);
    # 400-point Gauss-Legendre is converged to rounding (its coefficients fall below 1e-14 by 60)
    x, w = np.polynomial.legendre.leggauss(400)
    phi = np.pi * (x + 1.0) / 2.0
    out = wp.zeros(phi.size, dtype=wp.float64, device="cpu")
    wp.launch(_phi_values, dim=phi.size, inputs=[wp.array(phi, dtype=wp.float64, device="cpu"), out], device="cpu")
    return float(np.pi / 2.0 * np.dot(w, out.numpy()))


def test_one_inner_integral_in_halves_only_where_the_tolerance_is_tight():
    exact = _dense_reference()
    # scale: unknown, a neighbour of the same size (2.79: the tolerance is 1.8e-7 of it), a
    # neighbour 10x smaller (the tolerance then 1.8e-6 of it: one K15 would do)
    scale = np.array([0.0, exact, exact / 10.0])
    out = wp.zeros((3, 3), dtype=wp.float64, device="cpu")
    for split, want in ((0.3, [45, 30, 45]), (0.0, [45, 45, 45])):
        wp.launch(_inner, dim=3, inputs=[wp.array(scale, dtype=wp.float64, device="cpu"), split, out], device="cpu")
        got = out.numpy()
        assert list(got[:, 2]) == want, (split, got[:, 2])
        # each within its estimate of the dense reference, and within the tolerance
        assert np.all(np.abs(got[:, 0] - exact) <= got[:, 1]), (got, exact)
        assert np.all(got[:, 1] <= 5e-7)


def _albedo_grid(n):
    mu = np.linspace(0.0, 1.0, n)
    alpha = np.linspace(0.0, 1.0, n)
    m, a = np.meshgrid(mu, alpha, indexing="ij")
    return m.ravel(), a.ravel()


def test_fewer_evaluations_at_tight_tolerances_none_saved_or_spent_at_loose_ones():
    mu, alpha = _albedo_grid(12)
    _, _, c = integrate_texels("reflect", mu, alpha, None, dist=1, tol=5e-7, return_cost=True)
    _, _, c0 = integrate_texels("reflect", mu, alpha, None, dist=1, tol=5e-7, return_cost=True, normal_split=0.0)
    # measured on the 32 x 32 albedo: 2271 -> 2126 evaluations per texel (-6.4%)
    assert c.sum() <= 0.97 * c0.sum(), (c.sum(), c0.sum())
    loose = [integrate_texels("reflect", mu, alpha, None, dist=1, tol=1e-3, return_cost=True, normal_split=s)
             for s in (0.3, 0.0)]
    for x, y in zip(*loose):
        assert np.array_equal(x, y)


def test_band_texels_are_honest_against_the_reference():
    texels = [(0.571, 0.714), (0.35, 0.9), (0.8, 0.6)]
    mu = np.array([m for m, _ in texels])
    alpha = np.array([a for _, a in texels])
    refs = [ref.albedo(m, a, "beckmann", "correlated") for m, a in texels]
    rv = np.array([r.value for r in refs])
    re = np.array([r.err for r in refs])
    for tol in (5e-7, 1e-7):
        v, e, c = integrate_texels("reflect", mu, alpha, None, dist=1, tol=tol, return_cost=True)
        _, _, c0 = integrate_texels("reflect", mu, alpha, None, dist=1, tol=tol, return_cost=True, normal_split=0.0)
        # the halves are taken on every one of them (fewer evaluations in all, not on each: 3403 /
        # 2908 / 2359 against 4468 / 3283 / 2311 at 5e-7)
        assert np.all(c != c0) and c.sum() < c0.sum(), (tol, c, c0)
        assert np.all(np.abs(v[:, 0] - rv) - re <= e[:, 0]), (tol, v[:, 0] - rv, e[:, 0])
        assert np.all(np.abs(v[:, 0] - rv) <= 1e-6)


def test_ggx_does_not_see_the_split():
    mu, alpha = _albedo_grid(9)
    a = integrate_texels("reflect", mu, alpha, None, tol=5e-7, return_cost=True)
    b = integrate_texels("reflect", mu, alpha, None, tol=5e-7, return_cost=True, normal_split=0.0)
    for x, y in zip(a, b):
        assert np.array_equal(x, y)


def test_no_halves_where_lambda_o_has_no_weight():
    # the correlated G / mu = 1 / (mu + li + mu Lambda_o) weighs Lambda_o by G1(i) = mu / (mu + li):
    # 0 at grazing incidence, where the halves cost +25% (measured at mu = 0, alpha 0.57 .. 1)
    mu = np.zeros(5)
    alpha = np.linspace(0.6, 1.0, 5)
    a = integrate_texels("reflect", mu, alpha, None, dist=1, tol=5e-7, return_cost=True)
    b = integrate_texels("reflect", mu, alpha, None, dist=1, tol=5e-7, return_cost=True, normal_split=0.0)
    for x, y in zip(a, b):
        assert np.array_equal(x, y)
