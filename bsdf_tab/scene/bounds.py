"""Failure certificates: candidates known to fail from points already checked, and the lower
bound they give on the size of a spacing combination's winner.

A point checked for a candidate with ``n_i`` nodes on interpolated axis ``i`` that lies inside
a cell along axis ``i`` (a point of its check lines that is not a node: a midpoint, or any
other, which depend on ``n_i`` alone, :func:`.search.check_points`) and is a node along every
other interpolated axis ``j`` is looked up by interpolating along axis ``i`` only,
between two texels at nodes of the candidate. On the nested doubling ladder (2, 3, 5, 9, ...
nodes; the nodes of n are nodes of 2n - 1) a node index k of an n-node axis is a node of every
ladder size from its *rung* on (the first size whose nodes contain it, :func:`rung`). So every
candidate of the same spacings with ``n_i`` nodes on axis ``i`` and at least the point's rung
on each other axis checks that point (it is on its check lines), looks it up from the same two
texels and makes the same error there: when that error is above the target, all of them fail.
Such a *certificate* ``(i, n_i, rungs)`` is recorded for each failing point the search has
checked (:class:`Certificates`); the texels of the point are the same stored texels, so no
texel is computed to use it.

The lower bound: a candidate that failed is followed, in the search, by the chain of
candidates that double one axis at a time (which axis is decided by its cross points, which
cost texels). Every candidate of that chain has at least as many nodes on every axis, and the
first that passes is not certified to fail; so its size is at least the smallest size of an
uncertified candidate that dominates the failed one (:meth:`Certificates.cone_bound`). The
search files the undecided chain under that size instead of its next candidate's, and
decides it only when the best-first order reaches that size: a spacing combination that
loses is dropped without its last, largest, cross checks.
"""

from __future__ import annotations

import itertools

import numpy as np

__all__ = ["CERT_MARGIN", "Certificates", "LADDER", "rung"]

#: The doubling ladder of node counts (the search's caps stop it at ``MAX_NODES`` = 1025).
LADDER = tuple(2 ** k + 1 for k in range(11))
#: A point certifies failure only above ``target + CERT_MARGIN``: the same lookup computed for
#: another candidate may differ in the last bits (the texel coordinate t (n - 1) of a node is
#: an integer only up to rounding); values are O(1), so 1e-12 covers it.
CERT_MARGIN = 1e-12


def rung(k: int, n: int) -> int:
    """The smallest ladder size (2, 3, 5, 9, ...) whose endpoint nodes include node ``k`` of an
    ``n``-node ladder axis (n - 1 a power of two): 2 for the endpoints, else (n - 1) / 2^p + 1
    where 2^p is the largest power of two dividing k."""
    if k == 0 or k == n - 1:
        return 2
    return (n - 1) // (k & -k) + 1


def rungs(n: int) -> np.ndarray:
    """:func:`rung` of every node index of an ``n``-node ladder axis."""
    return np.array([rung(k, n) for k in range(n)], dtype=np.int64)


class Certificates:
    """The certified failures of one spacing combination with ``dims`` interpolated axes.

    ``points``: every ladder size combination (rows), ``covered``: those certified to fail.
    ``found`` counts certificates recorded, ``used`` the candidates failed by one without a
    texel computed (:meth:`fails` returning a value).
    """

    def __init__(self, dims: int, max_nodes: int):
        ladder = [n for n in LADDER if n <= max_nodes]
        combos = list(itertools.product(ladder, repeat=dims))  # [()] when dims = 0: one empty point
        self.points = np.array(combos, dtype=np.int64).reshape(len(combos), dims)
        self.sizes = np.prod(self.points, axis=1)
        self.covered = np.zeros(len(self.points), dtype=bool)
        self.error = np.zeros(len(self.points))  # the largest certified error of a covered candidate
        self.found = 0
        self.used = 0
        # per axis: (nodes on it, error, the point's table coordinates) of the failing point with
        # the most nodes on that axis (then the largest error): where a probe looks next
        self.hints: list[tuple[int, float, list[float]] | None] = [None] * dims

    def add(self, axis: int, n: int, other: tuple[int, ...], error: float, point: list[float] | None = None) -> None:
        """Certify: every candidate with ``n`` nodes on ``axis`` and at least ``other[j]`` on each
        other axis j fails, with an error of at least ``error`` (``other[axis]`` is ignored).
        ``point``: the failing point's coordinates (a hint for :meth:`hint`)."""
        mask = self.points[:, axis] == n
        for j, r in enumerate(other):
            if j != axis:
                mask &= self.points[:, j] >= r
        self.found += 1
        self.covered |= mask
        self.error[mask] = np.maximum(self.error[mask], error)
        old = self.hints[axis]
        if point is not None and (old is None or (n, error) > old[:2]):
            self.hints[axis] = (n, error, list(point))

    def add_cross(self, axis: int, sizes: tuple[int, ...], err: np.ndarray, target: float,
                  worst: list[float] | None = None) -> None:
        """Certificates from the errors ``err`` at a candidate's points that lie inside its cells
        along ``axis`` (that axis: any number of points, each between two of its nodes; every
        other interpolated axis: its nodes, in order; no other axes); ``worst``: the coordinates
        of the largest (a hint)."""
        bad = err > target + CERT_MARGIN
        if not bad.any():
            return
        grids = np.meshgrid(*[rungs(n) if j != axis else np.zeros(err.shape[axis], dtype=np.int64)
                              for j, n in enumerate(sizes)], indexing="ij")
        found = np.stack([g[bad] for g in grids], axis=-1)
        top = float(err.max())
        for row in np.unique(found, axis=0):
            sel = np.all(found == row, axis=-1)
            e = float(err[bad][sel].max())
            self.add(axis, sizes[axis], tuple(int(r) for r in row), e, worst if e == top else None)

    def hint(self, axis: int) -> tuple[int, float, list[float]] | None:
        """(nodes, error, coordinates) of the failing point along ``axis`` with the most nodes."""
        return self.hints[axis]

    def _row(self, sizes: tuple[int, ...]) -> np.ndarray:
        return np.all(self.points == np.asarray(sizes, dtype=np.int64), axis=1)

    def fails(self, sizes: tuple[int, ...]) -> float | None:
        """The certified error of the candidate ``sizes`` (None: not certified to fail)."""
        row = self._row(sizes)
        if not (row & self.covered).any():
            return None
        self.used += 1
        return float(self.error[row][0])

    def cone_min(self, sizes: tuple[int, ...]) -> tuple[float, tuple[int, ...] | None]:
        """(size, node counts) of the smallest candidate not certified to fail with at least
        ``sizes`` nodes on every axis, other than ``sizes`` itself ((inf, None): none below the
        caps; ties: the first in ladder order)."""
        s = np.asarray(sizes, dtype=np.int64)
        cone = np.all(self.points >= s, axis=1) & ~self._row(sizes) & ~self.covered
        if not cone.any():
            return float("inf"), None
        idx = np.flatnonzero(cone)
        k = idx[int(np.argmin(self.sizes[idx]))]
        return float(self.sizes[k]), tuple(int(x) for x in self.points[k])

    def cone_bound(self, sizes: tuple[int, ...]) -> float:
        """The size of :meth:`cone_min`: a lower bound on the size of the first candidate that
        passes in the chain that follows the failed candidate ``sizes``."""
        return self.cone_min(sizes)[0]
