"""The Gauss-Kronrod 7-15 rule and the one global-bisection routine.

The rule's constants are written once, as host NumPy arrays (:data:`XGK`, :data:`WGK`,
:data:`WG7`: QUADPACK's layout, positive abscissae with the centre last; :data:`GK_X`,
:data:`GK_WK`, :data:`GK_WG`: all 15 nodes on [-1, 1] in the order the device loops visit them),
and the device constants are built from them.

:func:`gk_error` is the error model of one rule application (|K15 - G7|, or QUADPACK's
rescaling). :func:`make_global_bisection` builds the globally adaptive loop (bisect the interval
with the largest estimate until the summed estimate of both channels meets the tolerance) around
any rule with the signature ``rule(p, x, a, b) -> (K, error, cost)``; the adaptive method uses it
at both of its levels with different rules. It is a Python factory over the rule (a Warp closure)
so that each level gets its own C++ function with a direct call to its rule: no rule selector in
the hot loop and no extra call level.

Reference: Piessens et al. 1983, "QUADPACK" (qk15, and the global adaptive strategy of qag).
"""

from typing import Any

import math

import numpy as np
import warp as wp

# Gauss-Kronrod 15-point abscissae on [-1, 1] (positive half, centre last) and weights;
# Gauss 7-point weights for the odd Kronrod abscissae and the centre (QUADPACK qk15).
XGK = np.array([
    0.991455371120812639206854697526329, 0.949107912342758524526189684047851,
    0.864864423359769072789712788640926, 0.741531185599394439863864773280788,
    0.586087235467691130294144845693013, 0.405845151377397166906606412076961,
    0.207784955007898467600689403773245, 0.0,
])
WGK = np.array([
    0.022935322010529224963732008058970, 0.063092092629978553290700663189204,
    0.104790010322250183839876322541518, 0.140653259715525918745189590510238,
    0.169004726639267902826583426598550, 0.190350578064785409913256402421014,
    0.204432940075298892414161999234649, 0.209482141084727828012999174891714,
])
WG7 = np.array([
    0.0, 0.129484966168869693270611432679082, 0.0, 0.279705391489276667901467771423780,
    0.0, 0.381830050505118944950369775488975, 0.0, 0.417959183673469387755102040816327,
])


def _interpolatory(keep):
    """Weights of the symmetric interpolatory rule on the nodes +-XGK[keep] (centre included),
    in the same layout: exact for the even monomials up to its size (and all odd ones)."""
    x = XGK[keep]
    a = np.array([[2.0 * xi**k if xi != 0.0 else float(k == 0) for xi in x] for k in range(0, 2 * len(x), 2)])
    w = np.zeros(8)
    w[keep] = np.linalg.solve(a, 2.0 / np.arange(1.0, 2.0 * len(x), 2.0))
    return w


# the interpolatory rules on five of the seven Gauss nodes (0, +-XGK[3], +-XGK[1]; exact to
# degree 5, positive weights) and on three (0, +-XGK[3]; degree 3): |G7 - I5| is the two-stage
# rule's first estimate (:func:`first_stage`)
WI5 = _interpolatory([1, 3, 7])
WI3 = _interpolatory([3, 7])
# all 15 nodes: j < 8 at +XGK[j], j >= 8 at -XGK[j - 8] (the device loops' order)
GK_X = np.concatenate([XGK, -XGK[:7]])
GK_WK = np.concatenate([WGK, WGK[:7]])
GK_WG = np.concatenate([WG7, WG7[:7]])

vec8d = wp.types.vector(length=8, dtype=wp.float64)
XGK_D = wp.constant(vec8d(*XGK.tolist()))
WGK_D = wp.constant(vec8d(*WGK.tolist()))
WG7_D = wp.constant(vec8d(*WG7.tolist()))
WI5_D = wp.constant(vec8d(*WI5.tolist()))
WI3_D = wp.constant(vec8d(*WI3.tolist()))

# Legendre coefficients of the degree-14 interpolant at the 15 nodes (orthonormal basis on
# [-1, 1], nodes in GK_X order): rows k = 9 .. 14 of the inverse Vandermonde matrix. Their
# decay says how well the 15 values resolve the integrand (see :func:`decay_ratio`).
_LEG_V = np.polynomial.legendre.legvander(GK_X, 14) * np.sqrt((2.0 * np.arange(15) + 1.0) / 2.0)
LEG_TAIL = np.linalg.inv(_LEG_V)[9:15]
vec16d = wp.types.vector(length=16, dtype=wp.float64)
# The nodes come in pairs +-x (j and j + 8; j = 7 is the centre), and P_k is even or odd: the
# rows are symmetric (even k) or antisymmetric (odd k) in each pair, to rounding. Symmetrized,
# as weights of the pairs' sums (even k, the centre last) or differences (odd k): 45 products
# instead of 90 (issue 14, tenth round).
_LEG_PAIR = [np.append(0.5 * (row[:7] + (1 if k % 2 == 0 else -1) * row[8:15]), row[7] if k % 2 == 0 else 0.0)
             for k, row in zip(range(9, 15), LEG_TAIL)]
LEG9_D, LEG10_D, LEG11_D, LEG12_D, LEG13_D, LEG14_D = (wp.constant(vec8d(*row.tolist())) for row in _LEG_PAIR)
# |G7 applied to the orthonormal P_14| on [-1, 1]: K15 - G7 of the 15-node interpolant is c14 times
# it (K15 integrates the interpolant exactly, G7 every degree below 14)
GAMMA14 = float(abs(np.sum(GK_WG * _LEG_V[:, 14])))
GAMMA14_D = wp.constant(wp.float64(GAMMA14))


@wp.func
def gk_abscissa(ctr: wp.float64, hl: wp.float64, j: wp.int32):
    """Node j of the 15 on [ctr - hl, ctr + hl] in the device loops' order (GK_X): j < 8 at
    ctr + hl XGK[j], the others at ctr - hl XGK[j - 8]."""
    if j >= 8:
        return ctr - hl * XGK_D[j - 8]
    return ctr + hl * XGK_D[j]


@wp.func
def legendre_tail(f: vec16d):
    """(A, B, C) = (|c13| + |c14|, |c11| + |c12|, |c9| + |c10|): the last six Legendre
    coefficients of the 15-node interpolant of ``f`` (orthonormal basis, values at the nodes in
    GK_X order) in pairs."""
    c9 = wp.float64(0.0)
    c10 = wp.float64(0.0)
    c11 = wp.float64(0.0)
    c12 = wp.float64(0.0)
    c13 = wp.float64(0.0)
    c14 = wp.float64(0.0)
    for j in range(7):
        # the pair +-x_j: odd degrees see its difference, even ones its sum
        d = f[j] - f[j + 8]
        e = f[j] + f[j + 8]
        c9 += LEG9_D[j] * d
        c10 += LEG10_D[j] * e
        c11 += LEG11_D[j] * d
        c12 += LEG12_D[j] * e
        c13 += LEG13_D[j] * d
        c14 += LEG14_D[j] * e
    c10 += LEG10_D[7] * f[7]
    c12 += LEG12_D[7] * f[7]
    c14 += LEG14_D[7] * f[7]
    return wp.vec3d(wp.abs(c13) + wp.abs(c14), wp.abs(c11) + wp.abs(c12), wp.abs(c9) + wp.abs(c10))


@wp.func
def tail_ratio(t: wp.vec3d):
    """max(A / B, B / C) of :func:`legendre_tail`'s pairs; 0 when A = 0, 1 when B or C vanish
    while A does not."""
    if t[0] <= wp.float64(0.0):
        return wp.float64(0.0)
    if t[1] <= wp.float64(0.0) or t[2] <= wp.float64(0.0):
        # a top coefficient without lower ones: no decay to trust (and no division by 0)
        return wp.float64(1.0)
    return wp.max(t[0] / t[1], t[1] / t[2])


@wp.func
def k15_floor(f0: vec16d, f1: vec16d):
    """GAMMA14 (|c13| + |c14|) min(1, r) per channel (:func:`legendre_tail`, r its
    :func:`tail_ratio`): what the 15 values' last Legendre pair predicts for |K15 - G7| =
    GAMMA14 |c14| (before the half length), the floor of the outer rule's difference (round 12)."""
    t0 = legendre_tail(f0)
    t1 = legendre_tail(f1)
    return GAMMA14_D * wp.vec2d(t0[0] * wp.min(wp.float64(1.0), tail_ratio(t0)),
                                t1[0] * wp.min(wp.float64(1.0), tail_ratio(t1)))


@wp.func
def decay_ratio(f: vec16d):
    """How fast the Legendre coefficients of the 15-node interpolant of ``f`` (values at the
    nodes in GK_X order) fall over their last six degrees: r = max(A / B, B / C) with
    A = |c13| + |c14|, B = |c11| + |c12|, C = |c9| + |c10| (pairs, so that a function even or
    odd about the centre is not misread). r >= 1 (or 1 when B or C vanish while A does not)
    means the values do not resolve the function; 0 when A = 0 (for a polynomial of degree <= 8
    the six coefficients are rounding noise, and so is |K15 - G7|)."""
    return tail_ratio(legendre_tail(f))


@wp.func
def gk_error_decay(rk: wp.vec2d, rg: wp.vec2d, r: wp.vec2d, safety: wp.float64, power: wp.float64):
    """|K15 - G7| scaled by min(1, safety r^power) per channel (r from :func:`decay_ratio`),
    floored at 50 ulp of |K|: the G7 error, shrunk where the coefficients show that K15 is
    resolved beyond G7."""
    one = wp.float64(1.0)
    out = wp.vec2d(wp.float64(0.0), wp.float64(0.0))
    for c in range(2):
        d = wp.abs(rk[c] - rg[c])
        # min(1, safety r^power), without the pow call where it is 1 (r >= 1, safety >= 1) or 0
        # (r = 0; power > 0), and r^3 as r r r (within 2 ulp of pow: the estimate's last bits)
        fac = one
        if r[c] <= wp.float64(0.0):
            fac = wp.float64(0.0)
        elif r[c] < one or safety < one:
            rp = r[c] * r[c] * r[c]
            if power != wp.float64(3.0):
                rp = wp.pow(r[c], power)
            fac = wp.min(one, safety * rp)
        out[c] = wp.max(d * fac, wp.float64(1.1e-14) * wp.abs(rk[c]))
    return out


# The 7 Gauss values' interpolant in the orthonormal Legendre basis: c_k = sum_j WG7_j P_k(x_j) f_j
# for k <= 6 (G7 is exact to degree 13), as weights in the 15-node order (zero at Kronrod nodes).
# |G7 - I5| is GAMMA6 |c6| (I5 exact to degree 5, G7 to 13): the degree-6 term alone, blind to an
# odd degree-5 one (issue 14, round 12)
_P7 = [np.polynomial.legendre.legval(GK_X, [0.0] * k + [1.0]) * math.sqrt((2.0 * k + 1.0) / 2.0) for k in range(7)]
G7_LEG = [GK_WG * _P7[k] for k in range(7)]
GAMMA6 = float(abs(np.sum(np.concatenate([WI5, WI5[:7]]) * _P7[6])))
GAMMA6_D = wp.constant(wp.float64(GAMMA6))
vec15d = wp.types.vector(length=15, dtype=wp.float64)
G7L3_D, G7L4_D, G7L5_D, G7L6_D = (wp.constant(vec15d(*G7_LEG[k].tolist())) for k in (3, 4, 5, 6))


@wp.func
def pair_floor(f: vec16d, w_lo0: vec15d, w_lo1: vec15d, w_hi0: vec15d, w_hi1: vec15d):
    """A * min(1, A / B) with A = |c_hi0| + |c_hi1| and B = |c_lo0| + |c_lo1|, each coefficient
    c = sum_j w[j] f[j] over the 15 values (weights 0 where a node is not the rule's): the last
    pair of Legendre coefficients of a stage's interpolant, damped by how much smaller it is than
    the pair below (A when B vanishes, 0 when A does)."""
    lo0 = wp.float64(0.0)
    lo1 = wp.float64(0.0)
    hi0 = wp.float64(0.0)
    hi1 = wp.float64(0.0)
    for j in range(15):
        lo0 += w_lo0[j] * f[j]
        lo1 += w_lo1[j] * f[j]
        hi0 += w_hi0[j] * f[j]
        hi1 += w_hi1[j] * f[j]
    a = wp.abs(hi0) + wp.abs(hi1)
    b = wp.abs(lo0) + wp.abs(lo1)
    if a <= wp.float64(0.0):
        return wp.float64(0.0)
    if b <= wp.float64(0.0):
        return a
    return a * wp.min(wp.float64(1.0), a / b)


@wp.func
def first_tail(f: vec16d):
    """(|c5| + |c6|) min(1, r) of the 7 Gauss values' interpolant (orthonormal Legendre), r =
    (|c5| + |c6|) / (|c3| + |c4|) (:func:`pair_floor`)."""
    return pair_floor(f, G7L3_D, G7L4_D, G7L5_D, G7L6_D)


@wp.func
def first_stage(f0: vec16d, f1: vec16d, hl: wp.float64, which: wp.int32, safety: wp.float64):
    """The first stage of the two-stage rule: G7 from the 7 Gauss nodes (odd j in the 15-node
    order of ``f0``, ``f1``) and its error ``safety`` |G7 - I| (I: :data:`WI5` for ``which`` 5,
    else :data:`WI3`, on the same nodes), both times the half length ``hl``; the error floored at
    50 ulp of |G7|. Returns (G7, error).

    What |G7 - I5| measures: the difference of two rules on the same 7 values, i.e. the
    degree-6 term of the 7-point interpolant (I5 is exact to degree 5) -- not G7's own error.
    Its blind spot: a function that the 7 values do not resolve (a ramp or kink narrower than
    the node spacing, e.g. a G1 shadowing ramp next to a horizon where the smoothstep map's
    Jacobian is small) has an interpolant that looks smooth, and |G7 - I5| can then be far
    *below* |G7 - exact| (measured 66x for a GGX G1 ramp of width 0.026, 103x for 1/(1 + w) ramps,
    250x for a Fresnel-like kink). ``safety`` (the adaptive method's ``first_safety``) scales
    it; it is a heuristic, not a bound (docs/methods.md, issue 14, fourth round)."""
    g = wp.vec2d(wp.float64(0.0), wp.float64(0.0))
    q = wp.vec2d(wp.float64(0.0), wp.float64(0.0))
    for j in range(15):
        if j % 2 == 1:
            f = wp.vec2d(f0[j], f1[j])
            g += WG7_D[j % 8] * f
            if which == 5:
                q += WI5_D[j % 8] * f
            else:
                q += WI3_D[j % 8] * f
    out = wp.vec2d(wp.float64(0.0), wp.float64(0.0))
    for c in range(2):
        out[c] = wp.max(safety * wp.abs(g[c] - q[c]) * hl, wp.float64(1.1e-14) * wp.abs(g[c] * hl))
    return g * hl, out


@wp.func
def first_floor(f0: vec16d, f1: vec16d, hl: wp.float64):
    """GAMMA6 (|c5| + |c6|) min(1, r) hl per channel (:func:`first_tail`): what the 7 values'
    last pair predicts for |G7 - I5| = GAMMA6 |c6|, the floor of the first stage's difference
    (round 12). Formed only where a stage would accept (the callers test without it first)."""
    return wp.vec2d(GAMMA6_D * first_tail(f0) * hl, GAMMA6_D * first_tail(f1) * hl)


# the second stage's rule (issue 14, round 11): interpolatory on G7's nodes but +-XGK[3], and the
# Kronrod pairs +-XGK[2], +-XGK[4] (nine nodes, exact to degree 9, positive weights). Any rule on a
# superset of G7's nodes with fewer than 15 is G7 itself (its degree is 13), so a Gauss pair goes;
# +-XGK[3] with +-XGK[2], +-XGK[4] was the most conservative of the positive choices on smooth and
# near-singular test functions
WI9 = _interpolatory([1, 2, 4, 5, 7])
WI9_D = wp.constant(vec8d(*WI9.tolist()))


# the 11 values of the second stage (G7's and +-XGK[2], +-XGK[4]; 15-node order) and their
# interpolant's Legendre coefficients c7 .. c10 (orthonormal) as weights in the 15-node order:
# |G7 - I9| is GAMMA10 |c10| (I9 exact to degree 9), blind to an odd degree-9 term (round 12)
S11 = [1, 2, 3, 4, 5, 7, 9, 10, 11, 12, 13]
_V11 = np.polynomial.legendre.legvander(GK_X[S11], 10) * np.sqrt((2.0 * np.arange(11) + 1.0) / 2.0)
_V11I = np.linalg.inv(_V11)
S11_LEG = []
for _k in range(7, 11):
    _row = np.zeros(15)
    _row[S11] = _V11I[_k]
    S11_LEG.append(_row)
GAMMA10 = float(abs(np.sum(np.concatenate([WI9, WI9[:7]]) * np.polynomial.legendre.legval(GK_X, [0.0] * 10 + [1.0])
                           * math.sqrt(21.0 / 2.0))))
GAMMA10_D = wp.constant(wp.float64(GAMMA10))
S11L7_D, S11L8_D, S11L9_D, S11L10_D = (wp.constant(vec15d(*row.tolist())) for row in S11_LEG)


@wp.func
def second_tail(f: vec16d):
    """(|c9| + |c10|) min(1, r) of the 11 second-stage values' interpolant (orthonormal
    Legendre), r = (|c9| + |c10|) / (|c7| + |c8|) (:func:`pair_floor`)."""
    return pair_floor(f, S11L7_D, S11L8_D, S11L9_D, S11L10_D)


@wp.func
def second_stage(f0: vec16d, f1: vec16d, g: wp.vec2d, hl: wp.float64, safety: wp.float64):
    """The second stage of the three-stage rule: G7 (``g``, times ``hl`` already) with the error
    ``safety`` |G7 - I9|, I9 the interpolatory rule on G7's nodes but +-XGK[3] and the Kronrod
    nodes +-XGK[2], +-XGK[4] (j = 1, 2, 4, 5, 7, 9, 10, 12, 13 of ``f0``, ``f1``); floored at
    50 ulp of |G7|. Returns the error."""
    q = wp.vec2d(wp.float64(0.0), wp.float64(0.0))
    for j in range(15):
        if j == 1 or j == 2 or j == 4 or j == 5 or j == 7 or j == 9 or j == 10 or j == 12 or j == 13:
            q += WI9_D[j % 8] * wp.vec2d(f0[j], f1[j])
    out = wp.vec2d(wp.float64(0.0), wp.float64(0.0))
    for c in range(2):
        out[c] = wp.max(safety * wp.abs(g[c] - q[c] * hl), wp.float64(1.1e-14) * wp.abs(g[c]))
    return out


@wp.func
def second_floor(f0: vec16d, f1: vec16d, hl: wp.float64):
    """GAMMA10 (|c9| + |c10|) min(1, r) hl per channel (:func:`second_tail`): the floor of the
    second stage's |G7 - I9| = GAMMA10 |c10| (round 12), formed only where the stage would accept."""
    return wp.vec2d(GAMMA10_D * second_tail(f0) * hl, GAMMA10_D * second_tail(f1) * hl)


@wp.func
def end_map(t: wp.float64, ends: wp.int32):
    """(s, ds/dt): the map of t in [0, 1] onto a piece's s in [0, 1] that flattens the mapped ends
    (``ends``: 1 the start, 2 the end, 3 both, 0 none). Both: the smoothstep s = 3t^2 - 2t^3; the
    start only: s = t^2; the end only: s = 1 - (1 - t)^2; none: s = t. At a mapped end a
    square-root behaviour sqrt(s) becomes linear in t and a kink smooth; an unmapped end keeps the
    rule's nodes where a smooth integrand needs them (issue 14, seventh round: the inner phi
    pieces end at phi = 0 or pi, where the integrand is even and smooth, as often as at a cut)."""
    one = wp.float64(1.0)
    two = wp.float64(2.0)
    if ends == 3:
        return t * t * (wp.float64(3.0) - two * t), wp.float64(6.0) * t * (one - t)
    if ends == 1:
        return t * t, two * t
    if ends == 2:
        u = one - t
        return one - u * u, two * u
    return t, one


def check_factors(positive: bool, **factors) -> None:
    """Each keyword a finite number, > 0 (``positive``) or >= 0 (0: off); not a bool."""
    for name, value in factors.items():
        ok = not isinstance(value, bool) and math.isfinite(float(value))
        if not (ok and (float(value) > 0.0 if positive else float(value) >= 0.0)):
            raise ValueError(f"{name} must be a finite number {'> 0' if positive else '>= 0 (0: off)'}, got {value!r}")


def check_rule_keywords(inner_first, first_share, first_safety, err_safety, err_power, second_safety=0.0) -> None:
    """The inner error estimates' keywords, validated: the two-stage rule's ``inner_first`` 0
    (off), 5 (I5) or 3 (I3), ``first_share`` in [0, 1], ``first_safety`` finite and > 0 (below 1
    only for measuring the margin: the estimate is then smaller than |G7 - I| itself), the second
    stage's ``second_safety`` finite and >= 0 (0: off); the decay
    estimate's ``err_safety`` and ``err_power`` finite and > 0 (:func:`gk_error_decay` takes a
    decay ratio of 0 to a factor 0, which is the formula's limit only for a positive power)."""
    for name, value in (("err_safety", err_safety), ("err_power", err_power)):
        if isinstance(value, bool) or not (math.isfinite(float(value)) and float(value) > 0.0):
            raise ValueError(f"{name} must be a finite number > 0, got {value!r}")
    if isinstance(inner_first, bool) or inner_first not in (0, 3, 5):
        raise ValueError(f"inner_first must be 0 (off), 3 or 5 (the first stage's lower rule), got {inner_first!r}")
    if not (0.0 <= float(first_share) <= 1.0):
        raise ValueError(f"first_share must be in [0, 1], got {first_share!r}")
    if not (math.isfinite(float(first_safety)) and float(first_safety) > 0.0):
        raise ValueError(f"first_safety must be a finite number > 0, got {first_safety!r}")
    if isinstance(second_safety, bool) or not (math.isfinite(float(second_safety)) and float(second_safety) >= 0.0):
        raise ValueError(f"second_safety must be a finite number >= 0 (0: off), got {second_safety!r}")


STACK = 64
"""Interval capacity of one global bisection (the estimates still count when it is full)."""
stackd = wp.types.vector(length=STACK, dtype=wp.float64)


@wp.func
def gk_error(rk: wp.vec2d, rg: wp.vec2d, resasc: wp.vec2d, err_model: wp.int32):
    """Error estimate of the K15 value from |K15 - G7| (err_model 0), or QUADPACK's rescaling
    resasc min(1, (200 |K - G| / resasc)^1.5) (err_model 1), floored at 50 ulp of |K|."""
    out = wp.vec2d(wp.float64(0.0), wp.float64(0.0))
    for c in range(2):
        d = wp.abs(rk[c] - rg[c])
        e = d
        if err_model == 1 and resasc[c] > wp.float64(0.0) and d > wp.float64(0.0):
            # t^1.5 as t sqrt(t) (within 2 ulp of pow, without libm's general pow)
            t = wp.float64(200.0) * d / resasc[c]
            e = resasc[c] * wp.min(wp.float64(1.0), t * wp.sqrt(t))
        out[c] = wp.max(e, wp.float64(1.1e-14) * wp.abs(rk[c]))
    return out


@wp.func
def gk_resasc(f0: vec16d, f1: vec16d, rk: wp.vec2d):
    """QUADPACK's resasc per channel, before the half length: sum WGK |f - K15 / 2| over the 15
    values (nodes in the device loops' order), rk the K15 weighted sum of the values."""
    mean = rk * wp.float64(0.5)
    out = wp.vec2d(wp.float64(0.0), wp.float64(0.0))
    for j in range(15):
        out += WGK_D[j % 8] * wp.vec2d(wp.abs(f0[j] - mean[0]), wp.abs(f1[j] - mean[1]))
    return out


def make_global_bisection(rule):
    """A ``@wp.func`` ``bisect(p, x, ends, ne, tol, max_rules, cost0)``: global adaptivity with ``rule``.

    ``rule(p, x, a, b)`` returns (K, error, cost) of one rule application over [a, b] (two
    channels; ``x`` carries the rule's own parameters, any type). ``bisect`` starts from the
    intervals between consecutive ``ends[0..ne]`` (a vector; empty intervals are skipped), then
    bisects the interval with the largest error (the larger of its two channels) while either
    channel's summed error exceeds ``tol``, ``used + 2 <= max_rules`` rule applications and the
    :data:`STACK` capacity allow. A texel stopped by a cap keeps its large estimate: the error
    stays honest. ``cost0`` is the zero of the rules' cost type (an int, or a vector of counters).
    Returns (sum of K, sum of errors, sum of the rules' costs, the part of that sum spent by the
    bisections: the cost beyond the initial intervals, the "refinement").
    """

    @wp.func
    def bisect(p: Any, x: Any, ends: Any, ne: wp.int32, tol: wp.float64, max_rules: wp.int32, cost0: Any):
        zero = wp.float64(0.0)
        r_one = wp.vec2d(zero, zero)
        e_one = wp.vec2d(zero, zero)
        c_one = cost0
        if ne == 1 and ends[1] > ends[0]:
            # one interval (the inner level's pieces): apply the rule before the stacks are
            # built, and return at once when it meets the tolerance (most pieces): the same sums
            # as below (0 + r, 0 + e), without zero-filling STACK x 6 doubles per call
            r_one, e_one, c_one = rule(p, x, ends[0], ends[1])
            if e_one[0] <= tol and e_one[1] <= tol:
                return r_one, e_one, cost0 + c_one, cost0
        ia = stackd()
        ib = stackd()
        v0 = stackd()
        v1 = stackd()
        e0 = stackd()
        e1 = stackd()
        n = int(0)
        used = int(0)
        cost = cost0
        cost_ref = cost0
        te = wp.vec2d(zero, zero)
        for q in range(ne):
            if ends[q + 1] > ends[q]:
                r = r_one
                e = e_one
                c = c_one
                if ne != 1:
                    r, e, c = rule(p, x, ends[q], ends[q + 1])
                used += 1
                cost += c
                ia[n] = ends[q]
                ib[n] = ends[q + 1]
                v0[n] = r[0]
                v1[n] = r[1]
                e0[n] = e[0]
                e1[n] = e[1]
                te += e
                n += 1
        while (te[0] > tol or te[1] > tol) and used + 2 <= max_rules and n < STACK:
            j = int(0)
            worst = wp.float64(-1.0)
            for q in range(n):
                w = wp.max(e0[q], e1[q])
                if w > worst:
                    worst = w
                    j = q
            mid = wp.float64(0.5) * (ia[j] + ib[j])
            rl, el, cl = rule(p, x, ia[j], mid)
            rr, er, cr = rule(p, x, mid, ib[j])
            used += 2
            cost += cl + cr
            cost_ref += cl + cr
            te += el + er - wp.vec2d(e0[j], e1[j])
            ia[n] = mid
            ib[n] = ib[j]
            v0[n] = rr[0]
            v1[n] = rr[1]
            e0[n] = er[0]
            e1[n] = er[1]
            ib[j] = mid
            v0[j] = rl[0]
            v1[j] = rl[1]
            e0[j] = el[0]
            e1[j] = el[1]
            n += 1
        total = wp.vec2d(zero, zero)
        err = wp.vec2d(zero, zero)
        for q in range(n):
            total += wp.vec2d(v0[q], v1[q])
            err += wp.vec2d(e0[q], e1[q])
        return total, err, cost, cost_ref

    return bisect

