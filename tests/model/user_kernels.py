"""A user's own kernel module: imports the package's Warp functions and calls them, in float32
and float64, the way SPEC section 4 promises ("a researcher imports the Warp functions into
their own @wp.kernel"). Nothing here is part of the package."""


import numpy as np
import warp as wp

from bsdf_tab.model import (
    BECKMANN,
    CORRELATED,
    FRESNEL_CONDUCTOR,
    FRESNEL_DIELECTRIC,
    FRESNEL_ONE,
    FRESNEL_SCHLICK,
    GGX,
    SEPARABLE,
    D,
    Lambda,
    brdf,
    btdf,
    fresnel,
    fresnel_conductor,
    fresnel_dielectric,
    fresnel_schlick,
    dcos_sample_tan,
    dcos_tan_of_v,
    dcos_v_of_theta,
    dlnD_dcos,
    lambda_cos,
    pdf_vndf,
    sample_vndf,
    smith_G,
    smith_G1,
)

__all__ = ["GGX", "BECKMANN", "SEPARABLE", "CORRELATED", "FRESNEL_ONE", "FRESNEL_SCHLICK",
           "FRESNEL_DIELECTRIC", "FRESNEL_CONDUCTOR", "run_point", "run_bsdf", "run_sample", "run_dcos"]


def _make_kernels(V, S):
    """Kernels for vector type V and scalar type S (wp.vec3f/float32 or wp.vec3d/float64)."""

    @wp.kernel
    def point_kernel(
        cos_v: wp.array(dtype=S),
        alpha: wp.array(dtype=S),
        v: wp.array(dtype=V),
        m: wp.array(dtype=V),
        cos_o: wp.array(dtype=S),
        eta: wp.array(dtype=S),
        k: wp.array(dtype=S),
        dist: wp.int32,
        shadowing: wp.int32,
        out: wp.array2d(dtype=S),
    ):
        t = wp.tid()
        c = cos_v[t]
        a = alpha[t]
        out[t, 0] = D(c, a, dist)
        out[t, 1] = Lambda(c, a, dist)
        out[t, 2] = lambda_cos(c, a, dist)
        out[t, 3] = smith_G1(v[t], m[t], a, dist)
        out[t, 4] = smith_G(c, cos_o[t], a, dist, shadowing)
        out[t, 5] = fresnel_schlick(c, eta[t])
        out[t, 6] = fresnel_dielectric(c, eta[t])
        out[t, 7] = fresnel_conductor(c, eta[t], k[t])
        out[t, 8] = fresnel(c, FRESNEL_ONE, eta[t], k[t])
        out[t, 9] = fresnel(c, FRESNEL_DIELECTRIC, eta[t], k[t])
        out[t, 10] = fresnel(c, FRESNEL_CONDUCTOR, eta[t], k[t])
        out[t, 11] = fresnel(c, FRESNEL_SCHLICK, eta[t], k[t])
        out[t, 12] = pdf_vndf(v[t], m[t], a, dist)

    @wp.kernel
    def bsdf_kernel(
        wi: wp.array(dtype=V),
        wo: wp.array(dtype=V),
        alpha: wp.array(dtype=S),
        p0: wp.array(dtype=S),
        p1: wp.array(dtype=S),
        dist: wp.int32,
        shadowing: wp.int32,
        ftype: wp.int32,
        out: wp.array2d(dtype=S),
    ):
        t = wp.tid()
        out[t, 0] = brdf(wi[t], wo[t], alpha[t], dist, shadowing, ftype, p0[t], p1[t])
        out[t, 1] = btdf(wi[t], wo[t], alpha[t], dist, shadowing, p0[t])

    @wp.kernel
    def sample_kernel(
        wi: V,
        alpha: S,
        dist: wp.int32,
        seed: wp.int32,
        out: wp.array(dtype=V),
        pdf: wp.array(dtype=S),
    ):
        t = wp.tid()
        rng = wp.rand_init(seed, t)
        u1 = S(wp.randf(rng))
        u2 = S(wp.randf(rng))
        m = sample_vndf(wi, alpha, u1, u2, dist)
        out[t] = m
        pdf[t] = pdf_vndf(wi, m, alpha, dist)

    @wp.kernel
    def dcos_kernel(
        x: wp.array(dtype=S),
        alpha: wp.array(dtype=S),
        dist: wp.int32,
        out: wp.array2d(dtype=S),
    ):
        t = wp.tid()
        a = alpha[t]
        out[t, 0] = dcos_sample_tan(x[t], a, dist)
        out[t, 1] = dcos_tan_of_v(x[t], a, dist)
        out[t, 2] = dcos_v_of_theta(x[t], a, dist)
        out[t, 3] = dlnD_dcos(x[t], a, dist)

    return point_kernel, bsdf_kernel, sample_kernel, dcos_kernel


_KERNELS = {
    np.float32: _make_kernels(wp.vec3f, wp.float32),
    np.float64: _make_kernels(wp.vec3d, wp.float64),
}
_VEC = {np.float32: wp.vec3f, np.float64: wp.vec3d}


def _arr(x, dtype, vec=False):
    x = np.ascontiguousarray(np.asarray(x, dtype=dtype))
    return wp.array(x, dtype=_VEC[dtype] if vec else wp.dtype_from_numpy(np.dtype(dtype)), device="cpu")


def run_point(dtype, cos_v, alpha, v, m, cos_o, eta, k, dist, shadowing):
    """Columns: D, Lambda, lambda_cos, G1(v,m), G(cos_v,cos_o), schlick(f0=eta), dielectric(eta),
    conductor(eta,k), fresnel ONE, DIELECTRIC, CONDUCTOR, SCHLICK, pdf_vndf(v, m)."""
    n = len(cos_v)
    out = wp.zeros((n, 13), dtype=wp.dtype_from_numpy(np.dtype(dtype)), device="cpu")
    wp.launch(
        _KERNELS[dtype][0], dim=n, device="cpu",
        inputs=[_arr(cos_v, dtype), _arr(alpha, dtype), _arr(v, dtype, True), _arr(m, dtype, True),
                _arr(cos_o, dtype), _arr(eta, dtype), _arr(k, dtype), int(dist), int(shadowing), out],
    )
    return out.numpy().astype(np.float64)


def run_bsdf(dtype, wi, wo, alpha, p0, p1, dist, shadowing, ftype):
    """Columns: brdf(wi, wo, ..., ftype, p0, p1), btdf(wi, wo, ..., eta=p0)."""
    n = len(wi)
    out = wp.zeros((n, 2), dtype=wp.dtype_from_numpy(np.dtype(dtype)), device="cpu")
    wp.launch(
        _KERNELS[dtype][1], dim=n, device="cpu",
        inputs=[_arr(wi, dtype, True), _arr(wo, dtype, True), _arr(alpha, dtype), _arr(p0, dtype),
                _arr(p1, dtype), int(dist), int(shadowing), int(ftype), out],
    )
    return out.numpy().astype(np.float64)


def run_sample(dtype, wi, alpha, dist, n, seed=1234):
    """n VNDF samples for one incidence; returns (m (n,3), pdf_vndf(wi, m) (n,))."""
    V = _VEC[dtype]
    S = wp.dtype_from_numpy(np.dtype(dtype))
    out = wp.zeros(n, dtype=V, device="cpu")
    pdf = wp.zeros(n, dtype=S, device="cpu")
    wp.launch(_KERNELS[dtype][2], dim=n, device="cpu",
              inputs=[V(*[float(x) for x in wi]), S(alpha), int(dist), int(seed), out, pdf])
    return out.numpy().astype(np.float64), pdf.numpy().astype(np.float64)


def run_dcos(dtype, x, alpha, dist):
    """Columns at x (one array, read as u, v, theta_m or cos theta_m): dcos_sample_tan(u),
    dcos_tan_of_v(v), dcos_v_of_theta(theta), dlnD_dcos(cos)."""
    n = len(x)
    out = wp.zeros((n, 4), dtype=wp.dtype_from_numpy(np.dtype(dtype)), device="cpu")
    wp.launch(_KERNELS[dtype][3], dim=n, device="cpu", inputs=[_arr(x, dtype), _arr(alpha, dtype), int(dist), out])
    return out.numpy().astype(np.float64)
