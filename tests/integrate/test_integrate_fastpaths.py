"""The adaptive kernel's per-evaluation shortcuts (issue 14, fifth round) against independent values.

Each shortcut must give the value of the general computation it replaces (bit for bit, or within
the last bits where said): the phi cosine :func:`cos_0_pi` against the C library's ``cos``
(through NumPy, and mpmath where they differ); the one-interval return of the global bisection
against the same interval run through the general path; :func:`gk_error_decay`'s pow-free
branches against the formula d min(1, safety r^power) written in NumPy.
"""

import math

import numpy as np
import pytest
import warp as wp

from bsdf_tab.integrate.integrand import cos_0_pi
from bsdf_tab.integrate.quadrature import WG7_D, WGK_D, XGK_D, gk_error, gk_error_decay, make_global_bisection

wp.init()


@wp.kernel
def _cos_kernel(x: wp.array(dtype=wp.float64), y: wp.array(dtype=wp.float64)):
    i = wp.tid()
    y[i] = cos_0_pi(x[i])


def test_cos_0_pi_is_libm_cos_within_one_ulp_of_one():
    rng = np.random.default_rng(5)
    q = math.pi / 4.0
    # the documented domain [-pi/4, 5 pi/4], its three branch points and pi/2 (cos = 0) closely
    edges = np.concatenate([c + np.linspace(-1e-9, 1e-9, 201) for c in (q, math.pi / 2.0, 3.0 * q)])
    x = np.concatenate([rng.uniform(-q, 5.0 * q, 200_000), edges,
                        [0.0, math.pi, np.nextafter(math.pi, 4.0), -1e-300, 5.0 * q]])
    xa = wp.array(x, dtype=wp.float64, device="cpu")
    ya = wp.zeros_like(xa)
    wp.launch(_cos_kernel, dim=x.size, inputs=[xa, ya], device="cpu")
    y = ya.numpy()
    diff = np.abs(y - np.cos(x))
    # the integrand needs i.m = sin_i sin(theta_m) cos(phi) + mu cos(theta_m) to ~1e-16 absolute
    assert diff.max() <= 2.3e-16, (x[np.argmax(diff)], diff.max())
    # relative accuracy where cos is not small (1 ulp of the value)
    big = np.abs(np.cos(x)) > 1e-3
    assert np.all(diff[big] <= np.spacing(np.abs(np.cos(x[big])))), "more than 1 ulp off"
    # near pi/2 the reduction keeps relative accuracy too (pi/2 in two parts): check by mpmath
    mpmath = pytest.importorskip("mpmath")
    mpmath.mp.dps = 40
    near = x[np.abs(x - math.pi / 2.0) < 1e-9][::20]
    yn = y[np.abs(x - math.pi / 2.0) < 1e-9][::20]
    exact = np.array([float(mpmath.cos(mpmath.mpf(float(v)))) for v in near])
    assert np.all(np.abs(yn - exact) <= 4.0 * np.spacing(np.abs(exact))), np.max(np.abs(yn - exact) / np.spacing(np.abs(exact)))


@wp.func
def _rule(p: wp.vec2d, x: wp.float64, a: wp.float64, b: wp.float64):
    """G7-K15 of (sqrt(t), t^2) over [a, b], QUADPACK's estimate; cost 1 per application."""
    half = wp.float64(0.5)
    ctr = half * (a + b)
    hl = half * (b - a)
    rk = wp.vec2d(wp.float64(0.0), wp.float64(0.0))
    rg = wp.vec2d(wp.float64(0.0), wp.float64(0.0))
    for j in range(15):
        jj = j
        sgn = wp.float64(1.0)
        if j >= 8:
            jj = j - 8
            sgn = wp.float64(-1.0)
        t = ctr + sgn * hl * XGK_D[jj]
        f = wp.vec2d(wp.sqrt(wp.max(t, wp.float64(0.0))), t * t)
        rk += WGK_D[jj] * f
        rg += WG7_D[jj] * f
    # resasc = |K| (a coarse stand-in; both paths below use the same rule)
    return rk * hl, gk_error(rk * hl, rg * hl, wp.vec2d(wp.abs(rk[0]), wp.abs(rk[1])) * hl, 0), int(1)


_bisect = make_global_bisection(_rule)


@wp.kernel
def _paths_kernel(tol: wp.array(dtype=wp.float64), out: wp.array2d(dtype=wp.float64)):
    t = wp.tid()
    zero = wp.float64(0.0)
    one = wp.float64(1.0)
    # the same interval [0, 1]: alone (the one-interval return), and beside two empty ones (the
    # general path, which builds the stacks first)
    r1, e1, c1, f1 = _bisect(wp.vec2d(zero, zero), zero, wp.vec2d(zero, one), 1, tol[t], 400, int(0))
    r3, e3, c3, f3 = _bisect(wp.vec2d(zero, zero), zero, wp.vec4d(zero, one, one, one), 3, tol[t], 400, int(0))
    out[t, 0] = r1[0]
    out[t, 1] = r1[1]
    out[t, 2] = e1[0]
    out[t, 3] = e1[1]
    out[t, 4] = wp.float64(c1)
    out[t, 5] = wp.float64(f1)
    out[t, 6] = r3[0]
    out[t, 7] = r3[1]
    out[t, 8] = e3[0]
    out[t, 9] = e3[1]
    out[t, 10] = wp.float64(c3)
    out[t, 11] = wp.float64(f3)


def test_one_interval_return_is_the_general_path_bit_for_bit():
    tols = np.array([1e-1, 1e-2, 1e-4, 1e-8, 1e-12])
    out = wp.zeros((tols.size, 12), dtype=wp.float64, device="cpu")
    wp.launch(_paths_kernel, dim=tols.size, inputs=[wp.array(tols, dtype=wp.float64, device="cpu"), out], device="cpu")
    out = out.numpy()
    assert np.array_equal(out[:, :6], out[:, 6:]), out
    # the loosest tolerance is met by the first rule (one application, no refinement), the
    # tightest needs bisections: both branches of the shortcut are exercised
    assert out[0, 4] == 1 and out[0, 5] == 0
    assert out[-1, 4] > 3 and out[-1, 5] == out[-1, 4] - 1
    # and the values are the integrals (2/3 and 1/3) within the reported errors
    assert np.all(np.abs(out[:, :2] - [2.0 / 3.0, 1.0 / 3.0]) <= out[:, 2:4] + 1e-15)


@wp.kernel
def _decay_err_kernel(v: wp.array2d(dtype=wp.float64), out: wp.array2d(dtype=wp.float64)):
    t = wp.tid()
    e = gk_error_decay(wp.vec2d(v[t, 0], v[t, 1]), wp.vec2d(v[t, 2], v[t, 3]), wp.vec2d(v[t, 4], v[t, 5]),
                       v[t, 6], v[t, 7])
    out[t, 0] = e[0]
    out[t, 1] = e[1]


def test_decay_error_shortcuts_keep_the_formula():
    rows = []
    for r in (0.0, 1e-3, 0.37, 0.999, 1.0, 2.5):
        for safety in (1.0, 0.5, 3.0):
            for power in (3.0, 2.5):
                rows.append((0.8, 0.0, 0.3, 0.0, r, 0.0, safety, power))
    v = np.array(rows)
    out = wp.zeros((len(rows), 2), dtype=wp.float64, device="cpu")
    wp.launch(_decay_err_kernel, dim=len(rows), inputs=[wp.array(v, dtype=wp.float64, device="cpu"), out],
              device="cpu")
    out = out.numpy()
    d = np.abs(v[:, 0] - v[:, 2])
    expect = np.maximum(d * np.minimum(1.0, v[:, 6] * v[:, 4] ** v[:, 7]), 1.1e-14 * np.abs(v[:, 0]))
    # r^3 is formed as r r r (2 roundings): the last bits only
    assert np.allclose(out[:, 0], expect, rtol=4e-16, atol=0.0), np.c_[v[:, 4:], out[:, 0], expect]
    # channel 1 (K = G = 0): the floor 0
    assert np.all(out[:, 1] == 0.0)
