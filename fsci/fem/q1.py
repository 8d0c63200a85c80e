"""Bilinear (Q1) shape functions on the reference square [-1, 1]², node order counter-clockwise
starting at (-1, -1). Compiled helpers used by every element kernel."""

from __future__ import annotations

import numpy as np
from numba import njit

@njit(cache=True, inline="always")
def q1_shape(r, s, N, dN):
    """Fill ``N[4]`` and reference derivatives ``dN[4, 2]`` at ``(r, s)`` (real or complex)."""
    N[0] = 0.25 * (1 - r) * (1 - s)
    N[1] = 0.25 * (1 + r) * (1 - s)
    N[2] = 0.25 * (1 + r) * (1 + s)
    N[3] = 0.25 * (1 - r) * (1 + s)
    dN[0, 0] = -0.25 * (1 - s)
    dN[0, 1] = -0.25 * (1 - r)
    dN[1, 0] = 0.25 * (1 - s)
    dN[1, 1] = -0.25 * (1 + r)
    dN[2, 0] = 0.25 * (1 + s)
    dN[2, 1] = 0.25 * (1 + r)
    dN[3, 0] = -0.25 * (1 + s)
    dN[3, 1] = 0.25 * (1 - r)


@njit(cache=True, inline="always")
def q1_physical_gradients(xe, dN, dNx):
    """Physical gradients ``dNx[4, 2]`` for cell coordinates ``xe[4, 2]``; returns det J.
    Works for real and complex ``xe``/``dN`` (complex-step kernels)."""
    zero = 0.0 * xe[0, 0] * dN[0, 0]
    j00 = zero
    j01 = zero
    j10 = zero
    j11 = zero
    for a in range(4):
        j00 += xe[a, 0] * dN[a, 0]
        j01 += xe[a, 0] * dN[a, 1]
        j10 += xe[a, 1] * dN[a, 0]
        j11 += xe[a, 1] * dN[a, 1]
    det = j00 * j11 - j01 * j10
    for a in range(4):
        dNx[a, 0] = (j11 * dN[a, 0] - j10 * dN[a, 1]) / det
        dNx[a, 1] = (-j01 * dN[a, 0] + j00 * dN[a, 1]) / det
    return det


def q1_values(xi: np.ndarray) -> np.ndarray:
    """Vectorised shape functions at reference points ``(k, 2)``: ``N (k, 4)``."""
    r, s = xi[:, 0], xi[:, 1]
    return 0.25 * np.column_stack([(1 - r) * (1 - s), (1 + r) * (1 - s), (1 + r) * (1 + s), (1 - r) * (1 + s)])


def q1_eval(xi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Vectorised shape functions at reference points ``(k, 2)``: ``N (k, 4)``, ``dN (k, 4, 2)``."""
    r, s = xi[:, 0], xi[:, 1]
    N = q1_values(xi)
    dN = 0.25 * np.stack(
        [
            np.column_stack([-(1 - s), -(1 - r)]),
            np.column_stack([(1 - s), -(1 + r)]),
            np.column_stack([(1 + s), (1 + r)]),
            np.column_stack([-(1 + s), (1 - r)]),
        ],
        axis=1,
    )
    return N, dN
