"""The quadrilateral mesh type used for every solid body.

A :class:`QuadMesh` holds node coordinates, Q1 cells (counter-clockwise), and named node and
edge sets. Boundary edges are always oriented so that the cell lies on their left, hence the
outward normal of an edge ``(a, b)`` is ``rot(-90°)(x_b - x_a)``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from fsci.errors import MeshError

# Local edges of a Q1 cell (counter-clockwise): edge k joins local nodes k and k+1.
CELL_EDGES = np.array([[0, 1], [1, 2], [2, 3], [3, 0]], dtype=np.int64)


@dataclass
class QuadMesh:
    """Unstructured mesh of bilinear quadrilaterals.

    Parameters
    ----------
    nodes
        Node coordinates, shape ``(n_nodes, 2)``.
    cells
        Node indices of each cell, counter-clockwise, shape ``(n_cells, 4)``.
    node_sets
        Named node index arrays.
    edge_sets
        Named boundary edges, each ``(n, 2)`` with the cell on the left of ``a -> b``.
    """

    nodes: np.ndarray
    cells: np.ndarray
    node_sets: dict[str, np.ndarray] = field(default_factory=dict)
    edge_sets: dict[str, np.ndarray] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.nodes = np.ascontiguousarray(self.nodes, dtype=np.float64)
        self.cells = np.ascontiguousarray(self.cells, dtype=np.int64)
        if self.nodes.ndim != 2 or self.nodes.shape[1] != 2:
            raise MeshError(f"nodes must have shape (n, 2), got {self.nodes.shape}")
        if self.cells.ndim != 2 or self.cells.shape[1] != 4:
            raise MeshError(f"cells must have shape (m, 4), got {self.cells.shape}")
        if self.cells.size and (self.cells.min() < 0 or self.cells.max() >= len(self.nodes)):
            raise MeshError("cell connectivity refers to nodes that do not exist")
        self.node_sets = {k: np.asarray(v, dtype=np.int64) for k, v in self.node_sets.items()}
        self.edge_sets = {k: np.asarray(v, dtype=np.int64).reshape(-1, 2) for k, v in self.edge_sets.items()}

    @property
    def n_nodes(self) -> int:
        return len(self.nodes)

    @property
    def n_cells(self) -> int:
        return len(self.cells)

    # ------------------------------------------------------------------ quality
    def corner_jacobians(self) -> np.ndarray:
        """Determinant of the isoparametric map at the four corners of every cell, ``(m, 4)``."""
        x = self.nodes[self.cells]  # (m, 4, 2)
        nxt = np.roll(x, -1, axis=1) - x
        prv = np.roll(x, 1, axis=1) - x
        return nxt[..., 0] * prv[..., 1] - nxt[..., 1] * prv[..., 0]

    def check(self, name: str = "mesh") -> None:
        """Raise :class:`MeshError` naming the first inverted or degenerate cell."""
        if self.n_cells == 0:
            raise MeshError(f"{name}: mesh has no cells")
        det = self.corner_jacobians()
        area = self.cell_areas()
        scale = np.maximum(area, 1e-300)
        bad = np.where(det.min(axis=1) <= 1e-10 * scale)[0]
        if len(bad):
            c = int(bad[0])
            kind = "inverted" if det[c].min() < 0 else "degenerate"
            raise MeshError(
                f"{name}: cell {c} is {kind} (corner Jacobians {np.array2string(det[c], precision=3)}, "
                f"nodes {self.cells[c].tolist()}); cells must be convex and counter-clockwise"
            )

    def cell_areas(self) -> np.ndarray:
        """Area of each cell (shoelace formula)."""
        x = self.nodes[self.cells]
        xs, ys = x[..., 0], x[..., 1]
        return 0.5 * np.sum(xs * np.roll(ys, -1, axis=1) - np.roll(xs, -1, axis=1) * ys, axis=1)

    def oriented(self) -> "QuadMesh":
        """Copy with every clockwise cell reversed to counter-clockwise order."""
        cells = self.cells.copy()
        cw = self.cell_areas() < 0
        cells[cw] = cells[cw][:, ::-1]
        return QuadMesh(self.nodes, cells, dict(self.node_sets), dict(self.edge_sets))

    # ------------------------------------------------------------------ topology
    @cached_property
    def boundary(self) -> "BoundaryEdges":
        """All boundary edges with their parent cells (computed once)."""
        edges = self.cells[:, CELL_EDGES].reshape(-1, 2)
        key = np.sort(edges, axis=1)
        _, inverse, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
        inverse = inverse.ravel()
        once = counts[inverse] == 1
        idx = np.nonzero(once)[0]
        return BoundaryEdges(edges=edges[idx], cell=idx // 4, local=idx % 4)

    def parent_of_edges(self, edges: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Parent cell and local edge index of given boundary edges ``(n, 2)``."""
        b = self.boundary
        lookup = {(int(a), int(c)): i for i, (a, c) in enumerate(b.edges)}
        cell = np.empty(len(edges), dtype=np.int64)
        local = np.empty(len(edges), dtype=np.int64)
        for i, (a, c) in enumerate(edges):
            j = lookup.get((int(a), int(c)))
            if j is None:
                j = lookup.get((int(c), int(a)))
                if j is None:
                    raise MeshError(f"edge ({a}, {c}) is not a boundary edge of the mesh")
            cell[i] = b.cell[j]
            local[i] = b.local[j]
        return cell, local

    def boundary_loops(self) -> list[np.ndarray]:
        """Closed boundary loops as node index arrays (first node not repeated).

        Outer loops are counter-clockwise and holes clockwise, because boundary edges keep
        their cell on the left.
        """
        edges = self.boundary.edges
        nxt: dict[int, int] = {}
        for a, b in edges:
            if int(a) in nxt:
                raise MeshError(f"boundary node {a} has two outgoing boundary edges (non-manifold mesh)")
            nxt[int(a)] = int(b)
        loops = []
        seen: set[int] = set()
        for start in nxt:
            if start in seen:
                continue
            loop = [start]
            seen.add(start)
            node = nxt[start]
            while node != start:
                if node in seen or node not in nxt:
                    raise MeshError("boundary edges do not form closed loops")
                loop.append(node)
                seen.add(node)
                node = nxt[node]
            loops.append(np.array(loop, dtype=np.int64))
        return loops

    def locate(self, points: np.ndarray, tol: float = 1e-10) -> tuple[np.ndarray, np.ndarray]:
        """Find the cell and local coordinates of reference points.

        Parameters
        ----------
        points
            ``(k, 2)`` coordinates in the reference configuration.

        Returns
        -------
        cell, xi
            Cell index (``-1`` if outside the mesh) and local coordinates ``(k, 2)``.
        """
        points = np.atleast_2d(np.asarray(points, dtype=float))
        x = self.nodes[self.cells]
        lo = x.min(axis=1)
        hi = x.max(axis=1)
        size = np.max(hi - lo)
        cells = -np.ones(len(points), dtype=np.int64)
        xis = np.zeros((len(points), 2))
        for k, p in enumerate(points):
            cand = np.nonzero(np.all((p >= lo - tol * size) & (p <= hi + tol * size), axis=1))[0]
            for c in cand:
                xi = _inverse_map(x[c], p)
                if xi is not None and np.all(np.abs(xi) <= 1 + 1e-9):
                    cells[k] = c
                    xis[k] = xi
                    break
        return cells, xis


@dataclass(frozen=True)
class BoundaryEdges:
    """Boundary edges (cell on the left), their parent cell and local edge number."""

    edges: np.ndarray
    cell: np.ndarray
    local: np.ndarray


def _inverse_map(xc: np.ndarray, p: np.ndarray) -> np.ndarray | None:
    """Newton inversion of the bilinear map of one cell; ``None`` if it does not converge."""
    xi = np.zeros(2)
    for _ in range(30):
        r, s = xi
        n = 0.25 * np.array([(1 - r) * (1 - s), (1 + r) * (1 - s), (1 + r) * (1 + s), (1 - r) * (1 + s)])
        dn = 0.25 * np.array(
            [[-(1 - s), -(1 - r)], [(1 - s), -(1 + r)], [(1 + s), (1 + r)], [-(1 + s), (1 - r)]]
        )
        f = n @ xc - p
        jac = xc.T @ dn
        try:
            step = np.linalg.solve(jac, f)
        except np.linalg.LinAlgError:
            return None
        xi = xi - step
        if np.max(np.abs(step)) < 1e-14:
            return xi
        if np.max(np.abs(xi)) > 10:
            return None
    return xi
