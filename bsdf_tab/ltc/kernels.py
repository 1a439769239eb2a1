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

__all__ = ["ObjectiveKernel"]

_INV_PI = wp.constant(wp.float64(0.31830988618379067154))


@wp.kernel
def _objective(
    L: wp.array2d(dtype=wp.vec3d),
    wn: wp.array2d(dtype=wp.float64),
    mf: wp.array2d(dtype=wp.float64),
    idx: wp.array(dtype=wp.int32),
    X: wp.array2d(dtype=wp.float64),
    out: wp.array(dtype=wp.float64),
    clip: int,
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
        # the horizon-mass amplitude: D / m_up, m_up = (1 + n_z) / 2 with n along M's row 2 = (-y, 0, x) / det
        nz = x / wp.max(wp.sqrt(x * x + y * y), wp.float64(1e-300))  # (x, y) = 0 only for a singular Minv
        if det_s < wp.float64(0.0):
            nz = -nz
        det = det / wp.max(wp.float64(0.5) * (wp.float64(1.0) + nz), wp.float64(1e-300))  # m_up > 0 unless all below
    acc = wp.float64(0.0)
    for k in range(L.shape[1]):
        wk = wn[b, k]
        if wk > wp.float64(0.0):
            d = L[b, k]
            lx = x * d[0] + z * d[2]
            lz = y * d[0] + w_ * d[2]
            n2 = lx * lx + d[1] * d[1] + lz * lz  # >= L_y^2 + ..., > 0 for invertible Minv, |L| = 1
            dens = wp.max(lz, wp.float64(0.0)) * det / (n2 * n2)
            acc += wk * wp.max(wp.float64(1.0) - dens * mf[b, k], wp.float64(0.0))
    out[t] = acc


class ObjectiveKernel:
    """Device copies of one batch's nodes; ``__call__(idx, X)`` as the NumPy objective."""

    def __init__(self, L: np.ndarray, wn: np.ndarray, mf: np.ndarray, device=None, max_batch: int = 0,
                 clipped: bool = False):
        self.clip = 1 if clipped else 0
        self.device = resolve_device(device)
        self.L = wp.array(np.ascontiguousarray(L), dtype=wp.vec3d, device=self.device)
        self.wn = wp.array(np.ascontiguousarray(wn), dtype=wp.float64, device=self.device)
        self.mf = wp.array(np.ascontiguousarray(mf), dtype=wp.float64, device=self.device)
        self._size = 0
        self._grow(max(max_batch, 16 * L.shape[0]))

    def _grow(self, n: int) -> None:
        self._size = n
        self._idx = wp.zeros(n, dtype=wp.int32, device=self.device)
        self._X = wp.zeros((n, 4), dtype=wp.float64, device=self.device)
        self._out = wp.zeros(n, dtype=wp.float64, device=self.device)
        if self.device.is_cpu:  # host views of the same memory: no copies per call
            self._idx_h, self._X_h, self._out_h = self._idx.numpy(), self._X.numpy(), self._out.numpy()
        # a recorded launch: the arguments are packed once, each call only sets the dimension
        self._cmd = wp.launch(_objective, dim=1, device=self.device, record_cmd=True,
                              inputs=[self.L, self.wn, self.mf, self._idx, self._X, self._out, self.clip])

    def __call__(self, idx: np.ndarray, X: np.ndarray) -> np.ndarray:
        n = int(idx.size)
        if n > self._size:
            self._grow(n)
        if self.device.is_cpu:
            self._idx_h[:n] = idx
            self._X_h[:n] = X
        else:
            self._idx.assign(np.pad(idx.astype(np.int32), (0, self._size - n)))
            self._X.assign(np.pad(np.asarray(X, dtype=np.float64), ((0, self._size - n), (0, 0))))
        self._cmd.set_dim(n)
        self._cmd.launch()
        if self.device.is_cpu:
            return self._out_h[:n].copy()
        return self._out.numpy()[:n]
