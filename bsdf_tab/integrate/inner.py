"""The adaptive method's inner level: the integral over phi at one micro-normal angle theta_m.

For fixed theta_m, i.m = sin(theta_i) sin(theta_m) cos(phi) + mu cos(theta_m) is monotone in phi
on [0, pi], and every boundary of the integrand is a threshold on i.m with a closed form (the
reflection horizon, i.m = 0, the critical angle of an eta < 1 Fresnel, the transmission
horizon). :func:`inner_integral` splits [0, pi] at those cuts, drops the pieces where every
channel vanishes, maps each piece at the ends that need it (``p.inner_map``,
:func:`bsdf_tab.integrate.quadrature.end_map`) and integrates it by globally adaptive G7-K15
as a three-stage rule (:func:`gk_phi`); :func:`inner_integral_scaled` also takes the size of a
neighbouring inner integral, with which a Beckmann texel starts its first piece in halves near
o_r = n where the tolerance is tight (issue 14, round 13). :mod:`bsdf_tab.integrate.adaptive` has the method's
account of the estimates and the measurements behind them; this module is its inner half, as
:mod:`bsdf_tab.integrate.outer` is the start of its outer one.
"""

from __future__ import annotations

import warp as wp

from ..model.distribution import BECKMANN
from ..model.shadowing import CORRELATED
from .integrand import (
    MODE_DIELECTRIC, PI64, TexelParams, cos_0_pi, fresnel_knee, integrand_cos, integrand_phi, phi_of_c,
    tir_eta,
)
from .quadrature import (
    WG7_D, WGK_D, decay_ratio, end_map, first_floor, first_stage, gk_abscissa, gk_error, gk_error_decay,
    gk_resasc, make_global_bisection, second_floor, second_stage, vec8d, vec16d,
)

# no kernel of this module is differentiated: no adjoint code
wp.set_module_options({"enable_backward": False})

vec6d = wp.types.vector(length=6, dtype=wp.float64)
# an absent cut: below every i.m of the phi circle (i.m >= -1)
NO_CUT = wp.constant(wp.float64(-2.0))
# node sets of the 15 (bit j: node j of gk_abscissa): G7's (odd j), the Kronrod extension's (even
# j), and the second stage's four of those (+-XGK[2], +-XGK[4])
MASK_G7 = wp.constant(0x2AAA)
MASK_K = wp.constant(0x5555)
MASK_S2 = wp.constant((1 << 2) | (1 << 4) | (1 << 10) | (1 << 12))
# Beckmann's first inner piece starts in halves (``p.normal_split``, issue 14, round 13) only for
# alpha above this (below, Lambda's part that is not analytic at o_r = n is below the tolerances:
# no bisection there to save) and where the inner tolerance is below this share of the integral (one
# K15's estimate near that point measured 2.5e-7 .. 3.4e-7 of it: a looser tolerance accepts it)
NORMAL_SPLIT_ALPHA = wp.constant(wp.float64(0.5))
NORMAL_SPLIT_REL = wp.constant(wp.float64(3.0e-7))
# ... and only where Lambda_o has weight in G: the correlated G / mu = 1 / (mu + li + mu Lambda_o)
# weighs it by G1(i) = mu / (mu + li), 0 at grazing incidence (there the halves cost +25% at mu = 0)
NORMAL_SPLIT_WEIGHT = wp.constant(wp.float64(0.1))


# inlined into gk_phi (its two calls): out of line it took p, x, f0 and f1 by value, ~0.5 KB
# copied per call, and measured 8-11% slower (issue 14, ninth round)
@wp.func(inline=True)
def _phi_nodes(p: TexelParams, x: vec8d, ctr: wp.float64, hl: wp.float64, mask: wp.int32,
               f0: vec16d, f1: vec16d):
    # the integrand at the nodes j of parity ``odd`` (j < 8: +XGK[j], else -XGK[j - 8]) of
    # [ctr - hl, ctr + hl] in t, through the piece's end map (x[6]: which ends, end_map), into
    # f0, f1: first every node's cos(phi) and Jacobian, then the integrand at each (the cosines'
    # chains apart from the integrand's)
    ends = int(x[6])
    ln = x[4] - x[3]
    cps = vec16d()
    jac = vec16d()
    for j in range(15):
        if (mask >> j) & 1 != 0:
            s, ds = end_map(gk_abscissa(ctr, hl, j), ends)
            cps[j] = cos_0_pi(x[3] + ln * s)
            jac[j] = ds * ln
    for j in range(15):
        if (mask >> j) & 1 != 0:
            f = integrand_cos(p, x[0], x[1], x[2], cps[j]) * jac[j]
            f0[j] = f[0]
            f1[j] = f[1]
    return f0, f1


@wp.func
def gk_phi(p: TexelParams, x: vec8d, ta: wp.float64, tb: wp.float64):
    """G7-K15 over t in [ta, tb] for the piece phi = a + (b - a) s(t), s the piece's end map
    (:func:`end_map`, ends x[6]), x = (cm, sm, tm, a, b, thr, ends, -) (cos, sin, tan of theta_m,
    the piece, its first-stage tolerance per unit t, which ends are mapped). Returns (K,
    error, evaluations). ``p.inner_first``: the 7 Gauss nodes (odd j) first, G7 accepted with
    :func:`first_stage`'s error (first_safety |G7 - I5|) if <= thr (tb - ta) and G7 != 0; then
    (``p.second_safety`` > 0) the Kronrod nodes +-XGK[2], +-XGK[4] and G7 accepted with
    :func:`second_stage`'s error (second_safety |G7 - I9|) on the same test, 11 evaluations;
    else the other 4 and K15."""
    half = wp.float64(0.5)
    ctr = half * (ta + tb)
    hl = half * (tb - ta)
    rk = wp.vec2d(wp.float64(0.0), wp.float64(0.0))
    rg = wp.vec2d(wp.float64(0.0), wp.float64(0.0))
    f0 = vec16d()
    f1 = vec16d()
    g = wp.vec2d(wp.float64(0.0), wp.float64(0.0))
    f0, f1 = _phi_nodes(p, x, ctr, hl, MASK_G7, f0, f1)
    # (g = 0: 7 or 11 zeros may miss a support between the nodes; K15 looks at 15 points)
    thr = x[5] * (tb - ta)
    if p.inner_first > 0:
        g, d = first_stage(f0, f1, hl, p.inner_first, p.first_safety)
        if wp.max(d[0], d[1]) <= thr and (g[0] != 0.0 or g[1] != 0.0):
            if p.first_tail > wp.float64(0.0) and p.inner_first == 5:
                # the floor from the 7 values' last Legendre pair (round 12), formed only here
                fl = first_floor(f0, f1, hl) * (p.first_safety * p.first_tail)
                d = wp.vec2d(wp.max(d[0], fl[0]), wp.max(d[1], fl[1]))
            if wp.max(d[0], d[1]) <= thr:
                return g, d, int(7)
    f0, f1 = _phi_nodes(p, x, ctr, hl, MASK_S2, f0, f1)
    if p.inner_first > 0 and p.second_safety > wp.float64(0.0):
        d = second_stage(f0, f1, g, hl, p.second_safety)
        if wp.max(d[0], d[1]) <= thr and (g[0] != 0.0 or g[1] != 0.0):
            if p.second_tail > wp.float64(0.0):
                # |G7 - I9| is one coefficient: floored by its Legendre pair (round 12), formed only here
                fl = second_floor(f0, f1, hl) * (p.second_safety * p.second_tail)
                d = wp.vec2d(wp.max(d[0], fl[0]), wp.max(d[1], fl[1]))
            if wp.max(d[0], d[1]) <= thr:
                return g, d, int(11)
    f0, f1 = _phi_nodes(p, x, ctr, hl, MASK_K - MASK_S2, f0, f1)
    for j in range(15):
        jj = j
        if j >= 8:
            jj = j - 8
        f = wp.vec2d(f0[j], f1[j])
        rk += WGK_D[jj] * f
        if j % 2 == 1:
            # (G7's weight is 0 at the Kronrod nodes: the loop is unrolled, the test folded)
            rg += WG7_D[jj] * f
    if p.err_model_inner == 2:
        # a channel with K15 = G7 has the error 0 whatever its decay ratio (reflection's
        # channel 1 is always 0): its 90 Legendre products are not formed
        r = wp.vec2d(wp.float64(0.0), wp.float64(0.0))
        if rk[0] * hl != rg[0] * hl:
            r[0] = decay_ratio(f0)
        if rk[1] * hl != rg[1] * hl:
            r[1] = decay_ratio(f1)
        return rk * hl, gk_error_decay(rk * hl, rg * hl, r, p.err_safety, p.err_power), int(15)
    resasc = gk_resasc(f0, f1, rk)
    return rk * hl, gk_error(rk * hl, rg * hl, resasc * hl, p.err_model_inner), int(15)


@wp.func
def _normal_point_within(p: TexelParams, cm: wp.float64, ss: wp.float64, y: wp.float64):
    """Whether the point o_r = n lies within y of phi = 0 (Beckmann's Lambda, exp(-cot^2 theta_o /
    alpha^2), is not analytic there): it sits at phi = i y0, cosh(y0) = ((1 + mu) / (2 cos theta_m)
    - mu cos theta_m) / ss (ss = sin theta_i sin theta_m), near phi = 0 when theta_m ~ theta_i / 2.
    cosh(y) by its Taylor polynomial to y^4: a threshold (the y^6 / 720 left out moves it by < 2e-8
    at the map's y <= 0.03 pi, < 1e-3 relative at the halves' y <= 0.3 pi); no exp per inner integral."""
    one = wp.float64(1.0)
    y2 = y * y
    return (one + p.mu) / (wp.float64(2.0) * cm) - p.mu * cm < (one + y2 * wp.float64(0.5) * (one + y2 / wp.float64(12.0))) * ss


# globally adaptive G7-K15 over one phi piece (t in [0, 1]): bisect the worst interval until the
# summed error of both channels is below the piece's share of the inner tolerance
_adaptive_piece = make_global_bisection(gk_phi)


@wp.func
def inner_integral(p: TexelParams, cm: wp.float64, sm: wp.float64, tm: wp.float64, tol: wp.float64,
                   max_rules: wp.int32):
    """int_0^pi of the integrand over phi, split at the closed-form thresholds on i.m."""
    return inner_integral_scaled(p, cm, sm, tm, tol, max_rules, wp.float64(0.0))


@wp.func
def inner_integral_scaled(p: TexelParams, cm: wp.float64, sm: wp.float64, tm: wp.float64, tol: wp.float64,
                          max_rules: wp.int32, scale: wp.float64):
    """:func:`inner_integral` with ``scale``, the size of a neighbouring inner integral (the outer
    rule's previous node; 0: unknown), which lets a Beckmann texel start its first piece in halves
    where one K15 would be rejected anyway (``p.normal_split``)."""
    zero = wp.float64(0.0)
    one = wp.float64(1.0)
    pi = PI64
    total = wp.vec2d(zero, zero)
    err = wp.vec2d(zero, zero)
    ss = p.sin_i * sm
    if ss <= wp.float64(1.0e-300):
        # i.m does not depend on phi (normal incidence or m = n): constant integrand
        f = integrand_phi(p, cm, sm, tm, wp.float64(0.5) * pi)
        return f * pi, err, int(1), int(0)  # one evaluation
    c_min = p.mu * cm - ss
    c_max = p.mu * cm + ss
    # the candidate thresholds on i.m (k2, k3 = NO_CUT where absent): i.m = 0, the reflection
    # horizon, then the critical (or knee) i.m and the transmission horizon
    k0 = zero
    k1 = p.mu / (wp.float64(2.0) * cm)
    k2 = NO_CUT
    k3 = NO_CUT
    # lowest i.m where transmission exists (eta < 1): c_TIR, or the transmission horizon c_t
    # where (c/eta - sqrt(k2)) cos(theta_m) = mu/eta (that root is valid only if c_t >= mu/cm)
    t_floor = zero
    if p.mode == MODE_DIELECTRIC and p.eta < one:
        e2 = one - p.eta * p.eta
        k2 = wp.sqrt(e2)
        t_floor = k2
        if p.mu > zero:
            c_t = k1 + e2 * cm / (wp.float64(2.0) * p.mu)
            if c_t * cm >= p.mu:
                k3 = c_t
                t_floor = c_t
        else:
            # grazing from inside: o_t.n = (c/eta - sqrt(k2)) cos(theta_m) > 0, never transmitted
            t_floor = wp.float64(2.0)
    else:
        eta_f = tir_eta(p)
        if eta_f < one:
            # reflection with a dielectric Fresnel of eta < 1: its square-root kink at the critical angle
            k2 = wp.sqrt(one - eta_f * eta_f)
        else:
            knee = fresnel_knee(p)
            if knee > zero:
                # eta just above 1: the Fresnel's knee (mapped as the critical cut is)
                k2 = knee
    # the cuts in phi order: i.m falls as phi grows, so sort the i.m descending, in scalars (a
    # sorting network: insertion into vectors by value cost ~5% of a loose-tolerance table in
    # store-forwarding stalls, issue 14, tenth round); the phi of each one inside (c_min, c_max)
    s0 = wp.max(k0, k1)
    s1 = wp.min(k0, k1)
    s2 = wp.max(k2, k3)
    s3 = wp.min(k2, k3)
    h0 = wp.max(s0, s2)
    l2 = wp.min(s0, s2)
    h1 = wp.max(s1, s3)
    l3 = wp.min(s1, s3)
    sorted_c = wp.vec4d(h0, wp.max(l2, h1), wp.min(l2, h1), l3)
    cuts = vec6d()
    cuts_c = vec6d()  # the cuts' i.m, in the same order
    nc = int(0)
    phi_crit = wp.float64(-1.0)
    for q in range(4):
        cb = sorted_c[q]
        if cb > c_min and cb < c_max:
            phc = phi_of_c(cb, p, cm, sm)
            if cb == k2:
                phi_crit = phc
            cuts[nc] = phc
            cuts_c[nc] = cb
            nc += 1
    # below c_floor every channel vanishes: reflection needs i.m > mu / (2 cos theta_m), and
    # transmission i.m > 0 (eta >= 1) or i.m above the transmission horizon (eta < 1)
    c_floor = wp.where(p.mode == MODE_DIELECTRIC, wp.min(k1, t_floor), k1)
    a = zero
    c_a = c_max  # i.m at the piece's start a (the cut's own value: no cos(acos(.)) round trip)
    rules = int(0)
    rules_ref = int(0)
    for q in range(nc + 1):
        b = pi
        if q < nc:
            b = cuts[q]
        if c_a <= c_floor + wp.float64(1.0e-12):
            # i.m falls as phi grows: this piece and all later ones are empty (1e-12: as when
            # i.m(a) was recomputed from the rounded cut a)
            break
        if b > a:
            tp = tol * (b - a) / pi
            # the ends to map (end_map): every end (inner_map 0), the cuts (1), the critical cut (2)
            ends = 3
            if p.inner_map == 1:
                ends = wp.where(a > zero, 1, 0) + wp.where(q < nc, 2, 0)
            elif p.inner_map == 2:
                ends = wp.where(a == phi_crit, 1, 0) + wp.where(b == phi_crit, 2, 0)
            if a == zero and p.dist == BECKMANN and p.normal_map > zero:
                # closer than normal_map times the piece, G7 and K15 agreed to 1e-8 while both
                # missed 1.7e-7 (issue 14, round 12): phi = 0 is mapped, which moves the point
                # away from the nodes' reach
                if _normal_point_within(p, cm, ss, p.normal_map * b):
                    ends = ends | 1
            x = vec8d(cm, sm, tm, a, b, p.first_share * tp, wp.float64(ends), zero)
            halves = False
            if (a == zero and p.dist == BECKMANN and p.normal_split > zero and p.alpha > NORMAL_SPLIT_ALPHA
                    and tol < NORMAL_SPLIT_REL * scale
                    and (p.shadowing != CORRELATED or p.mu > NORMAL_SPLIT_WEIGHT * (p.mu + p.li))):
                # within normal_split of the piece one K15 is ~1e-12 off, but its estimate (the
                # Legendre pairs plateau before they fall) ~3e-7 of the integral, so a tighter
                # tolerance rejects it and bisects; the halves from the start save that rule (round 13)
                halves = _normal_point_within(p, cm, ss, p.normal_split * b)
            if halves:
                r, e, used, used_ref = _adaptive_piece(p, x, wp.vec3d(zero, wp.float64(0.5), one), 2, tp, max_rules, int(0))
            else:
                r, e, used, used_ref = _adaptive_piece(p, x, wp.vec2d(zero, one), 1, tp, max_rules, int(0))
            total += r
            err += e
            rules += used
            rules_ref += used_ref
        a = b
        if q < nc:
            c_a = cuts_c[q]
    return total, err, rules, rules_ref
