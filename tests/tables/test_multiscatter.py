"""Kulla-Conty compensation: the white furnace (single scattering + compensation lobe = 1 with
F = 1, by quadrature of the Warp lobe over directions with E interpolated from a table), the
``kulla_conty`` table, F_avg and the Fresnel factor F_ms."""

from __future__ import annotations

import math

import numpy as np
import pytest
import warp as wp
from scipy import integrate

import bsdf_tab
from bsdf_tab.model import fresnel_avg, kc_C, kc_F_ms, kc_f_ms, lerp_grid_2d
from tests.reference import microfacet_ref as ref

ALPHAS = [0.05, 0.15, 0.3, 0.5, 0.75, 1.0]
NU = 17  # mu = u^2, u = i / 16: smooth in u even with correlated shadowing's mu ln mu
COMBOS = [("ggx", "correlated"), ("beckmann", "separable")]
N_PHI = 8
TWO_PI = 2.0 * math.pi
_gx, _gw = np.polynomial.legendre.leggauss(3)
GL3_X = wp.constant(wp.vec3d(*(0.5 * (_gx + 1)).tolist()))
GL3_W = wp.constant(wp.vec3d(*(0.5 * _gw).tolist()))


def tab(spec):
    return bsdf_tab.tabulate(spec, device="cpu")


@wp.kernel
def furnace_kernel(
    E: wp.array2d(dtype=wp.float64),
    E_avg: wp.array(dtype=wp.float64),
    n_phi: int,
    out: wp.array2d(dtype=wp.float64),
):
    """E(mu_i) + int f_ms(mu_i, mu_o) cos(theta_o) dw_o over the upper hemisphere.

    Directions w_o = (sin t cos p, sin t sin p, cos t) with cos t = u^2, u the table's own
    coordinate: 3-point Gauss-Legendre on every table cell in u (exact for the piecewise linear
    interpolant times the Jacobian 2u), n_phi points uniform in p. E(mu_o) is interpolated
    from the table (bilinear on its index grid: t0 = u (n - 1), t1 = alpha index)."""
    i, j = wp.tid()
    n = E.shape[0]
    cells = n - 1
    e_i = E[i, j]
    e_avg = E_avg[j]
    acc = wp.float64(0.0)
    dphi = wp.float64(TWO_PI) / wp.float64(n_phi)
    for c in range(cells):
        for q in range(3):
            u = (wp.float64(c) + GL3_X[q]) / wp.float64(cells)
            w_u = GL3_W[q] / wp.float64(cells)
            mu_o = u * u
            s = wp.sqrt(wp.max(wp.float64(0.0), wp.float64(1.0) - mu_o * mu_o))
            e_o = lerp_grid_2d(E, u * wp.float64(cells), wp.float64(j))
            for p in range(n_phi):
                phi = (wp.float64(p) + wp.float64(0.5)) * dphi
                wo = wp.vec3d(s * wp.cos(phi), s * wp.sin(phi), mu_o)
                # dw_o = d(cos t) dp = 2 u du dp
                acc += kc_f_ms(e_i, e_o, e_avg) * wo[2] * wp.float64(2.0) * u * w_u * dphi
    out[i, j] = e_i + acc


@pytest.fixture(scope="module", params=COMBOS, ids=lambda c: f"{c[0]}-{c[1]}")
def tables(request):
    dist, shad = request.param
    common = {"distribution": dist, "shadowing": shad, "fresnel": {"type": "one"}}
    albedo = tab({"table": "albedo", **common, "axes": {"mu": {"size": NU, "spacing": "square"}, "alpha": ALPHAS}})
    u_mid = (np.arange(NU - 1) + 0.5) / (NU - 1)
    mid = tab({"table": "albedo", **common, "axes": {"mu": (u_mid**2).tolist(), "alpha": ALPHAS}})
    avg = tab({"table": "albedo_avg", **common, "axes": {"alpha": ALPHAS}})
    return albedo, mid, avg


def test_white_furnace(tables):
    """E(mu) + int f_ms cos dw_o = 1 at every (mu, alpha) of the grid, within the table accuracy.

    Bound per texel: E_err(mu_i) + (1 - E(mu_i)) (I + E_avg_err) / (1 - E_avg), where I bounds
    |2 int (E - E_lin) mu dmu| <= max |E - E_lin| by twice the interpolation error measured at
    the cell midpoints in u (an independent albedo table there). The quadrature itself is exact
    for the interpolant (3-point Gauss-Legendre per cell)."""
    albedo, mid, avg = tables
    E, E_err = albedo.channels["E"], albedo.channels["E_err"]
    E_avg, E_avg_err = avg.channels["E_avg"], avg.channels["E_avg_err"]
    out = wp.zeros(E.shape, dtype=wp.float64, device="cpu")
    wp.launch(furnace_kernel, dim=E.shape, inputs=[wp.array(E, dtype=wp.float64, device="cpu"),
              wp.array(E_avg, dtype=wp.float64, device="cpu"), N_PHI, out], device="cpu")
    total = out.numpy()
    interp = np.max(np.abs(mid.channels["E"] - 0.5 * (E[:-1] + E[1:])) + mid.channels["E_err"], axis=0)
    bound = E_err + (1 - E) * (2 * interp + E_avg_err)[None, :] / (1 - E_avg)[None, :] + 1e-12
    residual = np.abs(total - 1.0)
    assert np.all(residual <= bound), (residual.max(), bound.min())
    assert residual.max() < 5e-3  # measured: 8.4e-4 (GGX correlated), 2.4e-3 (Beckmann separable) with 17 nodes in u; 5e-5, 1.6e-4 with 65
    # single scattering alone is far from 1 for rough surfaces: the compensation does the work
    assert (1 - E).max() > 0.3


def test_white_furnace_is_exact_with_the_interpolant_average(tables):
    """With E_avg taken as the average of the interpolated E itself, the furnace closes to
    rounding: the residual above is only the table's interpolation error."""
    albedo, _, _ = tables
    E = albedo.channels["E"]
    u = np.linspace(0, 1, NU)
    # 2 int E_lin mu dmu = 4 int E_lin(u) u^3 du, exact by Gauss-Legendre per cell
    x, w = np.polynomial.legendre.leggauss(4)
    uu = (u[:-1, None] + (0.5 * (x + 1))[None, :] / (NU - 1)).ravel()
    ww = np.tile(0.5 * w / (NU - 1), NU - 1)
    e_lin = np.stack([np.interp(uu, u, E[:, j]) for j in range(E.shape[1])], -1)
    e_avg_lin = 4 * np.einsum("k,kj->j", ww * uu**3, e_lin)
    out = wp.zeros(E.shape, dtype=wp.float64, device="cpu")
    wp.launch(furnace_kernel, dim=E.shape, inputs=[wp.array(E, dtype=wp.float64, device="cpu"),
              wp.array(e_avg_lin, dtype=wp.float64, device="cpu"), N_PHI, out], device="cpu")
    assert np.max(np.abs(out.numpy() - 1.0)) < 1e-12


# --------------------------------------------------------------------------- the table


@wp.kernel
def lobe_kernel(E: wp.array2d(dtype=wp.float64), E_avg: wp.array2d(dtype=wp.float64), j: int,
                f_ms: wp.array2d(dtype=wp.float64), cc: wp.array2d(dtype=wp.float64)):
    a, b = wp.tid()
    f_ms[a, b] = kc_f_ms(E[a, j], E[b, j], E_avg[a, j])
    cc[a, b] = kc_C(E[a, j], E_avg[a, j]) * kc_C(E[b, j], E_avg[b, j])


def test_kulla_conty_table():
    alphas = [0.0, 0.02, 0.3, 1.0]
    mu = {"size": 6, "spacing": "square"}
    kc = tab({"table": "kulla_conty", "axes": {"mu": mu, "alpha": alphas}})
    alb = tab({"table": "albedo", "axes": {"mu": mu, "alpha": alphas}})
    avg = tab({"table": "albedo_avg", "axes": {"alpha": alphas}})
    ch = kc.channels
    assert set(ch) == {"E", "E_avg", "C", "E_err", "E_avg_err", "C_err"}
    assert all(np.isfinite(v).all() for v in ch.values())
    np.testing.assert_array_equal(ch["E"], alb.channels["E"])
    np.testing.assert_array_equal(ch["E_avg"], np.broadcast_to(avg.channels["E_avg"], ch["E"].shape))
    miss = 1 - ch["E_avg"][0]
    ok = miss > 2 * ch["E_avg_err"][0]
    assert not ok[0] and ok[1:].all()  # alpha = 0: nothing to compensate
    want = np.maximum(1 - ch["E"][:, ok], 0) / np.sqrt(np.pi * miss[ok])  # E may exceed 1 by its error
    np.testing.assert_allclose(ch["C"][:, ok], want, rtol=1e-14)
    assert not ch["C"][:, ~ok].any()
    assert np.all(ch["C_err"] >= 0) and ch["C_err"][:, ok].max() < 1e-4
    # f_ms(mu_i, mu_o) = C(mu_i) C(mu_o), through the Warp functions
    n = ch["E"].shape[0]
    for j in range(1, len(alphas)):
        f = wp.zeros((n, n), dtype=wp.float64, device="cpu")
        cc = wp.zeros((n, n), dtype=wp.float64, device="cpu")
        wp.launch(lobe_kernel, dim=(n, n), inputs=[wp.array(ch["E"], dtype=wp.float64, device="cpu"),
                  wp.array(ch["E_avg"], dtype=wp.float64, device="cpu"), j, f, cc], device="cpu")
        np.testing.assert_allclose(f.numpy(), cc.numpy(), rtol=1e-13, atol=1e-300)
        np.testing.assert_allclose(f.numpy(), f.numpy().T, rtol=1e-15)  # reciprocal


# --------------------------------------------------------------------------- Fresnel average


@wp.kernel
def favg_kernel(ftype: wp.array(dtype=wp.int32), p0: wp.array(dtype=wp.float64),
                p1: wp.array(dtype=wp.float64), out: wp.array(dtype=wp.float64)):
    k = wp.tid()
    out[k] = fresnel_avg(ftype[k], p0[k], p1[k])


@wp.kernel
def favg_kernel32(ftype: wp.array(dtype=wp.int32), p0: wp.array(dtype=wp.float32),
                  p1: wp.array(dtype=wp.float32), out: wp.array(dtype=wp.float32)):
    k = wp.tid()
    out[k] = fresnel_avg(ftype[k], p0[k], p1[k])


FRESNELS = [("one",), ("schlick", 0.04), ("schlick", 0.9), ("dielectric", 1.5), ("dielectric", 1.0 / 1.5),
            ("dielectric", 0.95), ("conductor", 0.2, 3.0), ("conductor", 1.1, 6.8), ("conductor", 2.9, 0.1)]
FTYPE = {"one": 0, "schlick": 1, "dielectric": 2, "conductor": 3}


def f_avg_reference(spec):
    pts = [math.sqrt(1 - spec[1] ** 2)] if spec[0] == "dielectric" and spec[1] < 1 else None
    val, _ = integrate.quad(lambda m: 2 * float(ref.fresnel(m, spec)) * m, 0, 1, points=pts, epsabs=1e-14, epsrel=1e-13)
    return val


def test_fresnel_avg_float64_and_float32():
    ft = np.array([FTYPE[s[0]] for s in FRESNELS], dtype=np.int32)
    p0 = np.array([s[1] if len(s) > 1 else 0.0 for s in FRESNELS])
    p1 = np.array([s[2] if len(s) > 2 else 0.0 for s in FRESNELS])
    want = np.array([f_avg_reference(s) for s in FRESNELS])
    out = wp.zeros(len(ft), dtype=wp.float64, device="cpu")
    wp.launch(favg_kernel, dim=len(ft), inputs=[wp.array(ft, device="cpu"), wp.array(p0, dtype=wp.float64, device="cpu"),
              wp.array(p1, dtype=wp.float64, device="cpu"), out], device="cpu")
    np.testing.assert_allclose(out.numpy(), want, rtol=1e-7, atol=0)
    out32 = wp.zeros(len(ft), dtype=wp.float32, device="cpu")
    wp.launch(favg_kernel32, dim=len(ft), inputs=[wp.array(ft, device="cpu"), wp.array(p0, dtype=wp.float32, device="cpu"),
              wp.array(p1, dtype=wp.float32, device="cpu"), out32], device="cpu")
    np.testing.assert_allclose(out32.numpy(), want, rtol=2e-6, atol=0)


@wp.kernel
def fms_kernel(f_avg: wp.array(dtype=wp.float64), e_avg: wp.array(dtype=wp.float64), out: wp.array(dtype=wp.float64)):
    k = wp.tid()
    out[k] = kc_F_ms(f_avg[k], e_avg[k])


def test_F_ms_is_the_geometric_series_of_bounces():
    """F_ms (1 - E_avg) = sum_{k>=1} F_avg E_avg (F_avg (1 - E_avg))^k; F_avg = 1 gives 1."""
    rng = np.random.default_rng(5)
    f_avg = np.concatenate([rng.uniform(0.02, 1.0, 20), [1.0, 1.0]])
    e_avg = np.concatenate([rng.uniform(0.3, 0.999, 20), [0.5, 0.9]])
    out = wp.zeros(len(f_avg), dtype=wp.float64, device="cpu")
    wp.launch(fms_kernel, dim=len(f_avg), inputs=[wp.array(f_avg, dtype=wp.float64, device="cpu"),
              wp.array(e_avg, dtype=wp.float64, device="cpu"), out], device="cpu")
    got = out.numpy()
    k = np.arange(1, 400)[:, None]
    series = np.sum(f_avg * e_avg * (f_avg * (1 - e_avg)) ** k, axis=0)
    np.testing.assert_allclose(got * (1 - e_avg), series, rtol=1e-12)
    np.testing.assert_allclose(got[-2:], 1.0, rtol=1e-15)
