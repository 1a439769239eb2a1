"""The peers' axes, from their published formulas (``../shared/anchors`` READMEs)."""

from __future__ import annotations

import numpy as np

__all__ = ["cycles_axis", "cycles_ior_axis", "cycles_z_axis", "openpbr_ior_axis", "unit_centers", "unit_endpoints"]


def cycles_axis(n: int) -> np.ndarray:
    """Cycles' mu and roughness axes: ``clamp(i / (n - 1), 1e-4, 1)``."""
    return np.clip(np.arange(n) / (n - 1), 1e-4, 1.0)


def cycles_z_axis(n: int = 16) -> np.ndarray:
    """Cycles' glass z axis: ``clamp(k / (n - 1), 1e-4, 0.99)`` (F0 = z^4)."""
    return np.clip(np.arange(n) / (n - 1), 1e-4, 0.99)


def cycles_ior_axis(n: int = 16) -> np.ndarray:
    """Cycles' glass IOR axis from z: ``ior = (1 + z^2) / (1 - z^2)`` (1.00000002 .. 99.5)."""
    z2 = cycles_z_axis(n) ** 2
    return (1.0 + z2) / (1.0 - z2)


def openpbr_ior_axis() -> np.ndarray:
    """OpenPBR's 32 IORs: index i < 16: ``1/ior = 1 + 1.5 (15 - i)/15``; i >= 16: ``ior = 1 + 1.5 (i - 16)/15``.

    0.4 .. 1 then 1 .. 2.5: the value 1.0 appears twice (indices 15 and 16).
    """
    return np.array([1.0 / (1.0 + 1.5 * (15 - i) / 15.0) if i < 16 else 1.0 + 1.5 * (i - 16) / 15.0 for i in range(32)])


def unit_endpoints(n: int) -> np.ndarray:
    """``i / (n - 1)``: nodes on both ends of [0, 1]."""
    return np.arange(n) / (n - 1)


def unit_centers(n: int) -> np.ndarray:
    """``(i + 1/2) / n``: texel centres."""
    return (np.arange(n) + 0.5) / n
