"""Warp kernels of the LTC fit: the L1 objective for a batch of parameter vectors (float64).

The same sum as :class:`bsdf_tab.ltc.fit.Objective` evaluates in NumPy (tested equal):
2 sum_k (w_k / E) max(1 - E D_ltc(L_k) / f_k, 0), one thread per evaluation, the lobe's nodes
fixed per texel, the matrix given by its stored entries (Minv / Minv_11: x, y, z, w); with
``clipped`` the lobe is D_ltc / m_up (the horizon-mass amplitude, m_up = (1 + n_z) / 2 in closed
form), which makes the sum the clipped metric int_up |D_ltc / m_up - T|. A CPU launch releases the GIL, so fits of disjoint texels in several threads
use several cores.
"""

from __future__ import annotations

import numpy as np
import warp as wp

from ..integrate.runtime import resolve_device

# no kernel of this module is differentiated: no adjoint code (a third of the compile time)
wp.set_module_options({"enable_backward": False})

__all__ = ["BatchLaunch", "ObjectiveKernel", "horizon_mass", "l1_deficits", "ltc_density"]

_INV_PI = wp.constant(wp.float64(0.31830988618379067154))


@wp.func
def horizon_mass(x: wp.float64, y: wp.float64, det_s: wp.float64):
    """m_up = (1 + n_z) / 2, the LTC lobe's mass above the horizon, n along M's row 2 = (-y, 0, x) / det."""
    nz = x / wp.max(wp.sqrt(x * x + y * y), wp.float64(1e-300))  # (x, y) = 0 only for a singular Minv
    if det_s < wp.float64(0.0):
        nz = -nz
    return wp.max(wp.float64(0.5) * (wp.float64(1.0) + nz), wp.float64(1e-300))  # > 0 unless all below


@wp.func
def ltc_density(x: wp.float64, y: wp.float64, z: wp.float64, w_: wp.float64, det: wp.float64, d: wp.vec3d):
    """D_ltc(d) = max(0, (Minv d)_z) det / |Minv d|^4 for unit d, Minv = [[x, 0, z], [0, 1, 0], [y, 0, w]]
    (det = |det Minv| / pi, times any amplitude)."""
    lx = x * d[0] + z * d[2]
    lz = y * d[0] + w_ * d[2]
    n2 = lx * lx + d[1] * d[1] + lz * lz  # >= d_y^2 + ..., > 0 for invertible Minv, |d| = 1
    return wp.max(lz, wp.float64(0.0)) * det / (n2 * n2)


@wp.func
def l1_deficits(L: wp.array2d(dtype=wp.vec3d), wn: wp.array2d(dtype=wp.float64), mf: wp.array2d(dtype=wp.float64),
                b: wp.int32, x: wp.float64, y: wp.float64, z: wp.float64, w_: wp.float64, det: wp.float64,
                a: wp.float64, acc0: wp.float64):
    """The L1 metric's node sums over texel ``b``'s nodes, one density per node (D_k = D_ltc(L_k) mf_k):
    (acc0 + sum_k wn_k max(1 - a D_k, 0), sum_k wn_k max(1 - D_k, 0)), i.e. 2 int max(T - a D_ltc, 0)
    for an amplitude a and for 1 (zero-weight nodes skipped)."""
    zero = wp.float64(0.0)
    one = wp.float64(1.0)
    acc = acc0
    plain = zero
    for k in range(L.shape[1]):
        wk = wn[b, k]
        if wk > zero:
            dens = ltc_density(x, y, z, w_, det, L[b, k]) * mf[b, k]
            acc += wk * wp.max(one - a * dens, zero)
            plain += wk * wp.max(one - dens, zero)
    return wp.vec2d(acc, plain)


@wp.kernel
def _objective(
    L: wp.array2d(dtype=wp.vec3d),
    wn: wp.array2d(dtype=wp.float64),
    mf: wp.array2d(dtype=wp.float64),
    idx: wp.array(dtype=wp.int32),
    X: wp.array2d(dtype=wp.float64),
    clip: int,
    out: wp.array(dtype=wp.float64),
):
    t = wp.tid()
    b = idx[t]
    # Minv / Minv_11 = [[x, 0, z], [0, 1, 0], [y, 0, w]] (the storage form)
    x = X[t, 0]
    y = X[t, 1]
    z = X[t, 2]
    w_ = X[t, 3]
    det_s = x * w_ - y * z
    det = wp.abs(det_s) * _INV_PI
    if clip != 0:
        # the horizon-mass amplitude: D / m_up
        det = det / horizon_mass(x, y, det_s)
    out[t] = l1_deficits(L, wn, mf, b, x, y, z, w_, det, wp.float64(1.0), wp.float64(0.0))[1]


class BatchLaunch:
    """A recorded launch of ``kernel(*before, idx, X, *after, out)`` over a batch: ``__call__(idx, X)``
    -> out[:n]. The device buffers grow on demand; on the CPU the host views share their memory, so
    a call copies nothing but its inputs, and the launch's arguments are packed once."""

    def __init__(self, kernel, before: list, after: list, width: int, device, size: int):
        self.kernel, self.before, self.after, self.width = kernel, list(before), list(after), int(width)
        self.device = device
        self._grow(size)

    def _grow(self, n: int) -> None:
        self._size = n
        self._idx = wp.zeros(n, dtype=wp.int32, device=self.device)
        self._X = wp.zeros((n, self.width), dtype=wp.float64, device=self.device)
        self._out = wp.zeros(n, dtype=wp.float64, device=self.device)
        if self.device.is_cpu:
            self._idx_h, self._X_h, self._out_h = self._idx.numpy(), self._X.numpy(), self._out.numpy()
        self._cmd = wp.launch(self.kernel, dim=1, device=self.device, record_cmd=True,
                              inputs=self.before + [self._idx, self._X] + self.after + [self._out])

    def __call__(self, idx: np.ndarray, X: np.ndarray) -> np.ndarray:
        """X (n, <= width): the first columns of each row; the others stay 0."""
        n = int(idx.size)
        if n > self._size:
            self._grow(n)
        X = np.asarray(X, dtype=np.float64)
        if self.device.is_cpu:
            self._idx_h[:n] = idx
            self._X_h[:n, :X.shape[1]] = X
        else:
            Xp = np.zeros((self._size, self.width))
            Xp[:n, :X.shape[1]] = X
            self._idx.assign(np.pad(idx.astype(np.int32), (0, self._size - n)))
            self._X.assign(Xp)
        self._cmd.set_dim(n)
        self._cmd.launch()
        if self.device.is_cpu:
            return self._out_h[:n].copy()
        return self._out.numpy()[:n]


class ObjectiveKernel(BatchLaunch):
    """Device copies of one batch's nodes; ``__call__(idx, X)`` as the NumPy objective."""

    def __init__(self, L: np.ndarray, wn: np.ndarray, mf: np.ndarray, device=None, max_batch: int = 0,
                 clipped: bool = False):
        dev = resolve_device(device)
        arr = lambda a, dt=wp.float64: wp.array(np.ascontiguousarray(a), dtype=dt, device=dev)  # noqa: E731
        super().__init__(_objective, [arr(L, wp.vec3d), arr(wn), arr(mf)], [1 if clipped else 0], 4, dev,
                         max(max_batch, 16 * L.shape[0]))
