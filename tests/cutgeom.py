"""Helpers for cut tests: outlines of simple shapes and exact polygon moments."""

from __future__ import annotations

import numpy as np
import shapely

from fsci.fem.quadrature import gauss_line
from fsci.geometry.outlines import Outline, body_polygon
from fsci.mesh import generate


def rect_outline(b: int, x0, y0, x1, y1, n=3, angle=0.0, center=None) -> Outline:
    m = generate.rectangle(x0, x1, y0, y1, n, n)
    x = m.nodes.copy()
    if angle:
        c = np.asarray(center if center is not None else [(x0 + x1) / 2, (y0 + y1) / 2])
        R = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
        x = (x - c) @ R.T + c
    loops = m.boundary_loops()
    poly = body_polygon(x, loops, f"rect{b}")
    return Outline(b, f"rect{b}", x, m.boundary.edges, poly, m.boundary.edges)


def disk_outline(b: int, c, r, n_edges=64, phase=0.3) -> Outline:
    """A regular polygon approximating a disk, as a one-ring quad mesh (outline only matters)."""
    t = phase + 2 * np.pi * np.arange(n_edges) / n_edges
    outer = np.column_stack([c[0] + r * np.cos(t), c[1] + r * np.sin(t)])
    inner = np.column_stack([c[0] + 0.5 * r * np.cos(t), c[1] + 0.5 * r * np.sin(t)])
    x = np.vstack([outer, inner, [c]])
    cells = []
    for k in range(n_edges):
        k1 = (k + 1) % n_edges
        cells.append([k, k1, n_edges + k1, n_edges + k])
    # inner polygon fan as quads would need more nodes; a quad ring is enough for an outline
    edges = np.column_stack([np.arange(n_edges), (np.arange(n_edges) + 1) % n_edges])
    poly = shapely.Polygon(outer)
    return Outline(b, f"disk{b}", x, edges, poly, edges)


def polygon_moment(poly: shapely.Geometry, a: int, b: int) -> float:
    """∫∫ x^a y^b over a polygon (with holes) by Green's theorem, exact for polynomials:
    ∫∫ x^a y^b dA = ∮ x^(a+1) y^b / (a+1) dy along the positively oriented boundary."""
    total = 0.0
    gx, gw = gauss_line(a + b + 2)
    s = 0.5 * (gx + 1.0)
    for p in shapely.get_parts(poly):
        if p.geom_type != "Polygon":
            continue
        rings = [(p.exterior, True)] + [(r, False) for r in p.interiors]
        for ring, outer in rings:
            c = np.asarray(ring.coords)
            sign = 1.0 if ring.is_ccw == outer else -1.0
            for k in range(len(c) - 1):
                p0, p1 = c[k], c[k + 1]
                xs = p0[0] + s * (p1[0] - p0[0])
                ys = p0[1] + s * (p1[1] - p0[1])
                total += sign * 0.5 * np.sum(gw * xs ** (a + 1) * ys ** b) / (a + 1) * (p1[1] - p0[1])
    return total
