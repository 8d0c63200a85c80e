"""The cut of the background grid by the bodies (paper Sec. 3.1.2-3.1.3).

One :class:`CutState` per geometry holds everything the fluid and coupling terms read:

* cell states: ``FLUID`` (uncut, standard Gauss), ``CUT`` (integrated on its PHYSICAL part),
  ``SOLID`` (not integrated);
* ACTIVE nodes (one dof set per node) and the cells whose faces carry CIP / ghost penalty;
* volume quadrature on the physical part of cut cells: the fluid polygon of the cell is
  triangulated (constrained Delaunay, GEOS) and integrated with a collapsed Gauss rule exact
  for total degree ``quad_degree`` (5 by default: every Galerkin integrand of (22) on a
  rectangle is of total degree ≤ 5);
* interface segments: every interface edge of every body split at grid lines, at crossings
  with other bodies' outlines and at the box boundary; each piece knows its body, edge, local
  coordinate range, background cell and whether it bounds fluid (Γ^FS) or not (Γ^SC: inside
  another body, bounding a removed island, or outside the box).

The physical fluid region is ``box − ⋃ bodies − islands``; an island is a connected fluid piece
whose bounding-box diagonal is below ``island_factor`` × the size of the cells it touches
(4C's SELFCUT_MESHCORRECTION_MULTIPLICATOR; 2 in its FSCI test).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely
from numba import njit

from fsci.fem.quadrature import gauss_quad, triangle_rule
from fsci.geometry.outlines import Outline
from fsci.mesh.grid import Grid

FLUID, CUT, SOLID = 0, 1, 2
# kinds of interface-piece ends: fixed parameter, or on a grid line x = const / y = const (the end
# then moves along the line with the edge, see fsci.coupling.traction)
END_FIXED, END_X, END_Y = -1, 2, 3
AREA_TOL = 1e-15  # relative to the cell area: below this a fluid or solid part is treated as empty


@dataclass
class Segments:
    """Interface pieces (one row per piece)."""

    body: np.ndarray  # body index
    edge: np.ndarray  # index into that body's interface edges
    s0: np.ndarray  # local coordinate range on the edge, 0 at node a, 1 at node b
    s1: np.ndarray
    cell: np.ndarray  # background cell evaluated for fluid quantities
    fs: np.ndarray  # True: bounds the physical fluid (Γ^FS); False: Γ^SC
    kind0: np.ndarray  # kind of each end (END_FIXED, END_X, END_Y) and its grid-line coordinate
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


def _segment_events(A0, A1, B0, B1, tol=1e-12):
    """Parameters on segments A where they meet segments B (pairwise arrays).

    Returns (pair index, s) for proper crossings, touching points and the end points of
    collinear overlaps."""
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
    k = np.nonzero(par)[0]
    if len(k):
        dist = np.abs(w[k, 0] * d[k, 1] - w[k, 1] * d[k, 0]) / ld[k]
        col = k[dist <= tol * np.maximum(ld[k], 1.0)]
        for P in (B0, B1):
            sp = np.einsum("ij,ij->i", P[col] - A0[col], d[col]) / ld[col] ** 2
            inside = (sp >= -tol) & (sp <= 1 + tol)
            idx.append(col[inside])
            ss.append(np.clip(sp[inside], 0.0, 1.0))
    return np.concatenate(idx), np.concatenate(ss)


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
    film_closure
        Gaps between two different bodies thinner than ``2 film_closure × (smallest cell)`` are
        not fluid (closed contact whose discrete gap is slightly positive; see docs).
    """

    def __init__(self, grid: Grid, outlines: list[Outline], island_factor: float = 2.0, quad_degree: int = 5,
                 keep_nodes: np.ndarray | None = None, film_closure: float = 0.0) -> None:
        self.grid = grid
        self.outlines = outlines
        self.island_factor = island_factor
        self.film_closure = film_closure
        self.quad_degree = quad_degree
        x0, x1, y0, y1 = grid.box
        self.box = shapely.box(x0, y0, x1, y1)
        self._build_region()
        self._classify_cells()
        self._build_quadrature()
        self._build_segments()
        self._build_active(keep_nodes)

    # ----------------------------------------------------------------- fluid region
    def _build_region(self) -> None:
        g = self.grid
        bodies = [o.polygon for o in self.outlines]
        solid = shapely.union_all(bodies + self._closed_films(bodies)) if bodies else shapely.Polygon()
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
            (islands if size < self.island_factor * h else keep).append(part)
        self.fluid = shapely.union_all(keep) if keep else shapely.Polygon()
        self.islands = islands
        shapely.prepare(self.fluid)

    def _closed_films(self, bodies: list[shapely.Geometry]) -> list[shapely.Geometry]:
        """Regions within δ of two different bodies: films thinner than 2δ between bodies in
        contact, whose sign of the (tiny) discrete gap must not decide what is fluid."""
        if self.film_closure <= 0.0 or len(bodies) < 2:
            return []
        g = self.grid
        d = self.film_closure * float(min(np.diff(g.xs).min(), np.diff(g.ys).min()))
        grown = shapely.buffer(np.array(bodies, dtype=object), d, join_style="mitre")
        i, j = shapely.STRtree(grown).query(grown, predicate="intersects")
        pairs = i < j
        if not pairs.any():
            return []
        films = shapely.intersection(grown[i[pairs]], grown[j[pairs]])
        return [f for f in films if not f.is_empty]

    def _classify_cells(self) -> None:
        """FLUID / CUT / SOLID per cell. A cell whose open interior no segment of the fluid
        region's boundary can meet (exact: axis-separated, or the segment's line strictly misses
        the closed cell) is entirely fluid or entirely solid, decided by its centre; only the
        others are clipped (GEOS) and classified by the area of their fluid part."""
        g = self.grid
        n = g.n_cells
        state = np.full(n, SOLID, dtype=np.int8)
        self.polygons: dict[int, shapely.Geometry] = {}
        area_cell = g.cell_size[:, 0] * g.cell_size[:, 1]
        self.fluid_area = np.zeros(n)
        if self.fluid.is_empty:
            self.state = state
            return
        xy, ring = shapely.get_coordinates(shapely.get_rings(shapely.get_parts(self.fluid)), return_index=True)
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
            boxes = shapely.box(g.xs[ij[cand, 0]], g.ys[ij[cand, 1]], g.xs[ij[cand, 0] + 1], g.ys[ij[cand, 1] + 1])
            parts = shapely.intersection(boxes, self.fluid)
            parts = np.array([_polygonal(p) for p in parts], dtype=object)
            areas = shapely.area(parts)
            rel = areas / area_cell[cand]
            full = rel >= 1.0 - AREA_TOL
            empty = rel <= AREA_TOL
            state[cand[full]] = FLUID
            self.fluid_area[cand[full]] = area_cell[cand[full]]
            cut = ~full & ~empty
            state[cand[cut]] = CUT
            self.fluid_area[cand[cut]] = areas[cut]
            for c, p in zip(cand[cut], parts[cut]):
                self.polygons[int(c)] = p
        self.state = state

    def _build_quadrature(self) -> None:
        """Tensor Gauss on FLUID cells, triangle rules on the PHYSICAL part of CUT cells."""
        g = self.grid
        fluid_cells = np.nonzero(self.state == FLUID)[0]
        xi, w = gauss_quad(2)
        size = g.cell_size[fluid_cells]
        x0 = np.column_stack([g.xs[g.cell_ij[fluid_cells, 0]], g.ys[g.cell_ij[fluid_cells, 1]]])
        pts_f = (x0[:, None, :] + 0.5 * (xi[None] + 1.0) * size[:, None, :])
        wts_f = w[None, :] * (0.25 * size[:, 0] * size[:, 1])[:, None]
        cut_cells = np.array(sorted(self.polygons), dtype=np.int64)
        pts_c, wts_c, owner_c = np.zeros((0, 2)), np.zeros(0), np.zeros(0, dtype=np.int64)
        if len(cut_cells):
            # all triangles of all cut cells at once (same triangles, same order as one cell at a time)
            tris = shapely.constrained_delaunay_triangles(np.array([self.polygons[int(c)] for c in cut_cells], dtype=object))
            parts, which = shapely.get_parts(tris, return_index=True)
            keep = shapely.area(parts) > 0.0
            parts, which = parts[keep], which[keep]
            xy, ring = shapely.get_coordinates(shapely.get_exterior_ring(parts), return_index=True)
            first = np.searchsorted(ring, np.arange(len(parts)))
            verts = xy[first[:, None] + np.arange(3)[None, :]].reshape(-1, 3, 2)
            pts_c, wts_c = triangle_rule(verts, self.quad_degree)
            owner_c = np.repeat(cut_cells[which], len(wts_c) // max(len(parts), 1))
        pts = np.vstack([pts_f.reshape(-1, 2), pts_c])
        wts = np.concatenate([wts_f.ravel(), wts_c])
        owner = np.concatenate([np.repeat(fluid_cells, 4), owner_c])
        order = np.argsort(owner, kind="stable")
        owner = owner[order]
        self.int_cells, counts = np.unique(owner, return_counts=True)
        self.int_cells = self.int_cells.astype(np.int64)
        self.qptr = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
        self.qx = np.ascontiguousarray(pts[order])
        self.qw = np.ascontiguousarray(wts[order])

    # ----------------------------------------------------------------- interface
    def _build_segments(self) -> None:
        g = self.grid
        hmin = float(min(np.diff(g.xs).min(), np.diff(g.ys).min()))
        nb = len(self.outlines)
        # interface edges of all bodies (rows per body from off[b]) and every boundary edge
        a_if = np.vstack([o.x[o.edges[:, 0]] for o in self.outlines]) if nb else np.zeros((0, 2))
        c_if = np.vstack([o.x[o.edges[:, 1]] for o in self.outlines]) if nb else np.zeros((0, 2))
        off = np.concatenate([[0], np.cumsum([len(o.edges) for o in self.outlines])]).astype(np.int64)
        body_if = np.repeat(np.arange(nb), np.diff(off))
        lines_if = shapely.linestrings(np.stack([a_if, c_if], axis=1)) if len(a_if) else np.zeros(0, dtype=object)
        # crossings with other bodies' outlines (contact overlaps, touching bodies): one tree, one query
        cross_body = np.zeros(0, dtype=np.int64)
        cross_edge = np.zeros(0, dtype=np.int64)
        cross_s = np.zeros(0)
        if nb > 1 and len(a_if):
            p0 = np.vstack([o.x[o.all_edges[:, 0]] for o in self.outlines])
            p1 = np.vstack([o.x[o.all_edges[:, 1]] for o in self.outlines])
            body_all = np.repeat(np.arange(nb), [len(o.all_edges) for o in self.outlines])
            i_mine, i_other = shapely.STRtree(shapely.linestrings(np.stack([p0, p1], axis=1))).query(lines_if)
            other = body_if[i_mine] != body_all[i_other]
            i_mine, i_other = i_mine[other], i_other[other]
            if len(i_mine):
                k, cross_s = _segment_events(a_if[i_mine], c_if[i_mine], p0[i_other], p1[i_other])
                cross_edge = i_mine[k]
                cross_body = body_if[cross_edge]
        # vertices of the fluid region lying on an edge: where the wetted part ends even if the other
        # body only nearly touches (gaps of round-off size, closed films)
        on_body = np.zeros(0, dtype=np.int64)
        on_edge_i = np.zeros(0, dtype=np.int64)
        on_s = np.zeros(0)
        if not self.fluid.is_empty and len(a_if):
            fluid_pts = shapely.get_coordinates(self.fluid)
            i_pt, i_mine = shapely.STRtree(lines_if).query(shapely.points(fluid_pts), predicate="dwithin",
                                                           distance=1e-9 * hmin)
            if len(i_pt):
                d = c_if[i_mine] - a_if[i_mine]
                sp = np.einsum("ij,ij->i", fluid_pts[i_pt] - a_if[i_mine], d) / np.einsum("ij,ij->i", d, d)
                ok = (sp > 0.0) & (sp < 1.0)
                on_edge_i, on_s = i_mine[ok], sp[ok]
                on_body = body_if[on_edge_i]
        rows = []
        for b, o in enumerate(self.outlines):
            a = a_if[off[b]:off[b + 1]]
            c = c_if[off[b]:off[b + 1]]
            nE = len(a)
            ev_edge = [np.arange(nE), np.arange(nE)]
            ev_s = [np.zeros(nE), np.ones(nE)]
            cap = 64 * nE + 64
            cnt = np.zeros(1, dtype=np.int64)
            for _ in range(2):  # second pass only if the first buffer was too small
                oe, os_, ok_, ol_ = (np.empty(cap, dtype=np.int64), np.empty(cap), np.empty(cap, dtype=np.int64),
                                     np.empty(cap))
                _grid_crossings(a, c, g.xs, g.ys, oe, os_, ok_, ol_, cnt)
                if cnt[0] <= cap:
                    break
                cap = int(cnt[0])
            n_grid = int(cnt[0])
            ev_edge.append(oe[:n_grid])
            ev_s.append(os_[:n_grid])
            m = cross_body == b
            ev_edge.append(cross_edge[m] - off[b])
            ev_s.append(cross_s[m])
            m = on_body == b
            ev_edge.append(on_edge_i[m] - off[b])
            ev_s.append(on_s[m])
            E = np.concatenate(ev_edge)
            S = np.concatenate(ev_s)
            n_other = len(E) - 2 * nE - n_grid
            Kd = np.concatenate([np.full(2 * nE, END_FIXED), ok_[:n_grid], np.full(n_other, END_FIXED)])
            Ln = np.concatenate([np.zeros(2 * nE), ol_[:n_grid], np.zeros(n_other)])
            order = np.lexsort((S, E))
            E, S, Kd, Ln = E[order], S[order], Kd[order], Ln[order]
            same = (E[1:] == E[:-1])
            keep = same & ((S[1:] - S[:-1]) > 1e-13)
            i0 = np.nonzero(keep)[0]
            rows.append((np.full(len(i0), b), E[i0], S[i0], S[i0 + 1], Kd[i0], Ln[i0], Kd[i0 + 1], Ln[i0 + 1]))
        if not rows:
            z, f = np.zeros(0, dtype=np.int64), np.zeros(0)
            self.segments = Segments(z, z, f, f, z, np.zeros(0, bool), z, f, z, f, np.zeros(0, bool))
            return
        body = np.concatenate([r[0] for r in rows]).astype(np.int64)
        edge = np.concatenate([r[1] for r in rows]).astype(np.int64)
        s0 = np.concatenate([r[2] for r in rows])
        s1 = np.concatenate([r[3] for r in rows])
        ends = [np.concatenate([r[k] for r in rows]) for k in (4, 5, 6, 7)]
        mid = np.empty((len(body), 2))
        nrm = np.empty((len(body), 2))
        for b, o in enumerate(self.outlines):
            m = body == b
            a = o.x[o.edges[edge[m], 0]]
            c = o.x[o.edges[edge[m], 1]]
            sm = 0.5 * (s0[m] + s1[m])
            mid[m] = a + sm[:, None] * (c - a)
            nrm[m] = o.normals()[edge[m]]
        delta = 1e-8 * hmin
        probe = mid + delta * nrm
        if self.fluid.is_empty:
            fs = np.zeros(len(body), bool)
        else:
            # wetted if the outward side is fluid; a film thinner than the probe distance is
            # recognised by the piece lying on the fluid region up to round-off
            fs = shapely.contains_xy(self.fluid, probe[:, 0], probe[:, 1])
            scale = 1.0 + float(np.max(np.abs(mid))) if len(mid) else 1.0
            near = ~fs
            if near.any():
                dist = shapely.distance(shapely.points(mid[near]), self.fluid)
                fs[np.nonzero(near)[0][dist <= 8 * np.finfo(float).eps * scale]] = True
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
        self.segments = Segments(body, edge, s0, s1, cell.astype(np.int64), fs.astype(bool), ends[0].astype(np.int64),
                                 ends[1], ends[2].astype(np.int64), ends[3], inside)

    # ----------------------------------------------------------------- active set and faces
    def _build_active(self, keep_nodes: np.ndarray | None) -> None:
        g = self.grid
        physical = self.state != SOLID
        active = np.zeros(g.n_nodes, dtype=bool)
        active[g.cells[physical].ravel()] = True
        if keep_nodes is not None:
            active |= keep_nodes
        self.active = active
        face_cell = np.all(active[g.cells], axis=1)
        self.face_cell = face_cell
        f = g.faces
        both = face_cell[f[:, 0]] & face_cell[f[:, 1]]
        self.faces = np.ascontiguousarray(f[both])
        st = self.state
        self.ghost = (st[self.faces[:, 0]] != FLUID) | (st[self.faces[:, 1]] != FLUID)

    # ----------------------------------------------------------------- queries
    def boundary_pieces(self, side: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """PHYSICAL parts of the box side's grid edges: edge index (into ``grid.side_edges``)
        and local range ``[s0, s1]`` (0 at the edge's first node). Uncut edges give [0, 1]."""
        cache = self.__dict__.setdefault("_boundary_pieces", {})
        if side in cache:
            return cache[side]
        g = self.grid
        X = g.nodes
        edges = g.side_edges(side)
        d = 0 if side in ("bottom", "top") else 1  # coordinate that varies along the side
        coords = X[edges[:, 0], d]
        a, b = X[edges[0, 0]], X[edges[-1, 1]]
        piece_e, piece_s0, piece_s1 = [], [], []
        if not self.fluid.is_empty:
            inter = shapely.intersection(shapely.LineString([a, b]), self.fluid)
            for part in shapely.get_parts(inter):
                if part.geom_type != "LineString" or part.length <= 0.0:
                    continue
                c = np.asarray(part.coords)[:, d]
                lo, hi = float(c.min()), float(c.max())
                k0 = max(int(np.searchsorted(coords, lo, side="right")) - 1, 0)
                k1 = min(int(np.searchsorted(coords, hi, side="left")), len(edges))
                for k in range(k0, k1):
                    e0, e1 = X[edges[k, 0], d], X[edges[k, 1], d]
                    s0 = max(0.0, (lo - e0) / (e1 - e0))
                    s1 = min(1.0, (hi - e0) / (e1 - e0))
                    if s1 - s0 > 1e-14:
                        piece_e.append(k)
                        piece_s0.append(s0)
                        piece_s1.append(s1)
        out = (np.asarray(piece_e, dtype=np.int64), np.asarray(piece_s0, float), np.asarray(piece_s1, float))
        cache[side] = out
        return out

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


def _polygonal(geom: shapely.Geometry) -> shapely.Geometry:
    """Keep only the polygonal parts of an overlay result (drop touching lines/points)."""
    if geom.geom_type in ("Polygon", "MultiPolygon"):
        return geom
    parts = [p for p in shapely.get_parts(geom) if p.geom_type == "Polygon" and p.area > 0]
    if not parts:
        return shapely.Polygon()
    return parts[0] if len(parts) == 1 else shapely.MultiPolygon(parts)
