"""Error norms against exact solutions (used by the convergence tests and examples).

Quadrature for the error integrals is independent of the one used to assemble: tensor Gauss
of order ``n`` on uncut cells, and the caller's polygon rule on cut cells.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from fsci.fem.q1 import q1_eval
from fsci.fem.quadrature import gauss_quad

Field = Callable[[np.ndarray, np.ndarray], np.ndarray]


def grid_cell_quadrature(grid, cells: np.ndarray, n: int = 4) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Tensor Gauss rule on background cells: points ``(k, 2)``, weights, cell of each point."""
    xi, w = gauss_quad(n)
    size = grid.cell_size[cells]
    x0 = np.column_stack([grid.xs[grid.cell_ij[cells, 0]], grid.ys[grid.cell_ij[cells, 1]]])
    pts = x0[:, None, :] + 0.5 * (xi[None] + 1.0) * size[:, None, :]
    wts = w[None, :] * (0.25 * size[:, 0] * size[:, 1])[:, None]
    return pts.reshape(-1, 2), wts.ravel(), np.repeat(cells, len(w))


def fluid_values(fluid, points: np.ndarray, cells: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Discrete velocity ``(k, 2)``, velocity gradient ``(k, 2, 2)`` and pressure at points in
    given background cells."""
    g = fluid.grid
    x0 = np.column_stack([g.xs[g.cell_ij[cells, 0]], g.ys[g.cell_ij[cells, 1]]])
    h = g.cell_size[cells]
    N, dN = q1_eval(2.0 * (points - x0) / h - 1.0)
    dNx = dN * (2.0 / h)[:, None, :]
    nodes = fluid.cut.conn_at(cells, points) if fluid.cut is not None else g.cells[cells]
    V = fluid.V[nodes]
    v = np.einsum("ka,kai->ki", N, V)
    gv = np.einsum("kai,kaj->kij", V, dNx)
    p = np.einsum("ka,ka->k", N, fluid.P[nodes])
    return v, gv, p


def fluid_errors(fluid, v_exact: Field, gradv_exact: Field, p_exact: Field,
                 quadrature: tuple[np.ndarray, np.ndarray, np.ndarray], zero_mean_pressure: bool = True) -> dict[str, float]:
    """L2 and H1-seminorm velocity errors and L2 pressure error (pressure means removed)."""
    x, w, cells = quadrature
    v, gv, p = fluid_values(fluid, x, cells)
    ve = v_exact(x[:, 0], x[:, 1])
    ge = gradv_exact(x[:, 0], x[:, 1])
    pe = p_exact(x[:, 0], x[:, 1])
    if zero_mean_pressure:
        area = w.sum()
        p = p - np.dot(w, p) / area
        pe = pe - np.dot(w, pe) / area
    return {
        "v_l2": float(np.sqrt(np.dot(w, np.sum((v - ve) ** 2, axis=1)))),
        "v_h1": float(np.sqrt(np.dot(w, np.sum((gv - ge) ** 2, axis=(1, 2))))),
        "p_l2": float(np.sqrt(np.dot(w, (p - pe) ** 2))),
    }


def solid_errors(solid, u_exact: Field, gradu_exact: Field, n: int = 4) -> dict[str, float]:
    """L2 and H1-seminorm displacement errors of a body (reference configuration)."""
    xi, wq = gauss_quad(n)
    N, dN = q1_eval(xi)
    Xc = solid.X[solid.mesh.cells]  # (m, 4, 2)
    Uc = solid.U[solid.mesh.cells]
    J = np.einsum("ead,qak->eqdk", Xc, dN)  # J[d, k] = dX_d/dxi_k
    det = J[..., 0, 0] * J[..., 1, 1] - J[..., 0, 1] * J[..., 1, 0]
    inv = np.stack([np.stack([J[..., 1, 1], -J[..., 0, 1]], -1), np.stack([-J[..., 1, 0], J[..., 0, 0]], -1)], -2) / det[..., None, None]
    dNx = np.einsum("qak,eqkf->eqaf", dN, inv)
    X = np.einsum("qa,ead->eqd", N, Xc)
    u = np.einsum("qa,ead->eqd", N, Uc)
    gu = np.einsum("ead,eqaf->eqdf", Uc, dNx)
    w = det * wq[None, :]
    Xf = X.reshape(-1, 2)
    ue = u_exact(Xf[:, 0], Xf[:, 1]).reshape(u.shape)
    ge = gradu_exact(Xf[:, 0], Xf[:, 1]).reshape(gu.shape)
    return {
        "u_l2": float(np.sqrt(np.sum(w * np.sum((u - ue) ** 2, axis=-1)))),
        "u_h1": float(np.sqrt(np.sum(w * np.sum((gu - ge) ** 2, axis=(-1, -2))))),
    }
