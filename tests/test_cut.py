"""Cut geometry robustness (issue: cut state): areas, interface lengths and polynomial moments
exact to 1e-12 against GEOS/analytic values for disks, rectangles and touching/overlapping
bodies shifted by 1e-14 … 1e-2 h, through nodes, along grid lines and tangent to grid lines."""

from __future__ import annotations

import numpy as np
import pytest
import shapely

from fsci.cut.state import CUT, FLUID, SOLID, CutState
from fsci.mesh.grid import Grid

from cutgeom import disk_outline, polygon_moment, rect_outline

SHIFTS = [0.0, 1e-14, 1e-12, 1e-10, 1e-8, 1e-6, 1e-4, 1e-2]
GRID = Grid(np.linspace(0.0, 1.0, 11), np.linspace(0.0, 1.0, 11))
H = 0.1


def check_cut(cs: CutState, fluid_exact: shapely.Geometry, interface_exact: float, degree_max: int = 4):
    box_area = 1.0
    # total and per-cell areas
    assert abs(cs.qw.sum() - fluid_exact.area) < 1e-12 * box_area
    area_cells = np.zeros(GRID.n_cells)
    owner = np.repeat(cs.int_cells, np.diff(cs.qptr))
    np.add.at(area_cells, owner, cs.qw)
    ij = GRID.cell_ij
    for c in np.nonzero(cs.state == CUT)[0]:
        box = shapely.box(GRID.xs[ij[c, 0]], GRID.ys[ij[c, 1]], GRID.xs[ij[c, 0] + 1], GRID.ys[ij[c, 1] + 1])
        assert abs(area_cells[c] - shapely.intersection(box, fluid_exact).area) < 1e-12 * H * H
    assert np.all(area_cells[cs.state == SOLID] == 0.0)
    # interface length bounding the fluid
    assert abs(cs.interface_length(fs=True) - interface_exact) < 1e-12
    # polynomial moments: degree ≤ 4 on the PHYSICAL part of cut cells (polygon rules),
    # degree ≤ 3 over the whole fluid (uncut cells use 2×2 Gauss, exact per variable to 3)
    cut_cells = np.nonzero(cs.state == CUT)[0]
    on_cut = np.isin(owner, cut_cells)
    cut_region = shapely.intersection(fluid_exact, shapely.union_all(shapely.box(
        GRID.xs[ij[cut_cells, 0]], GRID.ys[ij[cut_cells, 1]], GRID.xs[ij[cut_cells, 0] + 1], GRID.ys[ij[cut_cells, 1] + 1])))
    for a in range(degree_max + 1):
        for b in range(degree_max + 1 - a):
            mono = cs.qx[:, 0] ** a * cs.qx[:, 1] ** b
            if len(cut_cells):
                q = np.dot(cs.qw[on_cut], mono[on_cut])
                assert abs(q - polygon_moment(cut_region, a, b)) < 1e-12, (a, b)
            if a + b <= 3:
                assert abs(np.dot(cs.qw, mono) - polygon_moment(fluid_exact, a, b)) < 1e-12, (a, b)
    # every piece of the fluid-wetted interface sits in a cell that carries fluid
    seg = cs.segments
    assert np.all(cs.state[seg.cell[seg.fs]] != SOLID)
    # ACTIVE nodes are exactly the nodes of integrated cells
    act = np.zeros(GRID.n_nodes, bool)
    act[GRID.cells[cs.state != SOLID].ravel()] = True
    assert np.array_equal(act, cs.active)


@pytest.mark.parametrize("shift", SHIFTS)
def test_disk_shifted(shift):
    o = disk_outline(0, (0.5 + shift * H, 0.45 + shift * H), 0.23, n_edges=97)
    cs = CutState(GRID, [o])
    fluid = shapely.difference(shapely.box(0, 0, 1, 1), o.polygon)
    check_cut(cs, fluid, o.polygon.length)


@pytest.mark.parametrize("shift", SHIFTS)
def test_rectangle_on_grid_lines_and_nodes(shift):
    """Corners at grid nodes (shift 0), edges along grid lines, then shifted off them."""
    xs, ys = GRID.xs, GRID.ys  # exactly on the grid's coordinates (linspace rounds 0.6 up)
    o = rect_outline(0, xs[2] + shift * H, ys[3] + shift * H, xs[6] + shift * H, ys[7])
    cs = CutState(GRID, [o])
    fluid = shapely.difference(shapely.box(0, 0, 1, 1), o.polygon)
    check_cut(cs, fluid, o.polygon.length)
    if shift == 0.0:  # aligned: no cut cells at all, the interface lies on grid lines
        assert not np.any(cs.state == CUT)
        assert np.all(cs.segments.fs)


def test_disk_tangent_to_grid_lines():
    """A polygon whose extreme vertices lie exactly on grid lines."""
    o = disk_outline(0, (0.5, 0.5), 0.3, n_edges=4 * 25, phase=0.0)  # vertices at (0.8,0.5), (0.5,0.8), ...
    cs = CutState(GRID, [o])
    fluid = shapely.difference(shapely.box(0, 0, 1, 1), o.polygon)
    check_cut(cs, fluid, o.polygon.length)


@pytest.mark.parametrize("gap", [-1e-2, -1e-4, -1e-8, -1e-12, -1e-14, 0.0, 1e-14, 1e-10, 1e-6, 1e-2])
def test_two_rectangles_touching_overlapping_and_separating(gap):
    """Two blocks whose facing edges overlap (gap < 0), touch (0) or separate (gap > 0),
    the contact line lying across cells."""
    a = rect_outline(0, 0.23, 0.21, 0.77, 0.5 + 0.37 * H)
    top = 0.5 + 0.37 * H + gap * H
    b = rect_outline(1, 0.31, top, 0.69, 0.83)
    cs = CutState(GRID, [a, b], island_factor=0.0)
    union = shapely.union_all([a.polygon, b.polygon])
    fluid = shapely.difference(shapely.box(0, 0, 1, 1), union)
    wet = shapely.intersection(union.boundary, shapely.box(0, 0, 1, 1)).length
    if gap > 0:
        wet = a.polygon.length + b.polygon.length
    check_cut(cs, fluid, wet)
    seg = cs.segments
    sc_len = sum(np.linalg.norm(p[:, 1] - p[:, 0], axis=1).sum() for p in
                 [cs.interface_points(k, ~seg.fs)[0] for k in (0, 1)])
    expected_sc = a.polygon.length + b.polygon.length - wet
    assert abs(sc_len - expected_sc) < 1e-12


def test_fluid_island_between_bodies_is_removed():
    """A fluid pocket enclosed by two overlapping bodies and smaller than the island
    threshold is not fluid; its boundary becomes Γ^SC."""
    left = rect_outline(0, 0.2, 0.3, 0.52, 0.7)
    ring_a = rect_outline(1, 0.5, 0.3, 0.8, 0.495)
    ring_b = rect_outline(2, 0.5, 0.505, 0.8, 0.7)
    right = rect_outline(3, 0.6, 0.3, 0.8, 0.7)  # encloses the slot x in (0.52, 0.6), y in (0.495, 0.505)
    cs = CutState(GRID, [left, ring_a, ring_b, right], island_factor=2.0)
    assert len(cs.islands) == 1 and abs(cs.islands[0].area - 0.08 * 0.01) < 1e-14
    union = shapely.union_all([o.polygon for o in (left, ring_a, ring_b, right)])
    assert abs(cs.qw.sum() - (1.0 - union.area - 0.08 * 0.01)) < 1e-12
    keep = CutState(GRID, [left, ring_a, ring_b, right], island_factor=0.0, trapped_film=0.0)
    assert len(keep.islands) == 0 and abs(keep.qw.sum() - (1.0 - union.area)) < 1e-12


@pytest.mark.parametrize("thickness, right_end, dropped", [
    (0.01, 0.8, True),     # enclosed, mean thickness 0.0098 < 0.1 × cell diagonal 0.0141: dropped
    (0.02, 0.8, False),    # enclosed, 0.0192: thick enough to stay fluid
    (0.01, 1.0, False),    # as thin but reaching the box boundary (an outlet): stays fluid
])
def test_film_trapped_between_bodies_is_dropped_when_thin(thickness, right_end, dropped):
    """A slot of fluid five cells long between bodies in contact (too long for the bounding-box
    island rule) is dropped with ``trapped_film = 0.1`` when it is enclosed and thinner than
    0.1 cell diagonals on average (2 area / perimeter); its boundary then is Γ^SC."""
    lo, hi = 0.5 - 0.5 * thickness, 0.5 + 0.5 * thickness
    bodies = [rect_outline(0, 0.1, 0.3, 0.2, 0.7), rect_outline(1, 0.15, 0.3, right_end, lo),
              rect_outline(2, 0.15, hi, right_end, 0.7)]
    if right_end < 1.0:
        bodies.append(rect_outline(3, 0.7, 0.3, 0.8, 0.7))  # closes the slot x in (0.2, 0.7)
    slot = 0.5 * thickness if right_end < 1.0 else 0.8 * thickness
    union = shapely.union_all([o.polygon for o in bodies])
    fluid_area = 1.0 - union.area
    cs = CutState(GRID, bodies, island_factor=2.0, trapped_film=0.1)
    assert (len(cs.islands) == 1) == dropped
    assert abs(cs.qw.sum() - (fluid_area - (slot if dropped else 0.0))) < 1e-12
    sc = sum(np.linalg.norm(p[:, 1] - p[:, 0], axis=1).sum() for p in
             [cs.interface_points(k, ~cs.segments.fs)[0] for k in range(len(bodies))])
    slot_walls = 2.0 * (slot / thickness) + (2.0 * thickness if right_end < 1.0 else thickness)
    keep = CutState(GRID, bodies, island_factor=2.0, trapped_film=0.0)  # the rule off: always fluid
    sc_keep = sum(np.linalg.norm(p[:, 1] - p[:, 0], axis=1).sum() for p in
                  [keep.interface_points(k, ~keep.segments.fs)[0] for k in range(len(bodies))])
    assert len(keep.islands) == 0 and abs(keep.qw.sum() - fluid_area) < 1e-12
    assert abs(sc - sc_keep - (slot_walls if dropped else 0.0)) < 1e-12


def test_rotated_rectangle_many_shifts_never_crash():
    rng = np.random.default_rng(7)
    for _ in range(30):
        ang = rng.uniform(0, np.pi)
        c = rng.uniform(0.35, 0.65, 2)
        o = rect_outline(0, c[0] - 0.2, c[1] - 0.1, c[0] + 0.2, c[1] + 0.1, angle=ang)
        cs = CutState(GRID, [o])
        fluid = shapely.difference(shapely.box(0, 0, 1, 1), o.polygon)
        assert abs(cs.qw.sum() - fluid.area) < 1e-12
        assert abs(cs.interface_length() - o.polygon.length) < 1e-12


def test_quadrature_degree_is_configurable():
    o = disk_outline(0, (0.51, 0.47), 0.31, n_edges=41)
    cs = CutState(GRID, [o], quad_degree=8)
    for c, poly in cs.polygons.items():
        sel = slice(cs.qptr[np.searchsorted(cs.int_cells, c)], cs.qptr[np.searchsorted(cs.int_cells, c) + 1])
        for a in range(9):
            b = 8 - a
            q = np.dot(cs.qw[sel], cs.qx[sel, 0] ** a * cs.qx[sel, 1] ** b)
            assert abs(q - polygon_moment(poly, a, b)) < 1e-13


def test_a_held_dry_region_is_not_fluid():
    """``held_dry`` removes its region from the fluid like an island: the slot of
    ``test_fluid_island_between_bodies_is_removed``, opened at its left end, stays fluid without
    it and is dry with it; its walls are then Γ^SC."""
    left = rect_outline(0, 0.2, 0.3, 0.49, 0.7)  # 0.01 short of the slot: its mouth is open
    lower, upper = rect_outline(1, 0.5, 0.3, 0.8, 0.495), rect_outline(2, 0.5, 0.505, 0.8, 0.7)
    right = rect_outline(3, 0.6, 0.3, 0.8, 0.7)
    bodies = [left, lower, upper, right]
    slot = shapely.box(0.52, 0.495, 0.6, 0.505)
    open_ = CutState(GRID, bodies, island_factor=2.0)
    held = CutState(GRID, bodies, island_factor=2.0, held_dry=slot)
    assert not open_.islands and not held.islands
    assert abs(open_.qw.sum() - held.qw.sum() - slot.area) < 1e-12

    def sc_length(cs):
        return sum(np.linalg.norm(p[:, 1] - p[:, 0], axis=1).sum() for p in
                   [cs.interface_points(k, ~cs.segments.fs)[0] for k in range(len(bodies))])
    # the two walls of the held part of the slot and its end
    assert abs(sc_length(held) - sc_length(open_) - (2 * 0.08 + 0.01)) < 1e-12


@pytest.mark.parametrize("x0, x1", [
    (0.33, 0.57),     # off every side: each side is fluid whole (no GEOS call)
    (0.0, 0.57),      # its side on the box's left side: that side's fluid ends at the body
    (-0.2, 0.57),     # through the left side
    (0.43, 1.0 - 1e-13),  # ending 1e-13 short of the right side: a sliver of fluid stays there
])
@pytest.mark.parametrize("y0", [0.0, 0.2371])  # standing on the bottom, or off it
def test_the_physical_part_of_each_box_side(x0, x1, y0):
    """``boundary_pieces``: the PHYSICAL part of every grid edge on each box side, against the
    intersection of that edge with the fluid region (GEOS), edge by edge."""
    o = rect_outline(0, x0, y0, x1, 0.61)
    cs = CutState(GRID, [o])
    X = GRID.nodes
    for side in ("left", "right", "bottom", "top"):
        edges = GRID.side_edges(side)
        k, s0, s1, vn = cs.boundary_pieces(side)
        got = np.zeros(len(edges))
        np.add.at(got, k, (s1 - s0) * np.linalg.norm(X[edges[k, 1]] - X[edges[k, 0]], axis=1))
        want = shapely.length(shapely.intersection(shapely.linestrings(X[edges]), cs.fluid))
        assert np.allclose(got, want, rtol=0.0, atol=1e-15), side
        assert np.all((s0 >= 0.0) & (s1 <= 1.0) & (s1 - s0 > 1e-14)) and np.array_equal(vn, GRID.side_edges(side)[k])


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_points_near_segments_match_geos(seed):
    """The fluid region's vertices on interface edges (``_near_pairs``): the same pairs as
    GEOS's ``dwithin`` query, for points on, beside and off random segments of all slopes
    (vertical and horizontal ones included) and at their ends."""
    from fsci.cut.state import _near_pairs

    rng = np.random.default_rng(seed)
    a = rng.uniform(0.0, 1.0, (60, 2))
    c = a + rng.uniform(-0.2, 0.2, (60, 2))
    c[:5, 0] = a[:5, 0]  # vertical
    c[5:10, 1] = a[5:10, 1]  # horizontal
    tol = 1e-9
    t = rng.uniform(0.0, 1.0, 60)
    d = c - a
    n = np.column_stack([-d[:, 1], d[:, 0]]) / np.linalg.norm(d, axis=1)[:, None]
    p = np.vstack([a + t[:, None] * d,                      # on the segments
                   a + t[:, None] * d + 0.5 * tol * n,      # within tol beside them
                   a + t[:, None] * d + 2.0 * tol * n,      # just beyond tol
                   a, c - 0.5 * tol * d / np.linalg.norm(d, axis=1)[:, None],  # at the ends, past one
                   rng.uniform(0.0, 1.0, (200, 2))])        # anywhere
    i_pt, i_seg = _near_pairs(p, a, c, tol)
    want_pt, want_seg = shapely.STRtree(shapely.linestrings(np.stack([a, c], axis=1))).query(
        shapely.points(p), predicate="dwithin", distance=tol)
    got = set(zip(i_pt.tolist(), i_seg.tolist()))
    assert got == set(zip(want_pt.tolist(), want_seg.tolist()))
    assert len(got) >= 180 and len(got) == len(i_pt)  # the on and within-tol points found, no pair twice


def _pieces_by_numpy(E, S, Kd, Ln):
    """The pieces between events as the cut made them with numpy (lexsort, groups of
    coincident events, the first moving end of a group, else its first grid line)."""
    from fsci.cut.state import END_X, END_Y, is_moving_end

    order = np.lexsort((S, E))
    E, S, Kd, Ln = E[order], S[order], Kd[order].copy(), Ln[order].copy()
    same = E[1:] == E[:-1]
    keep = same & ((S[1:] - S[:-1]) > 1e-13)
    group = np.concatenate([[0], np.cumsum(~(same & ~keep))])
    first = np.full(group[-1] + 1, -1)
    for ends in ((Kd == END_X) | (Kd == END_Y), is_moving_end(Kd)):
        for g in np.unique(group[ends]):
            first[g] = np.nonzero(ends & (group == g))[0][0]
    take = first[group]
    m = take >= 0
    Kd[m], Ln[m] = Kd[take[m]], Ln[take[m]]
    i = np.nonzero(keep)[0]
    return E[i], S[i], S[i + 1], Kd[i], Ln[i], Kd[i + 1], Ln[i + 1]


@pytest.mark.parametrize("seed", range(5))
def test_pieces_between_events_with_coincident_and_near_events(seed):
    """``_pieces_between_events`` (the interface pieces' split, compiled): the same pieces and
    end kinds as the numpy construction, on events with exact ties, ties within 1e-13 and
    every end kind, in random order."""
    from fsci.cut.state import _pieces_between_events

    rng = np.random.default_rng(seed)
    n = 200
    E = rng.integers(0, 6, n).astype(np.int64)
    S = rng.choice(np.array([0.0, 0.25, 0.25 + 5e-14, 0.5, 0.5 + 2e-13, 0.75, 1.0]), n)
    Kd = rng.choice(np.array([-1, 2, 3, 4, 5, 6]), n).astype(np.int64)
    Ln = rng.uniform(0.0, 10.0, n)
    got = _pieces_between_events(E, S, Kd, Ln)
    want = _pieces_by_numpy(E, S, Kd, Ln)
    assert len(got[0]) > 20
    for g, w in zip(got, want):
        assert np.array_equal(g, w)
    assert all(len(a) == 0 for a in _pieces_between_events(E[:0], S[:0], Kd[:0], Ln[:0]))


def test_interface_pieces_tile_each_edge_between_grid_lines_and_crossings():
    """The interface pieces of a disk and a tilted block that overlap it (made per body by one
    compiled loop): on every interface edge they run from s = 0 to 1 without gap or overlap
    (beyond the 1e-13 within which two events are one); no
    grid line crosses a piece's interior; an end on a grid line has that line's kind (END_X,
    END_Y) and coordinate; where the outlines cross, the pieces end with kind END_BODY on the
    crossing."""
    from fsci.cut.state import END_BODY, END_X, END_Y

    outlines = [disk_outline(0, (0.43, 0.47), 0.23, n_edges=61),
                rect_outline(1, 0.55, 0.2, 0.85, 0.6, angle=0.3)]
    seg = CutState(GRID, outlines, island_factor=0.0).segments
    crossings = shapely.intersection(outlines[0].polygon.exterior, outlines[1].polygon.exterior)
    crossings = shapely.get_coordinates(crossings)
    assert len(crossings) == 2
    body_ends = 0
    for b, o in enumerate(outlines):
        a, c = o.x[o.edges[:, 0]], o.x[o.edges[:, 1]]
        for e in range(len(o.edges)):
            m = np.nonzero((seg.body == b) & (seg.edge == e))[0]
            m = m[np.argsort(seg.s0[m])]
            s0, s1 = seg.s0[m], seg.s1[m]
            # (events closer than 1e-13, as a crossing and the fluid region's vertex on it, are one)
            assert s0[0] == 0.0 and s1[-1] == 1.0 and np.all(np.abs(s0[1:] - s1[:-1]) <= 1e-13), (b, e)
            p0 = a[e] + s0[:, None] * (c[e] - a[e])
            p1 = a[e] + s1[:, None] * (c[e] - a[e])
            for d, lines in ((0, GRID.xs), (1, GRID.ys)):
                lo, hi = np.minimum(p0[:, d], p1[:, d]), np.maximum(p0[:, d], p1[:, d])
                inside = (lines[None, :] > lo[:, None] + 1e-12) & (lines[None, :] < hi[:, None] - 1e-12)
                assert not inside.any(), (b, e)
            for kind, line, p in ((seg.kind0[m], seg.line0[m], p0), (seg.kind1[m], seg.line1[m], p1)):
                for d, k_line in ((0, END_X), (1, END_Y)):
                    on = kind == k_line
                    assert np.allclose(p[on, d], line[on], rtol=0.0, atol=1e-12)
                    assert np.all(np.min(np.abs((GRID.xs, GRID.ys)[d][None, :] - line[on][:, None]), axis=1) == 0.0)
                at_body = kind == END_BODY
                body_ends += int(at_body.sum())
                for q in p[at_body]:
                    assert np.min(np.linalg.norm(crossings - q, axis=1)) < 1e-12
    assert body_ends == 8  # two crossings, each ending two pieces on each of the two bodies
