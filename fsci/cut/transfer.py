"""Solution-space update (paper Sec. 3.4.3): values for newly ACTIVE background nodes, and the
carrying of the state from the virtual nodes of one cut to those of the next.

A node that becomes ACTIVE gets the average of its already-known neighbours (the 8 grid
neighbours); nodes with no known neighbour are filled in further sweeps, so the extension
grows layer by layer out of the previous ACTIVE set.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def _extend(values, known, target, nxp, nyp):
    n = values.shape[0]
    k = values.shape[1]
    todo = np.empty(n, dtype=np.int64)
    m = 0
    for a in range(n):
        if target[a] and not known[a]:
            todo[m] = a
            m += 1
    acc = np.zeros(k)
    for _sweep in range(nxp + nyp):
        if m == 0:
            break
        newly = np.zeros(m, dtype=np.bool_)
        for t in range(m):
            a = todo[t]
            i = a % nxp
            j = a // nxp
            cnt = 0
            acc[:] = 0.0
            for dj in range(-1, 2):
                for di in range(-1, 2):
                    if di == 0 and dj == 0:
                        continue
                    ii = i + di
                    jj = j + dj
                    if 0 <= ii < nxp and 0 <= jj < nyp:
                        b = jj * nxp + ii
                        if known[b]:
                            for c in range(k):
                                acc[c] += values[b, c]
                            cnt += 1
            if cnt > 0:
                for c in range(k):
                    values[a, c] = acc[c] / cnt
                newly[t] = True
        for t in range(m):
            if newly[t]:
                known[todo[t]] = True
        mm = 0
        for t in range(m):
            if not newly[t]:
                todo[mm] = todo[t]
                mm += 1
        m = mm


def extend_to_new_nodes(grid, values: np.ndarray, known: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Fill ``values`` (``(n_nodes,)`` or ``(n_nodes, k)``) at ``target & ~known`` nodes in place."""
    v2 = values.reshape(len(values), -1)
    _extend(v2, known.copy(), target, grid.nx + 1, grid.ny + 1)
    return values


def transfer_indices(old_node: np.ndarray, old_rep: np.ndarray, old_active: np.ndarray, new_node: np.ndarray,
                     new_rep: np.ndarray, n_nodes: int) -> np.ndarray:
    """For each virtual node of a new cut, the virtual node of the previous cut whose values it
    takes (-1: none; the node was not ACTIVE). A node with one set of unknowns before and after
    keeps its values; where a node has several (one per connected fluid part) before or after, each
    new set takes the old set of that node whose fluid lies nearest (representative points), so
    fluid that splits off keeps its values and two parts that merge keep those of the nearer."""
    src = np.full(len(new_node), -1, dtype=np.int64)
    src[:n_nodes] = np.where(old_active[:n_nodes], np.arange(n_nodes), -1)
    multi = np.unique(np.concatenate([old_node[n_nodes:], new_node[n_nodes:]]))
    if len(multi) == 0:
        return src
    olds: dict[int, list[int]] = {int(a): [int(a)] if old_active[a] else [] for a in multi}
    news: dict[int, list[int]] = {int(a): [int(a)] for a in multi}
    for v in range(n_nodes, len(old_node)):
        if old_active[v]:
            olds[int(old_node[v])].append(v)
    for v in range(n_nodes, len(new_node)):
        news[int(new_node[v])].append(v)
    for a, vs in news.items():
        cand = np.array(olds[a], dtype=np.int64)
        for v in vs:
            if len(cand) == 0:
                src[v] = -1
            else:
                src[v] = cand[np.argmin(np.linalg.norm(old_rep[cand] - new_rep[v], axis=1))]
    return src


def carry_values(grid, old: np.ndarray, src: np.ndarray, new_node: np.ndarray, new_active: np.ndarray,
                 extend: bool) -> np.ndarray:
    """Values of one state array on the virtual nodes of a new cut (:func:`transfer_indices`):
    the source's values, then (``extend``) newly ACTIVE grid nodes from their neighbours, and a
    new set of a node without a source from the node's first set."""
    n = grid.n_nodes
    out = np.zeros((len(new_node),) + old.shape[1:])
    out[:n] = old[:n]  # nodes without a source keep their (stale) values unless extended
    has = src >= 0
    out[has] = old[src[has]]
    if extend:
        extend_to_new_nodes(grid, out[:n], has[:n], new_active[:n])
    miss = np.nonzero(~has)[0]
    miss = miss[miss >= n]
    out[miss] = out[new_node[miss]]
    return out
