"""The doctor's hypotheses for 1-D averages, 2-D dielectric averages and 3-D glass tables.

Three kinds, each a set of quantities a file's axes may hold (in any order):

- ``albedo_avg`` (1-D): the roughness slot only; channels ``E_avg`` or ``1-E_avg``
  (Cycles ``ggx_Eavg``, OpenPBR ``ideal_metal_avg_energy_complement``); GGX or Beckmann,
  separable or correlated.
- ``dielectric_avg`` (2-D): an ior axis and the roughness slot; channels the mu-averages of
  ``R``, ``T``, ``R+T``, ``1-(R+T)`` or ``1-R`` (Cycles ``ggx_glass_Eavg``, OpenPBR
  ``*_dielectric_avg_energy_complement``); GGX.
- ``dielectric`` (3-D): ior, mu and the roughness slot; the same channels (Cycles
  ``ggx_glass_E``, OpenPBR ``*_dielectric_energy_complement``, EEVEE's BTDF); GGX.

The ior axis' mappings: ``z`` (x = sqrt((ior - 1)/(ior + 1)), ior = (1 + x^2)/(1 - x^2):
Cycles' z axis and EEVEE's x; x held at <= 0.99, ior 99.5) with eta = ior (light from
outside) or ``z-inv`` with eta = 1 / ior (from inside), and ``openpbr`` (index-based: the
first half 1/ior = 1 + 1.5 (n/2 - 1 - i)/(n/2 - 1), the second ior = 1 + 1.5 (i - n/2)/(n/2 - 1),
eta = ior on both sides of 1). mu and roughness take the 2-D doctor's spacings
(:mod:`.fit`), every axis its node conventions and orientation.

Search: (1) every permutation of the quantities over the file axes with every spacing and
orientation, under every model, with endpoints (and for 1-D / 2-D also centre) nodes;
(2) the ``keep`` best geometries under every model, their node conventions chosen axis by
axis (two passes of coordinate descent over :data:`bsdf_tab.doctor.fit.NODE_TYPES`).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, replace

import numpy as np

from .exact import MODELS
from .fit import MU_COORD, MU_SPACINGS, NODE_TYPES, ROUGH_COORD, ROUGH_MAPS, encodings, even_indices
from .glass import GLASS_MODELS, albedo_avg_candidate, eta_of_z, glass_avg, glass_values

__all__ = ["FILE_SPACING", "IOR_SPACINGS", "KINDS_ND", "NDAxis", "NDHypothesis", "claimed_axes", "meanings_of",
           "search_nd"]

IOR_SPACINGS = ("z", "z-inv", "openpbr")
IOR_COORD = {"z": "x = sqrt((ior - 1)/(ior + 1)), ior = (1 + x^2)/(1 - x^2), eta = ior > 1",
             "z-inv": "x = sqrt((ior - 1)/(ior + 1)), ior = (1 + x^2)/(1 - x^2), eta = 1/ior < 1",
             "openpbr": "index i < n/2: 1/ior = 1 + 1.5 (n/2 - 1 - i)/(n/2 - 1); i >= n/2: ior = 1 + 1.5 (i - n/2)/(n/2 - 1); "
                        "eta = ior"}
#: kind -> (quantities in canonical order, models)
KINDS_ND = {"albedo_avg": (("rough",), MODELS), "dielectric_avg": (("rough", "ior"), GLASS_MODELS),
            "dielectric": (("mu", "rough", "ior"), GLASS_MODELS)}
GLASS_MEANINGS = ("R", "T", "R+T", "1-(R+T)", "1-R")
AVG_MEANINGS = ("E_avg", "1-E_avg")


def meanings_of(kind: str) -> tuple:
    return AVG_MEANINGS if kind == "albedo_avg" else GLASS_MEANINGS


def _openpbr_ior(n: int) -> np.ndarray:
    half = n // 2
    i = np.arange(n, dtype=np.float64)
    d = max(half - 1, 1)  # n >= 4 on every checked axis
    out = 1.0 + 1.5 * (i - half) / d
    lo = i < half
    out[lo] = 1.0 / (1.0 + 1.5 * (half - 1 - i[lo]) / d)  # the denominator is >= 1 there
    return out


#: The spacing of an axis whose values the file's own header gives (a bsdf-tab file's claims).
FILE_SPACING = "file"


@dataclass(frozen=True)
class NDAxis:
    """One file axis under a hypothesis: quantity ``mu`` / ``rough`` / ``ior``, its name and spacing.

    ``given``: with spacing :data:`FILE_SPACING`, the axis' values as the file's header gives
    them, in the quantity's units (mu, alpha, eta)."""

    quantity: str
    name: str
    spacing: str
    nodes: str = "endpoints"
    reversed: bool = False
    given: tuple | None = None

    def positions(self, n: int) -> np.ndarray:
        u = NODE_TYPES[self.nodes][0](n)
        return u[::-1].copy() if self.reversed else u

    def values(self, n: int) -> np.ndarray:
        """mu (mu axes), alpha (the roughness slot) or eta (ior axes) of each file index."""
        if self.given is not None:  # the file's own values (its size was checked against n)
            return np.asarray(self.given, dtype=np.float64)
        if self.quantity == "ior":
            if self.spacing == "openpbr":
                v = _openpbr_ior(n)
                return v[::-1].copy() if self.reversed else v
            ior = eta_of_z(self.positions(n))
            return 1.0 / ior if self.spacing == "z-inv" else ior
        u = self.positions(n)
        if self.quantity == "mu":
            return np.clip(MU_SPACINGS[self.spacing](u), 0.0, 1.0)
        return ROUGH_MAPS[(self.name, self.spacing)](u)

    def axis_values(self, n: int) -> np.ndarray:
        """The axis' own values: mu, roughness, alpha or ior (not eta)."""
        v = self.values(n)
        if self.quantity == "ior":
            return 1.0 / v if self.spacing == "z-inv" else v
        if self.given is not None:
            return np.sqrt(v) if self.name == "roughness" else v
        return np.sqrt(v) if self.name == "roughness" else v

    @property
    def coordinate(self) -> str:
        if self.given is not None:
            unit = {"ior": "eta", "mu": "mu"}.get(self.quantity, self.name)
            return f"{unit} as the file's header gives it (a bsdf-tab file)"
        if self.quantity == "ior":
            return IOR_COORD[self.spacing]
        return MU_COORD[self.spacing] if self.quantity == "mu" else ROUGH_COORD[(self.name, self.spacing)]

    @property
    def label(self) -> str:
        return {"mu": "mu", "ior": "ior"}.get(self.quantity, self.name)

    def key(self) -> tuple:
        return (self.quantity, self.name, self.spacing, self.nodes, self.reversed)

    def geometry(self) -> tuple:
        return (self.quantity, self.name, self.spacing, self.reversed)


@dataclass(frozen=True)
class NDHypothesis:
    """A hypothesis of an N-D kind and its screening score."""

    kind: str
    axes: tuple  # NDAxis per file axis
    distribution: str = "ggx"
    shadowing: str = "correlated"
    encoding: str = "linear"
    meanings: tuple = ()
    errors: tuple = ()
    score: float = math.inf

    def geometry(self) -> tuple:
        return tuple(a.geometry() for a in self.axes)

    def by_quantity(self, q: str) -> int | None:
        for i, a in enumerate(self.axes):
            if a.quantity == q:
                return i
        return None

    @property
    def side(self) -> str | None:
        i = self.by_quantity("ior")
        if i is None:
            return None
        return {"z": "eta > 1 (eta = ior, light from outside)", "z-inv": "eta < 1 (eta = 1/ior, light from inside)",
                "openpbr": "eta = ior on both sides of 1 (0.4 .. 2.5)",
                FILE_SPACING: "eta as the file's header gives it"}[self.axes[i].spacing]


def predict(kind: str, values: dict) -> dict:
    """Meaning -> array in canonical axis order, from model values (``E_avg`` or ``R``, ``T``)."""
    if kind == "albedo_avg":
        return {"E_avg": values["E_avg"], "1-E_avg": 1.0 - values["E_avg"]}
    R, T = values["R"], values["T"]
    return {"R": R, "T": T, "R+T": R + T, "1-(R+T)": 1.0 - R - T, "1-R": 1.0 - R}


def model_values(kind: str, dist: str, shadow: str, nodes: dict) -> dict:
    """The spline candidates at ``nodes`` (quantity -> mu / alpha / eta values), canonical order."""
    if kind == "albedo_avg":
        return {"E_avg": albedo_avg_candidate(dist, shadow, nodes["rough"])}
    if kind == "dielectric_avg":
        return glass_avg(shadow, nodes["rough"], nodes["ior"])
    return glass_values(shadow, nodes["mu"], nodes["rough"], nodes["ior"])


def to_file_order(kind: str, hyp_axes, arrays: dict) -> dict:
    canon = KINDS_ND[kind][0]
    perm = [canon.index(a.quantity) for a in hyp_axes]
    return {k: np.transpose(v, perm) for k, v in arrays.items()}


_CLAIM_SLOTS = {"mu": ("mu", "mu"), "alpha": ("rough", "alpha"), "roughness": ("rough", "roughness"),
                "eta": ("ior", "ior")}


def claimed_axes(claims: dict, shape: tuple) -> list | None:
    """Per file axis, an :class:`NDAxis` with the values a bsdf-tab file's header claims
    (``claims["axes"]``: ``[[name, values], ...]``), or None where it claims nothing usable."""
    axes = claims.get("axes") if isinstance(claims, dict) else None
    if isinstance(axes, dict):
        axes = [[name, values] for name, values in axes.items()]
    if not isinstance(axes, list) or len(axes) != len(shape):
        return None
    out = []
    for item, n in zip(axes, shape):
        slot = _CLAIM_SLOTS.get(item[0]) if isinstance(item, list) and len(item) == 2 else None
        try:
            values = np.asarray(item[1], dtype=np.float64) if slot else None
        except (TypeError, ValueError):  # malformed claims are no claims
            values = None
        if values is None or values.shape != (n,) or not np.isfinite(values).all():
            out.append(None)
            continue
        if slot[1] == "roughness":
            values = values**2  # the roughness slot's quantity is alpha = roughness^2
        out.append(NDAxis(slot[0], slot[1], FILE_SPACING, given=tuple(float(v) for v in values)))
    return out if any(a is not None for a in out) else None


TRIM = 0.05


def _trimmed(diff: np.ndarray) -> np.ndarray:
    n = diff.shape[1]
    k = max(int(n * (1.0 - TRIM)), 1)
    if k >= n:
        return diff.mean(axis=1)
    return np.partition(diff, k - 1, axis=1)[:, :k].mean(axis=1)


class _Scorer:
    """Scores hypotheses on the screened texels, caching the model per (model, axis nodes)."""

    def __init__(self, kind: str, data: np.ndarray, active: list[int], screen: int):
        self.kind, self.active = kind, active
        self.shape = data.shape[:-1]
        self.idx = [even_indices(n, screen) for n in self.shape]
        sub = data[np.ix_(*self.idx)]
        self.encoded = {}
        for enc, d in encodings(sub).items():
            finite = np.isfinite(d)
            self.encoded[enc] = (np.where(finite, d, 0.0), None if finite.all() else finite)
        self._cache: dict = {}

    def _pred(self, h: NDHypothesis) -> dict:
        # each axis' nodes depend on the size of the file axis it sits on: the key pairs the two
        # (sorted: the same quantities on the same axes in another order share the prediction)
        key = (h.distribution, h.shadowing) + tuple(sorted((a.key(), n) for a, n in zip(h.axes, self.shape)))
        if key not in self._cache:
            nodes = {a.quantity: a.values(n)[i] for a, n, i in zip(h.axes, self.shape, self.idx)}
            self._cache[key] = predict(self.kind, model_values(self.kind, h.distribution, h.shadowing, nodes))
        return to_file_order(self.kind, h.axes, self._cache[key])

    def score(self, h: NDHypothesis, encs=None) -> NDHypothesis:
        pred = self._pred(h)
        names = list(pred)
        stack = np.stack([pred[m] for m in names])
        best = None
        for enc, (d, mask) in (encs or self.encoded).items():
            total, meanings, errors = 0.0, [], []
            for c in self.active:
                diff = np.abs(d[None, ..., c] - stack).reshape(len(names), -1)
                if mask is not None:
                    diff = diff[:, mask[..., c].ravel()]
                errs = _trimmed(diff)
                k = int(np.argmin(errs))
                total += float(errs[k])
                meanings.append(names[k])
                errors.append(float(errs[k]))
            if best is None or total < best[0]:
                best = (total, enc, tuple(meanings), tuple(errors))
        total, enc, meanings, errors = best
        return replace(h, encoding=enc, meanings=meanings, errors=errors, score=total / max(len(self.active), 1))


def _variants(quantity: str, nodes_set, claimed: NDAxis | None = None) -> list[NDAxis]:
    if claimed is not None and claimed.quantity == quantity:  # a bsdf-tab file: its own axis values too
        return [claimed] + _variants(quantity, nodes_set)
    if quantity == "ior":
        out = []
        for sp in IOR_SPACINGS:
            for rev in (False, True):
                for nodes in (("endpoints",) if sp == "openpbr" else nodes_set):
                    out.append(NDAxis("ior", "ior", sp, nodes, rev))
        return out
    maps = [("mu", s) for s in MU_SPACINGS] if quantity == "mu" else list(ROUGH_MAPS)
    return [NDAxis(quantity, name, sp, nodes, rev) for name, sp in maps for nodes in nodes_set for rev in (False, True)]


def _descend(scorer: _Scorer, h: NDHypothesis, encs, passes: int = 2) -> list[NDHypothesis]:
    """Node conventions axis by axis (coordinate descent); every hypothesis scored on the way."""
    seen = {}
    cur = scorer.score(h, encs)
    seen[tuple(a.nodes for a in cur.axes)] = cur
    for _ in range(passes):
        for k, a in enumerate(cur.axes):
            if a.spacing in ("openpbr", FILE_SPACING):  # index-based or given: no node convention to choose
                continue
            for nodes in NODE_TYPES:
                axes = list(cur.axes)
                axes[k] = replace(a, nodes=nodes)
                key = tuple(x.nodes for x in axes)
                if key not in seen:
                    seen[key] = scorer.score(replace(cur, axes=tuple(axes)), encs)
            cur = min((v for v in seen.values()), key=lambda x: x.score)
    return list(seen.values())


def search_nd(kind: str, data: np.ndarray, active: list[int], keep: int = 3,
              claimed: list | None = None) -> list[NDHypothesis]:
    """Rank the hypotheses of ``kind`` for ``data`` (axes..., channels); best first.

    Parameters
    ----------
    kind : str
        ``albedo_avg``, ``dielectric_avg`` or ``dielectric`` (:data:`KINDS_ND`).
    data : numpy.ndarray
        The table, shape (n_0, ..., channels) with as many axes as the kind has quantities.
    active : list of int
        The non-constant channels.
    keep : int
        Geometries carried to the fine stage.
    claimed : list, optional
        Per file axis, an :class:`NDAxis` with the file's own values (:func:`claimed_axes`) or
        None: tried besides the spacings (a bsdf-tab file's linear eta axis has none of them).
    """
    quantities, models = KINDS_ND[kind]
    ndim = data.ndim - 1
    if ndim != len(quantities):
        raise ValueError(f"{kind} has {len(quantities)} axes, the data {ndim}")
    scorer = _Scorer(kind, data, active, screen=10 if ndim == 3 else 32)
    coarse_nodes = ("endpoints",) if ndim == 3 else ("endpoints", "centers")
    coarse = []
    claimed = claimed if claimed is not None and len(claimed) == ndim else [None] * ndim
    for perm in itertools.permutations(quantities):
        for combo in itertools.product(*[_variants(q, coarse_nodes, c) for q, c in zip(perm, claimed)]):
            for dist, shadow in models:  # every model: separable and correlated differ by up to 0.9 inside glass
                coarse.append(scorer.score(NDHypothesis(kind, tuple(combo), dist, shadow)))
    coarse.sort(key=lambda h: h.score)
    geometries, bases = [], []
    for h in coarse:
        if h.geometry() not in geometries:
            geometries.append(h.geometry())
            bases.append(h)
        if len(geometries) == keep:
            break
    encs = {e: scorer.encoded[e] for e in dict.fromkeys([coarse[0].encoding, "linear"])}
    fine = []
    for base in bases:
        for d, s in models:
            fine += _descend(scorer, replace(base, distribution=d, shadowing=s), encs)
    fine.sort(key=lambda h: h.score)
    return fine

