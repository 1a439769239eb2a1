"""The search for the smallest table of one planned group, and the checks that verify it.

A candidate (one spacing per interpolated axis, one node count per axis on the doubling
ladder) is verified at every point of its *check set*: its refined grid (the nodes of the next
rung: every cell midpoint and centre) and its *check lines*: along each interpolated axis, at
the nodes of the other axes, the points :func:`check_points` (every cell midpoint, but at least
``MIN_CHECK_CELLS`` intervals over the range, so a coarse candidate is checked at several points
per cell, and on mu, alpha and roughness points ever closer to the low end, where the functions
change fastest). Error = max over those points of |lookup(candidate) - direct| plus the direct
value's integration error. The search is best-first over the candidates of every spacing
combination (fewest texels first; ties: the earlier combination); a failing candidate doubles
the axis whose check-line points inside its cells err most.

What it computes is kept small without changing what it decides (``docs/scenes.md``):

- every texel comes from the run's :class:`~.texels.TexelStore`: the nested ladder makes a
  candidate's nodes, its check points and the next candidates' nodes the same texels;
- a candidate is first checked at its *cross* points (its check lines: check points along one
  axis, nodes along the others): they alone decide which axis to double, and when one of them
  is above the target the candidate fails whatever its cell centres hold, so the centres are
  computed only for a candidate that may pass;
- a candidate reached by doubling is first checked on the lines through its parent's worst
  points, and on each line first at the few check points next to that point (``WINDOW``). A
  point above the target there fails it for sure;
- a point above the target fails every candidate that looks it up from the same two texels
  (a *certificate*, :mod:`.bounds`): a candidate certified to fail is failed without a texel
  computed;
- which axis a failed candidate's child doubles (its cross points, which cost texels) is
  decided only when the best-first order reaches the smallest candidate its chain can still
  pass with: the smallest one not certified to fail among those with at least its node counts
  (:meth:`.bounds.Certificates.cone_bound`). Before deciding, the search tries to certify that
  candidate with up to ``MAX_PROBES`` lines, each on the then smallest uncertified one within
  the limits (``probe``: along an axis, through the last failing point found along it); when the bound so rises past the others, the chain waits again. A spacing combination
  that loses is so dropped after a few lines instead of its last, largest, cross checks.

The winner and its reported error (computed on its whole check set) are those of verifying
every candidate on its whole check set in the best-first order: a certificate only fails
candidates that fail, and a chain is put off only while some other pending candidate is
smaller than any it can pass with. (The progress lines list fewer candidates: those of chains
never resumed are not verified.)
"""

from __future__ import annotations

import functools
import heapq
import itertools
import math
from typing import Callable

import numpy as np

from ..errors import SpecError, TexelLimitError
from ..spec import channel_names
from .bounds import CERT_MARGIN, Certificates, rung
from .lookup import AxisPlan, lookup, texels_read

__all__ = ["MAX_CHECK_TEXELS", "MAX_NODES", "MIN_CHECK_CELLS", "PLAN_MARGIN", "Verifier", "check_count",
           "check_points", "check_size", "combine", "search"]

PLAN_MARGIN = 0.8  # plan to 0.8 lookup_tol at the check points: headroom for points between them
#: The check lines of an interpolated axis have at least this many intervals over the axis's
#: range (a ladder size, so they hold every candidate's nodes): a candidate of few nodes is
#: checked at several points per cell, not only at its midpoints. A single midpoint per cell misses what
#: happens inside a wide cell: copper's 2-node mu axis at tol 0.1 passed with 0.065 at mu = 0.5
#: while its error at mu = 0.18 is 0.124.
MIN_CHECK_CELLS = 16
#: ... and, in the first of those intervals, the points at 1/2, 1/4, ... of the interval from
#: the axis's low end, down to the node spacing of a MAX_NODES axis (nodes of finer ladder sizes,
#: :func:`end_depth`): the functions change fastest there (grazing mu -> 0, where they dip along
#: mu ~ alpha; the smallest roughness), and a feature narrower than one check interval went
#: unseen (an aluminium albedo, roughness from 0.05, linear mu, tol 0.1: 0.064 at the check
#: points, 0.099 at mu = 0.003). The high ends (mu -> 1, the roughest) are smooth, and so are
#: the other axes' low ends (phi_v: E is even about 0; eta, anisotropy): only these axes get them.
LOW_END_AXES = ("mu", "alpha", "roughness")
MAX_NODES = 1025
MAX_CHECK_TEXELS = 300_000
WINDOW = 1  # a line check looks first at the check points next to its point (within 1 of them)
MAX_PROBES = 8  # line probes per decision of a failed candidate's child (.bounds)


def check_size(n: int) -> int:
    """The node count of the uniform part of the check lines of an interpolated axis of ``n``
    ladder nodes: the next rung (2n - 1: every cell midpoint), and at least ``MIN_CHECK_CELLS + 1``
    (a ladder size too, so it holds the candidate's nodes and those of every smaller candidate)."""
    return max(2 * n - 1, MIN_CHECK_CELLS + 1)


def end_depth(n: int, name: str = "mu") -> int:
    """The number of the low end's check points of an axis ``name`` of ``n`` ladder nodes: the
    halvings of the uniform check interval down to the node spacing of a ``MAX_NODES`` axis
    (none for an axis not in ``LOW_END_AXES``)."""
    if name not in LOW_END_AXES:
        return 0
    return max(0, int(round(math.log2((MAX_NODES - 1) / (check_size(n) - 1)))))


def check_count(n: int, name: str = "mu") -> int:
    """The number of check points of an interpolated axis ``name`` of ``n`` ladder nodes."""
    return check_size(n) + end_depth(n, name)


@functools.lru_cache(maxsize=1024)
def _check_points(name: str, n: int, spacing: str, rng: tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
    m, depth = check_size(n), end_depth(n, name)
    scale = 1 << depth
    big = AxisPlan(name, "interp", range=rng, spacing=spacing, size=(m - 1) * scale + 1).nodes()
    last = len(big) - 1
    ends = [scale >> k for k in range(1, depth + 1)]
    idx = np.unique(np.concatenate([np.arange(0, len(big), scale), ends]).astype(np.int64))
    values = big[idx]
    inside = np.flatnonzero(idx % (last // (n - 1)) != 0)  # not a node of the candidate
    values.setflags(write=False)
    inside.setflags(write=False)
    return values, inside


def check_points(ax: AxisPlan) -> tuple[np.ndarray, np.ndarray]:
    """(the check-line points of the interpolated axis ``ax``, sorted; the positions of those that
    are not its nodes, i.e. inside its cells). The points are the nodes of the ladder size
    :func:`check_size` and, in its first interval, the low end's points (:func:`end_depth`): all
    of them are nodes of finer ladder sizes, so a candidate's check points are the same texels
    as other candidates' nodes and check points. They depend on the axis's name, node count,
    spacing and range only, so every candidate with that node count checks the same points
    inside the same cells of that axis (:mod:`.bounds`)."""
    return _check_points(ax.name, ax.size, ax.spacing, tuple(ax.range))


def combine(kind: str, diffs: dict, errs: dict) -> np.ndarray:
    """Per-point lookup error from per-channel lookup differences and integration errors."""
    if kind == "dfg":
        # E = f0 A + B for any f0 in [0, 1]: the lookup error f0 dA + dB is largest at f0 = 0 or 1
        return np.maximum(np.abs(diffs["B"]), np.abs(diffs["A"] + diffs["B"])) + errs["A"] + errs["B"]
    return np.max([np.abs(diffs[ch]) + errs[ch] for ch in diffs], axis=0)


class Verifier:
    """The checks of the candidates of one planned table ``tp`` (a TablePlan), on the store."""

    def __init__(self, tp, store, interpolation: str):
        self.tp, self.store, self.interpolation = tp, store, interpolation
        self.base = {k: v for k, v in tp.spec().items() if k != "axes"}
        self.interp = [i for i, a in enumerate(tp.axes) if a.mode == "interp"]
        self.chans = list(channel_names(tp.kind))
        self.probes = 0  # lines checked only to certify candidates (search's probe)
        self.certified = 0  # candidates failed by a certificate, without a texel computed

    def trial(self, combo, sizes) -> list[AxisPlan]:
        """The axes of a candidate (spacings ``combo``, node counts ``sizes`` of the interp axes)."""
        out = [AxisPlan(a.name, a.mode, list(a.values), tuple(a.range), a.spacing, a.size) for a in self.tp.axes]
        for i, sp, n in zip(self.interp, combo, sizes):
            out[i].spacing, out[i].size = sp, n
        return out

    @staticmethod
    def fine(trial: list[AxisPlan]) -> list[np.ndarray]:
        """The nodes of the refined grid (the next rung on every interp axis)."""
        return [AxisPlan(a.name, a.mode, a.values, a.range, a.spacing, 2 * a.size - 1).nodes() if a.mode == "interp"
                else a.nodes() for a in trial]

    def lines(self, trial: list[AxisPlan]) -> list[list[np.ndarray]]:
        """Per interp axis: the grid of its check lines (:func:`check_points` along it, the
        nodes along the others)."""
        coarse = [a.nodes() for a in trial]
        return [[check_points(trial[j])[0] if j == i else c for j, c in enumerate(coarse)] for i in self.interp]

    def values(self, lists: list[np.ndarray]) -> dict[str, np.ndarray]:
        return self.store.grid(self.base, [(a.name, v) for a, v in zip(self.tp.axes, lists)])

    def prefetch(self, grids: list[list[np.ndarray]]) -> None:
        """Compute the missing texels of several grids in one go (fewer, larger launches)."""
        self.store.prefetch(self.base, [a.name for a in self.tp.axes], grids)

    def errors(self, trial: list[AxisPlan], table: dict, lists: list[np.ndarray]) -> np.ndarray:
        """Lookup error of the candidate (``table``: its values) at the grid ``lists``."""
        grids = np.meshgrid(*lists, indexing="ij")
        direct = self.values(lists)
        errs = {ch: direct[ch + "_err"] for ch in self.chans}
        modes: list = [None]
        if self.interpolation == "nearest":  # every texel that can be nearest to a tie, either way
            modes = [tuple(bool((c >> self.interp.index(i)) & 1) if i in self.interp else False
                           for i in range(len(trial))) for c in range(1 << len(self.interp))]
        total = np.zeros(grids[0].shape)
        for m in modes:
            diffs = {ch: lookup(table[ch], trial, grids, self.interpolation, m) - direct[ch] for ch in self.chans}
            total = np.maximum(total, combine(self.tp.kind, diffs, errs))
        return total

    def cross(self, trial: list[AxisPlan], certs: Certificates | None = None, target: float = 0.0):
        """(per interp axis: the max error on its check lines at the points inside its cells, and
        that point's coordinates). ``certs``: record the failing points (above ``target``)."""
        coarse = [a.nodes() for a in trial]
        crosses = self.lines(trial)
        self.prefetch([coarse] + crosses)
        table = self.values(coarse)
        per_axis, worst = [], []
        discrete = tuple(j for j in range(len(trial)) if j not in self.interp)
        sizes = tuple(trial[j].size for j in self.interp)
        for pos, (i, lists) in enumerate(zip(self.interp, crosses)):
            err = self.errors(trial, table, lists)
            inside = check_points(trial[i])[1]
            sub = np.take(err, inside, axis=i)
            k = np.unravel_index(int(np.argmax(sub)), sub.shape)
            per_axis.append(float(sub[k]))
            worst.append([float(lists[j][inside[k[j]] if j == i else k[j]]) for j in range(len(lists))])
            if certs is not None:  # the worst over the discrete axes (the same in every candidate)
                certs.add_cross(pos, sizes, sub.max(axis=discrete) if discrete else sub, target, worst[-1])
        return per_axis, worst

    def partial(self, trial: list[AxisPlan], reads: list[np.ndarray]) -> dict[str, np.ndarray]:
        """The candidate's table with only the texels ``reads`` (per axis, node indices) computed:
        what a lookup that reads no other texel needs (the others are 0 and never read)."""
        nodes = [a.nodes() for a in trial]
        sub = self.values([n[r] for n, r in zip(nodes, reads)])
        out = {}
        for ch, val in sub.items():
            arr = np.zeros(tuple(len(a) for a in trial))
            arr[np.ix_(*reads)] = val
            out[ch] = arr
        return out

    def line(self, trial: list[AxisPlan], worst_parent: list[list[float]], certs: Certificates | None = None,
             target: float = 0.0, positions: list[int] | None = None):
        """(lower bound of the error, per interp axis the worst point found) on the check lines
        through ``worst_parent`` (per interp axis, a point whose coordinates on the
        other axes are nodes of ``trial``). Only the texels of those lines and the nodes their
        lookup reads are computed, and first only a few check points around each point
        (``WINDOW``): a line is checked whole only where none of them is above ``target``.
        ``positions``: only the lines along these interp axes (indices into the interp axes;
        default all). ``certs``: record a failing point (:mod:`.bounds`)."""
        positions = list(range(len(self.interp))) if positions is None else positions
        fine = [check_points(a)[0] if a.mode == "interp" else None for a in trial]
        mids = {}
        for k in positions:
            f = fine[self.interp[k]]
            inside = set(check_points(trial[self.interp[k]])[1].tolist())
            c = int(np.argmin(np.abs(f - worst_parent[k][self.interp[k]])))
            mids[k] = f[[m for m in range(c - WINDOW, c + WINDOW + 1) if m in inside]]
        found = self._lines(trial, worst_parent, positions, mids, certs, target)
        rest = [k for k in positions if found[k][0] <= target + CERT_MARGIN]
        if rest:
            whole = {k: fine[self.interp[k]][check_points(trial[self.interp[k]])[1]] for k in rest}
            found.update(self._lines(trial, worst_parent, rest, whole, certs, target))
        return max(found[k][0] for k in positions), [found[k][1] for k in positions]

    def _lines(self, trial, points, positions, mids, certs, target) -> dict[int, tuple[float, list[float]]]:
        """Per position k: (the max error, its point) at the check points ``mids[k]`` along interp
        axis k through ``points[k]``, with only the texels those points and their lookup read."""
        lines = [[mids[k] if j == self.interp[k] else np.array([x]) for j, x in enumerate(points[k])]
                 for k in positions]
        both = self.interpolation == "nearest"
        reads = [[texels_read(a, x, self.interpolation, both) for a, x in zip(trial, lists)] for lists in lines]
        nodes = [a.nodes() for a in trial]
        self.prefetch(lines + [[n[r] for n, r in zip(nodes, rd)] for rd in reads])
        out = {}
        for k, lists, rd in zip(positions, lines, reads):
            i = self.interp[k]
            err = self.errors(trial, self.partial(trial, rd), lists).ravel()
            j = int(np.argmax(err))
            pt = list(points[k])
            pt[i] = float(mids[k][j])
            out[k] = (float(err[j]), pt)
            if certs is not None and err[j] > target + CERT_MARGIN:  # the line's rungs elsewhere
                other = tuple(rung(int(np.argmin(np.abs(nodes[q] - pt[q]))), trial[q].size) for q in self.interp)
                certs.add(k, trial[i].size, other, float(err[j]), pt)
        return out

    def on_nodes(self, trial: list[AxisPlan], point: list[float], skip: int) -> bool:
        """Whether ``point`` is at nodes of ``trial`` on every interp axis but position ``skip``."""
        for k, i in enumerate(self.interp):
            if k != skip:
                nodes = trial[i].nodes()
                if np.min(np.abs(nodes - point[i])) > 1e-12 * max(1.0, float(np.max(np.abs(nodes)))):
                    return False
        return True

    def full(self, trial: list[AxisPlan]) -> float:
        """The candidate's error over its whole check set: the refined grid and the check lines."""
        table = self.values([a.nodes() for a in trial])
        grids = [self.fine(trial)] + self.lines(trial)
        return max(float(self.errors(trial, table, lists).max()) for lists in grids)

    def fixed_error(self, axes: list[AxisPlan], trial: list[AxisPlan]) -> float:
        """Lookup error of the table of ``axes`` (the fixed-size alternative) at the check set of
        ``trial`` (its refined grid and check lines), plus the largest integration error of the
        texels the lookup reads.

        Only those texels are computed: the values of the others do not enter the lookup."""
        grids = [self.fine(trial)] + self.lines(trial)
        reads = [np.unique(np.concatenate([texels_read(ax, lists[k], self.interpolation) for lists in grids]))
                 for k, ax in enumerate(axes)]
        self.prefetch(grids + [[ax.nodes()[r] for ax, r in zip(axes, reads)]])
        full = self.partial(axes, reads)
        sub = {ch + "_err": full[ch + "_err"][np.ix_(*reads)] for ch in self.chans}
        worst = 0.0
        for lists in grids:
            mesh = np.meshgrid(*lists, indexing="ij")
            direct = self.values(lists)
            diffs = {ch: lookup(full[ch], axes, mesh, self.interpolation) - direct[ch] for ch in self.chans}
            err = combine(self.tp.kind, diffs, {ch: direct[ch + "_err"] for ch in self.chans})
            worst = max(worst, float(np.max(err)))
        return worst + max(float(np.max(sub[ch + "_err"])) for ch in self.chans)


def search(tp, spacings: list[str], lookup_tol: float, interpolation: str, store,
           max_texels: int | None = None, log: Callable[[str], None] | None = None):
    """The smallest candidate of ``tp`` below ``PLAN_MARGIN * lookup_tol``: (trial axes, error, verifier)."""
    v = Verifier(tp, store, interpolation)
    interp = [tp.axes[i] for i in v.interp]
    combos: list[tuple] = [()]
    for a in interp:
        opts = spacings if a.range[0] >= 0.0 else ["linear"]
        combos = [c + (sp,) for c in combos for sp in opts]
    target = PLAN_MARGIN * lookup_tol
    discrete = int(np.prod([len(a) for a in tp.axes if a.mode != "interp"]))
    seq = itertools.count()
    heap = [(2 ** len(interp) if interp else 1, ci, tuple(2 for _ in interp), next(seq), "verify", None)
            for ci in range(len(combos))]
    heapq.heapify(heap)

    def say(ci, sizes, err: float, ok: bool, bound: bool = False, certified: bool = False) -> None:
        if log is not None:
            shape = " x ".join(f"{a.name} {n} {sp}" for a, n, sp in zip(interp, sizes, combos[ci])) or "discrete axes only"
            log(f"{tp.file}: {shape}: lookup error {'>= ' if bound else ''}{err:.3g} "
                f"({'ok' if ok else 'refine'}{', certified' if certified else ''}; target {target:.3g})")

    def grow(ci, sizes, per_axis, worst) -> None:
        k = int(np.argmax(per_axis))
        grown = tuple(2 * n - 1 if j == k else n for j, n in enumerate(sizes))
        heapq.heappush(heap, (int(np.prod(grown)), ci, grown, next(seq), "verify", worst))

    def defer(ci, sizes) -> None:
        """A failed candidate whose child is undecided: filed under the smallest candidate its
        chain can still pass with (.bounds), decided when the best-first order gets there."""
        heapq.heappush(heap, (certs[ci].cone_bound(sizes), ci, sizes, next(seq), "grow", None))

    def computable(sizes) -> bool:
        """Whether a candidate is within the texel limit and the check caps (nothing is computed
        for one that is not, by the search or by a probe)."""
        if max_texels is not None and int(np.prod(sizes)) * discrete > max_texels:
            return False
        lines = sum(int(np.prod(sizes)) // n * check_count(n, a.name) for n, a in zip(sizes, interp))
        checked = (int(np.prod([2 * n - 1 for n in sizes])) + lines) * discrete
        return checked <= MAX_CHECK_TEXELS and all(n <= MAX_NODES for n in sizes)

    def probe(ci, sizes, key) -> bool:
        """Before a failed candidate's cross points decide its child: try to certify the smallest
        candidates its chain could still pass with (up to MAX_PROBES of them, the smallest first, and
        only those within the texel limit and the caps), each by one line (along an axis through the
        last failing point found along it, :meth:`.bounds.Certificates.hint`). True: the bound
        rose above ``key`` and the chain is filed again under it."""
        c = certs[ci]
        for _ in range(MAX_PROBES):
            bound, nxt = c.cone_min(sizes)
            if bound > key:
                heapq.heappush(heap, (bound, ci, sizes, next(seq), "grow", None))
                return True
            if nxt is None:  # every candidate it dominates is certified, and nothing else is left:
                return False  # decided as the search without certificates would (caps, limits)
            if not computable(nxt):  # above the texel limit or a cap: nothing is computed for it
                return False
            trial = v.trial(combos[ci], nxt)
            # the axis whose last failing point would still err most with nxt's nodes, if its error
            # falls as h^2 (4x per doubling); h[0] >= 2 nodes, so h[0] - 1 >= 1 (no division by 0)
            hints = [(h[1] / 4.0 ** math.log2((nxt[k] - 1) / (h[0] - 1)), k) for k, h in enumerate(c.hints)
                     if h is not None and v.on_nodes(trial, h[2], k)]
            if not hints:
                return False
            _, k = max(hints)
            point = [None] * len(interp)
            point[k] = c.hint(k)[2]
            v.probes += 1
            err, _ = v.line(trial, point, c, target, positions=[k])
            if err <= target + CERT_MARGIN:
                return False
        return False

    certs = [Certificates(len(interp), MAX_NODES) for _ in combos]
    best, limited = None, False
    while heap:
        texels, ci, sizes, _, what, info = heapq.heappop(heap)
        trial = v.trial(combos[ci], sizes)
        if what == "grow":  # a failed candidate whose child may now be next: decide which axis
            if len(interp) > 1 and probe(ci, sizes, texels):
                continue
            grow(ci, sizes, *v.cross(trial, certs[ci], target))
            continue
        if max_texels is not None and int(np.prod(sizes)) * discrete > max_texels:
            limited = True  # checked before anything is computed
            continue
        if not computable(sizes):
            continue
        certified = certs[ci].fails(sizes) if interp else None
        if certified is not None:  # fails at a point already checked: nothing to compute
            v.certified += 1
            say(ci, sizes, certified, False, True, True)
            defer(ci, sizes)
            continue
        if info is not None:
            bound, worst = v.line(trial, info, certs[ci], target)
            if bound > target:
                say(ci, sizes, bound, False, True)
                if len(sizes) == 1:
                    grow(ci, sizes, [bound], worst)
                else:
                    defer(ci, sizes)
                continue
        if interp:
            per_axis, worst = v.cross(trial, certs[ci], target)
            if max(per_axis) > target:
                say(ci, sizes, max(per_axis), False, True)
                grow(ci, sizes, per_axis, worst)
                continue
        total = v.full(trial)
        say(ci, sizes, total, total <= target)
        if total <= target or not interp:
            best = (trial, total)
            break
        grow(ci, sizes, per_axis, worst)
    if best is None and limited:
        raise TexelLimitError(
            "tol",
            f"table {tp.file} cannot reach a lookup error of {lookup_tol:g} within the limit of "
            f"{max_texels} texels per table; loosen tol",
            limit=max_texels,
        )
    if best is None:
        rough = [a for a in interp if a.name in ("alpha", "roughness")]
        hint = (f", or start the {rough[0].name} range higher than {rough[0].range[0]:g} (the tables change "
                f"fastest near grazing mu at the smallest {rough[0].name}: along mu ~ alpha)" if rough else "")
        raise SpecError(
            "tol",
            f"cannot reach a lookup error of {lookup_tol:g} for table {tp.file} within {MAX_NODES} nodes per "
            f"axis ({MAX_CHECK_TEXELS} check texels); loosen tol{hint}",
        )
    return best[0], best[1], v
