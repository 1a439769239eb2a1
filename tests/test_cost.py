"""bsdf_tab.cost: the predicted cost agrees with the measured one; the limit names its parameters."""

from __future__ import annotations

import pytest

from bsdf_tab import cost
from bsdf_tab.errors import SpecError
from bsdf_tab.tables import KINDS


def test_every_kind_has_a_cost_family():
    # a new table kind without a cost entry would be priced as the dearest family: make it explicit
    assert set(KINDS) <= set(cost.KIND_MODE)


def test_effort_and_texels_scale_the_cost():
    base = {"table": "albedo", "axes": {"mu": {"size": 4}, "alpha": {"size": 4}}, "method": "mc_vndf"}
    a = cost.estimate({**base, "effort": 4096})
    b = cost.estimate({**base, "effort": 4096 * 16})
    assert 10 < b.seconds / a.seconds < 17
    c = cost.estimate({**base, "effort": 4096, "axes": {"mu": {"size": 8}, "alpha": {"size": 8}}})
    assert c.seconds == pytest.approx(4 * a.seconds)
    tight = cost.estimate({**base, "method": "adaptive", "tolerance": 1e-11})
    loose = cost.estimate({**base, "method": "adaptive", "tolerance": 1e-3})
    # measured x9.6 (albedo) .. x12.9 (dfg) CPU time from 1e-3 to 1e-11 (bsdf_tab/cost.py)
    assert 7 < tight.seconds / loose.seconds < 14 and tight.bound_seconds >= tight.seconds


def test_the_issue_cases_are_over_a_minute():
    # 8 texels x 2^26 samples (23 s wall on 2 cores measured in issue 12) and tol 1e-12 at 64^3
    small = cost.estimate({"table": "albedo", "axes": {"mu": {"size": 2}, "alpha": {"size": 4}},
                           "method": "mc_vndf", "effort": 67108864})
    assert 25 < small.seconds < 150
    big = cost.estimate({"table": "dielectric", "tolerance": 1e-12,
                         "axes": {"mu": {"size": 64}, "alpha": {"size": 64}, "eta": {"size": 64}}})
    # 262144 texels x ~0.9 ms (13x the 1e-3 texel): 440 core-s after issue 14's fifth round, 234
    # after its seventh; either way far above the service's synchronous limit of 60 (a 413)
    assert big.seconds > 120
    # Monte Carlo cannot converge a mu-average: its cost is the round cap's
    avg = cost.estimate({"table": "albedo_avg", "axes": {"alpha": {"size": 8}}, "method": "mc_vndf", "effort": 4096})
    assert avg.seconds > 1000


def test_check_names_the_parameters():
    spec = {"table": "albedo", "axes": {"mu": {"size": 2}, "alpha": {"size": 4}}, "method": "mc_vndf",
            "effort": 67108864}
    with pytest.raises(cost.CostLimitError) as err:
        cost.check(spec, 30)
    assert isinstance(err.value, SpecError) and err.value.param == "axes,effort"
    assert "predicted cost" in err.value.message and "lower effort" in err.value.message
    assert err.value.cost.seconds > 30 and err.value.limit == 30
    assert cost.check({"table": "albedo"}, 60).seconds < 60
    with pytest.raises(cost.CostLimitError) as err:
        cost.check({"table": "dfg", "tolerance": 1e-12, "axes": {"mu": {"size": 256}, "alpha": {"size": 256}}}, 1)
    assert err.value.param == "axes,tolerance" and "coarser tolerance" in err.value.message
    # wall seconds on several cores (the CLI's --max-seconds)
    c = cost.estimate(spec)
    assert c.wall_seconds(2) == pytest.approx(c.seconds / 2)


def test_predicted_and_measured_agree():
    """Over the calibration sweep (kinds, methods, efforts, tolerances), within AGREEMENT_FACTOR.

    CPU time of one worker thread: the load of other processes changes it little.
    """
    rows = cost.calibrate()
    bad = [(r["spec"], round(r["ratio"], 2)) for r in rows
           if not 1 / cost.AGREEMENT_FACTOR <= r["ratio"] <= cost.AGREEMENT_FACTOR]
    assert not bad, bad
