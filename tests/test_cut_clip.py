"""The fluid part of cut cells clipped from the fluid region's rings (:mod:`fsci.cut.clip`):
per-cell areas and polynomial moments of total degree ≤ 5 (what the fluid's Galerkin terms
need) equal GEOS's cell-by-cell overlay to round-off, on generic bodies, bodies crossing the
box, vertices on grid lines, edges along them, and a body thinner than a cell; generic cells
never reach GEOS, and only cells whose fluid may be several parts do with one set of unknowns
per part."""

from __future__ import annotations

import numpy as np
import pytest
import shapely

from fsci.cut.state import CUT, FLUID, SOLID, CutState
from fsci.geometry.outlines import Outline
from fsci.mesh.grid import Grid

from cutgeom import disk_outline, polygon_moment, rect_outline

# a graded grid: the walk must not assume equal cells
XS = np.concatenate([[0.0], np.cumsum(np.linspace(0.06, 0.11, 12))])
XS /= XS[-1]
YS = np.linspace(0.0, 1.0, 10) ** 1.2
GRID = Grid(XS, YS)


def polygon_outline(b: int, pts: np.ndarray) -> Outline:
    """A body given by its boundary polygon (counter-clockwise) only."""
    n = len(pts)
    edges = np.column_stack([np.arange(n), (np.arange(n) + 1) % n])
    return Outline(b, f"poly{b}", pts, edges, shapely.Polygon(pts), edges)


def star(rng, centre, r0, n=9) -> np.ndarray:
    t = np.sort(rng.uniform(0.0, 2 * np.pi, n))
    r = r0 * rng.uniform(0.5, 1.0, n)
    return np.column_stack([centre[0] + r * np.cos(t), centre[1] + r * np.sin(t)])


def check_cells(cs: CutState, degree: int = 5) -> None:
    """Every cell's fluid area, and every cut cell's moments ∫ x^a y^b (a + b ≤ degree), against
    the cell box intersected with the fluid region by GEOS."""
    g = cs.grid
    ij = g.cell_ij
    boxes = shapely.box(g.xs[ij[:, 0]], g.ys[ij[:, 1]], g.xs[ij[:, 0] + 1], g.ys[ij[:, 1] + 1])
    exact = shapely.intersection(boxes, cs.fluid)
    cell_area = g.cell_size[:, 0] * g.cell_size[:, 1]
    ref_area = shapely.area(exact)
    assert np.all(np.abs(cs.fluid_area - ref_area) <= 1e-13 * cell_area)
    assert np.all(cs.state[ref_area == 0.0] == SOLID)
    assert np.all(cs.state[np.abs(ref_area - cell_area) <= 1e-16 * cell_area] == FLUID)
    owner = np.repeat(cs.int_cells, np.diff(cs.qptr))
    for c in np.nonzero(cs.state == CUT)[0]:
        sel = owner == c
        x, y, w = cs.qx[sel, 0], cs.qx[sel, 1], cs.qw[sel]
        # the points may lie anywhere in the cell (signed triangles), never outside it
        x0, x1, y0, y1 = g.xs[ij[c, 0]], g.xs[ij[c, 0] + 1], g.ys[ij[c, 1]], g.ys[ij[c, 1] + 1]
        assert np.all((x >= x0 - 1e-15) & (x <= x1 + 1e-15) & (y >= y0 - 1e-15) & (y <= y1 + 1e-15))
        for a in range(degree + 1):
            for b in range(degree + 1 - a):
                assert abs(np.dot(w, x ** a * y ** b) - polygon_moment(exact[c], a, b)) <= 1e-14 * cell_area[c], (c, a, b)


def test_generic_bodies_are_clipped_without_geos():
    rng = np.random.default_rng(11)
    for _ in range(12):
        bodies = [polygon_outline(0, star(rng, rng.uniform(0.3, 0.7, 2), 0.25, n=11)),
                  disk_outline(1, rng.uniform(0.2, 0.8, 2), rng.uniform(0.05, 0.12), n_edges=23)]
        if bodies[0].polygon.intersects(bodies[1].polygon):
            bodies = bodies[:1]
        cs = CutState(GRID, bodies)
        assert np.count_nonzero(cs.state == CUT) > 10
        assert cs.clipped_by_geos == 0
        check_cells(cs)


def test_bodies_crossing_the_box_sides_and_corner():
    """The fluid region's rings run along the box sides (grid lines) and leave them at vertices
    on those lines, as where the stamp crosses the box top."""
    for centre, r in (((0.5, 1.0), 0.3), ((1.0, 0.45), 0.2), ((0.0, 0.0), 0.35), ((0.97, 0.5), 0.25)):
        cs = CutState(GRID, [disk_outline(0, centre, r, n_edges=40)])
        assert cs.clipped_by_geos == 0
        check_cells(cs)


@pytest.mark.parametrize("shift", [0.0, 1e-15, 1e-9, 1e-3])
def test_vertices_on_grid_lines_and_edges_along_them(shift):
    """A rectangle with its corners on grid nodes and its sides on grid lines, moved off them
    by ``shift`` (relative to a cell); a triangle whose vertex lies on a vertical grid line
    inside a cell side. Cells the walk cannot order go to GEOS; the moments hold either way."""
    h = float(GRID.cell_size.min())
    rect = rect_outline(0, XS[3] + shift * h, YS[2], XS[7], YS[6] + shift * h)
    tri = polygon_outline(1, np.array([[XS[9], 0.5 * (YS[6] + YS[7])], [XS[11] - 0.01, YS[6] + 0.013],
                                       [XS[11] - 0.02, YS[8] - 0.01]]))
    cs = CutState(GRID, [rect, tri])
    check_cells(cs)
    cut_near_tri = [c for c in np.nonzero(cs.state == CUT)[0] if GRID.cell_ij[c, 0] >= 8]
    assert len(cut_near_tri) >= 3


def test_a_ring_crossing_a_grid_line_at_its_vertex_needs_no_geos():
    """The vertex on the line ends the piece in one cell and starts the piece in the next."""
    ym = 0.5 * (YS[5] + YS[6])
    tri = polygon_outline(0, np.array([[XS[8] + 0.02, ym + 0.04], [XS[9], ym], [XS[10] - 0.01, ym + 0.02]]))
    cs = CutState(GRID, [tri])
    assert cs.clipped_by_geos == 0
    check_cells(cs)


def test_a_cell_with_two_fluid_parts_goes_to_geos_with_one_set_per_part():
    """A strip thinner than a cell splits the cells it crosses into two fluid parts: with one set
    of unknowns per part those cells are GEOS's (their parts are needed), with one per node
    they are clipped from the rings like any other."""
    strip = rect_outline(0, 0.1, 0.4, 0.9, 0.43, angle=0.2)
    per_part = CutState(GRID, [strip], separate_parts=True)
    per_node = CutState(GRID, [strip])
    assert per_part.split_cells and per_part.clipped_by_geos >= len(per_part.split_cells)
    assert per_node.clipped_by_geos == 0
    for cs in (per_part, per_node):
        check_cells(cs)
    assert np.array_equal(per_part.state, per_node.state)
    for c, parts in per_part.split_cells.items():  # each part integrated on its own
        for k, part in enumerate(parts):
            sel = np.repeat(per_part.int_parts, np.diff(per_part.qptr)) == c + GRID.n_cells * k
            assert abs(per_part.qw[sel].sum() - part.area) <= 1e-14
