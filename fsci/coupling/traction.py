"""The interface traction of every body-boundary point (paper Sec. 3.2-3.4.4, (27)-(40)).

One kernel serves plain FSI, dry contact and fluid-structure-contact: at every Gauss point of a
piece of a body's coupling boundary (straight, own outward normal ``n``) it evaluates both
branches of the normal traction (27)

    F  = σ^F_nn + γ^F v^rel_n        (FSI side; on Γ^SC the extended values, §4.6)
    Cc = σ̃^S_nn + γ^S g_n            (contact side; +∞ without an opposite surface)
    C  = Cc − F                      (29): C ≤ 0 → contact branch

and adds the contributions of the point's case

    I   (Γ^FS, C > 0):  (δv − δu, F n) + (δp n − 2μ ε(δv) n, v^rel_n n)              (31), (28)
    II  (Γ^SC, C ≤ 0):  (−δu, Cc n)                                                 (32)
    III (Γ^FS, C ≤ 0):  Remark 6 (35): fluid rows as I, solid rows as II (default);
                        original (33): (δv − δu, Cc n), no mass/adjoint term
    IV  (Γ^SC, C > 0):  (−δu, F_e n), F_e the extended FSI side                      (34)

plus, on Γ^FS in every case, the tangential Navier-slip traction (37)-(39) with the slip
length κ of the body, or of the gap law (40) ``κ = κ0 h (h/g_n − 1)`` for ``0 < g_n < h``
(0 beyond h, ∞ for ``g_n ≤ 0``). With ``a = h_K/(γ0^t C_T)``::

    σ_t = bet (t_F)_t + lam (v_rel)_t,   lam = μ/(κ + a),  bet = a/(κ + a),  eta = a κ/((κ + a) μ)
    fluid adjoint: + s_adj (μ(∇δv + s ∇δvᵀ) n, v^rel_n n + bet (v_rel)_t − eta (t_F)_t)

Time levels (one-step-θ, paper Sec. 3.4): the fluid pressure is the implicit (n+θ) pressure of
the bulk, so it enters with weight ``w_p`` = 1; the viscous traction, the penalties, the contact
stress and the adjoint terms are θ-weighted like the bulk viscous and solid internal forces
(weight ``w_t``); the mass-conservation rows with weight ``w_c`` = 1. The old level is the same
residual evaluated with ``(w_p, w_t, w_c) = (0, 1, 0)`` at the converged state of the previous step
(see :mod:`fsci.coupling.term`). The case is decided on the unweighted values of the level.

Local unknowns of a piece (``N_LOCAL`` = 56, absent slots are skipped):
``[own element u (8) | opposite element u (8) | fluid cell (v_x, v_y, p) × 4 | extension cell × 4 |
extension edge u (4) | the edge end 0 lies on or whose node projects there u (4) | that of end 1
(4) | of the extension point (4)]``. The Jacobian is the exact derivative over the live slots: by complex
step in the solid unknowns, and, since with the case of every point fixed the residual is affine
in the fluid cell's and the extension cell's values, by real differences of step
``AFFINE_STEP`` in those (the same columns to 2e-15 of their size, at about half the cost). It
includes the motion of the split points (Remark 9), of the ends where the edge crosses a grid
line or another body's boundary or where a closed film ends (the end of the wetted part in
contact, and the extension point there), g_n, x̌, n, σ̌, κ(g_n) and the extended values'
dependence on the transition cell and edge; an end elsewhere (a held dry region, a mitre corner
of a closed film) is fixed with the cut (docs/architecture.md, decisions 21 and 39). The bulk
shape derivative follows every moving part of the fluid boundary: the wetted pieces and the
mouths of closed films (``MOUTH`` pieces, decision 43).
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from fsci.fem.q1 import q1_physical_gradients, q1_shape
from fsci.fem.sparse import add_local
from fsci.physics.fluid import P_LINEAR, cell_density
from fsci.physics.materials import cauchy_stress

CS_STEP = 1e-30  # complex-step size
AFFINE_STEP = 2.0 ** 20  # difference step in the unknowns the residual is affine in (fluid values)
CORNERS = np.array([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]])

N_LOCAL = 56  # local unknowns of a piece
# node slots: own element 4, opposite element 4, fluid cell 4, extension cell 4, extension edge 2,
# the edge end 0 lies on or whose node projects there 2, that of end 1 2, of the extension point 2
N_SLOTS = 24
OFF_OPP, OFF_CELL, OFF_EXT, OFF_EDGE, OFF_END = 8, 16, 28, 40, 44

# flags (bit field per piece)
HAS_OPP, ON_FS, HAS_EXT, SLIP_LAW, HAS_FLUID, HELD, MOUTH = 1, 2, 4, 8, 16, 32, 64
# MOUTH: the mouth of a closed film along the edge, at distance F_FILM on its outward side: no
# interface terms, only the bulk shape derivative (fsci.cut.state.CutState._film_mouths)
# HELD: a dry piece whose contact swung back and forth in this step's iterations; its points with
# g_n <= 0 stay in contact for the rest of the step (CouplingTerm.track_case_swings, decision 38)
# integer data per piece
I_EO, I_LAWO, I_EM, I_LAWM, I_D0, I_D1, I_FLAGS, I_DE = range(8)
N_INT = 8
# float data per piece
(F_WOWN, F_PEN, F_S0, F_S1, F_CU, F_GAM, F_AT, F_X0C, F_Y0C, F_HX, F_HY, F_SE, F_CUE, F_GAME, F_X0E, F_Y0E,
 F_HXE, F_HYE, F_KAPPA0, F_SLIPH, F_C0, F_C1, F_CE, F_FILM, F_GAMV, F_VMS) = range(26)
N_FLT = 26
# F_GAM, F_GAME: γ^F of the cell and the extension cell; in steady flow only their viscous part,
# and γ^F adds F_GAMV · max(|v| at the cell's nodes, F_VMS) at the unknowns (_nitsche_gamma)
# columns of the per-Gauss-point output
(O_X, O_Y, O_CASE, O_GAP, O_F, O_CC, O_KAPPA, O_W, O_NX, O_NY, O_TX, O_TY, O_TN_FSI, O_TN_CON) = range(14)
N_OUT = 14
CASE_I, CASE_II, CASE_III, CASE_IV = 1, 2, 3, 4


@njit(cache=True)
def _stress_nn(Xe, ue, law, prm, r, s, n0, n1):
    """n·σ·n of a Q1 solid element (reference coordinates Xe, displacements ue) at local (r, s)."""
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
def _piece_end(d, s_fixed, c, A0, A1, t0, t1, L2, P0, P1, Q0, Q1, B0, B1, w0, w1, film):
    """End of a piece on the edge A + s t: fixed (d < 0), the orthogonal projection of opposite
    node d = 0/1 (Remark 9), where the edge crosses the grid line x = c (d = 2) / y = c (d = 3),
    where it crosses another body's edge B + r w (d = 4, fsci.cut.state.END_BODY), or that edge's
    line moved by ``film`` along its outward normal (d = 5) or against it (d = 6): the end of a
    closed film; or the projection of the node B (d = 7) or B + w (d = 8) of an edge other than
    the opposite segment (fsci.cut.state.END_NODE0/1: where the opposite surface ends) — the
    ends move with the unknowns, so the Jacobian includes the motion of the splits."""
    if d < 0:
        return s_fixed + 0.0 * A0
    if d == 0:
        return ((P0 - A0) * t0 + (P1 - A1) * t1) / L2
    if d == 1:
        return ((Q0 - A0) * t0 + (Q1 - A1) * t1) / L2
    if d == 2:
        return (c - A0) / t0
    if d == 3:
        return (c - A1) / t1
    if d == 7:
        return ((B0 - A0) * t0 + (B1 - A1) * t1) / L2
    if d == 8:
        return ((B0 + w0 - A0) * t0 + (B1 + w1 - A1) * t1) / L2
    den = t0 * w1 - t1 * w0
    if abs(den.real) <= 1e-12 * np.sqrt(L2.real * (w0.real * w0.real + w1.real * w1.real)):
        return s_fixed + 0.0 * A0  # the edges turned parallel since the cut: no crossing to follow
    if d >= 5:
        off = (film if d == 5 else -film) / np.sqrt(w0 * w0 + w1 * w1)
        B0 = B0 + off * w1
        B1 = B1 - off * w0
    return ((B0 - A0) * w1 - (B1 - A1) * w0) / den


@njit(cache=True, inline="always")
def _crossed_edge(z, Xe, end):
    """Start point and direction ``(B0, B1, w0, w1)`` of the other body's edge that piece end
    ``end`` (0 or 1; 2: the extension point) crosses: reference coordinates in
    ``Xe[2 + 2 end : 4 + 2 end]``, displacements in the local unknowns from ``OFF_END + 4 end``
    (zero where there is none)."""
    o = OFF_END + 4 * end
    r = 2 + 2 * end
    B0 = Xe[r, 0] + z[o]
    B1 = Xe[r, 1] + z[o + 1]
    return B0, B1, Xe[r + 1, 0] + z[o + 2] - B0, Xe[r + 1, 1] + z[o + 3] - B1


@njit(cache=True)
def _fluid_at(z, off, x, y, x0c, y0c, hx, hy, mu, sym, n0, n1, N, dN):
    """Fluid velocity, pressure and traction t_F = σ^F n of cell slots ``z[off:off+12]`` at (x, y).

    Returns (v0, v1, p, t0, t1, tv0, tv1) with ``tv`` the viscous part of the traction; fills
    ``N``/``dN`` (reference derivatives) for the test functions."""
    q1_shape(2.0 * (x - x0c) / hx - 1.0, 2.0 * (y - y0c) / hy - 1.0, N, dN)
    zero = 0.0 * z[0]
    v0 = zero
    v1 = zero
    p = zero
    g00 = zero
    g01 = zero
    g10 = zero
    g11 = zero
    for A in range(4):
        dxA = dN[A, 0] * 2.0 / hx
        dyA = dN[A, 1] * 2.0 / hy
        VA0 = z[off + 3 * A]
        VA1 = z[off + 1 + 3 * A]
        v0 += N[A] * VA0
        v1 += N[A] * VA1
        p += N[A] * z[off + 2 + 3 * A]
        g00 += VA0 * dxA
        g01 += VA0 * dyA
        g10 += VA1 * dxA
        g11 += VA1 * dyA
    tv0 = mu * ((g00 + sym * g00) * n0 + (g01 + sym * g10) * n1)
    tv1 = mu * ((g10 + sym * g01) * n0 + (g11 + sym * g11) * n1)
    return v0, v1, p, tv0 - p * n0, tv1 - p * n1, tv0, tv1


@njit(cache=True, inline="always")
def _nitsche_gamma(z, off, fp, f_gam):
    """γ^F of Remark 8 for the fluid cell at ``off``: ``fp[f_gam]``, in steady flow plus its
    convective part ``F_GAMV · max(|v| at the cell's nodes, F_VMS)`` at the unknowns ``z``
    (a maximum: its derivative is that of the component attaining it)."""
    gam = 0.0 * z[0] + fp[f_gam]
    if fp[F_GAMV] == 0.0:
        return gam
    best = fp[F_VMS]
    col = -1
    for k in range(8):
        j = off + 3 * (k // 2) + k % 2
        if abs(z[j].real) > best:
            best = abs(z[j].real)
            col = j
    if col < 0:
        return gam + fp[F_GAMV] * best
    return gam + fp[F_GAMV] * (z[col] if z[col].real > 0.0 else -z[col])


@njit(cache=True)
def piece_residual(z, r, out, ip, fp, Xo, prmo, Xm, prmm, W, vq, kap, Xe, We, vqe, mu, sym, sadj, variant33,
                   w_p, w_t, w_c, gp, gw, cases):
    """Residual ``r[N_LOCAL]`` of one piece at local unknowns ``z`` (real or complex).

    ``cases``: empty, or the case (CASE_I-IV) of every Gauss point, which is then taken as given
    instead of decided from (29) at ``z`` (for the differences of :func:`_piece_locals`).

    ``Xe`` holds the reference coordinates of the extension edge (rows 0-1) and of the other
    bodies' edges the piece's ends and its extension point cross (rows 2-3, 4-5 and 6-7,
    :func:`_crossed_edge`).

    ``out[g]`` receives the real parts of the point data (columns ``O_*``). Returns True if the
    piece contributes anything (a dry piece out of contact does not)."""
    for k in range(N_LOCAL):
        r[k] = 0.0 * z[0]
    flags = ip[I_FLAGS]
    has_opp = (flags & HAS_OPP) != 0
    on_fs = (flags & ON_FS) != 0
    has_ext = (flags & HAS_EXT) != 0
    slip_law = (flags & SLIP_LAW) != 0
    held = (flags & HELD) != 0
    eo = ip[I_EO]
    ia = eo
    ib = (eo + 1) % 4
    uo = np.empty((4, 2), dtype=z.dtype)
    um = np.empty((4, 2), dtype=z.dtype)
    for a in range(4):
        for i in range(2):
            uo[a, i] = z[2 * a + i]
            um[a, i] = z[OFF_OPP + 2 * a + i]
    A0 = Xo[ia, 0] + uo[ia, 0]
    A1 = Xo[ia, 1] + uo[ia, 1]
    t0 = Xo[ib, 0] + uo[ib, 0] - A0
    t1 = Xo[ib, 1] + uo[ib, 1] - A1
    L2 = t0 * t0 + t1 * t1
    L = np.sqrt(L2)
    n0 = t1 / L
    n1 = -t0 / L
    ja = ip[I_EM]
    jb = (ja + 1) % 4
    P0 = Xm[ja, 0] + um[ja, 0]
    P1 = Xm[ja, 1] + um[ja, 1]
    Q0 = Xm[jb, 0] + um[jb, 0]
    Q1 = Xm[jb, 1] + um[jb, 1]
    B0, B1, w0, w1 = _crossed_edge(z, Xe, 0)
    sa = _piece_end(ip[I_D0], fp[F_S0], fp[F_C0], A0, A1, t0, t1, L2, P0, P1, Q0, Q1, B0, B1, w0, w1, fp[F_FILM])
    B0, B1, w0, w1 = _crossed_edge(z, Xe, 1)
    sb = _piece_end(ip[I_D1], fp[F_S1], fp[F_C1], A0, A1, t0, t1, L2, P0, P1, Q0, Q1, B0, B1, w0, w1, fp[F_FILM])
    e0 = Q0 - P0
    e1 = Q1 - P1
    det = -e0 * n1 + n0 * e1
    w_own = fp[F_WOWN]
    pen = fp[F_PEN]
    cu = fp[F_CU]
    gam = _nitsche_gamma(z, OFF_CELL, fp, F_GAM)
    a_t = fp[F_AT]
    N = np.empty(4, dtype=z.dtype)
    dN = np.empty((4, 2), dtype=z.dtype)
    # extended FSI side (§4.6): scalar values at the transition point, constant in the piece
    Fe = 0.0 * z[0]
    Fe_applied = 0.0 * z[0]
    if has_ext:
        ea0 = Xe[0, 0] + z[OFF_EDGE]
        ea1 = Xe[0, 1] + z[OFF_EDGE + 1]
        et0 = Xe[1, 0] + z[OFF_EDGE + 2] - ea0
        et1 = Xe[1, 1] + z[OFF_EDGE + 3] - ea1
        # the transition point: fixed, or where the extension edge crosses another body's edge
        B0, B1, w0, w1 = _crossed_edge(z, Xe, 2)
        se = _piece_end(ip[I_DE], fp[F_SE], fp[F_CE], ea0, ea1, et0, et1, et0 * et0 + et1 * et1, 0.0, 0.0, 0.0, 0.0,
                        B0, B1, w0, w1, fp[F_FILM])
        eL = np.sqrt(et0 * et0 + et1 * et1)
        m0 = et1 / eL
        m1 = -et0 / eL
        xe = ea0 + se * et0
        ye = ea1 + se * et1
        ve0, ve1, pe, te0, te1, tve0, tve1 = _fluid_at(z, OFF_EXT, xe, ye, fp[F_X0E], fp[F_Y0E], fp[F_HXE],
                                                       fp[F_HYE], mu, sym, m0, m1, N, dN)
        cue = fp[F_CUE]
        vse0 = (1.0 - se) * (cue * z[OFF_EDGE] - We[0, 0]) + se * (cue * z[OFF_EDGE + 2] - We[1, 0]) + vqe[0]
        vse1 = (1.0 - se) * (cue * z[OFF_EDGE + 1] - We[0, 1]) + se * (cue * z[OFF_EDGE + 3] - We[1, 1]) + vqe[1]
        vrne = (ve0 - vse0) * m0 + (ve1 - vse1) * m1
        visc_e = tve0 * m0 + tve1 * m1
        game = _nitsche_gamma(z, OFF_EXT, fp, F_GAME)
        Fe = -pe + visc_e + game * vrne
        Fe_applied = -w_p * pe + w_t * (visc_e + game * vrne)
    contributes = False
    for g in range(len(gp)):
        s = sa + (sb - sa) * gp[g]
        w = gw[g] * (sb - sa) * L
        x0 = A0 + s * t0
        x1 = A1 + s * t1
        Na = 1.0 - s
        Nb = s
        # ------------------------------------------------ contact side of (27)
        gap = 0.0 * z[0]
        Cc = 0.0 * z[0]
        if has_opp:
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
                snn += w_own * _stress_nn(Xo, uo, ip[I_LAWO], prmo, ro, so_, n0, n1)
            if w_own < 1.0:
                snn += (1.0 - w_own) * _stress_nn(Xm, um, ip[I_LAWM], prmm, rm, sm, n0, n1)
            Cc = snn + pen * gap
        # ------------------------------------------------ FSI side of (27)
        F = 0.0 * z[0]
        F_applied = 0.0 * z[0]
        vrn = 0.0 * z[0]
        tt0 = 0.0 * z[0]
        tt1 = 0.0 * z[0]
        vt0 = 0.0 * z[0]
        vt1 = 0.0 * z[0]
        if on_fs:
            v0, v1, p, tf0, tf1, tv0, tv1 = _fluid_at(z, OFF_CELL, x0, x1, fp[F_X0C], fp[F_Y0C], fp[F_HX], fp[F_HY],
                                                      mu, sym, n0, n1, N, dN)
            vs0 = Na * (cu * uo[ia, 0] - W[0, 0]) + Nb * (cu * uo[ib, 0] - W[1, 0]) + vq[g, 0]
            vs1 = Na * (cu * uo[ia, 1] - W[0, 1]) + Nb * (cu * uo[ib, 1] - W[1, 1]) + vq[g, 1]
            vr0 = v0 - vs0
            vr1 = v1 - vs1
            vrn = vr0 * n0 + vr1 * n1
            visc = tv0 * n0 + tv1 * n1
            tnn = tf0 * n0 + tf1 * n1
            tt0 = tf0 - tnn * n0
            tt1 = tf1 - tnn * n1
            vt0 = vr0 - vrn * n0
            vt1 = vr1 - vrn * n1
            F = -p + visc + gam * vrn
            F_applied = -w_p * p + w_t * (visc + gam * vrn)
        elif has_ext:
            F = Fe
            F_applied = Fe_applied
        # C = 0 (touching, unloaded) keeps bodies supported
        if len(cases):
            contact = cases[g] == CASE_II or cases[g] == CASE_III
        else:
            contact = has_opp and (Cc.real - F.real <= 0.0 or (held and gap.real <= 0.0))
        # ------------------------------------------------ tangential: Navier slip (37), law (40)
        lam = 0.0 * z[0]
        bet = 0.0 * z[0]
        eta_s = 0.0 * z[0]
        kappa_out = 0.0
        if on_fs:
            kg = 0.0 * z[0] + kap[g]
            free = np.isinf(kap[g])
            if slip_law:
                h = fp[F_SLIPH]
                if not has_opp or gap.real >= h:
                    kg = 0.0 * z[0]
                    free = False
                elif gap.real > 0.0:
                    kg = fp[F_KAPPA0] * h * (h / gap - 1.0)
                    free = False
                else:
                    free = True
            if free:
                eta_s = eta_s + a_t / mu
                kappa_out = np.inf
            else:
                lam = mu / (kg + a_t)
                bet = a_t / (kg + a_t)
                eta_s = a_t * kg / ((kg + a_t) * mu)
                kappa_out = kg.real
        st0 = w_t * (bet * tt0 + lam * vt0)
        st1 = w_t * (bet * tt1 + lam * vt1)
        # ------------------------------------------------ normal traction on the solid, by case
        if contact:
            sn_solid = w_t * Cc
            case = CASE_III if on_fs else CASE_II
        else:
            sn_solid = F_applied
            case = CASE_I if on_fs else CASE_IV
        active = on_fs or contact or has_ext
        if active:
            contributes = True
            ts0 = sn_solid * n0 + st0
            ts1 = sn_solid * n1 + st1
            r[2 * ia] -= w * Na * ts0
            r[2 * ia + 1] -= w * Na * ts1
            r[2 * ib] -= w * Nb * ts0
            r[2 * ib + 1] -= w * Nb * ts1
        # ------------------------------------------------ fluid rows (Γ^FS only: (24))
        if on_fs:
            orig33 = contact and variant33
            sn_fluid = w_t * Cc if orig33 else F_applied
            tfl0 = sn_fluid * n0 + st0
            tfl1 = sn_fluid * n1 + st1
            mass = 0.0 if orig33 else 1.0
            ad0 = bet * vt0 - eta_s * tt0
            ad1 = bet * vt1 - eta_s * tt1
            for A in range(4):
                dxA = dN[A, 0] * 2.0 / fp[F_HX]
                dyA = dN[A, 1] * 2.0 / fp[F_HY]
                gn = dxA * n0 + dyA * n1
                gad = dxA * ad0 + dyA * ad1
                # test function dv = N_A e_i:  mu (grad dv + s grad dv^T) n = mu (gn e_i + s n_i grad N_A)
                adj0 = sadj * mu * w_t * (mass * gn * n0 * (1.0 + sym) * vrn + gn * ad0 + sym * n0 * gad)
                adj1 = sadj * mu * w_t * (mass * gn * n1 * (1.0 + sym) * vrn + gn * ad1 + sym * n1 * gad)
                r[OFF_CELL + 3 * A] += w * (N[A] * tfl0 + adj0)
                r[OFF_CELL + 1 + 3 * A] += w * (N[A] * tfl1 + adj1)
                r[OFF_CELL + 2 + 3 * A] += w * w_c * mass * N[A] * vrn
        out[g, O_X] = x0.real
        out[g, O_Y] = x1.real
        out[g, O_CASE] = case
        out[g, O_GAP] = gap.real if has_opp else np.inf
        out[g, O_F] = F.real
        out[g, O_CC] = Cc.real if has_opp else np.inf
        out[g, O_KAPPA] = kappa_out
        out[g, O_W] = w.real
        out[g, O_NX] = n0.real
        out[g, O_NY] = n1.real
        # reported traction on the solid: the unweighted values of this level
        rep_n = (Cc.real if contact else F.real) if active else 0.0
        rep_t0 = (bet * tt0 + lam * vt0).real
        rep_t1 = (bet * tt1 + lam * vt1).real
        out[g, O_TX] = rep_n * n0.real + rep_t0
        out[g, O_TY] = rep_n * n1.real + rep_t1
        out[g, O_TN_FSI] = 0.0 if contact else rep_n
        out[g, O_TN_CON] = rep_n if contact else 0.0
    return contributes


@njit(cache=True)
def add_bulk_shape_derivative(K, z, ip, fp, Xo, Xm, Xe, Vo, Vb, bq, fprm, gp, gw):
    """Add to ``K`` (full local Jacobian) the derivative of the fluid bulk integrals (22) over the
    piece's cell with respect to the motion of the piece (Reynolds transport: moving Γ^FS by δu
    into the fluid removes fluid, ``δ ∫_{Ω^F} r_i = −∫_{Γ^FS} r_i (δu · n) ds``), where ``r_i`` is
    the cell integrand of fluid test function i (:func:`fsci.physics.fluid.cell_density`).
    Cut-cell quadrature is exact for these integrands, so this is the exact derivative of the
    discrete bulk residual with respect to the boundary position. ``Vo``: previous velocity at
    the cell nodes, ``Vb``: the stabilisation velocity there in a time step (in steady flow the
    unknown one), ``bq[g]``: body-force density at the Gauss points, ``fprm``: cell
    parameters of the fluid kernel. A ``MOUTH`` piece is the mouth of a closed film: the same
    integral on the edge's line moved by δ = ``fp[F_FILM]`` along its normal (decision 43)."""
    if (ip[I_FLAGS] & ON_FS) == 0:
        return
    eo = ip[I_EO]
    ia = eo
    ib = (eo + 1) % 4
    A0 = Xo[ia, 0] + z[2 * ia]
    A1 = Xo[ia, 1] + z[2 * ia + 1]
    t0 = Xo[ib, 0] + z[2 * ib] - A0
    t1 = Xo[ib, 1] + z[2 * ib + 1] - A1
    L2 = t0 * t0 + t1 * t1
    L = np.sqrt(L2)
    n0 = t1 / L
    n1 = -t0 / L
    ja = ip[I_EM]
    jb = (ja + 1) % 4
    P0 = Xm[ja, 0] + z[OFF_OPP + 2 * ja]
    P1 = Xm[ja, 1] + z[OFF_OPP + 2 * ja + 1]
    Q0 = Xm[jb, 0] + z[OFF_OPP + 2 * jb]
    Q1 = Xm[jb, 1] + z[OFF_OPP + 2 * jb + 1]
    B0, B1, w0, w1 = _crossed_edge(z, Xe, 0)
    sa = _piece_end(ip[I_D0], fp[F_S0], fp[F_C0], A0, A1, t0, t1, L2, P0, P1, Q0, Q1, B0, B1, w0, w1, fp[F_FILM])
    B0, B1, w0, w1 = _crossed_edge(z, Xe, 1)
    sb = _piece_end(ip[I_D1], fp[F_S1], fp[F_C1], A0, A1, t0, t1, L2, P0, P1, Q0, Q1, B0, B1, w0, w1, fp[F_FILM])
    if (ip[I_FLAGS] & MOUTH) != 0:
        # a film's mouth: on the edge's line moved by δ along n, which moves with the edge along n
        # (δ n turns, but only tangentially to itself), so the same normal velocity; its ends
        # move along the boundary only, which the first variation of the integral does not see
        A0 += fp[F_FILM] * n0
        A1 += fp[F_FILM] * n1
    hx = fp[F_HX]
    hy = fp[F_HY]
    N = np.empty(4)
    dN = np.empty((4, 2))
    dNx = np.empty((4, 2))
    Ve = np.empty((4, 2))
    Pe = np.empty(4)
    gv = np.empty((2, 2))
    go = np.empty((2, 2))
    dens = np.empty(12)
    sp = np.empty(7)
    for A in range(4):
        Ve[A, 0] = z[OFF_CELL + 3 * A]
        Ve[A, 1] = z[OFF_CELL + 3 * A + 1]
        Pe[A] = z[OFF_CELL + 3 * A + 2]
    if fprm[P_LINEAR] != 0.0:  # steady flow: the scalings at the unknown velocity
        Vb = Ve
    for g in range(len(gp)):
        s = sa + (sb - sa) * gp[g]
        w = gw[g] * (sb - sa) * L
        q1_shape(2.0 * (A0 + s * t0 - fp[F_X0C]) / hx - 1.0, 2.0 * (A1 + s * t1 - fp[F_Y0C]) / hy - 1.0, N, dN)
        for A in range(4):
            dNx[A, 0] = dN[A, 0] * 2.0 / hx
            dNx[A, 1] = dN[A, 1] * 2.0 / hy
        cell_density(N, dNx, hx, hy, Ve, Vo, Pe, Vb, gv, go, fprm, bq[g, 0], bq[g, 1], sp, dens)
        for r in range(12):
            f = -w * dens[r]
            K[OFF_CELL + r, 2 * ia] += f * (1.0 - s) * n0
            K[OFF_CELL + r, 2 * ia + 1] += f * (1.0 - s) * n1
            K[OFF_CELL + r, 2 * ib] += f * s * n0
            K[OFF_CELL + r, 2 * ib + 1] += f * s * n1


_SLOT_OFFSET = np.array([0, 2, 4, 6, 8, 10, 12, 14, 16, 19, 22, 25, 28, 31, 34, 37, 40, 42, 44, 46, 48, 50, 52, 54])
SLOT_NDOF = np.array([2, 2, 2, 2, 2, 2, 2, 2, 3, 3, 3, 3, 3, 3, 3, 3, 2, 2, 2, 2, 2, 2, 2, 2])


def assemble_pieces(z_all, ip_all, fp_all, Xo_all, prmo_all, Xm_all, prmm_all, W_all, vq_all, kap_all, Xe_all,
                    We_all, vqe_all, Vo_all, Vb_all, bq_all, fprm, shape, mu, sym, sadj, variant33, w_p, w_t, w_c, gp, gw,
                    conn, pos, data, rhs, row_base, row_len, start, ndof, want_matrix, out_all):
    """Add every piece: its residual and the Jacobian — complex step over its local solid
    unknowns, real differences over its fluid unknowns (the residual is affine in them),
    plus (``shape``) the derivative of the fluid bulk integrals with respect to the position of
    Γ^FS (:func:`add_bulk_shape_derivative`).

    ``conn[k]`` holds the global nodes of the ``N_SLOTS`` node slots (-1: slot absent); local
    rows and columns are compacted to the present slots before :func:`add_local`. The pieces
    are evaluated in parallel (numba threads, :func:`_piece_locals`) and added to the global
    arrays one after the other in piece order (:func:`_add_pieces`), so the sums do not depend
    on the number of threads. The local Jacobians are kept compacted (``m × m`` for the ``m``
    unknowns of a piece's present slots, one after the other in ``K_live``): a full ``N_LOCAL²``
    block per piece was 8 times the memory, written and read again in every assembly."""
    n = len(ip_all)
    R_all = np.zeros((n, N_LOCAL))
    sizes = _live_counts(conn) ** 2 if want_matrix else np.zeros(n, dtype=np.int64)
    k_off = np.zeros(n + 1, dtype=np.int64)
    np.cumsum(sizes, out=k_off[1:])
    K_live = np.empty(k_off[-1])
    used = np.zeros(n, dtype=np.bool_)
    try:
        _piece_locals(z_all, ip_all, fp_all, Xo_all, prmo_all, Xm_all, prmm_all, W_all, vq_all, kap_all, Xe_all,
                      We_all, vqe_all, Vo_all, Vb_all, bq_all, fprm, shape, mu, sym, sadj, variant33, w_p, w_t, w_c, gp, gw,
                      conn, want_matrix, out_all, R_all, K_live, k_off, used)
    except SystemError as exc:
        # numba passes an exception of a parallel worker on as SystemError with the original as
        # its context: an arithmetic failure is an iterate the model cannot evaluate, and Newton
        # must see it as such (backtracking, then a step cut) instead of stopping the run
        if isinstance(exc.__context__, ArithmeticError):
            raise exc.__context__ from None
        raise
    _add_pieces(conn, pos, R_all, K_live, k_off, used, data, rhs, row_base, row_len, start, ndof, want_matrix)


@njit(cache=True)
def _live_counts(conn):
    """Number of local unknowns of the present slots of every piece."""
    out = np.zeros(conn.shape[0], dtype=np.int64)
    for k in range(conn.shape[0]):
        for slot in range(N_SLOTS):
            if conn[k, slot] >= 0:
                out[k] += SLOT_NDOF[slot]
    return out


@njit(cache=True)
def _live_columns(conn_k, idx):
    """Local indices of the unknowns of the present slots of one piece into ``idx``; their number."""
    m = 0
    for slot in range(N_SLOTS):
        if conn_k[slot] >= 0:
            for c in range(SLOT_NDOF[slot]):
                idx[m] = _SLOT_OFFSET[slot] + c
                m += 1
    return m


@njit(cache=True)
def _finish_local(Kf, shape, z, ip, fp, Xo, Xm, Xe, Vo, Vb, bq, fprm, gp, gw, idx, m, Kc):
    """Add the bulk shape derivative (``shape``) to a piece's full local Jacobian ``Kf`` and
    store it compacted to its ``m`` live unknowns ``idx`` in ``Kc`` (row-major)."""
    if shape:
        add_bulk_shape_derivative(Kf, z, ip, fp, Xo, Xm, Xe, Vo, Vb, bq, fprm, gp, gw)
    for ii in range(m):
        for jj in range(m):
            Kc[ii * m + jj] = Kf[idx[ii], idx[jj]]


@njit(cache=True, parallel=True)
def _piece_locals(z_all, ip_all, fp_all, Xo_all, prmo_all, Xm_all, prmm_all, W_all, vq_all, kap_all, Xe_all,
                  We_all, vqe_all, Vo_all, Vb_all, bq_all, fprm, shape, mu, sym, sadj, variant33, w_p, w_t, w_c, gp, gw,
                  conn, want_matrix, out_all, R_all, K_live, k_off, used):
    """Residual ``R_all[k]`` and the local Jacobian of every piece, compacted to the unknowns of
    its present slots (row-major into ``K_live[k_off[k]:k_off[k + 1]]``); ``used[k]`` False for a
    piece that contributes nothing."""
    for k in prange(len(ip_all)):
        z = z_all[k]
        if (ip_all[k, I_FLAGS] & MOUTH) != 0:
            # a closed film's mouth: nothing in the residual, the bulk shape derivative in the Jacobian
            used[k] = want_matrix and shape
            R_all[k, :] = 0.0
            if used[k]:
                idx = np.empty(N_LOCAL, dtype=np.int64)
                m = _live_columns(conn[k], idx)
                _finish_local(np.zeros((N_LOCAL, N_LOCAL)), True, z, ip_all[k], fp_all[k], Xo_all[k], Xm_all[k],
                              Xe_all[k], Vo_all[k], Vb_all[k], bq_all[k], fprm, gp, gw, idx, m,
                              K_live[k_off[k]:k_off[k + 1]])
            continue
        r = np.empty(N_LOCAL)
        out = out_all[k]
        used[k] = piece_residual(z, r, out, ip_all[k], fp_all[k], Xo_all[k], prmo_all[k], Xm_all[k],
                                 prmm_all[k], W_all[k], vq_all[k], kap_all[k], Xe_all[k], We_all[k], vqe_all[k], mu,
                                 sym, sadj, variant33, w_p, w_t, w_c, gp, gw, np.empty(0, dtype=np.int64))
        if not used[k]:
            continue
        R_all[k, :] = r
        if want_matrix:
            idx = np.empty(N_LOCAL, dtype=np.int64)
            m = _live_columns(conn[k], idx)
            rc = np.empty(N_LOCAL, dtype=np.complex128)
            zc = np.empty(N_LOCAL, dtype=np.complex128)
            rr = np.empty(N_LOCAL)
            zr = np.empty(N_LOCAL)
            dummy = np.empty((len(gp), N_OUT))
            cases = np.empty(len(gp), dtype=np.int64)
            for g in range(len(gp)):
                cases[g] = int(out[g, O_CASE])
            Kf = np.empty((N_LOCAL, N_LOCAL))  # every column of a present slot is filled below
            # in steady flow γ^F depends on the largest of the cell's velocities (a large step in
            # any of them makes it that one): affine in the pressures only
            affine_v = fp_all[k, F_GAMV] == 0.0
            for jj in range(m):
                j = idx[jj]
                if OFF_CELL <= j < OFF_EDGE and (affine_v or (j - OFF_CELL) % 3 == 2):
                    # a fluid unknown (cell or extension cell): with the case of every point fixed
                    # the residual is affine in these, so a real difference is their exact column
                    # at about half the cost of a complex evaluation; a large step makes its
                    # round-off relative to the column, not to the residual
                    for l in range(N_LOCAL):
                        zr[l] = z[l]
                    zr[j] = z[j] + AFFINE_STEP
                    step = zr[j] - z[j]
                    piece_residual(zr, rr, dummy, ip_all[k], fp_all[k], Xo_all[k], prmo_all[k], Xm_all[k],
                                   prmm_all[k], W_all[k], vq_all[k], kap_all[k], Xe_all[k], We_all[k], vqe_all[k], mu,
                                   sym, sadj, variant33, w_p, w_t, w_c, gp, gw, cases)
                    for l in range(N_LOCAL):
                        Kf[l, j] = (rr[l] - r[l]) / step
                    continue
                for l in range(N_LOCAL):
                    zc[l] = z[l]
                zc[j] += 1j * CS_STEP
                piece_residual(zc, rc, dummy, ip_all[k], fp_all[k], Xo_all[k], prmo_all[k], Xm_all[k], prmm_all[k],
                               W_all[k], vq_all[k], kap_all[k], Xe_all[k], We_all[k], vqe_all[k], mu, sym, sadj,
                               variant33, w_p, w_t, w_c, gp, gw, cases)
                for l in range(N_LOCAL):
                    Kf[l, j] = rc[l].imag / CS_STEP
            _finish_local(Kf, shape, z, ip_all[k], fp_all[k], Xo_all[k], Xm_all[k], Xe_all[k], Vo_all[k], Vb_all[k],
                          bq_all[k], fprm, gp, gw, idx, m, K_live[k_off[k]:k_off[k + 1]])


@njit(cache=True)
def _add_pieces(conn, pos, R_all, K_live, k_off, used, data, rhs, row_base, row_len, start, ndof, want_matrix):
    """Add the local residuals and (compacted) Jacobians piece by piece."""
    idx = np.empty(N_LOCAL, dtype=np.int64)
    none = np.zeros((0, 0))
    for k in range(len(used)):
        if not used[k]:
            continue
        m = _live_columns(conn[k], idx)
        Re = np.empty(m)
        for i in range(m):
            Re[i] = R_all[k, idx[i]]
        Ke = K_live[k_off[k]:k_off[k + 1]].reshape((m, m)) if want_matrix else none
        add_local(data, rhs, row_base, row_len, start, ndof, conn[k], pos[k], Ke, Re, want_matrix)
