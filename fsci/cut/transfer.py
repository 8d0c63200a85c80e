"""Solution-space update (paper Sec. 3.4.3): values for newly ACTIVE background nodes.

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
