"""The inner phi pieces' end maps (bsdf_tab/integrate/adaptive.py, issue 14 round 7).

An inner piece ends at phi = 0 or pi (the integrand is even there: smooth) or at a cut on i.m:
the reflection horizon, i.m = 0, the transmission horizon (kinks to zero) and the critical
angle of an eta < 1 Fresnel (a square root). ``inner_map`` 0 maps every end by the smoothstep
(before round 7), 1 each cut only, 2 the critical cut only; the default is 2 at tolerances
>= 1e-3 and 1 below. Every map must leave the texels honest against the independent
reference (``tests/reference/microfacet_ref.py``, method B) at every tolerance, with a cut of
each kind present, and the defaults must spend less than the smoothstep everywhere.
"""

from __future__ import annotations


import numpy as np
import pytest

from bsdf_tab.integrate import integrate_texels
from tests.integrate.honesty import assert_honest, reference_set



def _cases():
    # grazing, oblique and near-normal incidence; near-mirror and rough; both sides of eta = 1
    mu = np.array([0.02, 0.35, 0.7, 0.97, 0.5, 0.15])
    alpha = np.array([0.3, 0.05, 0.6, 0.15, 0.02, 1.0])
    eta_lt = np.array([1 / 1.5, 1 / 1.33, 1 / 2.4, 1 / 1.1, 1 / 3.0, 1 / 1.5])
    eta_gt = 1.0 / eta_lt
    return [
        # reflection horizon and i.m = 0 cuts only
        reference_set("reflect", "ggx", "correlated", mu, alpha),
        # a reflection with a dielectric Fresnel of eta < 1: its critical cut (ftype 2: p0 = eta)
        reference_set("reflect", "beckmann", "separable", mu, alpha, fresnel=("dielectric", 0.6)),
        # eta < 1: the critical cut and the transmission horizon; eta > 1: the horizons only
        reference_set("dielectric", "ggx", "correlated", mu, alpha, eta_lt),
        reference_set("dielectric", "beckmann", "correlated", mu, alpha, eta_gt),
    ]


@pytest.fixture(scope="module")
def cases():
    return _cases()


@pytest.mark.parametrize("tol", [1e-3, 1e-5, 5e-7])
def test_every_map_is_honest_and_the_default_spends_least(cases, tol):
    cost = {}
    for inner_map in (None, 0, 1, 2):
        total = 0
        for mode, kw, mu, alpha, eta, refs in cases:
            v, e, c = integrate_texels(mode, mu, alpha, eta, tol=tol, return_cost=True, inner_map=inner_map, **kw)
            total += int(c.sum())
            assert_honest(v, e, refs, tol, (inner_map, mode, kw, tol))
        cost[inner_map] = total
    # the default is the cheaper of the two new maps at each tolerance, and well below the smoothstep
    # (measured: 0.86 / 0.86 / 0.81 of its evaluations at 1e-3 / 1e-5 / 5e-7)
    assert cost[None] == min(cost[1], cost[2]), cost
    assert cost[None] < 0.92 * cost[0], cost


@pytest.mark.parametrize("bad", [3, -1, True, 1.5])
def test_inner_map_is_validated(bad):
    with pytest.raises(ValueError, match="inner_map"):
        integrate_texels("reflect", [0.5], [0.2], tol=1e-3, inner_map=bad)
