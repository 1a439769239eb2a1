"""The random texel sets of the accuracy tests, shared with ``bench/accuracy_honesty.py``.

:func:`sample_texels`: mu half uniform in [1e-4, 1], half log-uniform; alpha log-uniform in
[1e-3, 1]; eta None, ">1" (uniform in [1.01, 4]) or "<1" (their reciprocals).
:func:`fresnel_spec`: a random Fresnel of one type, as (reference spec, p0, p1).
"""

from __future__ import annotations

import numpy as np


def sample_texels(seed, n, *, eta=None):
    rng = np.random.default_rng(seed)
    k = n // 2
    mu = np.concatenate([rng.uniform(1e-4, 1.0, n - k), 10 ** rng.uniform(-4, 0, k)])
    alpha = 10 ** rng.uniform(-3, 0, n)
    etas = None
    if eta is not None:
        etas = rng.uniform(1.01, 4.0, n)
        if eta == "<1":
            etas = 1.0 / etas
    return mu, alpha, etas


def fresnel_spec(name, rng):
    if name == "one":
        return ("one",), 0.0, 0.0
    if name == "schlick":
        f0 = float(rng.uniform(0.02, 0.95))
        return ("schlick", f0), f0, 0.0
    if name == "dielectric":
        eta = float(rng.uniform(1.01, 4.0))
        if rng.uniform() < 0.5:
            eta = 1.0 / eta
        return ("dielectric", eta), eta, 0.0
    eta, k = float(rng.uniform(0.1, 3.0)), float(rng.uniform(0.0, 6.0))
    return ("conductor", eta, k), eta, k
