"""The adaptive method's outer level before any rule: breakpoints, initial intervals, the map.

The outer v integral (:mod:`bsdf_tab.integrate.adaptive`) starts from the theta_m where the
inner phi pieces change: where a threshold on i.m enters or leaves the phi circle
(theta_m = (pi/2 -+ theta_i)/2, pi/2 - theta_i, |theta_i -+ theta_c|, the transmission floor's
crossings) and where two thresholds cross inside it (the transmission floor switching from
the horizon root to c_TIR; the reflection horizon crossing the critical i.m, issue 14 round 6).
Each piece between them is cut into equal parts in theta_m and in v (the floor), and the
longest run of last intervals whose rigorous mass bound fits in ``bound_share`` of the budget
is left out (:func:`bsdf_tab.integrate.integrand.mass_bound`). At loose tolerances the floor
gives way to two cuts where o_r.n = kappa alpha at phi = pi and phi = 0 (issue 14, round 9):
between each cut and its horizon breakpoint lies the Smith G1(o_r) ramp, which at mu ~ 1 and
small alpha sits in the v map's tail, narrower than the nodes' spacing. Not for dielectric
texels with eta < 1: their transmission horizon has a G1(o_t) ramp of its own, without a
closed-form cut (a scan at 1e-3 found one texel dishonest there).

The outer rules then work in a piece coordinate w in [0, ne]: piece k = floor(w) of the initial
ends, and t = w - k mapped by the smoothstep v = v_k + (v_k+1 - v_k)(3 t^2 - 2 t^3) (issue 14,
round 6): at a breakpoint the outer integrand has a kink or a power (v - v_k)^(n + 1/2), which
the map's t^2 makes smooth, so G7-K15 needs far fewer bisections there. Bisection in w never
crosses a piece end.
"""

from __future__ import annotations

import warp as wp

from ..model.distribution import dcos_tan_of_v, dcos_v_of_theta
from .integrand import (
    HALF_PI64, MODE_DIELECTRIC, TexelParams, fresnel_knee, mass_bound, tir_eta, transmission_breaks,
    vec24d,
)
from .quadrature import end_map

# no kernel of this module is differentiated: no adjoint code
wp.set_module_options({"enable_backward": False})

vec48d = wp.types.vector(length=48, dtype=wp.float64)


@wp.struct
class OuterX:
    """The outer rule's parameters: the inner budget and its cap, the factor on the inner
    estimates, the initial ends in v, and their map (1: smoothstep, 0: linear)."""

    tol_in: wp.float64
    max_rules: wp.int32
    omap: wp.int32
    carry: wp.float64
    first: wp.int32  # the outer first stage (0: off; 5: G7 accepted on first_safety |G7 - I5|)
    thr: wp.float64  # its tolerance per unit w
    safety: wp.float64  # its factor on |G7 - I5|
    tail: wp.float64  # the factor on the Legendre-tail floor of |K15 - G7| (0: off)
    first_tail: wp.float64  # the first stage's factor on its tail floor of |G7 - I5| (0: off)
    near0: wp.float64  # no first stage where the interval is longer than this times its distance to v = 0 (0: off)
    ends: vec48d


@wp.func
def v_of_w(x: OuterX, w: wp.float64):
    """(v, dv/dw) at w in [0, ne]: piece k = floor(w) of ``x.ends``, t = w - k through the map."""
    k = wp.min(int(wp.floor(w)), 46)
    t = w - wp.float64(k)
    va = x.ends[k]
    dv = x.ends[k + 1] - va
    s, ds = end_map(t, wp.where(x.omap == 0, 0, 3))
    return va + dv * s, dv * ds


@wp.func
def _graded(p: TexelParams, ends: vec48d, ne: wp.int32, grade: wp.float64, tan_max: wp.float64):
    """The pieces [ends[q], ends[q + 1]] cut where tan(theta_m) grows by more than ``grade`` within
    one, at tan(theta_m) = tan(theta_m(ends[q])) grade^k, up to ``tan_max`` (grazing incidence:
    (i.m) / cos(theta_m) grows like tan(theta_m), and the reflection horizon's structure sits at
    cot(theta_m) ~ mu / 2, the top of the range; one piece would span it with no node there)."""
    out = vec48d()
    out[0] = ends[0]
    no = int(0)
    for q in range(ne):
        hi = wp.min(dcos_tan_of_v(ends[q + 1], p.alpha, p.dist), tan_max)
        t = dcos_tan_of_v(ends[q], p.alpha, p.dist)
        # keep room for the later ends (47 at most)
        while t > wp.float64(0.0) and t * grade < hi and no < 46 - (ne - q):
            t = t * grade
            no += 1
            out[no] = dcos_v_of_theta(wp.atan(t), p.alpha, p.dist)
        no += 1
        out[no] = ends[q + 1]
    return out, no


@wp.func
def initial_ends(p: TexelParams, mode: wp.int32, tol_total: wp.float64, n_fixed: wp.int32,
                 max_dtheta_in: wp.float64, max_piece_in: wp.float64, bound_share: wp.float64,
                 ramp_cut: wp.float64, grade: wp.float64):
    """(ends, ne, skip): the initial outer intervals [ends[q], ends[q + 1]], q < ne, in v, and the
    mass bound of the D tail left out beyond ends[ne] (0 when nothing is left out).

    ``ramp_cut`` = kappa > 0 (loose tolerances): cuts where o_r.n = kappa alpha at phi = pi and at
    phi = 0, theta_m = (acos(kappa alpha) -+ theta_i) / 2, each just inside a horizon
    breakpoint, and no floor (``max_dtheta``, ``max_piece``) -- except for dielectric texels
    with eta < 1, whose transmission horizon has a G1 ramp of its own (module docstring)."""
    zero = wp.float64(0.0)
    one = wp.float64(1.0)
    # outer breakpoints in theta_m where the phi pieces change (module docstring)
    theta_i = wp.acos(p.mu)
    hp = HALF_PI64
    th = vec24d()
    nt = int(0)
    cands = vec24d()
    cands[0] = wp.float64(0.5) * (hp - theta_i)
    cands[1] = hp - theta_i
    cands[2] = wp.float64(0.5) * (hp + theta_i)
    ncand = int(3)
    max_dtheta = max_dtheta_in
    max_piece = max_piece_in
    if ramp_cut != zero and not (mode == MODE_DIELECTRIC and p.eta < one):
        if ramp_cut > zero:
            max_dtheta = zero
            max_piece = one
        k_a = wp.abs(ramp_cut) * p.alpha
        if k_a < one:
            # the reflected direction's G1 ramp (o_r.n from 0 to ~alpha): in its own interval
            ak = wp.acos(k_a)
            cands[3] = wp.float64(0.5) * (ak - theta_i)
            cands[4] = wp.float64(0.5) * (ak + theta_i)
            ncand = 5
    if tir_eta(p) < one:
        # the critical angle (dielectric mode, or reflection with a dielectric Fresnel)
        theta_c = wp.acos(wp.sqrt(one - tir_eta(p) * tir_eta(p)))
        cands[ncand] = wp.abs(theta_i - theta_c)
        cands[ncand + 1] = theta_i + theta_c
        ncand += 2
        # where the reflection horizon i.m = mu / (2 cos theta_m) crosses the critical i.m
        # (the kink of F leaves the reflected support): cos theta_m = mu / (2 cos theta_c)
        ch = p.mu / (wp.float64(2.0) * wp.sqrt(one - tir_eta(p) * tir_eta(p)))
        if ch < one:
            cands[ncand] = wp.acos(ch)
            ncand += 1
    knee = fresnel_knee(p)
    if knee > zero:
        # eta just above 1: where the extreme i.m crosses the Fresnel knee sqrt(eta^2 - 1)
        theta_k = wp.acos(knee)
        cands[ncand] = wp.abs(theta_i - theta_k)
        cands[ncand + 1] = theta_i + theta_k
        ncand += 2
    if mode == MODE_DIELECTRIC and p.eta < one:
        # where the transmitted set (i.m above its floor, see _inner) appears or fills the whole
        # phi circle: no closed form, so locate sign changes on a grid and bisect
        cands, ncand = transmission_breaks(p, theta_i, cands, ncand)
    # fixed angles too: the v map packs theta_m >> alpha into the last ~alpha of [0, 1], where a
    # single rule could otherwise step over the horizon structure without noticing it
    for q in range(wp.min(n_fixed, 24 - ncand)):
        cands[ncand] = wp.float64(q + 1) * HALF_PI64 / wp.float64(n_fixed + 1)
        ncand += 1
    for q in range(ncand):
        x = cands[q]
        if x > zero and x < hp:
            # insertion in place (a function returning the vector by value copied it: stalls on
            # store forwarding, as the inner cuts' did, issue 14, tenth round)
            i = nt
            while i > 0 and th[i - 1] > x:
                th[i] = th[i - 1]
                i -= 1
            th[i] = x
            nt += 1
    v_end = one
    if mode != MODE_DIELECTRIC:
        # reflection only: no admissible micro-normal beyond theta_m = (pi/2 + theta_i) / 2
        v_end = dcos_v_of_theta(wp.float64(0.5) * (hp + theta_i), p.alpha, p.dist)
    # initial intervals: the pieces between the breakpoints, each cut into equal parts in
    # theta_m no wider than max_dtheta (when > 0), none longer than max_piece in v; the
    # splits stop short of the capacity so that every breakpoint (and v_end) is kept
    th_end = hp
    if mode != MODE_DIELECTRIC:
        th_end = wp.float64(0.5) * (hp + theta_i)
    ends = vec48d()
    ends[0] = zero
    ne = int(1)
    th_prev = zero
    for q in range(nt + 1):
        vb = v_end
        tb = th_end
        if q < nt:
            tb = wp.min(th[q], th_end)
            vb = wp.min(dcos_v_of_theta(th[q], p.alpha, p.dist), v_end)
        room = 44 - (nt + 1 - q)
        if max_dtheta > zero and tb > th_prev:
            nth = int(wp.ceil((tb - th_prev) / max_dtheta))
            for k in range(1, nth):
                tk = th_prev + (tb - th_prev) * wp.float64(k) / wp.float64(nth)
                vk = wp.min(dcos_v_of_theta(tk, p.alpha, p.dist), v_end)
                while vk - ends[ne - 1] > max_piece and ne < room:
                    ends[ne] = ends[ne - 1] + max_piece
                    ne += 1
                if vk > ends[ne - 1] and ne < room:
                    ends[ne] = vk
                    ne += 1
        while vb - ends[ne - 1] > max_piece and ne < room:
            ends[ne] = ends[ne - 1] + max_piece
            ne += 1
        if vb > ends[ne - 1] and vb <= v_end and ne < 47:
            ends[ne] = vb
            ne += 1
        th_prev = wp.max(th_prev, tb)
    ne -= 1
    if grade > one:
        # up to cot(theta_m) = mu / 4 (the horizon's scale), at most 1 / (1e-3 tol): at mu = 0 the
        # structure reaches theta_m = pi / 2, where the D cos mass left is below any tolerance
        tan_max = wp.float64(1.0e3) / tol_total
        if p.mu * tan_max > wp.float64(4.0):
            tan_max = wp.float64(4.0) / p.mu
        ends, ne = _graded(p, ends, ne, grade, tan_max)
    # the D tail: the longest run of last intervals whose mass bound fits in bound_share of the
    # budget is not integrated (value 0, error the bound: both are in [0, bound])
    skip = zero
    if bound_share > zero:
        run = zero
        q = ne - 1
        while q >= 0:
            # the suffix from ends[q] as one piece, or the last suffix's bound plus this piece's
            b = mass_bound(p, ends[q], ends[ne])
            bp = mass_bound(p, ends[q], ends[q + 1])
            if bp >= zero and (b < zero or run + bp < b):
                b = run + bp
            if b < zero or b > bound_share * tol_total:
                break
            run = b
            q -= 1
        skip = run
        ne = q + 1
    return ends, ne, skip
