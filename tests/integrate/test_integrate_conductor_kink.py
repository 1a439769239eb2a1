"""A conductor Fresnel with k -> 0 is the dielectric Fresnel, kink at the critical angle included.

The audit (session 18): with eta 0.5, k = 0 the albedo's error channel under-reported by up to
125x (17x at tolerance 1e-6), because only a dielectric Fresnel got the critical-angle cuts. The
reference here is an independent path for the same function: the dielectric Fresnel of the same
eta (k = 0 makes the two formulas equal; at the node c = 1 they agree to rounding), integrated
at 1e-11 with the cuts it always had.
"""

from __future__ import annotations

import numpy as np
import pytest

from bsdf_tab.integrate.adaptive import integrate_texels

RNG = np.random.default_rng(7)
MU = RNG.uniform(0.05, 1.0, 48)
ALPHA = 10 ** RNG.uniform(np.log10(0.02), np.log10(0.8), 48)


def _albedo(ftype: int, eta: float, k: float, tol: float, mu=MU, alpha=ALPHA):
    value, error, cost = integrate_texels("reflect", mu, alpha, None, dist=0, shadowing=1, ftype=ftype, fp0=eta,
                                          fp1=k, tol=tol, return_cost=True)
    return value[:, 0], error[:, 0], cost


@pytest.mark.parametrize("eta", [0.5, 0.8])
@pytest.mark.parametrize("tol", [1e-4, 1e-6, 1e-8])
def test_a_lossless_conductor_is_honest_at_its_critical_angle(eta, tol):
    ref, ref_err, _ = _albedo(2, eta, 0.0, 1e-11)  # the dielectric Fresnel of the same eta
    value, error, cost = _albedo(3, eta, 0.0, tol)
    true = np.abs(value - ref) - ref_err
    assert np.all(true <= error), (np.max(true / error), MU[np.argmax(true / error)])
    assert cost.mean() < 3e4  # it was ~1e5 per texel: bisecting towards a kink no rule resolves


def test_a_metal_gets_no_cuts_and_costs_the_same():
    """k >= 1 (CONDUCTOR_KINK_K): smooth, no critical-angle cuts; gold's albedo at a glance."""
    gold_a, _, cost_a = _albedo(3, 0.2, 3.0, 1e-6)
    gold_b, _, cost_b = _albedo(3, 0.2, 1.0, 1e-6)
    assert cost_a.mean() < 5000 and cost_b.mean() < 5000
    assert np.all((gold_a > 0.0) & (gold_a <= 1.0))
