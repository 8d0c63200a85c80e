"""Contact search (paper Sec. 2.3, (10)): for points on a body's potential-contact
boundary, the projection along the body's outward normal ``n`` onto the boundary segments of
other bodies (or of the same body, for self contact).

For a straight edge the normal is constant, so the set of parameters ξ ∈ [0, 1] of an edge
``e`` whose normal ray hits an opposite segment ``f`` is an interval whose end points are the
orthogonal projections of ``f``'s end points onto ``e``'s line. The search returns these
intervals ("pieces"): the contact integrals are split at the projections of the opposite
element edges (paper Remark 9), each piece seeing one opposite segment.

Rules: the opposite segment must face the edge (``n_e · n_f < -0.1``, 4C's criterion); the gap
``g_n = (x̌ - x)·n`` at the piece's midpoint must satisfy ``|g_n| <= radius`` (beyond the
cut-off ``g_n = ∞``); a segment behind the surface (``g_n < 0``) is seen through a thin part of
the own body, not penetrated, and is no candidate, if the ray from the point to twice its depth
crosses another edge of the own surface (a penetration deeper than half the body's local
thickness cannot be told from a segment seen through it); where several opposite segments are
hit, the nearest (smallest ``|g_n|``) wins. The same projection gives the gap of the
slip-length law (40).

End-point descriptors: ``-1`` fixed parameter (``s0``/``s1`` as given), ``0``/``1`` the
projection of the opposite segment's first/second node.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely

FACING = -0.1


@dataclass
class Surface:
    """Potential-contact edges of one body in the current configuration."""

    body: int
    x: np.ndarray  # current node coordinates of the body
    edges: np.ndarray  # (k, 2) node ids, cell on the left
    cell: np.ndarray  # parent cell of each edge
    local: np.ndarray  # local edge index in the parent cell

    def normals(self) -> np.ndarray:
        d = self.x[self.edges[:, 1]] - self.x[self.edges[:, 0]]
        return np.column_stack([d[:, 1], -d[:, 0]]) / np.linalg.norm(d, axis=1)[:, None]


@dataclass
class Pieces:
    """Contact integration pieces on one surface against opposite segments."""

    edge: np.ndarray  # own edge index
    opp_surface: np.ndarray  # index of the opposite surface
    opp_edge: np.ndarray  # opposite edge index
    s0: np.ndarray
    s1: np.ndarray
    d0: np.ndarray  # end-point descriptors
    d1: np.ndarray

    def __len__(self) -> int:
        return len(self.edge)


def _project(A, B, P, Q):
    """Affine maps along own edges A->B: parameters of the projections of P and Q, and the
    ray-segment coordinates at the own edge's ends. All arrays (k, 2)."""
    t = B - A
    L2 = np.einsum("ij,ij->i", t, t)
    sP = np.einsum("ij,ij->i", P - A, t) / L2
    sQ = np.einsum("ij,ij->i", Q - A, t) / L2
    return sP, sQ


def segment_ends(surfaces: list[Surface], surface: np.ndarray, edge: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """End points ``(P, Q)`` of the edges ``edge`` of the surfaces ``surface`` (one row per pair)."""
    P = np.empty((len(edge), 2))
    Q = np.empty((len(edge), 2))
    for k in np.unique(surface):
        m = surface == k
        sf = surfaces[k]
        P[m] = sf.x[sf.edges[edge[m], 0]]
        Q[m] = sf.x[sf.edges[edge[m], 1]]
    return P, Q


def gap_along_normal(A, B, P, Q, s):
    """Gap and opposite coordinate η of the ray from A + s (B - A) along the normal of A->B."""
    t = B - A
    L = np.linalg.norm(t, axis=1)
    n = np.column_stack([t[:, 1], -t[:, 0]]) / L[:, None]
    x = A + s[:, None] * t
    d = Q - P
    w = x - P
    det = -d[:, 0] * n[:, 1] + n[:, 0] * d[:, 1]
    eta = (-w[:, 0] * n[:, 1] + n[:, 0] * w[:, 1]) / det
    g = (d[:, 0] * w[:, 1] - d[:, 1] * w[:, 0]) / det
    return g, eta


def _seen_through(so: Surface, edge: np.ndarray, A: np.ndarray, B: np.ndarray, s: np.ndarray,
                  g: np.ndarray, opp: np.ndarray) -> np.ndarray:
    """For candidates behind the own surface (``g < 0``): True where the ray from the point
    ``x = A + s (B - A)`` through the opposite point ``x̌ = x + g n`` to ``x + 2 g n`` leaves the
    own body, i.e. crosses another edge of the own surface (``opp``: the opposite edge where it
    belongs to the own surface, self contact, else -1; not counted). Such a segment is seen
    through a thin part of the own body (a flap's tip, the far side of a wedge), not penetrated:
    a true penetration ends inside the own body, and at most half its local thickness deep.
    The ray goes on past x̌ because a body that penetrates the own one slightly puts x̌ inside
    the own body even when it is seen through it: on the pump a flap's tip pressed 3e-5 into
    the other flap's face was found, from that flap's far face, at the gap -2e-3 (docs/
    architecture.md, decision 38). Decides by geometry, not by the size of ``g``, so it holds on
    every mesh."""
    t = B - A
    n = np.column_stack([t[:, 1], -t[:, 0]]) / np.linalg.norm(t, axis=1)[:, None]
    x = A + s[:, None] * t
    xb = x + 2.0 * g[:, None] * n
    own = shapely.STRtree(shapely.linestrings(np.stack([so.x[so.edges[:, 0]], so.x[so.edges[:, 1]]], axis=1)))
    ray, hit = own.query(shapely.linestrings(np.stack([x, xb], axis=1)), predicate="intersects")
    other = (hit != edge[ray]) & (hit != opp[ray])  # the ray starts on its own edge
    out = np.zeros(len(edge), dtype=bool)
    out[ray[other]] = True
    return out


def _boxes_meet(a: tuple[np.ndarray, np.ndarray], b: tuple[np.ndarray, np.ndarray]) -> bool:
    """Whether two closed boxes ``(lower corner, upper corner)`` intersect."""
    return bool(np.all(a[0] <= b[1]) and np.all(b[0] <= a[1]))


def find_pieces(surfaces: list[Surface], own: int, radius: float, self_contact: bool = False,
                split: bool = True, n_fixed: int = 10) -> Pieces:
    """Contact pieces of surface ``own`` against all other surfaces (and itself if
    ``self_contact``). With ``split=False`` every edge is divided into ``n_fixed`` equal
    sub-intervals with fixed ends, each assigned the opposite segment hit by its midpoint."""
    so = surfaces[own]
    A = so.x[so.edges[:, 0]]
    B = so.x[so.edges[:, 1]]
    n_own = None  # (made once a surface is within reach)
    rows = []
    reach = (np.minimum(A, B).min(axis=0, initial=np.inf) - radius, np.maximum(A, B).max(axis=0, initial=-np.inf) + radius)
    for k, sf in enumerate(surfaces):
        if k == own and not self_contact:
            continue
        P = sf.x[sf.edges[:, 0]]
        Q = sf.x[sf.edges[:, 1]]
        if k != own and not _boxes_meet(reach, (np.minimum(P, Q).min(axis=0, initial=np.inf),
                                                np.maximum(P, Q).max(axis=0, initial=-np.inf))):
            continue  # out of reach as a whole (the tree's query would find nothing)
        tree = shapely.STRtree(shapely.linestrings(np.stack([P, Q], axis=1)))
        n_own = so.normals() if n_own is None else n_own
        lo = np.minimum(A, B) - radius
        hi = np.maximum(A, B) + radius
        ie, jf = tree.query(shapely.box(lo[:, 0], lo[:, 1], hi[:, 0], hi[:, 1]))
        if len(ie) == 0:
            continue
        n_opp = sf.normals()
        face = np.einsum("ij,ij->i", n_own[ie], n_opp[jf]) < FACING
        if k == own:  # self contact: not the edge itself nor its neighbours
            shared = np.array([len(set(so.edges[a]) & set(sf.edges[b])) > 0 for a, b in zip(ie, jf)], dtype=bool)
            face &= ~shared
        ie, jf = ie[face], jf[face]
        if split:
            sP, sQ = _project(A[ie], B[ie], P[jf], Q[jf])
            # interval of own parameters whose ray hits the segment: between the projections
            lo_s = np.minimum(sP, sQ)
            hi_s = np.maximum(sP, sQ)
            d_lo = np.where(sP <= sQ, 0, 1)
            d_hi = 1 - d_lo
            s0 = np.maximum(lo_s, 0.0)
            s1 = np.minimum(hi_s, 1.0)
            d0 = np.where(lo_s > 0.0, d_lo, -1)
            d1 = np.where(hi_s < 1.0, d_hi, -1)
            ok = s1 - s0 > 1e-12
            rows.append((ie[ok], np.full(ok.sum(), k), jf[ok], s0[ok], s1[ok], d0[ok], d1[ok]))
        else:
            for m in range(n_fixed):
                s = np.full(len(ie), (m + 0.5) / n_fixed)
                g, eta = gap_along_normal(A[ie], B[ie], P[jf], Q[jf], s)
                ok = (eta >= 0.0) & (eta <= 1.0)
                rows.append((ie[ok], np.full(ok.sum(), k), jf[ok], np.full(ok.sum(), m / n_fixed),
                             np.full(ok.sum(), (m + 1) / n_fixed), np.full(ok.sum(), -1), np.full(ok.sum(), -1)))
    if not rows:
        z = np.zeros(0, dtype=np.int64)
        return Pieces(z, z, z, np.zeros(0), np.zeros(0), z, z)
    e, osf, f, s0, s1, d0, d1 = (np.concatenate([r[i] for r in rows]) for i in range(7))
    pieces = _resolve_overlaps(surfaces, own, e, osf, f, s0, s1, d0, d1, radius, split)
    return pieces


def _resolve_overlaps(surfaces, own, e, osf, f, s0, s1, d0, d1, radius, split) -> Pieces:
    """Keep, for every part of every own edge, the nearest opposite segment within the
    cut-off; where candidates overlap the edge is split at all candidate end points.

    Vectorised over all edges at once: the sub-intervals of every edge (between consecutive
    distinct candidate end points), every (sub-interval, candidate covering its midpoint) pair,
    the gap of each pair at the midpoint, and per sub-interval the nearest candidate (the first
    in (edge, s0) order among equals)."""
    so = surfaces[own]
    z = np.zeros(0, dtype=np.int64)
    empty = Pieces(z, z, z, np.zeros(0), np.zeros(0), z, z)
    if len(e) == 0:
        return empty
    order = np.lexsort((s0, e))
    e, osf, f, s0, s1, d0, d1 = e[order], osf[order], f[order], s0[order], s1[order], d0[order], d1[order]
    starts = np.concatenate([[0], np.nonzero(np.diff(e))[0] + 1])
    ends = np.concatenate([starts[1:], [len(e)]])
    group = np.repeat(np.arange(len(starts)), ends - starts)  # group (own edge) of every candidate
    # distinct end points per group, ascending: the sub-interval boundaries
    gv = np.concatenate([group, group])
    vals = np.concatenate([s0, s1])
    o = np.lexsort((vals, gv))
    gv, vals = gv[o], vals[o]
    new_pt = np.ones(len(vals), dtype=bool)
    new_pt[1:] = (gv[1:] != gv[:-1]) | (vals[1:] != vals[:-1])
    gv, vals = gv[new_pt], vals[new_pt]
    nxt = np.nonzero(gv[1:] == gv[:-1])[0]  # consecutive boundaries of one group
    lo, hi, ig = vals[nxt], vals[nxt + 1], gv[nxt]
    ok = hi - lo > 1e-12
    lo, hi, ig = lo[ok], hi[ok], ig[ok]
    if len(lo) == 0:
        return empty
    mid = 0.5 * (lo + hi)
    # (sub-interval, candidate of its group) pairs whose candidate covers the midpoint
    cnt = ends[ig] - starts[ig]
    iv = np.repeat(np.arange(len(lo)), cnt)
    c = starts[ig][iv] + (np.arange(len(iv)) - np.repeat(np.cumsum(cnt) - cnt, cnt))
    cover = (s0[c] <= mid[iv]) & (mid[iv] <= s1[c])
    iv, c = iv[cover], c[cover]
    if len(iv) == 0:
        return empty
    edge = e[c]
    A = so.x[so.edges[edge, 0]]
    B = so.x[so.edges[edge, 1]]
    P, Q = segment_ends(surfaces, osf[c], f[c])
    g, _ = gap_along_normal(A, B, P, Q, mid[iv])
    ag = np.abs(g)
    keep = ag <= radius
    behind = np.nonzero(keep & (g < 0.0))[0]
    if len(behind):
        opp = np.where(osf[c][behind] == own, f[c][behind], -1)
        keep[behind] = ~_seen_through(so, edge[behind], A[behind], B[behind], mid[iv][behind], g[behind], opp)
    iv, c, ag = iv[keep], c[keep], ag[keep]
    if len(iv) == 0:
        return empty
    o = np.lexsort((c, ag, iv))  # per sub-interval: smallest |g|, then the first candidate
    first = np.ones(len(o), dtype=bool)
    first[1:] = iv[o][1:] != iv[o][:-1]
    best = c[o][first]
    j = iv[o][first]
    lo, hi = lo[j], hi[j]
    # one piece per run of sub-intervals with the same nearest candidate: a split there (the end
    # of a farther candidate) would be fixed, and the Gauss rule's error on the rational
    # integrand (the slip law (40)) would move with it outside the Jacobian (5e-4 of a block)
    run = np.ones(len(best), dtype=bool)
    run[1:] = (best[1:] != best[:-1]) | (lo[1:] != hi[:-1])
    head = np.nonzero(run)[0]
    tail = np.concatenate([head[1:], [len(best)]]) - 1
    best, lo, hi = best[head], lo[head], hi[tail]
    # keep symbolic end points only where they are the candidate's own interval ends
    dl = np.where(np.abs(lo - s0[best]) <= 1e-14, d0[best], -1)
    dh = np.where(np.abs(hi - s1[best]) <= 1e-14, d1[best], -1)
    return Pieces(e[best].astype(np.int64), osf[best].astype(np.int64), f[best].astype(np.int64),
                  lo.astype(float), hi.astype(float), dl.astype(np.int64), dh.astype(np.int64))
