"""The adaptive method's D-tail mass bound (issue 14, third round).

:func:`bsdf_tab.integrate.integrand.mass_bound` must bound the outer integral over a piece of v
from above, always (it replaces heuristic estimates and lets the method leave the D tail out):

* the property of the D cos CDF it relies on at the horizon, m(t) <= alpha^2 / t^2 (m the mass
  beyond tan(theta_m) = t), for every registered distribution;
* the bound against band integrals of the table integrands computed here from the independent
  reference's point functions (``tests/reference/microfacet_ref.py``: D, G, Fresnel) by SciPy
  quadrature, including the tail to the horizon (the dielectric mode's last piece);
* whole texels whose tail is left out (small alpha, Beckmann's fast tail, grazing mu, total
  internal reflection, dfg, every Fresnel type): their reported error covers the true error
  against the reference's table integrals, and they cost fewer evaluations than without bounds.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import warp as wp
from scipy import integrate as sint

from bsdf_tab.integrate import integrate_texels
from bsdf_tab.integrate.integrand import MODES, make_texel, mass_bound
from bsdf_tab.model import DISTRIBUTIONS, FRESNELS, SHADOWINGS
from bsdf_tab.model.distribution import dcos_v_of_theta
from tests.reference import microfacet_ref as ref

DISTS = {i: name for name, i in DISTRIBUTIONS.items()}


@wp.kernel
def _bound_kernel(mode: wp.int32, dist: wp.int32, shadowing: wp.int32, ftype: wp.int32, fp0: wp.float64,
                  fp1: wp.float64, mu: wp.array(dtype=wp.float64), alpha: wp.array(dtype=wp.float64),
                  eta: wp.array(dtype=wp.float64), th_a: wp.array(dtype=wp.float64),
                  th_b: wp.array(dtype=wp.float64), out: wp.array(dtype=wp.float64),
                  v_out: wp.array2d(dtype=wp.float64)):
    k = wp.tid()
    p = make_texel(mode, dist, shadowing, ftype, fp0, fp1, mu[k], alpha[k], eta[k])
    va = dcos_v_of_theta(th_a[k], alpha[k], dist)
    vb = dcos_v_of_theta(th_b[k], alpha[k], dist)
    v_out[k, 0] = va
    v_out[k, 1] = vb
    out[k] = mass_bound(p, va, vb)


def _bounds(mode, dist, shadowing, mu, alpha, eta, th_a, th_b, ftype=0, fp0=0.0, fp1=0.0):
    n = len(mu)
    arr = [wp.array(np.asarray(x, dtype=np.float64), dtype=wp.float64, device="cpu") for x in (mu, alpha, eta, th_a, th_b)]
    out = wp.zeros(n, dtype=wp.float64, device="cpu")
    v = wp.zeros((n, 2), dtype=wp.float64, device="cpu")
    wp.launch(_bound_kernel, dim=n, inputs=[MODES[mode], dist, shadowing, ftype, float(fp0), float(fp1), *arr, out, v],
              device="cpu")
    return out.numpy(), v.numpy()


@pytest.mark.parametrize("dist", sorted(DISTS))
def test_tail_mass_is_at_most_alpha2_over_tan2(dist):
    # m(t) = (1 - v)^2 from the package's v(theta); the bound's horizon form needs m <= alpha^2 / t^2
    alpha = np.repeat([1e-3, 0.01, 0.1, 0.5, 1.0, 2.0, 4.0], 200)
    theta = np.tile(np.linspace(1e-3, 0.5 * math.pi - 1e-6, 200), 7)
    _, v = _bounds("reflect", dist, 1, np.ones_like(alpha), alpha, np.ones_like(alpha), theta, theta)
    m = (1.0 - v[:, 0]) ** 2
    t = np.tan(theta)
    # GGX's m = alpha^2 / (alpha^2 + t^2) meets the bound as t -> inf; 1e-7 is the rounding of
    # cos(theta) next to pi/2 (theta = pi/2 - 1e-6 here) in v against np.tan
    assert np.all(m <= alpha**2 / t**2 * (1 + 1e-7))
    away = theta < 1.5
    assert np.all(m[away] <= alpha[away] ** 2 / t[away] ** 2 * (1 + 1e-12))
    # and it is the D cos mass beyond theta (the reference's D, integrated here)
    for a, th in ((0.1, 0.3), (0.5, 1.0), (2.0, 0.7)):
        mass, _ = sint.quad(lambda x: 2 * math.pi * float(ref.D(DISTS[dist], math.cos(x), a)) * math.cos(x) * math.sin(x),
                            th, 0.5 * math.pi, epsabs=1e-14, epsrel=1e-11, limit=200)
        _, vv = _bounds("reflect", dist, 1, [1.0], [a], [1.0], [th], [th])
        assert abs((1.0 - vv[0, 0]) ** 2 - mass) <= 1e-9 * max(mass, 1e-3)


def _band(mode, dist, shad, mu, alpha, eta, th_a, th_b, fres=("one",)):
    """int over theta_m in [th_a, th_b] of each channel's F G D (i.m) / mu dw_m (the table
    integral's band), from the reference's point functions: SciPy's adaptive quad in theta_m,
    Gauss-Legendre in the azimuth split where i.m crosses the thresholds (square-root ends
    mapped away)."""
    sin_i = math.sqrt(max(0.0, 1.0 - mu * mu))
    wi = np.array([sin_i, 0.0, mu])
    dname = DISTS[dist]
    sname = {i: n for n, i in SHADOWINGS.items()}[shad]

    spec = fres if mode == "reflect" else ("dielectric", eta)
    xg, wg = np.polynomial.legendre.leggauss(64)
    sg = 0.5 * (xg + 1.0)
    smooth, dsmooth = 3 * sg**2 - 2 * sg**3, 6 * sg * (1 - sg)

    def points(th, ph):
        """(R, T) integrands at theta_m = th and the azimuths ph (vectorized)."""
        m = np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.full_like(ph, np.cos(th))], -1)
        c = m @ wi
        cp = np.maximum(c, 0.0)
        d = ref.D(dname, m[:, 2], alpha)
        o = 2 * cp[:, None] * m - wi
        f = np.array([ref.fresnel(float(x), spec) for x in cp])
        r = np.where((c > 0) & (o[:, 2] > 0), f * ref.G(dname, sname, wi, o, m, alpha) * d * cp / mu, 0.0)
        t = np.zeros_like(r)
        if mode == "dielectric":
            # o_t = (c / eta - sqrt(k2)) m - i / eta where k2 = 1 - (1 - c^2) / eta^2 > 0 (no TIR)
            k2 = 1.0 - (1.0 - cp * cp) / (eta * eta)
            ot = (cp / eta - np.sqrt(np.maximum(k2, 0.0)))[:, None] * m - wi / eta
            ok = (c > 0) & (k2 > 0) & (ot[:, 2] < 0)
            t = np.where(ok, (1 - f) * ref.G(dname, sname, wi, ot, m, alpha) * d * cp / mu, 0.0)
        return r, t

    def inner(th, ch):
        if sin_i == 0.0:
            return 2 * math.pi * points(th, np.zeros(1))[ch][0] * math.sin(th)
        # i.m = sin_i sin th cos ph + mu cos th: split where it crosses 0, mu / (2 cos th) and
        # sqrt(1 - eta^2); 64-node Gauss-Legendre on each piece after a smoothstep map
        cuts = [0.0, math.pi]
        for cb in (0.0, mu / (2 * math.cos(th)), math.sqrt(max(0.0, 1 - eta * eta)) if eta < 1 else -9.0):
            x = (cb - mu * math.cos(th)) / (sin_i * math.sin(th))
            if -1 < x < 1:
                cuts.append(math.acos(x))
        cuts = sorted(cuts)
        tot = 0.0
        for a, b in zip(cuts[:-1], cuts[1:]):
            vals = points(th, a + (b - a) * smooth)[ch]
            tot += 0.5 * (b - a) * float(np.sum(wg * vals * dsmooth))
        return 2 * tot * math.sin(th)

    out = []
    for ch in range(2 if mode == "dielectric" else 1):
        # theta = atan(alpha tan psi): unfolds the peak of D and reaches the horizon
        pa, pb = math.atan(math.tan(th_a) / alpha), math.atan(math.tan(th_b) / alpha) if th_b < 0.5 * math.pi else 0.5 * math.pi

        def outer(psi):
            th = math.atan(alpha * math.tan(psi))
            dth = alpha / (math.cos(psi) ** 2 + (alpha * math.sin(psi)) ** 2)
            return inner(th, ch) * dth

        out.append(sint.quad(outer, pa, pb, epsabs=1e-13, epsrel=1e-7, limit=100)[0])
    return out


# (mode, dist, shadowing, mu, alpha, eta, theta_a, theta_b): tails of small alpha, normal
# incidence (where the bound is nearly attained: bound / band 1.000 for mu = 1, 1.05 for T), grazing
# mu, the horizon (theta_b = pi/2; T at mu 0.9 is within 1.4x). Measured: the other cases are
# 2.3 .. 55x below their bounds (the sin(theta_i) tan(theta_m) term is the slack: cos(phi)
# averages out), so a bound too small by less than that would pass those.
BANDS = [
    ("reflect", 0, 0, 1.0, 0.01, 1.0, 0.2, 0.25 * math.pi),
    ("reflect", 1, 1, 1.0, 0.05, 1.0, 0.1, 0.25 * math.pi),
    ("reflect", 0, 1, 0.5, 0.02, 1.0, 0.4, 0.9),
    ("reflect", 1, 0, 0.5, 0.3, 1.0, 0.6, 1.1),
    ("reflect", 0, 0, 0.01, 0.05, 1.0, 0.8, 0.5 * (0.5 * math.pi + math.acos(0.01))),
    ("dielectric", 0, 1, 1.0, 0.02, 1.5, 0.3, 0.5 * math.pi),
    ("dielectric", 0, 1, 0.9, 0.01, 1.5, 0.3, 0.5 * math.pi),  # T within 1.4x of its bound
    ("dielectric", 1, 0, 0.3, 0.1, 0.7, 0.4, 0.5 * math.pi),
    ("dielectric", 0, 0, 0.8, 0.2, 0.5, 0.2, 0.7),
]


@pytest.mark.parametrize("case", BANDS, ids=[f"{c[0]}-{DISTS[c[1]]}-mu{c[3]}-a{c[4]}-eta{c[5]}-{c[6]:.2f}-{c[7]:.2f}" for c in BANDS])
def test_mass_bound_bounds_the_band_integral(case):
    mode, dist, shad, mu, alpha, eta, th_a, th_b = case
    b, _ = _bounds(mode, dist, shad, [mu], [alpha], [eta], [th_a], [th_b])
    assert b[0] > 0
    # the kernel integrates over phi in [0, pi] and v: its bound / pi bounds the table's band
    band = _band(mode, dist, shad, mu, alpha, eta, th_a, th_b)
    for val in band:
        assert val <= b[0] / math.pi, (val, b[0] / math.pi)
    # and it is not vacuous: within a factor 200 of the larger channel here
    assert b[0] / math.pi <= 200 * max(band) + 1e-12, (band, b[0] / math.pi)


def test_mass_bound_refuses_what_it_cannot_bound():
    # a mirror, Schlick outside [0, 1], a negative conductor index, [0, 1] whole in v with mu < 1
    b, _ = _bounds("reflect", 0, 1, [0.5], [0.0], [1.0], [0.1], [0.3])
    assert b[0] < 0
    b, _ = _bounds("reflect", 0, 1, [0.5], [0.1], [1.0], [0.1], [0.3], ftype=FRESNELS["schlick"], fp0=1.5)
    assert b[0] < 0
    b, _ = _bounds("reflect", 0, 1, [0.5], [0.1], [1.0], [0.1], [0.3], ftype=FRESNELS["conductor"], fp0=-1.0, fp1=1.0)
    assert b[0] < 0
    b, _ = _bounds("dielectric", 0, 1, [0.5], [0.1], [1.5], [0.0], [0.5 * math.pi])
    assert b[0] < 0


# whole texels whose D tail is left out: (mode, dist, shadowing, fresnel, mu, alpha, eta, tol)
TEXELS = [
    ("reflect", 0, 0, ("one",), 1.0, 0.001, 1.0, 1e-3),  # the bound nearly attained
    ("reflect", 1, 0, ("one",), 1.0, 0.1, 1.0, 1e-3),
    ("reflect", 1, 1, ("one",), 0.3, 0.05, 1.0, 1e-6),  # Beckmann's tail at a tight tolerance
    ("reflect", 1, 1, ("one",), 0.0, 0.05, 1.0, 1e-3),  # grazing (SPEC section 5)
    ("reflect", 0, 0, ("schlick", 0.3), 0.7, 0.005, 1.0, 1e-3),
    ("reflect", 0, 1, ("conductor", 0.2, 3.0), 0.4, 0.002, 1.0, 1e-4),
    ("reflect", 0, 1, ("dielectric", 0.6), 0.5, 0.003, 1.0, 1e-3),  # a critical angle
    ("dfg", 1, 0, None, 0.3, 0.1, 1.0, 1e-4),
    ("dielectric", 0, 1, None, 0.5, 0.01, 1.5, 1e-3),  # the horizon piece (tail form)
    ("dielectric", 0, 0, None, 0.2, 0.003, 0.6, 1e-3),  # total internal reflection
    ("dielectric", 1, 1, None, 0.7, 0.05, 1.3, 1e-5),
]


@pytest.fixture(scope="module")
def tail_texels():
    rows = []
    for mode, dist, shad, fres, mu, alpha, eta, tol in TEXELS:
        dname, sname = DISTS[dist], {i: n for n, i in SHADOWINGS.items()}[shad]
        if mode == "reflect":
            r = ref.albedo(mu, alpha, dname, sname, fres)
            rv, re = [r.value], [r.err]
        elif mode == "dfg":
            r = ref.dfg(mu, alpha, dname, sname)
            rv, re = [r[0].value, r[1].value], [r[0].err, r[1].err]
        else:
            r = ref.dielectric(mu, alpha, eta, dname, sname)
            rv, re = [r[0].value, r[1].value], [r[0].err, r[1].err]
        # on the floor's initial intervals (ramp_cut 0): the default start at tolerances >= 1e-3
        # (the G1 ramp cuts, issue 14 round 9) has fewer, longer ones, where a left-out tail
        # may be inside a longer interval and save nothing; and ungraded (outer_grade 0): the
        # grading below 1e-5 (round 11) and the tails left out at >= 1e-4 never meet by default
        kw = {"dist": dist, "shadowing": shad, "tol": tol, "ramp_cut": 0.0, "outer_grade": 0.0}
        if fres is not None and fres[0] != "one":
            kw.update(ftype=FRESNELS[fres[0]], fp0=fres[1], fp1=fres[2] if len(fres) > 2 else 0.0)
        out = {}
        for share in (0.25, -1.0):
            v, e, c = integrate_texels(mode, np.array([mu]), np.array([alpha]), np.array([eta]), return_cost=True,
                                       bound_share=share, **kw)
            out[share] = (v[0], e[0], int(c[0]))
        rows.append((mode, mu, alpha, eta, tol, np.array(rv), np.array(re), out))
    return rows


def test_left_out_tails_are_honest_and_cheaper(tail_texels):
    for mode, mu, alpha, eta, tol, rv, re, out in tail_texels:
        v, e, c = out[0.25]
        n = rv.size
        label = (mode, mu, alpha, eta, tol)
        # honest: the true error within the reported one (the reference's own bound aside)
        assert np.all(np.abs(v[:n] - rv) <= e[:n] + re), (label, v[:n], rv, e[:n])
        assert np.all(e[:n] <= 1.0001 * tol), (label, e[:n])
        # the tail was left out: fewer evaluations than the same texel without bounds
        assert c < out[-1.0][2], (label, c, out[-1.0][2])


def test_bounds_off_is_the_previous_method(tail_texels):
    # bound_share < 0 must not change anything but the bounds: the same texels stay honest
    for mode, mu, alpha, eta, tol, rv, re, out in tail_texels:
        v, e, _ = out[-1.0]
        n = rv.size
        assert np.all(np.abs(v[:n] - rv) <= e[:n] + re), (mode, mu, alpha, eta, tol)


def test_below_1e4_nothing_is_left_out():
    # the default leaves tails out only at tolerances >= 1e-4: at 5e-7 the values are those of
    # the cap alone (bound_share 0), bit for bit (tables there stay ~exact, tests/tables)
    rng = np.random.default_rng(14)
    mu, alpha = rng.uniform(0.05, 1.0, 12), 10 ** rng.uniform(-3, 0, 12)
    eta = rng.uniform(1.1, 2.0, 12)
    for mode in ("reflect", "dielectric"):
        for tol in (5e-7, 1e-5):
            v0, e0 = integrate_texels(mode, mu, alpha, eta, tol=tol)
            v1, e1 = integrate_texels(mode, mu, alpha, eta, tol=tol, bound_share=0.0)
            assert np.array_equal(v0, v1) and np.array_equal(e0, e1)
        # and at 1e-3 some tail of a near-mirror texel is left out (the values differ)
        va, _ = integrate_texels(mode, mu, alpha, eta, tol=1e-3)
        vb, _ = integrate_texels(mode, mu, alpha, eta, tol=1e-3, bound_share=0.0)
        assert not np.array_equal(va, vb)
