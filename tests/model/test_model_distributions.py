"""The distribution registry and what each registered distribution knows beyond D and Lambda:
the D cos CDF in theta_m and its inverse, D cos sampling, the d ln D / d cos bound.

Truths: the CDF is integrated numerically from the independent float64 reference D
(tests/reference), the derivative bound is checked against finite differences of the reference
D. Parametrized over :data:`bsdf_tab.model.DISTRIBUTIONS`: a new distribution is tested here as
soon as it is registered (and known to the reference).
"""

import math

import numpy as np
import pytest
from scipy.integrate import quad

from bsdf_tab import model
from bsdf_tab.model import DISTRIBUTION_DESCRIPTIONS, DISTRIBUTIONS, FRESNELS, SHADOWINGS
from bsdf_tab.model import distribution as registry
from tests.model import user_kernels as uk
from tests.reference import microfacet_ref as ref

NAMES = list(DISTRIBUTIONS)
ALPHAS = [1e-3, 0.05, 0.5, 1.0, 2.0]
PER_DISTRIBUTION = ["D", "lambda", "lambda_cos", "sample_vndf", "dcos_sample_tan", "dcos_tan_of_v",
                    "dcos_v_of_theta", "dlnD_dcos"]


def test_registries_are_consistent():
    for reg in (DISTRIBUTIONS, SHADOWINGS, FRESNELS):
        assert sorted(reg.values()) == list(range(len(reg))), reg
    assert set(DISTRIBUTION_DESCRIPTIONS) == set(DISTRIBUTIONS)
    assert all(d and "\n" not in d for d in DISTRIBUTION_DESCRIPTIONS.values())
    assert (model.GGX, model.BECKMANN) == (DISTRIBUTIONS["ggx"], DISTRIBUTIONS["beckmann"])
    assert (model.SEPARABLE, model.CORRELATED) == (SHADOWINGS["separable"], SHADOWINGS["correlated"])
    assert (model.FRESNEL_ONE, model.FRESNEL_SCHLICK, model.FRESNEL_DIELECTRIC, model.FRESNEL_CONDUCTOR) == (
        FRESNELS["one"], FRESNELS["schlick"], FRESNELS["dielectric"], FRESNELS["conductor"])
    assert model.distribution_id("beckmann") == DISTRIBUTIONS["beckmann"]
    with pytest.raises(ValueError, match="ggx"):
        model.distribution_id("phong")


@pytest.mark.parametrize("name", NAMES)
def test_each_distribution_module_owns_its_functions(name):
    mod = registry._MODULES[DISTRIBUTIONS[name]]
    assert mod.NAME == name
    for op in PER_DISTRIBUTION:
        assert callable(getattr(mod, f"{name}_{op}")), f"{mod.__name__} lacks {name}_{op}"


def _cdf_ref(name, theta, alpha):
    """u(theta) = 2 pi int_0^theta D(t) cos t sin t dt with the reference D (adaptive quadrature,
    split where tan t = alpha 2^k so that near-mirror alpha is resolved)."""
    f = lambda t: float(ref.D(name, math.cos(t), alpha)) * math.cos(t) * math.sin(t) * 2 * math.pi
    pts = [math.atan(alpha * 2.0**k) for k in range(-8, 12)]
    edges = [0.0] + sorted(p for p in pts if p < theta) + [theta]
    return sum(quad(f, a, b, epsabs=1e-14, epsrel=1e-13, limit=200)[0] for a, b in zip(edges[:-1], edges[1:]))


@pytest.mark.parametrize("name", NAMES)
@pytest.mark.parametrize("alpha", ALPHAS)
def test_dcos_cdf_and_inverses_match_the_reference_integral(name, alpha):
    dist = DISTRIBUTIONS[name]
    # theta_m around the lobe (tan = alpha k) and fixed angles up to the horizon
    tans = alpha * np.array([0.01, 0.1, 0.5, 1.0, 2.0, 5.0])
    theta = np.unique(np.concatenate([np.arctan(tans), np.linspace(0.05, 1.5, 7)]))
    theta = theta[theta < 1.55]
    u_ref = np.array([_cdf_ref(name, t, alpha) for t in theta])
    keep = u_ref < 1 - 1e-9  # beyond, the CDF is 1 to double precision and the inverse is ill-posed
    n = theta.size
    cols = uk.run_dcos(np.float64, theta, np.full(n, alpha), dist)
    v = cols[:, 2]
    # u = 1 - (1 - v)^2 is the CDF
    np.testing.assert_allclose(1 - (1 - v) ** 2, u_ref, rtol=1e-9, atol=1e-12)
    # dcos_tan_of_v inverts dcos_v_of_theta
    back = uk.run_dcos(np.float64, v[keep], np.full(keep.sum(), alpha), dist)[:, 1]
    np.testing.assert_allclose(back, np.tan(theta[keep]), rtol=1e-7)
    # the sampling inverse maps u to the same tan(theta_m); tan is ill-conditioned in u in the
    # tail (d ln tan / du ~ 1 / (1 - u)), where the quadrature's ~1e-12 in u is not enough
    body = u_ref < 1 - 1e-3
    t_u = uk.run_dcos(np.float64, u_ref[body], np.full(body.sum(), alpha), dist)[:, 0]
    np.testing.assert_allclose(t_u, np.tan(theta[body]), rtol=1e-6)
    # the horizon and the pole
    ends = uk.run_dcos(np.float64, np.array([0.0, math.pi / 2, 2.0]), np.full(3, alpha), dist)
    assert ends[0, 0] == 0 and ends[0, 1] == 0 and ends[0, 2] == 0
    assert ends[1, 2] == 1 and ends[2, 2] == 1


@pytest.mark.parametrize("name", NAMES)
def test_dcos_sampling_float32_is_finite(name):
    x = np.concatenate([np.linspace(0.0, 0.999, 50), [1 - 1e-6]])
    for alpha in (0.0, 1e-4, 0.3, 2.0):
        cols = uk.run_dcos(np.float32, x, np.full(x.size, alpha), DISTRIBUTIONS[name])
        assert np.all(np.isfinite(cols[:, :3])), alpha
        assert np.all(cols[:, :3] >= 0)


@pytest.mark.parametrize("name", NAMES)
@pytest.mark.parametrize("alpha", [0.01, 0.1, 0.5, 1.0, 2.0])
def test_dlnD_dcos_bounds_the_reference_derivative(name, alpha):
    # across the lobe (tan theta_m up to 20 alpha) and the whole range of cosines
    c = np.unique(np.concatenate([np.cos(np.arctan(alpha * np.linspace(0.05, 20.0, 40))), np.linspace(0.02, 0.999, 30)]))
    c = c[c < 1 - 1e-5]
    h = 1e-7 * c
    with np.errstate(divide="ignore"):
        fd = (np.log(ref.D(name, c + h, alpha)) - np.log(ref.D(name, c - h, alpha))) / (2 * h)
    ok = np.isfinite(fd)
    assert ok.sum() > 25
    bound = uk.run_dcos(np.float64, c, np.full(c.size, alpha), DISTRIBUTIONS[name])[:, 3]
    assert np.all(bound[ok] >= np.abs(fd[ok]) * (1 - 1e-5)), (c[ok][bound[ok] < np.abs(fd[ok])])
    # c = 0 (a horizontal half-vector) gives a huge bound or +inf, never nan
    at0 = uk.run_dcos(np.float64, np.zeros(1), np.full(1, alpha), DISTRIBUTIONS[name])[0, 3]
    assert at0 > 1e100
