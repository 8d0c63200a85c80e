"""The body-boundary quadrature of the coupling term, built once per geometry update.

Every body's coupling boundary Γ (paper Sec. 2: its fluid interface edges, or its contact
edges in a dry problem) is cut into straight *pieces*, each integrated with a Gauss rule. A
piece knows, once, everything the traction kernel (:mod:`fsci.coupling.traction`) reads:

* its body, edge and parameter range, split where the edge crosses fluid grid lines and other
  bodies' outlines (from the cut, :class:`fsci.cut.state.CutState`) and where the opposite
  contact surface's nodes project onto it (paper Remark 9); the projected ends are kept
  symbolic so that they move with the unknowns;
* the fluid part (cell and fluid piece) its fluid quantities are taken from and whether it bounds the physical fluid
  (Γ^FS) or not (Γ^SC, Sec. 3.1.3);
* the opposite surface segment seen along its normal within the search cut-off (contact
  search, paper (10)); without one, ``g_n = ∞``;
* for a Γ^SC piece, the extension point (§4.6): the closest point of Γ^FS ∩ Γ^SC on the same
  body, with the fluid cell on its fluid side.

Pieces that can contribute nothing (dry pieces without an opposite surface, Γ^SC pieces
without an opposite surface and without an extension point, parts outside the fluid box) are
dropped.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from fsci.cut.state import END_NODE0, is_moving_end
from fsci.geometry.search import Surface, find_pieces


@dataclass
class CouplingPieces:
    """Integration pieces of all bodies (one row per piece)."""

    body: np.ndarray  # body index
    edge: np.ndarray  # index into that body's coupling edges
    s0: np.ndarray  # parameter range on the edge (0 at its first node)
    s1: np.ndarray
    d0: np.ndarray  # end descriptors: -1 fixed, 0/1 projection of the opposite segment's node,
    d1: np.ndarray  # 2/3 on the grid line x = c / y = c (fsci.cut.state.END_X, END_Y), 4-6 where the
    # edge crosses another body's boundary edge c or its closed film's line (fsci.cut.state.MOVING_ENDS),
    # 7/8 projection of node 0/1 of coupling edge c, not the opposite segment (END_NODE0/1)
    c0: np.ndarray  # grid-line coordinate of an end of kind 2/3, that edge of kind 4-8
    c1: np.ndarray
    cell: np.ndarray  # fluid part of the piece: cell + n_cells × fluid piece (CutState.part_conn; -1: none)
    fs: np.ndarray  # bounds the physical fluid (Γ^FS)
    opp_body: np.ndarray  # body of the opposite segment (-1: none, g_n = ∞)
    opp_edge: np.ndarray  # its index in the opposite body's coupling edges
    ext_edge: np.ndarray  # extension point: edge of the same body (-1: none)
    ext_s: np.ndarray  # and its parameter on that edge
    ext_cell: np.ndarray  # fluid part on the fluid side of the extension point
    ext_d: np.ndarray  # its descriptor: 4-6 where it lies on another body's edge ext_c or its film line, else -1
    ext_c: np.ndarray
    mouth: np.ndarray  # a closed film's mouth along the edge (fsci.cut.state.CutState.mouths), not on it

    def __len__(self) -> int:
        return len(self.body)


@dataclass
class BoundaryOf:
    """Coupling boundary of one body in the current configuration."""

    x: np.ndarray  # current node coordinates
    edges: np.ndarray  # coupling edges (k, 2), cell on the left
    cell: np.ndarray  # parent cell of each edge
    local: np.ndarray  # local edge index in the parent cell
    contact: np.ndarray  # indices (into edges) of the edges that may touch other bodies


def _base_pieces(boundaries: list[BoundaryOf], cut) -> list[tuple[np.ndarray, ...]]:
    """Per body ``(edge, s0, s1, kind0, line0, kind1, line1, cell, fs)``: the cut's pieces inside
    the box, or (dry) the contact edges whole."""
    out = []
    for b, bd in enumerate(boundaries):
        if cut is not None:
            seg = cut.segments
            m = (seg.body == b) & seg.inside
            out.append((seg.edge[m], seg.s0[m], seg.s1[m], seg.kind0[m], seg.line0[m], seg.kind1[m], seg.line1[m],
                        seg.part[m], seg.fs[m]))
        else:
            e = bd.contact
            fixed = np.full(len(e), -1, np.int64)
            out.append((e, np.zeros(len(e)), np.ones(len(e)), fixed, np.zeros(len(e)), fixed, np.zeros(len(e)),
                        np.full(len(e), -1, np.int64), np.zeros(len(e), bool)))
    return out


def _search(boundaries: list[BoundaryOf], radius: float, self_contact: bool, split: bool, n_fixed: int):
    """Contact pieces per body, in coupling-edge indices: ``(edge, opp_body, opp_edge, s0, s1, d0, d1)``."""
    bodies = [b for b, bd in enumerate(boundaries) if len(bd.contact)]
    surfaces = [Surface(k, boundaries[b].x, boundaries[b].edges[boundaries[b].contact],
                        boundaries[b].cell[boundaries[b].contact], boundaries[b].local[boundaries[b].contact])
                for k, b in enumerate(bodies)]
    out: dict[int, tuple[np.ndarray, ...]] = {}
    for k, b in enumerate(bodies):
        pc = find_pieces(surfaces, k, radius, self_contact, split, n_fixed)
        if len(pc) == 0:
            continue
        ob = np.array(bodies, dtype=np.int64)[pc.opp_surface]
        oe = np.array([boundaries[bb].contact[j] for bb, j in zip(ob, pc.opp_edge)], dtype=np.int64)
        out[b] = (boundaries[b].contact[pc.edge], ob, oe, pc.s0, pc.s1, pc.d0, pc.d1)
    return out


def _merge(base: tuple[np.ndarray, ...], contact: tuple[np.ndarray, ...] | None,
           edge_offset: np.ndarray) -> np.ndarray:
    """Split the base pieces of one body at the ends of its contact pieces and attach the
    opposite segment covering each sub-piece. Rows: (edge, s0, s1, d0, d1, c0, c1, cell, fs,
    opposite body, opposite edge). ``edge_offset[b]``: index of body b's first coupling edge
    among all bodies' coupling edges.

    Where an opposite node projects (Remark 9) the pieces on both sides end at the projection,
    moving with the unknowns: the piece whose opposite segment has the node as ``d`` = 0/1, a
    piece on the other side with another opposite segment (the opposite surface ends at the
    node: a tip) or none as ``END_NODE0/1`` of that segment. Both sides then move together, so
    the pieces still tile the edge (on Γ^FS: the fluid boundary of the cut, discrete mass
    balance (46)), and the Jacobian has the motion of the split, across which the traction can
    jump (the slip law (40) of one gap on one side, of another or none on the other)."""
    e, s0, s1, k0, l0, k1, l1, cell, fs = base
    if contact is None:  # every piece as it is
        none = np.full(len(e), -1.0)
        return np.column_stack([e, s0, s1, k0, k1, l0, l1, cell, fs, none, none]).astype(float)
    ce, ob, oe, c0, c1, cd0, cd1 = contact
    out = np.empty((len(e) + 2 * len(ce), 11))
    n = _merge_rows(e.astype(np.int64), s0, s1, k0.astype(np.int64), l0, k1.astype(np.int64), l1,
                    cell.astype(np.int64), fs.astype(np.int64), ce.astype(np.int64), ob.astype(np.int64),
                    oe.astype(np.int64), c0, c1, cd0.astype(np.int64), cd1.astype(np.int64),
                    edge_offset.astype(np.int64), out)
    return out[:n]


@njit(cache=True)
def _split_end(v, j, cand, start, c0, c1, cd0, cd1, ob, oe, edge_offset):
    """Descriptor and coordinate of the end at split ``v`` of a sub-piece covered by contact
    piece ``j`` (-1: none): its own opposite node's projection, else one of a neighbouring
    contact piece (``cand``: those of the edge, in order) that ends there, else fixed."""
    if j >= 0:
        own, d = (c0[j], cd0[j]) if start else (c1[j], cd1[j])
        if abs(v - own) <= 1e-14 and d >= 0:
            return d, 0.0
    for i in cand:
        other, d = (c1[i], cd1[i]) if start else (c0[i], cd0[i])
        if i != j and abs(v - other) <= 1e-14 and d >= 0:
            return END_NODE0 + d, float(edge_offset[ob[i]] + oe[i])
    return -1, 0.0


@njit(cache=True)
def _merge_rows(e, s0, s1, k0, l0, k1, l1, cell, fs, ce, ob, oe, c0, c1, cd0, cd1, edge_offset, out):
    """The rows of :func:`_merge` into ``out`` (room for ``len(e) + 2 len(ce)``), in the order
    of the base pieces; returns their number."""
    n_edges = 1
    for k in range(len(e)):
        n_edges = max(n_edges, e[k] + 1)
    for j in range(len(ce)):
        n_edges = max(n_edges, ce[j] + 1)
    ptr = np.zeros(n_edges + 1, dtype=np.int64)  # the contact pieces of each edge, in their order
    for j in range(len(ce)):
        ptr[ce[j] + 1] += 1
    for i in range(n_edges):
        ptr[i + 1] += ptr[i]
    fill = ptr[:-1].copy()
    idx = np.empty(len(ce), dtype=np.int64)
    for j in range(len(ce)):
        idx[fill[ce[j]]] = j
        fill[ce[j]] += 1
    cuts = np.empty(2 * len(ce) + 2)
    n = 0
    for k in range(len(e)):
        cand = idx[ptr[e[k]]:ptr[e[k] + 1]]
        if len(cand) == 0:  # as it is
            out[n, 0], out[n, 1], out[n, 2], out[n, 3], out[n, 4] = e[k], s0[k], s1[k], k0[k], k1[k]
            out[n, 5], out[n, 6], out[n, 7], out[n, 8], out[n, 9], out[n, 10] = l0[k], l1[k], cell[k], fs[k], -1.0, -1.0
            n += 1
            continue
        m = 0
        cuts[m] = s0[k]
        cuts[m + 1] = s1[k]
        m += 2
        for j in cand:
            for v in (c0[j], c1[j]):
                if s0[k] < v < s1[k]:
                    cuts[m] = v
                    m += 1
        srt = np.sort(cuts[:m])
        prev = srt[0]
        for q in range(1, m):
            hi = srt[q]
            if hi == prev:  # (the same split twice)
                continue
            lo = prev
            prev = hi
            if hi - lo <= 1e-13:
                continue
            mid = 0.5 * (lo + hi)
            j = -1
            for i in cand:
                if c0[i] <= mid <= c1[i]:
                    j = i
                    break
            # an end is the base piece's end (fixed, on a grid line or another body's edge), or
            # where an opposite node projects (Remark 9, moving with the unknowns)
            if lo == s0[k]:
                dl, cl = k0[k], l0[k]
            else:
                dl, cl = _split_end(lo, j, cand, True, c0, c1, cd0, cd1, ob, oe, edge_offset)
            if hi == s1[k]:
                dh, ch = k1[k], l1[k]
            else:
                dh, ch = _split_end(hi, j, cand, False, c0, c1, cd0, cd1, ob, oe, edge_offset)
            out[n, 0], out[n, 1], out[n, 2], out[n, 3], out[n, 4] = e[k], lo, hi, dl, dh
            out[n, 5], out[n, 6], out[n, 7], out[n, 8] = cl, ch, cell[k], fs[k]
            out[n, 9] = ob[j] if j >= 0 else -1
            out[n, 10] = oe[j] if j >= 0 else -1
            n += 1
    return n


def _extension(x: np.ndarray, edges: np.ndarray, rows: np.ndarray, scale: float) -> np.ndarray:
    """For the pieces ``rows`` of one body (columns edge, s0, s1, d0, d1, cell, fs, c0, c1), the
    extension point of every Γ^SC piece: ``(edge, s, cell, d, c)`` of the closest point of
    Γ^FS ∩ Γ^SC with the descriptor of the Γ^FS piece's end there, or -1."""
    n = len(rows)
    ext = np.full((n, 5), -1.0)
    fs = rows[:, 6] > 0
    if n == 0 or fs.all() or not fs.any():
        return ext
    e = rows[:, 0].astype(np.int64)
    a = x[edges[e, 0]]
    d = x[edges[e, 1]] - a
    p0 = a + rows[:, 1, None] * d
    p1 = a + rows[:, 2, None] * d
    tol = 1e-9 * scale
    sc_pts = np.vstack([p0[~fs], p1[~fs]])
    cand = []  # (point, edge, s, cell, d, c) of FS piece ends touching an SC piece end
    for end, p in ((1, p0), (2, p1)):
        idx = np.nonzero(fs)[0]
        dist = np.min(np.linalg.norm(p[idx, None, :] - sc_pts[None, :, :], axis=2), axis=1)
        for k in idx[dist <= tol]:
            cand.append((p[k], e[k], rows[k, end], rows[k, 5], rows[k, 2 + end], rows[k, 6 + end]))
    if not cand:
        return ext
    pts = np.array([c[0] for c in cand])
    for k in np.nonzero(~fs)[0]:
        mid = 0.5 * (p0[k] + p1[k])
        j = int(np.argmin(np.linalg.norm(pts - mid, axis=1)))
        ext[k] = cand[j][1:]
    return ext


def build_pieces(boundaries: list[BoundaryOf], cut, radius: float, self_contact: bool = False, split: bool = True,
                 n_fixed: int = 10, extension: bool = True) -> CouplingPieces:
    """All coupling pieces of the current geometry (see the module docstring).

    Parameters
    ----------
    boundaries
        Coupling boundary of every body (bodies without coupling edges have empty arrays).
    cut
        The current :class:`fsci.cut.state.CutState` (fluid problems) or ``None`` (dry contact).
    radius
        Contact-search cut-off: opposite segments farther than this along the normal are not
        seen (``g_n = ∞``).
    self_contact, split, n_fixed
        Contact-search options (:func:`fsci.geometry.search.find_pieces`).
    extension
        Give Γ^SC pieces an extension point (False: the FSI side is zero there).
    """
    base = _base_pieces(boundaries, cut)
    contact = _search(boundaries, radius, self_contact, split, n_fixed)
    edge_offset = np.concatenate([[0], np.cumsum([len(bd.edges) for bd in boundaries])]).astype(np.int64)
    cols = []
    for b, bd in enumerate(boundaries):
        rows = _merge(base[b], contact.get(b), edge_offset)
        scale = 1.0 + float(np.max(np.abs(bd.x))) if len(bd.x) else 1.0
        ext = _extension(bd.x, bd.edges, rows[:, [0, 1, 2, 3, 4, 7, 8, 5, 6]], scale) if cut is not None and extension \
            else np.full((len(rows), 5), -1.0)
        ext[:, 3] = np.where(is_moving_end(ext[:, 3]), ext[:, 3], -1)
        fs = rows[:, 8] > 0
        has_opp = rows[:, 9] >= 0
        keep = fs | has_opp | (ext[:, 0] >= 0)
        rows, ext = rows[keep], ext[keep]
        cols.append(np.column_stack([np.full(len(rows), b), rows, ext, np.zeros(len(rows))]))
        sel = cut.mouths.body == b if cut is not None else None
        if sel is not None and sel.any():  # the mouths of closed films along this body's edges (bulk shape derivative only)
            m = cut.mouths
            none = np.full(int(sel.sum()), -1.0)
            cols.append(np.column_stack([np.full(len(none), b), m.edge[sel], m.s0[sel], m.s1[sel], none, none,
                                         0.0 * none, 0.0 * none, m.part[sel], -none, none, none, none,
                                         0.0 * none, none, none, 0.0 * none, -none]))
    a = np.vstack(cols) if cols else np.zeros((0, 18))
    i = lambda c: a[:, c].astype(np.int64)  # noqa: E731
    return CouplingPieces(body=i(0), edge=i(1), s0=a[:, 2].copy(), s1=a[:, 3].copy(), d0=i(4), d1=i(5),
                          c0=a[:, 6].copy(), c1=a[:, 7].copy(), cell=i(8), fs=a[:, 9] > 0, opp_body=i(10),
                          opp_edge=i(11), ext_edge=i(12), ext_s=a[:, 13].copy(),
                          ext_cell=i(14), ext_d=i(15), ext_c=a[:, 16].copy(), mouth=a[:, 17] > 0)
