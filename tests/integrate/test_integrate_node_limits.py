"""The adaptive integrand at a node rounded onto v = 1 (tan theta_m = inf, sin = inf * 0 = nan).

D cos has no mass there and the node's weight 2 (1 - v) is 0: the value must be 0, not inf or
nan (inf * 0 made nan texels for Beckmann dielectric tables when the fused Fresnel first clamped
a nan i.m). Independent check: the limit itself (0), for every distribution, mode and side.
"""

import numpy as np
import pytest
import warp as wp

from bsdf_tab.integrate.integrand import MODES, integrand_phi, make_texel
from bsdf_tab.model.distribution import DISTRIBUTIONS, dcos_tan_of_v


@wp.kernel
def _k_edge(mode: wp.int32, dist: wp.int32, mu: wp.array(dtype=wp.float64), alpha: wp.array(dtype=wp.float64),
            eta: wp.array(dtype=wp.float64), phi: wp.array(dtype=wp.float64), out: wp.array(dtype=wp.vec2d)):
    i = wp.tid()
    p = make_texel(mode, dist, 1, 0, wp.float64(0.0), wp.float64(0.0), mu[i], alpha[i], eta[i])
    one = wp.float64(1.0)
    tm = dcos_tan_of_v(one, p.alpha, p.dist)  # inf
    cm = one / wp.sqrt(one + tm * tm)  # 0, as the outer rule forms it
    sm = tm * cm  # nan
    out[i] = integrand_phi(p, cm, sm, tm, phi[i])


@pytest.mark.parametrize("dist", sorted(DISTRIBUTIONS))
@pytest.mark.parametrize("mode", ["reflect", "dielectric", "dfg"])
def test_integrand_is_zero_at_v_one(dist, mode):
    rng = np.random.default_rng(2)
    n = 400
    mu = np.concatenate([rng.uniform(0.0, 1.0, n), [0.0, 1.0]])
    alpha = np.concatenate([10 ** rng.uniform(-3, np.log10(4.0), n), [0.5, 0.5]])
    eta = np.concatenate([10 ** rng.uniform(np.log10(0.25), np.log10(4.0), n), [0.3376, 2.78]])
    phi = np.concatenate([rng.uniform(0.0, np.pi, n), [0.0, np.pi]])
    arrs = [wp.array(x, dtype=wp.float64, device="cpu") for x in (mu, alpha, eta, phi)]
    out = wp.zeros(mu.size, dtype=wp.vec2d, device="cpu")
    wp.launch(_k_edge, dim=mu.size, inputs=[MODES[mode], DISTRIBUTIONS[dist], *arrs, out], device="cpu")
    np.testing.assert_array_equal(out.numpy(), 0.0)
