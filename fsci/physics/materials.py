"""Hyperelastic laws in plane strain (paper Sec. 2.1, (43)).

Both laws return the in-plane second Piola-Kirchhoff stress ``S`` (2×2) and the material
tangent in Voigt form ``D`` (3×3, order 11, 22, 12 with engineering shear) from the in-plane
right Cauchy-Green tensor ``C`` (C33 = 1, plane strain).

* ``NEO_HOOKE``: paper (43), ``psi = c (tr C - 3) + (c/beta) (J^(-2 beta) - 1)``,
  ``c = E / (4 (1 + nu))``, ``beta = nu / (1 - 2 nu)``. The stress
  ``S = 2c (I - J^(-2beta) C^-1)`` and its tangent are regular at ``beta = 0`` and coincide
  there with the nu = 0 limit ``psi = c (tr C - 3) - 2c ln J``: no special case is needed.
* ``SVK``: St. Venant-Kirchhoff, ``S = lambda tr(E) I + 2 mu E`` (Turek-Hron benchmarks).

The functions are written so that numba compiles them for real and complex arguments (the
contact kernels differentiate by complex step).
"""

from __future__ import annotations

import numpy as np
from numba import njit

NEO_HOOKE = 0
SVK = 1
LAW_NAMES = {"neo_hooke": NEO_HOOKE, "svk": SVK}


def material_parameters(law: int, E: float, nu: float) -> np.ndarray:
    """Pack the constants a kernel needs: ``[c, beta]`` (Neo-Hooke) or ``[lambda, mu]`` (SVK)."""
    if law == NEO_HOOKE:
        return np.array([E / (4.0 * (1.0 + nu)), nu / (1.0 - 2.0 * nu)])
    lam = E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu))
    mu = E / (2.0 * (1.0 + nu))
    return np.array([lam, mu])


@njit(cache=True)
def stress_tangent(law, prm, C, S, D, want_tangent):
    """Fill ``S[2, 2]`` and (optionally) ``D[3, 3]`` for right Cauchy-Green ``C[2, 2]``."""
    if law == NEO_HOOKE:
        c = prm[0]
        beta = prm[1]
        detC = C[0, 0] * C[1, 1] - C[0, 1] * C[1, 0]
        i00 = C[1, 1] / detC
        i11 = C[0, 0] / detC
        i01 = -C[0, 1] / detC
        jb = detC ** (-beta)  # J^(-2 beta) with J = sqrt(det C)
        S[0, 0] = 2.0 * c * (1.0 - jb * i00)
        S[1, 1] = 2.0 * c * (1.0 - jb * i11)
        S[0, 1] = -2.0 * c * jb * i01
        S[1, 0] = S[0, 1]
        if want_tangent:
            # C_IJKL = 4c J^-2b [ b Ci_IJ Ci_KL + 1/2 (Ci_IK Ci_JL + Ci_IL Ci_JK) ]
            f = 4.0 * c * jb
            D[0, 0] = f * (beta * i00 * i00 + i00 * i00)
            D[1, 1] = f * (beta * i11 * i11 + i11 * i11)
            D[0, 1] = f * (beta * i00 * i11 + i01 * i01)
            D[0, 2] = f * (beta * i00 * i01 + i00 * i01)
            D[1, 2] = f * (beta * i11 * i01 + i01 * i11)
            D[2, 2] = f * (beta * i01 * i01 + 0.5 * (i00 * i11 + i01 * i01))
            D[1, 0] = D[0, 1]
            D[2, 0] = D[0, 2]
            D[2, 1] = D[1, 2]
    else:
        lam = prm[0]
        mu = prm[1]
        e00 = 0.5 * (C[0, 0] - 1.0)
        e11 = 0.5 * (C[1, 1] - 1.0)
        e01 = 0.5 * C[0, 1]
        tr = e00 + e11
        S[0, 0] = lam * tr + 2.0 * mu * e00
        S[1, 1] = lam * tr + 2.0 * mu * e11
        S[0, 1] = 2.0 * mu * e01
        S[1, 0] = S[0, 1]
        if want_tangent:
            D[0, 0] = lam + 2.0 * mu
            D[1, 1] = lam + 2.0 * mu
            D[0, 1] = lam
            D[1, 0] = lam
            D[2, 2] = mu
            D[0, 2] = 0.0
            D[1, 2] = 0.0
            D[2, 0] = 0.0
            D[2, 1] = 0.0


def strain_energy(law: int, prm: np.ndarray, C: np.ndarray) -> np.ndarray:
    """Strain energy density (reference volume) for in-plane ``C`` of shape ``(..., 2, 2)``
    (one 2×2 tensor or many): the ``psi`` of the module docstring."""
    detC = C[..., 0, 0] * C[..., 1, 1] - C[..., 0, 1] * C[..., 1, 0]
    if law == NEO_HOOKE:
        c, beta = prm
        trC = C[..., 0, 0] + C[..., 1, 1] + 1.0
        if beta == 0.0:
            return c * (trC - 3.0) - c * np.log(detC)
        return c * (trC - 3.0) + c / beta * (detC ** (-beta) - 1.0)
    lam, mu = prm
    E = 0.5 * (C - np.eye(2))
    return 0.5 * lam * (E[..., 0, 0] + E[..., 1, 1]) ** 2 + mu * np.sum(E * E, axis=(-1, -2))


@njit(cache=True)
def cauchy_stress(law, prm, F, sigma):
    """Cauchy stress ``sigma = J^-1 F S F^T`` (in-plane 2×2) for deformation gradient ``F``."""
    C = np.empty((2, 2), dtype=F.dtype)
    S = np.empty((2, 2), dtype=F.dtype)
    D = np.empty((3, 3), dtype=F.dtype)
    for i in range(2):
        for j in range(2):
            C[i, j] = F[0, i] * F[0, j] + F[1, i] * F[1, j]
    stress_tangent(law, prm, C, S, D, False)
    J = F[0, 0] * F[1, 1] - F[0, 1] * F[1, 0]
    for i in range(2):
        for j in range(2):
            s = 0.0 * J
            for k in range(2):
                for l in range(2):
                    s += F[i, k] * S[k, l] * F[j, l]
            sigma[i, j] = s / J
