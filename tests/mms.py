"""Manufactured solutions: exact fields and their forcing, generated with sympy.

The forcing is returned as expression strings in x, y that :class:`fsci.expressions.Expression`
accepts, so manufactured problems are ordinary case dictionaries.
"""

from __future__ import annotations

import numpy as np
import sympy as sp

x, y = sp.symbols("x y", real=True)


def to_str(e: sp.Expr) -> str:
    return sp.sstr(sp.simplify(e) if sp.count_ops(e) < 200 else e, full_prec=True)


def lambdify(e):
    f = sp.lambdify((x, y), e, "numpy")
    return lambda X, Y: np.broadcast_to(f(X, Y), np.broadcast(X, Y).shape) * 1.0


def solid_neo_hooke(u: tuple[sp.Expr, sp.Expr], E: float, nu: float, law: str = "neo_hooke"):
    """Body force per unit mass (rho0 = 1) making ``u`` an equilibrium of the plane-strain law."""
    F = sp.Matrix([[1 + sp.diff(u[0], x), sp.diff(u[0], y)], [sp.diff(u[1], x), 1 + sp.diff(u[1], y)]])
    C = F.T * F
    I2 = sp.eye(2)
    if law == "neo_hooke":
        c = sp.Rational(E) / (4 * (1 + sp.Rational(nu))) if isinstance(E, int) else E / (4 * (1 + nu))
        beta = nu / (1 - 2 * nu)
        detC = C[0, 0] * C[1, 1] - C[0, 1] * C[1, 0]
        adj = sp.Matrix([[C[1, 1], -C[0, 1]], [-C[1, 0], C[0, 0]]])
        S = 2 * c * (I2 - detC ** (-beta - 1) * adj)
    else:
        lam = E * nu / ((1 + nu) * (1 - 2 * nu))
        mu = E / (2 * (1 + nu))
        Eg = (C - I2) / 2
        S = lam * Eg.trace() * I2 + 2 * mu * Eg
    P = F * S
    b = [-(sp.diff(P[i, 0], x) + sp.diff(P[i, 1], y)) for i in range(2)]
    grad = [[sp.diff(u[i], v) for v in (x, y)] for i in range(2)]
    u_f = [lambdify(ui) for ui in u]
    g_f = [[lambdify(grad[i][j]) for j in range(2)] for i in range(2)]
    return {
        "u_str": [sp.sstr(ui) for ui in u],
        "b_str": [sp.sstr(bi) for bi in b],
        "u": lambda X, Y: np.stack([u_f[0](X, Y), u_f[1](X, Y)], -1),
        "grad": lambda X, Y: np.stack([np.stack([g_f[i][j](X, Y) for j in range(2)], -1) for i in range(2)], -2),
    }


def navier_stokes(v: tuple[sp.Expr, sp.Expr], p: sp.Expr, rho: float, mu: float, symmetric: bool = True):
    """Forcing (per unit mass) of the steady Navier-Stokes equations for given v, p."""
    grad = sp.Matrix([[sp.diff(v[i], w) for w in (x, y)] for i in range(2)])
    assert sp.simplify(grad[0, 0] + grad[1, 1]) == 0, "velocity must be divergence-free"
    tau = mu * (grad + grad.T) if symmetric else mu * grad
    f = []
    for i in range(2):
        conv = v[0] * grad[i, 0] + v[1] * grad[i, 1]
        divtau = sp.diff(tau[i, 0], x) + sp.diff(tau[i, 1], y)
        f.append((rho * conv - divtau + sp.diff(p, [x, y][i])) / rho)
    v_f = [lambdify(vi) for vi in v]
    g_f = [[lambdify(grad[i, j]) for j in range(2)] for i in range(2)]
    p_f = lambdify(p)
    return {
        "v_str": [sp.sstr(vi) for vi in v],
        "p_str": sp.sstr(p),
        "f_str": [sp.sstr(fi) for fi in f],
        "v": lambda X, Y: np.stack([v_f[0](X, Y), v_f[1](X, Y)], -1),
        "grad": lambda X, Y: np.stack([np.stack([g_f[i][j](X, Y) for j in range(2)], -1) for i in range(2)], -2),
        "p": p_f,
    }


def rates(hs, errs) -> np.ndarray:
    hs = np.asarray(hs, float)
    errs = np.asarray(errs, float)
    return np.log(errs[1:] / errs[:-1]) / np.log(hs[1:] / hs[:-1])
