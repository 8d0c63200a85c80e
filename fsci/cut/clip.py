"""The fluid part of cut cells from the fluid region's boundary, compiled (no overlay per cell).

A cell's fluid part ``P = cell ∩ fluid`` is bounded by the pieces of the fluid region's rings
inside the cell and by the stretches of the cell's sides that lie in the fluid. With the rings
oriented so that the fluid lies on their left, walking a cell's perimeter counter-clockwise
the fluid ends where a ring enters the cell and begins again where one leaves it, so the
stretches in the fluid run from each exit to the next entry. With all these boundary pieces
``(p, q)`` of ``∂P`` and the cell's lower-left corner ``o``, every integral over ``P`` is a sum
of signed integrals over the triangles ``(o, p, q)`` (the divergence theorem; the triangles
lie in the cell, which is convex, and pieces on the two sides through ``o`` give triangles of
zero area). A Gauss rule on each triangle, with the weights' sign the triangle's orientation,
is then exact for the same polynomial degree as on a triangulation of ``P``: the polygon
overlay and constrained Delaunay triangulation per cell that GEOS would do are not needed.

Cells where this walk is not well defined are left to GEOS (``irregular``): a crossing at (or
within round-off of) a grid node, a ring lying inside one cell, entries and exits that do not
alternate or coincide (a ring touching a side), a candidate cell no ring enters; and, for one
set of unknowns per fluid part, a cell with more than one entry (its fluid may be several
parts). A ring vertex on a grid line is an entry or exit like a crossing, and a ring edge
along a grid line (the box's sides, a body's side on a grid line) is a stretch of side.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from fsci.fem.quadrature import gauss_triangle

ENTRY, EXIT = 1, -1
NODE_TOL = 1e-12  # a crossing this close to a grid node (relative to the cell) is at the node


@njit(cache=True)
def _mark(i, j, nx, ny, cand_of, irregular):
    """Leave cell (i, j) to GEOS if it is a candidate."""
    if 0 <= i < nx and 0 <= j < ny:
        k = cand_of[j * nx + i]
        if k >= 0:
            irregular[k] = True


@njit(cache=True)
def _side_param(px, py, x0, x1, y0, y1):
    """Counter-clockwise perimeter coordinate s ∈ [0, 4) of point p on the boundary of the cell
    [x0, x1] × [y0, y1] (sides 0-3: bottom, right, top, left, each from its first corner
    counter-clockwise); -1 if p is not on it (exact comparisons: crossings lie on their grid
    line by construction)."""
    if py == y0 and px != x0:
        return min(max((px - x0) / (x1 - x0), 0.0), 1.0)
    if px == x1:
        return 1.0 + min(max((py - y0) / (y1 - y0), 0.0), 1.0)
    if py == y1:
        return 2.0 + min(max((x1 - px) / (x1 - x0), 0.0), 1.0)
    if px == x0:
        return 3.0 + min(max((y1 - py) / (y1 - y0), 0.0), 1.0) if py != y0 else 0.0
    return -1.0


@njit(cache=True)
def _point_at(kind, line, t, ax, ay, bx, by, xs, ys):
    """The point at parameter t of edge a -> b: on grid line ``line`` exactly for a crossing
    (``kind`` 0: x = xs[line], 1: y = ys[line]), else the edge's end (t = 0 or 1)."""
    if kind == 0:
        return xs[line], ay + t * (by - ay)
    if kind == 1:
        return ax + t * (bx - ax), ys[line]
    return (ax, ay) if t == 0.0 else (bx, by)


@njit(cache=True)
def _ring_pieces(xy, rstart, forward, xs, ys, cand_of, irregular,
                 seg_k, seg_p, seg_q, ev_k, ev_s, ev_kind, ev_p, count):
    """Split the rings' edges (traversed fluid on the left) at the grid lines: the pieces in
    candidate cells (``seg_*``) and where they enter or leave them (``ev_*``: candidate, side
    coordinate, ENTRY / EXIT, point), i.e. where a piece starts or ends on its cell's boundary.
    Edges along a grid line give no piece: the cell on their fluid side has them as a stretch
    of its side in the fluid, the other as one outside it. ``count`` returns the numbers of
    pieces and events (the arrays hold at most their length; the caller retries with room for
    all)."""
    nx, ny = len(xs) - 1, len(ys) - 1
    ns = 0
    ne = 0
    cap_s = seg_k.shape[0]
    cap_e = ev_k.shape[0]
    t_all = np.empty(len(xs) + len(ys) + 2)
    kind_all = np.empty(len(xs) + len(ys) + 2, dtype=np.int64)
    line_all = np.empty(len(xs) + len(ys) + 2, dtype=np.int64)
    for r in range(len(rstart) - 1):
        nv = rstart[r + 1] - rstart[r] - 1  # closed ring: its last point repeats the first
        crossed = False
        first_cell = -1
        for e in range(nv):
            if forward[r]:
                ia = rstart[r] + e
                ib = ia + 1
            else:
                ia = rstart[r + 1] - 1 - e
                ib = ia - 1
            ax, ay, bx, by = xy[ia, 0], xy[ia, 1], xy[ib, 0], xy[ib, 1]
            if ax == bx and ay == by:
                continue
            if ax == bx:
                i = np.searchsorted(xs, ax, side="left")
                if i < len(xs) and xs[i] == ax:
                    crossed = True
                    continue
            elif ay == by:
                j = np.searchsorted(ys, ay, side="left")
                if j < len(ys) and ys[j] == ay:
                    crossed = True
                    continue
            # parameters of the crossings with grid lines strictly inside the edge, in order
            n = 0
            t_all[n] = 0.0
            kind_all[n] = -1
            line_all[n] = -1
            n += 1
            dx, dy = bx - ax, by - ay
            for d in range(2):
                lines = xs if d == 0 else ys
                a0 = ax if d == 0 else ay
                dd = dx if d == 0 else dy
                if dd == 0.0:
                    continue
                lo, hi = min(a0, a0 + dd), max(a0, a0 + dd)
                i0 = np.searchsorted(lines, lo, side="right")
                i1 = np.searchsorted(lines, hi, side="left")
                for i in range(i0, i1):
                    t = (lines[i] - a0) / dd
                    if 0.0 < t < 1.0:
                        # insertion into the sorted list (few crossings per edge)
                        m = n
                        while m > 1 and t_all[m - 1] > t:
                            t_all[m] = t_all[m - 1]
                            kind_all[m] = kind_all[m - 1]
                            line_all[m] = line_all[m - 1]
                            m -= 1
                        t_all[m] = t
                        kind_all[m] = d
                        line_all[m] = i
                        n += 1
            t_all[n] = 1.0
            kind_all[n] = -1
            line_all[n] = -1
            n += 1
            if n > 2:
                crossed = True
            # crossings at a grid node, or within round-off of one: the cells around the node
            for m in range(1, n - 1):
                px, py = _point_at(kind_all[m], line_all[m], t_all[m], ax, ay, bx, by, xs, ys)
                lines = ys if kind_all[m] == 0 else xs  # the lines along the crossed one
                v = py if kind_all[m] == 0 else px
                jj = np.searchsorted(lines, v)
                for j in range(max(jj - 1, 0), min(jj + 1, len(lines))):
                    if abs(v - lines[j]) <= NODE_TOL * (lines[min(j + 1, len(lines) - 1)] - lines[max(j - 1, 0)]):
                        for a in range(line_all[m] - 1, line_all[m] + 1):
                            for b in range(j - 1, j + 1):
                                if kind_all[m] == 0:
                                    _mark(a, b, nx, ny, cand_of, irregular)
                                else:
                                    _mark(b, a, nx, ny, cand_of, irregular)
            # the pieces between consecutive crossings, each in one cell
            for m in range(n - 1):
                t0, t1 = t_all[m], t_all[m + 1]
                if not t1 > t0:
                    continue
                p0x, p0y = _point_at(kind_all[m], line_all[m], t0, ax, ay, bx, by, xs, ys)
                p1x, p1y = _point_at(kind_all[m + 1], line_all[m + 1], t1, ax, ay, bx, by, xs, ys)
                tm = 0.5 * (t0 + t1)
                ci = min(max(np.searchsorted(xs, ax + tm * dx, side="right") - 1, 0), nx - 1)
                cj = min(max(np.searchsorted(ys, ay + tm * dy, side="right") - 1, 0), ny - 1)
                c = cj * nx + ci
                if first_cell < 0:
                    first_cell = c
                k = cand_of[c]
                if k < 0:
                    continue
                if ns < cap_s:
                    seg_k[ns] = k
                    seg_p[ns, 0], seg_p[ns, 1] = p0x, p0y
                    seg_q[ns, 0], seg_q[ns, 1] = p1x, p1y
                ns += 1
                for end in range(2):
                    px = p0x if end == 0 else p1x
                    py = p0y if end == 0 else p1y
                    s = _side_param(px, py, xs[ci], xs[ci + 1], ys[cj], ys[cj + 1])
                    if s < 0.0:
                        continue
                    if ne < cap_e:
                        ev_k[ne] = k
                        ev_kind[ne] = ENTRY if end == 0 else EXIT
                        ev_p[ne, 0], ev_p[ne, 1] = px, py
                        ev_s[ne] = s
                    ne += 1
        if not crossed and first_cell >= 0:  # a ring inside one cell
            _mark(first_cell % nx, first_cell // nx, nx, ny, cand_of, irregular)
    count[0] = ns
    count[1] = ne


@njit(cache=True)
def _perimeter_pieces(ptr, ev_s, ev_kind, ev_p, cand_cells, xs, ys, nx, one_chain, irregular,
                      out_k, out_p, out_q):
    """The stretches of each regular candidate's sides in the fluid, from each exit to the next
    entry counter-clockwise (events sorted by candidate and side coordinate, ``ptr`` their
    start per candidate). Marks irregular the cells whose events do not alternate."""
    n = 0
    cx = np.empty(4)
    cy = np.empty(4)
    for k in range(len(ptr) - 1):
        if irregular[k]:
            continue
        e0, e1 = ptr[k], ptr[k + 1]
        m = e1 - e0
        if m == 0 or m % 2 == 1 or (one_chain and m != 2):
            irregular[k] = True
            continue
        ok = True
        for a in range(m):
            b = e0 + (a + 1) % m
            if ev_kind[e0 + a] == ev_kind[b] or (a + 1 < m and not ev_s[b] > ev_s[e0 + a]):
                ok = False
        if not ok:
            irregular[k] = True
            continue
        c = cand_cells[k]
        i, j = c % nx, c // nx
        cx[0], cx[1], cx[2], cx[3] = xs[i], xs[i + 1], xs[i + 1], xs[i]
        cy[0], cy[1], cy[2], cy[3] = ys[j], ys[j], ys[j + 1], ys[j + 1]
        for a in range(m):
            ea = e0 + a
            if ev_kind[ea] != EXIT:
                continue
            eb = e0 + (a + 1) % m
            s0, s1 = ev_s[ea], ev_s[eb]
            if s1 <= s0:
                s1 += 4.0
            px, py = ev_p[ea, 0], ev_p[ea, 1]
            corner = int(np.floor(s0)) + 1
            while corner < s1:
                qx, qy = cx[corner % 4], cy[corner % 4]
                out_k[n] = k
                out_p[n, 0], out_p[n, 1] = px, py
                out_q[n, 0], out_q[n, 1] = qx, qy
                n += 1
                px, py = qx, qy
                corner += 1
            out_k[n] = k
            out_p[n, 0], out_p[n, 1] = px, py
            out_q[n, 0], out_q[n, 1] = ev_p[eb, 0], ev_p[eb, 1]
            n += 1
    return n


@njit(cache=True)
def _ring_forward(xy, rstart, exterior):
    """Whether each closed ring, traversed as stored, has the region on its left: an exterior
    ring counter-clockwise, a hole clockwise (the sign of its shoelace area)."""
    out = np.empty(len(rstart) - 1, dtype=np.bool_)
    for r in range(len(rstart) - 1):
        a = 0.0
        for i in range(rstart[r], rstart[r + 1] - 1):
            a += xy[i, 0] * xy[i + 1, 1] - xy[i + 1, 0] * xy[i, 1]
        out[r] = (a > 0.0) == exterior[r]
    return out


@njit(cache=True)
def _fan(seg_k, seg_p, seg_q, n_seg, cells, xs, ys, nx, irregular, ref, ref_w, area, q_k, q_x, q_w, n_q):
    """Add the signed triangle (o, p, q) of each boundary piece of a regular cell, o its lower
    left corner, to the cell's area and its Gauss points (``ref``, ``ref_w``: the rule on the
    reference triangle); returns the new number of points."""
    nr = len(ref_w)
    for m in range(n_seg):
        k = seg_k[m]
        if irregular[k]:
            continue
        c = cells[k]
        ox, oy = xs[c % nx], ys[c // nx]
        e1x, e1y = seg_p[m, 0] - ox, seg_p[m, 1] - oy
        e2x, e2y = seg_q[m, 0] - ox, seg_q[m, 1] - oy
        det = e1x * e2y - e1y * e2x
        if det == 0.0:
            continue  # a piece on a side through o
        area[k] += 0.5 * det
        for g in range(nr):
            q_k[n_q] = k
            q_x[n_q, 0] = ox + ref[g, 0] * e1x + ref[g, 1] * e2x
            q_x[n_q, 1] = oy + ref[g, 0] * e1y + ref[g, 1] * e2y
            q_w[n_q] = det * ref_w[g]
            n_q += 1
    return n_q


def clip_cells(xy: np.ndarray, rstart: np.ndarray, exterior: np.ndarray, xs: np.ndarray, ys: np.ndarray,
               cells: np.ndarray, one_chain: bool, degree: int
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Fluid area and Gauss points of the candidate ``cells``.

    Parameters
    ----------
    xy, rstart
        Coordinates of the fluid region's closed rings, one after the other, and where each
        starts (``len(rings) + 1`` entries).
    exterior
        Whether each ring is an exterior ring (else a hole).
    xs, ys
        The grid lines.
    cells
        The candidate cells (those a ring may cross).
    one_chain
        Leave to GEOS every cell that more than one stretch of ring crosses (its fluid may be
        several parts).
    degree
        Total polynomial degree the points integrate exactly.

    Returns
    -------
    area
        ``(len(cells),)`` fluid area of each regular cell (0 for an irregular one).
    irregular
        ``(len(cells),)`` cells left to GEOS (see the module docstring).
    q_k, q_x, q_w
        The Gauss points of the regular cells (their candidate index, position, weight; the
        weights of a triangle have its orientation's sign).
    """
    nx = len(xs) - 1
    ny = len(ys) - 1
    n_cand = len(cells)
    cand_of = np.full(nx * ny, -1, dtype=np.int64)
    cand_of[cells] = np.arange(n_cand)
    irregular = np.zeros(n_cand, dtype=np.bool_)
    forward = _ring_forward(xy, rstart, exterior)
    count = np.zeros(2, dtype=np.int64)
    cap_s = cap_e = 4 * len(xy) + 64
    while True:
        seg_k, seg_p, seg_q = np.empty(cap_s, dtype=np.int64), np.empty((cap_s, 2)), np.empty((cap_s, 2))
        ev_k, ev_s, ev_kind, ev_p = (np.empty(cap_e, dtype=np.int64), np.empty(cap_e),
                                     np.empty(cap_e, dtype=np.int64), np.empty((cap_e, 2)))
        irregular[:] = False
        _ring_pieces(xy, rstart, forward, xs, ys, cand_of, irregular,
                     seg_k, seg_p, seg_q, ev_k, ev_s, ev_kind, ev_p, count)
        if count[0] <= cap_s and count[1] <= cap_e:
            break
        cap_s, cap_e = int(count[0]), int(count[1])
    ns, ne = int(count[0]), int(count[1])
    order = np.lexsort((ev_s[:ne], ev_k[:ne]))
    ev_k, ev_s, ev_kind, ev_p = ev_k[order], ev_s[order], ev_kind[order], ev_p[order]
    ptr = np.searchsorted(ev_k, np.arange(n_cand + 1))
    cap = 3 * ne + 8
    per_k, per_p, per_q = np.empty(cap, dtype=np.int64), np.empty((cap, 2)), np.empty((cap, 2))
    n_per = _perimeter_pieces(ptr, ev_s, ev_kind, ev_p, cells, xs, ys, nx, one_chain, irregular, per_k, per_p, per_q)
    ref, ref_w = gauss_triangle(degree)
    cap_q = (ns + n_per) * len(ref_w)
    area = np.zeros(n_cand)
    q_k, q_x, q_w = np.empty(cap_q, dtype=np.int64), np.empty((cap_q, 2)), np.empty(cap_q)
    n_q = _fan(seg_k, seg_p, seg_q, ns, cells, xs, ys, nx, irregular, ref, ref_w, area, q_k, q_x, q_w, 0)
    n_q = _fan(per_k, per_p, per_q, n_per, cells, xs, ys, nx, irregular, ref, ref_w, area, q_k, q_x, q_w, n_q)
    return area, irregular, q_k[:n_q], q_x[:n_q], q_w[:n_q]
