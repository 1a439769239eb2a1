"""Texel values shared by every candidate of a planning run: each texel is computed once.

The planner's candidate tables, their check grids and the fixed-size comparison are all grids
of (mu, alpha[, eta], ...) nodes of a few table families (kind, distribution, shadowing,
Fresnel, integration tolerance). The doubling ladder is nested (the nodes of n are nodes of
2n - 1), so consecutive candidates share most of their texels, and candidates of different
spacings share their endpoints and a few more. :class:`TexelStore` keeps every texel computed
during one planning run, keyed by its family and its coordinates; a grid asks only for the
texels not yet known, covered by a few tensor-product blocks, each one
:func:`bsdf_tab.api.tabulate` call with explicit axis values (so one kernel launch per block,
not per candidate). Texels are independent of the grid they are computed in (the integrators
integrate each texel on its own), so a texel read from the store is the one a full tabulation
of the candidate's grid would give.
"""

from __future__ import annotations

import json
from typing import Callable

import numpy as np

from ..spec import channel_names

__all__ = ["TexelStore", "cover"]

#: Coordinates closer than this (relative, after rounding to 12 digits) are the same texel:
#: the same node reached through two ladders (k / (n - 1) and 2k / (2n - 2)) may differ in
#: the last bit.
KEY_DIGITS = 12


def _key(x: float) -> float:
    return float(round(float(x), KEY_DIGITS))


def cover(points: list[tuple[int, ...]], dims: int) -> list[tuple[tuple[int, ...], ...]]:
    """Tensor-product blocks that cover a set of grid points exactly (no point twice).

    Groups the points by their coordinates on the first ``dims - 1`` axes; prefixes that need
    the same set of last-axis indices form one block with them, recursively. A grid minus a
    nested sub-grid (the planner's usual case) takes ``dims`` blocks at most.
    """
    if not points:
        return []
    if dims == 1:
        return [(tuple(sorted({p[0] for p in points})),)]
    by_prefix: dict[tuple[int, ...], set[int]] = {}
    for p in points:
        by_prefix.setdefault(p[:-1], set()).add(p[-1])
    by_last: dict[tuple[int, ...], list[tuple[int, ...]]] = {}
    for prefix, lasts in by_prefix.items():
        by_last.setdefault(tuple(sorted(lasts)), []).append(prefix)
    out = []
    for lasts, prefixes in sorted(by_last.items()):
        for block in cover(prefixes, dims - 1):
            out.append(block + (lasts,))
    return out


class TexelStore:
    """Texels of one planning run, by table family and coordinates.

    ``compute(spec)`` computes a table (the planner's path to :func:`bsdf_tab.api.tabulate`);
    ``before(spec)``, when given, is called with every spec before it is computed and may
    raise to stop the planning (the service's cost limit, :func:`bsdf_tab.scene.plan_scene`'s
    ``before_compute``).
    """

    def __init__(self, compute: Callable[[dict], object], before: Callable[[dict], None] | None = None):
        self.compute = compute
        self.before = before
        self._families: dict[str, dict] = {}
        self.calls = 0  # tabulations run
        self.texels = 0  # texels computed
        self.requested = 0  # texels asked for (over all grids, repeats counted)

    def family(self, base: dict, names: list[str]) -> str:
        return json.dumps([base, names], sort_keys=True)

    def grid(self, base: dict, axes: list[tuple[str, np.ndarray]]) -> dict[str, np.ndarray]:
        """Values and ``_err`` channels of the family ``base`` (a spec without axes) on the grid
        of ``axes`` ((name, node values) in table order), computing only the missing texels."""
        names = [n for n, _ in axes]
        self.prefetch(base, names, [[v for _, v in axes]])
        nodes = [np.atleast_1d(np.asarray(v, dtype=np.float64)) for _, v in axes]
        fam = self._families[self.family(base, names)]
        keys = [[_key(x) for x in v] for v in nodes]
        shape = tuple(len(v) for v in nodes)
        self.requested += int(np.prod(shape))
        flat = [fam[tuple(k[i] for k, i in zip(keys, idx))] for idx in np.ndindex(*shape)]
        chans = self._channels(base)
        data = np.asarray(flat, dtype=np.float64).reshape(shape + (len(chans),))
        return {c: data[..., i] for i, c in enumerate(chans)}

    @staticmethod
    def _channels(base: dict) -> list[str]:
        chans = list(channel_names(base["table"]))
        return chans + [c + "_err" for c in chans]

    def prefetch(self, base: dict, names: list[str], grids: list[list[np.ndarray]]) -> None:
        """Compute the texels of several grids (each a list of node values per axis) that are
        not known yet, together: their union covered by as few tensor blocks as it takes."""
        fam_key = self.family(base, names)
        fam = self._families.setdefault(fam_key, {})
        axis_nodes: list[dict[float, float]] = [{} for _ in names]  # key -> value, per axis
        missing = set()
        for lists in grids:
            nodes = [np.atleast_1d(np.asarray(v, dtype=np.float64)) for v in lists]
            keys = [[_key(x) for x in v] for v in nodes]
            for a, (k, v) in enumerate(zip(keys, nodes)):
                for kk, vv in zip(k, v):
                    axis_nodes[a].setdefault(kk, float(vv))
            for idx in np.ndindex(*(len(v) for v in nodes)):
                point = tuple(k[i] for k, i in zip(keys, idx))
                if point not in fam:
                    missing.add(point)
        if not missing:
            return
        order = [sorted(axis_nodes[a]) for a in range(len(names))]
        pos = [{k: i for i, k in enumerate(o)} for o in order]
        chans = self._channels(base)
        for block in cover([tuple(pos[a][p[a]] for a in range(len(names))) for p in missing], len(names)):
            spec = dict(base, axes={n: [axis_nodes[a][order[a][i]] for i in block[a]] for a, n in enumerate(names)})
            if self.before is not None:
                self.before(spec)
            table = self.compute(spec)
            self.calls += 1
            data = np.stack([np.asarray(table.channels[c], dtype=np.float64) for c in chans], axis=-1)
            self.texels += int(np.prod(data.shape[:-1]))
            for local in np.ndindex(*data.shape[:-1]):
                fam[tuple(order[a][block[a][i]] for a, i in enumerate(local))] = data[local]
