"""Nitsche coupling on the fluid-wetted interface Γ^FS (FORMULATION §4.4 case I, §4.5).

On every interface piece (a straight solid boundary edge segment inside one background cell),
with ``n`` the solid outward normal, ``t_F = σ^F n = -p n + μ(∇v + s ∇vᵀ) n`` the fluid
traction evaluated in the background cell (fluid-sided, as 4C's ``xfluid`` strategy),
``v_rel = v - ∂u/∂t`` and the slip coefficients of (37)::

    lam = μ/(κ + a),  bet = a/(κ + a),  eta = a κ/((κ + a) μ),   a = h_K/(γ0^t C_T)
    (κ = ∞: lam = bet = 0, eta = a/μ)

the single interface traction is

    σ_Γ = (n·t_F + γ^F v_rel·n) n + bet (t_F)_t + lam (v_rel)_t          (27) case I, (37)

and the weak-form contributions are

    solid rows:   -(δu, σ_Γ)                                              (23)
    fluid rows:   +(δv, σ_Γ) + (δp, v_rel·n)                              (31)
                  + s_adj (μ(∇δv + s∇δvᵀ) n, v_rel·n n)                    (28)
                  + s_adj (μ(∇δv + s∇δvᵀ) n, bet (v_rel)_t - eta (t_F)_t)  (39)

``s_adj = -1`` is the skew-symmetric adjoint (paper, 4C's FSCI test), ``+1`` symmetric.

The Jacobian of every piece is computed exactly by complex-step differentiation of this
residual with respect to its 16 local unknowns (displacements of the two edge nodes, velocity
and pressure of the four cell nodes). It includes the dependence of the interface position,
normal, length and solid velocity on the displacements, for the piece's fixed local
coordinate range (the cut is frozen within an iteration; the dependence of the cut itself on
the displacements is dropped — see docs/architecture.md).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from fsci.fem.q1 import q1_shape
from fsci.fem.sparse import add_local

CS_STEP = 1e-30  # complex-step size


@njit(cache=True)
def segment_residual(z, r, X, W, cu, vq, kap, s0, s1, x0c, y0c, hx, hy, gam, a_t, mu, sym, sadj,
                     gp, gw, traction):
    """Residual ``r[16]`` of one interface piece at local unknowns ``z[16]`` (real or complex).

    ``z = [u_a(2), u_b(2), (v_x, v_y, p) of the 4 cell nodes]``; ``X`` reference coordinates of
    the edge nodes, solid velocity ``cu * u - W`` at the nodes plus ``vq[g]`` at Gauss point g;
    ``kap[g]`` slip length (``inf`` = free slip). ``traction[g]`` receives σ_Γ (real part)."""
    for k in range(16):
        r[k] = 0.0 * z[0]
    N = np.empty(4, dtype=z.dtype)
    dN = np.empty((4, 2), dtype=z.dtype)
    xa0 = X[0, 0] + z[0]
    xa1 = X[0, 1] + z[1]
    dx = X[1, 0] + z[2] - xa0
    dy = X[1, 1] + z[3] - xa1
    L = np.sqrt(dx * dx + dy * dy)
    n0 = dy / L
    n1 = -dx / L
    for g in range(len(gp)):
        s = s0 + (s1 - s0) * gp[g]
        w = gw[g] * (s1 - s0) * L
        x = xa0 + s * dx
        y = xa1 + s * dy
        q1_shape(2.0 * (x - x0c) / hx - 1.0, 2.0 * (y - y0c) / hy - 1.0, N, dN)
        v0 = 0.0 * z[0]
        v1 = 0.0 * z[0]
        p = 0.0 * z[0]
        g00 = 0.0 * z[0]
        g01 = 0.0 * z[0]
        g10 = 0.0 * z[0]
        g11 = 0.0 * z[0]
        for A in range(4):
            dxA = dN[A, 0] * 2.0 / hx
            dyA = dN[A, 1] * 2.0 / hy
            VA0 = z[4 + 3 * A]
            VA1 = z[5 + 3 * A]
            v0 += N[A] * VA0
            v1 += N[A] * VA1
            p += N[A] * z[6 + 3 * A]
            g00 += VA0 * dxA
            g01 += VA0 * dyA
            g10 += VA1 * dxA
            g11 += VA1 * dyA
        Na = 1.0 - s
        Nb = s
        vs0 = Na * (cu * z[0] - W[0, 0]) + Nb * (cu * z[2] - W[1, 0]) + vq[g, 0]
        vs1 = Na * (cu * z[1] - W[0, 1]) + Nb * (cu * z[3] - W[1, 1]) + vq[g, 1]
        t0 = -p * n0 + mu * ((g00 + sym * g00) * n0 + (g01 + sym * g10) * n1)
        t1 = -p * n1 + mu * ((g10 + sym * g01) * n0 + (g11 + sym * g11) * n1)
        snn = t0 * n0 + t1 * n1
        vr0 = v0 - vs0
        vr1 = v1 - vs1
        vrn = vr0 * n0 + vr1 * n1
        tt0 = t0 - snn * n0
        tt1 = t1 - snn * n1
        vt0 = vr0 - vrn * n0
        vt1 = vr1 - vrn * n1
        kg = kap[g]
        if np.isinf(kg):
            lam = 0.0
            bet = 0.0
            eta = a_t / mu
        else:
            lam = mu / (kg + a_t)
            bet = a_t / (kg + a_t)
            eta = a_t * kg / ((kg + a_t) * mu)
        sg0 = (snn + gam * vrn) * n0 + bet * tt0 + lam * vt0
        sg1 = (snn + gam * vrn) * n1 + bet * tt1 + lam * vt1
        traction[g, 0] = sg0.real
        traction[g, 1] = sg1.real
        r[0] -= w * Na * sg0
        r[1] -= w * Na * sg1
        r[2] -= w * Nb * sg0
        r[3] -= w * Nb * sg1
        ad0 = bet * vt0 - eta * tt0
        ad1 = bet * vt1 - eta * tt1
        for A in range(4):
            dxA = dN[A, 0] * 2.0 / hx
            dyA = dN[A, 1] * 2.0 / hy
            gn = dxA * n0 + dyA * n1
            gad = dxA * ad0 + dyA * ad1
            # test function dv = N_A e_i:  mu (grad dv + s grad dv^T) n = mu (gn e_i + s n_i grad N_A)
            r[4 + 3 * A] += w * (N[A] * sg0 + sadj * mu * (gn * n0 * (1.0 + sym) * vrn + gn * ad0 + sym * n0 * gad))
            r[5 + 3 * A] += w * (N[A] * sg1 + sadj * mu * (gn * n1 * (1.0 + sym) * vrn + gn * ad1 + sym * n1 * gad))
            r[6 + 3 * A] += w * N[A] * vrn


@njit(cache=True)
def assemble_interface(xs, ys, nx, gcells, seg_cell, seg_s0, seg_s1, seg_X, seg_U, seg_W, seg_cu, seg_vq,
                       seg_kap, seg_gam, seg_at, V, P, mu, sym, sadj, gp, gw, conn, pos, data, rhs, row_base,
                       row_len, start, ndof, want_matrix, trac):
    """Add the coupling terms of all pieces; ``conn[k] = [node a, node b, 4 cell nodes]`` (global).
    ``trac[k, g]`` receives the interface traction σ_Γ at the Gauss points."""
    z = np.empty(16)
    zc = np.empty(16, dtype=np.complex128)
    r = np.empty(16)
    rc = np.empty(16, dtype=np.complex128)
    Ke = np.zeros((16, 16))
    dummy = np.empty((len(gp), 2))
    for k in range(len(seg_cell)):
        c = seg_cell[k]
        i = c % nx
        j = c // nx
        x0c = xs[i]
        y0c = ys[j]
        hx = xs[i + 1] - x0c
        hy = ys[j + 1] - y0c
        z[0] = seg_U[k, 0, 0]
        z[1] = seg_U[k, 0, 1]
        z[2] = seg_U[k, 1, 0]
        z[3] = seg_U[k, 1, 1]
        for A in range(4):
            n = gcells[c, A]
            z[4 + 3 * A] = V[n, 0]
            z[5 + 3 * A] = V[n, 1]
            z[6 + 3 * A] = P[n]
        segment_residual(z, r, seg_X[k], seg_W[k], seg_cu[k], seg_vq[k], seg_kap[k], seg_s0[k], seg_s1[k],
                         x0c, y0c, hx, hy, seg_gam[k], seg_at[k], mu, sym, sadj, gp, gw, trac[k])
        if want_matrix:
            for m in range(16):
                for l in range(16):
                    zc[l] = z[l]
                zc[m] += 1j * CS_STEP
                segment_residual(zc, rc, seg_X[k], seg_W[k], seg_cu[k], seg_vq[k], seg_kap[k], seg_s0[k],
                                 seg_s1[k], x0c, y0c, hx, hy, seg_gam[k], seg_at[k], mu, sym, sadj, gp, gw, dummy)
                for l in range(16):
                    Ke[l, m] = rc[l].imag / CS_STEP
        add_local(data, rhs, row_base, row_len, start, ndof, conn[k], pos[k], Ke, r, want_matrix)
