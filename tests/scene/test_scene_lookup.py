"""bsdf_tab.scene.lookup: the axes of a planned table (nodes, texel coordinate, description)
and the renderer's read, against closed forms and SciPy's grid interpolator (scene_cases)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scene_cases import renderer_lookup

from bsdf_tab.scene import AxisPlan, lookup

AXES = [
    AxisPlan("mu", "interp", range=(0.0, 1.0), spacing="square", size=9),
    AxisPlan("alpha", "interp", range=(0.05, 0.3), spacing="linear", size=5),
    AxisPlan("eta", "discrete", values=[0.6666667, 1.5]),
]


def test_nodes_are_the_closed_form_spacings():
    t = np.arange(9) / 8
    np.testing.assert_allclose(AXES[0].nodes(), t ** 2, rtol=0, atol=1e-15)  # (sqrt(0) + (1 - 0) t)^2
    np.testing.assert_allclose(AXES[1].nodes(), 0.05 + 0.25 * np.arange(5) / 4, rtol=0, atol=1e-15)
    assert AXES[0].nodes()[[0, -1]].tolist() == [0.0, 1.0] and AXES[1].nodes()[[0, -1]].tolist() == [0.05, 0.3]
    assert AXES[2].nodes().tolist() == [0.6666667, 1.5]
    assert [len(a) for a in AXES] == [9, 5, 2]


def test_texel_coordinate_and_description():
    mu = AXES[0]
    x = np.array([0.0, 0.25, 1.0, 1.5])
    np.testing.assert_allclose(mu.coord(x), [0.0, 4.0, 8.0, 8.0])  # sqrt(0.25) * 8; clamped above
    desc = mu.describe()
    assert desc["lookup"] == "interpolate" and desc["size"] == 9 and "sqrt(x)" in desc["coordinate"]
    assert AXES[2].describe() == {"name": "eta", "lookup": "index", "values": [0.6666667, 1.5], "size": 2}
    assert AXES[2].coord(np.array([1.5, 0.6666667])).tolist() == [1.0, 0.0]


@pytest.mark.parametrize("interpolation", ["linear", "nearest"])
def test_lookup_matches_a_renderer_read(interpolation):
    rng = np.random.default_rng(11)
    values = rng.uniform(-1.0, 1.0, (9, 5, 2))
    entry = {"axes": [a.describe() for a in AXES]}
    points = {"mu": np.sort(rng.uniform(0, 1, 13)), "alpha": np.sort(rng.uniform(0.05, 0.3, 7)),
              "eta": np.array([0.6666667, 1.5])}
    want = renderer_lookup(entry, values, points, interpolation)
    got = lookup(values, AXES, np.meshgrid(*points.values(), indexing="ij"), interpolation)
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)


def test_lookup_reproduces_nodes_and_linear_functions():
    """At the nodes a lookup is the texel; multilinear in the texel coordinate is exact for a
    function linear in (sqrt(mu), alpha)."""
    grids = np.meshgrid(*[a.nodes() for a in AXES], indexing="ij")
    f = lambda m, a, e: 2.0 * np.sqrt(m) - 3.0 * a + e  # noqa: E731
    values = f(*grids)
    np.testing.assert_allclose(lookup(values, AXES, grids, "linear"), values, rtol=0, atol=1e-14)
    np.testing.assert_allclose(lookup(values, AXES, grids, "nearest"), values, rtol=0, atol=1e-14)
    mu, alpha = np.meshgrid(np.linspace(0, 1, 23), np.linspace(0.05, 0.3, 17), indexing="ij")
    eta = np.full(mu.shape, 1.5)
    np.testing.assert_allclose(lookup(values, AXES, [mu, alpha, eta], "linear"), f(mu, alpha, eta), rtol=0, atol=1e-13)


def test_nearest_ties_go_either_way_with_round_down():
    ax = [AxisPlan("alpha", "interp", range=(0.0, 1.0), spacing="linear", size=3)]
    values = np.array([10.0, 20.0, 30.0])
    mid = [np.array([0.25])]  # t = 0.5: a tie between texels 0 and 1
    assert lookup(values, ax, mid, "nearest").tolist() == [20.0]
    assert lookup(values, ax, mid, "nearest", round_down=(True,)).tolist() == [10.0]
    assert math.isclose(lookup(values, ax, mid, "linear")[0], 15.0)
