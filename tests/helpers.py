"""Shared helpers for tests: Jacobian checks by central finite differences."""

from __future__ import annotations

import numpy as np

from fsci.fields import StepContext


def residual(system, ctx: StepContext, x: np.ndarray) -> np.ndarray:
    system.scatter(x)
    return system.assemble(ctx, want_matrix=False, dirichlet=False).rhs.copy()


def jacobian_fd_error(system, ctx: StepContext, x0: np.ndarray, h: float = 1e-6, dofs=None, rows=None) -> float:
    """Max over columns of ||J_analytic e_j - (R(x+h e_j) - R(x-h e_j))/2h|| / ||J||_max-col."""
    system.scatter(x0)
    J = system.assemble(ctx, want_matrix=True, dirichlet=False).matrix().toarray()
    cols = range(len(x0)) if dofs is None else dofs
    scale = np.max(np.abs(J))
    worst = 0.0
    for j in cols:
        xp = x0.copy()
        xp[j] += h
        xm = x0.copy()
        xm[j] -= h
        fd = (residual(system, ctx, xp) - residual(system, ctx, xm)) / (2 * h)
        diff = fd - J[:, j]
        if rows is not None:
            diff = diff[rows]
        worst = max(worst, float(np.max(np.abs(diff))) / scale)
    system.scatter(x0)
    return worst
