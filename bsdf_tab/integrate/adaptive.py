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
adaptive G7-K15. The outer v integral is adaptive G7-K15 too, started from the closed-form
theta_m where the phi pieces change (theta_m = (pi/2 -+ theta_i)/2, pi/2 - theta_i, and the
critical-angle crossings).

Adaptivity is global at both levels (bisect the interval with the largest estimate until the
sum meets the budget: a quarter of the tolerance for the inner integrals, the rest for the outer
one). The outer integral starts from the breakpoints above, fixed angles theta_m = k pi/16 (the
v map packs theta_m >> alpha into a sliver near v = 1), and pieces no longer than 1/8 in v.

Error estimate: per rule, QUADPACK's rescaling of |K15 - G7| (err_model 1, default) or
|K15 - G7| itself (err_model 0), summed over the accepted intervals, plus the inner estimates
carried through the outer weights; floored at 1e-10. Rule applications are capped per texel
(``max_rules_outer``, ``max_rules_inner`` per phi piece): a texel that cannot reach the tolerance
within the cap reports its large estimate instead of a wrong small one.

References: Walter et al. 2007, "Microfacet Models for Refraction through Rough Surfaces";
Piessens et al. 1983, "QUADPACK" (Gauss-Kronrod 7-15 rule).
"""

from __future__ import annotations

import math

import numpy as np
import warp as wp

from ..model.distribution import BECKMANN, lambda_cos
from ..model.fresnel import fresnel, fresnel_dielectric
from ..model.frame import expm1_, log1p_, refract_k2
from ..model.shadowing import smith_G_over_cos_i_equal, smith_G_over_cos_i_from_lambda

# integrand families
MODE_REFLECT = wp.constant(0)  # channel 0: int F G D (i.m)/mu     (albedo)
MODE_DIELECTRIC = wp.constant(1)  # channels R, T (exact dielectric Fresnel, eta per texel)
MODE_DFG = wp.constant(2)  # channels A, B: split-sum weights (1 - (1-c)^5), (1-c)^5, F = 1

MODES = {"reflect": 0, "dielectric": 1, "dfg": 2}

_vec8d = wp.types.vector(length=8, dtype=wp.float64)
_STACK = 64
_stackd = wp.types.vector(length=_STACK, dtype=wp.float64)
_vec6d = wp.types.vector(length=6, dtype=wp.float64)
_vec16d = wp.types.vector(length=16, dtype=wp.float64)
_vec24d = wp.types.vector(length=24, dtype=wp.float64)
_vec32d = wp.types.vector(length=32, dtype=wp.float64)

# Gauss-Kronrod 15-point abscissae on [-1, 1] (positive half, centre last) and weights;
# Gauss 7-point weights for the odd Kronrod abscissae and the centre (QUADPACK qk15).
_XGK = wp.constant(
    _vec8d(
        0.991455371120812639206854697526329,
        0.949107912342758524526189684047851,
        0.864864423359769072789712788640926,
        0.741531185599394439863864773280788,
        0.586087235467691130294144845693013,
        0.405845151377397166906606412076961,
        0.207784955007898467600689403773245,
        0.0,
    )
)
_WGK = wp.constant(
    _vec8d(
        0.022935322010529224963732008058970,
        0.063092092629978553290700663189204,
        0.104790010322250183839876322541518,
        0.140653259715525918745189590510238,
        0.169004726639267902826583426598550,
        0.190350578064785409913256402421014,
        0.204432940075298892414161999234649,
        0.209482141084727828012999174891714,
    )
)
_WG = wp.constant(
    _vec8d(
        0.0,
        0.129484966168869693270611432679082,
        0.0,
        0.279705391489276667901467771423780,
        0.0,
        0.381830050505118944950369775488975,
        0.0,
        0.417959183673469387755102040816327,
    )
)


_PI = wp.constant(wp.float64(math.pi))
_ERR_FLOOR = wp.constant(wp.float64(1.0e-10))
_HALF_PI = wp.constant(wp.float64(0.5 * math.pi))


@wp.struct
class TexelParams:
    """What the integrand needs besides the integration variables.

    Deliberately a copy of ``_fixed.Tex`` (plus err_model) with its own integrand below rather
    than a call into ``_fixed.m_terms``: the extra call level passing the struct by value cost
    ~30% of the integrand time (68 against 51 ns per evaluation, measured)."""

    mode: wp.int32
    dist: wp.int32
    shadowing: wp.int32
    ftype: wp.int32
    fp0: wp.float64
    fp1: wp.float64
    mu: wp.float64
    sin_i: wp.float64
    alpha: wp.float64
    eta: wp.float64
    li: wp.float64  # mu * Lambda(mu)
    err_model: wp.int32  # 0: |K15 - G7|, 1: QUADPACK rescaling


@wp.func
def _integrand(p: TexelParams, cm: wp.float64, sm: wp.float64, tm: wp.float64, phi: wp.float64):
    """F G D (i.m) / (mu D cos theta_m) for reflection (x) and transmission (y) at (theta_m, phi)."""
    zero = wp.float64(0.0)
    one = wp.float64(1.0)
    cp = wp.cos(phi)
    c = p.sin_i * sm * cp + p.mu * cm
    out = wp.vec2d(zero, zero)
    if c <= zero:
        # chi+(i.m): i sees the back of the micro-facet
        return out
    # (i.m) / cos(theta_m), written without the division
    jac = p.sin_i * tm * cp + p.mu
    zo = wp.float64(2.0) * c * cm - p.mu
    if zo > zero:
        lo = lambda_cos(zo, p.alpha, p.dist)
        g = smith_G_over_cos_i_from_lambda(p.mu, p.li, zo, lo, p.shadowing) * jac
        if p.mode == MODE_DFG:
            w = one - c
            w5 = w * w * w * w * w
            out = wp.vec2d(g * (one - w5), g * w5)
        elif p.mode == MODE_DIELECTRIC:
            out = wp.vec2d(fresnel_dielectric(c, p.eta) * g, zero)
        else:
            out = wp.vec2d(fresnel(c, p.ftype, p.fp0, p.fp1) * g, zero)
    if p.mode == MODE_DIELECTRIC:
        k2 = refract_k2(c, p.eta)
        if k2 > zero:
            # not totally reflected: o_t = (c/eta - sqrt(k2)) m - i/eta, with c/eta - sqrt(k2)
            # rationalized so that its sign is exact near eta = 1 (it is 0 at eta = 1)
            d = (one - p.eta) * (one + p.eta) / (p.eta * p.eta) / (c / p.eta + wp.sqrt(k2))
            zt = d * cm - p.mu / p.eta
            g = zero
            if zt < zero:
                azt = -zt
                lt = lambda_cos(azt, p.alpha, p.dist)
                g = smith_G_over_cos_i_from_lambda(p.mu, p.li, azt, lt, p.shadowing) * jac
            elif d == zero and p.mu == zero:
                # eta = 1 at grazing: o_t = -i exactly; G / mu by its mu -> 0+ limit
                g = smith_G_over_cos_i_equal(p.mu, p.li, p.shadowing) * jac
            out = wp.vec2d(out[0], (one - fresnel_dielectric(c, p.eta)) * g)
    return out


@wp.func
def _phi_of_c(cb: wp.float64, p: TexelParams, cm: wp.float64, sm: wp.float64):
    # invert i.m = sin_i sm cos(phi) + mu cm for phi in [0, pi]
    x = (cb - p.mu * cm) / (p.sin_i * sm)
    return wp.acos(wp.clamp(x, wp.float64(-1.0), wp.float64(1.0)))


@wp.func
def _gk_error(rk: wp.vec2d, rg: wp.vec2d, resasc: wp.vec2d, err_model: wp.int32):
    """Error estimate of the K15 value from |K15 - G7| (err_model 0), or QUADPACK's rescaling
    resasc min(1, (200 |K - G| / resasc)^1.5) (err_model 1), floored at 50 ulp of |K|."""
    out = wp.vec2d(wp.float64(0.0), wp.float64(0.0))
    for c in range(2):
        d = wp.abs(rk[c] - rg[c])
        e = d
        if err_model == 1 and resasc[c] > wp.float64(0.0) and d > wp.float64(0.0):
            e = resasc[c] * wp.min(wp.float64(1.0), wp.pow(wp.float64(200.0) * d / resasc[c], wp.float64(1.5)))
        out[c] = wp.max(e, wp.float64(1.1e-14) * wp.abs(rk[c]))
    return out


@wp.func
def _gk_phi(p: TexelParams, cm: wp.float64, sm: wp.float64, tm: wp.float64, a: wp.float64, b: wp.float64,
            ta: wp.float64, tb: wp.float64):
    """G7-K15 over t in [ta, tb] for the piece phi = a + (b - a)(3t^2 - 2t^3). Returns (K, error)."""
    half = wp.float64(0.5)
    ctr = half * (ta + tb)
    hl = half * (tb - ta)
    rk = wp.vec2d(wp.float64(0.0), wp.float64(0.0))
    rg = wp.vec2d(wp.float64(0.0), wp.float64(0.0))
    f0 = _vec16d()
    f1 = _vec16d()
    for j in range(15):
        jj = j
        sgn = wp.float64(1.0)
        if j >= 8:
            jj = j - 8
            sgn = wp.float64(-1.0)
        t = ctr + sgn * hl * _XGK[jj]
        s = t * t * (wp.float64(3.0) - wp.float64(2.0) * t)
        ds = wp.float64(6.0) * t * (wp.float64(1.0) - t)
        f = _integrand(p, cm, sm, tm, a + (b - a) * s) * (ds * (b - a))
        f0[j] = f[0]
        f1[j] = f[1]
        rk += _WGK[jj] * f
        rg += _WG[jj] * f
    mean = rk * half
    resasc = wp.vec2d(wp.float64(0.0), wp.float64(0.0))
    for j in range(15):
        jj = j
        if j >= 8:
            jj = j - 8
        resasc += _WGK[jj] * wp.vec2d(wp.abs(f0[j] - mean[0]), wp.abs(f1[j] - mean[1]))
    return rk * hl, _gk_error(rk * hl, rg * hl, resasc * hl, p.err_model)


@wp.func
def _adaptive_piece(p: TexelParams, cm: wp.float64, sm: wp.float64, tm: wp.float64, a: wp.float64,
                    b: wp.float64, tol: wp.float64, max_rules: wp.int32):
    """Globally adaptive G7-K15 over one phi piece: bisect the worst interval until the summed
    error of both channels is below ``tol`` (absolute), or ``max_rules`` rule applications or the
    interval capacity are used (the estimates then still count: the error stays honest)."""
    ia = _stackd()
    ib = _stackd()
    v0 = _stackd()
    v1 = _stackd()
    e0 = _stackd()
    e1 = _stackd()
    k, e = _gk_phi(p, cm, sm, tm, a, b, wp.float64(0.0), wp.float64(1.0))
    ia[0] = wp.float64(0.0)
    ib[0] = wp.float64(1.0)
    v0[0] = k[0]
    v1[0] = k[1]
    e0[0] = e[0]
    e1[0] = e[1]
    n = int(1)
    used = int(1)
    te0 = e[0]
    te1 = e[1]
    while (te0 > tol or te1 > tol) and used + 2 <= max_rules and n < _STACK:
        j = int(0)
        worst = wp.float64(-1.0)
        for q in range(n):
            w = wp.max(e0[q], e1[q])
            if w > worst:
                worst = w
                j = q
        mid = wp.float64(0.5) * (ia[j] + ib[j])
        kl, el = _gk_phi(p, cm, sm, tm, a, b, ia[j], mid)
        kr, er = _gk_phi(p, cm, sm, tm, a, b, mid, ib[j])
        used += 2
        te0 += el[0] + er[0] - e0[j]
        te1 += el[1] + er[1] - e1[j]
        ia[n] = mid
        ib[n] = ib[j]
        v0[n] = kr[0]
        v1[n] = kr[1]
        e0[n] = er[0]
        e1[n] = er[1]
        ib[j] = mid
        v0[j] = kl[0]
        v1[j] = kl[1]
        e0[j] = el[0]
        e1[j] = el[1]
        n += 1
    total = wp.vec2d(wp.float64(0.0), wp.float64(0.0))
    err = wp.vec2d(wp.float64(0.0), wp.float64(0.0))
    for q in range(n):
        total += wp.vec2d(v0[q], v1[q])
        err += wp.vec2d(e0[q], e1[q])
    return total, err, used


@wp.func
def _insert_sorted(v: _vec6d, n: wp.int32, x: wp.float64):
    # insertion into the first n sorted entries (n < 6)
    i = n
    while i > 0 and v[i - 1] > x:
        v[i] = v[i - 1]
        i -= 1
    v[i] = x
    return v


@wp.func
def _insert_sorted24(v: _vec24d, n: wp.int32, x: wp.float64):
    # insertion into the first n sorted entries (n < 24)
    i = n
    while i > 0 and v[i - 1] > x:
        v[i] = v[i - 1]
        i -= 1
    v[i] = x
    return v


@wp.func
def _t_floor(p: TexelParams, cm: wp.float64):
    """Lowest i.m with transmission (eta < 1): the horizon root c_t if valid, else c_TIR."""
    e2 = wp.float64(1.0) - p.eta * p.eta
    if p.mu <= wp.float64(0.0):
        # grazing from inside: nothing is transmitted
        return wp.float64(2.0)
    c_t = p.mu / (wp.float64(2.0) * cm) + e2 * cm / (wp.float64(2.0) * p.mu)
    if c_t * cm >= p.mu:
        return c_t
    return wp.sqrt(e2)


@wp.func
def _t_gap(p: TexelParams, theta_i: wp.float64, theta: wp.float64, which: wp.int32):
    # c_max (which = 0) or c_min (which = 1) minus the transmission floor at theta_m = theta
    cm = wp.cos(theta)
    c = wp.cos(theta_i - theta)
    if which == 1:
        c = wp.cos(theta_i + theta)
    return c - _t_floor(p, cm)


@wp.func
def _transmission_breaks(p: TexelParams, theta_i: wp.float64, cands: _vec24d, ncand: wp.int32):
    """Append theta_m where c_max or c_min crosses the transmission floor (at most 2 each)."""
    n = ncand
    steps = int(64)
    for which in range(2):
        found = int(0)
        ta = wp.float64(1.0e-9)
        ga = _t_gap(p, theta_i, ta, which)
        for k in range(steps):
            tb = _HALF_PI * wp.float64(k + 1) / wp.float64(steps) - wp.float64(1.0e-9)
            gb = _t_gap(p, theta_i, tb, which)
            if (ga > wp.float64(0.0)) != (gb > wp.float64(0.0)) and found < 2 and n < 24:
                lo = ta
                hi = tb
                glo = ga
                for _it in range(60):
                    mid = wp.float64(0.5) * (lo + hi)
                    gm = _t_gap(p, theta_i, mid, which)
                    if (gm > wp.float64(0.0)) == (glo > wp.float64(0.0)):
                        lo = mid
                        glo = gm
                    else:
                        hi = mid
                cands[n] = wp.float64(0.5) * (lo + hi)
                n += 1
                found += 1
            ta = tb
            ga = gb
    return cands, n


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
        f = _integrand(p, cm, sm, tm, wp.float64(0.5) * pi)
        return f * pi, err, int(1)
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
    for q in range(ncand):
        cb = cands[q]
        if cb > c_min and cb < c_max:
            cuts = _insert_sorted(cuts, nc, _phi_of_c(cb, p, cm, sm))
            nc += 1
    # below c_floor every channel vanishes: reflection needs i.m > mu / (2 cos theta_m), and
    # transmission i.m > 0 (eta >= 1) or i.m above the transmission horizon (eta < 1)
    c_floor = cands[1]
    if p.mode == MODE_DIELECTRIC:
        c_floor = wp.min(c_floor, t_floor)
    a = zero
    rules = int(0)
    for q in range(nc + 1):
        b = pi
        if q < nc:
            b = cuts[q]
        if p.mu * cm + ss * wp.cos(a) <= c_floor:
            # phi increases as i.m decreases: this piece and all later ones are empty
            break
        if b > a:
            r, e, used = _adaptive_piece(p, cm, sm, tm, a, b, tol * (b - a) / pi, max_rules)
            total += r
            err += e
            rules += used
        a = b
    return total, err, rules


@wp.func
def _theta_of_v(p: TexelParams, v: wp.float64):
    """tan(theta_m) for outer variable v, where u = 1 - (1 - v)^2 is the D cos CDF."""
    one = wp.float64(1.0)
    w = one - v
    if p.dist == BECKMANN:
        # u = 1 - exp(-tan^2 / alpha^2)  =>  tan^2 = -alpha^2 log((1 - v)^2)
        return p.alpha * wp.sqrt(wp.max(wp.float64(0.0), wp.float64(-2.0) * log1p_(-v)))
    # GGX: u = tan^2 / (alpha^2 + tan^2)  =>  tan = alpha sqrt(u) / (1 - v)
    return p.alpha * wp.sqrt(v * (wp.float64(2.0) - v)) / w


@wp.func
def _v_of_theta(p: TexelParams, theta: wp.float64):
    """Inverse of :func:`_theta_of_v` (theta in [0, pi/2])."""
    one = wp.float64(1.0)
    if theta >= _HALF_PI:
        return one
    c = wp.cos(theta)
    s = wp.sin(theta)
    if p.dist == BECKMANN:
        t = s / c
        return -expm1_(-t * t / (wp.float64(2.0) * p.alpha * p.alpha))
    return one - p.alpha * c / wp.sqrt(p.alpha * p.alpha * c * c + s * s)


@wp.func
def _gk_v(p: TexelParams, va: wp.float64, vb: wp.float64, tol_in: wp.float64, max_rules: wp.int32):
    """G7-K15 over v in [va, vb] of 2 (1 - v) * inner(v). Returns (K, error incl. inner, rules)."""
    half = wp.float64(0.5)
    one = wp.float64(1.0)
    ctr = half * (va + vb)
    hl = half * (vb - va)
    rk = wp.vec2d(wp.float64(0.0), wp.float64(0.0))
    rg = wp.vec2d(wp.float64(0.0), wp.float64(0.0))
    ei = wp.vec2d(wp.float64(0.0), wp.float64(0.0))
    f0 = _vec16d()
    f1 = _vec16d()
    rules = int(0)
    for j in range(15):
        jj = j
        sgn = one
        if j >= 8:
            jj = j - 8
            sgn = -one
        v = ctr + sgn * hl * _XGK[jj]
        tm = _theta_of_v(p, v)
        cm = one / wp.sqrt(one + tm * tm)
        sm = tm * cm
        jac = wp.float64(2.0) * (one - v)
        f, e, used = _inner(p, cm, sm, tm, tol_in / jac, max_rules)
        rules += used
        f = f * jac
        f0[j] = f[0]
        f1[j] = f[1]
        rk += _WGK[jj] * f
        rg += _WG[jj] * f
        ei += _WGK[jj] * jac * e
    mean = rk * half
    resasc = wp.vec2d(wp.float64(0.0), wp.float64(0.0))
    for j in range(15):
        jj = j
        if j >= 8:
            jj = j - 8
        resasc += _WGK[jj] * wp.vec2d(wp.abs(f0[j] - mean[0]), wp.abs(f1[j] - mean[1]))
    return rk * hl, _gk_error(rk * hl, rg * hl, resasc * hl, p.err_model) + ei * hl, rules


@wp.func
def _mirror(p: TexelParams):
    """alpha = 0: D is a Dirac delta at n, o is the mirror (or straight refraction), G = 1."""
    one = wp.float64(1.0)
    if p.mode == MODE_DFG:
        w = one - p.mu
        w5 = w * w * w * w * w
        return wp.vec2d(one - w5, w5)
    if p.mode == MODE_DIELECTRIC:
        f = fresnel_dielectric(p.mu, p.eta)
        return wp.vec2d(f, one - f)
    return wp.vec2d(fresnel(p.mu, p.ftype, p.fp0, p.fp1), wp.float64(0.0))


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
    value: wp.array2d(dtype=wp.float64),
    error: wp.array2d(dtype=wp.float64),
    cost: wp.array(dtype=wp.int32),
):
    tid = wp.tid()
    i = idx[tid]
    zero = wp.float64(0.0)
    one = wp.float64(1.0)
    mu = wp.clamp(mu_a[i], zero, one)
    p = TexelParams()
    p.mode = mode
    p.dist = dist
    p.shadowing = shadowing
    p.ftype = ftype
    p.fp0 = fp0
    p.fp1 = fp1
    p.mu = mu
    p.sin_i = wp.sqrt(wp.max(zero, one - mu * mu))
    p.alpha = alpha_a[i]
    p.eta = eta_a[i]
    p.li = lambda_cos(mu, p.alpha, dist)
    p.err_model = err_model
    if p.alpha <= zero:
        r = _mirror(p)
        value[i, 0] = r[0]
        value[i, 1] = r[1]
        error[i, 0] = zero
        error[i, 1] = zero
        cost[i] = 1
        return
    # outer breakpoints in theta_m where the phi pieces change (module docstring)
    theta_i = wp.acos(mu)
    hp = _HALF_PI
    th = _vec24d()
    nt = int(0)
    cands = _vec24d()
    cands[0] = wp.float64(0.5) * (hp - theta_i)
    cands[1] = hp - theta_i
    cands[2] = wp.float64(0.5) * (hp + theta_i)
    ncand = int(3)
    if mode == MODE_DIELECTRIC and p.eta < one:
        theta_c = wp.acos(wp.sqrt(one - p.eta * p.eta))
        cands[3] = wp.abs(theta_i - theta_c)
        cands[4] = theta_i + theta_c
        ncand = 5
    if mode == MODE_DIELECTRIC and p.eta < one:
        # where the transmitted set (i.m above its floor, see _inner) appears or fills the whole
        # phi circle: no closed form, so locate sign changes on a grid and bisect
        cands, ncand = _transmission_breaks(p, theta_i, cands, ncand)
    # fixed angles too: the v map packs theta_m >> alpha into the last ~alpha of [0, 1], where a
    # single rule could otherwise step over the horizon structure without noticing it
    for q in range(7):
        cands[ncand] = wp.float64(q + 1) * _HALF_PI / wp.float64(8.0)
        ncand += 1
    for q in range(ncand):
        x = cands[q]
        if x > zero and x < hp:
            th = _insert_sorted24(th, nt, x)
            nt += 1
    v_end = one
    if mode != MODE_DIELECTRIC:
        # reflection only: no admissible micro-normal beyond theta_m = (pi/2 + theta_i) / 2
        v_end = _v_of_theta(p, wp.float64(0.5) * (hp + theta_i))
    # split the budget: a quarter for the inner phi integrals (summed through the outer weights,
    # at most tol_in in total), the rest for the outer v quadrature
    tol_total = tol * _PI
    tol_in = wp.float64(0.25) * tol_total
    ia = _stackd()
    ib = _stackd()
    v0 = _stackd()
    v1 = _stackd()
    e0 = _stackd()
    e1 = _stackd()
    # initial intervals: the pieces between the breakpoints, none longer than 1/8 in v
    ends = _vec32d()
    ends[0] = zero
    ne = int(1)
    for q in range(nt + 1):
        vb = v_end
        if q < nt:
            vb = wp.min(_v_of_theta(p, th[q]), v_end)
        while vb - ends[ne - 1] > wp.float64(0.125) and ne < 30:
            ends[ne] = ends[ne - 1] + wp.float64(0.125)
            ne += 1
        if vb > ends[ne - 1] and vb <= v_end and ne < 31:
            ends[ne] = vb
            ne += 1
    ne -= 1
    n = int(0)
    used = int(0)
    rules = int(0)
    te = wp.vec2d(zero, zero)
    for q in range(ne):
        if ends[q + 1] > ends[q]:
            r, e, inner_rules = _gk_v(p, ends[q], ends[q + 1], tol_in, max_rules_inner)
            used += 1
            rules += inner_rules
            ia[n] = ends[q]
            ib[n] = ends[q + 1]
            v0[n] = r[0]
            v1[n] = r[1]
            e0[n] = e[0]
            e1[n] = e[1]
            te += e
            n += 1
    # global adaptivity: bisect the interval with the largest error until the sum is small enough
    while (te[0] > tol_total or te[1] > tol_total) and used + 2 <= max_rules_outer and n < _STACK:
        j = int(0)
        worst = wp.float64(-1.0)
        for q in range(n):
            w = wp.max(e0[q], e1[q])
            if w > worst:
                worst = w
                j = q
        mid = wp.float64(0.5) * (ia[j] + ib[j])
        rl, el, rules_l = _gk_v(p, ia[j], mid, tol_in, max_rules_inner)
        rr, er, rules_r = _gk_v(p, mid, ib[j], tol_in, max_rules_inner)
        used += 2
        rules += rules_l + rules_r
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
    value[i, 0] = total[0] / _PI
    value[i, 1] = total[1] / _PI
    # floor: float64 accumulation over ~1e5 terms is not trusted below 1e-10 absolute
    error[i, 0] = wp.max(err[0] / _PI, _ERR_FLOOR)
    error[i, 1] = wp.max(err[1] / _PI, _ERR_FLOOR)
    # integrand evaluations: 15 per inner rule application
    cost[i] = rules * 15


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
    return_cost: bool = False,
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

    Returns
    -------
    values, errors : ndarray, shape (N, 2)
        Channel 0 / 1 are (E, 0), (R, T) or (A, B); errors are the per-texel estimates.
    cost : ndarray of int, shape (N,)
        Integrand evaluations per texel (only with ``return_cost=True``).
    """
    from .parallel import resolve_device, run_chunks

    dev = resolve_device(device) if not isinstance(device, wp.Device) else device
    mu = np.ascontiguousarray(mu, dtype=np.float64).ravel()
    alpha = np.ascontiguousarray(alpha, dtype=np.float64).ravel()
    n = mu.size
    eta = np.ones(n) if eta is None else np.ascontiguousarray(eta, dtype=np.float64).ravel()
    if not (alpha.size == n and eta.size == n):
        raise ValueError("mu, alpha and eta must have the same number of texels")
    mu_w = wp.array(mu, dtype=wp.float64, device=dev)
    alpha_w = wp.array(alpha, dtype=wp.float64, device=dev)
    eta_w = wp.array(eta, dtype=wp.float64, device=dev)
    value = wp.zeros((n, 2), dtype=wp.float64, device=dev)
    error = wp.zeros((n, 2), dtype=wp.float64, device=dev)
    cost = wp.zeros(n, dtype=wp.int32, device=dev)

    def launch(idx):
        wp.launch(
            texel_kernel,
            dim=idx.shape[0],
            inputs=[
                idx, mu_w, alpha_w, eta_w, MODES[mode], int(dist), int(shadowing), int(ftype),
                float(fp0), float(fp1), float(tol), int(err_model), int(max_rules_outer), int(max_rules_inner),
                value, error, cost,
            ],
            device=dev,
        )

    # interleave the texels so that expensive ones (grazing mu) spread over the workers
    order = np.argsort(np.arange(n) % 7, kind="stable") if n > 64 else None
    run_chunks(n, launch, dev, workers=workers, progress=progress, order=order)
    if return_cost:
        return value.numpy(), error.numpy(), cost.numpy()
    return value.numpy(), error.numpy()
