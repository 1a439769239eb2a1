"""The shading polish of the LTC fit: the clipped L1 metric plus the shading error on fixed quad lights.

The L1 metric bounds the shading error of every light (half of it, times E), but the L1-optimal
lobe is not the one that shades typical lights best: at grazing it must cover the true lobe's
mass near the horizon and overestimates lights above it (docs/ltc.md). The polish minimizes,
per texel, from the L1 fit,

    J = fit_l1_clipped(a) + l1_weight x fit_l1 + weight x (1/K) sum_k abs(a I(Minv P_k) - T_k / E),

over the four stored entries and (with ``free_amplitude``) the relative amplitude a = s / m_up
(s = 1: the horizon amplitude; fit_l1, the sphere metric, keeps the matrix near the L1 optimum
where moving it gains little shading), where P_k are :data:`FIT_QUADS` fixed quad lights
(:func:`fit_quads`: a deterministic set, independent of any benchmark's random quads), T_k the
exact integral of f_r cos over P_k (:func:`bsdf_tab.ltc.exact.quad_integrals`, once per texel:
it does not depend on the matrix) and I the closed-form clamped-cosine integral of the polygon
transformed by Minv, horizon-clipped (:func:`bsdf_tab.model.ltc.ltc_quad_integral`). Both terms
are a Warp kernel (one thread per evaluation, float64); the first is the same node sum as
:mod:`bsdf_tab.ltc.kernels` with a general amplitude: a m_up - 1 + 2 sum_k (w_k / E) max(1 - a E D / f_k, 0).
"""

from __future__ import annotations

import math

import numpy as np
import warp as wp

from ..model.ltc import ltc_minv, ltc_quad_integral
from .exact import RULE as EXACT_RULE, quad_integrals
from .kernels import BatchLaunch, horizon_mass, l1_deficits
from ..integrate.runtime import resolve_device

# no kernel of this module is differentiated: no adjoint code (a third of the compile time)
wp.set_module_options({"enable_backward": False})

__all__ = ["FIT_QUADS", "LN_S_MAX", "S_RANGE", "ShadingObjective", "fit_quads"]

#: Quad lights per texel in the polish (half about the mirror direction, half over the hemisphere).
FIT_QUADS = 16
_INV_PI = wp.constant(wp.float64(0.31830988618379067154))
#: The polish's amplitude s is kept in [1 / S_RANGE, S_RANGE] (ln s clamped): where the fit quads see
#: no light (a needle at the horizon, mu and alpha -> 0) the shading term alone would drive s to 0.
S_RANGE = 1.5
LN_S_MAX = math.log(S_RANGE)
_LN_S_MAX = wp.constant(wp.float64(LN_S_MAX))
_PRIMES = (2, 3, 5, 7, 11, 13, 17)


def _radical_inverse(i: np.ndarray, base: int) -> np.ndarray:
    """Van der Corput radical inverse of the integers i in ``base`` (the Halton sequence's coordinate)."""
    i = np.asarray(i, dtype=np.int64).copy()
    out = np.zeros(i.shape)
    f = 1.0 / base
    while np.any(i > 0):
        out += f * (i % base)
        i //= base
        f /= base
    return out


def _normal_ppf(u: np.ndarray) -> np.ndarray:
    """The standard normal's inverse CDF (Acklam's rational approximation, |error| < 1.2e-9)."""
    a = (-3.969683028665376e+01, 2.209460984245205e+02, -2.759285104469687e+02, 1.383577518672690e+02,
         -3.066479806614716e+01, 2.506628277459239e+00)
    b = (-5.447609879822406e+01, 1.615858368580409e+02, -1.556989798598866e+02, 6.680131188771972e+01,
         -1.328068155288572e+01)
    c = (-7.784894002430293e-03, -3.223964580411365e-01, -2.400758277161838e+00, -2.549732539343734e+00,
         4.374664141464968e+00, 2.938163982698783e+00)
    d = (7.784695709041462e-03, 3.224671290700398e-01, 2.445134137142996e+00, 3.754408661907416e+00)
    u = np.clip(u, 1e-12, 1.0 - 1e-12)  # the tails: finite
    q = np.minimum(u, 1.0 - u)
    t = np.sqrt(-2.0 * np.log(q))
    tail = (((((c[0] * t + c[1]) * t + c[2]) * t + c[3]) * t + c[4]) * t + c[5]) / \
        ((((d[0] * t + d[1]) * t + d[2]) * t + d[3]) * t + 1.0)
    r = (u - 0.5) ** 2
    mid = (((((a[0] * r + a[1]) * r + a[2]) * r + a[3]) * r + a[4]) * r + a[5]) * (u - 0.5) / \
        (((((b[0] * r + b[1]) * r + b[2]) * r + b[3]) * r + b[4]) * r + 1.0)
    return np.where(q < 0.02425, np.where(u < 0.5, -tail, tail), mid)


def _candidates(mu: np.ndarray, k: np.ndarray, near: bool) -> np.ndarray:
    """Candidate quads (B, len(k), 4, 3) of Halton points k: centre, rotation and half-sizes."""
    h = np.stack([_radical_inverse(k, b) for b in _PRIMES], axis=1)  # (K, 7)
    s = np.sqrt(np.maximum(1.0 - mu * mu, 0.0))  # clamp: rounding at mu = 1
    if near:
        R = np.stack([-s, np.zeros_like(mu), mu], axis=-1)  # (B, 3)
        c = R[:, None, :] + 0.35 * _normal_ppf(h[:, :3])[None]
    else:
        z = 0.15 + 0.85 * h[:, 0]
        ph = 2.0 * math.pi * h[:, 1]
        r = np.sqrt(1.0 - z * z)
        c = np.broadcast_to(np.stack([r * np.cos(ph), r * np.sin(ph), z], axis=-1)[None], (mu.size, len(k), 3)).copy()
    c[..., 2] = np.maximum(c[..., 2], 0.15)
    c /= np.linalg.norm(c, axis=-1, keepdims=True)  # |c| >= 0.15
    helper = np.where((np.abs(c[..., 2]) < 0.9)[..., None], np.array([0.0, 0.0, 1.0]), np.array([1.0, 0.0, 0.0]))
    e1 = np.cross(c, helper)
    e1 /= np.linalg.norm(e1, axis=-1, keepdims=True)  # helper is never parallel to c (by the choice above)
    e2 = np.cross(c, e1)
    psi = math.pi * h[:, 3][None, :, None]
    e1, e2 = np.cos(psi) * e1 + np.sin(psi) * e2, -np.sin(psi) * e1 + np.cos(psi) * e2
    hx = (0.05 + 0.45 * h[:, 4])[None, :, None]
    hy = (0.05 + 0.45 * h[:, 5])[None, :, None]
    corners = np.stack([hx * e1 + hy * e2, -hx * e1 + hy * e2, -hx * e1 - hy * e2, hx * e1 - hy * e2], axis=2)
    return c[:, :, None, :] + corners


def fit_quads(mu, count: int = FIT_QUADS) -> np.ndarray:
    """The polish's quad lights for view cosines mu (B,): (B, count, 4, 3), deterministic.

    Quad k of a texel (the same Halton point 1 + k for every texel): a centre direction, for the
    first half the mirror direction plus a normal offset of 0.35 per coordinate, for the second
    half uniform in solid angle with z in [0.15, 1]; z floored at 0.15; a rectangle in the tangent
    plane at that unit centre, half-sizes in [0.05, 0.5], rotated about the centre; vertices
    counter-clockwise seen from the shading point (a positive integral). A quad with a vertex
    below z = 0.01 is shrunk toward its centre until it clears it (the lights are above the
    horizon; rejecting such quads instead, as bench/ltc.py's random quads do, was measured:
    docs/ltc.md).
    """
    mu = np.atleast_1d(np.asarray(mu, dtype=np.float64))
    n_near = count // 2
    v = np.concatenate([_candidates(mu, np.arange(1, n_near + 1), True),
                        _candidates(mu, np.arange(n_near + 1, count + 1), False)], axis=1)
    c = v.mean(axis=2)
    low = (v - c[:, :, None, :])[..., 2].min(axis=2)
    # c_z >= 0.15 > 0.01: shrink toward the centre until the lowest vertex is at 0.01
    scale = np.where(c[..., 2] + low < 0.01, (c[..., 2] - 0.01) / np.where(low < 0.0, -low, 1.0), 1.0)
    v = c[:, :, None, :] + scale[..., None, None] * (v - c[:, :, None, :])
    flip = np.einsum("bqc,bqc->bq", np.cross(v[:, :, 1] - v[:, :, 0], v[:, :, 2] - v[:, :, 0]), v[:, :, 0]) < 0.0
    v[flip] = v[flip][:, ::-1]
    return v


@wp.kernel
def _polish_objective(
    L: wp.array2d(dtype=wp.vec3d),
    wn: wp.array2d(dtype=wp.float64),
    mf: wp.array2d(dtype=wp.float64),
    Lc: wp.array2d(dtype=wp.vec3d),
    wnc: wp.array2d(dtype=wp.float64),
    mfc: wp.array2d(dtype=wp.float64),
    limit: wp.array(dtype=wp.float64),
    quads: wp.array3d(dtype=wp.vec3d),
    target: wp.array2d(dtype=wp.float64),
    idx: wp.array(dtype=wp.int32),
    X: wp.array2d(dtype=wp.float64),
    weight: wp.float64,
    l1_weight: wp.float64,
    penalty: wp.float64,
    free_amp: int,
    out: wp.array(dtype=wp.float64),
):
    t = wp.tid()
    b = idx[t]
    x = X[t, 0]
    y = X[t, 1]
    z = X[t, 2]
    w_ = X[t, 3]
    one = wp.float64(1.0)
    zero = wp.float64(0.0)
    s = one
    if free_amp != 0:
        s = wp.exp(wp.clamp(X[t, 4], -_LN_S_MAX, _LN_S_MAX))
    det_s = x * w_ - y * z
    amp = s / horizon_mass(x, y, det_s)
    det = wp.abs(det_s) * _INV_PI
    # the clipped metric (from a m_up - 1) and the sphere metric on the same nodes
    sums = l1_deficits(L, wn, mf, b, x, y, z, w_, det, amp, s - one)
    acc = sums[0]
    sphere = sums[1]
    excess = zero
    if penalty > zero:
        # the constraint fit_l1 <= limit, fit_l1 on the constraint's own nodes
        cons = l1_deficits(Lc, wnc, mfc, b, x, y, z, w_, det, one, zero)[1]
        excess = wp.max(cons - limit[b], zero)
    minv = ltc_minv(x, y, z, w_)
    nq = quads.shape[1]
    sh = zero
    for k in range(nq):
        i = ltc_quad_integral(minv, quads[b, k, 0], quads[b, k, 1], quads[b, k, 2], quads[b, k, 3])
        sh += wp.abs(amp * i - target[b, k])
    out[t] = wp.max(acc, zero) + l1_weight * sphere + weight * sh / wp.float64(nq) + penalty * excess


def _normalized(nodes):
    """(L, wn, mf) of a lobe quadrature (L, f, w): weights 2 w / mass and mass / f, as :class:`bsdf_tab.ltc.fit.Objective`."""
    L, f, w = nodes
    mass = w.sum(axis=1, keepdims=True)  # the rule's E: > 0 for alpha > 0
    return L, 2.0 * w / mass, np.where(f > 0.0, mass / np.where(f > 0.0, f, 1.0), 0.0)  # E / f_k


class ShadingObjective:
    """The polish objective of a batch of texels: ``obj(idx, X)``, X (n, 4) stored entries, or (n, 5) with
    ln s (the amplitude relative to the horizon one) when ``free_amplitude``.

    ``E`` (B,) normalizes the exact quad integrals T_k (the lobe T = f_r cos / E); ``nodes`` are the
    lobe's quadrature (:func:`bsdf_tab.ltc.lobe.lobe_nodes`) for the L1 term, normalized by the rule's
    own mass as in :class:`bsdf_tab.ltc.fit.Objective`. ``constraint`` = (nodes, limit (B,), penalty) adds
    penalty x max(fit_l1 - limit, 0), fit_l1 the sphere metric on those nodes (a soft constraint
    fit_l1 <= limit).
    """

    def __init__(self, dist, shadowing, mu, alpha, E, nodes, weight: float, free_amplitude: bool = False,
                 count: int = FIT_QUADS, device=None, l1_weight: float = 0.0, constraint=None, exact_rule=None):
        L, wn, mf = _normalized(nodes)
        mu = np.atleast_1d(np.asarray(mu, dtype=np.float64))
        quads = fit_quads(mu, count)
        B = len(mu)
        T = quad_integrals(quads.reshape(-1, 4, 3), np.repeat(mu, count), np.repeat(alpha, count), dist, shadowing,
                           rule=exact_rule or EXACT_RULE, device=device).reshape(B, count)
        self.target = T / np.asarray(E, dtype=np.float64)[:, None]  # E > 0 for alpha > 0
        self.free = bool(free_amplitude)
        self.weight = float(weight)
        self.l1_weight = float(l1_weight)
        if constraint is None:
            Lc, wnc, mfc, limit, self.penalty = L[:, :1], wn[:, :1], mf[:, :1], np.zeros(B), 0.0  # unused: penalty 0
        else:
            (Lc, wnc, mfc), limit, self.penalty = _normalized(constraint[0]), constraint[1], float(constraint[2])
        self.count = 0
        dev = resolve_device(device)
        arr = lambda a, dt=wp.float64: wp.array(np.ascontiguousarray(a), dtype=dt, device=dev)  # noqa: E731
        self._launch = BatchLaunch(_polish_objective, [arr(L, wp.vec3d), arr(wn), arr(mf), arr(Lc, wp.vec3d), arr(wnc),
                                                       arr(mfc), arr(np.asarray(limit, dtype=np.float64)),
                                                       arr(quads, wp.vec3d), arr(self.target)],
                                   [self.weight, self.l1_weight, self.penalty, 1 if self.free else 0], 5, dev, 16 * B)

    def __call__(self, idx, X):
        self.count += int(idx.size)
        return self._launch(idx, X)
