"""bsdf_tab.scene.search and .texels: the reuse (one texel store per run, cross points first,
lazy refinement of losing candidates, the fixed-size comparison on the texels it reads) does
not change the plan. The reference is the documented search written again here without any
reuse: every candidate verified on its whole check set, each one tabulated directly by
``bsdf_tab.api.tabulate`` and read with SciPy's grid interpolator in the texel coordinate."""

from __future__ import annotations

import itertools
import json
import re
from fractions import Fraction

import numpy as np
import pytest
from scipy.interpolate import RegularGridInterpolator

import bsdf_tab.api
from bsdf_tab.api import tabulate
from bsdf_tab.scene import plan_scene
from bsdf_tab.scene.texels import cover

GOLD = {"materials": [{"name": "gold", "type": "conductor", "eta": 0.18, "k": 3.42, "roughness": {"range": [0.3, 0.6]}}]}


def _check_t(n: int, low_end: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """(the check-line points of an n-node ladder axis in its coordinate t in [0, 1], the mask of
    those inside its cells), as docs/scenes.md defines them: the uniform grid of
    max(2n - 1, 17) points (every cell midpoint; at least 16 intervals over the range) and, on a
    mu, alpha or roughness axis (``low_end``), 1/2, 1/4, ... of its first interval down to
    1/1024 of the range."""
    m = max(2 * n - 1, 17)
    ends = []
    x = Fraction(1, m - 1)
    while low_end and x > Fraction(1, 1024):
        x /= 2
        ends.append(x)
    pts = sorted({Fraction(j, m - 1) for j in range(m)} | set(ends))
    inside = np.array([(p * (n - 1)).denominator != 1 for p in pts])
    return np.array([float(p) for p in pts]), inside


def _axis_values(t: np.ndarray, lo: float, hi: float, spacing: str) -> np.ndarray:
    if spacing == "square":
        return (np.sqrt(lo) + t * (np.sqrt(hi) - np.sqrt(lo))) ** 2
    return lo + t * (hi - lo)


def _reference_check(base: dict, axes: list[tuple[str, float, float]], combo, sizes):
    """(the error over the candidate's check set, per axis the largest error on its check lines
    at the points inside its cells, texels tabulated). The check set: the refined grid (2n - 1
    nodes per axis: every cell midpoint and centre) and, along each axis, its check line
    points (``_check_t``) at the nodes of the other axes. Error: |multilinear(nodes) - value| +
    value's error; the candidate's nodes and every check grid tabulated directly with explicit
    axes and read with SciPy in the texel coordinate."""
    node_axes = {name: {"size": n, "spacing": sp, "nodes": "endpoints", "range": [lo, hi]}
                 for (name, lo, hi), n, sp in zip(axes, sizes, combo)}
    interp = RegularGridInterpolator([np.arange(n, dtype=float) for n in sizes],
                                     tabulate(dict(base, axes=node_axes)).channels["E"])

    def errors(ts):
        vals = {name: _axis_values(t, lo, hi, sp).tolist() for (name, lo, hi), t, sp in zip(axes, ts, combo)}
        fine = tabulate(dict(base, axes=vals))
        mesh = np.meshgrid(*[t * (n - 1) for t, n in zip(ts, sizes)], indexing="ij")
        looked = interp(np.stack([np.clip(m, 0, n - 1).ravel() for m, n in zip(mesh, sizes)], -1))
        return np.abs(looked.reshape(mesh[0].shape) - fine.channels["E"]) + fine.channels["E_err"]

    total = errors([np.linspace(0.0, 1.0, 2 * n - 1) for n in sizes])
    texels, worst, per_axis = total.size, float(total.max()), []
    for a, n in enumerate(sizes):
        t, inside = _check_t(n)
        err = errors([t if b == a else np.linspace(0.0, 1.0, m) for b, m in enumerate(sizes)])
        texels += err.size
        worst = max(worst, float(err.max()))
        per_axis.append(float(np.take(err, np.flatnonzero(inside), axis=a).max()))
    return worst, per_axis, texels


def _reference_search(base: dict, axes: list[tuple[str, float, float]], tol: float, spacings=("linear", "square")):
    """Best-first over (spacing per axis, doubling-ladder sizes): fewest texels first, ties the
    earlier spacing combination; verify on the check set (``_reference_check``); pass at 0.8
    tol; a failing candidate doubles the axis whose check line points inside its cells err
    most."""
    combos = list(itertools.product(spacings, repeat=len(axes)))
    frontier = [(2 ** len(axes), ci, (2,) * len(axes)) for ci in range(len(combos))]
    texels = 0
    while frontier:
        frontier.sort()
        _, ci, sizes = frontier.pop(0)
        err, per_axis, n = _reference_check(base, axes, combos[ci], sizes)
        texels += n
        if err <= 0.8 * tol:
            return combos[ci], sizes, err, texels
        k = int(np.argmax(per_axis))
        grown = tuple(2 * n - 1 if j == k else n for j, n in enumerate(sizes))
        frontier.append((int(np.prod(grown)), ci, grown))
    raise AssertionError("no candidate passed")


def test_check_points_are_the_documented_ones():
    """The planner's check-line points of an axis against the definition (``_check_t``, exact
    fractions): at least 16 intervals, every cell midpoint, on mu / alpha / roughness the low
    end's halvings down to 1/1024 of the range; the points inside the cells are exactly those
    that are not nodes."""
    from bsdf_tab.scene.lookup import AxisPlan
    from bsdf_tab.scene.search import check_points

    cases = [("mu", "linear", (0.0, 1.0)), ("mu", "square", (0.0, 1.0)), ("alpha", "square", (0.05, 0.3)),
             ("phi_v", "linear", (0.0, 0.5 * np.pi)), ("eta", "linear", (1.2, 1.6))]
    for name, spacing, (lo, hi) in cases:
        for n in [2, 3, 5, 9, 17, 33, 65, 129, 257, 513, 1025]:
            values, inside = check_points(AxisPlan(name, "interp", range=(lo, hi), spacing=spacing, size=n))
            t, mask = _check_t(n, low_end=name in ("mu", "alpha", "roughness"))
            assert len(values) == len(t) and np.allclose(values, _axis_values(t, lo, hi, spacing), rtol=0, atol=1e-14)
            assert np.array_equal(inside, np.flatnonzero(mask))
            assert len(t) - 1 >= 16 and t.min() == 0.0 and t.max() == 1.0


@pytest.mark.parametrize("tol", [4e-3, 1.5e-3])
def test_reuse_keeps_the_plan_of_the_search_without_reuse(monkeypatch, tol):
    counted = []
    real = bsdf_tab.api.tabulate
    monkeypatch.setattr(bsdf_tab.api, "tabulate", lambda spec, **kw: counted.append(spec) or real(spec, **kw))
    lines = []
    plan = plan_scene(GOLD, tol, log=lines.append)
    monkeypatch.undo()
    (t,) = plan.tables
    base = dict(t.spec(), tolerance=t.integration_tol)
    base.pop("axes")
    combo, sizes, err, ref_texels = _reference_search(base, [("mu", 0.0, 1.0), ("roughness", 0.3, 0.6)], tol)
    assert (t.axes[0].spacing, t.axes[1].spacing) == combo and t.shape == sizes, (t.shape, sizes, combo)
    # the same texels (each integrated on its own), so the same error up to the integration error
    assert abs(t.max_error - err) <= t.integration_tol, (t.max_error, err)
    # the baked values are those of the planned table tabulated directly
    direct = tabulate(dict(base, axes={a.name: a.spec() for a in t.axes}))
    assert np.abs(t.table.channels["E"] - direct.channels["E"]).max() <= 2 * t.integration_tol
    # and the reuse saved work: fewer texels than verifying every candidate in full (the
    # reference does not even count the fixed-size comparison, which the plan includes). 0.08 /
    # 0.14 of them since the check grid has at least 16 intervals and the low end's points per
    # axis (0.30 at both tolerances before; 0.40 / 0.38 before the certificates and windowed lines)
    computed = sum(int(np.prod([len(v) for v in s["axes"].values()])) for s in counted)
    assert computed == plan.texels_computed and computed < 0.35 * ref_texels, (computed, ref_texels)
    # every candidate failed by a certificate (no texel computed for it) does fail in full
    certified = [re.search(r"mu (\d+) (\w+) x roughness (\d+) (\w+): lookup error >= ([\d.e+-]+)", line).groups()
                 for line in lines if "certified" in line]
    assert len(certified) == plan.candidates_certified > 0 and plan.line_probes > 0
    for n_mu, sp_mu, n_r, sp_r, bound in certified:
        err, _, _ = _reference_check(base, [("mu", 0.0, 1.0), ("roughness", 0.3, 0.6)], (sp_mu, sp_r),
                                     (int(n_mu), int(n_r)))
        assert err > 0.8 * tol and err >= float(bound) * (1 - 1e-3) - t.integration_tol, (n_mu, n_r, bound)


def test_cover_is_exact():
    rng = np.random.default_rng(3)
    for dims in (1, 2, 3):
        shape = (5, 4, 3)[:dims]
        for _ in range(20):
            pts = [idx for idx in np.ndindex(*shape) if rng.random() < 0.5]
            blocks = cover(pts, dims)
            got = [p for b in blocks for p in itertools.product(*b)]
            assert sorted(got) == sorted(pts) and len(got) == len(set(got))
    # a grid minus a nested sub-grid: one block per axis
    fine = [(i, j) for i in range(9) for j in range(5) if not (i % 2 == 0 and j % 2 == 0)]
    assert len(cover(fine, 2)) == 2


def test_before_compute_sees_every_tabulation_and_can_stop_the_plan(monkeypatch):
    seen, counted = [], []
    real = bsdf_tab.api.tabulate
    monkeypatch.setattr(bsdf_tab.api, "tabulate", lambda spec, **kw: counted.append(spec) or real(spec, **kw))
    plan = plan_scene(GOLD, 2e-2, before_compute=seen.append)
    assert seen == counted and len(seen) == plan.tabulate_calls > 0

    class Stop(Exception):
        pass

    budget = {"texels": 60}

    def hook(spec):
        n = int(np.prod([len(v) for v in spec["axes"].values()]))
        if n > budget["texels"]:
            raise Stop(n)
        budget["texels"] -= n

    counted.clear()
    with pytest.raises(Stop):
        plan_scene(GOLD, 1e-3, before_compute=hook)
    # nothing was computed past the limit: the refused tabulation never ran
    assert sum(int(np.prod([len(v) for v in s["axes"].values()])) for s in counted) <= 60


NEAREST = {"lookup": {"interpolation": "nearest"},
           "materials": [{"name": "p", "type": "schlick", "f0": 0.04, "alpha": {"range": [0.1, 0.3]}}]}
GLASS_3D = {"materials": [{"name": "g", "type": "dielectric", "eta": {"range": [1.2, 1.6]}, "alpha": {"range": [0.1, 0.3]}}]}


@pytest.mark.parametrize("scene, tol", [(NEAREST, 5e-2), (GLASS_3D, 2e-2)], ids=["nearest", "3-d"])
def test_certificates_keep_the_plan_for_nearest_lookup_and_3d_tables(monkeypatch, scene, tol):
    """The search with no certificate ever recorded is the search before them (the cone bound
    is then the smallest child's size and no probe has a point to start from): the same plan,
    bit for bit, with more texels. Nearest lookup (ties checked both ways) and three
    interpolated axes are where the reference above does not reach."""
    from bsdf_tab.io import json_default
    from bsdf_tab.scene.bounds import Certificates

    with_certs = plan_scene(scene, tol)
    monkeypatch.setattr(Certificates, "add", lambda *args, **kwargs: None)
    without = plan_scene(scene, tol)
    dump = lambda p: json.dumps(p.to_dict(), default=json_default, sort_keys=True)  # noqa: E731
    assert dump(with_certs) == dump(without)
    for a, b in zip(with_certs.tables, without.tables):
        for ch in a.table.channels:
            assert a.table.channels[ch].tobytes() == b.table.channels[ch].tobytes()
    assert with_certs.candidates_certified > 0 and without.candidates_certified == 0
    assert with_certs.texels_computed < without.texels_computed


def test_probes_compute_nothing_above_the_texel_limit(monkeypatch):
    """A plan that ends in the texel limit computes only candidates within it: the line probes
    (which look ahead along a failed chain) must not tabulate a candidate above ``max_texels``.
    The same plan without probes (MAX_PROBES = 0, the search before them) is the reference:
    the same error, no more texels, no axis longer than a candidate within the limit has."""
    import bsdf_tab.scene.search as search
    from bsdf_tab.errors import TexelLimitError

    def run(probes):
        counted = []
        real = bsdf_tab.api.tabulate
        monkeypatch.setattr(bsdf_tab.api, "tabulate", lambda spec, **kw: counted.append(spec) or real(spec, **kw))
        monkeypatch.setattr(search, "MAX_PROBES", probes)
        with pytest.raises(TexelLimitError):
            plan_scene(GOLD, 3e-4, max_texels=200, workers=1)
        texels = sum(int(np.prod([len(v) for v in s["axes"].values()])) for s in counted)
        longest = max(len(v) for s in counted for v in s["axes"].values())
        return texels, longest

    with_probes, without = run(search.MAX_PROBES), run(0)
    assert with_probes[0] <= without[0]
    # a candidate within 200 texels has at most 100 nodes per axis (2 x 100), refined 2n - 1
    assert with_probes[1] <= 2 * 100 - 1 and with_probes[1] <= without[1]
