"""The LTC polygon integral (Warp functions and the NumPy host version) against an independent
reference: SciPy quadrature of the LTC lobe over the planar polygon, written here.

Reference: the polygon is split into triangles from vertex 0; on a triangle x(u, v) = a + u (b - a)
+ v (c - a) (v <= 1 - u) the solid angle element is dw = |n . x| / |x|^3 dA, and the integrand is
the LTC lobe D(L) = max(0, (Minv L)_z) |det Minv| / (pi |Minv L|^4) at L = x / |x| (zero below the
horizon of the lobe's cosine: nothing is clipped by hand). The Warp and NumPy versions clip the
transformed polygon to z >= 0 and sum Lambert's edge terms instead.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import warp as wp
from scipy import integrate

from bsdf_tab.ltc import polygon_integral
from bsdf_tab.model.ltc import ltc_eval, ltc_minv, ltc_polygon_integral, ltc_quad_integral


def lobe(minv, L):
    l = L @ minv.T
    n2 = np.sum(l * l, axis=-1)
    return np.maximum(l[..., 2], 0.0) * abs(np.linalg.det(minv)) / (math.pi * n2 * n2)


def _clip(verts, r):
    """The part of the planar polygon with r . x >= 0 (where the lobe is nonzero: a smooth integrand)."""
    out = []
    n = len(verts)
    for i in range(n):
        a, b = verts[i], verts[(i + 1) % n]
        da, db = r @ a, r @ b
        if da >= 0:
            out.append(a)
        if (da >= 0) != (db >= 0):
            out.append(a + (b - a) * (da / (da - db)))
    return out


def reference(minv, verts):
    # orientation of the original polygon: positive when (v1 - v0) x (v2 - v0) points away
    sign = math.copysign(1.0, np.cross(verts[1] - verts[0], verts[2] - verts[0]) @ verts[0])
    part = _clip(list(verts), minv[2])
    total = 0.0
    for k in range(1, len(part) - 1):
        a, b, c = part[0], part[k], part[k + 1]
        e1, e2 = b - a, c - a
        nrm = np.cross(e1, e2)
        area2 = np.linalg.norm(nrm)
        if area2 < 1e-14:
            continue
        n = nrm / area2

        def f(v, u):
            x = a + u * e1 + v * e2
            r = np.linalg.norm(x)
            return lobe(minv, x / r) * abs(n @ x) / r**3 * area2

        val, _ = integrate.dblquad(f, 0.0, 1.0, 0.0, lambda u: 1.0 - u, epsabs=1e-12, epsrel=1e-10)
        total += val
    return sign * total


RNG = np.random.default_rng(16)
MINVS = [np.eye(3), np.array([[0.8, 0.0, -0.3], [0.0, 1.0, 0.0], [0.2, 0.0, 0.9]]),
         np.array([[2.5, 0.0, 1.2], [0.0, 1.0, 0.0], [-0.4, 0.0, 0.6]])]
POLYS = {
    "quad_above": np.array([[-0.5, -0.4, 1.0], [0.6, -0.3, 1.1], [0.5, 0.7, 0.9], [-0.6, 0.5, 1.0]]),
    "wall_crossing": np.array([[1.0, -1.0, -0.5], [1.0, 1.0, -0.5], [1.0, 1.0, 1.0], [1.0, -1.0, 1.0]]),
    "starts_below": np.array([[0.3, 1.0, -0.8], [-0.7, 0.8, 0.6], [0.2, 1.2, 1.0], [0.9, 1.1, 0.1]]),
    "triangle": np.array([[0.2, 0.1, 1.0], [0.9, 0.3, 0.4], [0.1, 0.9, 0.6]]),
    "pentagon": np.array([[0.0, -1.0, 0.5], [1.0, -0.3, 0.2], [0.7, 0.8, -0.2], [-0.6, 0.9, 0.3], [-1.0, -0.2, 0.8]]),
}


def _ccw(verts):
    """Wind so that (v1 - v0) x (v2 - v0) points away from the shading point (positive sign)."""
    c = np.cross(verts[1] - verts[0], verts[2] - verts[0])
    return verts if c @ verts[0] > 0 else verts[::-1].copy()


@wp.kernel
def _poly64(minv: wp.array(dtype=wp.mat33d), verts: wp.array(dtype=wp.vec3d), out: wp.array(dtype=wp.float64)):
    i = wp.tid()
    out[i] = ltc_polygon_integral(minv[i], verts)


@wp.kernel
def _poly32(minv: wp.array(dtype=wp.mat33f), verts: wp.array(dtype=wp.vec3f), out: wp.array(dtype=wp.float32)):
    i = wp.tid()
    out[i] = ltc_polygon_integral(minv[i], verts)


@wp.kernel
def _quad64(minv: wp.array(dtype=wp.mat33d), verts: wp.array(dtype=wp.vec3d), out: wp.array(dtype=wp.float64)):
    i = wp.tid()
    out[i] = ltc_quad_integral(minv[i], verts[0], verts[1], verts[2], verts[3])


@wp.kernel
def _eval64(e: wp.array(dtype=wp.vec4d), L: wp.array(dtype=wp.vec3d), out: wp.array(dtype=wp.float64)):
    i = wp.tid()
    out[i] = ltc_eval(ltc_minv(e[i][0], e[i][1], e[i][2], e[i][3]), L[i])


def _run(kernel, minvs, verts, dtype, vec, mat):
    out = wp.zeros(len(minvs), dtype=dtype, device="cpu")
    wp.launch(kernel, dim=len(minvs), device="cpu",
              inputs=[wp.array(np.asarray(minvs), dtype=mat, device="cpu"), wp.array(verts, dtype=vec, device="cpu"), out])
    return out.numpy().astype(np.float64)


@pytest.mark.parametrize("name", sorted(POLYS))
def test_polygon_integral_against_scipy(name):
    verts = _ccw(POLYS[name])
    ref = np.array([reference(m, verts) for m in MINVS])
    assert (ref > 0).all()
    host = polygon_integral(np.broadcast_to(verts, (len(MINVS),) + verts.shape), np.asarray(MINVS))
    np.testing.assert_allclose(host, ref, rtol=1e-8, atol=1e-10)
    d64 = _run(_poly64, MINVS, verts, wp.float64, wp.vec3d, wp.mat33d)
    np.testing.assert_allclose(d64, ref, rtol=1e-8, atol=1e-10)
    d32 = _run(_poly32, MINVS, verts, wp.float32, wp.vec3f, wp.mat33f)
    assert np.isfinite(d32).all()
    np.testing.assert_allclose(d32, ref, rtol=2e-4, atol=1e-6)
    if len(verts) == 4:
        np.testing.assert_allclose(_run(_quad64, MINVS, verts, wp.float64, wp.vec3d, wp.mat33d), ref, rtol=1e-8, atol=1e-10)
    # reversed winding flips the sign; a polygon entirely below the horizon gives 0
    np.testing.assert_allclose(polygon_integral(verts[::-1], MINVS[0]), -ref[0], rtol=1e-8, atol=1e-10)
    below = verts * np.array([1.0, 1.0, -1.0]) - np.array([0.0, 0.0, 2.0])
    assert polygon_integral(below, np.eye(3)) == 0.0


def test_whole_hemisphere_is_one_for_any_ltc():
    """A huge quad over the shading point sees the whole upper hemisphere of the LTC's cosine
    only for the identity; for any Minv, the lobe's integral over the plane z = 1 is the lobe
    mass above the horizon, 1 for Minv = I."""
    R = 1e5
    quad = np.array([[R, -R, 1.0], [R, R, 1.0], [-R, R, 1.0], [-R, -R, 1.0]])
    assert polygon_integral(quad) == pytest.approx(1.0, abs=1e-4)
    d64 = _run(_poly64, [np.eye(3)], quad, wp.float64, wp.vec3d, wp.mat33d)
    assert d64[0] == pytest.approx(1.0, abs=1e-4)


def test_ltc_eval_matches_formula_and_storage_order():
    e = np.array([[1.0, 0.0, 0.0, 1.0], [0.8, 0.2, -0.3, 0.9], [2.5, -0.4, 1.2, 0.6]])
    L = RNG.normal(size=(3, 3))
    L[:, 2] = np.abs(L[:, 2])
    L /= np.linalg.norm(L, axis=1, keepdims=True)
    out = wp.zeros(3, dtype=wp.float64, device="cpu")
    wp.launch(_eval64, dim=3, device="cpu", inputs=[wp.array(e, dtype=wp.vec4d, device="cpu"),
                                                     wp.array(L, dtype=wp.vec3d, device="cpu"), out])
    # stored (x, y, z, w) = (Minv_00, Minv_20, Minv_02, Minv_22)
    minvs = [np.array([[x, 0, z], [0, 1, 0], [y, 0, w]]) for x, y, z, w in e]
    np.testing.assert_allclose(out.numpy(), [lobe(m, l) for m, l in zip(minvs, L)], rtol=1e-13)
