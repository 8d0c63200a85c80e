"""The cut of the background grid by the bodies (paper Sec. 3.1.2-3.1.3).

One :class:`CutState` per geometry holds everything the fluid and coupling terms read:

* cell states: ``FLUID`` (uncut, standard Gauss), ``CUT`` (integrated on its PHYSICAL part),
  ``SOLID`` (not integrated);
* the connected fluid *pieces* (largest first) and the sets of fluid unknowns (*virtual
  nodes*): one per background node (the paper's), or with ``separate_parts`` one per connected
  fluid part of the node's cells, so that fluid on both sides of a body thinner than a cell or
  of a shut valve is not coupled; ACTIVE virtual nodes and the faces that carry CIP / ghost
  penalty;
* volume quadrature on the physical part of cut cells: a collapsed Gauss rule exact for total
  degree ``quad_degree`` (5 by default: every Galerkin integrand of (22) on a rectangle is of
  total degree ≤ 5) on signed triangles from the cell's corner to the pieces of its fluid's
  boundary (:mod:`fsci.cut.clip`), or, where that walk is not defined, on a constrained
  Delaunay triangulation of the fluid polygon that GEOS clips from the cell;
* interface segments: every interface edge of every body split at grid lines, at crossings
  with other bodies' outlines and at the box boundary; each piece knows its body, edge, local
  coordinate range, background cell and whether it bounds fluid (Γ^FS) or not (Γ^SC: inside
  another body, bounding a removed island, or outside the box);
* the mouths of closed films (``mouths``): fluid boundary on the line at distance δ from an
  interface edge, for the bulk shape derivative only (:meth:`CutState._film_mouths`).

The physical fluid region is ``box − ⋃ bodies − islands``; an island is a connected fluid piece
whose bounding-box diagonal is below ``island_factor`` × the size of the cells it touches
(4C's SELFCUT_MESHCORRECTION_MULTIPLICATOR; 2 in its FSCI test), or a *trapped film*: a piece
that does not reach the box boundary and whose mean thickness 2 area / perimeter is below
``trapped_film`` × that size. A film of fluid enclosed between two contact zones of bodies
pressed together cannot flow anywhere: as incompressible fluid with the bodies' velocities on
its whole boundary it has a solution only if the bodies keep its volume exactly, which the
penalty contact does not. Thinner than a small fraction of a cell, it belongs to the contact
zone (paper Sec. 1, Figure 1, zone (3): fluid between contacting bodies that the macroscopic
model does not represent); kept, it stalls Newton (docs/cases/squeezed.md).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely
from numba import njit

from fsci.cut.clip import clip_cells
from fsci.fem.quadrature import gauss_quad, triangle_rule
from fsci.geometry.outlines import Outline
from fsci.mesh.grid import SIDES, Grid

FLUID, CUT, SOLID = 0, 1, 2
# kinds of interface-piece ends: fixed parameter, or on a grid line x = const / y = const (the end
# then moves along the line with the edge, see fsci.coupling.traction)
END_FIXED, END_X, END_Y = -1, 2, 3
# an end where the edge crosses another body's boundary edge (its index among all bodies' boundary
# edges in the end's line coordinate): the end moves with both edges (fsci.coupling.traction)
END_BODY = 4
# an end where the edge meets the boundary of a closed film: the line at distance film_closure ×
# (smallest cell) from another body's edge, on the side of its outward normal (END_FILM_OUT) or
# the other side (END_FILM_IN); the edge in the line coordinate as for END_BODY
END_FILM_OUT, END_FILM_IN = 5, 6
MOVING_ENDS = (END_BODY, END_FILM_OUT, END_FILM_IN)  # ends on another body's (offset) edge
# (coupling pieces only, not the cut's) an end where node 0 / 1 of a body's coupling edge projects
# along the edge's normal (paper Remark 9) when that edge is not the piece's opposite segment: the
# opposite surface ends there (a tip) and another one, or none, is seen beyond; the coordinate is
# the edge's index among all bodies' coupling edges (fsci.coupling.points.build_pieces)
END_NODE0, END_NODE1 = 7, 8
AREA_TOL = 1e-15  # relative to the cell area: below this a fluid or solid part is treated as empty
MITRE_LIMIT = 5.0  # of the grown outlines of closed films: a corner reaches at most this × δ out (GEOS's default)


def is_moving_end(kind: np.ndarray) -> np.ndarray:
    """Whether each end kind is one of ``MOVING_ENDS`` (the consecutive kinds 4-6; a comparison
    instead of ``np.isin``, which costs some 30 µs on a few hundred ends)."""
    return (kind >= END_BODY) & (kind <= END_FILM_IN)


def is_end_on_edge(kind: np.ndarray) -> np.ndarray:
    """Whether each end kind takes its position from an edge of a body other than the piece's
    opposite segment (``MOVING_ENDS``, ``END_NODE0``, ``END_NODE1``: the consecutive kinds 4-8)."""
    return (kind >= END_BODY) & (kind <= END_NODE1)


@dataclass
class Segments:
    """Interface pieces (one row per piece)."""

    body: np.ndarray  # body index
    edge: np.ndarray  # index into that body's interface edges
    s0: np.ndarray  # local coordinate range on the edge, 0 at node a, 1 at node b
    s1: np.ndarray
    cell: np.ndarray  # background cell evaluated for fluid quantities
    part: np.ndarray  # fluid part of that cell on the wetted side (cell + n_cells × k, CutState.part_conn)
    fs: np.ndarray  # True: bounds the physical fluid (Γ^FS); False: Γ^SC
    kind0: np.ndarray  # kind of each end (END_FIXED, END_X, END_Y, MOVING_ENDS) and its grid-line
    # coordinate, or for MOVING_ENDS the index of the other body's edge among all bodies' boundary edges
    line0: np.ndarray
    kind1: np.ndarray
    line1: np.ndarray
    inside: np.ndarray  # the piece faces into the fluid box (not outside it, not on a box side facing out)

    def __len__(self) -> int:
        return len(self.body)


@njit(cache=True)
def _raster_edges(p0, p1, xs, ys, tol, mark):
    """Mark cells whose closed rectangle may touch a segment (bounding-box test)."""
    nx = len(xs) - 1
    ny = len(ys) - 1
    for k in range(p0.shape[0]):
        xmin = min(p0[k, 0], p1[k, 0]) - tol
        xmax = max(p0[k, 0], p1[k, 0]) + tol
        ymin = min(p0[k, 1], p1[k, 1]) - tol
        ymax = max(p0[k, 1], p1[k, 1]) + tol
        i0 = max(np.searchsorted(xs, xmin, side="right") - 1, 0)
        i1 = min(np.searchsorted(xs, xmax, side="left"), nx)
        j0 = max(np.searchsorted(ys, ymin, side="right") - 1, 0)
        j1 = min(np.searchsorted(ys, ymax, side="left"), ny)
        for j in range(j0, j1):
            for i in range(i0, i1):
                mark[j * nx + i] = True


@njit(cache=True)
def _crossed_cells(a, b, xs, ys, crossed):
    """Mark cells whose open interior segment a->b may meet. Exact in the direction that
    matters: an unmarked cell is certainly not met (the segment lies in a closed half-plane
    outside the cell's open interior, or its line misses the closed cell by a margin far above
    round-off); marked cells are clipped exactly afterwards."""
    nx = len(xs) - 1
    ny = len(ys) - 1
    for k in range(a.shape[0]):
        ax, ay, bx, by = a[k, 0], a[k, 1], b[k, 0], b[k, 1]
        xmin, xmax = min(ax, bx), max(ax, bx)
        ymin, ymax = min(ay, by), max(ay, by)
        # cells with xs[i] < xmax and xs[i+1] > xmin (open x-range meets [xmin, xmax]), same in y
        i0 = max(np.searchsorted(xs, xmin, side="right") - 1, 0)
        i1 = min(np.searchsorted(xs, xmax, side="left") - 1, nx - 1)
        j0 = max(np.searchsorted(ys, ymin, side="right") - 1, 0)
        j1 = min(np.searchsorted(ys, ymax, side="left") - 1, ny - 1)
        dx = bx - ax
        dy = by - ay
        for j in range(j0, j1 + 1):
            for i in range(i0, i1 + 1):
                c = j * nx + i
                if crossed[c]:
                    continue
                pos = False
                neg = False
                big = 0.0
                for cxy in range(4):
                    px = xs[i + (1 if cxy == 1 or cxy == 2 else 0)] - ax
                    py = ys[j + (1 if cxy >= 2 else 0)] - ay
                    cr = dx * py - dy * px
                    big = max(big, abs(dx * py) + abs(dy * px))
                    if cr > 0.0:
                        pos = True
                    if cr < 0.0:
                        neg = True
                    if cr == 0.0:
                        pos = True
                        neg = True
                # separated by the line only if all corners lie strictly on one side, by more
                # than a generous multiple of the round-off of the cross products
                margin = 1e-12 * big
                sep = True
                for cxy in range(4):
                    px = xs[i + (1 if cxy == 1 or cxy == 2 else 0)] - ax
                    py = ys[j + (1 if cxy >= 2 else 0)] - ay
                    if abs(dx * py - dy * px) <= margin:
                        sep = False
                if not (sep and (pos != neg)):
                    crossed[c] = True


@njit(cache=True)
def _grid_crossings(a, b, xs, ys, out_edge, out_s, out_kind, out_line, count):
    """Parameters in (0, 1) where segments a->b cross grid lines (incl. the box sides), with the
    kind of line (``END_X``: x = const, ``END_Y``: y = const) and its coordinate."""
    n = 0
    for k in range(a.shape[0]):
        for d in range(2):
            lines = xs if d == 0 else ys
            lo = min(a[k, d], b[k, d])
            hi = max(a[k, d], b[k, d])
            delta = b[k, d] - a[k, d]
            if hi - lo <= 0.0:
                continue
            i0 = np.searchsorted(lines, lo, side="right")
            i1 = np.searchsorted(lines, hi, side="left")
            for i in range(i0, i1):
                s = (lines[i] - a[k, d]) / delta
                if 0.0 < s < 1.0:
                    if n < out_s.shape[0]:
                        out_edge[n] = k
                        out_s[n] = s
                        out_kind[n] = END_X if d == 0 else END_Y
                        out_line[n] = lines[i]
                    n += 1
    count[0] = n


@njit(cache=True)
def _points_near_segments(p, a, c, tol, out_point, out_seg, count):
    """Pairs (point ``i``, segment ``j``) with the distance from ``p[i]`` to the segment
    ``a[j] c[j]`` at most ``tol``, by point and then segment; ``count[0]`` their number (the
    first ``len(out_point)`` are stored). The segments are searched by the left end of their
    bounds (sorted), within the widest segment's width of the point."""
    m = a.shape[0]
    x_lo = np.minimum(a[:, 0], c[:, 0])
    order = np.argsort(x_lo)
    x_sorted = x_lo[order]
    width = 0.0
    for j in range(m):
        width = max(width, abs(c[j, 0] - a[j, 0]))
    found = np.empty(m, dtype=np.int64)
    n = 0
    for i in range(p.shape[0]):
        px, py = p[i, 0], p[i, 1]
        k0 = np.searchsorted(x_sorted, px - width - tol, side="left")
        k1 = np.searchsorted(x_sorted, px + tol, side="right")
        nf = 0
        for k in range(k0, k1):
            j = order[k]
            if px > max(a[j, 0], c[j, 0]) + tol or py < min(a[j, 1], c[j, 1]) - tol \
                    or py > max(a[j, 1], c[j, 1]) + tol:
                continue
            dx, dy = c[j, 0] - a[j, 0], c[j, 1] - a[j, 1]
            wx, wy = px - a[j, 0], py - a[j, 1]
            L2 = dx * dx + dy * dy
            r = (wx * dx + wy * dy) / L2 if L2 > 0.0 else 0.0
            if r <= 0.0:
                d2 = wx * wx + wy * wy
            elif r >= 1.0:
                d2 = (px - c[j, 0]) ** 2 + (py - c[j, 1]) ** 2
            else:
                cr = wx * dy - wy * dx
                d2 = cr * cr / L2
            if d2 <= tol * tol:
                found[nf] = j
                nf += 1
        found[:nf].sort()
        for q in range(nf):
            if n < out_point.shape[0]:
                out_point[n] = i
                out_seg[n] = found[q]
            n += 1
    count[0] = n


@njit(cache=True)
def _pieces_between_events(E, S, Kd, Ln):
    """The pieces of one body's edges between consecutive events (edge ``E``, parameter ``S``,
    end kind ``Kd`` and its coordinate ``Ln``): events sorted by edge and parameter (stably,
    as ``np.lexsort``), a piece between two events of one edge more than 1e-13 apart. Events
    that coincide (a crossing and the fluid region's vertex there, as where an outline leaves
    the box) all take the kind of the first of them that is a moving end (a crossing with
    another body or a closed film's end), else of the first on a grid line: a fixed end there
    left the end's motion out of the Jacobian (Newton linear at a rate of 1e-3 on the stamp,
    whose outline crosses the box's top). Returns the pieces' edge, ``s0``, ``s1`` and the kind
    and coordinate of both ends."""
    n = E.shape[0]
    o1 = np.argsort(S, kind="mergesort")
    order = o1[np.argsort(E[o1], kind="mergesort")]
    E, S, Kd, Ln = E[order], S[order], Kd[order], Ln[order]
    group = np.zeros(n, dtype=np.int64)
    keep = np.zeros(max(n - 1, 0), dtype=np.bool_)
    g = 0
    for i in range(n - 1):
        same = E[i + 1] == E[i]
        keep[i] = same and S[i + 1] - S[i] > 1e-13
        if keep[i] or not same:
            g += 1
        group[i + 1] = g
    first_line = np.full(g + 1, -1, dtype=np.int64)
    first_moving = np.full(g + 1, -1, dtype=np.int64)
    for i in range(n - 1, -1, -1):  # the first of each kind in its group
        if Kd[i] == END_X or Kd[i] == END_Y:
            first_line[group[i]] = i
        elif END_BODY <= Kd[i] <= END_FILM_IN:
            first_moving[group[i]] = i
    kind = Kd.copy()
    line = Ln.copy()
    for i in range(n):
        t = first_moving[group[i]]
        if t < 0:
            t = first_line[group[i]]
        if t >= 0:
            kind[i] = Kd[t]
            line[i] = Ln[t]
    m = 0
    for i in range(n - 1):
        m += keep[i]
    edge, s0, s1 = np.empty(m, dtype=np.int64), np.empty(m), np.empty(m)
    k0, l0, k1, l1 = np.empty(m, dtype=np.int64), np.empty(m), np.empty(m, dtype=np.int64), np.empty(m)
    j = 0
    for i in range(n - 1):
        if keep[i]:
            edge[j], s0[j], s1[j] = E[i], S[i], S[i + 1]
            k0[j], l0[j], k1[j], l1[j] = kind[i], line[i], kind[i + 1], line[i + 1]
            j += 1
    return edge, s0, s1, k0, l0, k1, l1


@njit(cache=True)
def _body_pieces(a, c, normals, xs, ys, b, first, cross_body, cross_edge, cross_s, cross_kind, cross_other,
                 on_body, on_edge, on_s, on_kind, on_other):
    """The interface pieces of body ``b`` (interface edges ``a → c``, their outward ``normals``;
    the body's first edge is edge ``first`` of all bodies'): its edges split at their ends
    (fixed), at the grid lines they cross (:func:`_grid_crossings`), at the crossings with other
    bodies (``cross_*``, of all bodies) and at the fluid region's vertices on them (``on_*``),
    by :func:`_pieces_between_events`, in this order of events. Returns the pieces' edge,
    ``s0``, ``s1``, the kind and coordinate of both ends, the midpoint and the edge's normal."""
    n_edges = a.shape[0]
    cap = 64 * n_edges + 64
    cnt = np.zeros(1, dtype=np.int64)
    for _ in range(2):  # second pass only if the first buffer was too small
        oe, os_, ok_, ol_ = np.empty(cap, dtype=np.int64), np.empty(cap), np.empty(cap, dtype=np.int64), np.empty(cap)
        _grid_crossings(a, c, xs, ys, oe, os_, ok_, ol_, cnt)
        if cnt[0] <= cap:
            break
        cap = cnt[0]
    n_grid = cnt[0]
    n = 2 * n_edges + n_grid + np.sum(cross_body == b) + np.sum(on_body == b)
    E, S, Kd, Ln = np.empty(n, dtype=np.int64), np.empty(n), np.empty(n, dtype=np.int64), np.empty(n)
    for k in range(n_edges):
        E[k], S[k], Kd[k], Ln[k] = k, 0.0, END_FIXED, 0.0
        E[n_edges + k], S[n_edges + k], Kd[n_edges + k], Ln[n_edges + k] = k, 1.0, END_FIXED, 0.0
    j = 2 * n_edges
    for k in range(n_grid):
        E[j], S[j], Kd[j], Ln[j] = oe[k], os_[k], ok_[k], ol_[k]
        j += 1
    for k in range(cross_body.shape[0]):
        if cross_body[k] == b:
            E[j], S[j], Kd[j], Ln[j] = cross_edge[k] - first, cross_s[k], cross_kind[k], cross_other[k]
            j += 1
    for k in range(on_body.shape[0]):
        if on_body[k] == b:
            E[j], S[j], Kd[j], Ln[j] = on_edge[k] - first, on_s[k], on_kind[k], on_other[k]
            j += 1
    edge, s0, s1, k0, l0, k1, l1 = _pieces_between_events(E, S, Kd, Ln)
    mid = np.empty((edge.shape[0], 2))
    nrm = np.empty((edge.shape[0], 2))
    for k in range(edge.shape[0]):
        e = edge[k]
        sm = 0.5 * (s0[k] + s1[k])
        for i in range(2):
            mid[k, i] = a[e, i] + sm * (c[e, i] - a[e, i])
            nrm[k, i] = normals[e, i]
    return edge, s0, s1, k0, l0, k1, l1, mid, nrm


def _near_pairs(p: np.ndarray, a: np.ndarray, c: np.ndarray, tol: float) -> tuple[np.ndarray, np.ndarray]:
    """Point and segment indices of :func:`_points_near_segments` as two arrays."""
    cnt = np.zeros(1, dtype=np.int64)
    cap = 4 * len(p) + 16
    for _ in range(2):  # second pass only if the first buffer was too small
        i_pt, i_seg = np.empty(cap, dtype=np.int64), np.empty(cap, dtype=np.int64)
        _points_near_segments(p, a, c, tol, i_pt, i_seg, cnt)
        if cnt[0] <= cap:
            break
        cap = int(cnt[0])
    return i_pt[:cnt[0]], i_seg[:cnt[0]]


def _segment_events(A0, A1, B0, B1, tol=1e-12):
    """Parameters on segments A where they meet segments B (pairwise arrays).

    Returns (pair index, s, proper) for proper crossings (``proper`` True: the lines are not
    parallel), touching points and the end points of collinear overlaps."""
    d = A1 - A0
    e = B1 - B0
    w = B0 - A0
    den = d[:, 0] * e[:, 1] - d[:, 1] * e[:, 0]
    ld = np.linalg.norm(d, axis=1)
    le = np.linalg.norm(e, axis=1)
    par = np.abs(den) <= tol * ld * le
    idx, ss = [], []
    k = np.nonzero(~par)[0]
    s = (w[k, 0] * e[k, 1] - w[k, 1] * e[k, 0]) / den[k]
    t = (w[k, 0] * d[k, 1] - w[k, 1] * d[k, 0]) / den[k]
    ok = (s >= -tol) & (s <= 1 + tol) & (t >= -tol) & (t <= 1 + tol)
    idx.append(k[ok])
    ss.append(np.clip(s[ok], 0.0, 1.0))
    n_proper = int(ok.sum())
    k = np.nonzero(par)[0]
    if len(k):
        dist = np.abs(w[k, 0] * d[k, 1] - w[k, 1] * d[k, 0]) / ld[k]
        col = k[dist <= tol * np.maximum(ld[k], 1.0)]
        for P in (B0, B1):
            sp = np.einsum("ij,ij->i", P[col] - A0[col], d[col]) / ld[col] ** 2
            inside = (sp >= -tol) & (sp <= 1 + tol)
            idx.append(col[inside])
            ss.append(np.clip(sp[inside], 0.0, 1.0))
    idx_all = np.concatenate(idx)
    proper = np.zeros(len(idx_all), dtype=bool)
    proper[:n_proper] = True
    return idx_all, np.concatenate(ss), proper


class CutState:
    """Cut of ``grid`` by the bodies' ``outlines`` (see module docstring).

    Parameters
    ----------
    grid
        The background grid.
    outlines
        Current outlines of all bodies.
    island_factor
        Fluid pieces with bounding-box diagonal < island_factor × local cell diagonal are
        removed.
    quad_degree
        Total polynomial degree integrated exactly on cut cells.
    keep_nodes
        Nodes that must stay ACTIVE (solution-space update rule, paper Sec. 3.4.3).
    trapped_film
        Enclosed fluid pieces thinner on average than ``trapped_film`` × (cell diagonal) are
        islands (see module docstring).
    film_closure
        Gaps between two different bodies thinner than ``2 film_closure × (smallest cell)`` are
        not fluid (closed contact whose discrete gap is slightly positive; see docs).
    separate_parts
        One set of fluid unknowns per connected fluid part of a node's cells (False: one per
        node, the paper's; see :meth:`_build_active`).
    held_dry
        A region that is not fluid whatever the gap there (dropped like an island): where the
        fluid's topology alternated within a Newton solve (``System.update_cut``).
    """

    def __init__(self, grid: Grid, outlines: list[Outline], island_factor: float = 2.0, quad_degree: int = 5,
                 keep_nodes: np.ndarray | None = None, film_closure: float = 0.0,
                 separate_parts: bool = False, trapped_film: float = 0.1,
                 held_dry: shapely.Geometry | None = None) -> None:
        self.grid = grid
        self.held_dry = held_dry
        self.trapped_film = trapped_film
        self.outlines = outlines
        self.island_factor = island_factor
        self.film_closure = film_closure
        self.separate_parts = separate_parts
        self.quad_degree = quad_degree
        x0, x1, y0, y1 = grid.box
        self.box = shapely.box(x0, y0, x1, y1)
        self._build_region()
        self._tree = shapely.STRtree(self.pieces) if len(self.pieces) > 1 else None
        self._classify_cells()
        self._build_quadrature()
        self._build_segments()
        self._build_active(keep_nodes)

    # ----------------------------------------------------------------- fluid region
    def _build_region(self) -> None:
        g = self.grid
        bodies = [o.polygon for o in self.outlines]
        held = [self.held_dry] if self.held_dry is not None and not self.held_dry.is_empty else []
        films = self._closed_films(bodies)
        self.has_films = bool(films)
        solid = shapely.union_all(bodies + films + held) if bodies else shapely.Polygon()
        fluid = shapely.difference(self.box, solid)
        parts = list(shapely.get_parts(fluid)) if not fluid.is_empty else []
        keep, islands = [], []
        diag = np.hypot(*g.cell_size.T)
        for part in parts:
            if part.area <= 0.0:
                continue
            bx0, by0, bx1, by1 = part.bounds
            size = np.hypot(bx1 - bx0, by1 - by0)
            cells = g.locate(np.array([[bx0, by0], [bx1, by1], [0.5 * (bx0 + bx1), 0.5 * (by0 + by1)]]))
            h = float(diag[cells].max())
            (islands if size < self.island_factor * h or self._is_trapped_film(part, h) else keep).append(part)
        # (all kept: the difference is the region already, no union to make)
        self.fluid = (fluid if len(keep) == len(parts) else shapely.union_all(keep)) if keep else shapely.Polygon()
        self._dry = [solid, *islands]  # all that is not fluid (its bounds: _side_is_fluid)
        # connected pieces, largest first (two pieces touching in a point are two pieces)
        self.pieces = sorted(shapely.get_parts(self.fluid), key=lambda q: -q.area) if keep else []
        if len(self.pieces) > 1:
            shapely.prepare(self.pieces)
        self.islands = islands
        shapely.prepare(self.fluid)

    def _is_trapped_film(self, part: shapely.Geometry, h: float) -> bool:
        """Whether fluid piece ``part`` is a film trapped between bodies: it does not reach the
        box boundary and its mean thickness (2 area / perimeter) is below ``trapped_film`` × the
        cell diagonal ``h``."""
        if self.trapped_film <= 0.0 or part.intersects(self.box.exterior):
            return False
        return 2.0 * part.area / part.length < self.trapped_film * h

    @property
    def film_delta(self) -> float:
        """Half-thickness δ of the films that are closed: ``film_closure`` × (smallest cell)."""
        return self.film_closure * self.grid.h_min

    def _closed_films(self, bodies: list[shapely.Geometry]) -> list[shapely.Geometry]:
        """Regions within δ of two different bodies: films thinner than 2δ between bodies in
        contact, whose sign of the (tiny) discrete gap must not decide what is fluid."""
        if self.film_closure <= 0.0 or len(bodies) < 2 or not self._bodies_near(2.0 * MITRE_LIMIT * self.film_delta):
            return []
        grown = shapely.buffer(np.array(bodies, dtype=object), self.film_delta, join_style="mitre",
                               mitre_limit=MITRE_LIMIT)
        i, j = shapely.STRtree(grown).query(grown, predicate="intersects")
        pairs = i < j
        if not pairs.any():
            return []
        films = shapely.intersection(grown[i[pairs]], grown[j[pairs]])
        return [f for f in films if not f.is_empty]

    def _bodies_near(self, margin: float) -> bool:
        """Whether the bounding boxes of two bodies' nodes, each grown by ``margin``, overlap;
        if not, no two bodies cross, touch or come within ``margin`` of each other."""
        if len(self.outlines) < 2:
            return False
        b = shapely.bounds([o.polygon for o in self.outlines]).tolist()  # (x0, y0, x1, y1): a body's outer boundary
        return any(p[0] - q[2] <= 2 * margin and q[0] - p[2] <= 2 * margin and p[1] - q[3] <= 2 * margin
                   and q[1] - p[3] <= 2 * margin for i, p in enumerate(b) for q in b[i + 1:])

    def _classify_cells(self) -> None:
        """FLUID / CUT / SOLID per cell. A cell whose open interior no segment of the fluid
        region's boundary can meet (exact: axis-separated, or the segment's line strictly misses
        the closed cell) is entirely fluid or entirely solid, decided by its centre; the others
        are clipped from the region's rings (:mod:`fsci.cut.clip`), or by GEOS where that walk
        is not well defined, and classified by the area of their fluid part."""
        g = self.grid
        n = g.n_cells
        state = np.full(n, SOLID, dtype=np.int8)
        self._polys: dict[int, shapely.Geometry] = {}  # fluid of the cut cells clipped by GEOS
        # Gauss points of the cut cells clipped from the rings: cell, point, weight
        self._fan = (np.zeros(0, dtype=np.int64), np.zeros((0, 2)), np.zeros(0))
        area_cell = g.cell_size[:, 0] * g.cell_size[:, 1]
        self.fluid_area = np.zeros(n)
        self.clipped_by_geos = 0
        if self.fluid.is_empty:
            self.state = state
            return
        parts = shapely.get_parts(self.fluid)
        rings = shapely.get_rings(parts)
        xy, ring = shapely.get_coordinates(rings, return_index=True)
        same = ring[1:] == ring[:-1]
        crossed = np.zeros(n, dtype=np.bool_)
        _crossed_cells(xy[:-1][same], xy[1:][same], g.xs, g.ys, crossed)
        ij = g.cell_ij
        other = np.nonzero(~crossed)[0]
        cx = 0.5 * (g.xs[ij[other, 0]] + g.xs[ij[other, 0] + 1])
        cy = 0.5 * (g.ys[ij[other, 1]] + g.ys[ij[other, 1] + 1])
        inside = other[shapely.contains_xy(self.fluid, cx, cy)]
        state[inside] = FLUID
        self.fluid_area[inside] = area_cell[inside]
        cand = np.nonzero(crossed)[0]
        if len(cand):
            exterior = np.zeros(len(rings), dtype=bool)
            exterior[np.cumsum(np.concatenate([[0], shapely.get_num_interior_rings(parts)[:-1] + 1]))] = True
            rstart = np.searchsorted(ring, np.arange(len(rings) + 1))
            areas, irregular, q_k, q_x, q_w = clip_cells(xy, rstart, exterior, g.xs, g.ys, cand, self.separate_parts,
                                                        self.quad_degree)
            geos = np.nonzero(irregular)[0]
            self.clipped_by_geos = len(geos)
            self._clip_by_geos(cand[geos].tolist())
            areas[geos] = [self._polys[c].area for c in cand[geos].tolist()]
            rel = areas / area_cell[cand]
            full = rel >= 1.0 - AREA_TOL
            empty = rel <= AREA_TOL
            state[cand[full]] = FLUID
            self.fluid_area[cand[full]] = area_cell[cand[full]]
            cut = ~full & ~empty
            state[cand[cut]] = CUT
            self.fluid_area[cand[cut]] = areas[cut]
            for c in cand[geos[~cut[geos]]].tolist():  # (GEOS's polygons are kept for CUT cells only)
                del self._polys[c]
            fan = cut[q_k]
            self._fan = (cand[q_k[fan]], q_x[fan], q_w[fan])
        self.state = state

    @property
    def polygons(self) -> dict[int, shapely.Geometry]:
        """Fluid part of every CUT cell as a GEOS geometry (computed on first use where the cell
        was clipped without GEOS)."""
        cells = self.cut_cells.tolist()
        self._clip_by_geos([c for c in cells if c not in self._polys])
        return {c: self._polys[c] for c in cells}

    def _cut_polygon(self, c: int) -> shapely.Geometry:
        """Fluid part of CUT cell ``c`` as a GEOS geometry."""
        if c not in self._polys:
            self._clip_by_geos([c])
        return self._polys[c]

    def _clip_by_geos(self, cells: list[int]) -> None:
        """GEOS's clip of the fluid region by each of ``cells``, kept."""
        if not cells:
            return
        g = self.grid
        ij = g.cell_ij[cells]
        boxes = shapely.box(g.xs[ij[:, 0]], g.ys[ij[:, 1]], g.xs[ij[:, 0] + 1], g.ys[ij[:, 1] + 1])
        for c, p in zip(cells, shapely.intersection(boxes, self.fluid)):
            self._polys[c] = _polygonal(p)

    def piece_of(self, points: np.ndarray) -> np.ndarray:
        """Label of the fluid piece containing each point (the nearest piece for a point
        outside the fluid, e.g. on an interface up to round-off); zeros for one piece."""
        lab = np.zeros(len(points), dtype=np.int64)
        if self._tree is None or len(points) == 0:
            return lab
        todo = np.arange(len(points))
        for k, q in enumerate(self.pieces):  # prepared point-in-polygon, largest piece first
            if len(todo) == 0:
                break
            inside = shapely.contains_xy(q, points[todo, 0], points[todo, 1])
            lab[todo[inside]] = k
            todo = todo[~inside]
        if len(todo):
            i, near = self._tree.query_nearest(shapely.points(points[todo]), all_matches=False)
            lab[todo[i]] = near
        return lab

    def local_part(self, cells: np.ndarray, points: np.ndarray) -> np.ndarray:
        """Index of the fluid part of its cell containing each point (the nearest part for a
        point on or off its boundary); 0 in a cell of one part."""
        out = np.zeros(len(cells), dtype=np.int64)
        if not self.split_cells:
            return out
        for k in np.nonzero(np.isin(cells, list(self.split_cells)))[0]:
            parts = self.split_cells[int(cells[k])]
            pt = shapely.points(points[k])
            out[k] = int(np.argmin(shapely.distance(parts, pt)))
        return out

    def _build_quadrature(self) -> None:
        """Tensor Gauss on FLUID cells, triangle rules on the PHYSICAL part of CUT cells; one
        integration part per connected fluid part of a cell, numbered ``cell + n_cells × k``
        (k-th polygon of the cell's fluid; k = 0 in a cell of one part)."""
        g = self.grid
        fluid_cells = np.nonzero(self.state == FLUID)[0]
        xi, w = gauss_quad(2)
        size = g.cell_size[fluid_cells]
        x0 = np.column_stack([g.xs[g.cell_ij[fluid_cells, 0]], g.ys[g.cell_ij[fluid_cells, 1]]])
        pts_f = (x0[:, None, :] + 0.5 * (xi[None] + 1.0) * size[:, None, :])
        wts_f = w[None, :] * (0.25 * size[:, 0] * size[:, 1])[:, None]
        part_f = fluid_cells
        # cells whose fluid is several polygons (a body thinner than the cell through it, a shut
        # valve): only among those clipped by GEOS (the others are crossed by one stretch of ring)
        self.split_cells = {c: np.array(shapely.get_parts(p)) for c, p in self._polys.items()
                            if shapely.get_num_geometries(p) > 1} if self.separate_parts else {}
        owner_c, pts_c, wts_c = self._fan
        geos_cells = np.array(sorted(self._polys), dtype=np.int64)
        if len(geos_cells):
            # all triangles of these cells at once (same triangles, same order as one cell at a time)
            tris = shapely.constrained_delaunay_triangles(np.array([self._polys[int(c)] for c in geos_cells], dtype=object))
            parts, which = shapely.get_parts(tris, return_index=True)
            keep = shapely.area(parts) > 0.0
            parts, which = parts[keep], which[keep]
            xy, ring = shapely.get_coordinates(shapely.get_exterior_ring(parts), return_index=True)
            first = np.searchsorted(ring, np.arange(len(parts)))
            verts = xy[first[:, None] + np.arange(3)[None, :]].reshape(-1, 3, 2)
            pts_g, wts_g = triangle_rule(verts, self.quad_degree)
            cell_t = geos_cells[which]
            part_t = cell_t + g.n_cells * self.local_part(cell_t, verts.mean(axis=1))
            pts_c = np.vstack([pts_c, pts_g])
            wts_c = np.concatenate([wts_c, wts_g])
            owner_c = np.concatenate([owner_c, np.repeat(part_t, len(wts_g) // max(len(parts), 1))])
        pts = np.vstack([pts_f.reshape(-1, 2), pts_c])
        wts = np.concatenate([wts_f.ravel(), wts_c])
        owner = np.concatenate([np.repeat(part_f, 4), owner_c])
        order = np.argsort(owner, kind="stable")
        owner = owner[order]
        first = np.flatnonzero(np.diff(owner, prepend=owner[:1] - 1))  # where each part's run starts
        self.int_parts = owner[first].astype(np.int64)
        self.int_cells = self.int_parts % g.n_cells
        self.qptr = np.append(first, len(owner)).astype(np.int64)
        self.qx = np.ascontiguousarray(pts[order])
        self.qw = np.ascontiguousarray(wts[order])

    # ----------------------------------------------------------------- interface
    def _build_segments(self) -> None:
        g = self.grid
        hmin = g.h_min
        nb = len(self.outlines)
        # interface edges of all bodies (rows per body from off[b]) and every boundary edge
        a_if = np.vstack([o.x[o.edges[:, 0]] for o in self.outlines]) if nb else np.zeros((0, 2))
        c_if = np.vstack([o.x[o.edges[:, 1]] for o in self.outlines]) if nb else np.zeros((0, 2))
        off = np.concatenate([[0], np.cumsum([len(o.edges) for o in self.outlines])]).astype(np.int64)
        body_if = np.repeat(np.arange(nb), np.diff(off))
        # crossings with other bodies' outlines (contact overlaps, touching bodies): one tree, one query
        cross_body = np.zeros(0, dtype=np.int64)
        cross_edge = np.zeros(0, dtype=np.int64)
        cross_s = np.zeros(0)
        cross_kind = np.zeros(0, dtype=np.int64)
        cross_other = np.zeros(0)
        others = None  # every body's boundary edges (p0, p1, body, tree), for crossings and film ends
        # (none to look for where no two bodies come within twice the film ends' reach)
        if nb > 1 and len(a_if) and self._bodies_near(2.0 * (self.film_delta + 1e-9 * hmin)):
            p0 = np.vstack([o.x[o.all_edges[:, 0]] for o in self.outlines])
            p1 = np.vstack([o.x[o.all_edges[:, 1]] for o in self.outlines])
            body_all = np.repeat(np.arange(nb), [len(o.all_edges) for o in self.outlines])
            tree_all = shapely.STRtree(shapely.linestrings(np.stack([p0, p1], axis=1)))
            others = (p0, p1, body_all, tree_all)
            i_mine, i_other = tree_all.query(shapely.linestrings(np.stack([a_if, c_if], axis=1)))
            other = body_if[i_mine] != body_all[i_other]
            i_mine, i_other = i_mine[other], i_other[other]
            if len(i_mine):
                k, cross_s, proper = _segment_events(a_if[i_mine], c_if[i_mine], p0[i_other], p1[i_other])
                cross_edge = i_mine[k]
                cross_body = body_if[cross_edge]
                # a proper crossing moves with both edges; the ends of collinear overlaps stay fixed
                cross_kind = np.where(proper, END_BODY, END_FIXED)
                cross_other = i_other[k].astype(float)
        # vertices of the fluid region lying on an edge: where the wetted part ends even if the other
        # body only nearly touches (gaps of round-off size, closed films)
        on_body = np.zeros(0, dtype=np.int64)
        on_edge_i = np.zeros(0, dtype=np.int64)
        on_s = np.zeros(0)
        on_kind = np.zeros(0, dtype=np.int64)
        on_other = np.zeros(0)
        if not self.fluid.is_empty and len(a_if):
            fluid_pts = shapely.get_coordinates(self.fluid)
            i_pt, i_mine = _near_pairs(fluid_pts, a_if, c_if, 1e-9 * hmin)
            if len(i_pt):
                d = c_if[i_mine] - a_if[i_mine]
                sp = np.einsum("ij,ij->i", fluid_pts[i_pt] - a_if[i_mine], d) / np.einsum("ij,ij->i", d, d)
                ok = (sp > 0.0) & (sp < 1.0)
                on_edge_i, on_s = i_mine[ok], sp[ok]
                on_body = body_if[on_edge_i]
                on_kind, on_other = self._film_ends(fluid_pts[i_pt[ok]], on_body, hmin, others)
        rows = [_body_pieces(a_if[off[b]:off[b + 1]], c_if[off[b]:off[b + 1]], o.normals(), g.xs, g.ys, b, off[b],
                             cross_body, cross_edge, cross_s, cross_kind, cross_other,
                             on_body, on_edge_i, on_s, on_kind, on_other) for b, o in enumerate(self.outlines)]
        if not rows:
            self.segments = self.mouths = _no_segments()
            return
        body = np.concatenate([np.full(len(r[0]), b, dtype=np.int64) for b, r in enumerate(rows)])
        edge, s0, s1, kind0, line0, kind1, line1, mid, nrm = (np.concatenate([r[k] for r in rows]) for k in range(9))
        delta = 1e-8 * hmin
        probe = mid + delta * nrm
        if self.fluid.is_empty:
            fs = np.zeros(len(body), bool)
        else:
            # wetted if the outward side is fluid; a film thinner than the probe distance is
            # recognised by the piece lying on the fluid region up to round-off
            fs = shapely.contains_xy(self.fluid, probe[:, 0], probe[:, 1])
            scale = 1.0 + float(np.max(np.abs(mid))) if len(mid) else 1.0
            reach = 8 * np.finfo(float).eps * scale
            # (only pieces within reach of the fluid region's bounds can be within reach of it)
            f0, e0, f1, e1 = shapely.bounds(self.fluid)
            near = ~fs & (mid[:, 0] >= f0 - reach) & (mid[:, 0] <= f1 + reach) & (mid[:, 1] >= e0 - reach) \
                & (mid[:, 1] <= e1 + reach)
            if near.any():  # (dwithin: the prepared fluid region's distance test, 10x a distance)
                fs[near] = shapely.dwithin(self.fluid, shapely.points(mid[near]), reach)
        cell = g.locate(np.where(fs[:, None], probe, mid))
        # an FS piece must sit in a cell with fluid; fix round-off cases on grid lines
        bad = fs & (self.state[cell] == SOLID)
        for k in np.nonzero(bad)[0]:
            cand = g.locate(np.array([probe[k], mid[k], mid[k] - delta * nrm[k]]))
            ok = [c for c in cand if self.state[c] != SOLID]
            if ok:
                cell[k] = ok[0]
            else:  # a film below the area tolerance: not fluid (keeps quadrature and interface consistent)
                fs[k] = False
        # faces into the box: not outside it, nor lying on a box side with the box behind it
        x0, x1, y0, y1 = g.box
        inside = (probe[:, 0] > x0) & (probe[:, 0] < x1) & (probe[:, 1] > y0) & (probe[:, 1] < y1)
        cell = cell.astype(np.int64)
        part = cell.copy()
        part[fs] += g.n_cells * self.local_part(cell[fs], probe[fs])  # the part on the wetted side
        self.segments = Segments(body, edge, s0, s1, cell, part, fs.astype(bool), kind0, line0, kind1, line1, inside)
        self.mouths = self._film_mouths(a_if, c_if, body_if, off, hmin)

    def _film_mouths(self, a_if: np.ndarray, c_if: np.ndarray, body_if: np.ndarray, off: np.ndarray,
                     hmin: float) -> Segments:
        """The mouths of the closed films (:meth:`_closed_films`): the parts of the fluid
        region's boundary on no body edge but on the line at distance δ from an interface edge,
        on its outward side, split at grid lines. As pieces of that edge (``s0``, ``s1`` its
        parameters, ``part`` the fluid part on the far side), they carry the motion of the
        fluid boundary there, which is the edge's motion along its normal, into the bulk shape
        derivative (:func:`fsci.coupling.traction.add_bulk_shape_derivative`). Parts on a mitre
        corner of the grown outlines or on a held dry region are not among them."""
        if not self.has_films or self.fluid.is_empty or not len(a_if):
            return _no_segments()
        g = self.grid
        delta = self.film_delta
        tol = 1e-9 * hmin
        xy, ring = shapely.get_coordinates(shapely.get_rings(shapely.get_parts(self.fluid)), return_index=True)
        same = ring[1:] == ring[:-1]
        pa, pb = xy[:-1][same], xy[1:][same]
        k, j = shapely.STRtree(shapely.linestrings(np.stack([a_if, c_if], axis=1))).query(
            shapely.points(0.5 * (pa + pb)), predicate="dwithin", distance=delta + tol)
        t = c_if[j] - a_if[j]
        L2 = np.einsum("ij,ij->i", t, t)
        n = np.column_stack([t[:, 1], -t[:, 0]]) / np.sqrt(L2)[:, None]
        on_line = (np.abs(np.einsum("ij,ij->i", pa[k] - a_if[j], n) - delta) <= tol) & \
            (np.abs(np.einsum("ij,ij->i", pb[k] - a_if[j], n) - delta) <= tol)
        k, j, t, L2, n = k[on_line], j[on_line], t[on_line], L2[on_line], n[on_line]
        rows = []
        for kk, jj, tt, ll, nn in zip(k.tolist(), j.tolist(), t, L2, n):
            a, b = pa[kk], pb[kk]
            if any(shapely.dwithin(o.polygon.boundary, shapely.Point(0.5 * (a + b)), tol) for o in self.outlines):
                continue  # on a body edge as well: a piece of that body carries it
            cnt = np.zeros(1, dtype=np.int64)
            cap = 2 * (len(g.xs) + len(g.ys))
            oe, os_, ok_, ol_ = np.empty(cap, np.int64), np.empty(cap), np.empty(cap, np.int64), np.empty(cap)
            _grid_crossings(a[None], b[None], g.xs, g.ys, oe, os_, ok_, ol_, cnt)
            cuts = np.unique(np.concatenate([[0.0, 1.0], os_[:cnt[0]]]))
            for lo, hi in zip(cuts[:-1], cuts[1:]):
                p, q = a + lo * (b - a), a + hi * (b - a)
                s = np.clip([np.dot(p - a_if[jj], tt) / ll, np.dot(q - a_if[jj], tt) / ll], 0.0, 1.0)
                if abs(s[1] - s[0]) <= 1e-13:
                    continue
                probe = 0.5 * (p + q) + 1e-8 * hmin * nn  # the fluid's side
                cell = int(g.locate(probe[None])[0])
                if self.state[cell] == SOLID or not shapely.contains_xy(self.fluid, *probe):
                    continue
                part = cell + g.n_cells * int(self.local_part(np.array([cell]), probe[None])[0])
                b_ = int(body_if[jj])
                rows.append((b_, jj - int(off[b_]), float(s.min()), float(s.max()), cell, part))
        if not rows:
            return _no_segments()
        r = np.array(rows, dtype=float)
        i = r[:, [0, 1, 4, 5]].astype(np.int64)
        fixed = np.full(len(r), END_FIXED, dtype=np.int64)
        return Segments(i[:, 0], i[:, 1], r[:, 2].copy(), r[:, 3].copy(), i[:, 2], i[:, 3], np.ones(len(r), bool),
                        fixed, np.zeros(len(r)), fixed.copy(), np.zeros(len(r)), np.ones(len(r), bool))

    def _film_ends(self, pts: np.ndarray, body: np.ndarray, hmin: float,
                   others: tuple | None) -> tuple[np.ndarray, np.ndarray]:
        """Kinds and other edges of the fluid region's vertices ``pts`` lying on edges of bodies
        ``body``: where a closed film ends (:meth:`_closed_films`) the vertex lies on the line at
        distance δ = film_closure × ``hmin`` from an edge of another body, within the edge's
        extent; there the end moves with both edges (END_FILM_OUT / END_FILM_IN, the index of
        that edge among all bodies' boundary edges). Elsewhere (a mitre corner of the grown
        outline, a held dry region) the end stays fixed. ``others``: every body's boundary edges
        ``(p0, p1, body, STRtree)`` (None with a single body)."""
        kind = np.full(len(pts), END_FIXED, dtype=np.int64)
        other = np.zeros(len(pts))
        if self.film_closure <= 0.0 or others is None or not len(pts):
            return kind, other
        delta = self.film_delta
        tol = 1e-9 * hmin
        p0, p1, body_all, tree = others
        i_pt, i_e = tree.query(shapely.points(pts), predicate="dwithin", distance=delta + tol)
        keep = body_all[i_e] != body[i_pt]
        i_pt, i_e = i_pt[keep], i_e[keep]
        w = p1[i_e] - p0[i_e]
        L = np.linalg.norm(w, axis=1)
        rel = pts[i_pt] - p0[i_e]
        sd = (w[:, 1] * rel[:, 0] - w[:, 0] * rel[:, 1]) / L  # along the outward normal (w1, -w0)/|w|
        r = np.einsum("ij,ij->i", rel, w) / L ** 2
        hit = (np.abs(np.abs(sd) - delta) <= tol) & (r >= 0.0) & (r <= 1.0)
        i_pt, i_e, sd = i_pt[hit], i_e[hit], sd[hit]
        kind[i_pt] = np.where(sd > 0.0, END_FILM_OUT, END_FILM_IN)
        other[i_pt] = i_e
        return kind, other

    # ----------------------------------------------------------------- active set and faces
    def _build_active(self, keep_nodes: np.ndarray | None) -> None:
        """ACTIVE nodes, virtual nodes (sets of unknowns) and the faces that carry CIP / ghost
        penalty.

        A background node carries one set of unknowns for each connected part of the fluid in
        its (up to four) cells, connected meaning: within a cell, or across a cell side where
        the fluid parts on both sides share a piece of that side (4C's nodal dof sets, which the
        paper leaves out, Ager, Seitz & Wall 2019, Sec. 3.4.3: "appropriate as long as no
        slender solid bodies are considered"). Fluid on both sides of a body thinner than a
        cell, or of a shut valve, is then not coupled through shared unknowns. Virtual node
        ``n < n_nodes`` is node ``n`` itself (its first set); further sets are numbered from
        ``n_nodes`` on.
        """
        g = self.grid
        n = g.n_nodes
        physical = self.state != SOLID
        active = np.zeros(n, dtype=bool)
        active[g.cells[physical].ravel()] = True
        # nodes kept ACTIVE although no PHYSICAL cell of this cut has them (grow-only re-cuts)
        self.kept_nodes = 0 if keep_nodes is None else int(np.count_nonzero(keep_nodes & ~active))
        if keep_nodes is not None:
            active |= keep_nodes
        self.node_active = active
        face_cell = np.all(active[g.cells], axis=1)
        self.face_cell = face_cell
        f = g.faces
        both = face_cell[f[:, 0]] & face_cell[f[:, 1]]
        faces = np.ascontiguousarray(f[both])
        fnodes = g.face_nodes[both]
        ghost = (self.state[faces[:, 0]] != FLUID) | (self.state[faces[:, 1]] != FLUID)
        self.active = active
        self.int_conn = g.cells[self.int_cells]
        self.n_vnodes = n
        self.vnode_node = np.arange(n, dtype=np.int64)
        self.vnode_rep = g.nodes
        self._vkey = np.zeros(0, dtype=np.int64)
        self._vid = np.zeros(0, dtype=np.int64)
        cand = self._nodes_with_separated_fluid() if self.separate_parts else np.zeros(0, dtype=np.int64)
        if len(cand):
            self._build_sets(cand)
        self.vnode_piece = np.full(self.n_vnodes, -1, dtype=np.int64)  # the fluid piece of each set
        if self.separate_parts and len(self.pieces) > 1:  # (read for the pressure pins)
            self.vnode_piece[self.int_conn] = self.piece_of(self._part_centroids())[:, None]
        else:
            self.vnode_piece[self.int_conn] = 0
        if len(cand) == 0:
            self.faces, self.ghost, self.face_vnodes = faces, ghost, fnodes
            return
        self.vnode_rep = self._representative_points()
        self.faces, self.ghost, self.face_vnodes = self._faces_of_sets(faces, ghost, fnodes, cand)

    def _part_geometry(self, cells: np.ndarray, local: np.ndarray) -> np.ndarray:
        """Polygon of fluid part ``local`` of each cell (the whole cell for a FLUID cell)."""
        g = self.grid
        out = np.empty(len(cells), dtype=object)
        ij = g.cell_ij[cells]
        boxes = shapely.box(g.xs[ij[:, 0]], g.ys[ij[:, 1]], g.xs[ij[:, 0] + 1], g.ys[ij[:, 1] + 1])
        for k, (c, m) in enumerate(zip(cells.tolist(), local.tolist())):
            if c in self.split_cells:
                out[k] = self.split_cells[c][m]
            elif self.state[c] == CUT:
                out[k] = self._cut_polygon(c)
            else:
                out[k] = boxes[k]
        return out

    def _neighbours(self) -> tuple[np.ndarray, np.ndarray]:
        """Every pair of cells sharing a side, ``(k, 2)`` (left/lower first), and the side's two
        nodes (the first cell's right side, nodes 1 and 2, or its top, nodes 3 and 2)."""
        g = self.grid
        cells = np.arange(g.n_cells)
        right = cells[g.cell_ij[:, 0] < g.nx - 1]
        up = cells[g.cell_ij[:, 1] < g.ny - 1]
        pairs = np.vstack([np.column_stack([right, right + 1]), np.column_stack([up, up + g.nx])])
        side = np.vstack([g.cells[right][:, [1, 2]], g.cells[up][:, [3, 2]]])
        return pairs, side

    def _part_centroids(self) -> np.ndarray:
        """Centroid of the fluid of every integration part, ``(k, 2)``."""
        w = np.add.reduceat(self.qw, self.qptr[:-1])
        return np.column_stack([np.add.reduceat(self.qw * self.qx[:, d], self.qptr[:-1]) for d in range(2)]) / w[:, None]

    def _side_links(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Fluid parts connected across a cell side next to a CUT cell: ``(code_a, code_b,
        side)`` rows, ``side`` the grid edge ``(node, node)`` they share; and the cells of
        sides between two PHYSICAL cells that no fluid crosses."""
        g = self.grid
        st = self.state
        pr, side = self._neighbours()
        keep = (st[pr[:, 0]] != SOLID) & (st[pr[:, 1]] != SOLID) & ((st[pr[:, 0]] == CUT) | (st[pr[:, 1]] == CUT))
        pr, side = pr[keep], side[keep]
        count = lambda c: np.array([len(self.split_cells.get(int(x), (0,))) for x in c], dtype=np.int64)  # noqa: E731
        na, nb = count(pr[:, 0]), count(pr[:, 1])
        rep_pair = np.repeat(np.arange(len(pr)), na * nb)
        offs = np.concatenate([[0], np.cumsum(na * nb)])[:-1]
        flat = np.arange(len(rep_pair)) - offs[rep_pair]
        la, lb = flat // nb[rep_pair], flat % nb[rep_pair]
        ca, cb = pr[rep_pair, 0], pr[rep_pair, 1]
        # two cells of one part each are linked if fluid lies at an end of their side (no body
        # along it there); otherwise their parts are linked if they share a piece of the side
        single = (na[rep_pair] == 1) & (nb[rep_pair] == 1)
        s_nodes = side[rep_pair]
        wet = shapely.contains_xy(self.fluid, g.nodes[s_nodes[:, 0], 0], g.nodes[s_nodes[:, 0], 1]) | \
            shapely.contains_xy(self.fluid, g.nodes[s_nodes[:, 1], 0], g.nodes[s_nodes[:, 1], 1])
        linked = single & wet
        test = np.nonzero(~linked)[0]
        hmin = g.h_min
        ga, gb = self._part_geometry(ca[test], la[test]), self._part_geometry(cb[test], lb[test])
        linked[test] = shapely.length(shapely.intersection(ga, gb)) > 1e-9 * hmin
        crossed = np.bincount(rep_pair[linked], minlength=len(pr)) > 0
        n_cells = g.n_cells
        return (ca[linked] + n_cells * la[linked], cb[linked] + n_cells * lb[linked], side[rep_pair[linked]],
                pr[~crossed])

    def _nodes_with_separated_fluid(self) -> np.ndarray:
        """Nodes whose cells' fluid may be more than one connected part: the nodes of cells
        with several fluid parts and of sides between two PHYSICAL cells that no fluid
        crosses (a body along a grid line). Every other node has one set."""
        g = self.grid
        self._links = self._side_links()
        closed = self._links[3]
        split = np.array(sorted(self.split_cells), dtype=np.int64)
        if len(split) == 0 and len(closed) == 0:
            return np.zeros(0, dtype=np.int64)
        return np.unique(np.concatenate([g.cells[split].ravel(), g.cells[closed.ravel()].ravel()]))

    def _build_sets(self, cand: np.ndarray) -> None:
        """Sets of unknowns of the nodes ``cand``: the connected components of the graph whose
        vertices are (node, fluid part of one of its cells) and whose edges join two parts of
        neighbouring cells linked across the side they share at that node."""
        from scipy.sparse import coo_matrix
        from scipy.sparse.csgraph import connected_components

        g = self.grid
        n = g.n_nodes
        is_cand = np.zeros(n, dtype=bool)
        is_cand[cand] = True
        # vertices: (integration part k, corner a) with a candidate node
        k_all = np.repeat(np.arange(len(self.int_parts)), 4)
        node_all = self.int_conn.ravel()
        sel = is_cand[node_all]
        vk, vnode = k_all[sel], node_all[sel]
        vcode = self.int_parts[vk]
        K = int(self.int_parts.max()) + 1
        key = vnode * K + vcode
        order = np.argsort(key)
        key, vnode, vcode = key[order], vnode[order], vcode[order]
        # edges: linked parts across a side, at each of the side's candidate end nodes
        ca, cb, side, _ = self._links
        # sides between two FLUID cells are crossed everywhere
        st = self.state
        pr, fside = self._neighbours()
        m = (st[pr[:, 0]] == FLUID) & (st[pr[:, 1]] == FLUID) & np.any(is_cand[fside], axis=1)
        ca = np.concatenate([ca, pr[m, 0]])
        cb = np.concatenate([cb, pr[m, 1]])
        side = np.vstack([side, fside[m]])
        src, dst = [], []
        for e in range(2):
            u = side[:, e]
            m = is_cand[u]
            ia = np.searchsorted(key, u[m] * K + ca[m])
            ib = np.searchsorted(key, u[m] * K + cb[m])
            src.append(ia)
            dst.append(ib)
        src, dst = np.concatenate(src), np.concatenate(dst)
        nv = len(key)
        _, label = connected_components(coo_matrix((np.ones(len(src)), (src, dst)), shape=(nv, nv)), directed=False)
        # one set per (node, component); the node's first component keeps the node's own number
        comp_key = np.unique(vnode * nv + label)
        comp_node = comp_key // nv
        first = np.ones(len(comp_key), dtype=bool)
        first[1:] = comp_node[1:] != comp_node[:-1]
        vid_comp = comp_node.copy()
        extra = np.nonzero(~first)[0]
        vid_comp[extra] = n + np.arange(len(extra))
        vid = vid_comp[np.searchsorted(comp_key, vnode * nv + label)]
        self._vkey, self._vid, self._vk = key, vid, K
        self.n_vnodes = n + len(extra)
        self.vnode_node = np.concatenate([np.arange(n), comp_node[extra]]).astype(np.int64)
        self.active = np.concatenate([self.node_active, np.ones(len(extra), dtype=bool)])
        self.int_conn = self.vnodes(g.cells[self.int_cells], self.int_parts[:, None])

    def vnodes(self, nodes: np.ndarray, parts: np.ndarray) -> np.ndarray:
        """Virtual node of each (background node, fluid part ``cell + n_cells × k`` of one of
        its cells); the node itself where it has one set."""
        nodes = np.asarray(nodes, dtype=np.int64)
        if len(self._vkey) == 0:
            return nodes.copy()
        k = nodes * self._vk + np.asarray(parts, dtype=np.int64)
        i = np.minimum(np.searchsorted(self._vkey, k), len(self._vkey) - 1)
        return np.where(self._vkey[i] == k, self._vid[i], nodes).astype(np.int64)

    def part_conn(self, parts: np.ndarray) -> np.ndarray:
        """Virtual nodes ``(k, 4)`` of fluid parts ``cell + n_cells × k``."""
        g = self.grid
        parts = np.asarray(parts, dtype=np.int64)
        return self.vnodes(g.cells[parts % g.n_cells], parts[:, None])

    def conn_at(self, cells: np.ndarray, points: np.ndarray) -> np.ndarray:
        """Virtual nodes ``(k, 4)`` that carry the fluid at points in the given cells."""
        g = self.grid
        cells = np.asarray(cells, dtype=np.int64)
        if self.n_vnodes == g.n_nodes:
            return g.cells[cells]
        return self.part_conn(cells + g.n_cells * self.local_part(cells, points))

    def _representative_points(self) -> np.ndarray:
        """A point of each virtual node's fluid near the node (the mean of the centroids of
        its integration parts; the node itself if it has none): matches the unknowns of one
        cut to those of the next (:func:`fsci.cut.transfer.transfer_indices`)."""
        g = self.grid
        rep = g.nodes[self.vnode_node].astype(float)
        if len(self.int_parts) == 0:
            return rep
        c = self._part_centroids()
        v = self.int_conn.ravel()
        cnt = np.bincount(v, minlength=self.n_vnodes).astype(float)
        acc = np.column_stack([np.bincount(v, weights=np.repeat(c[:, d], 4), minlength=self.n_vnodes) for d in range(2)])
        has = cnt > 0
        rep[has] = acc[has] / cnt[has, None]
        return rep

    def _faces_of_sets(self, faces: np.ndarray, ghost: np.ndarray, fnodes: np.ndarray,
                       cand: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Face entries where nodes have several sets: one per pair of fluid parts of the two
        cells that use the same set at both nodes of the face (the same fluid on both sides);
        a cell without fluid (a ghost-penalty neighbour) takes the single set of each of its
        nodes and has no entry if a node has several."""
        g = self.grid
        n = g.n_nodes
        is_cand = np.zeros(n, dtype=bool)
        is_cand[cand] = True
        simple = ~np.any(is_cand[fnodes], axis=1)
        out_f, out_g, out_n = [faces[simple]], [ghost[simple]], [fnodes[simple]]
        n_sets = np.bincount(self.vnode_node, minlength=n)
        parts_of: dict[int, list[int]] = {}
        for code, c in zip(self.int_parts.tolist(), self.int_cells.tolist()):
            parts_of.setdefault(c, []).append(code)
        rows_f, rows_g, rows_n = [], [], []
        for k in np.nonzero(~simple)[0]:
            cl, cr = int(faces[k, 0]), int(faces[k, 1])
            nodes = fnodes[k]
            shared, far = ([1, 2], [0, 3]) if faces[k, 2] == 0 else ([2, 3], [0, 1])  # in the left/lower cell
            for pl in parts_of.get(cl, [-1]):
                for pr in parts_of.get(cr, [-1]):
                    if pl < 0 and pr < 0:
                        continue
                    conn = nodes.copy()
                    if pl >= 0:
                        conn[:4] = self.vnodes(nodes[:4], np.full(4, pl))
                    elif np.any(n_sets[nodes[far]] > 1):  # a cell without fluid: its nodes' only sets
                        continue
                    if pr >= 0:
                        right = self.vnodes(nodes[shared + [4, 5]], np.full(4, pr))
                        if pl >= 0 and not np.array_equal(conn[shared], right[:2]):
                            continue  # other fluid on either side of the face
                        conn[shared] = right[:2]
                        conn[4:] = right[2:]
                    elif np.any(n_sets[nodes[4:]] > 1):
                        continue
                    rows_f.append(faces[k])
                    rows_g.append(ghost[k])
                    rows_n.append(conn)
        if rows_f:
            out_f.append(np.array(rows_f, dtype=np.int64))
            out_g.append(np.array(rows_g, dtype=bool))
            out_n.append(np.array(rows_n, dtype=np.int64))
        return (np.ascontiguousarray(np.concatenate(out_f)), np.concatenate(out_g),
                np.ascontiguousarray(np.concatenate(out_n)))

    # ----------------------------------------------------------------- queries
    def ghost_weights(self, ramp: float) -> np.ndarray:
        """Weight of the ghost penalty (26) on each face of :attr:`faces`: zero between two
        FLUID cells; otherwise ``min(1, σ / ramp)`` for the larger solid fraction σ of the face's
        two cells (1 for every face of a cut cell if ``ramp`` is 0, the paper's switch).

        With the switch, a cell that a body's edge grazes (a solid sliver of 1e-9 of the cell
        where the edge passes a grid node) puts the full penalty on its faces at once, and the
        residual jumps with a motion of the body far below the Newton tolerance: on the pump
        Newton and the cut then alternate between two states 6e-4 cells apart, neither the
        solution of its own cut (docs/architecture.md, decision 33). The ramp makes the penalty
        continuous in the geometry; a cell with a solid fraction above ``ramp`` (a small fluid
        part, the cells the penalty is for) is penalised exactly as in the paper."""
        _, w = self._ghost_cell_weights(ramp)
        return np.where(self.ghost, np.maximum(w[self.faces[:, 0]], w[self.faces[:, 1]]), 0.0)

    def _ghost_cell_weights(self, ramp: float) -> tuple[np.ndarray, np.ndarray]:
        """Solid fraction σ of every cell and its ghost-penalty weight (:meth:`ghost_weights`)."""
        g = self.grid
        solid = 1.0 - self.fluid_area / (g.cell_size[:, 0] * g.cell_size[:, 1])
        w = np.ones(g.n_cells) if ramp <= 0.0 else np.clip(solid / ramp, 0.0, 1.0)
        w[self.state == FLUID] = 0.0
        w[self.state == SOLID] = 1.0
        return solid, w

    def ghost_weight_slopes(self, ramp: float) -> tuple[np.ndarray, np.ndarray]:
        """For every face of :attr:`faces`: the cell whose solid fraction σ sets its ghost weight
        (:meth:`ghost_weights`, the larger of its two cells') and the weight's derivative with
        respect to that σ: ``1 / ramp`` where σ lies inside the ramp, else 0 (cell -1 on faces
        without ghost penalty). The weight then moves with the bodies (its derivative is
        part of the shape derivative, :meth:`fsci.coupling.term.CouplingTerm.ghost_motion`)."""
        if ramp <= 0.0:
            return np.full(len(self.faces), -1, dtype=np.int64), np.zeros(len(self.faces))
        solid, w = self._ghost_cell_weights(ramp)
        slope = np.where((self.state == CUT) & (solid > 0.0) & (solid < ramp), 1.0 / ramp, 0.0)
        left, right = self.faces[:, 0], self.faces[:, 1]
        cell = np.where(w[left] >= w[right], left, right)
        return np.where(self.ghost, cell, -1), np.where(self.ghost, slope[cell], 0.0)

    def boundary_pieces(self, side: str) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """PHYSICAL parts of the box side's grid edges: edge index (into ``grid.side_edges``),
        local range ``[s0, s1]`` (0 at the edge's first node; uncut edges give [0, 1]) and the
        virtual nodes ``(k, 2)`` of the edge's two nodes in the fluid part it bounds."""
        cache = self.__dict__.setdefault("_boundary_pieces", {})
        if side in cache:
            return cache[side]
        g = self.grid
        X = g.nodes
        edges = g.side_edges(side)
        d = 0 if side in ("bottom", "top") else 1  # coordinate that varies along the side
        coords = X[edges[:, 0], d]
        a, b = X[edges[0, 0]], X[edges[-1, 1]]
        ranges: list[tuple[float, float]] = []  # (lo, hi) of each PHYSICAL stretch of the side
        if not self.fluid.is_empty and self._side_is_fluid(side):
            ranges.append((float(a[d]), float(b[d])))
        elif not self.fluid.is_empty:
            ranges = self._side_stretches()[side]
        piece_e, piece_s0, piece_s1 = [np.zeros(0, dtype=np.int64)], [np.zeros(0)], [np.zeros(0)]
        for lo, hi in ranges:
            k0 = max(int(np.searchsorted(coords, lo, side="right")) - 1, 0)
            k1 = min(int(np.searchsorted(coords, hi, side="left")), len(edges))
            ks = np.arange(k0, k1)
            e0, e1 = X[edges[ks, 0], d], X[edges[ks, 1], d]
            s0 = np.maximum(0.0, (lo - e0) / (e1 - e0))
            s1 = np.minimum(1.0, (hi - e0) / (e1 - e0))
            on = s1 - s0 > 1e-14
            piece_e.append(ks[on])
            piece_s0.append(s0[on])
            piece_s1.append(s1[on])
        k, s0, s1 = np.concatenate(piece_e), np.concatenate(piece_s0), np.concatenate(piece_s1)
        sm = 0.5 * (s0 + s1)
        mid = (1.0 - sm)[:, None] * X[edges[k, 0]] + sm[:, None] * X[edges[k, 1]]
        cells = {"bottom": k, "top": (g.ny - 1) * g.nx + k, "left": k * g.nx, "right": k * g.nx + g.nx - 1}[side]
        part = cells + g.n_cells * self.local_part(cells, mid)
        out = (k, s0, s1, self.vnodes(edges[k], part[:, None]))
        cache[side] = out
        return out

    def _side_stretches(self) -> dict[str, list[tuple[float, float]]]:
        """``(lo, hi)`` of each stretch of the box sides that is not fluid whole
        (:meth:`_side_is_fluid`) where it bounds the fluid region, along the side's coordinate:
        one GEOS intersection of those sides (each a line from its first node to its last) with
        the region. Its lines are split where they change sides (at a corner), and stretches of
        a side that touch are joined."""
        if "_stretches" in self.__dict__:
            return self._stretches
        x0, x1, y0, y1 = self.grid.box
        ends = {"left": ((x0, y0), (x0, y1)), "right": ((x1, y0), (x1, y1)),
                "bottom": ((x0, y0), (x1, y0)), "top": ((x0, y1), (x1, y1))}
        sides = [side for side in SIDES if not self._side_is_fluid(side)]
        out: dict[str, list[tuple[float, float]]] = {side: [] for side in sides}
        lines = shapely.get_parts(shapely.intersection(shapely.multilinestrings([ends[k] for k in sides]), self.fluid))
        lines = lines[(shapely.get_type_id(lines) == 1) & (shapely.length(lines) > 0.0)]  # LineStrings
        xy, line = shapely.get_coordinates(lines, return_index=True)
        if len(xy):
            p, q = xy[:-1], xy[1:]
            mid = 0.5 * (p + q)
            # the side of every segment: the one whose line its midpoint is nearest
            dist = np.abs(np.column_stack([mid[:, 0] - x0, mid[:, 0] - x1, mid[:, 1] - y0, mid[:, 1] - y1]))
            on = np.argmin(dist, axis=1)
            on[line[1:] != line[:-1]] = -1  # not a segment: from one line to the next
            for k, side in enumerate(SIDES):
                if side not in out:
                    continue
                d = 0 if side in ("bottom", "top") else 1
                lo, hi = np.minimum(p[:, d], q[:, d]), np.maximum(p[:, d], q[:, d])
                seg = np.nonzero(on == k)[0]
                ranges = sorted(zip(lo[seg].tolist(), hi[seg].tolist()))
                for r0, r1 in ranges:  # joined where they touch
                    if out[side] and r0 <= out[side][-1][1]:
                        out[side][-1] = (out[side][-1][0], max(out[side][-1][1], r1))
                    else:
                        out[side].append((r0, r1))
        self._stretches = out
        return out

    def _side_is_fluid(self, side: str) -> bool:
        """Whether nothing but fluid reaches box side ``side``: the bounds of the bodies, closed
        films, held-dry regions and dropped islands stay strictly off its line (then no GEOS
        intersection is needed to find its PHYSICAL part)."""
        if "_fluid_sides" not in self.__dict__:
            dry = shapely.bounds(np.array(self._dry, dtype=object))  # (x0, y0, x1, y1) per part, NaN if empty
            if np.isnan(dry).all():
                self._fluid_sides = dict.fromkeys(SIDES, True)
            else:
                x0, x1, y0, y1 = self.grid.box
                d0, e0 = np.nanmin(dry[:, :2], axis=0)
                d1, e1 = np.nanmax(dry[:, 2:], axis=0)
                self._fluid_sides = {"left": d0 > x0, "right": d1 < x1, "bottom": e0 > y0, "top": e1 < y1}
        return self._fluid_sides[side]

    @property
    def cut_cells(self) -> np.ndarray:
        return np.nonzero(self.state == CUT)[0]

    def interface_points(self, b: int, mask: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """End points ``(k, 2, 2)`` and normals of body ``b``'s segments (optionally masked)."""
        o = self.outlines[b]
        seg = self.segments
        m = seg.body == b if mask is None else (seg.body == b) & mask
        a = o.x[o.edges[seg.edge[m], 0]]
        c = o.x[o.edges[seg.edge[m], 1]]
        p0 = a + seg.s0[m, None] * (c - a)
        p1 = a + seg.s1[m, None] * (c - a)
        return np.stack([p0, p1], axis=1), o.normals()[seg.edge[m]]

    def interface_length(self, b: int | None = None, fs: bool | None = True) -> float:
        """Total length of interface pieces (of one body; Γ^FS, Γ^SC or both)."""
        total = 0.0
        for bb in range(len(self.outlines)) if b is None else [b]:
            mask = None if fs is None else (self.segments.fs == fs)
            pts, _ = self.interface_points(bb, mask)
            total += float(np.sum(np.linalg.norm(pts[:, 1] - pts[:, 0], axis=1)))
        return total


def _no_segments() -> Segments:
    """An empty set of interface pieces."""
    z, f = np.zeros(0, dtype=np.int64), np.zeros(0)
    return Segments(z, z, f, f, z, z, np.zeros(0, bool), z, f, z, f, np.zeros(0, bool))


def _polygonal(geom: shapely.Geometry) -> shapely.Geometry:
    """Keep only the polygonal parts of an overlay result (drop touching lines/points)."""
    if geom.geom_type in ("Polygon", "MultiPolygon"):
        return geom
    parts = [p for p in shapely.get_parts(geom) if p.geom_type == "Polygon" and p.area > 0]
    if not parts:
        return shapely.Polygon()
    return parts[0] if len(parts) == 1 else shapely.MultiPolygon(parts)
