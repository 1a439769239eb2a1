"""The alpha = 0 texels (the mirror limit, a closed form) against 50-digit references.

Every method stores the mirror limit with an error that bounds its float64 rounding (until the
GPU run of issue 14 it reported 0, and the CPU and an H200 differed by up to 5 ulps of 1 there).
The references are written apart from the kernels: the Fresnel equations in the form of the
amplitude ratios r_s = (c - n c_t)/(c + n c_t) and r_p = (n c - c_t)/(n c + c_t) with complex
c_t = sqrt(1 - (1 - c^2)/n^2) (Born and Wolf), in mpmath at 50 digits, where the kernels use
Walter et al.'s g form (dielectric) and pbrt's a^2 + b^2 form (conductor). The regimes: grazing
and normal incidence, eta -> 1 from both sides (cancellation), total internal reflection and the
critical angle, a conductor with large k.
"""

import mpmath
import numpy as np
import pytest

from bsdf_tab.integrate import get_method
from bsdf_tab.integrate.integrand import MIRROR_ROUNDING
from bsdf_tab.model.fresnel import FRESNELS

mpmath.mp.dps = 50
MU = [0.0, 1e-12, 1e-4, 0.05, 0.3, 0.5, 0.7, 0.99, 1.0 - 1e-12, 1.0]


def fresnel_exact(c, n) -> mpmath.mpf:
    """Unpolarized reflectance at incidence cosine c of relative (complex) index n."""
    c = mpmath.mpf(c)
    n = mpmath.mpc(n)
    ct = mpmath.sqrt(1 - (1 - c * c) / (n * n))
    if mpmath.im(n) == 0 and mpmath.re(1 - (1 - c * c) / (n * n)) <= 0:
        return mpmath.mpf(1)  # total internal reflection (and the critical angle)
    rs = (c - n * ct) / (c + n * ct)
    rp = (n * c - ct) / (n * c + ct)
    return (abs(rs) ** 2 + abs(rp) ** 2) / 2


def _check(values, errors, exact):
    exact = np.array([[float(a), float(b)] for a, b in exact])
    miss = np.abs(values - exact)
    assert np.all(miss <= errors), (miss / np.maximum(errors, 1e-300)).max()
    # honest, and still tight: the rounding bound, not a tolerance
    assert np.all(errors <= 2 * MIRROR_ROUNDING)
    return miss


@pytest.mark.parametrize("method", ["adaptive", "vndf_gl", "mc_vndf"])
@pytest.mark.parametrize("eta", [1.5, 1.0 + 1e-6, 1.0 - 1e-6, 1.0 / 1.5, 0.25, 4.0])
def test_dielectric_mirror_limit_is_within_its_error(method, eta):
    mu = np.array(MU)
    v, e = get_method(method)("dielectric", mu, np.zeros(mu.size), np.full(mu.size, eta))
    exact = []
    for m in MU:
        f = fresnel_exact(m, eta)
        exact.append((f, 1 - f))
    _check(v, e, exact)


@pytest.mark.parametrize(
    "ftype,p0,p1",
    [("dielectric", 1.5, 0.0), ("dielectric", 1.0 + 1e-6, 0.0), ("conductor", 0.2, 3.9),
     ("conductor", 1.5, 1e3), ("conductor", 2.0, 0.0), ("schlick", 0.04, 0.0), ("one", 0.0, 0.0)],
)
def test_albedo_mirror_limit_is_within_its_error(ftype, p0, p1):
    mu = np.array(MU)
    v, e = get_method("adaptive")("reflect", mu, np.zeros(mu.size), None, ftype=FRESNELS[ftype], fp0=p0, fp1=p1)
    exact = []
    for m in MU:
        if ftype == "schlick":
            f = mpmath.mpf(p0) + (1 - mpmath.mpf(p0)) * (1 - mpmath.mpf(m)) ** 5
        elif ftype == "one":
            f = mpmath.mpf(1)
        else:
            f = fresnel_exact(m, mpmath.mpc(p0, p1))
        exact.append((f, 0))
    _check(v, e, exact)


def test_dfg_mirror_limit_is_within_its_error():
    mu = np.array(MU)
    v, e = get_method("adaptive")("dfg", mu, np.zeros(mu.size), None)
    exact = [(1 - (1 - mpmath.mpf(m)) ** 5, (1 - mpmath.mpf(m)) ** 5) for m in MU]
    _check(v, e, exact)
