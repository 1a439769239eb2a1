"""The ``bsdf`` table: point values against the independent NumPy reference, reciprocity, the
half/difference parametrization against plain angles, integration back to ``albedo``, and the
streamed bake (blocks through ``bsdf_tab.io``) against the reference."""

from __future__ import annotations

import json
import math
import tracemalloc

import numpy as np
import pytest

import bsdf_tab
from bsdf_tab.errors import SpecError
from bsdf_tab import io as bsdf_io
from bsdf_tab import read_exr
from bsdf_tab.spec import normalize_spec, resolve_axes
from bsdf_tab.table import Table
from tests.reference import microfacet_ref as ref

HALF_PI = 0.5 * math.pi
MATERIALS = [
    # (distribution, shadowing, fresnel spec, reference fresnel tuple, alpha)
    ("ggx", "correlated", {"type": "one"}, ("one",), 0.3),
    ("ggx", "separable", {"type": "conductor", "eta": 0.2, "k": 3.0}, ("conductor", 0.2, 3.0), 0.05),
    ("beckmann", "correlated", {"type": "schlick", "f0": 0.04}, ("schlick", 0.04), 0.5),
    ("beckmann", "separable", {"type": "dielectric", "eta": 1.5}, ("dielectric", 1.5), 0.2),
    ("ggx", "correlated", {"type": "dielectric", "eta": 0.7}, ("dielectric", 0.7), 0.4),
    ("ggx", "correlated", {"type": "dielectric", "eta": 1.01}, ("dielectric", 1.01), 1e-3),
]
ANGLES = [0.0, 1e-4, 0.2, 0.55, 0.9, 1.2, 1.45, 1.5706]  # incl. normal and near-grazing
PHIS = [0.0, 0.3, 1.2, 2.0, math.pi - 1e-3, math.pi]


def tab(spec):
    return bsdf_tab.tabulate(spec, device="cpu")


def spec_of(dist, shad, fres, alpha, axes, parametrization="angles"):
    return {"table": "bsdf", "distribution": dist, "shadowing": shad, "fresnel": fres, "alpha": alpha,
            "parametrization": parametrization, "axes": axes}


def plain_dirs(ti, to, phi):
    """w_i, w_o (upper) and w_o (lower, theta_o from -n), written here from the definitions."""
    ti, to, phi = np.meshgrid(ti, to, phi, indexing="ij")
    wi = np.stack([np.sin(ti), 0 * ti, np.cos(ti)], -1)
    wr = np.stack([np.sin(to) * np.cos(phi), np.sin(to) * np.sin(phi), np.cos(to)], -1)
    wt = wr * np.array([1.0, 1.0, -1.0])
    return wi, wr, wt


def check_against(values, errors, reference):
    diff = np.abs(values - reference)
    assert np.all(np.isfinite(values)) and np.all(errors >= 0)
    bad = diff > errors + 1e-300
    assert not bad.any(), (diff[bad][:5], errors[bad][:5], reference[bad][:5])
    return float(np.max(diff / np.maximum(np.abs(reference), 1e-300)))


# --------------------------------------------------------------------------- spec


def test_spec_normalizes_with_merl_defaults():
    n = normalize_spec({"table": "bsdf", "parametrization": "half_diff"})
    assert normalize_spec(n) == n and normalize_spec(json.dumps(n)) == n
    assert list(n["axes"]) == ["theta_h", "theta_d", "phi_d"] and n["alpha"] == 0.5 and n["method"] == "point"
    axes = resolve_axes(n)
    i = np.arange(90)
    assert np.allclose(axes["theta_h"], (i / 90) ** 2 * HALF_PI, rtol=1e-15, atol=0)
    assert np.allclose(axes["theta_d"], i / 90 * HALF_PI, rtol=1e-15, atol=0)
    assert np.allclose(axes["phi_d"], np.arange(180) / 180 * math.pi, rtol=1e-15, atol=0)
    # the parametrization is inferred from the axis names, roughness is alpha = r^2
    assert normalize_spec({"table": "bsdf", "axes": {"theta_d": [0.1]}})["parametrization"] == "half_diff"
    assert normalize_spec({"table": "bsdf", "roughness": 0.5})["roughness"] == 0.5


@pytest.mark.parametrize(
    "spec, param",
    [
        ({"table": "bsdf", "alpha": 0.0}, "alpha"),
        ({"table": "bsdf", "alpha": 0.1, "roughness": 0.1}, "alpha"),
        ({"table": "bsdf", "parametrization": "merl"}, "parametrization"),
        ({"table": "bsdf", "parametrization": "half_diff", "axes": {"theta_i": [0.1]}}, "axes.theta_i"),
        ({"table": "bsdf", "axes": {"theta_o": [2.0]}}, "axes.theta_o"),
        ({"table": "bsdf", "method": "adaptive"}, "method"),
        ({"table": "albedo", "alpha": 0.3}, "alpha"),
        ({"table": "albedo", "parametrization": "angles"}, "parametrization"),
    ],
)
def test_spec_errors_name_the_parameter(spec, param):
    with pytest.raises(SpecError) as info:
        normalize_spec(spec)
    assert info.value.param == param


# --------------------------------------------------------------------------- point values


@pytest.mark.parametrize("mat", MATERIALS, ids=lambda m: f"{m[0]}-{m[1]}-{m[3][0]}-{m[4]}")
def test_values_equal_reference_point_evaluation(mat):
    dist, shad, fres, rfres, alpha = mat
    t = tab(spec_of(dist, shad, fres, alpha, {"theta_i": ANGLES, "theta_o": ANGLES, "phi_d": PHIS}))
    wi, wr, wt = plain_dirs(ANGLES, ANGLES, PHIS)
    fr = ref.f_r(wi, wr, alpha, dist, shad, rfres)
    check_against(t.channels["f_r"], t.channels["f_r_err"], fr)
    assert fr.max() > 0
    if rfres[0] == "dielectric":
        ft = ref.f_t(wi, wt, alpha, dist, shad, rfres[1])
        check_against(t.channels["f_t"], t.channels["f_t_err"], ft)
        assert ft.max() > 0
    else:
        assert not t.channels["f_t"].any()


def test_error_bound_is_rounding_level():
    t = tab(spec_of("ggx", "correlated", {"type": "dielectric", "eta": 1.5}, 0.3,
                    {"theta_i": ANGLES, "theta_o": ANGLES, "phi_d": PHIS}))
    for c in ("f_r", "f_t"):
        f, e = t.channels[c], t.channels[c + "_err"]
        nz = f > 0
        assert np.all(e[~nz] == 0)
        assert np.max(e[nz] / f[nz]) < 1e-9  # |f| eps (64 + conditioning)
        assert np.median(e[nz] / f[nz]) < 1e-12


# --------------------------------------------------------------------------- reciprocity


def test_reciprocity_plain_angles():
    th = [0.05, 0.4, 0.8, 1.1, 1.4]
    axes = {"theta_i": th, "theta_o": th, "phi_d": PHIS}
    for dist, shad, fres, _, alpha in MATERIALS[:4]:
        t = tab(spec_of(dist, shad, fres, alpha, axes))
        f, e = t.channels["f_r"], t.channels["f_r_err"]
        assert np.all(np.abs(f - f.transpose(1, 0, 2)) <= e + e.transpose(1, 0, 2))


def test_reciprocity_transmission_generalized():
    """f_t(i, o; eta) / eta^2 = f_t(o, i; 1/eta) with the frame flipped (Walter 2007)."""
    th = [0.05, 0.4, 0.8, 1.1, 1.4]
    axes = {"theta_i": th, "theta_o": th, "phi_d": PHIS}
    eta = 1.5
    a = tab(spec_of("ggx", "separable", {"type": "dielectric", "eta": eta}, 0.3, axes))
    b = tab(spec_of("ggx", "separable", {"type": "dielectric", "eta": 1 / eta}, 0.3, axes))
    fa, ea = a.channels["f_t"], a.channels["f_t_err"]
    fb, eb = b.channels["f_t"].transpose(1, 0, 2), b.channels["f_t_err"].transpose(1, 0, 2)
    assert fa.max() > 0
    assert np.all(np.abs(fa / eta**2 - fb) <= ea / eta**2 + eb + 1e-15 * fb)


def test_reciprocity_half_diff():
    """Swapping i and o is phi_d -> phi_d + pi; with isotropy f(phi_d) = f(pi - phi_d)."""
    phis = np.linspace(0.0, math.pi, 9).tolist()
    axes = {"theta_h": [0.0, 0.1, 0.5, 1.0, 1.4], "theta_d": [0.0, 0.3, 0.7, 1.2, 1.5], "phi_d": phis}
    t = tab(spec_of("beckmann", "correlated", {"type": "conductor", "eta": 1.2, "k": 2.0}, 0.25, axes, "half_diff"))
    f, e = t.channels["f_r"], t.channels["f_r_err"]
    g = f[:, :, ::-1]
    assert f.max() > 0
    assert np.all(np.abs(f - g) <= e + e[:, :, ::-1] + 1e-15 * f)


# --------------------------------------------------------------------------- half / difference


def rusinkiewicz_to_plain(th, td, pd, eta):
    """(theta_i, theta_o, phi_d) of the reflected and the transmitted w_o, from the definitions."""
    h = np.stack([np.sin(th), 0 * th, np.cos(th)], -1)
    d = np.stack([np.sin(td) * np.cos(pd), np.sin(td) * np.sin(pd), np.cos(td)], -1)
    # rotate d about y by theta_h (the frame of h to the frame of n)
    wi = np.stack([np.cos(th) * d[..., 0] + np.sin(th) * d[..., 2], d[..., 1],
                   -np.sin(th) * d[..., 0] + np.cos(th) * d[..., 2]], -1)
    c = np.sum(wi * h, -1)
    wr = 2 * c[..., None] * h - wi
    k = np.sqrt(1 - (1 - c * c) / eta**2)
    wt = (c / eta - k)[..., None] * h - wi / eta

    def plain(wo, sign):
        phi_i = np.arctan2(wi[..., 1], wi[..., 0])
        phi_o = np.arctan2(wo[..., 1], wo[..., 0])
        dphi = np.mod(phi_o - phi_i, 2 * math.pi)
        dphi = np.where(dphi > math.pi, 2 * math.pi - dphi, dphi)  # isotropy: fold into [0, pi]
        return np.arccos(np.clip(wi[..., 2], -1, 1)), np.arccos(np.clip(sign * wo[..., 2], -1, 1)), dphi

    return plain(wr, 1.0), plain(wt, -1.0)


@pytest.mark.parametrize("channel", ["f_r", "f_t"])
def test_half_diff_matches_plain_angles(channel):
    eta, alpha = 1.5, 0.35
    fres = {"type": "dielectric", "eta": eta}
    axes = {"theta_h": [0.02, 0.3, 0.6, 0.9], "theta_d": [0.1, 0.5, 0.9, 1.2], "phi_d": [0.0, 0.7, 1.6, 2.5, math.pi]}
    hd = tab(spec_of("ggx", "correlated", fres, alpha, axes, "half_diff"))
    th, td, pd = np.meshgrid(*axes.values(), indexing="ij")
    refl, trans = rusinkiewicz_to_plain(th, td, pd, eta)
    ti, to, dphi = refl if channel == "f_r" else trans
    valid = (to < HALF_PI - 1e-9) & (ti < HALF_PI - 1e-9)
    # one plain table on the union of the converted angles, then pick the texels
    ui, uo, up = (np.unique(np.round(x[valid], 15)) for x in (ti, to, dphi))
    plain = tab(spec_of("ggx", "correlated", fres, alpha, {"theta_i": ui.tolist(), "theta_o": uo.tolist(), "phi_d": up.tolist()}))
    ii, io, ip = (np.searchsorted(u, np.round(x[valid], 15)) for u, x in ((ui, ti), (uo, to), (up, dphi)))
    a = hd.channels[channel][valid]
    b = plain.channels[channel][ii, io, ip]
    assert a.max() > 0 and np.count_nonzero(a) > 0.5 * a.size
    # the converted angles carry a few ulps of rounding: allow ~1e-9 relative beyond the error channels
    tol = hd.channels[channel + "_err"][valid] + plain.channels[channel + "_err"][ii, io, ip] + 1e-9 * np.abs(a)
    assert np.all(np.abs(a - b) <= tol)
    # and the texels that leave the hemisphere are zero
    assert not hd.channels[channel][~valid & (to > HALF_PI)].any()


# --------------------------------------------------------------------------- albedo


def directional_albedo(dist, shad, fres, alpha, mus, n):
    """E(mu) = int f_r cos dw_o by the table on a Gauss-Legendre grid: n nodes in u with
    mu_o = u^2 (smooth at grazing) times n nodes in phi_d on [0, pi] (x 2 by symmetry)."""
    x, w = np.polynomial.legendre.leggauss(n)
    u, wu = 0.5 * (x + 1), 0.5 * w
    mu_o, w_mu = u**2, wu * 2 * u  # d mu_o = 2 u du
    phi, wphi = 0.5 * math.pi * (x + 1), 0.5 * math.pi * w
    theta_o = np.arccos(mu_o)[::-1]  # increasing
    w_theta = (w_mu * mu_o)[::-1]  # cos(theta_o) d mu_o
    theta_i = np.arccos(np.asarray(mus))[::-1]
    t = tab(spec_of(dist, shad, fres, alpha, {"theta_i": theta_i.tolist(), "theta_o": theta_o.tolist(), "phi_d": phi.tolist()}))
    E = 2 * np.einsum("ijk,j,k->i", t.channels["f_r"], w_theta, wphi)
    return E[::-1]


@pytest.mark.parametrize(
    "dist, shad, fres, alpha",
    [("ggx", "correlated", {"type": "one"}, 0.5), ("beckmann", "separable", {"type": "conductor", "eta": 0.3, "k": 2.5}, 0.35)],
)
def test_integrating_the_table_reproduces_albedo(dist, shad, fres, alpha):
    """Bound: the quadrature error of the finer (2n) product rule is estimated by its difference
    from the coarser (n) one, |Q_2n - E| <= |Q_2n - Q_n| (Gauss rules converge fast on this
    smooth integrand), plus the albedo table's own error estimate."""
    mus = [0.15, 0.4, 0.7, 1.0]
    albedo = tab({"table": "albedo", "distribution": dist, "shadowing": shad, "fresnel": fres,
                  "axes": {"mu": mus, "alpha": [alpha]}})
    E, E_err = albedo.channels["E"][:, 0], albedo.channels["E_err"][:, 0]
    q_n = directional_albedo(dist, shad, fres, alpha, mus, 24)
    q_2n = directional_albedo(dist, shad, fres, alpha, mus, 48)
    bound = np.abs(q_2n - q_n) + E_err + 1e-12
    err = np.abs(q_2n - E)
    assert np.all(err <= bound), (err, bound)
    assert err.max() < 1e-8  # 48 x 48 nodes per mu for alpha >= 0.35 (measured ~1.2e-10)


# --------------------------------------------------------------------------- streaming


STREAM_SPEC = spec_of("ggx", "correlated", {"type": "dielectric", "eta": 1.5}, 0.3,
                      {"theta_h": {"size": 12}, "theta_d": {"size": 10}, "phi_d": {"size": 16}}, "half_diff")


def stream_reference(spec):
    """f_r, f_t of STREAM_SPEC's grid from the reference, at directions written here (half_diff)."""
    axes = resolve_axes(spec)
    th, td, pd = np.meshgrid(axes["theta_h"], axes["theta_d"], axes["phi_d"], indexing="ij")
    # Rusinkiewicz 1998 with phi_h = 0: h = (sin th, 0, cos th); d = w_i in the frame of h
    h = np.stack([np.sin(th), 0 * th, np.cos(th)], -1)
    d = np.stack([np.sin(td) * np.cos(pd), np.sin(td) * np.sin(pd), np.cos(td)], -1)
    wi = np.stack([np.cos(th) * d[..., 0] + np.sin(th) * d[..., 2], d[..., 1],
                   -np.sin(th) * d[..., 0] + np.cos(th) * d[..., 2]], -1)
    wr = 2.0 * np.sum(wi * h, -1, keepdims=True) * h - wi
    return ref.f_r(wi, wr, spec["alpha"], spec["distribution"], spec["shadowing"], ("dielectric", 1.5))


def test_streaming_exr_is_right_and_bounded_by_blocks(tmp_path):
    calls = []
    stream = bsdf_tab.iter_blocks(STREAM_SPEC, device="cpu", block_texels=300,
                                  progress=lambda done, total: calls.append((done, total)))
    res = bsdf_io.write_stream(stream, tmp_path / "stream.exr")
    got = read_exr(tmp_path / "stream.exr")
    want = stream_reference(STREAM_SPEC)
    # float32 storage on top of the float64 rounding bound
    check_against(got.channels["f_r"].astype(np.float64), got.channels["f_r_err"].astype(np.float64)
                  + 2.0**-23 * np.abs(want), want)
    assert got.meta["spec"] == normalize_spec(STREAM_SPEC)
    for c in ("f_r", "f_t"):  # the header's max error is the largest error the file holds
        assert res.max_error()[c] == pytest.approx(float(got.channels[c + "_err"].max()), rel=1e-6)
    assert calls[-1][0] == calls[-1][1] == 12 * 10 * 16 and len(calls) >= 6  # 160-texel slices, 300/block
    assert sorted(p.name for p in tmp_path.iterdir()) == ["stream.exr"]  # no scratch left


def test_streaming_npz_is_right(tmp_path):
    bsdf_io.write_stream(bsdf_tab.iter_blocks(STREAM_SPEC, device="cpu", block_texels=500), tmp_path / "t.npz")
    got = Table.from_bytes((tmp_path / "t.npz").read_bytes(), "npz")
    want = stream_reference(STREAM_SPEC)
    check_against(got.channels["f_r"], got.channels["f_r_err"], want)  # float64: the rounding bound alone
    assert list(got.axes) == ["theta_h", "theta_d", "phi_d"] and got.channels["f_r"].shape == (12, 10, 16)


def test_streaming_memory_is_bounded(tmp_path):
    spec = spec_of("ggx", "correlated", {"type": "dielectric", "eta": 1.5}, 0.3,
                   {"theta_i": {"size": 48}, "theta_o": {"size": 48}, "phi_d": {"size": 64}})
    full = 4 * 8 * 48 * 48 * 64  # bytes of the in-memory float64 channels (4.7 MB)

    def bake(name):
        bsdf_io.write_stream(bsdf_tab.iter_blocks(spec, device="cpu", block_texels=4096), tmp_path / name)

    bake("warm.exr")  # compile first
    tracemalloc.start()
    try:
        bake("t.exr")
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert peak < full / 4, peak


def test_cli_bake_streams_bsdf(tmp_path):
    from bsdf_tab.cli import main

    spec_path = tmp_path / "b.json"
    spec_path.write_text(json.dumps(STREAM_SPEC))
    assert main(["bake", str(spec_path), "-o", str(tmp_path / "b.exr"), "-q", "--device", "cpu"]) == 0
    a, b = read_exr(tmp_path / "b.exr"), tab(STREAM_SPEC)
    assert all(np.array_equal(a.channels[c], b.channels[c].astype(np.float32)) for c in b.channels)
