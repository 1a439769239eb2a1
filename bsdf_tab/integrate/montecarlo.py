"""Monte Carlo and quasi-Monte Carlo texel integrators (fixed effort: samples per texel).

Four estimators of the same integrals (see :mod:`bsdf_tab.integrate.integrand`):

``mc_cosine``  outgoing directions o from the cosine-weighted hemisphere (pdf cos/pi); the
               lower hemisphere uses the mirrored sample (transmission). Weight pi f.
``mc_dcos``    micro-normals from D(m) cos(theta_m) (Walter et al. 2007, sec. 5.3), reflection
               and refraction of w_i about the same m. Weight F G (i.m) / (mu cos theta_m).
``mc_vndf``    visible normals (Heitz 2018 for GGX, Heitz and d'Eon 2014 for Beckmann).
               Weight F G / G1(i) <= 1 (and R + T <= 1 per sample).
``qmc_vndf``   the VNDF estimator on an Owen-scrambled 2-D Sobol sequence (Burley 2020,
               "Practical Hash-based Owen Scrambling": hash-based nested uniform scrambling,
               index shuffling), 8 independent scrambles of N/8 points each.

Random numbers: Warp's ``wp.rand_init`` / ``wp.randf``, seeded by the seed and a hash of the
texel's own parameters (mu, alpha, eta), not its position in the launch: a texel gets the same
samples whatever the chunking, the worker count, the table it is in, or the cluster worker that
computes it (a Dask chunk assembles the in-process table bit for bit). alpha = 0 gives the mirror
limit exactly.

Error channel (honest, never small when the estimate is unreliable):

* MC: 4 sigma_hat / sqrt(N) (sample variance) + 7 W / N, where W bounds the weights (1 for
  VNDF; for D(m)cos the weight at the tan theta_m exceeded with probability 7 / N, or the largest
  weight seen; for cosine sampling the largest weight seen): a region of probability >= 7/N is missed with
  probability < 1e-3, and a smaller one contributes at most 7 W / N.
* mc_cosine also gets error 1 when the narrowest lobe of the integrand (width ~2 alpha in
  reflection, alpha |eta - 1| / eta in transmission) is expected to hold fewer than 64 samples,
  and error 1 when the layer |z_o| < mu next to the horizon (grazing mu) holds fewer than 64.
* QMC: t-quantile (7 dof, 99.95%) times the standard error of the 8 replicate means, + 7/N.
"""

from __future__ import annotations

import math

import numpy as np
import warp as wp

from ..model.distribution import dcos_sample_tan, sample_vndf
from .fixed import finalize, launch_texels, lobe_width
from .integrand import PI64, TWO_PI64, TexelParams, begin_texel, m_terms, o_terms, store

# no kernel of this module is differentiated: no adjoint code (a third of the compile time)
wp.set_module_options({"enable_backward": False})

DEFAULT_EFFORT = {"mc_cosine": 65536, "mc_dcos": 65536, "mc_vndf": 65536, "qmc_vndf": 16384}
QMC_REPLICATES = wp.constant(8)
_T_QUANTILE = 5.408  # Student t, 7 degrees of freedom, two-sided 99.9%
_MISS = 7.0  # exp(-7) < 1e-3: chance to miss a region of probability 7 / N
COSINE_MIN_LOBE_SAMPLES = 64.0


@wp.func
def _finish(s: wp.vec2d, q: wp.vec2d, wmax: wp.float64, n: wp.int32):
    """Mean and error 4 sigma / sqrt(N) + 7 W / N of N weights with sums s, squares q."""
    nf = wp.float64(n)
    mean = s / nf
    err = wp.vec2d(wp.float64(0.0), wp.float64(0.0))
    for c in range(2):
        var = wp.max(wp.float64(0.0), (q[c] - nf * mean[c] * mean[c]) / wp.max(nf - wp.float64(1.0), wp.float64(1.0)))
        err[c] = wp.float64(4.0) * wp.sqrt(var / nf) + wp.float64(7.0) * wmax / nf
    return mean, err


@wp.kernel
def mc_cosine_kernel(idx: wp.array(dtype=wp.int32), mu_a: wp.array(dtype=wp.float64),
                     alpha_a: wp.array(dtype=wp.float64), eta_a: wp.array(dtype=wp.float64), mode: wp.int32,
                     dist: wp.int32, shadowing: wp.int32, ftype: wp.int32, fp0: wp.float64, fp1: wp.float64,
                     effort: wp.int32, seed: wp.int32, value: wp.array2d(dtype=wp.float64),
                     error: wp.array2d(dtype=wp.float64)):
    i, p, done = begin_texel(wp.tid(), idx, mu_a, alpha_a, eta_a, mode, dist, shadowing, ftype, fp0, fp1, value, error)
    if done:
        # alpha = 0: the mirror limit is stored
        return
    zero = wp.float64(0.0)
    state = wp.rand_init(_texel_seed(seed, p))
    s = wp.vec2d(zero, zero)
    q = wp.vec2d(zero, zero)
    wmax = zero
    for _k in range(effort):
        u1 = wp.float64(wp.randf(state))
        u2 = wp.float64(wp.randf(state))
        r = wp.sqrt(u1)
        phi = TWO_PI64 * u2
        z = wp.sqrt(wp.max(zero, wp.float64(1.0) - u1))
        if z <= zero:
            continue
        o = wp.vec3d(r * wp.cos(phi), r * wp.sin(phi), z)
        w = o_terms(p, o) * (PI64 / z)
        if p.mode == 1:
            wt = o_terms(p, wp.vec3d(o[0], o[1], -z))
            w = wp.vec2d(w[0], wt[1] * PI64 / z)
        s += w
        q += wp.cw_mul(w, w)
        wmax = wp.max(wmax, wp.max(w[0], w[1]))
    mean, err = _finish(s, q, wmax, effort)
    store(value, error, i, mean, err)


@wp.func
def _dcos_normal(p: TexelParams, u1: wp.float64, u2: wp.float64):
    """m from D(m) cos(theta_m) (the distribution's inverse CDF in theta_m, phi uniform);
    returns (m, tan theta_m)."""
    one = wp.float64(1.0)
    t = dcos_sample_tan(u1, p.alpha, p.dist)
    cm = one / wp.sqrt(one + t * t)
    sm = t * cm
    phi = TWO_PI64 * u2
    return wp.vec3d(sm * wp.cos(phi), sm * wp.sin(phi), cm), t


@wp.kernel
def mc_dcos_kernel(idx: wp.array(dtype=wp.int32), mu_a: wp.array(dtype=wp.float64),
                   alpha_a: wp.array(dtype=wp.float64), eta_a: wp.array(dtype=wp.float64), mode: wp.int32,
                   dist: wp.int32, shadowing: wp.int32, ftype: wp.int32, fp0: wp.float64, fp1: wp.float64,
                   effort: wp.int32, seed: wp.int32, value: wp.array2d(dtype=wp.float64),
                   error: wp.array2d(dtype=wp.float64)):
    i, p, done = begin_texel(wp.tid(), idx, mu_a, alpha_a, eta_a, mode, dist, shadowing, ftype, fp0, fp1, value, error)
    if done:
        # alpha = 0: the mirror limit is stored
        return
    zero = wp.float64(0.0)
    state = wp.rand_init(_texel_seed(seed, p))
    s = wp.vec2d(zero, zero)
    q = wp.vec2d(zero, zero)
    wmax = zero
    for _k in range(effort):
        u1 = wp.float64(wp.randf(state))
        u2 = wp.float64(wp.randf(state))
        m, t = _dcos_normal(p, u1, u2)
        # (i.m) / cos(theta_m) without the division
        jac = p.sin_i * t * wp.cos(TWO_PI64 * u2) + p.mu
        w = m_terms(p, m) * jac
        s += w
        q += wp.cw_mul(w, w)
        wmax = wp.max(wmax, wp.max(w[0], w[1]))
    # the D cos weight is the VNDF weight (<= 1) times (i.m) / (cos theta_m (mu + mu Lambda_i)),
    # unbounded in tan theta_m: bound it at the tan theta_m that N samples exceed with
    # probability ~7 / N (GGX tail; used for Beckmann too, whose tail is lighter)
    t_star = p.alpha * wp.sqrt(wp.float64(effort) / wp.float64(7.0))
    w_bound = (p.sin_i * t_star + p.mu) / wp.max(p.mu + p.li, wp.float64(1.0e-300))
    mean, err = _finish(s, q, wp.max(wmax, w_bound), effort)
    store(value, error, i, mean, err)


@wp.kernel
def mc_vndf_kernel(idx: wp.array(dtype=wp.int32), mu_a: wp.array(dtype=wp.float64),
                   alpha_a: wp.array(dtype=wp.float64), eta_a: wp.array(dtype=wp.float64), mode: wp.int32,
                   dist: wp.int32, shadowing: wp.int32, ftype: wp.int32, fp0: wp.float64, fp1: wp.float64,
                   effort: wp.int32, seed: wp.int32, value: wp.array2d(dtype=wp.float64),
                   error: wp.array2d(dtype=wp.float64)):
    i, p, done = begin_texel(wp.tid(), idx, mu_a, alpha_a, eta_a, mode, dist, shadowing, ftype, fp0, fp1, value, error)
    if done:
        # alpha = 0: the mirror limit is stored
        return
    zero = wp.float64(0.0)
    state = wp.rand_init(_texel_seed(seed, p))
    wi = wp.vec3d(p.sin_i, zero, p.mu)
    scale = p.mu + p.li  # (G / mu)(mu + mu Lambda_i) = G / G1(i)
    s = wp.vec2d(zero, zero)
    q = wp.vec2d(zero, zero)
    for _k in range(effort):
        m = sample_vndf(wi, p.alpha, wp.float64(wp.randf(state)), wp.float64(wp.randf(state)), p.dist)
        w = m_terms(p, m) * scale
        s += w
        q += wp.cw_mul(w, w)
    mean, err = _finish(s, q, wp.float64(1.0), effort)
    store(value, error, i, mean, err)


# ---------------------------------------------------------------- Owen-scrambled Sobol (2-D)

_UB82F1E52 = wp.constant(wp.uint32(0xB82F1E52))
_UC7AFE638 = wp.constant(wp.uint32(0xC7AFE638))
_U8D22F6E6 = wp.constant(wp.uint32(0x8D22F6E6))
_UAC564B05 = wp.constant(wp.uint32(0xAC564B05))
_U80000000 = wp.constant(wp.uint32(0x80000000))
_U9E3779B9 = wp.constant(wp.uint32(0x9E3779B9))
_U85EBCA6B = wp.constant(wp.uint32(0x85EBCA6B))
_UC2B2AE35 = wp.constant(wp.uint32(0xC2B2AE35))


@wp.func
def _reverse_bits(x: wp.uint32):
    x = ((x >> wp.uint32(1)) & wp.uint32(0x55555555)) | ((x & wp.uint32(0x55555555)) << wp.uint32(1))
    x = ((x >> wp.uint32(2)) & wp.uint32(0x33333333)) | ((x & wp.uint32(0x33333333)) << wp.uint32(2))
    x = ((x >> wp.uint32(4)) & wp.uint32(0x0F0F0F0F)) | ((x & wp.uint32(0x0F0F0F0F)) << wp.uint32(4))
    x = ((x >> wp.uint32(8)) & wp.uint32(0x00FF00FF)) | ((x & wp.uint32(0x00FF00FF)) << wp.uint32(8))
    return (x >> wp.uint32(16)) | (x << wp.uint32(16))


@wp.func
def _lk_permutation(x: wp.uint32, seed: wp.uint32):
    # Laine-Karras style hash: each output bit depends only on the same and lower input bits
    x = x + seed
    x = x ^ (x * wp.uint32(0x6C50B47C))
    x = x ^ (x * _UB82F1E52)
    x = x ^ (x * _UC7AFE638)
    x = x ^ (x * _U8D22F6E6)
    return x


@wp.func
def _owen(x: wp.uint32, seed: wp.uint32):
    """Nested uniform (Owen) scramble of the bits of x, from the top bit down."""
    return _reverse_bits(_lk_permutation(_reverse_bits(x), seed))


@wp.func
def _hash(x: wp.uint32):
    # PCG output hash
    state = x * wp.uint32(747796405) + _UAC564B05
    word = ((state >> ((state >> wp.uint32(28)) + wp.uint32(4))) ^ state) * wp.uint32(277803737)
    return (word >> wp.uint32(22)) ^ word


@wp.func
def _texel_key(p: TexelParams):
    """A hash of the texel's parameters (mu, alpha, eta quantized to 2^-30, 2^-28, 2^-24 steps).

    The samples of a texel depend on what the texel is, never on its index in a launch."""
    h = _hash(wp.uint32(wp.clamp(p.mu, wp.float64(0.0), wp.float64(1.0)) * wp.float64(1073741824.0)))
    h = _hash(h ^ wp.uint32(wp.clamp(p.alpha, wp.float64(0.0), wp.float64(15.0)) * wp.float64(268435456.0)))
    h = _hash(h ^ wp.uint32(wp.clamp(p.eta, wp.float64(0.0), wp.float64(255.0)) * wp.float64(16777216.0)))
    return _hash(h ^ wp.uint32(p.mode))


@wp.func
def _texel_seed(seed: wp.int32, p: TexelParams):
    # rand_init takes an int32 seed: the low 31 bits of the mixed key
    return wp.int32(_hash(wp.uint32(seed) ^ _texel_key(p)) & wp.uint32(0x7FFFFFFF))


@wp.func
def _sobol1(index: wp.uint32):
    """Second Sobol dimension (direction numbers v_k = v_{k-1} ^ (v_{k-1} >> 1))."""
    x = wp.uint32(0)
    v = _U80000000
    n = index
    while n != wp.uint32(0):
        if (n & wp.uint32(1)) != wp.uint32(0):
            x = x ^ v
        n = n >> wp.uint32(1)
        v = v ^ (v >> wp.uint32(1))
    return x


@wp.func
def _to_unit(x: wp.uint32):
    return wp.float64(x) * wp.float64(2.3283064365386963e-10)


@wp.kernel
def qmc_vndf_kernel(idx: wp.array(dtype=wp.int32), mu_a: wp.array(dtype=wp.float64),
                    alpha_a: wp.array(dtype=wp.float64), eta_a: wp.array(dtype=wp.float64), mode: wp.int32,
                    dist: wp.int32, shadowing: wp.int32, ftype: wp.int32, fp0: wp.float64, fp1: wp.float64,
                    effort: wp.int32, seed: wp.int32, value: wp.array2d(dtype=wp.float64),
                    error: wp.array2d(dtype=wp.float64)):
    i, p, done = begin_texel(wp.tid(), idx, mu_a, alpha_a, eta_a, mode, dist, shadowing, ftype, fp0, fp1, value, error)
    if done:
        # alpha = 0: the mirror limit is stored
        return
    zero = wp.float64(0.0)
    wi = wp.vec3d(p.sin_i, zero, p.mu)
    scale = p.mu + p.li
    nrep = QMC_REPLICATES
    per = effort  # points per replicate (the host passes N / 8)
    s = wp.vec2d(zero, zero)
    q = wp.vec2d(zero, zero)
    for r in range(nrep):
        key = _hash(_hash(wp.uint32(seed)) ^ _hash(_texel_key(p) * wp.uint32(8) + wp.uint32(r)))
        k_index = _hash(key ^ _U9E3779B9)
        k0 = _hash(key ^ _U85EBCA6B)
        k1 = _hash(key ^ _UC2B2AE35)
        acc = wp.vec2d(zero, zero)
        for k in range(per):
            j = _owen(wp.uint32(k), k_index)  # shuffle: a permutation within power-of-2 blocks
            u1 = _to_unit(_owen(_reverse_bits(j), k0))
            u2 = _to_unit(_owen(_sobol1(j), k1))
            m = sample_vndf(wi, p.alpha, u1, u2, p.dist)
            acc += m_terms(p, m) * scale
        rep = acc / wp.float64(per)
        s += rep
        q += wp.cw_mul(rep, rep)
    nf = wp.float64(nrep)
    mean = s / nf
    err = wp.vec2d(zero, zero)
    for c in range(2):
        var = wp.max(zero, (q[c] - nf * mean[c] * mean[c]) / (nf - wp.float64(1.0)))
        err[c] = wp.float64(_T_QUANTILE) * wp.sqrt(var / nf) + wp.float64(_MISS) / (nf * wp.float64(per))
    store(value, error, i, mean, err)


# ---------------------------------------------------------------- host entry points


def _run(name, kernel, mode, mu, alpha, eta=None, *, dist=0, shadowing=1, ftype=0, fp0=0.0, fp1=0.0, tol=None,
         device=None, workers=None, progress=None, effort=None, seed=0x5EED):
    effort = int(DEFAULT_EFFORT[name] if effort is None else effort)
    if effort < 2:
        raise ValueError(f"{name}: effort (samples per texel) must be >= 2, got {effort}")
    kernel_effort = max(2, effort // 8) if name == "qmc_vndf" else effort
    values, errors, mu, alpha, eta = launch_texels(
        kernel, mode, mu, alpha, eta, dist=dist, shadowing=shadowing, ftype=ftype, fp0=fp0, fp1=fp1,
        effort=kernel_effort, seed=seed, device=device, workers=workers, progress=progress,
    )
    if name == "mc_cosine" and values.size:
        # fewer than COSINE_MIN_LOBE_SAMPLES expected in the lobe: the estimate means nothing
        w = lobe_width(mode, mu, alpha, eta)
        blind = (effort * w * w < COSINE_MIN_LOBE_SAMPLES) & (alpha > 0)
        errors[blind] = 1.0
        # grazing: the integrand (G / mu) varies on the scale |z_o| ~ mu, a layer that holds
        # ~N mu^2 cosine samples
        errors[(effort * mu * mu < COSINE_MIN_LOBE_SAMPLES) & (alpha > 0)] = 1.0
    return finalize(mode, values, errors, alpha)


def _make(name, kernel, doc):
    def integrate_texels(mode, mu, alpha, eta=None, **kwargs):
        return _run(name, kernel, mode, mu, alpha, eta, **kwargs)

    integrate_texels.__name__ = f"integrate_texels_{name}"
    integrate_texels.__doc__ = (
        f"{doc}\n\nSignature of :func:`bsdf_tab.integrate.adaptive.integrate_texels` plus ``effort`` "
        f"(samples per texel, default {DEFAULT_EFFORT[name]}) and ``seed``; ``tol`` is ignored "
        "(fixed effort). Returns (values, errors), each (N, 2)."
    )
    return integrate_texels


integrate_mc_cosine = _make("mc_cosine", mc_cosine_kernel, "Monte Carlo, cosine-weighted outgoing directions.")
integrate_mc_dcos = _make("mc_dcos", mc_dcos_kernel, "Monte Carlo, micro-normals from D(m) cos(theta_m).")
integrate_mc_vndf = _make("mc_vndf", mc_vndf_kernel, "Monte Carlo, visible-normal (VNDF) sampling.")
integrate_qmc_vndf = _make("qmc_vndf", qmc_vndf_kernel, "Owen-scrambled Sobol QMC with VNDF sampling.")

METHODS = {
    "mc_cosine": integrate_mc_cosine,
    "mc_dcos": integrate_mc_dcos,
    "mc_vndf": integrate_mc_vndf,
    "qmc_vndf": integrate_qmc_vndf,
}
