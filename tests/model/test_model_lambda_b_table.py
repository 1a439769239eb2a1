"""The Beckmann Smith Lambda from b = a^2 (native table code, issue 14, thirteenth round).

``beckmann_lambda_a2(b)`` is ierfc(sqrt(b)) / (2 sqrt(b)), b = cot^2(theta) / alpha^2: from b the
integrand's G needs no root. Here the coefficients of :mod:`bsdf_tab.model.lambda_b_table` are
refitted (they must be the Chebyshev interpolants the module says they are), the native values
are checked against 40-digit mpmath from the definition exp(-a^2) / sqrt(pi) - a erfc(a) on random
b, at every piece's ends (the index and the scale come from b's bits), below the table (the root
form), at the cut b = 36, and at 0, inf, nan and negative b.
"""

import math

import mpmath as mp
import numpy as np
import pytest
import warp as wp

from bsdf_tab.model.beckmann import LAMBDA_B_MIN, beckmann_lambda_a2, beckmann_lambda_b_table
from bsdf_tab.model.lambda_b_table import LAMBDA_B_E_MIN, LAMBDA_B_MAX, LAMBDA_B_PER_OCTAVE, LAMBDA_B_PIECES


@wp.kernel
def _k_lambda(b: wp.array(dtype=wp.float64), out: wp.array2d(dtype=wp.float64)):
    i = wp.tid()
    out[i, 0] = beckmann_lambda_a2(b[i])
    out[i, 1] = beckmann_lambda_b_table(b[i])


def _run(b):
    x = wp.array(np.asarray(b, dtype=np.float64), dtype=wp.float64, device="cpu")
    out = wp.zeros((len(b), 2), dtype=wp.float64, device="cpu")
    wp.launch(_k_lambda, dim=len(b), inputs=[x, out], device="cpu")
    return out.numpy()


def _lambda_ref(b):
    # Smith Lambda of Beckmann at a = sqrt(b), from the definition (Walter et al. 2007, eq. 27)
    a = mp.sqrt(mp.mpf(b))
    return (mp.exp(-a * a) / mp.sqrt(mp.pi) - a * mp.erfc(a)) / (2 * a)


def _piece_ends():
    ends = []
    for e in range(LAMBDA_B_E_MIN, 6):
        for j in range(LAMBDA_B_PER_OCTAVE):
            b0 = math.ldexp(1.0 + j / LAMBDA_B_PER_OCTAVE, e)
            if b0 < LAMBDA_B_MAX:
                ends += [b0, math.nextafter(b0, 0.0), math.nextafter(b0, math.inf)]
    return ends


def test_table_layout():
    assert float(LAMBDA_B_MIN) == 2.0**LAMBDA_B_E_MIN
    assert len(set(map(len, LAMBDA_B_PIECES))) == 1
    # every piece up to the one holding b = 36 = 32 (1 + 1/8), and no more
    assert len(LAMBDA_B_PIECES) == LAMBDA_B_PER_OCTAVE * (5 - LAMBDA_B_E_MIN) + math.ceil(LAMBDA_B_PER_OCTAVE / 8)


@pytest.mark.parametrize("share", [0.0, 0.002, 0.04, 0.3, 0.5, 0.77, 0.9, 0.99, 1.0])
def test_pieces_are_the_chebyshev_interpolants_they_claim(share):
    per = LAMBDA_B_PER_OCTAVE
    k = min(int(share * len(LAMBDA_B_PIECES)), len(LAMBDA_B_PIECES) - 1)
    e, j = LAMBDA_B_E_MIN + k // per, k % per
    with mp.workdps(40):
        b0 = mp.ldexp(1 + mp.mpf(j) / per, e)
        b1 = mp.ldexp(1 + mp.mpf(j + 1) / per, e)
        poly = mp.chebyfit(lambda x: _lambda_ref(b0 + (x + 1) * (b1 - b0) / 2), [-1, 1], len(LAMBDA_B_PIECES[k]))
    np.testing.assert_allclose(LAMBDA_B_PIECES[k], [float(c) for c in reversed(poly)], rtol=1e-12, atol=1e-300)


def test_against_mpmath_on_random_b_and_every_piece_end():
    rng = np.random.default_rng(2026)
    b = np.concatenate([10.0 ** rng.uniform(-8.0, math.log10(36.0), 4000), _piece_ends()])
    b = b[b < LAMBDA_B_MAX]
    got = _run(b)
    with mp.workdps(40):
        for bi, (lam, tab) in zip(b, got):
            exact = _lambda_ref(bi)
            # the table: 5.8e-17 (1 + Lambda) from the fit, plus the float64 evaluation's few ulp
            # of Lambda; below it the root form, ierfc to 1.2e-16 absolute over 2 a
            bound = (3e-16 if bi >= LAMBDA_B_MIN else 5e-16) * (1 + exact)
            assert abs(mp.mpf(lam) - exact) <= bound, (bi, lam, float(exact))
            if bi >= LAMBDA_B_MIN:
                assert tab == lam, (bi, tab, lam)
            else:
                assert tab == 0.0


def test_cut_and_special_values():
    b = [math.nextafter(36.0, 0.0), 36.0, 37.0, 1e300, math.inf, 0.0, -1.0, math.nan, 5e-324]
    got = _run(b)
    # just below the cut: Lambda(36) = ierfc(6) / 12 ~ 1.5e-18, within its bound; from 36 on 0
    assert 0.0 < got[0, 0] < 1.6e-18 and float(_lambda_ref(b[0])) == pytest.approx(got[0, 0], rel=1e-12)
    assert list(got[1:5, 0]) == [0.0] * 4 and list(got[1:5, 1]) == [0.0] * 4
    # the horizon: infinite; outside the domain: nan (the table alone: 0 below its range and for nan)
    assert got[5, 0] == math.inf and math.isnan(got[6, 0]) and math.isnan(got[7, 0])
    assert list(got[5:8, 1]) == [0.0] * 3
    # the smallest subnormal: the root form still (a = 2.2e-162)
    assert got[8, 0] == pytest.approx(1.0 / (2.0 * math.sqrt(math.pi) * math.sqrt(5e-324)), rel=1e-12)
