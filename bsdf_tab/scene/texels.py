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

import copy
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


#: Node ids per axis are packed into one int64 key per texel: BITS bits per axis (at most
#: 2^BITS distinct nodes per axis in a run; 4 axes x 15 bits < 63).
BITS = 15


class _Family:
    """The texels of one family: per axis, node key -> id (in order of first use); the texels'
    packed ids, sorted, and their channel rows."""

    def __init__(self, dims: int, nchan: int):
        self.node_keys = [np.zeros(0) for _ in range(dims)]  # per axis: node keys, sorted
        self.node_sorted_ids = [np.zeros(0, dtype=np.int64) for _ in range(dims)]  # their ids
        self.node_values: list[list[float]] = [[] for _ in range(dims)]  # per axis: id -> value
        self.keys = np.zeros(0, dtype=np.int64)  # packed texel keys, sorted
        self.rows = np.zeros((0, nchan))  # rows[i]: the texel of keys[i]
        # per axis: the bytes of a node array asked for before -> its ids (a node's id never
        # changes, and the checks ask for the same node arrays many times)
        self.memo: list[dict[bytes, np.ndarray]] = [{} for _ in range(dims)]

    def ids(self, a: int, values: np.ndarray) -> np.ndarray:
        """The node ids of ``values`` on axis ``a`` (new nodes get the next ids)."""
        values = np.ascontiguousarray(values, dtype=np.float64)
        memo = self.memo[a].get(values.tobytes())
        if memo is not None:
            return memo
        out = self._ids(a, values)
        out.setflags(write=False)
        self.memo[a][values.tobytes()] = out
        return out

    def _ids(self, a: int, values: np.ndarray) -> np.ndarray:
        k = np.round(values, KEY_DIGITS)
        keys, ids = self.node_keys[a], self.node_sorted_ids[a]
        pos = np.minimum(np.searchsorted(keys, k), max(len(keys) - 1, 0))
        new = ~(keys[pos] == k) if len(keys) else np.ones(k.shape, dtype=bool)
        if new.any():
            fresh, first = np.unique(k[new], return_index=True)
            if len(self.node_values[a]) + len(fresh) > 1 << BITS:  # pragma: no cover - beyond the caps
                raise ValueError("too many distinct nodes on one axis for the texel store")
            start = len(self.node_values[a])
            self.node_values[a] += [float(x) for x in values[new][first]]
            keys = np.concatenate([keys, fresh])
            ids = np.concatenate([ids, np.arange(start, start + len(fresh), dtype=np.int64)])
            order = np.argsort(keys, kind="stable")
            self.node_keys[a], self.node_sorted_ids[a] = keys[order], ids[order]
            keys, ids = self.node_keys[a], self.node_sorted_ids[a]
            pos = np.searchsorted(keys, k)
        return ids[pos]

    def packed(self, ids: list[np.ndarray]) -> np.ndarray:
        """The packed keys of the grid of per-axis ids (shape: the grid's)."""
        key = np.zeros(tuple(len(i) for i in ids), dtype=np.int64)
        for a, i in enumerate(ids):
            shape = [1] * len(ids)
            shape[a] = -1
            key = key + (i.reshape(shape) << (BITS * a))
        return key

    def find(self, key: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(position in ``rows``, found) of packed keys."""
        pos = np.searchsorted(self.keys, key)
        pos = np.minimum(pos, max(len(self.keys) - 1, 0))
        found = (self.keys[pos] == key) if len(self.keys) else np.zeros(key.shape, dtype=bool)
        return pos, found

    def add(self, key: np.ndarray, rows: np.ndarray) -> None:
        keys = np.concatenate([self.keys, key.ravel()])
        data = np.concatenate([self.rows, rows.reshape(-1, rows.shape[-1])])
        order = np.argsort(keys, kind="stable")
        self.keys, self.rows = keys[order], data[order]


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
        self._families: dict[str, _Family] = {}
        # (id of a base dict, axis names) -> (a copy of that base, its family): the checks pass
        # the same base dict thousands of times; its JSON key is built once per equal base
        self._recent: dict[tuple, tuple[dict, _Family]] = {}
        self.calls = 0  # tabulations run
        self.texels = 0  # texels computed
        self.requested = 0  # texels asked for (over all grids, repeats counted)
        self.certified = 0  # the search's counters (.search.Verifier), kept with the run's texels
        self.probes = 0

    @staticmethod
    def _channels(base: dict) -> list[str]:
        chans = list(channel_names(base["table"]))
        return chans + [c + "_err" for c in chans]

    def _family(self, base: dict, names: list[str]) -> _Family:
        recent = self._recent.get((id(base), tuple(names)))
        if recent is not None and recent[0] == base:  # equal to the copy: not changed since
            return recent[1]
        key = json.dumps([base, names], sort_keys=True)
        if key not in self._families:
            self._families[key] = _Family(len(names), len(self._channels(base)))
        fam = self._families[key]
        self._recent[(id(base), tuple(names))] = (copy.deepcopy(base), fam)
        return fam

    def grid(self, base: dict, axes: list[tuple[str, np.ndarray]]) -> dict[str, np.ndarray]:
        """Values and ``_err`` channels of the family ``base`` (a spec without axes) on the grid
        of ``axes`` ((name, node values) in table order), computing only the missing texels."""
        names = [n for n, _ in axes]
        lists = [np.atleast_1d(np.asarray(v, dtype=np.float64)) for _, v in axes]
        fam = self._family(base, names)
        key = fam.packed([fam.ids(a, v) for a, v in enumerate(lists)])
        pos, found = fam.find(key)
        if not found.all():  # usually a prefetch has computed them all already
            self.prefetch(base, names, [lists])
            pos, found = fam.find(key)
            assert found.all()  # prefetch computed every missing texel
        self.requested += key.size
        data = fam.rows[pos]
        return {c: data[..., i] for i, c in enumerate(self._channels(base))}

    def prefetch(self, base: dict, names: list[str], grids: list[list[np.ndarray]]) -> None:
        """Compute the texels of several grids (each a list of node values per axis) that are
        not known yet, together: their union covered by as few tensor blocks as it takes."""
        fam = self._family(base, names)
        missing = []
        for lists in grids:
            ids = [fam.ids(a, np.atleast_1d(np.asarray(v, dtype=np.float64))) for a, v in enumerate(lists)]
            _, found = fam.find(fam.packed(ids))
            where = np.nonzero(~found)
            if where[0].size:
                missing.append(np.stack([ids[a][w] for a, w in enumerate(where)], axis=-1))
        if not missing:
            return
        points = np.unique(np.concatenate(missing), axis=0)  # (n, dims) node ids
        # blocks over node ids, each axis's ids ordered by value (a spec's explicit axis values)
        order, ranks = [], []
        for a in range(len(names)):
            used = np.unique(points[:, a])
            used = used[np.argsort([fam.node_values[a][i] for i in used], kind="stable")]
            lookup = np.empty(int(used.max()) + 1, dtype=np.int64)
            lookup[used] = np.arange(len(used))
            order.append(used)
            ranks.append(lookup[points[:, a]])
        ranked = list(map(tuple, np.stack(ranks, axis=-1).tolist()))
        chans = self._channels(base)
        for block in cover(ranked, len(names)):
            ids = [order[a][list(block[a])] for a in range(len(names))]
            spec = dict(base, axes={n: [fam.node_values[a][i] for i in ids[a]] for a, n in enumerate(names)})
            if self.before is not None:
                self.before(spec)
            table = self.compute(spec)
            self.calls += 1
            data = np.stack([np.asarray(table.channels[c], dtype=np.float64) for c in chans], axis=-1)
            self.texels += int(np.prod(data.shape[:-1]))
            fam.add(fam.packed(ids), data)
