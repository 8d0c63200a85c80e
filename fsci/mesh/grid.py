"""The fluid's rectilinear background grid.

Cells are axis-aligned rectangles ``[xs[i], xs[i+1]] × [ys[j], ys[j+1]]``. Node ``(i, j)`` has
id ``j * (nx + 1) + i``, cell ``(i, j)`` has id ``j * nx + i`` and nodes
``(i, j), (i+1, j), (i+1, j+1), (i, j+1)`` (counter-clockwise). Point location and face
enumeration are index arithmetic.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from fsci.errors import InputError

SIDES = ("left", "right", "bottom", "top")


@dataclass
class Grid:
    """Rectilinear grid with node coordinates ``xs`` (nx+1) and ``ys`` (ny+1)."""

    xs: np.ndarray
    ys: np.ndarray
    nx: int = field(init=False)
    ny: int = field(init=False)

    def __post_init__(self) -> None:
        self.xs = np.ascontiguousarray(self.xs, dtype=float)
        self.ys = np.ascontiguousarray(self.ys, dtype=float)
        for name, v in (("fluid.grid.xs", self.xs), ("fluid.grid.ys", self.ys)):
            if v.ndim != 1 or len(v) < 2 or np.any(np.diff(v) <= 0):
                raise InputError(name, f"{len(v)} values", "strictly increasing coordinates, at least 2")
        self.nx = len(self.xs) - 1
        self.ny = len(self.ys) - 1

    @property
    def n_nodes(self) -> int:
        return (self.nx + 1) * (self.ny + 1)

    @property
    def n_cells(self) -> int:
        return self.nx * self.ny

    @property
    def box(self) -> tuple[float, float, float, float]:
        return float(self.xs[0]), float(self.xs[-1]), float(self.ys[0]), float(self.ys[-1])

    @cached_property
    def nodes(self) -> np.ndarray:
        X, Y = np.meshgrid(self.xs, self.ys, indexing="xy")
        return np.column_stack([X.ravel(), Y.ravel()])

    @cached_property
    def cells(self) -> np.ndarray:
        i, j = np.meshgrid(np.arange(self.nx), np.arange(self.ny), indexing="xy")
        i, j = i.ravel(), j.ravel()
        n = self.nx + 1
        return np.column_stack([j * n + i, j * n + i + 1, (j + 1) * n + i + 1, (j + 1) * n + i]).astype(np.int64)

    @cached_property
    def cell_ij(self) -> np.ndarray:
        c = np.arange(self.n_cells)
        return np.column_stack([c % self.nx, c // self.nx])

    @cached_property
    def cell_size(self) -> np.ndarray:
        """``(n_cells, 2)`` widths ``hx, hy``."""
        ij = self.cell_ij
        return np.column_stack([np.diff(self.xs)[ij[:, 0]], np.diff(self.ys)[ij[:, 1]]])

    @cached_property
    def h_min(self) -> float:
        """Smallest cell side (the unit of the cut's geometric tolerances)."""
        return float(min(np.diff(self.xs).min(), np.diff(self.ys).min()))

    @cached_property
    def h_max(self) -> float:
        """Largest cell diagonal / sqrt(2) (the element size used by the slip-length law)."""
        return float(np.max(np.hypot(*self.cell_size.T)) / np.sqrt(2.0))

    @cached_property
    def faces(self) -> np.ndarray:
        """All interior faces ``(n_faces, 3)``: left/bottom cell, right/top cell, direction.

        Direction 0: vertical face (normal +x), 1: horizontal face (normal +y)."""
        nx, ny = self.nx, self.ny
        i, j = np.meshgrid(np.arange(1, nx), np.arange(ny), indexing="xy")
        v = np.column_stack([j.ravel() * nx + i.ravel() - 1, j.ravel() * nx + i.ravel(), np.zeros(i.size, int)])
        i, j = np.meshgrid(np.arange(nx), np.arange(1, ny), indexing="xy")
        h = np.column_stack([(j.ravel() - 1) * nx + i.ravel(), j.ravel() * nx + i.ravel(), np.ones(i.size, int)])
        return np.vstack([v, h]).astype(np.int64)

    @cached_property
    def face_nodes(self) -> np.ndarray:
        """Nodes of the two cells of each face ``(cl, cr, d)`` of :attr:`faces`, ``(n_faces, 6)``:
        the four of ``cl`` (counter-clockwise from its lower left), then the two of ``cr`` away
        from the face (d = 0: its lower and upper right; d = 1: its upper right and upper left).
        Read-only (a cut takes the rows of its faces)."""
        cells, faces = self.cells, self.faces
        right = cells[faces[:, 1]]
        far = np.where((faces[:, 2] == 0)[:, None], right[:, [1, 2]], right[:, [2, 3]])
        out = np.ascontiguousarray(np.hstack([cells[faces[:, 0]], far]).astype(np.int64))
        out.flags.writeable = False
        return out

    def side_nodes(self, side: str) -> np.ndarray:
        """Node ids on one side of the box (``left``, ``right``, ``bottom``, ``top``)."""
        n = self.nx + 1
        if side == "left":
            return np.arange(self.ny + 1) * n
        if side == "right":
            return np.arange(self.ny + 1) * n + self.nx
        if side == "bottom":
            return np.arange(n)
        if side == "top":
            return self.ny * n + np.arange(n)
        raise InputError("boundary", side, "one of " + ", ".join(SIDES))

    def side_edges(self, side: str) -> np.ndarray:
        """Boundary edges of a side ``(k, 2)`` (node ids, increasing coordinate; read-only)."""
        if side not in self._side_edges:
            self.side_nodes(side)  # raises, naming the sides there are
        return self._side_edges[side]

    @cached_property
    def _side_edges(self) -> dict[str, np.ndarray]:
        """:meth:`side_edges` of every side, made once (they are asked for at every step)."""
        out = {}
        for side in SIDES:
            nd = self.side_nodes(side)
            out[side] = np.column_stack([nd[:-1], nd[1:]])
            out[side].flags.writeable = False
        return out

    def side_normal(self, side: str) -> np.ndarray:
        return {"left": np.array([-1.0, 0.0]), "right": np.array([1.0, 0.0]),
                "bottom": np.array([0.0, -1.0]), "top": np.array([0.0, 1.0])}[side]

    def locate(self, points: np.ndarray) -> np.ndarray:
        """Cell id containing each point ``(k, 2)`` (clipped to the grid)."""
        p = np.atleast_2d(points)
        # (minimum / maximum: half the time of np.clip on the few points of most calls)
        i = np.minimum(np.maximum(np.searchsorted(self.xs, p[:, 0], side="right") - 1, 0), self.nx - 1)
        j = np.minimum(np.maximum(np.searchsorted(self.ys, p[:, 1], side="right") - 1, 0), self.ny - 1)
        return j * self.nx + i
