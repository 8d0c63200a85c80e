"""Structured quadrilateral mesh generators.

* :func:`rectangle` – uniform structured mesh of an axis-aligned rectangle;
* :func:`rectilinear` – tensor-product mesh from given x and y coordinates (grading);
* :func:`graded` – 1D coordinates with geometric grading;
* :func:`mapped` – transfinite (Coons) map of the unit square onto a region bounded by four
  curves, e.g. the Turek-Hron bar clamped on the cylinder arc.

Every generator names the four sides ``bottom``, ``right``, ``top``, ``left`` as node sets
and edge sets (edges oriented with the cell on the left), plus ``all`` for the whole boundary.
"""

from __future__ import annotations

from typing import Callable, Sequence

import numpy as np

from fsci.errors import InputError
from fsci.mesh.quadmesh import QuadMesh

Curve = Callable[[np.ndarray], np.ndarray]


def graded(a: float, b: float, n: int, ratio: float = 1.0) -> np.ndarray:
    """``n + 1`` coordinates from ``a`` to ``b`` whose last/first cell size ratio is ``ratio``.

    ``ratio > 1`` makes cells grow towards ``b``; ``ratio = 1`` is uniform.
    """
    if n < 1:
        raise InputError("n", n, "at least one cell")
    if ratio <= 0:
        raise InputError("ratio", ratio, "a positive grading ratio")
    if abs(ratio - 1.0) < 1e-14 or n == 1:
        return np.linspace(a, b, n + 1)
    q = ratio ** (1.0 / (n - 1))
    w = q ** np.arange(n)
    s = np.concatenate([[0.0], np.cumsum(w)]) / np.sum(w)
    x = a + (b - a) * s
    x[-1] = b
    return x


def _grid_mesh(x: np.ndarray, y: np.ndarray) -> QuadMesh:
    """Tensor-product mesh on node coordinates ``x[i, j], y[i, j]`` of shape (nx+1, ny+1)."""
    nxp, nyp = x.shape
    nx, ny = nxp - 1, nyp - 1
    nodes = np.column_stack([x.T.ravel(), y.T.ravel()])  # node id = j * (nx+1) + i

    def nid(i, j):
        return j * nxp + i

    ii, jj = np.meshgrid(np.arange(nx), np.arange(ny), indexing="xy")
    ii, jj = ii.ravel(), jj.ravel()
    cells = np.column_stack([nid(ii, jj), nid(ii + 1, jj), nid(ii + 1, jj + 1), nid(ii, jj + 1)])
    i_all, j_all = np.arange(nxp), np.arange(nyp)
    bottom = nid(i_all, 0)
    top = nid(i_all[::-1], ny)
    right = nid(nx, j_all)
    left = nid(0, j_all[::-1])
    node_sets = {"bottom": np.sort(bottom), "top": np.sort(top), "left": np.sort(left), "right": np.sort(right)}
    edge_sets = {
        "bottom": np.column_stack([bottom[:-1], bottom[1:]]),
        "right": np.column_stack([right[:-1], right[1:]]),
        "top": np.column_stack([top[:-1], top[1:]]),
        "left": np.column_stack([left[:-1], left[1:]]),
    }
    edge_sets["all"] = np.vstack([edge_sets[k] for k in ("bottom", "right", "top", "left")])
    node_sets["all"] = np.unique(edge_sets["all"])
    node_sets.update({"bottom_left": np.array([nid(0, 0)]), "bottom_right": np.array([nid(nx, 0)]),
                      "top_right": np.array([nid(nx, ny)]), "top_left": np.array([nid(0, ny)])})
    return QuadMesh(nodes, cells, node_sets, edge_sets)


def rectilinear(xs: Sequence[float], ys: Sequence[float]) -> QuadMesh:
    """Tensor-product mesh with node coordinates ``xs`` × ``ys`` (strictly increasing)."""
    xs = np.asarray(xs, dtype=float)
    ys = np.asarray(ys, dtype=float)
    for name, v in (("xs", xs), ("ys", ys)):
        if v.ndim != 1 or len(v) < 2 or np.any(np.diff(v) <= 0):
            raise InputError(name, v.tolist() if v.size < 10 else f"array of {v.size}", "strictly increasing, ≥ 2 values")
    x, y = np.meshgrid(xs, ys, indexing="ij")
    return _grid_mesh(x, y)


def rectangle(x0: float, x1: float, y0: float, y1: float, nx: int, ny: int) -> QuadMesh:
    """Uniform ``nx`` × ``ny`` mesh of ``[x0, x1] × [y0, y1]``."""
    for name, n in (("nx", nx), ("ny", ny)):
        if not isinstance(n, (int, np.integer)) or n < 1:
            raise InputError(name, n, "a positive integer number of cells")
    if x1 <= x0 or y1 <= y0:
        raise InputError("extent", (x0, x1, y0, y1), "x1 > x0 and y1 > y0")
    return rectilinear(np.linspace(x0, x1, nx + 1), np.linspace(y0, y1, ny + 1))


def mapped(
    bottom: Curve,
    right: Curve,
    top: Curve,
    left: Curve,
    nx: int,
    ny: int,
    sx: np.ndarray | None = None,
    sy: np.ndarray | None = None,
) -> QuadMesh:
    """Transfinite (Coons patch) mesh of a region bounded by four curves.

    Each curve maps a parameter in [0, 1] to points ``(k, 2)``: ``bottom`` and ``top`` run in
    +x-like direction (left to right), ``left`` and ``right`` from bottom to top. Corners must
    match. ``sx``/``sy`` optionally give the parameter values (grading) of the ``nx + 1`` /
    ``ny + 1`` node lines.
    """
    s = np.linspace(0, 1, nx + 1) if sx is None else np.asarray(sx, float)
    t = np.linspace(0, 1, ny + 1) if sy is None else np.asarray(sy, float)
    B, T = bottom(s), top(s)
    L, R = left(t), right(t)
    c00, c10, c11, c01 = B[0], B[-1], T[-1], T[0]
    for a, b, name in ((L[0], c00, "left/bottom"), (R[0], c10, "right/bottom"), (R[-1], c11, "right/top"), (L[-1], c01, "left/top")):
        if np.linalg.norm(a - b) > 1e-9 * (1 + np.linalg.norm(b)):
            raise InputError("mapped.corners", name, "boundary curves must meet at the corners")
    S, Tt = np.meshgrid(s, t, indexing="ij")
    X = np.empty(S.shape + (2,))
    for d in range(2):
        X[..., d] = (
            (1 - Tt) * B[:, None, d] + Tt * T[:, None, d] + (1 - S) * L[None, :, d] + S * R[None, :, d]
            - ((1 - S) * (1 - Tt) * c00[d] + S * (1 - Tt) * c10[d] + S * Tt * c11[d] + (1 - S) * Tt * c01[d])
        )
    return _grid_mesh(X[..., 0], X[..., 1])
