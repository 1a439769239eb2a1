"""The float64 Beckmann ierfc (native table code, issue 14) against mpmath.

``beckmann_ierfc`` is ierfc(a) = int_a^inf erfc(t) dt; its float64 overload evaluates the
coefficients of :mod:`bsdf_tab.model.ierfc_table` in native code. Here the coefficients are
refitted (they must be the Chebyshev interpolants the module says they are), the values are
checked against 40-digit mpmath from the definition exp(-a^2) / sqrt(pi) - a erfc(a) at the piece
ends, the switch to the tail form, the underflow cut, 0, inf and nan, and the adjoint against
-erfc(a). The generic (float32) overload keeps its own form. ``beckmann_ierfc_abs`` (8 of the
same pieces' coefficients, for the integrand's G) against its absolute promise, and the
``beckmann_lambda_cos_abs`` built on it against z + |cos| Lambda, the sum G adds it to.
"""

import math

import mpmath as mp
import numpy as np
import pytest
import warp as wp

from bsdf_tab.model.beckmann import beckmann_ierfc, beckmann_ierfc_abs, beckmann_lambda_cos_abs
from bsdf_tab.model.ierfc_table import IERFC_A_MAX, IERFC_PER_UNIT, IERFC_PIECES, IERFC_TAIL

EPS = 2.0**-52


@wp.kernel
def _k_ierfc(a: wp.array(dtype=wp.float64), out: wp.array(dtype=wp.float64)):
    i = wp.tid()
    out[i] = beckmann_ierfc(a[i])


@wp.kernel
def _k_ierfc32(a: wp.array(dtype=wp.float32), out: wp.array(dtype=wp.float32)):
    i = wp.tid()
    out[i] = beckmann_ierfc(a[i])


@wp.kernel(enable_backward=True)
def _k_ierfc_grad(a: wp.array(dtype=wp.float64), out: wp.array(dtype=wp.float64)):
    i = wp.tid()
    out[i] = beckmann_ierfc(a[i])


@wp.kernel
def _k_ierfc_abs(a: wp.array(dtype=wp.float64), out: wp.array(dtype=wp.float64)):
    i = wp.tid()
    out[i] = beckmann_ierfc_abs(a[i])


@wp.kernel
def _k_lambda_cos_abs(z: wp.array(dtype=wp.float64), al: wp.array(dtype=wp.float64), out: wp.array(dtype=wp.float64)):
    i = wp.tid()
    out[i] = beckmann_lambda_cos_abs(z[i], al[i])


def _run(kernel, a, dtype=wp.float64):
    x = wp.array(np.asarray(a), dtype=dtype, device="cpu")
    out = wp.zeros(len(a), dtype=dtype, device="cpu")
    wp.launch(kernel, dim=len(a), inputs=[x, out], device="cpu")
    return out.numpy()


def _ierfc_ref(a):
    # the definition at 40 digits (its two terms cancel at large a: 40 digits absorb that up to
    # a ~ 1e8, beyond which the value is far below float64's range anyway)
    with mp.workdps(40):
        a = mp.mpf(a)
        return mp.exp(-a * a) / mp.sqrt(mp.pi) - a * mp.erfc(a)


def _points():
    rng = np.random.default_rng(3)
    ends = np.array([k / IERFC_PER_UNIT for k in range(int(IERFC_A_MAX * IERFC_PER_UNIT) + 1)])
    near = np.concatenate([np.nextafter(ends, -1.0), ends, np.nextafter(ends, 100.0)])
    return np.concatenate([
        [0.0, 5e-324, 1e-300, 1e-17, 1e-8, 1e-3, 6.5, 10.0, 20.0, 26.0, 26.5],
        near[near >= 0.0],
        rng.uniform(0.0, IERFC_A_MAX, 3000),
        rng.uniform(IERFC_A_MAX, 26.6, 600),
    ])


def test_ierfc_float64_within_4_ulp_of_mpmath():
    a = _points()
    got = _run(_k_ierfc, a)
    ref = np.array([float(_ierfc_ref(x)) for x in a])
    # near a^2 = 708 the values are subnormal: absolute accuracy there
    sub = ref < 2.0**-1022
    assert np.all(np.abs(got[sub] - ref[sub]) <= 2.0**-1060)
    rel = np.abs(got - ref)[~sub] / ref[~sub]
    a = a[~sub]
    got = got[~sub]
    ref = ref[~sub]
    worst = int(np.argmax(rel))
    # below a = 6 the pieces (coefficients within 1.6e-16 of the interpolants' values); beyond, the
    # tail adds exp's and u = 1 / a^2's roundings
    assert rel.max() <= 4.0 * EPS, f"ierfc({a[worst]!r}) = {got[worst]!r}, mpmath {ref[worst]!r}: {rel.max() / EPS:.2f} ulp"


def test_ierfc_float64_limits_and_underflow_cut():
    a = np.array([0.0, math.sqrt(708.0), np.nextafter(math.sqrt(708.0), 100.0), 27.0, 1e200, np.inf, np.nan])
    got = _run(_k_ierfc, a)
    assert got[0] == pytest.approx(1.0 / math.sqrt(math.pi), rel=EPS)
    # at a^2 = 708 the value is ~3e-312 (subnormal, relative accuracy lost); beyond the cut, 0
    assert abs(got[1] - float(_ierfc_ref(a[1]))) <= 2.0**-1060
    assert list(got[2:6]) == [0.0, 0.0, 0.0, 0.0]
    assert math.isnan(got[6])


def test_ierfc_abs_within_1_2e_16_absolute():
    # the integrand's G form: 8 of the pieces' 10 coefficients, an absolute promise, 0 from a = 6
    a = np.concatenate([_points(), [np.inf]])
    got = _run(_k_ierfc_abs, a)
    ref = np.array([float(_ierfc_ref(x)) if np.isfinite(x) else 0.0 for x in a])
    err = np.abs(got - ref)
    worst = int(np.argmax(err))
    assert err.max() <= 1.2e-16, f"ierfc_abs({a[worst]!r}) = {got[worst]!r}, mpmath {ref[worst]!r}"
    assert np.all(got[a >= IERFC_A_MAX] == 0.0)
    assert _run(_k_ierfc_abs, np.array([np.nan, -1.0])).tolist() == [0.0, 0.0]


def test_lambda_cos_abs_error_next_to_cos_plus_lambda():
    # |cos| Lambda = alpha s ierfc(a) / 2, a = z / (alpha s): ierfc's 1.2e-16 times alpha s / 2, and
    # a few roundings (the root, the division, the products) relative to z + |cos| Lambda, the sum
    # G adds it to
    rng = np.random.default_rng(11)
    z = np.concatenate([rng.uniform(0.0, 1.0, 1500), 10 ** rng.uniform(-8, 0, 300), [0.0, 1.0, 0.5]])
    al = np.concatenate([10 ** rng.uniform(-4, math.log10(4.0), 1800), [0.5, 0.5, 0.0]])
    x = wp.array(z, dtype=wp.float64, device="cpu")
    y = wp.array(al, dtype=wp.float64, device="cpu")
    out = wp.zeros(z.size, dtype=wp.float64, device="cpu")
    wp.launch(_k_lambda_cos_abs, dim=z.size, inputs=[x, y, out], device="cpu")
    got = out.numpy()
    for j in range(z.size):
        with mp.workdps(40):
            zj, aj = mp.mpf(z[j]), mp.mpf(al[j])
            s = mp.sqrt(1 - zj * zj)
            exact = aj * s * _ierfc_ref(zj / (aj * s)) / 2 if aj * s > 0 else mp.mpf(0)
            tol = 6e-17 * float(aj * s) + 6 * EPS * float(zj + exact)
        assert abs(got[j] - float(exact)) <= tol, (z[j], al[j], got[j], float(exact))


def test_ierfc_float32_keeps_the_generic_form():
    a = np.concatenate([np.linspace(0.0, 9.0, 181), [np.float32(np.inf)]]).astype(np.float32)
    got = _run(_k_ierfc32, a, dtype=wp.float32)
    ref = np.array([float(_ierfc_ref(float(x))) if np.isfinite(x) else 0.0 for x in a])
    assert np.all(np.isfinite(got))
    np.testing.assert_allclose(got, ref, rtol=2e-5, atol=1e-44)


def test_ierfc_adjoint_is_minus_erfc():
    a = np.array([0.0, 0.3, 1.0, 2.49, 5.99, 6.0, 7.5])
    x = wp.array(a, dtype=wp.float64, device="cpu", requires_grad=True)
    out = wp.zeros(a.size, dtype=wp.float64, device="cpu", requires_grad=True)
    tape = wp.Tape()
    with tape:
        wp.launch(_k_ierfc_grad, dim=a.size, inputs=[x, out], device="cpu")
    tape.backward(grads={out: wp.array(np.ones(a.size), dtype=wp.float64, device="cpu")})
    np.testing.assert_allclose(x.grad.numpy(), [-math.erfc(v) for v in a], rtol=1e-14, atol=0.0)


@pytest.mark.parametrize("k", [0, 1, 11, 23, 24, 40, 47, 95, 120, 191])
def test_pieces_are_the_chebyshev_interpolants_they_claim(k):
    # refit piece k as ierfc_table's docstring says (its degree, 40 digits) and compare
    assert k < len(IERFC_PIECES)
    n = len(IERFC_PIECES[k])
    with mp.workdps(40):
        a0 = mp.mpf(k) / IERFC_PER_UNIT
        a1 = mp.mpf(k + 1) / IERFC_PER_UNIT
        poly = mp.chebyfit(lambda x: _ierfc_ref(a0 + (x + 1) * (a1 - a0) / 2), [-1, 1], n)
    want = [float(c) for c in reversed(poly)]
    assert n == 10 and set(map(len, IERFC_PIECES)) == {n}
    np.testing.assert_allclose(IERFC_PIECES[k], want, rtol=1e-12, atol=1e-300)


def test_tail_is_the_chebyshev_interpolant_it_claims():
    def q(x):
        # exp(a^2) ierfc(a) / u at u = (x + 1) / 72, a = 1 / sqrt(u); the limit 1 / (2 sqrt(pi)) at u = 0
        u = (x + 1) / 72
        if u == 0:
            return 1 / (2 * mp.sqrt(mp.pi))
        a = 1 / mp.sqrt(u)
        return (1 / mp.sqrt(mp.pi) - a * mp.erfc(a) * mp.exp(a * a)) / u

    with mp.workdps(50):
        poly = mp.chebyfit(q, [-1, 1], 12)
    np.testing.assert_allclose(IERFC_TAIL, [float(c) for c in reversed(poly)], rtol=1e-12, atol=1e-300)
    # and the piece table spans [0, IERFC_A_MAX) with IERFC_PER_UNIT pieces per unit
    assert len(IERFC_PIECES) == int(IERFC_A_MAX * IERFC_PER_UNIT)
