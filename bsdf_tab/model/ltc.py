"""Linearly Transformed Cosines as Warp ``@wp.func``: the lobe and the polygon integral.

Heitz, Dupuy, Hill, Neubelt 2016, "Real-Time Polygonal-Light Shading with Linearly Transformed
Cosines". An LTC table (table kind ``ltc``) stores per (mu, alpha) the inverse matrix Minv
(normalized by its middle entry: ``ltc_minv`` builds it from the four stored entries) and the
magnitude E. In the local frame of the shading point (n = +z, the view direction in the xz
plane with positive x), the reflected radiance of a polygonal light of radiance L_e is

    L_o = L_e E ltc_polygon_integral(Minv, vertices)

(times F0 E + (1 - F0) fresnel instead of E for Schlick F0), the vertices relative to the
shading point. Generic over float32 / float64 (``wp.mat33f`` / ``wp.mat33d`` with matching
``vec3`` types). No I/O, no state: import into any kernel.

- ``ltc_minv(x, y, z, w)``: [[x, 0, z], [0, 1, 0], [y, 0, w]] (the stored entries Minv_00,
  Minv_20, Minv_02, Minv_22, the RGBA of the public code's ``ltc_1``).
- ``ltc_eval(Minv, L)``: the lobe D(L) = max(0, (Minv L)_z) |det Minv| / (pi |Minv L|^4)
  (integrates to 1 over the sphere).
- ``ltc_edge(a, b)``: theta (a x b).z / |a x b| for one edge (Lambert's edge term).
- ``ltc_polygon_integral(Minv, vertices)``: for a 1-D ``wp.array`` of ``vec3`` (the polygon,
  any number of vertices), the integral of the clamped cosine max(0, w_z) / pi over the
  polygon transformed by Minv and clipped to the upper hemisphere; positive when
  (v1 - v0) x (v2 - v0) points away from the shading point (take ``abs`` for a two-sided light).
- ``ltc_quad_integral(Minv, p0, p1, p2, p3)``: the same for a quad given by its vertices.
"""

from typing import Any

import warp as wp

__all__ = ["ltc_edge", "ltc_eval", "ltc_minv", "ltc_polygon_integral", "ltc_quad_integral"]


@wp.func
def ltc_minv(x: Any, y: Any, z: Any, w: Any):
    """Minv from its stored entries: rows (x, 0, z), (0, 1, 0), (y, 0, w)."""
    zero = type(x)(0.0)
    one = type(x)(1.0)
    return wp.matrix(x, zero, z, zero, one, zero, y, zero, w, shape=(3, 3), dtype=type(x))


@wp.func
def ltc_eval(Minv: Any, L: Any):
    """D(L) = max(0, l_z) |det Minv| / (pi |l|^4), l = Minv L."""
    l = Minv * L
    n2 = wp.dot(l, l)
    zero = type(n2)(0.0)
    if n2 <= zero:
        # Minv L = 0 only for a singular Minv: no density
        return zero
    return wp.max(l[2], zero) * wp.abs(wp.determinant(Minv)) / (type(n2)(wp.pi) * n2 * n2)


@wp.func
def ltc_edge(a: Any, b: Any):
    """theta (a x b).z / |a x b|, theta the angle between a and b (0 for a degenerate edge)."""
    zero = type(a[0])(0.0)
    la = wp.length(a)
    lb = wp.length(b)
    if la <= zero or lb <= zero:
        # a vertex at the shading point: no edge
        return zero
    an = a / la
    bn = b / lb
    c = wp.cross(an, bn)
    s = wp.length(c)
    theta = wp.atan2(s, wp.dot(an, bn))
    if s > type(s)(1e-7):
        return c[2] * theta / s
    # theta / sin(theta) -> 1 as the edge shrinks
    return c[2]


@wp.func
def _clip_step(a: Any, b: Any, total: Any, exit_pt: Any, has_exit: int, first_entry: Any, has_first: int):
    """One edge (a, b) of the horizon-clipped edge sum; returns the updated state."""
    zero = type(a[0])(0.0)
    za = a[2]
    zb = b[2]
    if za >= zero and zb >= zero:
        total = total + ltc_edge(a, b)
    elif za >= zero:
        # leaving the upper half-space: za >= 0 > zb, so za - zb > 0
        c = a + (b - a) * (za / (za - zb))
        total = total + ltc_edge(a, c)
        exit_pt = c
        has_exit = 1
    elif zb >= zero:
        # entering: za < 0 <= zb, so za - zb < 0
        c = a + (b - a) * (za / (za - zb))
        total = total + ltc_edge(c, b)
        if has_exit == 1:
            total = total + ltc_edge(exit_pt, c)  # along the horizon
            has_exit = 0
        elif has_first == 0:
            first_entry = c
            has_first = 1
    return total, exit_pt, has_exit, first_entry, has_first


@wp.func
def ltc_polygon_integral(Minv: Any, vertices: Any):
    """Clamped-cosine integral over the polygon ``vertices`` (wp.array of vec3) transformed by Minv."""
    n = vertices.shape[0]
    total = type(Minv[0, 0])(0.0)
    if n < 3:
        return total
    p0 = Minv * vertices[0]
    exit_pt = p0
    first_entry = p0
    has_exit = int(0)
    has_first = int(0)
    a = p0
    for i in range(n):
        b = p0
        if i + 1 < n:
            b = Minv * vertices[i + 1]
        total, exit_pt, has_exit, first_entry, has_first = _clip_step(
            a, b, total, exit_pt, has_exit, first_entry, has_first)
        a = b
    if has_exit == 1 and has_first == 1:
        total = total + ltc_edge(exit_pt, first_entry)
    return total / (type(total)(2.0) * type(total)(wp.pi))


@wp.func
def ltc_quad_integral(Minv: Any, p0: Any, p1: Any, p2: Any, p3: Any):
    """:func:`ltc_polygon_integral` for the quad (p0, p1, p2, p3)."""
    a = Minv * p0
    b = Minv * p1
    c = Minv * p2
    d = Minv * p3
    total = type(a[0])(0.0)
    exit_pt = a
    first_entry = a
    has_exit = int(0)
    has_first = int(0)
    total, exit_pt, has_exit, first_entry, has_first = _clip_step(a, b, total, exit_pt, has_exit, first_entry, has_first)
    total, exit_pt, has_exit, first_entry, has_first = _clip_step(b, c, total, exit_pt, has_exit, first_entry, has_first)
    total, exit_pt, has_exit, first_entry, has_first = _clip_step(c, d, total, exit_pt, has_exit, first_entry, has_first)
    total, exit_pt, has_exit, first_entry, has_first = _clip_step(d, a, total, exit_pt, has_exit, first_entry, has_first)
    if has_exit == 1 and has_first == 1:
        total = total + ltc_edge(exit_pt, first_entry)
    return total / (type(total)(2.0) * type(total)(wp.pi))
