"""The hypotheses a LUT is fitted against, and the search over them.

A hypothesis says, for a 2-D LUT of shape (rows, columns[, channels]):

- which file axis is ``mu`` (cos theta_v) and which the roughness slot;
- the mu axis' texture coordinate x: ``linear`` (x = mu), ``sqrt`` (x = sqrt(mu), Unity),
  ``sqrt(1-mu)`` (mu = 1 - x^2, the Heitz LTC fit) or ``theta`` (x = theta / (pi/2));
- the roughness slot: ``roughness`` (alpha = x^2), ``alpha`` (alpha = x), or roughness with
  ``sqrt`` spacing (x = sqrt(roughness), alpha = x^4);
- the nodes along each axis: ``endpoints`` x_i = i/(n-1), ``centers`` (i + 1/2)/n, ``left``
  i/n, ``right`` (i + 1)/n, an endpoints grid shifted by +-1/2 or +-1 texel, or a centres grid
  shifted by +-1 texel (clamped to [0, 1]); and whether the axis runs reversed (x_{n-1-i});
- the model (GGX / Beckmann, separable / correlated), the encoding of the values (``linear``;
  ``srgb``: the file holds sRGB-encoded values; ``srgb-decoded``: the values went through an
  sRGB decode), and for each file channel its meaning: ``E`` (albedo, F = 1), ``1-E`` (energy
  complement), ``A`` / ``B`` (split-sum scale / bias), or a constant.

The score of a hypothesis is the mean absolute difference over the non-constant channels. The
search is staged: every geometry with endpoints / centres nodes under GGX-correlated, then the
best few geometries with every node convention and every model (:func:`search`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from .exact import FIT_MODELS, candidate
from .readers import srgb_decode, srgb_encode

__all__ = ["AxisHyp", "Hypothesis", "MEANINGS", "MU_SPACINGS", "NODE_FORMULA", "NODE_TYPES", "ROUGH_MAPS", "encodings", "even_indices",
           "search"]

MU_SPACINGS = {
    "linear": lambda u: u,
    "sqrt": lambda u: u * u,
    "sqrt(1-mu)": lambda u: 1.0 - u * u,
    "theta": lambda u: np.cos(u * (math.pi / 2.0)),
}
MU_COORD = {"linear": "x = mu", "sqrt": "x = sqrt(mu)", "sqrt(1-mu)": "x = sqrt(1 - mu)",
            "theta": "x = acos(mu) / (pi / 2)"}
#: (axis name, spacing) -> alpha(x)
ROUGH_MAPS = {
    ("roughness", "linear"): lambda u: u * u,
    ("alpha", "linear"): lambda u: u,
    ("roughness", "sqrt"): lambda u: u**4,
}
ROUGH_COORD = {("roughness", "linear"): "x = roughness, alpha = x^2", ("alpha", "linear"): "x = alpha",
               ("roughness", "sqrt"): "x = sqrt(roughness), alpha = x^4"}

#: node convention -> (positions(n), texel offset from the endpoints grid)
NODE_TYPES = {
    "endpoints": (lambda n: np.arange(n) / max(n - 1, 1), 0.0),
    "centers": (lambda n: (np.arange(n) + 0.5) / n, None),
    "left": (lambda n: np.arange(n) / n, None),
    "right": (lambda n: (np.arange(n) + 1.0) / n, None),
    "endpoints+0.5": (lambda n: np.clip((np.arange(n) + 0.5) / max(n - 1, 1), 0, 1), 0.5),
    "endpoints-0.5": (lambda n: np.clip((np.arange(n) - 0.5) / max(n - 1, 1), 0, 1), -0.5),
    "endpoints+1": (lambda n: np.clip((np.arange(n) + 1.0) / max(n - 1, 1), 0, 1), 1.0),
    "endpoints-1": (lambda n: np.clip((np.arange(n) - 1.0) / max(n - 1, 1), 0, 1), -1.0),
    "centers+1": (lambda n: np.clip((np.arange(n) + 1.5) / n, 0, 1), 1.0),
    "centers-1": (lambda n: np.clip((np.arange(n) - 0.5) / n, 0, 1), -1.0),
}
#: where node i of a shifted grid sits (the findings' words)
NODE_FORMULA = {"endpoints+0.5": "(i + 1/2) / (n - 1)", "endpoints-0.5": "(i - 1/2) / (n - 1)",
                "endpoints+1": "(i + 1) / (n - 1)", "endpoints-1": "(i - 1) / (n - 1)",
                "centers+1": "(i + 3/2) / n (the centre of texel i + 1)", "centers-1": "(i - 1/2) / n (the centre of texel i - 1)"}
COARSE_NODES = ("endpoints", "centers")
COARSE_MODELS = (("ggx", "correlated"), ("ggx", "schlick"))  # the two far apart: both pick geometries
MEANINGS = ("E", "1-E", "A", "B")
ENCODINGS = ("linear", "srgb", "srgb-decoded")


@dataclass(frozen=True)
class AxisHyp:
    """One file axis under a hypothesis (see the module docstring)."""

    quantity: str  # "mu" or "rough"
    name: str  # "mu", "roughness", "alpha"
    spacing: str
    nodes: str = "endpoints"
    reversed: bool = False

    def positions(self, n: int) -> np.ndarray:
        """Texture coordinate x of each file index."""
        u = NODE_TYPES[self.nodes][0](n)
        return u[::-1].copy() if self.reversed else u

    def values(self, n: int) -> np.ndarray:
        """mu (mu axes) or alpha (roughness slot) of each file index."""
        u = self.positions(n)
        if self.quantity == "mu":
            return np.clip(MU_SPACINGS[self.spacing](u), 0.0, 1.0)
        return ROUGH_MAPS[(self.name, self.spacing)](u)

    def axis_values(self, n: int) -> np.ndarray:
        """The axis' own values (mu, roughness or alpha) of each file index."""
        v = self.values(n)
        return np.sqrt(v) if self.name == "roughness" else v

    @property
    def coordinate(self) -> str:
        return MU_COORD[self.spacing] if self.quantity == "mu" else ROUGH_COORD[(self.name, self.spacing)]

    def geometry(self) -> tuple:
        return (self.quantity, self.name, self.spacing, self.reversed)


@dataclass(frozen=True)
class Hypothesis:
    """A full hypothesis and its screening score."""

    rows: AxisHyp
    cols: AxisHyp
    distribution: str = "ggx"
    shadowing: str = "correlated"
    encoding: str = "linear"
    meanings: tuple = ()
    errors: tuple = ()  # mean abs error per channel (screening)
    score: float = math.inf

    @property
    def mu_axis(self) -> AxisHyp:
        return self.rows if self.rows.quantity == "mu" else self.cols

    @property
    def rough_axis(self) -> AxisHyp:
        return self.cols if self.rows.quantity == "mu" else self.rows

    def geometry(self) -> tuple:
        return (self.rows.geometry(), self.cols.geometry())

    def predict(self, pred: dict, shape: tuple[int, int]) -> dict:
        """Channel predictions in file layout from model values on (mu nodes x alpha nodes)."""
        out = {"E": pred["E"], "1-E": 1.0 - pred["E"], "A": pred["A"], "B": pred["B"]}
        if self.rows.quantity != "mu":
            out = {k: v.T for k, v in out.items()}
        return out


def encodings(data: np.ndarray) -> dict[str, np.ndarray]:
    """The table each encoding hypothesis says the file holds (only ``linear`` outside [0, 1])."""
    out = {"linear": data}
    finite = data[np.isfinite(data)]
    if finite.size and finite.min() >= -1e-6 and finite.max() <= 1.0 + 1e-6:
        out["srgb"] = srgb_decode(data)
        out["srgb-decoded"] = srgb_encode(data)
    return out


def _model_values(dist: str, shadow: str, h_rows: AxisHyp, h_cols: AxisHyp, shape, rows_idx, cols_idx) -> dict:
    """The model on the hypothesis' nodes of the screened rows and columns, as (mu nodes x alpha nodes)."""
    H, W = shape
    if h_rows.quantity == "mu":
        return candidate(dist, shadow).values(h_rows.values(H)[rows_idx], h_cols.values(W)[cols_idx])
    return candidate(dist, shadow).values(h_cols.values(W)[cols_idx], h_rows.values(H)[rows_idx])


def even_indices(n: int, most: int) -> np.ndarray:
    """All of ``range(n)`` up to ``most``, else ``most`` evenly spread indices (both ends included)."""
    if n <= most:
        return np.arange(n)
    return np.unique(np.round(np.linspace(0, n - 1, most)).astype(int))


TRIM = 0.05


def _trimmed_mean(diff: np.ndarray) -> np.ndarray:
    """Mean of each row without its largest ``TRIM`` share: an end row stored by a convention of its
    own (a clamp, a limit not taken) does not decide the geometry; a shift of every texel does."""
    n = diff.shape[1]
    k = max(int(n * (1.0 - TRIM)), 1)
    if k >= n:
        return diff.mean(axis=1)
    return np.partition(diff, k - 1, axis=1)[:, :k].mean(axis=1)


def _score(hyp: Hypothesis, encoded: dict, active: list[int], shape, idx) -> Hypothesis:
    pred = hyp.predict(_model_values(hyp.distribution, hyp.shadowing, hyp.rows, hyp.cols, shape, *idx), shape)
    names = list(pred)
    stack = np.stack([pred[m] for m in names])  # (meanings, H, W)
    best = None
    for enc, (d, mask) in encoded.items():
        total, meanings, errors = 0.0, [], []
        for c in active:
            diff = np.abs(d[None, :, :, c] - stack).reshape(len(names), -1)
            if mask is not None:
                diff = diff[:, mask[:, :, c].ravel()]
            errs = _trimmed_mean(diff)
            k = int(np.argmin(errs))
            total += float(errs[k])
            meanings.append(names[k])
            errors.append(float(errs[k]))
        if best is None or total < best[0]:
            best = (total, enc, tuple(meanings), tuple(errors))
    total, enc, meanings, errors = best
    return replace(hyp, encoding=enc, meanings=meanings, errors=errors, score=total / max(len(active), 1))


def _axis_variants(quantity: str, nodes_set) -> list[AxisHyp]:
    maps = [("mu", s) for s in MU_SPACINGS] if quantity == "mu" else list(ROUGH_MAPS)
    return [AxisHyp(quantity, name, spacing, nodes, rev)
            for name, spacing in maps for nodes in nodes_set for rev in (False, True)]


def _prepared(data: np.ndarray) -> dict:
    """Each encoding's table, with a mask of finite texels (None when all are finite)."""
    out = {}
    for enc, d in encodings(data).items():
        finite = np.isfinite(d)
        out[enc] = (np.where(finite, d, 0.0), None if finite.all() else finite)
    return out


def search(data: np.ndarray, active: list[int], keep: int = 3, screen: int = 32) -> list[Hypothesis]:
    """Rank the hypotheses for ``data`` (rows, columns, channels); best first.

    Stages: (1) every geometry (orientation, spacings, reversal) with endpoints / centres
    nodes, GGX-correlated; (2) the ``keep`` best geometries with every node
    convention and every model, under the encoding the coarse stage chose (and linear). Scores
    are trimmed means (:func:`_trimmed_mean`).

    Parameters
    ----------
    data : numpy.ndarray
        The LUT, shape (H, W, C).
    active : list of int
        The non-constant channels (the others are not scored).
    keep : int
        Geometries carried from the coarse stage to the fine one.
    screen : int
        Rows and columns screened at most (evenly spread; a hypothesis' nodes are those of the
        full axis, so a half-texel shift of a 256-node axis is still a shift).
    Returns
    -------
    list of Hypothesis
        The hypotheses of the fine stage, by score.
    """
    H, W, _ = data.shape
    idx = (even_indices(H, screen), even_indices(W, screen))
    encoded = _prepared(data[np.ix_(idx[0], idx[1])])

    def scored(hyps, encs=encoded):
        return sorted((_score(h, encs, active, (H, W), idx) for h in hyps), key=lambda h: h.score)

    coarse = []
    for mu_rows in (True, False):
        for m in _axis_variants("mu", COARSE_NODES):
            for r in _axis_variants("rough", COARSE_NODES):
                for dist, shadow in COARSE_MODELS:
                    coarse.append(Hypothesis(*((m, r) if mu_rows else (r, m)), dist, shadow))
    coarse = scored(coarse)
    geometries = []
    for h in coarse:
        if h.geometry() not in geometries:
            geometries.append(h.geometry())
        if len(geometries) == keep:
            break
    fine = []
    for g in geometries:
        base = next(h for h in coarse if h.geometry() == g)
        fine += [Hypothesis(replace(base.rows, nodes=rn), replace(base.cols, nodes=cn), dist, shadow)
                 for rn in NODE_TYPES for cn in NODE_TYPES for dist, shadow in FIT_MODELS]
    encs = {e: encoded[e] for e in dict.fromkeys([coarse[0].encoding, "linear"])}  # the coarse stage decides it
    return scored(fine, encs)
