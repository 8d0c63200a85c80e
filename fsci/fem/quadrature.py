"""Gauss rules on segments, quadrilaterals and triangles.

Triangle rules are collapsed (Duffy) products of Gauss-Legendre and Gauss-Jacobi(1, 0) rules:
``n × n`` points integrate polynomials of total degree ``2n - 1`` exactly. They are generated,
not tabulated, so every degree is available and the exactness is checked in the tests.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from scipy.special import roots_jacobi, roots_legendre


@lru_cache(maxsize=None)
def gauss_line(n: int) -> tuple[np.ndarray, np.ndarray]:
    """``n``-point Gauss-Legendre rule on [-1, 1] (exact for degree ``2n - 1``)."""
    x, w = roots_legendre(n)
    return np.ascontiguousarray(x), np.ascontiguousarray(w)


@lru_cache(maxsize=None)
def gauss_quad(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Tensor Gauss rule on [-1, 1]², points ``(n², 2)`` and weights ``(n²,)``."""
    x, w = gauss_line(n)
    X, Y = np.meshgrid(x, x, indexing="ij")
    W = np.outer(w, w)
    return np.column_stack([X.ravel(), Y.ravel()]), W.ravel()


@lru_cache(maxsize=None)
def gauss_triangle(degree: int) -> tuple[np.ndarray, np.ndarray]:
    """Rule on the reference triangle (0,0), (1,0), (0,1), exact for total degree ``degree``.

    Returns points ``(k, 2)`` and weights summing to ½.
    """
    n = max(1, (degree + 2) // 2)
    # Duffy map: x = (1 + a)/2 * (1 - y), y = (1 + b)/2 ; Jacobian (1 - y)/4 * ... absorbed by Jacobi weight
    a, wa = roots_legendre(n)
    b, wb = roots_jacobi(n, 1.0, 0.0)  # weight (1 - b)
    pts, wts = [], []
    for bj, wbj in zip(b, wb):
        y = 0.5 * (1.0 + bj)
        for ai, wai in zip(a, wa):
            x = 0.5 * (1.0 + ai) * (1.0 - y)
            pts.append((x, y))
            wts.append(wai * wbj / 8.0)
    return np.array(pts), np.array(wts)


def triangle_rule(vertices: np.ndarray, degree: int) -> tuple[np.ndarray, np.ndarray]:
    """Map the reference rule onto triangles.

    Parameters
    ----------
    vertices
        ``(t, 3, 2)`` triangle vertices (any orientation).
    degree
        Polynomial degree integrated exactly.

    Returns
    -------
    points, weights
        ``(t * k, 2)`` and ``(t * k,)``; weights are positive (absolute area).
    """
    ref, w = gauss_triangle(degree)
    v0 = vertices[:, 0, :]
    e1 = vertices[:, 1, :] - v0
    e2 = vertices[:, 2, :] - v0
    det = np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])
    pts = v0[:, None, :] + ref[None, :, 0, None] * e1[:, None, :] + ref[None, :, 1, None] * e2[:, None, :]
    wts = det[:, None] * w[None, :]
    return pts.reshape(-1, 2), wts.ravel()
