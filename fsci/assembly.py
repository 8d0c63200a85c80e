"""One assembly pass: a data array on a cached pattern plus a residual vector.

Terms add into it through :meth:`Assembly.target` (the arrays every numba kernel takes) and
:meth:`Assembly.positions` (pattern offsets of a connectivity).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from fsci.fem.sparse import DofLayout, Pattern


class Assembly:
    """Matrix data and residual being assembled for one layout and pattern."""

    def __init__(self, layout: DofLayout, pattern: Pattern, want_matrix: bool) -> None:
        self.layout = layout
        self.pattern = pattern
        self.want_matrix = want_matrix
        self.data = np.zeros(pattern.nnz if want_matrix else 1)
        self.rhs = np.zeros(layout.n_dofs)

    def target(self) -> tuple:
        """``(data, rhs, row_base, row_len, start, ndof, want_matrix)`` for the kernels."""
        p = self.pattern
        return (self.data, self.rhs, p.row_base, p.row_len, self.layout.start, self.layout.ndof, self.want_matrix)

    def positions(self, conn: np.ndarray) -> np.ndarray:
        if not self.want_matrix:
            return np.zeros((len(conn), conn.shape[1], conn.shape[1]), dtype=np.int32)
        return self.pattern.positions(conn)

    def apply_dirichlet(self, dofs: np.ndarray, residual: np.ndarray) -> None:
        """Replace the rows of ``dofs`` by identity rows with residual ``x_D - x_D(prescribed)``.

        The first Newton increment then carries the prescribed change of the boundary values
        into the interior (a consistent Dirichlet predictor)."""
        if len(dofs) == 0:
            return
        self.rhs[dofs] = residual
        if self.want_matrix:
            ip = self.pattern.indptr
            lens = ip[dofs + 1] - ip[dofs]
            idx = np.repeat(ip[dofs], lens) + (np.arange(lens.sum()) - np.repeat(np.cumsum(lens) - lens, lens))
            self.data[idx] = 0.0
            self.data[self.pattern.diagonal_positions()[dofs]] = 1.0

    def matrix(self) -> sp.csr_matrix:
        return self.pattern.matrix(self.data)


class ResidualAssembly(Assembly):
    """Residual evaluation without a matrix (no pattern is built)."""

    def __init__(self, layout: DofLayout) -> None:
        self.layout = layout
        self.pattern = None
        self.want_matrix = False
        self.data = np.zeros(1)
        self.rhs = np.zeros(layout.n_dofs)

    def target(self) -> tuple:
        z = np.zeros(self.layout.n_nodes, dtype=np.int64)
        return (self.data, self.rhs, z, z, self.layout.start, self.layout.ndof, False)

    def positions(self, conn: np.ndarray) -> np.ndarray:
        return np.zeros((len(conn), conn.shape[1], conn.shape[1]), dtype=np.int32)

    def apply_dirichlet(self, dofs: np.ndarray, residual: np.ndarray) -> None:
        self.rhs[dofs] = residual
