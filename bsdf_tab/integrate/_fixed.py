"""Shared pieces of the fixed-effort methods (grid, Monte Carlo, QMC, VNDF Gauss-Legendre).

Device side: the texel parameters, the integrand written over the micro-normal m (used by
D(m)cos, VNDF and VNDF-square quadrature) and over the outgoing direction o (used by the
hemisphere grid and cosine-sampled Monte Carlo), and the mirror limit alpha = 0.
Host side: one launcher for every fixed-effort kernel, and the o-space resolution guard.

Conventions are those of :mod:`bsdf_tab.integrate.adaptive` (SPEC section 2): w_i =
(sqrt(1 - mu^2), 0, mu); mode "reflect" gives (E, 0) with Fresnel ``ftype``, "dielectric"
(R, T) with exact dielectric Fresnel of relative IOR eta, "dfg" (A, B) with F = 1.
Every G is formed as G / mu from mu Lambda (finite at grazing mu = 0).
"""

from __future__ import annotations

import math

import numpy as np
import warp as wp

from ..model.distribution import D, lambda_cos
from ..model.fresnel import fresnel, fresnel_dielectric
from ..model.frame import refract_k2
from ..model.shadowing import smith_G_over_cos_i_equal, smith_G_over_cos_i_from_lambda

MODE_REFLECT = wp.constant(0)
MODE_DIELECTRIC = wp.constant(1)
MODE_DFG = wp.constant(2)
MODES = {"reflect": 0, "dielectric": 1, "dfg": 2}

PI64 = wp.constant(wp.float64(math.pi))
TWO_PI64 = wp.constant(wp.float64(2.0 * math.pi))


@wp.struct
class Tex:
    """One texel: incidence, material, integrand family."""

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
    li: wp.float64  # mu Lambda(mu)


@wp.func
def make_tex(mode: wp.int32, dist: wp.int32, shadowing: wp.int32, ftype: wp.int32, fp0: wp.float64,
             fp1: wp.float64, mu_in: wp.float64, alpha: wp.float64, eta: wp.float64):
    zero = wp.float64(0.0)
    one = wp.float64(1.0)
    p = Tex()
    mu = wp.clamp(mu_in, zero, one)
    p.mode = mode
    p.dist = dist
    p.shadowing = shadowing
    p.ftype = ftype
    p.fp0 = fp0
    p.fp1 = fp1
    p.mu = mu
    p.sin_i = wp.sqrt(wp.max(zero, one - mu * mu))
    p.alpha = alpha
    p.eta = eta
    p.li = lambda_cos(mu, alpha, dist)
    return p


@wp.func
def mirror(p: Tex):
    """alpha = 0: D is a Dirac delta at n (mirror reflection / straight refraction, G = 1)."""
    one = wp.float64(1.0)
    if p.mode == MODE_DFG:
        w = one - p.mu
        w5 = w * w * w * w * w
        return wp.vec2d(one - w5, w5)
    if p.mode == MODE_DIELECTRIC:
        f = fresnel_dielectric(p.mu, p.eta)
        return wp.vec2d(f, one - f)
    return wp.vec2d(fresnel(p.mu, p.ftype, p.fp0, p.fp1), wp.float64(0.0))


@wp.func
def m_terms(p: Tex, m: wp.vec3d):
    """(F G / mu, (1 - F) G_t / mu) at micro-normal m, with every chi+ condition applied.

    Only m.x and m.z are read (isotropic, w_i in the xz-plane).

    Channel 0 is reflection (E, R, or A), channel 1 transmission T (dielectric) or B (dfg).
    The table integrals are int m_terms (i.m) D(m) dw_m (Walter 2007 eqs. 14, 17).
    """
    zero = wp.float64(0.0)
    one = wp.float64(1.0)
    out = wp.vec2d(zero, zero)
    c = p.sin_i * m[0] + p.mu * m[2]
    if c <= zero or m[2] <= zero:
        # i sees the back of the micro-facet
        return out
    cm = m[2]
    zo = wp.float64(2.0) * c * cm - p.mu
    if zo > zero:
        lo = lambda_cos(zo, p.alpha, p.dist)
        g = smith_G_over_cos_i_from_lambda(p.mu, p.li, zo, lo, p.shadowing)
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
            # refracted o_t = (c/eta - sqrt(k2)) m - i/eta; the coefficient rationalized so that
            # its sign is exact near eta = 1
            d = (one - p.eta) * (one + p.eta) / (p.eta * p.eta) / (c / p.eta + wp.sqrt(k2))
            zt = d * cm - p.mu / p.eta
            g = zero
            if zt < zero:
                azt = -zt
                g = smith_G_over_cos_i_from_lambda(p.mu, p.li, azt, lambda_cos(azt, p.alpha, p.dist), p.shadowing)
            elif d == zero and p.mu == zero:
                # eta = 1 at grazing: o_t = -i, G / mu by its mu -> 0 limit
                g = smith_G_over_cos_i_equal(p.mu, p.li, p.shadowing)
            out = wp.vec2d(out[0], (one - fresnel_dielectric(c, p.eta)) * g)
    return out


@wp.func
def o_terms(p: Tex, o: wp.vec3d):
    """f |cos theta_o| at outgoing direction o: reflection (o.z > 0) in channel 0 (A and B
    for dfg), transmission (o.z < 0, dielectric only) in channel 1. G / mu form throughout."""
    zero = wp.float64(0.0)
    one = wp.float64(1.0)
    out = wp.vec2d(zero, zero)
    wi = wp.vec3d(p.sin_i, zero, p.mu)
    if o[2] > zero:
        h = wi + o
        hl = wp.length(h)
        if hl <= zero:
            return out
        h = h / hl
        c = wp.dot(wi, h)
        if c <= zero:
            return out
        zo = o[2]
        g = smith_G_over_cos_i_from_lambda(p.mu, p.li, zo, lambda_cos(zo, p.alpha, p.dist), p.shadowing)
        v = g * D(h[2], p.alpha, p.dist) * wp.float64(0.25)
        if p.mode == MODE_DFG:
            w = one - c
            w5 = w * w * w * w * w
            return wp.vec2d(v * (one - w5), v * w5)
        if p.mode == MODE_DIELECTRIC:
            return wp.vec2d(v * fresnel_dielectric(c, p.eta), zero)
        return wp.vec2d(v * fresnel(c, p.ftype, p.fp0, p.fp1), zero)
    if o[2] < zero and p.mode == MODE_DIELECTRIC:
        h = -(wi + p.eta * o)
        hl = wp.length(h)
        if hl <= zero:
            # eta = 1 and o = -i: the delta of smooth transmission, zero measure here
            return out
        h = h / hl
        if h[2] < zero:
            h = -h
        ci = wp.dot(wi, h)
        co = wp.dot(o, h)
        if ci <= zero or co >= zero:
            return out
        den = ci + p.eta * co
        if den == zero:
            return out
        azo = -o[2]
        g = smith_G_over_cos_i_from_lambda(p.mu, p.li, azo, lambda_cos(azo, p.alpha, p.dist), p.shadowing)
        t = ci * (-co) * p.eta * p.eta * (one - fresnel_dielectric(ci, p.eta)) * g * D(h[2], p.alpha, p.dist)
        return wp.vec2d(zero, t / (den * den))
    return out


@wp.func
def store(value: wp.array2d(dtype=wp.float64), error: wp.array2d(dtype=wp.float64), i: wp.int32,
          v: wp.vec2d, e: wp.vec2d):
    value[i, 0] = v[0]
    value[i, 1] = v[1]
    error[i, 0] = e[0]
    error[i, 1] = e[1]


def launch_texels(kernel, mode, mu, alpha, eta, *, dist, shadowing, ftype, fp0, fp1, effort, seed,
                  device, workers, progress, extra=()):
    """Run a fixed-effort ``kernel`` over the texels; every such kernel has the signature
    (idx, mu, alpha, eta, mode, dist, shadowing, ftype, fp0, fp1, effort, seed, value, error,
    *extra), ``extra`` being NumPy float64 arrays (e.g. quadrature nodes) copied to the device.
    Returns (values, errors), each (N, 2) float64, plus the float64 inputs."""
    from .parallel import resolve_device, run_chunks

    if mode not in MODES:
        raise ValueError(f"unknown mode {mode!r}; one of {', '.join(MODES)}")
    dev = resolve_device(device) if not isinstance(device, wp.Device) else device
    mu = np.ascontiguousarray(mu, dtype=np.float64).ravel()
    alpha = np.ascontiguousarray(alpha, dtype=np.float64).ravel()
    n = mu.size
    eta = np.ones(n) if eta is None else np.ascontiguousarray(eta, dtype=np.float64).ravel()
    if not (alpha.size == n and eta.size == n):
        raise ValueError("mu, alpha and eta must have the same number of texels")
    if n == 0:
        return np.zeros((0, 2)), np.zeros((0, 2)), mu, alpha, eta
    mu_w = wp.array(mu, dtype=wp.float64, device=dev)
    alpha_w = wp.array(alpha, dtype=wp.float64, device=dev)
    eta_w = wp.array(eta, dtype=wp.float64, device=dev)
    value = wp.zeros((n, 2), dtype=wp.float64, device=dev)
    error = wp.zeros((n, 2), dtype=wp.float64, device=dev)
    extra_w = [wp.array(np.ascontiguousarray(a, dtype=np.float64), dtype=wp.float64, device=dev) for a in extra]

    def launch(idx):
        wp.launch(
            kernel,
            dim=idx.shape[0],
            inputs=[idx, mu_w, alpha_w, eta_w, MODES[mode], int(dist), int(shadowing), int(ftype),
                    float(fp0), float(fp1), int(effort), int(seed), value, error, *extra_w],
            device=dev,
        )

    # fixed cost per texel: small chunks only to spread the work over the workers
    run_chunks(n, launch, dev, workers=workers, progress=progress)
    return value.numpy(), error.numpy(), mu, alpha, eta


def lobe_width(mode: str, mu, alpha, eta):
    """Angular width (radians) of the narrowest lobe of the integrand over outgoing directions:
    ~2 alpha for reflection, ~alpha |eta - 1| / eta for transmission (the half-vector map
    compresses by |eta - 1| as eta -> 1). Used to flag what o-space methods cannot resolve."""
    w = 2.0 * np.asarray(alpha, dtype=np.float64)
    if mode == "dielectric":
        eta = np.asarray(eta, dtype=np.float64)
        w_t = np.asarray(alpha) * np.abs(eta - 1.0) / np.maximum(eta, 1.0)
        tir = eta < 1.0
        # transmission exists unless the whole direction is beyond the critical angle; keep it
        w = np.minimum(w, np.where(tir, np.maximum(w_t, 0.0), w_t))
    return w


def finalize(mode, values, errors, alpha):
    """Clamp to the physical range (values in [0, 1], R + T <= 1) and cap errors at 1 (value and
    truth both lie in [0, 1]); a non-finite estimate becomes 0 with error 1. A texel moved by the
    clamp gets the move added to its error, so the error stays an honest bound."""
    bad = ~np.isfinite(values)
    values = np.where(bad, 0.0, values)
    errors = np.where(bad | ~np.isfinite(errors), 1.0, errors)
    clipped = np.clip(values, 0.0, 1.0)
    errors = errors + np.abs(clipped - values)
    values = clipped
    if mode == "dielectric":
        s = values.sum(axis=1)
        over = s > 1.0
        if over.any():
            scaled = values[over] / s[over, None]
            errors[over] += values[over] - scaled
            values[over] = scaled
    if mode == "reflect":
        values[:, 1] = 0.0
        errors[:, 1] = 0.0
    errors = np.clip(errors, 0.0, 1.0)
    exact = (np.asarray(alpha) <= 0.0)[:, None]
    errors = np.where(exact, 0.0, errors)
    return values, errors
