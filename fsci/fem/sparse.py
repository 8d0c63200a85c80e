"""Sparse assembly with a cached pattern built at the level of node pairs.

Every unknown belongs to a *global node* carrying ``ndof[a]`` consecutive dofs (2 for solid
nodes, 3 for fluid nodes ``v_x, v_y, p``). Any term couples the full dof blocks of the nodes
it touches, so the sparsity pattern is the node-pair graph expanded by the dof counts. All rows
of one node then share the same column list, and the position of entry
``(dof(a, c), dof(b, c'))`` in the CSR data array is

    row_base[a] + c * row_len[a] + col_off(a, b) + c'.

Element kernels receive ``col_off`` for their node pairs (computed once per connectivity and
pattern) and add straight into the CSR data array: no COO triplets, no sorting per assembly.

A pattern may hold more pairs than the terms couple (``reach``: pairs a moving interface may
take on in later Newton iterations); the matrix then stores explicit zeros there, and
:meth:`Pattern.covers` tells whether a set of blocks fits into it.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
from numba import njit


@njit(cache=True)
def _count_pairs(conn, counts):
    m = conn.shape[1]
    for e in range(conn.shape[0]):
        valid = 0
        for i in range(m):
            if conn[e, i] >= 0:
                valid += 1
        for i in range(m):
            a = conn[e, i]
            if a >= 0:
                counts[a] += valid


@njit(cache=True)
def _fill_pairs(conn, ptr, fill, buf):
    m = conn.shape[1]
    for e in range(conn.shape[0]):
        for i in range(m):
            a = conn[e, i]
            if a < 0:
                continue
            for j in range(m):
                b = conn[e, j]
                if b >= 0:
                    buf[ptr[a] + fill[a]] = b
                    fill[a] += 1


@njit(cache=True)
def _count_bipartite(A, B, counts):
    for e in range(A.shape[0]):
        na = 0
        nb = 0
        for i in range(A.shape[1]):
            if A[e, i] >= 0:
                na += 1
        for j in range(B.shape[1]):
            if B[e, j] >= 0:
                nb += 1
        for i in range(A.shape[1]):
            if A[e, i] >= 0:
                counts[A[e, i]] += nb
        for j in range(B.shape[1]):
            if B[e, j] >= 0:
                counts[B[e, j]] += na


@njit(cache=True)
def _fill_bipartite(A, B, ptr, fill, buf):
    for e in range(A.shape[0]):
        for i in range(A.shape[1]):
            a = A[e, i]
            if a < 0:
                continue
            for j in range(B.shape[1]):
                b = B[e, j]
                if b >= 0:
                    buf[ptr[a] + fill[a]] = b
                    fill[a] += 1
                    buf[ptr[b] + fill[b]] = a
                    fill[b] += 1


@njit(cache=True)
def _unique_rows(ptr, buf, n):
    counts = np.zeros(n, dtype=np.int64)
    for a in range(n):
        row = np.sort(buf[ptr[a] : ptr[a + 1]])
        k = 0
        last = -1
        for v in row:
            if v != last:
                buf[ptr[a] + k] = v
                k += 1
                last = v
        counts[a] = k
    nptr = np.zeros(n + 1, dtype=np.int64)
    for a in range(n):
        nptr[a + 1] = nptr[a] + counts[a]
    nbr = np.empty(nptr[n], dtype=np.int64)
    for a in range(n):
        for k in range(counts[a]):
            nbr[nptr[a] + k] = buf[ptr[a] + k]
    return nptr, nbr


@njit(cache=True)
def _expand(nptr, nbr, ndof, start):
    n = len(ndof)
    row_len = np.zeros(n, dtype=np.int64)
    col_off = np.zeros(len(nbr), dtype=np.int64)
    for a in range(n):
        s = 0
        for k in range(nptr[a], nptr[a + 1]):
            col_off[k] = s
            s += ndof[nbr[k]]
        row_len[a] = s
    n_dof = start[n]
    indptr = np.zeros(n_dof + 1, dtype=np.int64)
    row_base = np.zeros(n, dtype=np.int64)
    pos = 0
    for a in range(n):
        row_base[a] = pos
        for c in range(ndof[a]):
            indptr[start[a] + c] = pos
            pos += row_len[a]
    indptr[n_dof] = pos
    indices = np.empty(pos, dtype=np.int32)
    for a in range(n):
        for c in range(ndof[a]):
            p = row_base[a] + c * row_len[a]
            for k in range(nptr[a], nptr[a + 1]):
                b = nbr[k]
                for c2 in range(ndof[b]):
                    indices[p] = start[b] + c2
                    p += 1
    return row_len, col_off, indptr, indices, row_base


@njit(cache=True)
def _positions(conn, nptr, nbr, col_off):
    """Column offsets of the node pairs of ``conn`` and the number of pairs not in the pattern."""
    n_e, m = conn.shape
    out = np.full((n_e, m, m), -1, dtype=np.int32)
    missing = 0
    for e in range(n_e):
        for i in range(m):
            a = conn[e, i]
            if a < 0:
                continue
            lo = nptr[a]
            for j in range(m):
                b = conn[e, j]
                if b < 0:
                    continue
                hi = nptr[a + 1]
                l, r = lo, hi - 1
                while l < r:
                    mid = (l + r) // 2
                    if nbr[mid] < b:
                        l = mid + 1
                    else:
                        r = mid
                if l < hi and nbr[l] == b:
                    out[e, i, j] = col_off[l]
                else:
                    missing += 1
    return out, missing


@njit(cache=True)
def add_local(data, rhs, row_base, row_len, start, ndof, nodes, pos, Ke, Re, want_matrix, diagonal_blocks=False):
    """Add one local matrix/vector (rows node-major, ``ndof`` components per node).

    ``nodes[i] < 0`` marks a slot without dofs (skipped). ``diagonal_blocks``: the local matrix
    couples only equal components of two nodes (the CIP / ghost-penalty terms on faces parallel
    to an axis), and only those entries are added: a third of the memory traffic for three
    components per node."""
    m = len(nodes)
    ri = 0
    for i in range(m):
        a = nodes[i]
        if a < 0:
            continue
        nda = ndof[a]
        for c in range(nda):
            rhs[start[a] + c] += Re[ri + c]
        if want_matrix:
            for c in range(nda):
                base = row_base[a] + c * row_len[a]
                ci = 0
                for j in range(m):
                    b = nodes[j]
                    if b < 0:
                        continue
                    ndb = ndof[b]
                    off = base + pos[i, j]
                    lo, hi = (c, min(c + 1, ndb)) if diagonal_blocks else (0, ndb)
                    for c2 in range(lo, hi):
                        data[off + c2] += Ke[ri + c, ci + c2]
                    ci += ndb
        ri += nda


@dataclass
class DofLayout:
    """Global nodes with their number of dofs; dofs of a node are consecutive."""

    ndof: np.ndarray
    start: np.ndarray = field(init=False)

    def __post_init__(self) -> None:
        self.ndof = np.ascontiguousarray(self.ndof, dtype=np.int64)
        self.start = np.concatenate([[0], np.cumsum(self.ndof)]).astype(np.int64)

    @property
    def n_nodes(self) -> int:
        return len(self.ndof)

    @property
    def n_dofs(self) -> int:
        return int(self.start[-1])

    def signature(self) -> bytes:
        return hashlib.sha1(self.ndof.tobytes()).digest()


def _conn_key(conn: np.ndarray) -> bytes:
    c = np.ascontiguousarray(conn, dtype=np.int64)
    return hashlib.sha1(c.tobytes()).digest() + bytes(str(c.shape), "ascii")


class Pattern:
    """CSR sparsity pattern of a set of coupling blocks on a :class:`DofLayout`.

    Parameters
    ----------
    layout
        The dof layout.
    blocks
        Connectivity arrays ``(n_e, m)`` of global node ids; every node pair inside one row is
        coupled. Entries ``< 0`` are ignored. Every node is coupled with itself, so diagonals
        are always stored.
    reach
        Pairs of arrays ``(A, B)`` with the same number of rows: every node of ``A[e]`` is
        coupled with every node of ``B[e]`` (both ways; not the nodes of ``A[e]`` among
        themselves, nor those of ``B[e]``).
    """

    POSITIONS_KEPT = 16  # connectivities whose positions are cached

    def __init__(self, layout: DofLayout, blocks: list[np.ndarray],
                 reach: list[tuple[np.ndarray, np.ndarray]] = ()) -> None:
        self.layout = layout
        n = layout.n_nodes
        diag = np.arange(n, dtype=np.int64)[:, None]
        blocks = [diag] + [np.ascontiguousarray(b, dtype=np.int64) for b in blocks if len(b)]
        reach = [(np.ascontiguousarray(a, dtype=np.int64), np.ascontiguousarray(b, dtype=np.int64))
                 for a, b in reach if len(a)]
        counts = np.zeros(n, dtype=np.int64)
        for b in blocks:
            _count_pairs(b, counts)
        for a, b in reach:
            _count_bipartite(a, b, counts)
        ptr = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
        buf = np.empty(ptr[-1], dtype=np.int64)
        fill = np.zeros(n, dtype=np.int64)
        for b in blocks:
            _fill_pairs(b, ptr, fill, buf)
        for a, b in reach:
            _fill_bipartite(a, b, ptr, fill, buf)
        self._expand(*_unique_rows(ptr, buf, n))

    @classmethod
    def from_graph(cls, layout: DofLayout, nptr: np.ndarray, nbr: np.ndarray) -> "Pattern":
        """The pattern of a node graph (:attr:`nptr`, :attr:`nbr` of another pattern: each
        node's sorted neighbours) on ``layout``."""
        if len(nptr) != layout.n_nodes + 1:
            raise ValueError(f"a node graph of {len(nptr) - 1} nodes on a layout of {layout.n_nodes}")
        pat = cls.__new__(cls)
        pat.layout = layout
        pat._expand(np.ascontiguousarray(nptr, dtype=np.int64), np.ascontiguousarray(nbr, dtype=np.int64))
        return pat

    def _expand(self, nptr: np.ndarray, nbr: np.ndarray) -> None:
        self.nptr, self.nbr = nptr, nbr
        lay = self.layout
        self.row_len, self.col_off, self.indptr, self.indices, self.row_base = _expand(nptr, nbr, lay.ndof, lay.start)
        self.key = hashlib.sha1(nptr.tobytes() + nbr.tobytes() + lay.ndof.tobytes()).digest()
        self._pos_cache: dict[bytes, np.ndarray | None] = {}  # None: the connectivity does not fit
        self._diag: np.ndarray | None = None

    @property
    def nnz(self) -> int:
        return int(self.indptr[-1])

    def _lookup(self, conn: np.ndarray) -> np.ndarray | None:
        """Column offsets of the node pairs of ``conn``, None if one is not in the pattern (cached)."""
        key = _conn_key(conn)
        cache = self._pos_cache
        if key in cache:
            cache[key] = pos = cache.pop(key)  # the most recently used last
            return pos
        pos, missing = _positions(np.ascontiguousarray(conn, dtype=np.int64), self.nptr, self.nbr, self.col_off)
        # a pattern can serve many steps, each with new coupling connectivities: the least
        # recently used go (an assembly looks up about five)
        while len(cache) >= self.POSITIONS_KEPT:
            cache.pop(next(iter(cache)))
        cache[key] = pos = pos if missing == 0 else None
        return pos

    def positions(self, conn: np.ndarray) -> np.ndarray:
        """Column offsets ``(n_e, m, m)`` of node pairs of a connectivity (cached)."""
        pos = self._lookup(conn)
        if pos is None:
            raise ValueError("a node pair of the connectivity is not in the sparsity pattern")
        return pos

    def covers(self, blocks: list[np.ndarray]) -> bool:
        """Whether every node pair of ``blocks`` (as in the constructor) is in the pattern."""
        return all(self._lookup(b) is not None for b in blocks if len(b))

    def diagonal_positions(self) -> np.ndarray:
        """Index into the data array of every diagonal entry ``(n_dofs,)``."""
        if self._diag is None:
            lay = self.layout
            out = np.empty(lay.n_dofs, dtype=np.int64)
            own = self.positions(np.arange(lay.n_nodes, dtype=np.int64)[:, None])[:, 0, 0]
            for c in range(int(lay.ndof.max(initial=0))):
                has = lay.ndof > c
                a = np.nonzero(has)[0]
                out[lay.start[a] + c] = self.row_base[a] + c * self.row_len[a] + own[a] + c
            self._diag = out
        return self._diag

    def matrix(self, data: np.ndarray) -> sp.csr_matrix:
        """Wrap a data array in a CSR matrix sharing the pattern arrays."""
        n = self.layout.n_dofs
        mat = sp.csr_matrix((data, self.indices, self.indptr), shape=(n, n), copy=False)
        mat.has_sorted_indices = True
        return mat


class PatternCache:
    """Keeps the patterns of recently used (layout, blocks) combinations."""

    def __init__(self, size: int = 4) -> None:
        self.size = size
        self._store: dict[bytes, Pattern] = {}

    def get(self, layout: DofLayout, blocks: list[np.ndarray],
            reach: list[tuple[np.ndarray, np.ndarray]] = ()) -> Pattern:
        h = hashlib.sha1(layout.signature())
        for b in blocks:
            h.update(_conn_key(b))
        for a, b in reach:
            h.update(b"reach" + _conn_key(a) + _conn_key(b))
        key = h.digest()
        pat = self._store.get(key)
        if pat is None:
            pat = Pattern(layout, blocks, reach)
            if len(self._store) >= self.size:
                self._store.pop(next(iter(self._store)))
            self._store[key] = pat
        return pat
