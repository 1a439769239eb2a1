"""A vectorized NumPy float64 implementation of the same integrals, for the speed comparison.

Same micro-normal parametrization as the Warp integrator (v, phi), same closed-form splits of
the phi range and the same outer breakpoints, but a fixed composite Gauss-Legendre rule
(``n`` nodes per piece in each dimension) evaluated with NumPy array operations over
(texels, v nodes, phi nodes). It has no error control: ``bench/core.py`` raises ``n`` until its
maximum difference to the adaptive result is below the accuracy target, and times that run.
"""

from __future__ import annotations

import numpy as np
from scipy.special import erfc


def _lambda_cos(z, alpha, dist):
    z = np.abs(z)
    s2 = np.maximum(0.0, 1.0 - z * z)
    if dist == "ggx":
        a2s2 = alpha * alpha * s2
        den = 2.0 * (np.sqrt(z * z + a2s2) + z)
        return np.divide(a2s2, den, out=np.zeros_like(den), where=den > 0)
    s = np.sqrt(s2)
    with np.errstate(divide="ignore", invalid="ignore"):
        a = np.where(s * alpha > 0, z / (alpha * s), np.inf)
        out = alpha * s * 0.5 * (np.exp(-a * a) / np.sqrt(np.pi) - a * erfc(a))
    return np.where(np.isfinite(out), out, 0.0)


def _g_over_mu(mu, li, z, lz, shadowing):
    if shadowing == "correlated":
        den = mu * z + li * z + lz * mu
    else:
        den = (mu + li) * (z + lz)
    return np.divide(z, den, out=np.zeros_like(den), where=den > 0)


def _fresnel_dielectric(c, eta):
    g2 = eta * eta - 1.0 + c * c
    g = np.sqrt(np.maximum(g2, 0.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        a = (g - c) / (g + c)
        b = (c * (g + c) - 1.0) / (c * (g - c) + 1.0)
        f = 0.5 * a * a * (1.0 + b * b)
    return np.where(g2 <= 0, 1.0, np.nan_to_num(f, nan=1.0))


def _tan_theta(v, alpha, dist):
    if dist == "ggx":
        return alpha * np.sqrt(v * (2.0 - v)) / (1.0 - v)
    return alpha * np.sqrt(np.maximum(0.0, -2.0 * np.log1p(-v)))


def _v_of_theta(theta, alpha, dist):
    c, s = np.cos(theta), np.sin(theta)
    if dist == "ggx":
        return 1.0 - alpha * c / np.sqrt(alpha * alpha * c * c + s * s)
    t = s / np.maximum(c, 1e-300)
    return -np.expm1(-t * t / (2.0 * alpha * alpha))


def integrate(mode, mu, alpha, eta, n, dist="ggx", shadowing="correlated", chunk=32):
    """Fixed-rule (v, phi) quadrature of E (mode "reflect", F = 1) or (R, T) ("dielectric")."""
    out = np.zeros((mu.size, 2))
    x, w = np.polynomial.legendre.leggauss(n)
    for s in range(0, mu.size, chunk):
        sl = slice(s, s + chunk)
        out[sl] = _chunk(mode, mu[sl], alpha[sl], eta[sl], x, w, dist, shadowing)
    return out


def _pieces(ends, x, w):
    """Composite GL nodes/weights on consecutive [ends[k], ends[k+1]] (per row)."""
    a, b = ends[:, :-1, None], ends[:, 1:, None]
    nodes = 0.5 * (a + b) + 0.5 * (b - a) * x
    weights = 0.5 * (b - a) * w
    return nodes.reshape(len(ends), -1), weights.reshape(len(ends), -1)


def _chunk(mode, mu, alpha, eta, x, w, dist, shadowing):
    t = mu.size
    theta_i = np.arccos(mu)
    sin_i = np.sqrt(1.0 - mu * mu)
    hp = 0.5 * np.pi
    # outer breakpoints as in the Warp integrator: horizon angles + fixed angles
    cands = [0.5 * (hp - theta_i), hp - theta_i, 0.5 * (hp + theta_i)]
    cands += [np.full(t, k * np.pi / 16) for k in range(1, 8)]
    if mode == "dielectric":
        tc = np.arccos(np.sqrt(np.maximum(0.0, 1.0 - eta * eta)))
        inside = eta < 1
        cands += [np.where(inside, np.abs(theta_i - tc), 0.0), np.where(inside, theta_i + tc, 0.0)]
        v_end = np.ones(t)
    else:
        v_end = _v_of_theta(0.5 * (hp + theta_i), alpha, dist)
    th = np.clip(np.stack(cands, 1), 0.0, hp)
    vb = np.minimum(_v_of_theta(th, alpha[:, None], dist), v_end[:, None])
    grid = np.linspace(0.0, 1.0, 9)[None, :] * v_end[:, None]
    ends = np.sort(np.concatenate([grid, vb], 1), axis=1)
    v, wv = _pieces(ends, x, w)  # (t, nv)
    # zero-length pieces (coinciding breakpoints, v_end = 1) carry zero weight: keep them finite
    v = np.minimum(v, np.nextafter(1.0, 0.0))
    tm = _tan_theta(v, alpha[:, None], dist)
    cm = 1.0 / np.sqrt(1.0 + tm * tm)
    sm = tm * cm
    jac_v = 2.0 * (1.0 - v) * wv
    # inner phi pieces between the closed-form thresholds on i.m
    mu3, sin3 = mu[:, None, None], sin_i[:, None, None]
    cm3, sm3 = cm[..., None], sm[..., None]
    ss = sin3 * sm3
    c_r = mu3 / (2.0 * cm3)
    cuts = [np.zeros_like(c_r), c_r]
    if mode == "dielectric":
        e2 = np.maximum(0.0, 1.0 - eta * eta)[:, None, None]
        cuts += [np.sqrt(e2), c_r + e2 * cm3 / (2.0 * np.maximum(mu3, 1e-300))]
    with np.errstate(divide="ignore", invalid="ignore"):
        phis = [np.arccos(np.clip(np.nan_to_num((cb - mu3 * cm3) / ss), -1.0, 1.0)) for cb in cuts]
    phis = np.sort(np.concatenate([np.zeros_like(c_r), np.full_like(c_r, np.pi)] + phis, -1), -1)
    a, b = phis[..., :-1, None], phis[..., 1:, None]
    tt = 0.5 * (x + 1.0)
    smooth = tt * tt * (3.0 - 2.0 * tt)
    dsmooth = 6.0 * tt * (1.0 - tt) * 0.5 * w
    phi = (a + (b - a) * smooth).reshape(t, v.shape[1], -1)
    wphi = ((b - a) * dsmooth).reshape(t, v.shape[1], -1)
    cp = np.cos(phi)
    c = sin3 * sm3 * cp + mu3 * cm3
    jac = sin3 * tm[..., None] * cp + mu3
    li = _lambda_cos(mu, alpha, dist)[:, None, None]
    al3 = alpha[:, None, None]
    zo = 2.0 * c * cm3 - mu3
    ok_r = (c > 0) & (zo > 0)
    zo_s = np.where(ok_r, zo, 1.0)
    g_r = np.where(ok_r, _g_over_mu(mu3, li, zo_s, _lambda_cos(zo_s, al3, dist), shadowing) * jac, 0.0)
    out = np.zeros((t, 2))
    weight = jac_v[..., None] * wphi / np.pi
    g_r = np.nan_to_num(g_r)
    if mode == "reflect":
        out[:, 0] = np.sum(weight * g_r, axis=(1, 2))
        return out
    eta3 = eta[:, None, None]
    f = _fresnel_dielectric(np.clip(c, 0.0, 1.0), eta3)
    out[:, 0] = np.sum(weight * f * g_r, axis=(1, 2))
    k2 = 1.0 - (1.0 - c * c) / (eta3 * eta3)
    with np.errstate(invalid="ignore", divide="ignore"):
        d = (1.0 / (eta3 * eta3) - 1.0) / (c / eta3 + np.sqrt(np.maximum(k2, 0.0)))
    zt = d * cm3 - mu3 / eta3
    ok_t = (c > 0) & (k2 > 0) & (zt < 0)
    azt = np.where(ok_t, -zt, 1.0)
    g_t = np.where(ok_t, _g_over_mu(mu3, li, azt, _lambda_cos(azt, al3, dist), shadowing) * jac, 0.0)
    out[:, 1] = np.sum(weight * (1.0 - f) * np.nan_to_num(g_t), axis=(1, 2))
    return out
