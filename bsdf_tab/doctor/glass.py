"""Exact candidates of the doctor's 1-D and 3-D kinds: albedo averages and rough-dielectric R, T.

- :class:`GlassCandidate`: one GGX dielectric table (R, T) per shadowing mode and side
  (``eta > 1``: light from outside; ``eta < 1``: from inside), on a small grid uniform in
  ``s = sqrt(mu)``, ``r = sqrt(alpha)`` and ``z`` with ``eta = (1 + z^2) / (1 - z^2)``
  (or its reciprocal), z in [1e-3, 0.99]; read at any nodes by a tricubic spline. Baked
  through :func:`bsdf_tab.api.tabulate` (adaptive, tolerance 1e-5: a few seconds each on 2
  cores) and cached in memory and on disk like the split-sum candidates (:mod:`.exact`).
- :func:`glass_avg`: the mu-weighted averages ``2 int X(mu) mu dmu`` of a candidate
  (Gauss-Legendre in s over the spline), and :func:`albedo_avg_candidate` the same of the
  split-sum candidate's E.
- :func:`glass_exact_at`, :func:`glass_avg_exact_at`, :func:`albedo_avg_exact_at`: the model
  baked at exactly given nodes (the exact check of the winner).
"""

from __future__ import annotations

import io

import numpy as np

from ..api import tabulate
from ..io import write_bytes
from ..version import __version__
from .exact import cache_dir, candidate, cubic_basis

__all__ = ["GLASS_MODELS", "GlassCandidate", "Z_MAX", "albedo_avg_candidate", "albedo_avg_exact_at",
           "eta_of_z", "glass_avg", "glass_candidate", "glass_exact_at", "glass_avg_exact_at", "z_of_eta"]

GRID = (13, 13, 11)  # s (mu = s^2), r (alpha = r^2), z
Z_MIN, Z_MAX = 1e-3, 0.99
TOLERANCE = 1e-5
GLASS_MODELS = (("ggx", "correlated"), ("ggx", "separable"))
_MEMORY: dict = {}
_GL_S, _GL_W = np.polynomial.legendre.leggauss(48)
_GL_S = 0.5 * (_GL_S + 1.0)  # nodes in s on [0, 1]
_GL_W = 0.5 * _GL_W


def eta_of_z(z):
    """ior = (1 + z^2) / (1 - z^2) (Cycles' z axis, EEVEE's x = sqrt((ior - 1)/(ior + 1))); z clamped to
    [1e-4, 0.99] as Cycles does (ior = 1 exactly is the invisible interface, R + T = 1, not the
    microfacet limit ior -> 1, which is below 1 at grazing angles)."""
    z2 = np.clip(np.asarray(z, dtype=np.float64), 1e-4, Z_MAX) ** 2
    return (1.0 + z2) / (1.0 - z2)  # z2 <= 0.98: no division by zero


def z_of_eta(ior):
    """The inverse of :func:`eta_of_z` for ior >= 1 (ior < 1 is read as 1 / ior)."""
    ior = np.asarray(ior, dtype=np.float64)
    ior = np.where(ior < 1.0, 1.0 / np.maximum(ior, 1e-12), ior)  # guard: ior > 0 on every doctor axis
    return np.sqrt(np.clip((ior - 1.0) / (ior + 1.0), 0.0, 1.0))


def _unit(x, lo=0.0, hi=1.0):
    return np.clip((np.asarray(x, dtype=np.float64) - lo) / (hi - lo), 0.0, 1.0)


class GlassCandidate:
    """R and T of one model and side on the (s, r, z) grid; :meth:`values` reads it anywhere."""

    def __init__(self, shadowing: str, inside: bool, R: np.ndarray, T: np.ndarray):
        self.shadowing, self.inside = shadowing, inside
        self._grid = {"R": np.asarray(R, dtype=np.float64), "T": np.asarray(T, dtype=np.float64)}

    def values(self, mu, alpha, ior) -> dict:
        """``R``, ``T`` on the grid mu x alpha x ior (shape (len(mu), len(alpha), len(ior))); ior is
        the axis value >= 1 (the side is the candidate's)."""
        n_s, n_r, n_z = GRID
        bs = cubic_basis(n_s, np.sqrt(np.clip(mu, 0.0, 1.0)))
        br = cubic_basis(n_r, np.sqrt(np.clip(alpha, 0.0, 1.0)))
        bz = cubic_basis(n_z, _unit(z_of_eta(ior), Z_MIN, Z_MAX))
        return {c: np.einsum("ia,jb,kc,abc->ijk", bs, br, bz, g, optimize=True) for c, g in self._grid.items()}


def _eta_nodes(inside: bool) -> np.ndarray:
    eta = eta_of_z(np.linspace(Z_MIN, Z_MAX, GRID[2]))
    return np.sort(1.0 / eta) if inside else eta


def _bake_glass(shadowing: str, inside: bool):
    s, r = np.linspace(0.0, 1.0, GRID[0]), np.linspace(0.0, 1.0, GRID[1])
    t = tabulate({"table": "dielectric", "distribution": "ggx", "shadowing": shadowing, "tolerance": TOLERANCE,
                  "axes": {"mu": [float(x) for x in s**2], "alpha": [float(x) for x in r**2],
                           "eta": [float(x) for x in _eta_nodes(inside)]}})
    R, T = np.asarray(t.channels["R"]), np.asarray(t.channels["T"])
    if inside:  # the eta axis increased, so z decreased: put it back in z order
        R, T = R[:, :, ::-1], T[:, :, ::-1]
    return R, T


def glass_candidate(shadowing: str, inside: bool) -> GlassCandidate:
    """The cached dielectric candidate (baked on first use, a few seconds)."""
    key = ("glass", shadowing, inside)
    if key in _MEMORY:
        return _MEMORY[key]
    side = "inside" if inside else "outside"
    path = cache_dir() / f"glass_ggx_{shadowing}_{side}_{'x'.join(map(str, GRID))}_v{__version__}.npz"
    R = T = None
    if path.is_file():
        try:
            with np.load(path) as z:
                R, T = z["R"], z["T"]
        except (OSError, ValueError, KeyError):
            R = T = None
    if R is None or R.shape != GRID:
        R, T = _bake_glass(shadowing, inside)
        buf = io.BytesIO()
        np.savez(buf, R=R, T=T)
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            write_bytes(path, buf.getvalue())
        except OSError:  # a read-only home: keep it in memory only
            pass
    _MEMORY[key] = GlassCandidate(shadowing, inside, R, T)
    return _MEMORY[key]


def glass_values(shadowing: str, mu, alpha, eta) -> dict:
    """R, T of the spline candidates at mu x alpha x eta, any eta (each node from its side's candidate)."""
    eta = np.asarray(eta, dtype=np.float64)
    out = {c: np.zeros((len(mu), len(alpha), len(eta))) for c in ("R", "T")}
    for inside, sel in ((False, eta >= 1.0), (True, eta < 1.0)):
        if sel.any():
            v = glass_candidate(shadowing, inside).values(mu, alpha, eta[sel])
            for c in out:
                out[c][:, :, sel] = v[c]
    return out


def glass_avg(shadowing: str, alpha, eta) -> dict:
    """R_avg, T_avg = 2 int X(mu) mu dmu of the spline candidates, shape (len(alpha), len(eta))."""
    v = glass_values(shadowing, _GL_S**2, alpha, eta)
    w = 4.0 * _GL_W * _GL_S**3  # mu = s^2: 2 mu dmu = 4 s^3 ds
    return {c: np.tensordot(w, x, axes=(0, 0)) for c, x in v.items()}


def albedo_avg_candidate(distribution: str, shadowing: str, alpha) -> np.ndarray:
    """E_avg(alpha) of the split-sum candidate (Gauss-Legendre in s over its spline)."""
    e = candidate(distribution, shadowing).values(_GL_S**2, np.asarray(alpha, dtype=np.float64))["E"]
    return np.tensordot(4.0 * _GL_W * _GL_S**3, e, axes=(0, 0))


def _spec_nodes(values, lo: float, hi: float):
    v = np.clip(np.asarray(values, dtype=np.float64), lo, hi)
    u, inv = np.unique(v, return_inverse=True)
    return [float(x) for x in u], inv


def glass_exact_at(shadowing: str, mu, alpha, eta) -> dict:
    """R, T baked at exactly these nodes (any order; eta on both sides allowed), shape (mu, alpha, eta)."""
    um, im = _spec_nodes(mu, 0.0, 1.0)
    ua, ia = _spec_nodes(alpha, 0.0, 4.0)
    ue, ie = _spec_nodes(eta, 1e-6, 100.0)
    t = tabulate({"table": "dielectric", "distribution": "ggx", "shadowing": shadowing, "tolerance": 1e-6,
                  "axes": {"mu": um, "alpha": ua, "eta": ue}})
    return {c: np.asarray(t.channels[c], dtype=np.float64)[np.ix_(im, ia, ie)] for c in ("R", "T")}


_G8, _W8 = np.polynomial.legendre.leggauss(8)
AVG_RULE = ("Gauss-Legendre in sqrt(mu), 4 panels x 8 nodes, split at the critical angle for eta < 1, "
            "over the exact table")


def _avg_rule(eta: float) -> tuple[np.ndarray, np.ndarray]:
    """Nodes s and weights of 2 int X mu dmu = 4 int X s^3 ds, mu = s^2; panels split at the
    critical angle sqrt(1 - eta^2) when eta < 1 (R has a kink there)."""
    cuts = [0.0, 0.25, 0.5, 0.75, 1.0]
    if eta < 1.0:
        sc = float(np.sqrt(np.sqrt(1.0 - eta * eta)))  # s of the critical cosine
        cuts = sorted(set([0.0, 0.5 * sc, sc, 0.5 * (sc + 1.0), 1.0]))
    s = np.concatenate([a + (b - a) * 0.5 * (_G8 + 1.0) for a, b in zip(cuts[:-1], cuts[1:])])
    w = np.concatenate([(b - a) * 0.5 * _W8 for a, b in zip(cuts[:-1], cuts[1:])])
    return s, 4.0 * w * s**3


def glass_avg_exact_at(shadowing: str, alpha, eta) -> dict:
    """R_avg, T_avg at these nodes from the exact table on the quadrature nodes in mu (:data:`AVG_RULE`)."""
    eta = np.asarray(eta, dtype=np.float64)
    out = {c: np.zeros((len(alpha), len(eta))) for c in ("R", "T")}
    for e in np.unique(eta):
        s, w = _avg_rule(float(e))
        v = glass_exact_at(shadowing, s**2, alpha, [float(e)])
        for c in out:
            out[c][:, eta == e] = np.tensordot(w, v[c][:, :, 0], axes=(0, 0))[:, None]
    return out


def albedo_avg_exact_at(distribution: str, shadowing: str, alpha) -> np.ndarray:
    """E_avg baked at exactly these alpha nodes (the ``albedo_avg`` table kind)."""
    ua, ia = _spec_nodes(alpha, 0.0, 4.0)
    t = tabulate({"table": "albedo_avg", "distribution": distribution, "shadowing": shadowing, "tolerance": 1e-6,
                  "axes": {"alpha": ua}})
    return np.asarray(t.channels["E_avg"], dtype=np.float64)[ia]

