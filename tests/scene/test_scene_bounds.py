"""bsdf_tab.scene.bounds: failure certificates and the cone bound, against definitions written
again here with exact fractions and brute-force enumeration, and the principle they rest on
(a cross point is looked up from the same two texels by every candidate a certificate covers)
checked with the renderer's lookup on a closed-form function."""

from __future__ import annotations

import itertools
from fractions import Fraction

import numpy as np

from bsdf_tab.scene.bounds import LADDER, Certificates, rung
from bsdf_tab.scene.lookup import AxisPlan, lookup

SMALL = [n for n in LADDER if n <= 65]  # rung() checked on these


def _is_node(x: Fraction, n: int) -> bool:
    """x (a fraction of the axis, in t) is a node of the n-node endpoint ladder axis."""
    return (x * (n - 1)).denominator == 1


def test_rung_is_the_first_ladder_size_holding_the_node():
    for n in SMALL:
        for k in range(n):
            x = Fraction(k, n - 1)
            first = min(m for m in LADDER if _is_node(x, m))
            assert rung(k, n) == first, (k, n)


def _covered(failing, sizes, dims) -> bool:
    """A failing point (axis, n on it, per other axis the point's t as a fraction) is among the
    cross points the candidate ``sizes`` checks along that axis."""
    return any(sizes[axis] == n and all(_is_node(t[j], sizes[j]) for j in range(dims) if j != axis)
               for axis, n, t in failing)


def test_certificates_from_cross_errors_match_brute_force():
    rng = np.random.default_rng(5)
    target = 1.0
    for dims in (2, 3):
        for _ in range(12):
            sizes = tuple(int(rng.choice([3, 5, 9])) for _ in range(dims))
            certs = Certificates(dims, LADDER[-1])
            failing = []
            for axis in range(dims):
                shape = tuple(n - 1 if j == axis else n for j, n in enumerate(sizes))
                err = np.where(rng.random(shape) < 0.08, 2.0, 0.5)
                certs.add_cross(axis, sizes, err, target)
                for idx in zip(*np.nonzero(err > target)):
                    t = [Fraction(int(idx[j]), sizes[j] - 1) if j != axis else None for j in range(dims)]
                    failing.append((axis, sizes[axis], t))
            got = {tuple(int(x) for x in p) for p, c in zip(certs.points, certs.covered) if c}
            expected = {s for s in itertools.product(LADDER, repeat=dims) if _covered(failing, s, dims)}
            assert got == expected, (sizes, got ^ expected)
            # the cone bound: the smallest uncovered candidate dominating `sizes` (not itself)
            cone = [s for s in itertools.product(LADDER, repeat=dims)
                    if all(a >= b for a, b in zip(s, sizes)) and s != sizes and s not in expected]
            assert certs.cone_bound(sizes) == min(int(np.prod(s)) for s in cone)
            for s in expected:
                assert certs.fails(s) is not None
            assert certs.fails(tuple(LADDER[-1] for _ in range(dims))) is None


def test_a_cross_point_reads_the_same_texels_in_every_covered_candidate():
    """The principle: a point inside a cell along axis 0 and at a node of rung r along axis 1
    has the same lookup in (n0, m) for every ladder m >= r, whatever the table's values."""
    f = lambda x, y: np.sin(7.0 * x) * np.exp(-3.0 * y) + x * y ** 3  # noqa: E731
    for spacing in ("linear", "square"):
        for n0, n1 in [(5, 3), (9, 5), (3, 9)]:
            ax0 = AxisPlan("mu", "interp", range=(0.0, 1.0), spacing=spacing, size=n0)
            # any point inside a cell along axis 0 (not only its midpoints: the check grid has
            # several points per cell of a coarse axis, and more near the low end)
            fine0 = AxisPlan("mu", "interp", range=(0.0, 1.0), spacing=spacing, size=64 * (n0 - 1) + 1).nodes()
            mids0 = np.delete(fine0, np.arange(0, len(fine0), 64))
            ax1 = AxisPlan("alpha", "interp", range=(0.05, 0.3), spacing=spacing, size=n1)
            for k in range(n1):
                y = ax1.nodes()[k]
                ref = None
                for m in [s for s in LADDER if rung(k, n1) <= s <= 129]:
                    a1 = AxisPlan("alpha", "interp", range=(0.05, 0.3), spacing=spacing, size=m)
                    vals = f(*np.meshgrid(ax0.nodes(), a1.nodes(), indexing="ij"))
                    got = lookup(vals, [ax0, a1], [mids0, np.full_like(mids0, y)], "linear")
                    ref = got if ref is None else ref
                    assert np.abs(got - ref).max() <= 1e-13, (spacing, n0, n1, k, m)
                # and a size that does not hold the node reads other texels (the rung matters)
                below = [s for s in LADDER if s < rung(k, n1)]
                if below:
                    a1 = AxisPlan("alpha", "interp", range=(0.05, 0.3), spacing=spacing, size=below[-1])
                    vals = f(*np.meshgrid(ax0.nodes(), a1.nodes(), indexing="ij"))
                    got = lookup(vals, [ax0, a1], [mids0, np.full_like(mids0, y)], "linear")
                    assert np.abs(got - ref).max() > 1e-6


def test_no_interpolated_axis_has_one_uncertifiable_candidate():
    """A table with only discrete axes (``search`` still builds certificates for it): one empty
    candidate, never certified, no cone beyond it (no crash on the empty product)."""
    certs = Certificates(0, 65)
    assert certs.points.shape == (1, 0)
    assert certs.fails(()) is None
    assert certs.cone_min(()) == (float("inf"), None)
