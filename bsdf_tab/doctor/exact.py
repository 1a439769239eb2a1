"""Exact candidate tables: baked once per model, cached, and read at any nodes.

A candidate is a split-sum ``dfg`` table (A, B; E = A + B is the albedo with F = 1) of one
model (GGX or Beckmann, separable or height-correlated shadowing) on a 33 x 33 grid uniform in
``sqrt(mu)`` and ``sqrt(alpha)``, baked through :func:`bsdf_tab.api.tabulate` (adaptive,
tolerance 1e-6) and kept in memory and on disk (``$BSDF_TAB_DOCTOR_CACHE``, default
``~/.cache/bsdf_tab/doctor``; one ``.npz`` per model and package version). It is read at a
hypothesis' nodes by a bicubic not-a-knot spline (numpy; mean error ~1e-6, worst ~5e-4 next
to alpha = 0): good enough to rank hypotheses. The winner is then checked against :func:`exact_at`, the model
baked at the file's own nodes.
"""

from __future__ import annotations

import io
import os
from functools import lru_cache
from pathlib import Path

import numpy as np

from ..api import tabulate
from ..io import write_bytes
from ..version import __version__
from .schlick import dfg_quadrature

__all__ = ["CACHE_ENV", "FIT_MODELS", "GRID", "MODELS", "Candidate", "cache_dir", "candidate", "cubic_basis",
           "exact_at"]

#: (distribution, shadowing) pairs bsdf-tab's integrators bake (1-D averages use these).
MODELS = (("ggx", "correlated"), ("ggx", "separable"), ("beckmann", "correlated"), ("beckmann", "separable"))
#: the pairs 2-D LUTs are fitted against: and GGX with Schlick-GGX shadowing (k = alpha / 2), the
#: approximation of Karis' UE4 notes, learnopengl.com and Godot, by the doctor's own quadrature
#: (:mod:`.schlick`)
FIT_MODELS = MODELS + (("ggx", "schlick"),)
GRID = 33
TOLERANCE = 1e-6
CACHE_ENV = "BSDF_TAB_DOCTOR_CACHE"
_MEMORY: dict = {}


def cache_dir() -> Path:
    """Where candidate tables are cached on disk."""
    return Path(os.environ.get(CACHE_ENV) or Path.home() / ".cache" / "bsdf_tab" / "doctor")


@lru_cache(maxsize=8)
def _second_derivative_operator(n: int, h: float) -> np.ndarray:
    """S with M = S y: the second derivatives of the not-a-knot cubic spline through y on a uniform grid."""
    A = np.zeros((n, n))
    D = np.zeros((n, n))
    for i in range(1, n - 1):
        A[i, i - 1:i + 2] = (1.0, 4.0, 1.0)
        D[i, i - 1:i + 2] = np.array([1.0, -2.0, 1.0]) * 6.0 / h**2
    A[0, :3] = (1.0, -2.0, 1.0)  # not-a-knot: the third derivative is continuous at x_1 and x_{n-2}
    A[-1, -3:] = (1.0, -2.0, 1.0)
    return np.linalg.solve(A, D)


def cubic_basis(n: int, x: np.ndarray) -> np.ndarray:
    """B with f(x) = B @ y: the not-a-knot cubic spline through y on n uniform nodes of [0, 1], at x."""
    h = 1.0 / (n - 1)
    x = np.clip(np.asarray(x, dtype=np.float64), 0.0, 1.0)
    i = np.clip(np.floor(x / h).astype(int), 0, n - 2)
    t = x / h - i
    rows = np.arange(x.size)
    lin = np.zeros((x.size, n))
    lin[rows, i] = 1.0 - t
    lin[rows, i + 1] += t
    cub = np.zeros((x.size, n))
    cub[rows, i] = h**2 / 6.0 * ((1.0 - t) ** 3 - (1.0 - t))
    cub[rows, i + 1] += h**2 / 6.0 * (t**3 - t)
    return lin + cub @ _second_derivative_operator(n, h)


class Candidate:
    """One model's exact split-sum table, read at any (mu, alpha) nodes by a bicubic spline.

    Parameters
    ----------
    distribution, shadowing : str
        The model.
    A, B : numpy.ndarray
        The channels on the grid ``mu = s^2``, ``alpha = r^2``, s and r uniform on [0, 1].
    """

    def __init__(self, distribution: str, shadowing: str, A: np.ndarray, B: np.ndarray):
        self.distribution, self.shadowing = distribution, shadowing
        self._channels = {"A": np.asarray(A, dtype=np.float64), "B": np.asarray(B, dtype=np.float64)}
        self._n = self._channels["A"].shape[0]

    def values(self, mu: np.ndarray, alpha: np.ndarray) -> dict[str, np.ndarray]:
        """``A``, ``B`` and ``E`` on the grid ``mu x alpha`` (any order of nodes), shape (len(mu), len(alpha))."""
        s = np.sqrt(np.clip(np.asarray(mu, dtype=np.float64), 0.0, 1.0))
        r = np.sqrt(np.clip(np.asarray(alpha, dtype=np.float64), 0.0, 1.0))
        bs, br = cubic_basis(self._n, s), cubic_basis(self._n, r)
        out = {c: bs @ v @ br.T for c, v in self._channels.items()}
        out["E"] = out["A"] + out["B"]
        return out


def _bake(distribution: str, shadowing: str) -> tuple[np.ndarray, np.ndarray]:
    g = np.linspace(0.0, 1.0, GRID)
    if shadowing == "schlick":
        return dfg_quadrature(g**2, g**2)
    nodes = [float(x) for x in g**2]
    t = tabulate({"table": "dfg", "distribution": distribution, "shadowing": shadowing, "tolerance": TOLERANCE,
                  "axes": {"mu": nodes, "alpha": nodes}})
    return np.asarray(t.channels["A"]), np.asarray(t.channels["B"])


def candidate(distribution: str, shadowing: str) -> Candidate:
    """The cached candidate of a model (baked on first use, a few seconds)."""
    key = (distribution, shadowing)
    if key in _MEMORY:
        return _MEMORY[key]
    path = cache_dir() / f"dfg_{distribution}_{shadowing}_{GRID}_v{__version__}.npz"
    A = B = None
    if path.is_file():
        try:
            with np.load(path) as z:
                A, B = z["A"], z["B"]
        except (OSError, ValueError, KeyError):
            A = B = None
    if A is None or A.shape != (GRID, GRID):
        A, B = _bake(distribution, shadowing)
        buf = io.BytesIO()
        np.savez(buf, A=A, B=B)
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            write_bytes(path, buf.getvalue())
        except OSError:  # a read-only home: keep it in memory only
            pass
    _MEMORY[key] = Candidate(distribution, shadowing, A, B)
    return _MEMORY[key]


def exact_at(distribution: str, shadowing: str, mu, alpha) -> dict[str, np.ndarray]:
    """The model baked at exactly these nodes (any order, repeats allowed): A, B, E of shape (len(mu), len(alpha))."""
    mu, alpha = np.asarray(mu, dtype=np.float64), np.asarray(alpha, dtype=np.float64)
    um, im = np.unique(np.clip(mu, 0.0, 1.0), return_inverse=True)
    ua, ia = np.unique(np.clip(alpha, 0.0, 4.0), return_inverse=True)
    if shadowing == "schlick":
        A, B = dfg_quadrature(um, ua, n_u=128, n_phi=64)
        out = {"A": A[np.ix_(im, ia)], "B": B[np.ix_(im, ia)]}
        out["E"] = out["A"] + out["B"]
        return out
    t = tabulate({"table": "dfg", "distribution": distribution, "shadowing": shadowing, "tolerance": TOLERANCE,
                  "axes": {"mu": [float(x) for x in um], "alpha": [float(x) for x in ua]}})
    out = {c: np.asarray(t.channels[c], dtype=np.float64)[np.ix_(im, ia)] for c in ("A", "B")}
    out["E"] = out["A"] + out["B"]
    return out
