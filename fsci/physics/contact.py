"""Nitsche contact between solids, one half pass (FORMULATION §4.4 case II, paper (32)).

On a piece ``[s0, s1]`` of an own boundary edge (straight, outward normal ``n``), facing one
segment of another body:

    g_n   = (x̌ - x)·n,  x̌ = projection of x along n onto the opposite segment        (10)
    σ̃_nn  = ω n·σ_own(x)·n + (1 - ω) n·σ_opp(x̌)·n                                   (27)
    σ_nn  = min(0, σ̃_nn + γ^S g_n)   (dry contact: the other branch of (27) is zero)
    solid rows of the own body:  -(δu, σ_nn n)                                       (32)

(two half passes: the opposite body gets its own terms in its own pass; no adjoint term, as
4C's NITSCHE_THETA = 0). ``ω`` and ``γ^S = γ0^S (ω φ_own + (1 - ω) φ_opp)`` come from the
trace-inequality estimates φ of the two parent elements (harmonic weights) or ω = ½.

The piece ends are either fixed or the projections of the opposite segment's nodes onto the
own edge (Remark 9); they are recomputed from the unknowns, so the Jacobian obtained by
complex-step differentiation over the 16 unknowns of the two parent elements is exact,
including the motion of the split points and the dependence of x̌, g_n, n and σ̌ on both
bodies' displacements.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from fsci.fem.q1 import q1_physical_gradients, q1_shape
from fsci.fem.sparse import add_local
from fsci.physics.materials import cauchy_stress

CS_STEP = 1e-30
CORNERS = np.array([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]])


@njit(cache=True)
def _stress_nn(Xe, ue, law, prm, r, s, n0, n1):
    """n·σ·n of a Q1 element (reference coords Xe, displacements ue) at local (r, s)."""
    N = np.empty(4, dtype=ue.dtype)
    dN = np.empty((4, 2), dtype=ue.dtype)
    dNx = np.empty((4, 2), dtype=ue.dtype)
    q1_shape(r, s, N, dN)
    q1_physical_gradients(Xe, dN, dNx)
    F = np.empty((2, 2), dtype=ue.dtype)
    for i in range(2):
        for j in range(2):
            F[i, j] = (1.0 if i == j else 0.0) + 0.0 * dNx[0, 0]
            for a in range(4):
                F[i, j] += ue[a, i] * dNx[a, j]
    sig = np.empty((2, 2), dtype=ue.dtype)
    cauchy_stress(law, prm, F, sig)
    return n0 * (sig[0, 0] * n0 + sig[0, 1] * n1) + n1 * (sig[1, 0] * n0 + sig[1, 1] * n1)


@njit(cache=True, inline="always")
def _piece_end(d, s_fixed, A0, A1, t0, t1, L2, P0, P1, Q0, Q1):
    """End of a contact piece: fixed (d < 0) or the projection of the opposite node d."""
    if d < 0:
        return s_fixed + 0.0 * A0
    if d == 0:
        return ((P0 - A0) * t0 + (P1 - A1) * t1) / L2
    return ((Q0 - A0) * t0 + (Q1 - A1) * t1) / L2


@njit(cache=True)
def contact_residual(z, r, Xo, eo, lawo, prmo, Xm, em, lawm, prmm, w_own, pen, s0, s1, d0, d1, gp, gw, out):
    """Residual ``r[16]`` of one contact piece;
    ``out[g] = (x, y, σ_nn, g_n, active, weight, n_x, n_y)``."""
    for k in range(16):
        r[k] = 0.0 * z[0]
    uo = np.empty((4, 2), dtype=z.dtype)
    um = np.empty((4, 2), dtype=z.dtype)
    for a in range(4):
        for i in range(2):
            uo[a, i] = z[2 * a + i]
            um[a, i] = z[8 + 2 * a + i]
    ia = eo
    ib = (eo + 1) % 4
    A0 = Xo[ia, 0] + uo[ia, 0]
    A1 = Xo[ia, 1] + uo[ia, 1]
    t0 = Xo[ib, 0] + uo[ib, 0] - A0
    t1 = Xo[ib, 1] + uo[ib, 1] - A1
    L2 = t0 * t0 + t1 * t1
    L = np.sqrt(L2)
    n0 = t1 / L
    n1 = -t0 / L
    ja = em
    jb = (em + 1) % 4
    P0 = Xm[ja, 0] + um[ja, 0]
    P1 = Xm[ja, 1] + um[ja, 1]
    Q0 = Xm[jb, 0] + um[jb, 0]
    Q1 = Xm[jb, 1] + um[jb, 1]
    # piece ends: fixed, or the orthogonal projection of an opposite node onto the own edge
    sa = _piece_end(d0, s0, A0, A1, t0, t1, L2, P0, P1, Q0, Q1)
    sb = _piece_end(d1, s1, A0, A1, t0, t1, L2, P0, P1, Q0, Q1)
    e0 = Q0 - P0
    e1 = Q1 - P1
    det = -e0 * n1 + n0 * e1
    for g in range(len(gp)):
        s = sa + (sb - sa) * gp[g]
        w = gw[g] * (sb - sa) * L
        x0 = A0 + s * t0
        x1 = A1 + s * t1
        w0 = x0 - P0
        w1 = x1 - P1
        eta = (-w0 * n1 + n0 * w1) / det
        gap = (e0 * w1 - e1 * w0) / det
        ro = (1.0 - s) * CORNERS[ia, 0] + s * CORNERS[ib, 0]
        so_ = (1.0 - s) * CORNERS[ia, 1] + s * CORNERS[ib, 1]
        rm = (1.0 - eta) * CORNERS[ja, 0] + eta * CORNERS[jb, 0]
        sm = (1.0 - eta) * CORNERS[ja, 1] + eta * CORNERS[jb, 1]
        snn = 0.0 * z[0]
        if w_own > 0.0:
            snn += w_own * _stress_nn(Xo, uo, lawo, prmo, ro, so_, n0, n1)
        if w_own < 1.0:
            snn += (1.0 - w_own) * _stress_nn(Xm, um, lawm, prmm, rm, sm, n0, n1)
        C = snn + pen * gap
        out[g, 0] = x0.real
        out[g, 1] = x1.real
        out[g, 3] = gap.real
        out[g, 5] = w.real
        out[g, 6] = n0.real
        out[g, 7] = n1.real
        if C.real <= 0.0:  # C = 0 (touching, unloaded) counts as active: keeps touching bodies supported
            out[g, 2] = C.real
            out[g, 4] = 1.0
            r[2 * ia] -= w * (1.0 - s) * C * n0
            r[2 * ia + 1] -= w * (1.0 - s) * C * n1
            r[2 * ib] -= w * s * C * n0
            r[2 * ib + 1] -= w * s * C * n1
        else:
            out[g, 2] = 0.0
            out[g, 4] = 0.0


@njit(cache=True)
def assemble_contact(Xo_all, eo_all, lawo_all, prmo_all, Xm_all, em_all, lawm_all, prmm_all, w_all, pen_all,
                     s0_all, s1_all, d0_all, d1_all, z_all, gp, gw, conn, pos, data, rhs, row_base, row_len,
                     start, ndof, want_matrix, out_all):
    """Add all contact pieces; ``z_all[k]`` holds the 16 displacements of the two elements."""
    r = np.empty(16)
    rc = np.empty(16, dtype=np.complex128)
    zc = np.empty(16, dtype=np.complex128)
    Ke = np.zeros((16, 16))
    dummy = np.empty((len(gp), 8))
    for k in range(len(s0_all)):
        contact_residual(z_all[k], r, Xo_all[k], eo_all[k], lawo_all[k], prmo_all[k], Xm_all[k], em_all[k],
                         lawm_all[k], prmm_all[k], w_all[k], pen_all[k], s0_all[k], s1_all[k], d0_all[k],
                         d1_all[k], gp, gw, out_all[k])
        active = False
        for g in range(len(gp)):
            if out_all[k, g, 4] > 0.0:
                active = True
        if not active:
            continue
        if want_matrix:
            for m in range(16):
                for l in range(16):
                    zc[l] = z_all[k, l]
                zc[m] += 1j * CS_STEP
                contact_residual(zc, rc, Xo_all[k], eo_all[k], lawo_all[k], prmo_all[k], Xm_all[k], em_all[k],
                                 lawm_all[k], prmm_all[k], w_all[k], pen_all[k], s0_all[k], s1_all[k],
                                 d0_all[k], d1_all[k], gp, gw, dummy)
                for l in range(16):
                    Ke[l, m] = rc[l].imag / CS_STEP
        add_local(data, rhs, row_base, row_len, start, ndof, conn[k], pos[k], Ke, r, want_matrix)
