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
split at those points, each piece mapped at the ends that need it (``inner_map``,
:func:`bsdf_tab.integrate.quadrature.end_map`: s = t^2 at a cut, which makes the square root of
Fresnel at the critical angle linear and the horizons' kinks smooth; no map at phi = 0 or pi,
where the integrand is even and smooth; issue 14, seventh round: -14 .. -27% evaluations against
the smoothstep at every end; at tolerances >= 1e-3 only the critical cut is mapped; but Beckmann
texels map phi = 0 or halve the piece near the point o_r = n, where Lambda is not analytic,
``NORMAL_MAP``, ``NORMAL_SPLIT``: :mod:`bsdf_tab.integrate.inner`, rounds 12 and 13), and integrated by
adaptive G7-K15 as a three-stage rule (issue 14, rounds 4 and 11): the 7 Gauss nodes first, and G7
is accepted with the error ``first_safety`` |G7 - I5| = 8 |G7 - I5| (I5 the interpolatory rule on
5 of those nodes) where that fits the interval's share of the piece's tolerance; otherwise 4 of
the Kronrod nodes are added and G7 is accepted with ``second_safety`` |G7 - I9| = 64 |G7 - I9|
(I9 on 9 of the 11 values, degree 9: far sharper than |G7 - I5| on smooth integrands); otherwise
the last 4 Kronrod nodes are added and the interval is K15 with the estimate below (the values
reused, so a rejected stage costs nothing). |G7 - I9| = GAMMA10 |c10| of the 11 values' interpolant,
blind to c9: floored at ``second_tail`` = 0.1 GAMMA10 (|c9| + |c10|) min(1, r) where it would accept
(round 12: a grazing Beckmann texel 1.32x; the first stage's with ``inner_first_tail``, off). The outer v integral is adaptive G7-K15 too, started from the closed-form
theta_m where the phi pieces change (theta_m = (pi/2 -+ theta_i)/2, pi/2 - theta_i, the
critical-angle crossings, and where two thresholds cross: :mod:`bsdf_tab.integrate.outer`), and
each outer rule works through a smoothstep map of its initial piece (issue 14, sixth round: the
outer integrand's kinks and half-integer powers sit at the piece ends, where the map makes them
smooth; with the round's other changes -36% evaluations at 5e-7 on the 1634-texel harness).
The outer rule is two-stage (issue 14, seventh round): its 7 Gauss nodes first, G7 accepted
when ``OUTER_FIRST_SAFETY`` |G7 - I5| = 64 |G7 - I5| plus the carried inner estimates fits in
the interval's share of the budget (an outer node costs a whole inner integral; 8 under-reported,
and 32 near normal incidence, where the inner integrals carry almost nothing: round 11, which
took it to 128; 64 since round 12's floor on |G7 - I5|, below: 32 left one texel at 1.25x), except
at mu = 1, where every outer interval is K15 (each inner integral is one evaluation there); its
|G7 - I5| = GAMMA6 |c6| floored at ``outer_first_tail`` = 0.1 GAMMA6 (|c5| + |c6|) min(1, r) (round
12: two texels up to 2.3x under their error), and skipped on intervals much longer than their
distance to v = 0, the branch point of tan(theta_m) ~ sqrt(v) (``OUTER_NEAR0`` = 16; round 12: a
grazing texel's graded piece [v_a, 256 v_a], 3.27x under its error):
``OUTER_FIRST_SPREAD`` = 4 times its even share, at most the whole budget, since the global loop
still refines until the pieces' estimates sum to the budget (issue 14, tenth round: -4 .. -10%
evaluations at 1e-3, -2 .. -3% below 1e-4, the harness honest).

Adaptivity is global at both levels (bisect the interval with the largest estimate until the
sum meets the budget: ``inner_share`` = 0.85 of the tolerance for the inner integrals, the rest
for the outer one). The inner estimates enter a texel's error at ``INNER_CARRY`` = 2 times
their value, and each inner integral aims at its share / 2: single inner estimates can
under-report (below), and with the outer map the outer level no longer bisects enough to absorb
that (a texel at 1e-7 reported 0.79 of its true error with the factor 1 and the smoothstep at
every inner end; 4 until the seventh round's inner end maps resolved it).
The outer integral starts from the breakpoints above, each piece between them cut into equal
parts in theta_m no wider than ``max_dtheta`` (pi/16; pi/8 at tolerances >= 5e-7) and no longer
than ``max_piece`` = 1/4 in v (1/2 at tolerances >= 1e-4): the v map packs theta_m >> alpha into
a sliver near v = 1, where a single rule could otherwise step over the horizon structure
unnoticed. At tolerances >= 1e-3 two cuts where o_r.n = ``RAMP_CUT`` alpha replace that floor
(but on dielectric texels with eta < 1): they put the Smith G1 ramp at the reflection horizon, the
structure the floor was there for, into an interval of its own; below 1e-3 the same cuts sit
beside the floor (round 11). At every tolerance the initial pieces are
also cut where tan(theta_m) grows by more than ``OUTER_GRADE`` = 16 within one, up to
cot(theta_m) = mu / 4 (round 11: at grazing incidence (i.m) / cos(theta_m) grows like
tan(theta_m) and the horizon's structure sits at cot(theta_m) ~ mu / 2, the top of the last
piece, which a single rule spanned unresolved: texels up to 6.5x their estimate). docs/methods.md has the
measurements behind every constant.

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
default; 0: |K15 - G7| itself; 2: as the inner default), |K15 - G7| first floored at
``TAIL_FLOOR`` GAMMA14 (|c13| + |c14|) min(1, r) = 0.1 of what the interpolant's last Legendre pair
predicts (|K15 - G7| is exactly GAMMA14 |c14|, one coefficient that can be small by accident while
c13 is not: a Beckmann texel 2.46x under its error at 1e-6, issue 14 round 12), summed over the accepted intervals,
plus the inner estimates carried through the outer weights; floored at 1e-9 (tolerances >= 1e-7;
down to 1e-10 below). The inner phi level (``err_model_inner`` 2) scales |K15 - G7| (the error
of G7) by min(1, ``err_safety`` r^``err_power``) = min(1, r^3), r the decay ratio of the last
Legendre coefficients of the 15-node interpolant
(:func:`bsdf_tab.integrate.quadrature.decay_ratio`): where the coefficients fall fast, K15 is
resolved far beyond G7; where they do not (r >= 1) the estimate is |K15 - G7|; an accepted
first stage reports 8 |G7 - I5| (:func:`bsdf_tab.integrate.quadrature.first_stage`), the degree-6
term of the 7 values' interpolant, not G7's error, blind to what 7 values do not resolve
(single inner integrals under-report: ``bench/inner_honesty.py``). The dielectric (R, T) and
split-sum (A, B) channels both report the larger of their two estimates (``shared_error``,
round 11): they share F, their errors are near opposites where G is ~1, and one channel's
estimate saw what the other's missed. Texel honesty rests on the outer level and the carry,
measured, not proven: on 1634 reference texels (``bench/accuracy_honesty.py``, 1e-2 .. 1e-7)
none reports less than its true error, worst ratio 0.20 below 1e-4 (docs/methods.md, also for
the estimates that under-reported: the decay ratio, r^6, the outer first stage at 8 and at 32
|G7 - I5| near normal incidence, each channel on its own). Rule applications are capped per texel (``max_rules_outer``,
``max_rules_inner`` per phi piece): a texel that cannot reach the tolerance within the cap
reports its large estimate instead of a wrong small one.

Where the pieces live: the integrand, mirror limit, mass bound and thresholds in
:mod:`bsdf_tab.integrate.integrand`; v(theta_m) in :mod:`bsdf_tab.model`; the rules, error models
and global bisection in :mod:`bsdf_tab.integrate.quadrature`; the inner phi level in
:mod:`bsdf_tab.integrate.inner`, the outer start in :mod:`bsdf_tab.integrate.outer`; here the
outer rule, the kernel and its launcher.

References: Walter et al. 2007, "Microfacet Models for Refraction through Rough Surfaces";
Piessens et al. 1983, "QUADPACK" (Gauss-Kronrod 7-15 rule).
"""

from __future__ import annotations

import math

import numpy as np
import warp as wp

from ..model.distribution import dcos_tan_of_v
from .inner import inner_integral_scaled
from .integrand import (  # noqa: F401  (MODE_*, MODES, TexelParams: this module's former names)
    MODE_DFG, MODE_DIELECTRIC, MODE_REFLECT, MODES, PI64, TexelParams, begin_texel, mass_bound, mode_id,
)
from .outer import OuterX, initial_ends, v_of_w, vec48d
from .quadrature import (
    WG7_D, WGK_D, check_factors, check_rule_keywords, decay_ratio, first_floor, first_stage, gk_abscissa, gk_error,
    gk_error_decay, gk_resasc, k15_floor, make_global_bisection, vec16d,
)
from .runtime import check_workers, chunk_launcher, resolve_device, run_chunks, texel_arrays

# no kernel of this module is differentiated: no adjoint code (a third of the compile time).
# Multiply-adds fused on the CPU too (CUDA fuses by default): Warp's generated C++ puts every
# operation in its own statement, where clang's default contraction does not reach, so the
# integrand's chains ran as separate multiplies and adds. Fused: 9-17% less time on the core
# tables (issue 14, ninth round); values move by a few ulp, the harness stays honest
wp.set_module_options({
    "enable_backward": False,
    "cpu_compiler_flags": (wp.config.cpu_compiler_flags or "-march=native") + " -ffp-contract=fast",
})

INNER_CARRY = 2.0  # the factor on the inner estimates in a texel's error (docs/methods.md, issue 14, rounds 6-7)
OUTER_FIRST_SAFETY = 64.0  # the factor on the outer first stage's |G7 - I5| (docs/methods.md, issue 14, rounds 7, 11 and 12)
FIRST_SAFETY = 8.0  # the factor on the inner first stage's |G7 - I5| (docs/methods.md, issue 14, rounds 4-5)
SECOND_SAFETY = 64.0  # the factor on the inner second stage's |G7 - I9| (docs/methods.md, issue 14, round 11)
OUTER_FIRST_SPREAD = 4.0  # an initial piece's outer first stage may take 4 / ne of the budget (docs/methods.md, issue 14, round 10)
OUTER_GRADE = 16.0  # outer pieces cut where tan(theta_m) grows by more than this (docs/methods.md, issue 14, round 11)
TAIL_FLOOR = 0.1  # the floors on the outer |K15 - G7|, the outer |G7 - I5| and the inner |G7 - I9| from their Legendre pairs (docs/methods.md, issue 14, round 12)
OUTER_NEAR0 = 16.0  # no outer first stage on an interval longer than this times its distance to v = 0 (round 12)
NORMAL_MAP = 0.03  # Beckmann: phi = 0 mapped where o_r = n lies within this share of the piece (round 12)
NORMAL_SPLIT = 0.3  # Beckmann: the first inner piece in halves where o_r = n lies within this share (round 13)
RAMP_CUT = 2.0  # o_r.n = RAMP_CUT alpha: the G1 ramp cut at loose tolerances (docs/methods.md, issue 14, round 9)


@wp.func
def _v_node(p: TexelParams, x: OuterX, ctr: wp.float64, hl: wp.float64, j: wp.int32, scale: wp.float64):
    """One outer node (j < 8 at +XGK[j], else -XGK[j - 8] of [ctr - hl, ctr + hl] in w): the inner
    integral times the Jacobian 2 (1 - v) dv/dw, its estimate times the same and ``x.carry``,
    the inner rule counts (applications, of which bisections), and the inner integral's size (the
    larger channel) for the next node's ``scale`` (:func:`inner_integral_scaled`)."""
    one = wp.float64(1.0)
    v, dvdw = v_of_w(x, gk_abscissa(ctr, hl, j))
    tm = dcos_tan_of_v(v, p.alpha, p.dist)
    cm = one / wp.sqrt(one + tm * tm)
    sm = tm * cm
    jac = wp.float64(2.0) * (one - v)
    # the inner budget per unit v as before the map (its sum over the v range is tol_in)
    f, e, used, used_ref = inner_integral_scaled(p, cm, sm, tm, x.tol_in / (jac * x.carry), x.max_rules, scale)
    size = wp.max(wp.abs(f[0]), wp.abs(f[1]))
    jac = jac * dvdw
    return f * jac, e * (jac * x.carry), wp.vec2i(used, used_ref), size


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
    f0 = vec16d()
    f1 = vec16d()
    rules = wp.vec2i(0, 0)
    g = wp.vec2d(wp.float64(0.0), wp.float64(0.0))
    d = wp.vec2d(wp.float64(0.0), wp.float64(0.0))
    accepted = int(0)
    scale = wp.float64(0.0)  # the previous node's inner integral (none before the first)
    first = x.first
    if x.near0 > wp.float64(0.0) and first > 0:
        # tan(theta_m) ~ sqrt(v) near v = 0: its branch point sits just before an interval that
        # is long against its distance to it (grazing texels' graded pieces), where 7 values do
        # not see it (round 12)
        # (a piece that starts at v = 0 has the point at its mapped end, where the map's t^2 makes
        # sqrt(v) linear: not there)
        if x.ends[wp.min(int(wp.floor(wa)), 46)] > wp.float64(0.0):
            va0, _d0 = v_of_w(x, wa)
            vb0, _d1 = v_of_w(x, wb)
            if vb0 - va0 > x.near0 * va0:
                first = 0
    # one call site of _v_node (a second doubled the CUDA compile): 7 Gauss nodes, first stage, 8 others
    for k in range(15):
        j = 2 * k + 1
        if k >= 7:
            j = 2 * (k - 7)
        if k == 7 and first > 0:
            g, d = first_stage(f0, f1, hl, first, x.safety)
            d = d + eg * hl
            if wp.max(d[0], d[1]) <= x.thr * (wb - wa):
                if x.first_tail > wp.float64(0.0) and first == 5:
                    # |G7 - I5| is one coefficient: floored by the 7 values' last Legendre pair (round 12)
                    fl = first_floor(f0, f1, hl) * (x.safety * x.first_tail) + eg * hl
                    d = wp.vec2d(wp.max(d[0], fl[0]), wp.max(d[1], fl[1]))
                if wp.max(d[0], d[1]) <= x.thr * (wb - wa):
                    accepted = 1
                    break
        f, e, used, scale = _v_node(p, x, ctr, hl, j, scale)
        rules += used
        f0[j] = f[0]
        f1[j] = f[1]
        rk += WGK_D[j % 8] * f
        rg += WG7_D[j % 8] * f
        ei += WGK_D[j % 8] * e
        eg += WG7_D[j % 8] * e
    if accepted != 0:
        return g, d, rules
    if x.tail > wp.float64(0.0):
        # |K15 - G7| is GAMMA14 |c14|, one coefficient: floored at what the tail pair predicts
        floor = k15_floor(f0, f1) * x.tail
        for c in range(2):
            if wp.abs(rk[c] - rg[c]) < floor[c]:
                rg[c] = rk[c] - floor[c]
    resasc = gk_resasc(f0, f1, rk)
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
    outer_first_spread: wp.float64,
    inner_map: wp.int32,
    ramp_cut: wp.float64,
    second_safety: wp.float64,
    shared_error: wp.int32,
    outer_grade: wp.float64,
    outer_tail: wp.float64,
    normal_map: wp.float64,
    normal_split: wp.float64,
    inner_first_tail: wp.float64,
    outer_first_tail: wp.float64,
    second_tail: wp.float64,
    outer_near0: wp.float64,
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
    p.second_safety = second_safety
    p.normal_map = normal_map
    p.normal_split = normal_split
    p.first_tail = inner_first_tail
    p.second_tail = second_tail
    # the outer level's start (bsdf_tab.integrate.outer): breakpoints, floor, D tail left out;
    # the budget: inner_share for the inner phi integrals (summed through the outer weights, at
    # most tol_in in total), the rest for the outer v quadrature
    tol_total = tol * PI64
    ends, ne, skip = initial_ends(p, mode, tol_total, n_fixed, max_dtheta, max_piece, bound_share, ramp_cut,
                                  outer_grade)
    tol_in = inner_share * (tol_total - skip)

    ox = OuterX()
    ox.tol_in = tol_in
    ox.max_rules = max_rules_inner
    ox.omap = outer_map
    ox.carry = inner_carry
    ox.first = outer_first
    if p.sin_i <= wp.float64(0.0):
        # normal incidence: each inner integral is one evaluation with no estimate to carry, and
        # |G7 - I5| alone under-reported (4.6x: GGX, eta 0.3, alpha 0.0085, tolerance 1e-6; a
        # near-mirror D packs the critical angle's neighbourhood into a piece's end): K15 on
        # every interval, 8 evaluations more each (issue 14, round 11)
        ox.first = 0
    ox.thr = wp.float64(0.0)
    ox.safety = outer_first_safety
    ox.tail = outer_tail
    ox.first_tail = outer_first_tail
    ox.near0 = outer_near0
    if ne > 0:
        # the first stage's budget per unit w: outer_first_spread times the texel's spread evenly
        # over the initial pieces (at most all of it); the global loop still bisects until the
        # sum of the pieces' estimates meets the budget
        ox.thr = (tol_total - skip) / wp.float64(ne) * wp.min(outer_first_spread, wp.float64(ne))
    ox.ends = ends
    wends = vec48d()
    for q in range(ne + 1):
        wends[q] = wp.float64(q)
    total, err, rules, rules_ref = _adaptive_outer(p, ox, wends, ne,
                                                   tol_total - skip, max_rules_outer, wp.vec2i(0, 0))
    err += wp.vec2d(skip, skip)
    if shared_error != 0 and mode != MODE_REFLECT:
        # R and T (A and B) share F: where G is ~1 their sum is smooth and their errors are
        # near opposites, which one channel's estimate can miss while the other's sees it (T at
        # 4.2x its own estimate, within R's: issue 14, round 11): both report the larger
        e_max = wp.max(err[0], err[1])
        err = wp.vec2d(e_max, e_max)
    value[i, 0] = total[0] / PI64
    value[i, 1] = total[1] / PI64
    # floor (err_floor, see integrate_texels): what the estimates cannot certify
    error[i, 0] = wp.max(err[0] / PI64, err_floor)
    error[i, 1] = wp.max(err[1] / PI64, err_floor)
    # integrand evaluations (the inner rules count theirs; 1 for a phi-independent integrand)
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
    outer_first_spread: float = OUTER_FIRST_SPREAD,
    inner_map: int | None = None,
    ramp_cut: float | None = None,
    second_safety: float = SECOND_SAFETY,
    shared_error: bool = True,
    outer_grade: float | None = None,
    outer_tail: float = TAIL_FLOOR,
    normal_map: float = NORMAL_MAP,
    normal_split: float = NORMAL_SPLIT,
    inner_first_tail: float = 0.0,
    outer_first_tail: float = TAIL_FLOOR,
    second_tail: float = TAIL_FLOOR,
    outer_near0: float = OUTER_NEAR0,
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
        ``first_share`` (1): its share of an interval's tolerance; ``first_safety`` (8): its factor;
        ``second_safety`` (64; 0: off, the method before issue 14's round 11): the second stage's
        factor on |G7 - I9|.
        ``outer_map`` (True): the outer rules through the smoothstep map of their initial piece
        (False: linear, the method before issue 14's sixth round); ``inner_carry`` (2; 4 in the
        sixth round): the factor on the inner estimates in the texel's error (the inner
        tolerance divided by it). ``outer_first`` (5: |G7 - I5|; 3: |G7 - I3|; 0: K15 always,
        before issue 14's seventh round; at mu = 1 always 0) and ``outer_first_safety`` (64; 32
        before round 11, 128 in it): the outer first stage;
        ``outer_first_spread`` (4; 1 before issue 14's tenth round): its share of the budget, that
        many times an even share over the initial pieces (at most all of it).
        ``inner_map``: which ends of an inner phi piece are mapped (None: 2 at tolerances >=
        1e-3, 1 below; 0: every end by the smoothstep, before the seventh round; 1: each cut on
        i.m; 2: the critical-angle cut only). ``ramp_cut`` (kappa; None: 2 at tolerances >=
        1e-3, 0 below; 0: off): outer cuts where o_r.n = kappa alpha at phi = pi and phi = 0,
        which isolate the Smith G1 ramp at the reflection horizon, in place of the floor
        (``max_dtheta`` and ``max_piece`` are then not applied), except on dielectric texels
        with eta < 1 (issue 14, ninth round); kappa < 0: the cuts at |kappa| beside the floor (the
        default below 1e-3, -2, since round 11). ``shared_error`` (True; False before round 11):
        dielectric and split-sum texels report the larger of their two channels' estimates in both.
        ``outer_grade`` (None: 16; 0: off, the method before round 11): the initial outer pieces
        cut where tan(theta_m) grows by more than this factor. ``outer_tail`` (0.1; 0: off, before
        round 12): the outer |K15 - G7| floored at that factor times GAMMA14 (|c13| + |c14|)
        min(1, r), the interpolant's tail pair. ``normal_map`` (0.03; 0: off, before round 12):
        Beckmann texels map the inner piece's end phi = 0 where the point o_r = n, at phi = i y0,
        is within that share of the piece (y0 < normal_map b); ``normal_split`` (0.3; 0: off, before
        round 13) starts that piece in halves where y0 < normal_split b and one K15 would be
        rejected anyway (:mod:`bsdf_tab.integrate.inner`). ``outer_first_tail`` (0.1; 0: off,
        before round 12) and ``second_tail`` (0.1; 0: off): the outer first stage's |G7 - I5| = GAMMA6
        |c6| of the 7 Gauss values floored at that factor times GAMMA6 (|c5| + |c6|) min(1, r), and
        the inner second stage's |G7 - I9| = GAMMA10 |c10| of its 11 values at GAMMA10 (|c9| + |c10|)
        min(1, r); ``inner_first_tail`` (0: off) the same for the inner first stage (measured, not
        needed by any texel found: +0.8% evaluations on a random scan). ``outer_near0`` (16; 0:
        off, before round 12): no outer first stage on an interval of a piece that starts at
        v > 0 and is longer than this times its distance to v = 0, where tan(theta_m) ~ sqrt(v)
        has its branch point (grazing texels' graded pieces: a texel 3.27x under its error).

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
    check_rule_keywords(inner_first, first_share, first_safety, err_safety, err_power, second_safety)
    if isinstance(outer_first, bool) or outer_first not in (0, 3, 5):
        raise ValueError(f"outer_first must be 0 (off), 3 or 5 (the first stage's lower rule), got {outer_first!r}")
    check_factors(True, outer_first_safety=outer_first_safety, outer_first_spread=outer_first_spread)
    if outer_grade is None:
        # the grading at every tolerance (issue 14, round 11): without it grazing texels missed
        # ~2.5e-9 .. 5e-7 at 1e-6 .. 1e-7 (up to 6.5x their estimate), a grazing Schlick texel
        # 1.4e-6 at 1e-4 .. 1e-5, and a near-mirror one 1.05e-3 at 1e-3, beyond the tolerance (7x
        # its estimate; the factor 32 itself left one at 6.8x, 16 none); the cuts cost +12 / +30%
        # evaluations on the harness at 1e-3 / 1e-2, +0 .. +8% on the core tables
        outer_grade = OUTER_GRADE
    if not (math.isfinite(float(outer_grade)) and (float(outer_grade) == 0.0 or float(outer_grade) > 1.0)):
        raise ValueError(f"outer_grade must be 0 (off) or a finite number > 1, got {outer_grade!r}")
    check_factors(False, outer_tail=outer_tail, normal_map=normal_map, normal_split=normal_split, outer_near0=outer_near0,
                  inner_first_tail=inner_first_tail, outer_first_tail=outer_first_tail, second_tail=second_tail)
    if not isinstance(shared_error, (bool, np.bool_)):
        raise ValueError(f"shared_error must be True or False, got {shared_error!r}")
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
    if ramp_cut is None:
        # tolerances >= 1e-3: the G1 ramp cuts instead of the floor (issue 14, ninth round:
        # -23 .. -30% evaluations on the harness at 1e-3 and 1e-2, honest; at 1e-4 not); below,
        # beside the floor (round 11: a reflection with a dielectric Fresnel at mu 0.1, alpha
        # 0.0024 missed 4.6e-7 in the ramp at the end of a floor piece at 1e-5 .. 5e-7, 1.29x its
        # estimate at 5e-7)
        ramp_cut = RAMP_CUT if tol >= 1e-3 else -RAMP_CUT
    if not (math.isfinite(float(ramp_cut))):
        raise ValueError(f"ramp_cut must be a finite number (0: off; < 0: beside the floor), got {ramp_cut!r}")
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
        float(inner_share), float(max_piece), int(n_fixed), int(err_model_inner), float(err_safety), float(err_power),
        float(max_dtheta), err_floor, float(bound_share), int(inner_first), float(first_share), float(first_safety),
        int(outer_map), float(inner_carry), int(outer_first), float(outer_first_safety), float(outer_first_spread),
        int(inner_map),
        float(ramp_cut), float(second_safety), int(bool(shared_error)), float(outer_grade), float(outer_tail), float(normal_map), float(normal_split), float(inner_first_tail), float(outer_first_tail), float(second_tail), float(outer_near0), value, error, cost, detail,
    ], dev)

    # on the CPU, interleave the texels so that expensive ones (grazing mu) spread over the
    # workers; on CUDA keep the table's order: a warp's 32 threads then hold neighbouring texels,
    # of similar cost (bench/gpu_launch.py)
    order = np.argsort(np.arange(n) % 7, kind="stable") if n > 64 and not dev.is_cuda else None
    run_chunks(n, launch, dev, workers=workers, progress=progress, order=order)
    if return_cost == "detail":
        return value.numpy(), error.numpy(), detail.numpy()
    if return_cost:
        return value.numpy(), error.numpy(), cost.numpy()
    return value.numpy(), error.numpy()
