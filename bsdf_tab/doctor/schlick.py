"""The split-sum table under Schlick-GGX shadowing, by deterministic quadrature (NumPy, float64).

Many engines' DFG LUTs are not Smith GGX: Karis' UE4 notes, learnopengl.com and Godot's
``integrate_dfg.glsl`` use the separable Schlick-GGX G1(x) = x / (x (1 - k) + k) with
k = alpha / 2 (alpha = roughness^2). bsdf-tab's integrators do not have it, so the doctor
computes this candidate itself:

    A, B = int (1 - Fc, Fc) G(v, l) (v.h) / (mu cos theta_h)  D(h) cos theta_h dw_h,
    Fc = (1 - v.h)^5,

with the GGX NDF mapped to the unit square (u: cos^2 theta_h = (1 - u) / (1 + (alpha^2 - 1) u),
so D cos dw_h = du dphi / (2 pi)), phi over the exact range where l = 2 (v.h) h - v is above
the horizon (cos phi > (mu / (2 cos theta_h) - mu cos theta_h) / (sin theta_v sin theta_h):
no indicator inside the rule), Gauss-Legendre in u and in phi, and the mirror limit at
alpha = 0. ``g1`` may be swapped for Smith's, which is how the rule is tested against
bsdf-tab's own separable table.
"""

from __future__ import annotations

import numpy as np

__all__ = ["SCHLICK_K", "dfg_quadrature", "schlick_g1", "smith_g1"]

SCHLICK_K = "alpha / 2"


def schlick_g1(x: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """Schlick-GGX G1 with k = alpha / 2 (the denominator is >= min(x, k) > 0 for x > 0)."""
    k = 0.5 * alpha
    return x / np.maximum(x * (1.0 - k) + k, 1e-300)


def smith_g1(x: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """Smith GGX G1 = 2 / (1 + sqrt(1 + alpha^2 tan^2)) (for tests of the rule)."""
    x = np.clip(x, 1e-12, 1.0)  # guard: x > 0 where l is above the horizon
    t2 = (1.0 - x * x) / (x * x)
    return 2.0 / (1.0 + np.sqrt(1.0 + alpha * alpha * t2))


def _u_of(cos_h: float, a: float) -> float:
    """The NDF coordinate u of the half-vector angle with cosine ``cos_h`` (inverse of the mapping above)."""
    c2 = cos_h * cos_h
    return (1.0 - c2) / (1.0 + (a * a - 1.0) * c2)  # denominator >= min(1, a^2) c2 > 0


def _one(mv: float, a: float, g1, gu, wu, gp, wp) -> tuple[float, float]:
    """A, B at one (mu, alpha > 0): u split where the phi range starts to shrink (theta_h =
    (pi/2 - theta_v)/2) and where it closes ((pi/2 + theta_v)/2), Gauss-Legendre in each piece."""
    tv = np.arccos(mv)
    cuts = [0.0, _u_of(np.cos(0.5 * (0.5 * np.pi - tv)), a), _u_of(np.cos(0.5 * (0.5 * np.pi + tv)), a)]
    sv = np.sqrt(max(1.0 - mv * mv, 0.0))
    A = B = 0.0
    for piece, (lo, hi) in enumerate(zip(cuts[:-1], cuts[1:])):
        if hi <= lo:
            continue
        if piece == 0:
            u = lo + (hi - lo) * 0.5 * (gu + 1.0)
            wu_ = (hi - lo) * 0.5 * wu
        else:  # u = 1 - t^2 (du = 2 t dt): the weight's 1/cos theta_h ~ 1/sqrt(1 - u) as theta_h -> pi/2
            t_lo, t_hi = np.sqrt(max(1.0 - hi, 0.0)), np.sqrt(max(1.0 - lo, 0.0))
            t = t_lo + (t_hi - t_lo) * 0.5 * (gu + 1.0)
            u = 1.0 - t * t
            wu_ = (t_hi - t_lo) * 0.5 * wu * 2.0 * t
        ch = np.sqrt((1.0 - u) / (1.0 + (a * a - 1.0) * u))  # denominator >= min(1, a^2) > 0
        sh = np.sqrt(np.maximum(1.0 - ch * ch, 0.0))
        num = mv / (2.0 * ch) - mv * ch
        den = sv * sh
        c = np.where(den > 1e-300, num / np.maximum(den, 1e-300), np.where(num > 0, 2.0, -2.0))
        pmax = np.arccos(np.clip(c, -1.0, 1.0))[:, None]
        phi = 0.5 * (gp[None, :] + 1.0) * pmax
        vdh = sv * sh[:, None] * np.cos(phi) + mv * ch[:, None]
        lz = 2.0 * vdh * ch[:, None] - mv
        ok = (lz > 0) & (vdh > 0)
        g = np.where(ok, g1(np.asarray(mv), a) * g1(np.clip(lz, 1e-12, 1.0), a), 0.0)
        w = g * np.clip(vdh, 0.0, 1.0) / (mv * ch[:, None])  # mv >= 1e-6, ch > 0
        fc = (1.0 - np.clip(vdh, 0.0, 1.0)) ** 5
        # phi over [0, pmax] and its mirror: 2 / (2 pi)
        wt = wu_[:, None] * 0.5 * wp[None, :] * pmax / np.pi
        A += float(np.sum((1.0 - fc) * w * wt))
        B += float(np.sum(fc * w * wt))
    return A, B


def dfg_quadrature(mu, alpha, g1=schlick_g1, n_u: int = 48, n_phi: int = 32) -> tuple[np.ndarray, np.ndarray]:
    """A and B on the grid mu x alpha (shape (len(mu), len(alpha))), separable G = g1(mu) g1(l_z)."""
    mu = np.clip(np.asarray(mu, dtype=np.float64), 1e-6, 1.0)  # mu = 0: the limit from 1e-6
    alpha = np.asarray(alpha, dtype=np.float64)
    gu, wu = np.polynomial.legendre.leggauss(n_u)
    gp, wp = np.polynomial.legendre.leggauss(n_phi)
    A = np.zeros((mu.size, alpha.size))
    B = np.zeros_like(A)
    for j, a in enumerate(alpha):
        for i, mv in enumerate(mu):
            if a <= 1e-7:  # the mirror: h = n, v.h = mu, G = g1(mu)^2 (-> 1)
                fc = (1.0 - mv) ** 5
                g = float(g1(np.asarray(mv), a)) ** 2 if a > 0 else 1.0
                A[i, j], B[i, j] = (1.0 - fc) * g, fc * g
            else:
                A[i, j], B[i, j] = _one(float(mv), float(a), g1, gu, wu, gp, wp)
    return A, B
