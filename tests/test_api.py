"""tabulate(): determinism across workers, progress, metadata, and closed-form limits per table.

Reference values here are closed forms or limit cases (SPEC section 5), not the code itself.
"""

import math

import numpy as np
import pytest

import bsdf_tab
import bsdf_tab.api
from bsdf_tab.integrate import integrate_texels


def _lam_ggx(mu, alpha):
    return (-1.0 + np.sqrt(1.0 + alpha**2 * (1.0 - mu**2) / mu**2)) / 2.0


def test_serial_and_parallel_runs_are_bitwise_identical():
    rng = np.random.default_rng(7)
    mu = rng.uniform(0.0, 1.0, 40)
    alpha = rng.uniform(0.01, 1.0, 40)
    eta = rng.uniform(0.3, 3.0, 40)
    one, _ = integrate_texels("dielectric", mu, alpha, eta, workers=1)
    two, _ = integrate_texels("dielectric", mu, alpha, eta, workers=2)
    # chunking must not matter either: reversed texel order, 2 workers
    rev, _ = integrate_texels("dielectric", mu[::-1], alpha[::-1], eta[::-1], workers=2)
    assert np.array_equal(one, two)
    assert np.array_equal(one, rev[::-1])


def test_progress_reports_every_texel_and_ends_at_total():
    calls = []
    t = bsdf_tab.tabulate(
        {"table": "albedo", "axes": {"mu": {"size": 5}, "alpha": {"size": 4}}},
        progress=lambda done, total: calls.append((done, total)),
    )
    assert t.shape == (5, 4)
    dones = [d for d, _ in calls]
    assert dones == sorted(dones)
    assert calls[-1][0] == calls[-1][1] == 20


def test_metadata_records_spec_conventions_method_and_max_error():
    t = bsdf_tab.tabulate(
        {"table": "albedo", "shadowing": "separable", "axes": {"mu": [0.5, 1.0], "roughness": [0.5]}}
    )
    meta = t.meta
    assert meta["spec"] == bsdf_tab.normalize_spec(meta["spec"])
    assert meta["conventions"]["roughness_axis"] == "roughness"
    assert meta["conventions"]["shadowing"] == "separable"
    assert meta["method"]["name"] == "adaptive"
    assert meta["max_error"]["E"] == pytest.approx(float(t.channels["E_err"].max()))
    assert meta["version"] == bsdf_tab.__version__


def test_roughness_axis_is_alpha_squared():
    a = bsdf_tab.tabulate({"table": "albedo", "axes": {"mu": [0.3], "roughness": [0.5]}})
    b = bsdf_tab.tabulate({"table": "albedo", "axes": {"mu": [0.3], "alpha": [0.25]}})
    assert a.channels["E"][0, 0] == b.channels["E"][0, 0]


def test_albedo_closed_forms():
    # GGX, F = 1: E(mu=1, alpha=1) = 1 - ln 2 (both modes); separable E(mu -> 0, alpha=1) = 2 - 2 ln 2
    for shadowing in ("separable", "correlated"):
        t = bsdf_tab.tabulate(
            {"table": "albedo", "shadowing": shadowing, "axes": {"mu": [0.0, 1.0], "alpha": [1.0]}}
        )
        assert abs(t.channels["E"][1, 0] - (1.0 - math.log(2.0))) < 1e-7
        if shadowing == "separable":
            assert abs(t.channels["E"][0, 0] - (2.0 - 2.0 * math.log(2.0))) < 1e-7


def test_mirror_limit_albedo_equals_fresnel():
    mu = np.array([0.05, 0.3, 0.7, 1.0])
    t = bsdf_tab.tabulate(
        {
            "table": "albedo",
            "fresnel": {"type": "schlick", "f0": 0.04},
            "axes": {"mu": mu.tolist(), "alpha": [0.0, 1e-6, 1e-4]},
        }
    )
    schlick = 0.04 + 0.96 * (1.0 - mu) ** 5
    assert np.allclose(t.channels["E"][:, 0], schlick, rtol=0, atol=1e-15)
    # the closed form's error is its float64 rounding: tiny, never 0 (tests/integrate/test_integrate_mirror.py)
    assert np.all((t.channels["E_err"][:, 0] > 0.0) & (t.channels["E_err"][:, 0] < 1e-13))
    # the deviation from the mirror limit is O(alpha^2 / mu^2) (shadowing loss, Fresnel curvature):
    # bounded here by 4 (alpha / mu)^2, plus the texel's own integration error estimate
    dev = np.abs(t.channels["E"][:, 1:] - schlick[:, None])
    bound = 4 * (np.array([1e-6, 1e-4])[None, :] / mu[:, None]) ** 2 + t.channels["E_err"][:, 1:]
    assert np.all(dev < bound)


def test_dielectric_energy_limits_and_eta_one():
    mu = np.array([0.0, 1e-4, 0.05, 0.5, 1.0])
    alpha = np.array([0.0, 1e-6, 0.3, 1.0])
    t = bsdf_tab.tabulate(
        {"table": "dielectric", "axes": {"mu": mu.tolist(), "alpha": alpha.tolist(),
                                          "eta": [1 / 1.5, 1 - 1e-4, 1.0, 1 + 1e-6, 1.5]}}
    )
    r, tt = t.channels["R"], t.channels["T"]
    assert np.all(np.isfinite(r)) and np.all(np.isfinite(tt))
    # R + T <= 1 up to the texels' own error estimates (at mu = 0 with eta > 1, R + T = 1 exactly)
    slack = t.channels["R_err"] + t.channels["T_err"] + 1e-14
    assert np.all(r >= 0) and np.all(tt >= 0) and np.all(r + tt <= 1.0 + slack)
    # alpha = 0: R + T = 1 exactly; alpha = 1e-6 away from grazing: within 1e-6
    assert np.allclose((r + tt)[:, 0, :], 1.0, atol=1e-15)
    assert np.all(np.abs((r + tt)[2:, 1, :] - 1.0) < 1e-6)
    # eta = 1: R = 0 and T = G(i, -i) / G1(i) = (1 + Lambda) / (1 + 2 Lambda) (correlated)
    k = 2
    assert np.all(r[:, :, k] == 0.0)
    for i, m in enumerate(mu[1:], start=1):
        for j, a in enumerate(alpha[1:], start=1):
            lam = _lam_ggx(m, a)
            assert abs(tt[i, j, k] - (1 + lam) / (1 + 2 * lam)) < 1e-6
    # grazing limit of that closed form: Lambda -> inf, T -> 1/2
    assert abs(tt[0, 2, k] - 0.5) < 1e-6
    # total internal reflection at alpha = 0 below the critical cosine sqrt(1 - 1/1.5^2)
    assert tt[2, 0, 0] == 0.0 and r[2, 0, 0] == 1.0


def test_averages_of_closed_forms():
    # alpha = 0, F = 1: E = 1 for every mu, so E_avg = 1 exactly
    t = bsdf_tab.tabulate({"table": "albedo_avg", "axes": {"alpha": [0.0, 0.5]}})
    assert t.channels["E_avg"][0] == pytest.approx(1.0, abs=1e-12)
    # alpha = 0 dielectric: R_avg = 2 int F(mu) mu dmu, independent quadrature of the Fresnel term
    eta = 1.5
    x, w = np.polynomial.legendre.leggauss(200)
    mu = 0.5 * (x + 1.0)

    def fresnel(c):
        g = np.sqrt(eta**2 - 1 + c * c)
        return 0.5 * ((g - c) / (g + c)) ** 2 * (1 + ((c * (g + c) - 1) / (c * (g - c) + 1)) ** 2)

    r_avg = np.sum(0.5 * w * 2 * fresnel(mu) * mu)
    t2 = bsdf_tab.tabulate({"table": "dielectric_avg", "axes": {"alpha": [0.0], "eta": [eta]}})
    assert abs(t2.channels["R_avg"][0, 0] - r_avg) < 1e-9
    assert abs(t2.channels["T_avg"][0, 0] - (1 - r_avg)) < 1e-9


def test_dfg_sums_to_albedo_and_schlick_identity():
    spec_axes = {"mu": [0.1, 0.6, 1.0], "alpha": [0.2, 0.8]}
    d = bsdf_tab.tabulate({"table": "dfg", "axes": spec_axes})
    e = bsdf_tab.tabulate({"table": "albedo", "axes": spec_axes})
    s = bsdf_tab.tabulate({"table": "albedo", "fresnel": {"type": "schlick", "f0": 0.3}, "axes": spec_axes})
    a, b = d.channels["A"], d.channels["B"]
    assert np.max(np.abs(a + b - e.channels["E"])) < 2e-6
    assert np.max(np.abs(0.3 * a + b - s.channels["E"])) < 2e-6


def test_bad_spec_raises_spec_error_naming_the_parameter():
    with pytest.raises(bsdf_tab.SpecError) as exc:
        bsdf_tab.tabulate({"table": "albedo", "axes": {"alpha": [-0.1]}})
    assert exc.value.param == "axes.alpha"


# --------------------------------------------------------------------------- iter_blocks, arguments


@pytest.mark.parametrize("workers", [0, -1, 1.5, True])
def test_bad_workers_is_a_value_error_naming_workers(workers):
    with pytest.raises(ValueError, match="workers"):
        bsdf_tab.tabulate({"table": "albedo", "axes": {"mu": [1.0], "alpha": [0.5]}}, workers=workers)
    with pytest.raises(ValueError, match="workers"):
        bsdf_tab.api.iter_blocks({"table": "albedo", "axes": {"mu": [1.0], "alpha": [0.5]}}, workers=workers)


def test_iter_blocks_cover_axis0_once_with_the_closed_form():
    # GGX, F = 1, correlated: E(mu = 1, alpha = 1) = 1 - ln 2 (SPEC section 5); bsdf values are
    # checked against the reference in tests/tables; here: blocks, order, shapes and the meta
    spec = {"table": "albedo", "axes": {"mu": [0.5, 1.0], "alpha": [0.25, 1.0]}}
    stream = bsdf_tab.api.iter_blocks(spec, device="cpu")
    assert stream.shape == (2, 2) and stream.channel_names == ["E", "E_err"]
    with pytest.raises(RuntimeError):
        stream.meta()  # not complete before every block was produced
    blocks = list(stream)
    assert [(b[0], b[1]) for b in blocks] == [(0, 2)]  # a kind without blocks: the whole table
    E = blocks[0][2]["E"]
    assert E[1, 1] == pytest.approx(1.0 - math.log(2.0), abs=1e-6)
    assert stream.meta()["max_error"]["E"] == float(blocks[0][2]["E_err"].max())


def test_iter_blocks_of_a_bsdf_table_are_whole_slices_in_order():
    spec = {"table": "bsdf", "alpha": 0.3, "axes": {"theta_i": {"size": 7}, "theta_o": {"size": 3}, "phi_d": {"size": 2}}}
    stream = bsdf_tab.api.iter_blocks(spec, device="cpu", block_texels=12)
    blocks = list(stream)
    assert [(s, e) for s, e, _ in blocks] == [(0, 2), (2, 4), (4, 6), (6, 7)]  # 6 texels a slice, 12 a block
    for s, e, ch in blocks:
        assert set(ch) == {"f_r", "f_t", "f_r_err", "f_t_err"} and ch["f_r"].shape == (e - s, 3, 2)
    top = max(float(ch["f_r_err"].max()) for _, _, ch in blocks)
    assert stream.meta()["max_error"]["f_r"] == top
    with pytest.raises(ValueError, match="block_texels"):
        bsdf_tab.api.iter_blocks(spec, block_texels=0)
