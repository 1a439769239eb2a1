"""The adaptive kernel's per-evaluation shortcuts (issue 14, fifth round) against independent values.

Each shortcut must give the value of the general computation it replaces (bit for bit, or within
the last bits where said): the phi cosine :func:`cos_0_pi` against the C library's ``cos``
(through NumPy, and mpmath near pi/2); the cuts' :func:`acos_poly` against mpmath (tenth round); :func:`gk_error_decay`'s pow-free branches against the
formula d min(1, safety r^power) written in NumPy. The one-interval return of the global
bisection is tested in ``test_integrate_quadrature.py`` against the general path.
"""

import math

import numpy as np
import pytest
import warp as wp

from bsdf_tab.integrate.integrand import acos_poly, cos_0_pi
from bsdf_tab.integrate.quadrature import gk_error_decay

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


@wp.kernel
def _acos_kernel(x: wp.array(dtype=wp.float64), y: wp.array(dtype=wp.float64)):
    i = wp.tid()
    y[i] = acos_poly(x[i])


def test_acos_poly_within_one_ulp_of_mpmath():
    mpmath = pytest.importorskip("mpmath")
    rng = np.random.default_rng(2)
    # the whole domain, both ends approached to 1e-16, the branch points +-1/2 closely, 0 and +-1
    x = np.concatenate([rng.uniform(-1.0, 1.0, 4000), 1.0 - 10 ** rng.uniform(-16, 0, 800),
                        -1.0 + 10 ** rng.uniform(-16, 0, 800), 0.5 + np.linspace(-1e-9, 1e-9, 101),
                        -0.5 + np.linspace(-1e-9, 1e-9, 101),
                        [0.0, -0.0, 1.0, -1.0, np.nextafter(0.5, 1.0), np.nextafter(-0.5, -1.0)]])
    xa = wp.array(x, dtype=wp.float64, device="cpu")
    ya = wp.zeros_like(xa)
    wp.launch(_acos_kernel, dim=x.size, inputs=[xa, ya], device="cpu")
    y = ya.numpy()
    with mpmath.workdps(40):
        exact = np.array([float(mpmath.acos(mpmath.mpf(float(v)))) for v in x])
    ulp = np.abs(y - exact) / np.spacing(np.maximum(exact, 1e-300))
    assert ulp.max() <= 1.0, (x[np.argmax(ulp)], ulp.max())
    assert y[x == 1.0].tolist() == [0.0] and np.all(y[x == -1.0] == math.pi)
    # outside the domain and nan: nan, as acos's
    xb = wp.array(np.array([1.0 + 1e-15, -1.5, np.inf, np.nan]), dtype=wp.float64, device="cpu")
    yb = wp.zeros_like(xb)
    wp.launch(_acos_kernel, dim=4, inputs=[xb, yb], device="cpu")
    assert np.all(np.isnan(yb.numpy()))


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
