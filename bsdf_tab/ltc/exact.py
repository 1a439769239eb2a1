"""The true lobe integrated over planar quads: int_P f_r(V, L) cos(theta_L) dL, a Warp kernel (float64).

The LTC fit's shading term (:mod:`bsdf_tab.ltc.shading`) compares the LTC estimate of a quad light
with this integral; it does not depend on the matrix, so it is computed once per texel and quad.

Rule: the quad is fanned into four triangles from its *peak point* p, the point of the quad
closest in angle to the mirror direction R = (-sqrt(1 - mu^2), 0, mu) (R itself when it pierces
the quad; else the best point of the boundary, where cos angle(a + u (b - a), R) has a single
stationary point per edge, u* = (A c1 - B c0) / (B c1 - A c2), in closed form). A near-mirror lobe
is a needle at R: with p at a vertex of every triangle, each triangle (p, a, b) is mapped from
the unit square by x = p + s ((a - p) + t (b - a)) (planar area s |(a - p) x (b - p)| ds dt,
solid angle d / |x|^3 per area, d the plane's distance) and the radial coordinate s is graded
toward p: Gauss-Legendre on [0, s0] with s0 = 0.01 alpha / (the triangle's angular size), then on
panels of equal width in ln s from s0 to 1 (in ln s, a lobe of any width alpha is a bump of
width O(1), which a fixed rule resolves), Gauss-Legendre in t. The lobe f_r cos = D(h) (G / mu) / 4
comes from :mod:`bsdf_tab.model` (G / mu from mu Lambda(mu): finite at mu = 0).

Accuracy: against the independent adaptive cubature of ``bench/ltc.py`` and against SciPy
(tests/ltc/test_shading.py); the rule's error is estimated by a coarser rule (``coarse``).
"""

from __future__ import annotations

import math

import numpy as np
import warp as wp

from ..model.distribution import D, distribution_id
from ..model.shadowing import SHADOWINGS, smith_G_over_cos_i
from .lobe import ALPHA_FLOOR
from ..integrate.runtime import resolve_device

# no kernel of this module is differentiated: no adjoint code (a third of the compile time)
wp.set_module_options({"enable_backward": False})

__all__ = ["COARSE_RULE", "FINE_RULE", "RULE", "peak_points", "quad_integrals"]

#: (Gauss-Legendre nodes per panel, the panels' width in ln s and ln t, the first radial panel
#: s0 = c_s alpha / size, the first panel along the edge c_t max(h, 2 alpha |p|) / |b - a|)
RULE = (8, 1.5, 0.3, 0.3)
COARSE_RULE = (6, 2.0, 0.3, 0.3)
#: A finer grading (3x the cost), for benchmarks: 5e-6 against the bench's cubature where RULE is 4e-5.
FINE_RULE = (8, 1.5, 0.02, 0.05)
_TINY = 1e-300


def peak_points(quads: np.ndarray, mu: np.ndarray) -> np.ndarray:
    """The point of each quad (N, 4, 3) closest in angle to the mirror direction of mu (N,)."""
    quads = np.asarray(quads, dtype=np.float64)
    mu = np.asarray(mu, dtype=np.float64)
    R = np.stack([-np.sqrt(np.maximum(1.0 - mu * mu, 0.0)), np.zeros_like(mu), mu], axis=-1)  # clamp: rounding
    n = np.cross(quads[:, 1] - quads[:, 0], quads[:, 2] - quads[:, 0])
    d = np.einsum("nc,nc->n", n, quads[:, 0])
    den = np.einsum("nc,nc->n", n, R)
    ok = np.abs(den) > _TINY
    t = np.where(ok, d / np.where(ok, den, 1.0), -1.0)  # the ray along R meets the plane at t R (t > 0)
    hit = t[:, None] * R
    inside = t > 0.0
    for k in range(4):
        a, b = quads[:, k], quads[:, (k + 1) % 4]
        inside &= np.einsum("nc,nc->n", np.cross(b - a, hit - a), n) * np.sign(d) >= 0.0
    best = quads[:, 0].copy()
    best_c = np.full(len(quads), -np.inf)
    for k in range(4):
        a, b = quads[:, k], quads[:, (k + 1) % 4]
        e = b - a
        A, B = np.einsum("nc,nc->n", R, a), np.einsum("nc,nc->n", R, e)
        c0, c1, c2 = np.einsum("nc,nc->n", a, a), np.einsum("nc,nc->n", a, e), np.einsum("nc,nc->n", e, e)
        den_u = B * c1 - A * c2
        okd = np.abs(den_u) > _TINY
        u_star = np.clip(np.where(okd, (A * c1 - B * c0) / np.where(okd, den_u, 1.0), 0.0), 0.0, 1.0)
        for u in (np.zeros(len(quads)), np.ones(len(quads)), u_star):
            x = a + u[:, None] * e
            c = np.einsum("nc,nc->n", x, R) / np.maximum(np.linalg.norm(x, axis=1), _TINY)  # x != 0: quad off the origin
            take = c > best_c
            best[take], best_c[take] = x[take], c[take]
    return np.where(inside[:, None], hit, best)


@wp.func
def _lobe(V: wp.vec3d, L: wp.vec3d, mu: wp.float64, alpha: wp.float64, dist: wp.int32, shadowing: wp.int32):
    """f_r(V, L) cos(theta_L) (F = 1) = D(h) (G / mu) / 4 for unit L, 0 below the horizon."""
    zero = wp.float64(0.0)
    if L[2] <= zero:
        return zero
    h = V + L
    hl = wp.length(h)
    if hl <= zero:
        # L = -V is below the horizon (handled above); guard anyway
        return zero
    h = h / hl
    if wp.dot(V, h) <= zero or h[2] <= zero:
        return zero
    return D(h[2], alpha, dist) * smith_G_over_cos_i(mu, L[2], alpha, dist, shadowing) / wp.float64(4.0)


@wp.func
def _graded(j: int, lo: wp.float64, length: wp.float64, tau0: wp.float64, lw: wp.float64):
    """Panel j of [lo, lo + length] graded toward lo: [0, tau0], then equal widths lw in ln(tau)."""
    a = wp.float64(0.0)
    b = tau0
    if j > 0:
        a = tau0 * wp.exp(lw * wp.float64(j - 1))
        b = tau0 * wp.exp(lw * wp.float64(j))
    return lo + a, lo + wp.min(b, length)


@wp.func
def _panels(length: wp.float64, tau0: wp.float64, width: wp.float64):
    """Number of log panels after [0, tau0] to reach ``length`` (0 when tau0 >= length) and their ln width."""
    if tau0 >= length:
        return 0, wp.float64(1.0)
    r = wp.log(length / tau0)  # tau0 > 0
    n = int(wp.ceil(r / width))
    return n, r / wp.float64(n)


@wp.kernel
def _quad_kernel(
    quads: wp.array2d(dtype=wp.vec3d),
    peak: wp.array(dtype=wp.vec3d),
    mu: wp.array(dtype=wp.float64),
    alpha: wp.array(dtype=wp.float64),
    xs: wp.array(dtype=wp.float64),
    ws: wp.array(dtype=wp.float64),
    panel_width: wp.float64,
    c_s: wp.float64,
    c_t: wp.float64,
    dist: wp.int32,
    shadowing: wp.int32,
    out: wp.array(dtype=wp.float64),
):
    q = wp.tid()
    m = mu[q]
    al = alpha[q]
    zero = wp.float64(0.0)
    one = wp.float64(1.0)
    V = wp.vec3d(wp.sqrt(wp.max(one - m * m, zero)), zero, m)  # clamp: rounding at mu = 1
    p = peak[q]
    total = zero
    ng = xs.shape[0]
    for k in range(4):
        a = quads[q, k]
        b = quads[q, (k + 1) % 4]
        cr = wp.cross(a - p, b - p)
        area2 = wp.length(cr)
        if area2 > wp.float64(1e-14) * wp.dot(p, p):
            # a triangle of no area (p on this edge) contributes nothing
            dplane = wp.abs(wp.dot(cr, p)) / area2
            size = wp.max(wp.length(a - p), wp.length(b - p)) / wp.length(p)  # |p| > 0: the quad is off the origin
            s0 = wp.min(one, c_s * al / size)  # a lobe as wide as the triangle needs no grading
            ns, lws = _panels(one, s0, panel_width)
            # t: graded both ways from the foot t0 of the perpendicular from p to the line ab, where
            # the radial integral peaks (a Lorentzian in t of width h / |b - a| for a needle at p)
            d = b - a
            dd = wp.dot(d, d)  # > 0: a quad's edge has length
            t0 = wp.min(one, wp.max(zero, -wp.dot(a - p, d) / dd))
            h = area2 / wp.sqrt(dd)
            # the width in t: h / |b - a| for a needle at p, at least the lobe's own (~ 2 alpha |p|)
            tau0 = c_t * wp.max(h, wp.float64(2.0) * al * wp.length(p)) / wp.sqrt(dd)
            if tau0 >= wp.float64(0.5):
                t0 = zero  # smooth along the edge: one panel over [0, 1]
                tau0 = one
            nl, lwl = _panels(t0, tau0, panel_width)
            nr, lwr = _panels(one - t0, tau0, panel_width)
            for side in range(2):
                nside = nr
                lw = lwr
                length = one - t0
                sgn = one
                if side == 1:
                    nside = nl
                    lw = lwl
                    length = t0
                    sgn = -one
                if length > zero:
                    for jt in range(nside + 1):
                        ta, tb = _graded(jt, zero, length, tau0, lw)
                        for it in range(ng):
                            tt = t0 + sgn * (ta + (tb - ta) * xs[it])
                            wt = (tb - ta) * ws[it]
                            w_dir = (a - p) + tt * d
                            acc = zero
                            for js in range(ns + 1):
                                sa, sb = _graded(js, zero, one, s0, lws)
                                for i in range(ng):
                                    s = sa + (sb - sa) * xs[i]
                                    x = p + s * w_dir
                                    r = wp.length(x)
                                    acc += (sb - sa) * ws[i] * s * _lobe(V, x / r, m, al, dist, shadowing) / (r * r * r)
                            total += wt * acc * area2 * dplane  # dA = s |(a - p) x (b - p)| ds dt, dw = d / r^3 dA
    out[q] = total


def _gl01(n: int):
    x, w = np.polynomial.legendre.leggauss(n)
    return 0.5 * (x + 1.0), 0.5 * w


def quad_integrals(quads, mu, alpha, dist: str = "ggx", shadowing: str = "correlated", rule=RULE, device=None):
    """int over each planar quad (N, 4, 3) of f_r cos dL (F = 1) at texels (mu, alpha) (N,): (N,)."""
    quads = np.ascontiguousarray(quads, dtype=np.float64)
    mu = np.ascontiguousarray(np.broadcast_to(mu, quads.shape[:1]), dtype=np.float64)
    alpha = np.maximum(np.ascontiguousarray(np.broadcast_to(alpha, quads.shape[:1]), dtype=np.float64), ALPHA_FLOOR)
    dev = resolve_device(device)
    xs, ws = _gl01(rule[0])
    arr = lambda a, dt=wp.float64: wp.array(np.ascontiguousarray(a), dtype=dt, device=dev)  # noqa: E731
    out = wp.zeros(len(quads), dtype=wp.float64, device=dev)
    wp.launch(_quad_kernel, dim=len(quads), device=dev,
              inputs=[arr(quads, wp.vec3d), arr(peak_points(quads, mu), wp.vec3d), arr(mu), arr(alpha), arr(xs),
                      arr(ws), float(rule[1]), float(rule[2]), float(rule[3]), distribution_id(dist), SHADOWINGS[shadowing], out])
    return out.numpy()
