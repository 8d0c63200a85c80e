"""Total-Lagrangian solid kernels (paper Sec. 2.1, weak form (21)).

Residual per body (one-step-theta, see :mod:`fsci.timeint`)::

    R(d) = m_c M (d - d_pred) + w_int * F_int(d) - F_body - F_Neumann(d) + r_old

with ``F_int = ∫ B^T S dV0`` (``B`` the nonlinear strain-displacement operator),
``m_c = 1/(theta dt^2)`` and ``d_pred = d_n + dt v_n`` (so that ``m_c M (d - d_pred)`` equals
``M (v_{n+1} - v_n)/dt``), and ``r_old`` the explicit (1 - theta) part. Quasi-static problems
use ``m_c = 0``.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from fsci.fem.q1 import q1_physical_gradients, q1_shape
from fsci.fem.sparse import add_local
from fsci.physics.materials import stress_tangent


@njit(cache=True)
def assemble_solid(X, cells, U, law, prm, rho, mass_coef, Upred, w_int, bq, qxi, qw,
                   gnode, pos, data, rhs, row_base, row_len, start, ndof, want_matrix):
    """Add internal forces, inertia and body force of all cells of one body.

    Parameters are arrays in the body's local node numbering; ``gnode`` maps them to global
    nodes of the dof layout and ``pos`` holds the pattern offsets of each cell's node pairs.
    ``bq[e * nq + q]`` is the body force per unit mass at quadrature point ``q`` of cell ``e``.
    """
    N = np.empty(4)
    dN = np.empty((4, 2))
    dNx = np.empty((4, 2))
    xe = np.empty((4, 2))
    ue = np.empty((4, 2))
    F = np.empty((2, 2))
    C = np.empty((2, 2))
    S = np.empty((2, 2))
    D = np.zeros((3, 3))
    B = np.empty((3, 8))
    Ke = np.empty((8, 8))
    Re = np.empty(8)
    nodes = np.empty(4, dtype=np.int64)
    for e in range(cells.shape[0]):
        for a in range(4):
            n = cells[e, a]
            nodes[a] = gnode[n]
            for i in range(2):
                xe[a, i] = X[n, i]
                ue[a, i] = U[n, i]
        Ke[:] = 0.0
        Re[:] = 0.0
        for q in range(len(qw)):
            q1_shape(qxi[q, 0], qxi[q, 1], N, dN)
            det = q1_physical_gradients(xe, dN, dNx)
            w = qw[q] * det
            for i in range(2):
                for j in range(2):
                    F[i, j] = (1.0 if i == j else 0.0)
                    for a in range(4):
                        F[i, j] += ue[a, i] * dNx[a, j]
            for i in range(2):
                for j in range(2):
                    C[i, j] = F[0, i] * F[0, j] + F[1, i] * F[1, j]
            stress_tangent(law, prm, C, S, D, want_matrix)
            for a in range(4):
                for i in range(2):
                    B[0, 2 * a + i] = F[i, 0] * dNx[a, 0]
                    B[1, 2 * a + i] = F[i, 1] * dNx[a, 1]
                    B[2, 2 * a + i] = F[i, 0] * dNx[a, 1] + F[i, 1] * dNx[a, 0]
            sv0 = S[0, 0]
            sv1 = S[1, 1]
            sv2 = S[0, 1]
            for k in range(8):
                Re[k] += w_int * w * (B[0, k] * sv0 + B[1, k] * sv1 + B[2, k] * sv2)
            for a in range(4):
                for i in range(2):
                    Re[2 * a + i] -= w * rho * N[a] * bq[e * len(qw) + q, i]
            if mass_coef != 0.0:
                for a in range(4):
                    for b in range(4):
                        m = mass_coef * rho * w * N[a] * N[b]
                        for i in range(2):
                            Re[2 * a + i] += m * (ue[b, i] - Upred[cells[e, b], i])
                        if want_matrix:
                            Ke[2 * a, 2 * b] += m
                            Ke[2 * a + 1, 2 * b + 1] += m
            if want_matrix:
                for k in range(8):
                    db0 = D[0, 0] * B[0, k] + D[0, 1] * B[1, k] + D[0, 2] * B[2, k]
                    db1 = D[1, 0] * B[0, k] + D[1, 1] * B[1, k] + D[1, 2] * B[2, k]
                    db2 = D[2, 0] * B[0, k] + D[2, 1] * B[1, k] + D[2, 2] * B[2, k]
                    for l in range(8):
                        Ke[l, k] += w_int * w * (B[0, l] * db0 + B[1, l] * db1 + B[2, l] * db2)
                for a in range(4):
                    for b in range(4):
                        g = 0.0
                        for I in range(2):
                            for J in range(2):
                                g += dNx[a, I] * S[I, J] * dNx[b, J]
                        g *= w_int * w
                        Ke[2 * a, 2 * b] += g
                        Ke[2 * a + 1, 2 * b + 1] += g
        add_local(data, rhs, row_base, row_len, start, ndof, nodes, pos[e], Ke, Re, want_matrix)


@njit(cache=True)
def assemble_edge_loads(X, U, edges, traction0, pressure, gnode, pos, data, rhs, row_base, row_len,
                        start, ndof, want_matrix):
    """Neumann loads on boundary edges ``(k, 2)`` (cell on the left, so outward normal is right).

    ``traction0[k]`` (2,) is a dead load per reference length; ``pressure[k]`` a follower
    pressure acting against the current outward normal: ``t = -pressure * n``. Both enter the
    residual with a minus sign (external forces)."""
    Ke = np.zeros((4, 4))
    Re = np.empty(4)
    nodes = np.empty(2, dtype=np.int64)
    for k in range(edges.shape[0]):
        a = edges[k, 0]
        b = edges[k, 1]
        nodes[0] = gnode[a]
        nodes[1] = gnode[b]
        L0 = np.sqrt((X[b, 0] - X[a, 0]) ** 2 + (X[b, 1] - X[a, 1]) ** 2)
        dx = X[b, 0] + U[b, 0] - X[a, 0] - U[a, 0]
        dy = X[b, 1] + U[b, 1] - X[a, 1] - U[a, 1]
        # ∫ N_a n ds = 0.5 * (dy, -dx) for each end node of a straight edge
        for m in range(2):
            Re[2 * m] = -0.5 * L0 * traction0[k, 0] + 0.5 * pressure[k] * dy
            Re[2 * m + 1] = -0.5 * L0 * traction0[k, 1] - 0.5 * pressure[k] * dx
        if want_matrix:
            hp = 0.5 * pressure[k]
            for m in range(2):
                # d(dy)/d u_b,y = +1, d(dy)/d u_a,y = -1 ; d(dx)/d u_b,x = +1, d(dx)/d u_a,x = -1
                Ke[2 * m, 1] = -hp
                Ke[2 * m, 3] = hp
                Ke[2 * m + 1, 0] = hp
                Ke[2 * m + 1, 2] = -hp
        add_local(data, rhs, row_base, row_len, start, ndof, nodes, pos[k], Ke, Re, want_matrix)


@njit(cache=True)
def cell_cauchy_stress(X, cells, U, law, prm, out):
    """Cauchy stress at the cell centre, ``out (m, 3)`` = (sxx, syy, sxy)."""
    N = np.empty(4)
    dN = np.empty((4, 2))
    dNx = np.empty((4, 2))
    xe = np.empty((4, 2))
    F = np.empty((2, 2))
    C = np.empty((2, 2))
    S = np.empty((2, 2))
    D = np.zeros((3, 3))
    for e in range(cells.shape[0]):
        for a in range(4):
            for i in range(2):
                xe[a, i] = X[cells[e, a], i]
        q1_shape(0.0, 0.0, N, dN)
        q1_physical_gradients(xe, dN, dNx)
        for i in range(2):
            for j in range(2):
                F[i, j] = 1.0 if i == j else 0.0
                for a in range(4):
                    F[i, j] += U[cells[e, a], i] * dNx[a, j]
        for i in range(2):
            for j in range(2):
                C[i, j] = F[0, i] * F[0, j] + F[1, i] * F[1, j]
        stress_tangent(law, prm, C, S, D, False)
        J = F[0, 0] * F[1, 1] - F[0, 1] * F[1, 0]
        P = np.empty((2, 2))
        for i in range(2):
            for j in range(2):
                P[i, j] = F[i, 0] * S[0, j] + F[i, 1] * S[1, j]
        out[e, 0] = (P[0, 0] * F[0, 0] + P[0, 1] * F[0, 1]) / J
        out[e, 1] = (P[1, 0] * F[1, 0] + P[1, 1] * F[1, 1]) / J
        out[e, 2] = (P[0, 0] * F[1, 0] + P[0, 1] * F[1, 1]) / J
