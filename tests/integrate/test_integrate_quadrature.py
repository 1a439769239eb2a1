"""The Gauss-Kronrod rule and the global-bisection routine of bsdf_tab.integrate.quadrature,
against closed forms: polynomial exactness of the constants, and adaptive integrals of
functions with a known integral (including a square-root endpoint the rule cannot resolve in
one step)."""

import math

import numpy as np
import pytest
import warp as wp

from bsdf_tab.integrate.quadrature import (
    GK_WG,
    GK_WK,
    GK_X,
    WG7_D,
    WGK_D,
    XGK_D,
    decay_ratio,
    end_map,
    gk_error,
    gk_error_decay,
    make_global_bisection,
    vec16d,
)


def test_gauss_kronrod_constants_are_exact_for_polynomials():
    # K15 integrates degree <= 22 exactly on [-1, 1], its Gauss 7 subset degree <= 13
    for k in range(23):
        exact = 0.0 if k % 2 else 2.0 / (k + 1)
        assert abs(np.dot(GK_WK, GK_X**k) - exact) < 1e-14, k
        if k <= 13:
            assert abs(np.dot(GK_WG, GK_X**k) - exact) < 1e-14, k
    # the Gauss nodes are the roots of P_7, with the Gauss-Legendre weights
    xg, wg = np.polynomial.legendre.leggauss(7)
    sel = GK_WG > 0
    order = np.argsort(GK_X[sel])
    np.testing.assert_allclose(GK_X[sel][order], xg, atol=1e-15)
    np.testing.assert_allclose(GK_WG[sel][order], wg, atol=1e-15)
    assert GK_X.size == 15 and np.unique(GK_X).size == 15


_vec15d = wp.types.vector(length=15, dtype=wp.float64)


@wp.func
def _rule(p: wp.vec2d, x: wp.float64, a: wp.float64, b: wp.float64):
    """G7-K15 of (sqrt(t - p[0]), t^2) over [a, b] (x: unused rule parameter)."""
    half = wp.float64(0.5)
    ctr = half * (a + b)
    hl = half * (b - a)
    rk = wp.vec2d(wp.float64(0.0), wp.float64(0.0))
    rg = wp.vec2d(wp.float64(0.0), wp.float64(0.0))
    fs = _vec15d()
    gs = _vec15d()
    for j in range(15):
        jj = j
        sgn = wp.float64(1.0)
        if j >= 8:
            jj = j - 8
            sgn = wp.float64(-1.0)
        t = ctr + sgn * hl * XGK_D[jj]
        f = wp.vec2d(wp.sqrt(wp.max(t - p[0], wp.float64(0.0))), t * t)
        fs[j] = f[0]
        gs[j] = f[1]
        rk += WGK_D[jj] * f
        rg += WG7_D[jj] * f
    mean = rk * half
    resasc = wp.vec2d(wp.float64(0.0), wp.float64(0.0))
    for j in range(15):
        jj = j
        if j >= 8:
            jj = j - 8
        resasc += WGK_D[jj] * wp.vec2d(wp.abs(fs[j] - mean[0]), wp.abs(gs[j] - mean[1]))
    return rk * hl, gk_error(rk * hl, rg * hl, resasc * hl, 1), int(1)


_bisect = make_global_bisection(_rule)


@wp.kernel
def _bisect_kernel(ends: wp.array(dtype=wp.vec4d), ne: wp.array(dtype=wp.int32), tol: wp.float64,
                   max_rules: wp.array(dtype=wp.int32), out: wp.array2d(dtype=wp.float64)):
    t = wp.tid()
    total, err, cost, cost_ref = _bisect(wp.vec2d(wp.float64(0.0), wp.float64(0.0)), wp.float64(0.0), ends[t],
                                         ne[t], tol, max_rules[t], int(0))
    out[t, 0] = total[0]
    out[t, 1] = total[1]
    out[t, 2] = err[0]
    out[t, 3] = err[1]
    out[t, 4] = wp.float64(cost)
    out[t, 5] = wp.float64(cost_ref)


def _run(cases, tol):
    ends = wp.array([np.array(c[0], dtype=np.float64) for c in cases], dtype=wp.vec4d, device="cpu")
    ne = wp.array([c[1] for c in cases], dtype=wp.int32, device="cpu")
    mr = wp.array([c[2] for c in cases], dtype=wp.int32, device="cpu")
    out = wp.zeros((len(cases), 6), dtype=wp.float64, device="cpu")
    wp.launch(_bisect_kernel, dim=len(cases), inputs=[ends, ne, tol, mr, out], device="cpu")
    return out.numpy()


@pytest.mark.parametrize("tol", [1e-6, 1e-10])
def test_global_bisection_meets_the_tolerance_honestly(tol):
    exact = np.array([2.0 / 3.0, 1.0 / 3.0])  # int_0^1 sqrt(t), t^2
    cases = [
        ((0.0, 1.0, 0.0, 0.0), 1, 400),  # one initial interval
        ((0.0, 0.25, 0.25, 1.0), 3, 400),  # several, one of them empty
        ((0.0, 1.0, 0.0, 0.0), 1, 3),  # capped: the estimate must stay honest
    ]
    out = _run(cases, tol)
    for k, (_, _, max_rules) in enumerate(cases):
        val, err, cost = out[k, :2], out[k, 2:4], out[k, 4]
        assert np.all(np.abs(val - exact) <= err + 1e-15), (k, val - exact, err)
        assert cost <= max_rules
        # refinement = everything beyond one rule per nonempty initial interval (bisections in pairs)
        n_init = 1 if k != 1 else 2
        assert out[k, 5] == cost - n_init and out[k, 5] % 2 == 0
        if max_rules >= 400:
            assert np.all(err <= tol), (k, err)
        else:
            assert err[0] > tol  # the square root is not resolved in 3 rules, and says so
    # the polynomial channel is exact from the first rule: its error is the rounding floor
    assert np.all(np.abs(out[:, 1] - 1.0 / 3.0) < 1e-15)


def test_one_interval_return_is_the_general_path_bit_for_bit():
    # issue 14, fifth round: one initial interval returns when its first rule is accepted, before
    # the stacks are built; the same interval beside two empty ones takes the general path
    for tol in (1e-1, 1e-2, 1e-4, 1e-8, 1e-12):
        one, general = _run([((0.0, 1.0, 0.0, 0.0), 1, 400), ((0.0, 1.0, 1.0, 1.0), 3, 400)], tol)
        assert np.array_equal(one, general), (tol, one, general)
        if tol == 1e-1:
            assert one[4] == 1 and one[5] == 0  # accepted at once: both branches are exercised
        if tol == 1e-12:
            assert one[4] > 3


# ------------------------------------------------------------------ the decay-ratio estimate (issue 14)


@wp.kernel
def _decay_kernel(fv: wp.array2d(dtype=wp.float64), out: wp.array(dtype=wp.float64)):
    t = wp.tid()
    f = vec16d()
    for j in range(15):
        f[j] = fv[t, j]
    out[t] = decay_ratio(f)


def _np_decay_ratio(f):
    # independent: least-squares Legendre fit of degree 14 through the 15 nodes (= interpolation),
    # coefficients turned orthonormal by sqrt((2k + 1) / 2)
    c = np.polynomial.legendre.legfit(GK_X, f, 14) / np.sqrt((2.0 * np.arange(15) + 1.0) / 2.0)
    a, b, cc = abs(c[13]) + abs(c[14]), abs(c[11]) + abs(c[12]), abs(c[9]) + abs(c[10])
    return max(a / b, b / cc)


def test_decay_ratio_reads_the_resolution_of_the_nodes():
    x = GK_X
    funcs = {
        "exp 2x": np.exp(2.0 * x),  # entire: fast decay
        "cos 3x": np.cos(3.0 * x),  # even: odd coefficients vanish, pairs still decay
        "pole near [-1, 1]": 1.0 / (1.0 + 25.0 * x**2),  # Runge: slow decay
        "sqrt endpoint": np.sqrt(x + 1.0),  # algebraic endpoint: not resolved
        "kink": np.abs(x - 0.3),
    }
    fv = wp.array(np.array(list(funcs.values())), dtype=wp.float64, device="cpu")
    out = wp.zeros(len(funcs), dtype=wp.float64, device="cpu")
    wp.launch(_decay_kernel, dim=len(funcs), inputs=[fv, out], device="cpu")
    r = dict(zip(funcs, out.numpy()))
    for name, f in funcs.items():
        # the top coefficients of the fast decays are ~1e-11: a few digits of agreement
        assert r[name] == pytest.approx(_np_decay_ratio(f), rel=1e-4), name
    assert r["exp 2x"] < 5e-2 and r["cos 3x"] < 0.1
    assert r["pole near [-1, 1]"] > 0.5 and r["sqrt endpoint"] > 0.5 and r["kink"] > 0.3


@wp.func
def _rule_decay(p: wp.vec2d, x: wp.float64, a: wp.float64, b: wp.float64):
    """G7-K15 of (sqrt(t - p[0]), 1 / (1 + 100 (t - 0.3)^2)) over [a, b], decay-ratio estimate."""
    half = wp.float64(0.5)
    ctr = half * (a + b)
    hl = half * (b - a)
    rk = wp.vec2d(wp.float64(0.0), wp.float64(0.0))
    rg = wp.vec2d(wp.float64(0.0), wp.float64(0.0))
    fs = vec16d()
    gs = vec16d()
    for j in range(15):
        jj = j
        sgn = wp.float64(1.0)
        if j >= 8:
            jj = j - 8
            sgn = wp.float64(-1.0)
        t = ctr + sgn * hl * XGK_D[jj]
        d = t - wp.float64(0.3)
        f = wp.vec2d(wp.sqrt(wp.max(t - p[0], wp.float64(0.0))), wp.float64(1.0) / (wp.float64(1.0) + wp.float64(100.0) * d * d))
        fs[j] = f[0]
        gs[j] = f[1]
        rk += WGK_D[jj] * f
        rg += WG7_D[jj] * f
    r = wp.vec2d(decay_ratio(fs), decay_ratio(gs))
    return rk * hl, gk_error_decay(rk * hl, rg * hl, r, wp.float64(1.0), wp.float64(3.0)), int(1)


_bisect_decay = make_global_bisection(_rule_decay)


@wp.kernel
def _bisect_decay_kernel(tol: wp.array(dtype=wp.float64), out: wp.array2d(dtype=wp.float64)):
    t = wp.tid()
    ends = wp.vec2d(wp.float64(0.0), wp.float64(1.0))
    total, err, cost, cost_ref = _bisect_decay(wp.vec2d(wp.float64(0.0), wp.float64(0.0)), wp.float64(0.0), ends,
                                               1, tol[t], 400, int(0))
    out[t, 0] = total[0]
    out[t, 1] = total[1]
    out[t, 2] = err[0]
    out[t, 3] = err[1]


def test_decay_estimate_stays_honest_on_singular_and_peaked_integrands():
    # int_0^1 sqrt(t) = 2/3 (endpoint singularity), int_0^1 1/(1 + 100 (t - 0.3)^2) =
    # (atan(7) + atan(3)) / 10 (a peak of width 0.1): every tolerance, true error <= reported
    tols = np.array([1e-3, 1e-5, 1e-7, 1e-9, 1e-11])
    exact = np.array([2.0 / 3.0, (math.atan(7.0) + math.atan(3.0)) / 10.0])
    out = wp.zeros((tols.size, 4), dtype=wp.float64, device="cpu")
    wp.launch(_bisect_decay_kernel, dim=tols.size, inputs=[wp.array(tols, dtype=wp.float64, device="cpu"), out],
              device="cpu")
    out = out.numpy()
    for k, tol in enumerate(tols):
        err = np.abs(out[k, :2] - exact)
        assert np.all(err <= out[k, 2:4]), (tol, err, out[k, 2:4])
        assert np.all(out[k, 2:4] <= tol), (tol, out[k, 2:4])


@wp.kernel
def _end_map_kernel(ends: int, t: wp.array(dtype=wp.float64), out: wp.array2d(dtype=wp.float64)):
    k = wp.tid()
    s, d = end_map(t[k], ends)
    out[k, 0] = s
    out[k, 1] = d


@pytest.mark.parametrize("ends", [0, 1, 2, 3])
def test_end_map_flattens_only_the_mapped_ends(ends):
    t = np.linspace(0.0, 1.0, 201)
    out = wp.zeros((t.size, 2), dtype=wp.float64, device="cpu")
    wp.launch(_end_map_kernel, dim=t.size, inputs=[ends, wp.array(t, dtype=wp.float64, device="cpu"), out],
              device="cpu")
    s, d = out.numpy().T
    assert s[0] == 0.0 and s[-1] == 1.0 and (np.diff(s) > 0).all()
    # ds/dt is the derivative of s (central differences: exact up to h^2 / 6 times the third derivative)
    np.testing.assert_allclose((s[2:] - s[:-2]) / (t[2:] - t[:-2]), d[1:-1], atol=1e-4)
    # Simpson over ds/dt (a polynomial of degree <= 2: exact) is the piece's length
    simpson = (d[0] + d[-1] + 4 * d[1:-1:2].sum() + 2 * d[2:-1:2].sum()) / 600.0
    assert simpson == pytest.approx(1.0, rel=1e-13)
    # a mapped end has ds/dt = 0 there (a square root of s becomes linear in t), an unmapped one not
    assert (d[0] == 0.0) == bool(ends & 1) and (d[-1] == 0.0) == bool(ends & 2)
    if ends & 1:
        ratio = np.sqrt(s[1:11]) / t[1:11]  # sqrt(s) ~ c t near a mapped start
        assert ratio.max() / ratio.min() < 1.05
