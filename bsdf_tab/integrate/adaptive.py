"""The default integrator: nested, error-controlled adaptive Gauss-Kronrod in micro-normal space.

Every hemispherical integral of the catalog is rewritten over the micro-normal m (Walter et al.
2007, eqs. 14 and 17: the Jacobians cancel against the BSDF's denominators):

    E  = int F(i.m) G(i, o_r) D(m) (i.m) / mu  dw_m     over o_r = reflect(i, m) above,
    T  = int (1 - F(i.m)) G(i, o_t) D(m) (i.m) / mu  dw_m   over o_t = refract(i, m) below.

Micro-normals are parametrized by (v, phi): u = 1 - (1 - v)^2 is the CDF of D(m) cos(theta_m) in
theta_m (closed form for GGX and Beckmann), so D cos dw_m = du dphi / (2 pi) and the integrand is
F G (i.m) / (mu cos theta_m), bounded, and scale-free in alpha (near-mirror alpha costs nothing
extra). The v map also removes the (1 - u)^(-1/2) growth of tan(theta_m) at grazing.

For fixed theta_m, i.m = sin(theta_i) sin(theta_m) cos(phi) + mu cos(theta_m) is monotone in phi on
[0, pi], and every boundary of the integrand is a threshold on i.m with a closed form:
the reflection horizon o_r.n = 0 at i.m = mu / (2 cos theta_m), i.m = 0, total internal reflection
at i.m = sqrt(1 - eta^2), and the transmission horizon o_t.n = 0 at
i.m = mu / (2 cos theta_m) + (1 - eta^2) cos theta_m / (2 mu) (eta < 1, where that root is valid). The inner phi integral is
split at those points, each piece mapped by phi = a + (b - a)(3 t^2 - 2 t^3) (which smooths the
square-root behaviour of Fresnel at the critical angle and of the horizons), and integrated by
adaptive G7-K15 as a two-stage rule (issue 14, fourth round): the 7 Gauss nodes first, and G7
is accepted with the error ``first_safety`` |G7 - I5| = 8 |G7 - I5| (I5 the interpolatory rule on
5 of those nodes) where that fits the interval's share of the piece's tolerance; otherwise the
8 Kronrod nodes are added and the interval is K15 with the estimate below (the 7 values reused,
so a rejected first stage costs nothing). The outer v integral is adaptive G7-K15 too, started from the closed-form
theta_m where the phi pieces change (theta_m = (pi/2 -+ theta_i)/2, pi/2 - theta_i, the
critical-angle crossings, and where two thresholds cross: :mod:`bsdf_tab.integrate.outer`), and
each outer rule works through a smoothstep map of its initial piece (issue 14, sixth round: the
outer integrand's kinks and half-integer powers sit at the piece ends, where the map makes them
smooth; with the round's other changes -36% evaluations at 5e-7 on the 1634-texel harness).

Adaptivity is global at both levels (bisect the interval with the largest estimate until the
sum meets the budget: ``inner_share`` = 0.85 of the tolerance for the inner integrals, the rest
for the outer one). The inner estimates enter a texel's error at ``INNER_CARRY`` = 4 times
their value, and each inner integral aims at its share / 4: single inner estimates can
under-report (below), and with the map the outer level no longer bisects enough to absorb that
(a texel at 1e-7 reported 0.79 of its true error with the factor 1). The outer integral starts from the breakpoints above, each piece between
them cut into equal parts in theta_m no wider than ``max_dtheta`` (pi/16; pi/8 at tolerances
>= 5e-7) and no longer than ``max_piece`` = 1/4 in v (1/2 at tolerances >= 1e-4): the v map packs theta_m >> alpha into a
sliver near v = 1, where a single rule could otherwise step over the horizon structure
unnoticed. (Issue 14's fourth round gave rough texels, alpha >= 0.3, a coarser floor at
tolerances >= 1e-4; with the map its pi/4 parts under-reported, and the floor of every texel
there is now its pi/8 parts and 1/2 pieces: the rough floor is gone.) ``n_fixed``
fixed angles theta_m = k pi/16 were the floor before issue 14's second round; docs/methods.md
has the measurements behind every constant.

The D tail (issue 14, third round): :func:`bsdf_tab.integrate.integrand.mass_bound` is a
rigorous upper bound of the outer integral over a piece of v (the piece's D cos mass, closed in
v, times a bound of the integrand: F <= 1, G / mu <= 1 / (mu + mu Lambda(mu)),
(i.m) / cos theta_m <= mu + sin(theta_i) tan(theta_m), and a tail form at the horizon). The
integrand is >= 0 and the rules' weights are positive, so both the true piece integral and any
rule's value lie in [0, max(K, bound)]: (1) every outer rule reports min(estimate,
max(K, bound)); (2) at tolerances >= 1e-4, the longest run of last initial intervals whose
summed bound fits in ``bound_share`` = 1/4 of the budget is not integrated at all (value 0,
error the bound), and the rest of the budget goes to the other intervals (below 1e-4 it saved
~1%, and values there are otherwise far more accurate than their tolerance). Both are proofs, not heuristics; the bound is
attained in the limit alpha -> 0 at normal incidence, so the true / reported ratio of a skipped
tail can reach 1 there (measured 0.9997). ``bound_share`` < 0 switches both off, 0 only (2).

Error estimate: the outer v level uses QUADPACK's rescaling of |K15 - G7| (err_model 1,
default; 0: |K15 - G7| itself; 2: as the inner default), summed over the accepted intervals,
plus the inner estimates carried through the outer weights; floored at 1e-9 (tolerances >= 1e-7;
down to 1e-10 below). The inner phi level (``err_model_inner`` 2) scales |K15 - G7| (the error
of G7) by min(1, ``err_safety`` r^``err_power``) = min(1, r^3), r the decay ratio of the last
Legendre coefficients of the 15-node interpolant
(:func:`bsdf_tab.integrate.quadrature.decay_ratio`): where the coefficients fall fast, K15 is
resolved far beyond G7; where they do not (r >= 1) the estimate is |K15 - G7|; an accepted
first stage reports 8 |G7 - I5| (:func:`bsdf_tab.integrate.quadrature.first_stage`), the degree-6
term of the 7 values' interpolant, not G7's error, blind to what 7 values do not resolve (one
inner integral can under-report: 9 of 24000 random ones, 20 with 4 |G7 - I5|, 83 with the plain). Texel
honesty rests on the outer level, measured, not proven: on 1634 reference texels
(``bench/accuracy_honesty.py``, 1e-2 .. 1e-7) none reports less than its true error, worst
heuristic ratio 0.44 (with the factor 4, one at 1e-3: 1.32); the outer rule compares K15 with G7
over 15 inner results, so an inner miss perturbs the outer difference. The same estimate at the outer level, r^6, or the two-stage rule
there under-reported (docs/methods.md). Rule applications are capped per texel (``max_rules_outer``,
``max_rules_inner`` per phi piece): a texel that cannot reach the tolerance within the cap
reports its large estimate instead of a wrong small one.

Where the pieces live: the integrand, the mirror limit, the mass bound and the breakpoints'
thresholds in :mod:`bsdf_tab.integrate.integrand` (shared with the fixed-effort methods); the
D cos CDF v(theta_m) and its inverse in :mod:`bsdf_tab.model`; the G7-K15 and I5 constants, the
error models and the global bisection (both levels) in :mod:`bsdf_tab.integrate.quadrature`.
This module holds the two rules, the breakpoints, the kernel and its launcher.

References: Walter et al. 2007, "Microfacet Models for Refraction through Rough Surfaces";
Piessens et al. 1983, "QUADPACK" (Gauss-Kronrod 7-15 rule).
"""

from __future__ import annotations

import math

import numpy as np
import warp as wp

from ..model.distribution import dcos_tan_of_v
from .integrand import (  # noqa: F401  (MODE_*, MODES, TexelParams: this module's former names)
    MODE_DFG, MODE_DIELECTRIC, MODE_REFLECT, MODES, TexelParams, begin_texel, insert_sorted, integrand_phi,
    mass_bound, phi_of_c, tir_eta, mode_id,
)
from .outer import OuterX, initial_ends, v_of_w, vec48d
from .quadrature import WG7_D, WGK_D, XGK_D, check_rule_keywords, decay_ratio, end_map, first_stage, vec16d, gk_error, gk_error_decay, make_global_bisection
from .runtime import check_workers, chunk_launcher, resolve_device, run_chunks, texel_arrays

# no kernel of this module is differentiated: no adjoint code (a third of the compile time)
wp.set_module_options({"enable_backward": False})

_vec6d = wp.types.vector(length=6, dtype=wp.float64)
_vec8d = wp.types.vector(length=8, dtype=wp.float64)
_vec16d = vec16d

_PI = wp.constant(wp.float64(math.pi))
INNER_CARRY = 2.0  # the factor on the inner estimates in a texel's error (docs/methods.md, issue 14, rounds 6-7)
OUTER_FIRST_SAFETY = 32.0  # the factor on the outer first stage's |G7 - I5| (docs/methods.md, issue 14, round 7)
FIRST_SAFETY = 8.0  # the factor on the inner first stage's |G7 - I5| (docs/methods.md, issue 14, rounds 4-5)


@wp.func
def _phi_node(p: TexelParams, x: _vec8d, ctr: wp.float64, hl: wp.float64, j: wp.int32):
    # the integrand at node j (j < 8: +XGK[j], else -XGK[j - 8]) of [ctr - hl, ctr + hl] in t,
    # through the piece's end map (x[6]: which ends are mapped, end_map)
    jj = j
    sgn = wp.float64(1.0)
    if j >= 8:
        jj = j - 8
        sgn = wp.float64(-1.0)
    s, ds = end_map(ctr + sgn * hl * XGK_D[jj], int(x[6]))
    return integrand_phi(p, x[0], x[1], x[2], x[3] + (x[4] - x[3]) * s) * (ds * (x[4] - x[3]))


@wp.func
def _gk_phi(p: TexelParams, x: _vec8d, ta: wp.float64, tb: wp.float64):
    """G7-K15 over t in [ta, tb] for the piece phi = a + (b - a)(3t^2 - 2t^3), x = (cm, sm, tm, a, b,
    thr) (cos, sin, tan of theta_m, the piece, its first-stage tolerance per unit t). Returns (K,
    error, evaluations). ``p.inner_first``: the 7 Gauss nodes (odd j) first, G7 accepted with
    :func:`first_stage`'s error (first_safety |G7 - I5|) if <= thr (tb - ta) and G7 != 0; else K15."""
    half = wp.float64(0.5)
    ctr = half * (ta + tb)
    hl = half * (tb - ta)
    rk = wp.vec2d(wp.float64(0.0), wp.float64(0.0))
    rg = wp.vec2d(wp.float64(0.0), wp.float64(0.0))
    f0 = _vec16d()
    f1 = _vec16d()
    for j in range(15):
        if j % 2 == 1:
            f = _phi_node(p, x, ctr, hl, j)
            f0[j] = f[0]
            f1[j] = f[1]
    if p.inner_first > 0:
        g, d = first_stage(f0, f1, hl, p.inner_first, p.first_safety)
        # (g = 0: 7 zeros may miss a support between the nodes; K15 looks at 15 points)
        if wp.max(d[0], d[1]) <= x[5] * (tb - ta) and (g[0] != 0.0 or g[1] != 0.0):
            return g, d, int(7)
    for j in range(15):
        if j % 2 == 0:
            f = _phi_node(p, x, ctr, hl, j)
            f0[j] = f[0]
            f1[j] = f[1]
    for j in range(15):
        jj = j
        if j >= 8:
            jj = j - 8
        f = wp.vec2d(f0[j], f1[j])
        rk += WGK_D[jj] * f
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
    mean = rk * half
    resasc = wp.vec2d(wp.float64(0.0), wp.float64(0.0))
    for j in range(15):
        jj = j
        if j >= 8:
            jj = j - 8
        resasc += WGK_D[jj] * wp.vec2d(wp.abs(f0[j] - mean[0]), wp.abs(f1[j] - mean[1]))
    return rk * hl, gk_error(rk * hl, rg * hl, resasc * hl, p.err_model_inner), int(15)


# globally adaptive G7-K15 over one phi piece (t in [0, 1]): bisect the worst interval until the
# summed error of both channels is below the piece's share of the inner tolerance
_adaptive_piece = make_global_bisection(_gk_phi)


@wp.func
def _inner(p: TexelParams, cm: wp.float64, sm: wp.float64, tm: wp.float64, tol: wp.float64,
           max_rules: wp.int32):
    """int_0^pi of the integrand over phi, split at the closed-form thresholds on i.m."""
    zero = wp.float64(0.0)
    one = wp.float64(1.0)
    pi = _PI
    total = wp.vec2d(zero, zero)
    err = wp.vec2d(zero, zero)
    ss = p.sin_i * sm
    if ss <= wp.float64(1.0e-300):
        # i.m does not depend on phi (normal incidence or m = n): constant integrand
        f = integrand_phi(p, cm, sm, tm, wp.float64(0.5) * pi)
        return f * pi, err, int(1), int(0)  # one evaluation
    c_min = p.mu * cm - ss
    c_max = p.mu * cm + ss
    cuts = _vec6d()
    nc = int(0)
    cands = _vec6d()
    ncand = int(0)
    cands[0] = zero
    cands[1] = p.mu / (wp.float64(2.0) * cm)
    ncand = 2
    # lowest i.m where transmission exists (eta < 1): c_TIR, or the transmission horizon c_t
    # where (c/eta - sqrt(k2)) cos(theta_m) = mu/eta (that root is valid only if c_t >= mu/cm)
    t_floor = zero
    if p.mode == MODE_DIELECTRIC and p.eta < one:
        e2 = one - p.eta * p.eta
        cands[2] = wp.sqrt(e2)
        ncand = 3
        t_floor = cands[2]
        if p.mu > zero:
            c_t = p.mu / (wp.float64(2.0) * cm) + e2 * cm / (wp.float64(2.0) * p.mu)
            if c_t * cm >= p.mu:
                cands[3] = c_t
                ncand = 4
                t_floor = c_t
        else:
            # grazing from inside: o_t.n = (c/eta - sqrt(k2)) cos(theta_m) > 0, never transmitted
            t_floor = wp.float64(2.0)
    elif tir_eta(p) < one:
        # reflection with a dielectric Fresnel of eta < 1: its square-root kink at the critical angle
        cands[2] = wp.sqrt(one - tir_eta(p) * tir_eta(p))
        ncand = 3
    phi_crit = wp.float64(-1.0)
    for q in range(ncand):
        cb = cands[q]
        if cb > c_min and cb < c_max:
            phc = phi_of_c(cb, p, cm, sm)
            if q == 2:
                phi_crit = phc
            cuts = insert_sorted(cuts, nc, phc)
            nc += 1
    # below c_floor every channel vanishes: reflection needs i.m > mu / (2 cos theta_m), and
    # transmission i.m > 0 (eta >= 1) or i.m above the transmission horizon (eta < 1)
    c_floor = wp.where(p.mode == MODE_DIELECTRIC, wp.min(cands[1], t_floor), cands[1])
    a = zero
    rules = int(0)
    rules_ref = int(0)
    for q in range(nc + 1):
        b = pi
        if q < nc:
            b = cuts[q]
        if p.mu * cm + ss * wp.cos(a) <= c_floor + wp.float64(1.0e-12):
            # i.m falls as phi grows: this piece and all later ones are empty (1e-12: a cut's
            # rounding leaves i.m(a) just above c_floor, and then a piece of zeros)
            break
        if b > a:
            tp = tol * (b - a) / pi
            # the ends to map (end_map): every end (inner_map 0), the cuts (1), the critical cut (2)
            ends = 3
            if p.inner_map == 1:
                ends = wp.where(a > zero, 1, 0) + wp.where(q < nc, 2, 0)
            elif p.inner_map == 2:
                ends = wp.where(a == phi_crit, 1, 0) + wp.where(b == phi_crit, 2, 0)
            r, e, used, used_ref = _adaptive_piece(p, _vec8d(cm, sm, tm, a, b, p.first_share * tp, wp.float64(ends), zero),
                                                   wp.vec2d(zero, one), 1, tp, max_rules, int(0))
            total += r
            err += e
            rules += used
            rules_ref += used_ref
        a = b
    return total, err, rules, rules_ref


@wp.func
def _v_node(p: TexelParams, x: OuterX, ctr: wp.float64, hl: wp.float64, j: wp.int32):
    """One outer node (j < 8 at +XGK[j], else -XGK[j - 8] of [ctr - hl, ctr + hl] in w): the inner
    integral times the Jacobian 2 (1 - v) dv/dw, its estimate times the same and ``x.carry``,
    and the inner rule counts (applications, of which bisections)."""
    one = wp.float64(1.0)
    jj = j
    sgn = one
    if j >= 8:
        jj = j - 8
        sgn = -one
    v, dvdw = v_of_w(x, ctr + sgn * hl * XGK_D[jj])
    tm = dcos_tan_of_v(v, p.alpha, p.dist)
    cm = one / wp.sqrt(one + tm * tm)
    sm = tm * cm
    jac = wp.float64(2.0) * (one - v)
    # the inner budget per unit v as before the map (its sum over the v range is tol_in)
    f, e, used, used_ref = _inner(p, cm, sm, tm, x.tol_in / (jac * x.carry), x.max_rules)
    jac = jac * dvdw
    return f * jac, e * (jac * x.carry), wp.vec2i(used, used_ref)


@wp.func
def _gk_v(p: TexelParams, x: OuterX, wa: wp.float64, wb: wp.float64):
    """G7-K15 over w in [wa, wb] of 2 (1 - v) inner(v) dv/dw, v = v(w) the piece map of
    ``x.ends`` (:func:`bsdf_tab.integrate.outer.v_of_w`); ``x`` also carries the inner budget per
    unit v, the inner rule cap, the factor on the inner estimates and the first stage.

    v is the distribution's D cos CDF variable (:func:`bsdf_tab.model.dcos_tan_of_v`). With
    ``x.first`` the 7 Gauss nodes come first, and G7 is accepted when ``x.safety`` |G7 - I5| plus
    the carried inner estimates fits in ``x.thr`` per unit w (issue 14, seventh round); otherwise
    the 8 Kronrod nodes are added (the 7 values reused).
    Returns (K, error incl. the inner estimates, (inner rule applications, of which bisections))."""
    half = wp.float64(0.5)
    ctr = half * (wa + wb)
    hl = half * (wb - wa)
    rk = wp.vec2d(wp.float64(0.0), wp.float64(0.0))
    rg = wp.vec2d(wp.float64(0.0), wp.float64(0.0))
    ei = wp.vec2d(wp.float64(0.0), wp.float64(0.0))
    eg = wp.vec2d(wp.float64(0.0), wp.float64(0.0))
    f0 = _vec16d()
    f1 = _vec16d()
    rules = wp.vec2i(0, 0)
    g = wp.vec2d(wp.float64(0.0), wp.float64(0.0))
    d = wp.vec2d(wp.float64(0.0), wp.float64(0.0))
    accepted = int(0)
    # one call site of _v_node (it holds the whole inner integral: a second one doubled the
    # CUDA compile): the 7 Gauss nodes (odd j) first, then the first stage, then the 8 others
    for k in range(15):
        j = 2 * k + 1
        if k >= 7:
            j = 2 * (k - 7)
        if k == 7 and x.first > 0:
            g, d = first_stage(f0, f1, hl, x.first, x.safety)
            d = d + eg * hl
            if wp.max(d[0], d[1]) <= x.thr * (wb - wa):
                accepted = 1
                break
        f, e, used = _v_node(p, x, ctr, hl, j)
        rules += used
        f0[j] = f[0]
        f1[j] = f[1]
        rk += WGK_D[j % 8] * f
        rg += WG7_D[j % 8] * f
        ei += WGK_D[j % 8] * e
        eg += WG7_D[j % 8] * e
    if accepted != 0:
        return g, d, rules
    mean = rk * half
    resasc = wp.vec2d(wp.float64(0.0), wp.float64(0.0))
    for j in range(15):
        jj = j
        if j >= 8:
            jj = j - 8
        resasc += WGK_D[jj] * wp.vec2d(wp.abs(f0[j] - mean[0]), wp.abs(f1[j] - mean[1]))
    est = gk_error(rk * hl, rg * hl, resasc * hl, p.err_model) + ei * hl
    if p.err_model == 2:
        r = wp.vec2d(decay_ratio(f0), decay_ratio(f1))
        est = gk_error_decay(rk * hl, rg * hl, r, p.err_safety, p.err_power) + ei * hl
    va, _dva = v_of_w(x, wa)  # (dv/dw unused: the bound is over the piece in v)
    vb, _dvb = v_of_w(x, wb)
    bnd = mass_bound(p, va, vb)
    if bnd >= wp.float64(0.0):
        # the true value and K (positive weights, g >= 0) are both in [0, max(K, bnd)]
        for c in range(2):
            est[c] = wp.min(est[c], wp.max(rk[c] * hl, bnd))
    return rk * hl, est, rules


# the outer level: global adaptivity in v over the initial pieces, with the same routine
_adaptive_outer = make_global_bisection(_gk_v)


@wp.kernel
def texel_kernel(
    idx: wp.array(dtype=wp.int32),
    mu_a: wp.array(dtype=wp.float64),
    alpha_a: wp.array(dtype=wp.float64),
    eta_a: wp.array(dtype=wp.float64),
    mode: wp.int32,
    dist: wp.int32,
    shadowing: wp.int32,
    ftype: wp.int32,
    fp0: wp.float64,
    fp1: wp.float64,
    tol: wp.float64,
    err_model: wp.int32,
    max_rules_outer: wp.int32,
    max_rules_inner: wp.int32,
    inner_share: wp.float64,
    max_piece: wp.float64,
    n_fixed: wp.int32,
    err_model_inner: wp.int32,
    err_safety: wp.float64,
    err_power: wp.float64,
    max_dtheta: wp.float64,
    err_floor: wp.float64,
    bound_share: wp.float64,
    inner_first: wp.int32,
    first_share: wp.float64,
    first_safety: wp.float64,
    outer_map: wp.int32,
    inner_carry: wp.float64,
    outer_first: wp.int32,
    outer_first_safety: wp.float64,
    inner_map: wp.int32,
    value: wp.array2d(dtype=wp.float64),
    error: wp.array2d(dtype=wp.float64),
    cost: wp.array(dtype=wp.int32),
    detail: wp.array2d(dtype=wp.int32),
):
    i, p, done = begin_texel(wp.tid(), idx, mu_a, alpha_a, eta_a, mode, dist, shadowing, ftype, fp0, fp1, value, error)
    if done:
        # alpha = 0: the mirror limit is stored, one evaluation
        cost[i] = 1
        detail[i, 0] = 1
        return
    p.err_model = err_model
    p.err_model_inner = err_model
    if err_model_inner >= 0:
        p.err_model_inner = err_model_inner
    p.err_safety = err_safety
    p.err_power = err_power
    p.bound_share = bound_share
    p.inner_first = inner_first
    p.first_share = first_share
    p.first_safety = first_safety
    p.inner_map = inner_map
    # the outer level's start (bsdf_tab.integrate.outer): breakpoints, floor, D tail left out;
    # the budget: inner_share for the inner phi integrals (summed through the outer weights, at
    # most tol_in in total), the rest for the outer v quadrature
    tol_total = tol * _PI
    ends, ne, skip = initial_ends(p, mode, tol_total, n_fixed, max_dtheta, max_piece, bound_share)
    tol_in = inner_share * (tol_total - skip)

    ox = OuterX()
    ox.tol_in = tol_in
    ox.max_rules = max_rules_inner
    ox.omap = outer_map
    ox.carry = inner_carry
    ox.first = outer_first
    ox.thr = wp.float64(0.0)
    ox.safety = outer_first_safety
    if ne > 0:
        # the first stage's budget: the texel's, spread evenly over the initial pieces in w
        ox.thr = (tol_total - skip) / wp.float64(ne)
    ox.ends = ends
    wends = vec48d()
    for q in range(ne + 1):
        wends[q] = wp.float64(q)
    total, err, rules, rules_ref = _adaptive_outer(p, ox, wends, ne,
                                                   tol_total - skip, max_rules_outer, wp.vec2i(0, 0))
    err += wp.vec2d(skip, skip)
    value[i, 0] = total[0] / _PI
    value[i, 1] = total[1] / _PI
    # floor (err_floor, see integrate_texels): what the estimates cannot certify
    error[i, 0] = wp.max(err[0] / _PI, err_floor)
    error[i, 1] = wp.max(err[1] / _PI, err_floor)
    # integrand evaluations (the inner rules count theirs: 15 or 7 per application, 1 for a
    # phi-independent integrand)
    cost[i] = rules[0]
    # where they went: (outer floor, outer bisections) x (inner first rules, inner bisections)
    fl = rules - rules_ref
    detail[i, 0] = fl[0] - fl[1]
    detail[i, 1] = fl[1]
    detail[i, 2] = rules_ref[0] - rules_ref[1]
    detail[i, 3] = rules_ref[1]


def integrate_texels(
    mode: str,
    mu: np.ndarray,
    alpha: np.ndarray,
    eta: np.ndarray | None = None,
    *,
    dist: int = 0,
    shadowing: int = 1,
    ftype: int = 0,
    fp0: float = 0.0,
    fp1: float = 0.0,
    tol: float = 5e-7,
    device=None,
    workers: int | None = None,
    progress=None,
    err_model: int = 1,
    max_rules_outer: int = 400,
    max_rules_inner: int = 200,
    inner_share: float = 0.85,
    max_piece: float | None = None,
    n_fixed: int = 0,
    err_model_inner: int = 2,
    err_safety: float = 1.0,
    err_power: float = 3.0,
    max_dtheta: float | None = None,
    bound_share: float | None = None,
    inner_first: int = 5,
    first_share: float = 1.0,
    first_safety: float = FIRST_SAFETY,
    outer_map: bool = True,
    inner_carry: float = INNER_CARRY,
    outer_first: int = 5,
    outer_first_safety: float = OUTER_FIRST_SAFETY,
    inner_map: int | None = None,
    return_cost: bool | str = False,
):
    """Integrate independent texels (mu[k], alpha[k], eta[k]) with the adaptive method.

    Parameters
    ----------
    mode : {"reflect", "dielectric", "dfg"}
        Integrand family (see module docstring). "reflect" uses Fresnel ``ftype`` (p0, p1).
    mu, alpha, eta : array_like
        Flat float64 arrays of the same length; ``eta`` only for "dielectric".
    tol : float
        Target absolute error per texel and channel.
    inner_share, max_piece, n_fixed, max_dtheta : float, float, int, float
        The floor and the budget (benchmarks and experiments): the share of the tolerance given
        to the inner phi integrals (0.85; 0.7 before issue 14's sixth round, 0.25 before its second), the longest initial outer piece in v (None: 1/2 at tolerances >= 1e-4, 1/4 below), the
        number of fixed angles theta_m = k (pi/2) / (n_fixed + 1) among the initial outer
        breakpoints (0; 7 before issue 14's second round), and the widest initial outer piece in
        theta_m (None: pi/8 at tolerances >= 5e-7, pi/16 below; 0: no such cut).
        ``err_model_inner``: the inner level's error model
        (-1: ``err_model``; 2, the default: |K15 - G7| times min(1, err_safety r^err_power),
        r the Legendre decay ratio; ``err_safety`` 1, ``err_power`` 3). ``bound_share``: the
        share of the budget for the D tail left out under its mass bound (None: 0.25 at
        tolerances >= 1e-4, 0 below; 0: none left out, the bound still caps each outer rule's
        estimate; < 0: no bounds, the method before issue 14's third round). ``inner_first``: the
        inner first stage (5: |G7 - I5|; 3: |G7 - I3|; 0: K15 always, before issue 14's round 4);
        ``first_share`` (1): its share of an interval's tolerance; ``first_safety`` (8): its factor.
        ``outer_map`` (True): the outer rules through the smoothstep map of their initial piece
        (False: linear, the method before issue 14's sixth round); ``inner_carry`` (4): the
        factor on the inner estimates in the texel's error (the inner tolerance divided by it).

    Returns
    -------
    values, errors : ndarray, shape (N, 2)
        Channel 0 / 1 are (E, 0), (R, T) or (A, B); errors are the per-texel estimates.
    cost : ndarray of int, shape (N,)
        Integrand evaluations per texel (only with ``return_cost=True``). With
        ``return_cost="detail"`` an (N, 4) array instead, the evaluations split by where they
        were spent: [outer initial intervals (the floor) x inner first rules, outer floor x
        inner bisections, outer bisections x inner first rules, outer bisections x inner
        bisections]; its rows sum to the plain cost.
    """
    dev = resolve_device(device)
    check_workers(workers)
    check_rule_keywords(inner_first, first_share, first_safety, err_safety, err_power)
    if isinstance(outer_first, bool) or outer_first not in (0, 3, 5):
        raise ValueError(f"outer_first must be 0 (off), 3 or 5 (the first stage's lower rule), got {outer_first!r}")
    if not (math.isfinite(float(outer_first_safety)) and float(outer_first_safety) > 0.0):
        raise ValueError(f"outer_first_safety must be a finite number > 0, got {outer_first_safety!r}")
    if not (math.isfinite(inner_carry) and inner_carry > 0.0):
        raise ValueError(f"inner_carry must be finite and > 0, got {inner_carry!r}")
    # the smallest error reported: 1e-9 for tolerances >= 1e-7 (misses of up to 5e-10 in the D tail
    # were measured under smaller estimates), down to 1e-10 (float64 sums of ~1e5 terms) below
    err_floor = max(1e-10, min(1e-9, 0.01 * float(tol)))
    if max_piece is None:
        # pieces <= 1/2 in v at tolerances >= 1e-4 (issue 14 round 6, with the outer map: -13% ..
        # -16% evaluations there; at 5e-7 1/2 under-reported), 1/4 below
        max_piece = 0.5 if tol >= 1e-4 else 0.25
    if max_dtheta is None:
        # the floor follows the tolerance: pi/8 parts at tolerances >= 5e-7 (the spec's; >= 1e-5
        # before the outer map of issue 14's sixth round), pi/16 below (pi/8 under-reported at 1e-7)
        max_dtheta = math.pi / 8 if tol >= 5e-7 else math.pi / 16
    if inner_map is None:
        # the inner pieces' ends mapped (issue 14 round 7): the critical cut only at tolerances
        # >= 1e-3 (-14% evaluations at 1e-3 against the smoothstep at every end), every cut below
        # (-20 .. -27% at 1e-4 .. 1e-7), never phi = 0 or pi
        inner_map = 2 if tol >= 1e-3 else 1
    if isinstance(inner_map, bool) or inner_map not in (0, 1, 2):
        raise ValueError(f"inner_map must be 0 (every end), 1 (the cuts) or 2 (the critical cut), got {inner_map!r}")
    if bound_share is None:
        # D tails left out at tolerances >= 1e-4 (-4 .. -9% evaluations there; ~1% below, where
        # a missing tail of up to tol / 4 would only move values that are otherwise ~exact)
        bound_share = 0.25 if tol >= 1e-4 else 0.0
    mode_sel = mode_id(mode)
    mu, alpha, eta, mu_w, alpha_w, eta_w = texel_arrays(mu, alpha, eta, dev)
    n = mu.size
    value = wp.zeros((n, 2), dtype=wp.float64, device=dev)
    error = wp.zeros((n, 2), dtype=wp.float64, device=dev)
    cost = wp.zeros(n, dtype=wp.int32, device=dev)
    detail = wp.zeros((n, 4), dtype=wp.int32, device=dev)

    launch = chunk_launcher(texel_kernel, [
        mu_w, alpha_w, eta_w, mode_sel, int(dist), int(shadowing), int(ftype),
        float(fp0), float(fp1), float(tol), int(err_model), int(max_rules_outer), int(max_rules_inner),
        float(inner_share), float(max_piece), int(n_fixed), int(err_model_inner), float(err_safety), float(err_power), float(max_dtheta),
        err_floor,
        float(bound_share), int(inner_first), float(first_share), float(first_safety), int(outer_map), float(inner_carry), int(outer_first), float(outer_first_safety), int(inner_map), value, error, cost, detail,
    ], dev)

    # interleave the texels so that expensive ones (grazing mu) spread over the workers
    order = np.argsort(np.arange(n) % 7, kind="stable") if n > 64 else None
    run_chunks(n, launch, dev, workers=workers, progress=progress, order=order)
    if return_cost == "detail":
        return value.numpy(), error.numpy(), detail.numpy()
    if return_cost:
        return value.numpy(), error.numpy(), cost.numpy()
    return value.numpy(), error.numpy()
