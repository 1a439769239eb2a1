"""The clamped-cosine polygon integral with horizon clipping, on the host (NumPy, float64).

For a polygon P seen from the origin, int_P max(0, w_z) / pi dw (Lambert's edge formula, as
used by Heitz et al. 2016, "Real-Time Polygonal-Light Shading with Linearly Transformed
Cosines", with the polygon first clipped to the upper half-space):

    I(P) = 1 / (2 pi) sum_edges theta_e n_e.z,   theta_e = angle(a, b),
    n_e = (a x b) / |a x b|,

over the edges (a, b) of P clipped to z >= 0 (the clipped part of the boundary runs along the
horizon, from the point where the boundary leaves the upper half-space to where it re-enters).
Positive when (v1 - v0) x (v2 - v0) points away from the shading point (counter-clockwise about
+z for a polygon overhead); take ``abs`` for a two-sided light. With an LTC, the polygon is
transformed by Minv first (the integral is invariant to the scale of the vertices).
This is the same edge-streaming algorithm as :func:`bsdf_tab.model.ltc.ltc_polygon_integral`.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["edge_term", "polygon_integral"]

_TINY = 1e-300


def edge_term(a, b):
    """theta (a x b).z / |a x b| for edge arrays a, b (..., 3), 0 for a degenerate edge."""
    an = a / np.maximum(np.linalg.norm(a, axis=-1, keepdims=True), _TINY)  # zero vector: no edge
    bn = b / np.maximum(np.linalg.norm(b, axis=-1, keepdims=True), _TINY)
    c = np.cross(an, bn)
    s = np.linalg.norm(c, axis=-1)
    theta = np.arctan2(s, np.sum(an * bn, axis=-1))
    # theta / sin(theta) -> 1 as the edge shrinks (s -> 0 with theta -> 0)
    ratio = np.where(s > 1e-12, theta / np.where(s > 1e-12, s, 1.0), 1.0)
    return c[..., 2] * ratio


def polygon_integral(vertices, minv=None):
    """int over the polygon (clipped to z >= 0) of max(0, w_z) / pi dw.

    Parameters
    ----------
    vertices : array_like (..., n, 3)
        Polygon vertices (any scale; the shading point is the origin).
    minv : array_like (..., 3, 3), optional
        An LTC's inverse matrix: the integral of the LTC lobe over the polygon.

    Returns
    -------
    ndarray (...)
        The signed integral (positive when (v1 - v0) x (v2 - v0) points away from the origin).
    """
    p = np.asarray(vertices, dtype=np.float64)
    if minv is not None:
        p = np.einsum("...ij,...kj->...ki", np.asarray(minv, dtype=np.float64), p)
    n = p.shape[-2]
    total = np.zeros(p.shape[:-2])
    shape = p.shape[:-2] + (3,)
    exit_pt, has_exit = np.zeros(shape), np.zeros(p.shape[:-2], dtype=bool)
    first_entry, has_first = np.zeros(shape), np.zeros(p.shape[:-2], dtype=bool)
    for i in range(n):
        a, b = p[..., i, :], p[..., (i + 1) % n, :]
        za, zb = a[..., 2], b[..., 2]
        up_a, up_b = za >= 0.0, zb >= 0.0
        with np.errstate(divide="ignore", invalid="ignore"):  # used only where the signs differ
            t = za / (za - zb)
            cross = a + t[..., None] * (b - a)
        both = up_a & up_b
        leave = up_a & ~up_b
        enter = ~up_a & up_b
        seg_a = np.where(enter[..., None], cross, a)
        seg_b = np.where(leave[..., None], cross, b)
        total += np.where(both | leave | enter, edge_term(seg_a, seg_b), 0.0)
        # the horizon edge: from the last exit to this entry (or, if the boundary starts below,
        # from the final exit back to the first entry, added after the loop)
        close = enter & has_exit
        total += np.where(close, edge_term(exit_pt, cross), 0.0)
        has_exit = np.where(close, False, has_exit)
        first = enter & ~close & ~has_first
        first_entry = np.where(first[..., None], cross, first_entry)
        has_first |= first
        exit_pt = np.where(leave[..., None], cross, exit_pt)
        has_exit |= leave
    wrap = has_exit & has_first
    total += np.where(wrap, edge_term(exit_pt, first_entry), 0.0)
    return total / (2.0 * math.pi)
