"""Smith shadowing-masking G for a pair of directions.

``SEPARABLE``: G1(i) G1(o) (Walter et al. 2007). ``CORRELATED``: 1 / (1 + Lambda(i) +
Lambda(o)) (Heitz 2014, "Understanding the Masking-Shadowing Function in Microfacet-Based
BRDFs"). Both are formed from |z| Lambda(z) so grazing directions give 0, not 0 * inf. The
chi+ terms depend on the micro-normal and are applied by the caller (see ``bsdf.py``).
"""

from typing import Any

import warp as wp

from .beckmann import LAMBDA_B_MIN, beckmann_lambda_b_table, beckmann_lambda_cos_abs
from .distribution import BECKMANN, GGX, lambda_cos
from .ggx import ggx_lambda_root

SHADOWINGS = {"separable": 0, "correlated": 1}
"""name (the spec's ``shadowing``) -> integer id, the ``shadowing`` selector below."""

SEPARABLE = wp.constant(SHADOWINGS["separable"])
CORRELATED = wp.constant(SHADOWINGS["correlated"])


@wp.func
def smith_G_over_cos_i_from_lambda(zi: Any, li: Any, zo: Any, lo: Any, shadowing: wp.int32):
    """G / zi from zi = |cos_i|, zo = |cos_o| and li = zi Lambda_i, lo = zo Lambda_o."""
    zero = zi * type(zi)(0.0)
    den = zero
    if shadowing == CORRELATED:
        # 1 / (zi (1 + Lambda_i + Lambda_o)) = zo / (zi zo + li zo + lo zi)
        den = zi * zo + li * zo + lo * zi
    else:
        # 1 / (zi (1 + Lambda_i)(1 + Lambda_o)) = zo / ((zi + li)(zo + lo))
        den = (zi + li) * (zo + lo)
    if den <= zero:
        # only with alpha = 0 at grazing: take the mirror value G = 1 (and 0 for zi = 0)
        if zi > zero:
            return type(zi)(1.0) / zi
        return zero
    return zo / den


@wp.func
def smith_G_over_cos_i_to(zi: Any, li: Any, zo: Any, alpha: Any, dist: wp.int32, shadowing: wp.int32):
    """G / zi from zi = |cos_i|, li = zi Lambda_i (known) and the other direction's zo = |cos_o|.

    The value of :func:`smith_G_over_cos_i_from_lambda` with lo = lambda_cos(zo), for an
    integrand that knows Lambda_i once per texel. For GGX it is formed from the root
    r = sqrt(zo^2 + alpha^2 (1 - zo^2)) = zo (1 + 2 Lambda_o) with one division (issue 14):
    correlated G / zi = 2 zo / (zo (zi + 2 li) + zi r), separable 2 zo / ((zi + li)(zo + r)),
    sums of non-negative terms (no cancellation). Beckmann takes Lambda_o from a^2 =
    zo^2 / (alpha^2 (1 - zo^2)) with no root (:func:`beckmann_lambda_a2`, 0 where a >= 6: Lambda_o <
    1.5e-19 there; its error ~6e-17 (1 + Lambda_o)), and G / zi = 1 / (zi + li + zi Lambda_o) or
    1 / ((zi + li)(1 + Lambda_o)): one division (issue 14, thirteenth round); other distributions
    use their lambda_cos.
    """
    zero = zi * type(zi)(0.0)
    den = zero
    if dist == GGX:
        r = ggx_lambda_root(zo, alpha)
        if shadowing == CORRELATED:
            den = zo * (zi + type(zi)(2.0) * li) + zi * r
        else:
            den = (zi + li) * (zo + r)
    elif dist == BECKMANN:
        # Lambda_o from b = a^2 = zo^2 / (alpha^2 (1 - zo^2)) with no root (beckmann_lambda_b_table;
        # 0 where a >= 6, Lambda_o < 1.5e-19 there, and b = inf at zo = 1): zo cancels from G / zi,
        # 1 / (zi + li + zi Lambda_o) or 1 / ((zi + li)(1 + Lambda_o)), one division (round 13)
        one = type(zi)(1.0)
        b = zo * zo / (alpha * alpha * ((one - zo) * (one + zo)))
        if b >= LAMBDA_B_MIN:
            lam = beckmann_lambda_b_table(b)
            if shadowing == CORRELATED:
                den = zi + li + zi * lam
            else:
                den = (zi + li) * (one + lam)
            if den > zero:
                return one / den
        else:
            # a < 1/16, near the horizon (and nan): lo = zo Lambda_o by the root form, which stays
            # exact as zo -> 0 (G / zi ~ zo there)
            lo = beckmann_lambda_cos_abs(zo, alpha)
            if shadowing == CORRELATED:
                den = zo * (zi + li) + zi * lo
            else:
                den = (zi + li) * (zo + lo)
            if den > zero:
                return zo / den
    if den <= zero:
        # another distribution, or GGX with alpha = 0 at grazing (the mirror value and its guard)
        return smith_G_over_cos_i_from_lambda(zi, li, zo, lambda_cos(zo, alpha, dist), shadowing)
    return type(zi)(2.0) * zo / den


@wp.func
def smith_G_over_cos_i_equal(z: Any, l: Any, shadowing: wp.int32):
    """G / z for two directions of the same |cos| = z (o = -i): the limit that stays finite at z = 0."""
    zero = z * type(z)(0.0)
    den = zero
    num = type(z)(1.0)
    if shadowing == CORRELATED:
        # z / (z^2 + 2 l z) = 1 / (z + 2 l)
        den = z + type(z)(2.0) * l
    else:
        # z / (z + l)^2
        num = z
        den = (z + l) * (z + l)
    if den <= zero:
        # alpha = 0 at grazing: mirror value G = 1, G / z unbounded; no finite answer
        return zero
    return num / den


@wp.func
def smith_G_over_cos_i(cos_i: Any, cos_o: Any, alpha: Any, dist: wp.int32, shadowing: wp.int32):
    """G(i, o) / |cos_i| without chi+ terms; finite as cos_i -> 0 (the integrators' form)."""
    zi = wp.abs(cos_i)
    zo = wp.abs(cos_o)
    return smith_G_over_cos_i_from_lambda(
        zi, lambda_cos(zi, alpha, dist), zo, lambda_cos(zo, alpha, dist), shadowing
    )


@wp.func
def smith_G(cos_i: Any, cos_o: Any, alpha: Any, dist: wp.int32, shadowing: wp.int32):
    """Shadowing-masking G(i, o) in [0, 1] without chi+ terms."""
    zi = wp.abs(cos_i)
    zo = wp.abs(cos_o)
    li = lambda_cos(zi, alpha, dist)
    lo = lambda_cos(zo, alpha, dist)
    num = zi * zo
    den = type(alpha)(0.0)
    if shadowing == CORRELATED:
        den = zi * zo + li * zo + lo * zi
    else:
        den = (zi + li) * (zo + lo)
    if den <= type(alpha)(0.0):
        # grazing with alpha = 0: a mirror does not shadow
        return type(alpha)(1.0)
    return num / den
