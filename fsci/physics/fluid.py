"""Incompressible Navier-Stokes on the rectilinear background grid (paper (22), Sec. 3.1-3.1.1).

Unknowns per ACTIVE node: ``v_x, v_y, p``. One-step-theta residual (momentum, continuity)::

    R_v = rho/dt (v - v_n, dv) + theta a(v; dv) + (1 - theta) a(v_n; dv) - (p, div dv) - (f, dv)
    R_p = (div v, dp) + s_p(p, dp)
    a(v; dv) = (rho v.grad v, dv) + (mu (grad v + s grad v^T), grad dv)

``s = 1`` is the symmetric (2 mu eps) form of (22), ``s = 0`` the Laplace form whose natural
outflow condition is the DFG/Turek "do-nothing" condition ``nu d_n v - p n = 0``.

Cells are integrated with whatever quadrature the caller passes (tensor Gauss on uncut cells,
polygon rules on the PHYSICAL part of cut cells): the kernel never cuts anything.

Face stabilisation (25), (26) on interior faces between ACTIVE cells, with 4C's
``Schott_Massing_Burman_DAngelo_Zunino`` scalings (see docs/architecture.md)::

    s(v, p; dv, dp) = sum_F ∫_F tau_v [[d_n v]].[[d_n dv]] + tau_div [[div v]][[div dv]]
                               + tau_p [[d_n p]][[d_n dp]]
    regime = nu + 10 h |u|_max + h^2/(12 dt)
    tau_u = rho gamma_u |u.n|^2 h^3 / regime,  tau_div = rho gamma_div regime h,
    tau_p = gamma_p h^3 / (rho regime),  tau_gp = gamma_gp rho nu h + gamma_gp,t rho h^3/dt
    tau_v = tau_u (+ w_F tau_gp on ghost-penalty faces, w_F in (0, 1], see CutState.ghost_weights)

For continuous Q1 functions on straight faces only the normal derivative jumps, so the full
gradient jump [[grad v]] of 4C equals [[d_n v]] ⊗ n. The velocities in the scalings are a
*frozen* field (the state at the start of the step, or of the outer iteration for steady
problems), so the face terms are linear and their Jacobian is exact.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from fsci.fem.q1 import q1_shape
from fsci.fem.sparse import add_local

# indices into the parameter vector of the cell kernel (N_CELL_PARAMETERS entries)
P_RHO, P_MU, P_SYM, P_MASS, P_THETA, P_RESIDUAL, P_LINEAR = range(7)
N_CELL_PARAMETERS = 7  # P_LINEAR as S_LINEAR of the faces
# constant of the inverse estimate in the residual-based τ (Bazilevs et al. 2007, linear elements)
C_INV = 36.0
# indices into the parameter vector of the face kernel
S_RHO, S_MU, S_GU, S_GP, S_GDIV, S_GGP, S_GGPT, S_DTINV, S_LINEAR = range(9)
# S_LINEAR != 0: the scalings' velocity is the unknown velocity itself (steady flow), and their
# derivative belongs in the Jacobian


@njit(cache=True, inline="always")
def _cell_geometry(xs, ys, nx, c):
    i = c % nx
    j = c // nx
    return xs[i], ys[j], xs[i + 1] - xs[i], ys[j + 1] - ys[j]


@njit(cache=True)
def galerkin_density(N, dNx, Ve, Voe, Pe, gv, go, prm, b0, b1, out):
    """Integrand of the Galerkin residual (22) at one point for the 12 test functions of a cell
    (``out[3a + i]``: momentum of node a, component i; ``out[3a + 2]``: continuity), before the
    quadrature weight. ``N``, ``dNx``: shape functions and physical gradients at the point;
    ``Ve``, ``Voe``, ``Pe``: current and previous velocity, pressure at the nodes; ``b``: the
    (time-weighted) body force density. Fills ``gv`` and ``go`` with the current and previous
    velocity gradient; returns the current and previous velocity and the pressure."""
    rho = prm[P_RHO]
    mu = prm[P_MU]
    sym = prm[P_SYM]
    mc = prm[P_MASS]
    th = prm[P_THETA]
    v0 = 0.0
    v1 = 0.0
    vo0 = 0.0
    vo1 = 0.0
    p = 0.0
    gv[:] = 0.0
    go[:] = 0.0
    for a in range(4):
        v0 += N[a] * Ve[a, 0]
        v1 += N[a] * Ve[a, 1]
        vo0 += N[a] * Voe[a, 0]
        vo1 += N[a] * Voe[a, 1]
        p += N[a] * Pe[a]
        for j in range(2):
            gv[0, j] += Ve[a, 0] * dNx[a, j]
            gv[1, j] += Ve[a, 1] * dNx[a, j]
            go[0, j] += Voe[a, 0] * dNx[a, j]
            go[1, j] += Voe[a, 1] * dNx[a, j]
    go00 = go[0, 0]
    go01 = go[0, 1]
    go10 = go[1, 0]
    go11 = go[1, 1]
    div = gv[0, 0] + gv[1, 1]
    conv0 = v0 * gv[0, 0] + v1 * gv[0, 1]
    conv1 = v0 * gv[1, 0] + v1 * gv[1, 1]
    convo0 = vo0 * go00 + vo1 * go01
    convo1 = vo0 * go10 + vo1 * go11
    for a in range(4):
        ra = 3 * a
        # momentum, component 0 then 1
        visc = (gv[0, 0] + sym * gv[0, 0]) * dNx[a, 0] + (gv[0, 1] + sym * gv[1, 0]) * dNx[a, 1]
        visco = (go00 + sym * go00) * dNx[a, 0] + (go01 + sym * go10) * dNx[a, 1]
        out[ra] = (mc * (v0 - vo0) * N[a] + th * (rho * conv0 * N[a] + mu * visc)
                   + (1.0 - th) * (rho * convo0 * N[a] + mu * visco) - p * dNx[a, 0] - b0 * N[a])
        visc = (gv[1, 0] + sym * gv[0, 1]) * dNx[a, 0] + (gv[1, 1] + sym * gv[1, 1]) * dNx[a, 1]
        visco = (go10 + sym * go01) * dNx[a, 0] + (go11 + sym * go11) * dNx[a, 1]
        out[ra + 1] = (mc * (v1 - vo1) * N[a] + th * (rho * conv1 * N[a] + mu * visc)
                       + (1.0 - th) * (rho * convo1 * N[a] + mu * visco) - p * dNx[a, 1] - b1 * N[a])
        # continuity
        out[ra + 2] = div * N[a]
    return v0, v1, vo0, vo1, p


# sign of the mixed derivative d²N_a/dξdη of the four Q1 shape functions (times 1/4)
_MIXED = np.array([1.0, -1.0, 1.0, -1.0])


@njit(cache=True)
def residual_stabilization_density(dNx, hx, hy, v0, v1, vo0, vo1, Ve, Voe, Pe, Vbe, gv, go, prm, b0, b1, sp, out):
    """Add to ``out`` the integrand of the residual-based bulk stabilisation (``scheme =
    "residual"``, the alternative to CIP (25) on every face)::

        τ_M (ū·∇w + ∇q / ρ) · R_M(v, p) + ρ ν_C (div w)(div v)

    (SUPG, PSPG and grad-div terms; Tezduyar 1991, Bazilevs et al. 2007), with the strong
    momentum residual of the θ-step (pressure and continuity implicit as in (22))::

        R_M = ρ/Δt (v - v_n) + θ (ρ v·∇v - μ ∇·(∇v + s ∇vᵀ)) + (1 - θ) (same at v_n) + ∇p - b

    On a Q1 cell with sides ``hx, hy`` the Laplacian vanishes and ∇·∇vᵀ = ∇ div v reduces to the
    mixed derivatives. With the metric G = diag(4/hx², 4/hy²)::

        τ_M = ((2/Δt)² + ū·G ū + C_INV ν² G:G)^(-1/2),   ν_C = (h/2)|ū| min(1, |ū| h / (6ν))

    ``ū`` is the stabilisation velocity (``Vbe`` at the nodes; the face scalings use the same
    field) at the cell centre, so τ, ν_C and the streamline direction are constants of the
    cell, and the integrand stays a polynomial that the cut-cell quadrature integrates exactly
    (which makes the shape derivative of the cut exact). In a time step ``ū`` is the last
    step's, independent of the unknowns; in steady flow it is the unknown velocity's and the
    Jacobian adds :func:`_scalings_derivative`. The point
    values ``v``, ``vo`` and gradients ``gv``, ``go`` are those :func:`galerkin_density` computed.
    Fills ``sp`` with (τ_M, ν_C, ū_x, ū_y, R_M,x, R_M,y, div v) for the Jacobian."""
    rho = prm[P_RHO]
    mu = prm[P_MU]
    sym = prm[P_SYM]
    mc = prm[P_MASS]
    th = prm[P_THETA]
    dxy = 1.0 / (hx * hy)
    ub0 = 0.0
    ub1 = 0.0
    m0 = 0.0
    m1 = 0.0
    mo0 = 0.0
    mo1 = 0.0
    dp0 = 0.0
    dp1 = 0.0
    for a in range(4):
        ub0 += 0.25 * Vbe[a, 0]
        ub1 += 0.25 * Vbe[a, 1]
        m0 += _MIXED[a] * dxy * Ve[a, 0]
        m1 += _MIXED[a] * dxy * Ve[a, 1]
        mo0 += _MIXED[a] * dxy * Voe[a, 0]
        mo1 += _MIXED[a] * dxy * Voe[a, 1]
        dp0 += Pe[a] * dNx[a, 0]
        dp1 += Pe[a] * dNx[a, 1]
    g0 = 4.0 / (hx * hx)
    g1 = 4.0 / (hy * hy)
    nu = mu / rho
    dtinv = mc / rho
    tau = 1.0 / np.sqrt(4.0 * dtinv * dtinv + g0 * ub0 * ub0 + g1 * ub1 * ub1 + C_INV * nu * nu * (g0 * g0 + g1 * g1))
    # grad-div viscosity of Tezduyar & Osawa (2000): (h/2)|ū| min(1, Re_h/3), Re_h = |ū| h / (2ν),
    # h the cell diagonal; it vanishes where viscosity dominates (1/(τ tr G) would stay ≈ 4ν there
    # and bias the pressure at walls: DFG 2D-1 Δp 0.6 % off on every grid)
    speed = np.sqrt(ub0 * ub0 + ub1 * ub1)
    hd = np.sqrt(hx * hx + hy * hy)
    nuc = 0.5 * hd * speed * min(1.0, speed * hd / (6.0 * nu))
    # strong momentum residual; (∇ div v)_x = ∂xy v_y, (∇ div v)_y = ∂xy v_x on Q1
    conv0 = v0 * gv[0, 0] + v1 * gv[0, 1]
    conv1 = v0 * gv[1, 0] + v1 * gv[1, 1]
    convo0 = vo0 * go[0, 0] + vo1 * go[0, 1]
    convo1 = vo0 * go[1, 0] + vo1 * go[1, 1]
    r0 = (mc * (v0 - vo0) + th * (rho * conv0 - mu * sym * m1) + (1.0 - th) * (rho * convo0 - mu * sym * mo1)
          + dp0 - b0)
    r1 = (mc * (v1 - vo1) + th * (rho * conv1 - mu * sym * m0) + (1.0 - th) * (rho * convo1 - mu * sym * mo0)
          + dp1 - b1)
    div = gv[0, 0] + gv[1, 1]
    for a in range(4):
        supg = tau * (ub0 * dNx[a, 0] + ub1 * dNx[a, 1])
        out[3 * a] += supg * r0 + rho * nuc * dNx[a, 0] * div
        out[3 * a + 1] += supg * r1 + rho * nuc * dNx[a, 1] * div
        out[3 * a + 2] += tau / rho * (dNx[a, 0] * r0 + dNx[a, 1] * r1)
    sp[0] = tau
    sp[1] = nuc
    sp[2] = ub0
    sp[3] = ub1
    sp[4] = r0
    sp[5] = r1
    sp[6] = div


@njit(cache=True, inline="always")
def _scalings_derivative(dNx, hx, hy, nu, rho, sp, dS):
    """``dS[a, c, i]``: derivative by ū_c of the residual-based stabilisation's integrand
    ``3a + i`` of :func:`residual_stabilization_density` (filled ``sp``) through τ_M, ν_C and
    the streamline direction, for steady flow (no 1/Δt in τ_M), where ū is the unknown velocity."""
    tau, nuc, ub0, ub1, r0, r1, div = sp[0], sp[1], sp[2], sp[3], sp[4], sp[5], sp[6]
    g = (4.0 / (hx * hx), 4.0 / (hy * hy))
    ub = (ub0, ub1)
    speed = np.sqrt(ub0 * ub0 + ub1 * ub1)
    hd = np.sqrt(hx * hx + hy * hy)
    for c in range(2):
        dtau = -tau ** 3 * g[c] * ub[c]
        if speed * hd < 6.0 * nu:  # ν_C = hd² |ū|² / (12 ν)
            dnuc = hd * hd * ub[c] / (6.0 * nu)
        elif speed > 0.0:  # ν_C = hd |ū| / 2
            dnuc = 0.5 * hd * ub[c] / speed
        else:
            dnuc = 0.0
        for a in range(4):
            dsupg = dtau * (ub0 * dNx[a, 0] + ub1 * dNx[a, 1]) + tau * dNx[a, c]
            dS[a, c, 0] = dsupg * r0 + rho * dnuc * dNx[a, 0] * div
            dS[a, c, 1] = dsupg * r1 + rho * dnuc * dNx[a, 1] * div
            dS[a, c, 2] = dtau / rho * (dNx[a, 0] * r0 + dNx[a, 1] * r1)


@njit(cache=True)
def cell_density(N, dNx, hx, hy, Ve, Voe, Pe, Vbe, gv, go, prm, b0, b1, sp, out):
    """Integrand of the fluid cell terms at one point: the Galerkin terms (22)
    (:func:`galerkin_density`) plus, for ``scheme = "residual"``, the residual-based
    stabilisation (:func:`residual_stabilization_density`). One definition for the cell
    integrals and the shape derivative of the cut. Returns the velocity and pressure."""
    v0, v1, vo0, vo1, p = galerkin_density(N, dNx, Ve, Voe, Pe, gv, go, prm, b0, b1, out)
    if prm[P_RESIDUAL] != 0.0:
        residual_stabilization_density(dNx, hx, hy, v0, v1, vo0, vo1, Ve, Voe, Pe, Vbe, gv, go, prm, b0, b1, sp, out)
    return v0, v1, p


@njit(cache=True)
def assemble_fluid_cells(items, xs, ys, nx, conn, cell_ids, qptr, qx, qw, bq, V, P, Vo, Vbar, prm,
                         gnode, pos, data, rhs, row_base, row_len, start, ndof, want_matrix):
    """Add the cell terms (:func:`cell_density`) for the integration parts ``k`` in ``items``, in
    that order: background cell ``cell_ids[k]`` with the (virtual) nodes ``conn[k]`` of its
    fluid piece.

    ``qx[qptr[k]:qptr[k+1]]`` are the physical quadrature points of part ``k`` with
    weights ``qw`` and body force density ``bq`` (already multiplied by rho and time-weighted).
    ``V, P`` are the current and ``Vo`` the previous velocity on all virtual nodes, ``Vbar``
    the frozen stabilisation velocity.
    """
    rho = prm[P_RHO]
    mu = prm[P_MU]
    sym = prm[P_SYM]
    mc = prm[P_MASS]
    th = prm[P_THETA]
    residual = prm[P_RESIDUAL] != 0.0
    N = np.empty(4)
    dN = np.empty((4, 2))
    dNx = np.empty((4, 2))
    Ke = np.empty((12, 12))
    Re = np.empty(12)
    nodes = np.empty(4, dtype=np.int64)
    Ve = np.empty((4, 2))
    Voe = np.empty((4, 2))
    Vbe = np.empty((4, 2))
    Pe = np.empty(4)
    gv = np.empty((2, 2))
    go = np.empty((2, 2))
    dens = np.empty(12)
    sp = np.zeros(7)
    dR = np.empty((2, 12))  # derivative of the strong momentum residual by the 12 cell unknowns
    dS = np.empty((4, 2, 3))  # derivative of the three integrands of node a by ū_c (steady flow)
    linear = prm[P_LINEAR] != 0.0
    nu = mu / rho
    for k in items:
        c = cell_ids[k]
        x0, y0, hx, hy = _cell_geometry(xs, ys, nx, c)
        dxy = 1.0 / (hx * hy)
        for a in range(4):
            n = conn[k, a]
            nodes[a] = gnode[n]
            Ve[a, 0] = V[n, 0]
            Ve[a, 1] = V[n, 1]
            Voe[a, 0] = Vo[n, 0]
            Voe[a, 1] = Vo[n, 1]
            Vbe[a, 0] = Vbar[n, 0]
            Vbe[a, 1] = Vbar[n, 1]
            Pe[a] = P[n]
        Ke[:] = 0.0
        Re[:] = 0.0
        for q in range(qptr[k], qptr[k + 1]):
            r = 2.0 * (qx[q, 0] - x0) / hx - 1.0
            s = 2.0 * (qx[q, 1] - y0) / hy - 1.0
            q1_shape(r, s, N, dN)
            for a in range(4):
                dNx[a, 0] = dN[a, 0] * 2.0 / hx
                dNx[a, 1] = dN[a, 1] * 2.0 / hy
            w = qw[q]
            v0, v1, p = cell_density(N, dNx, hx, hy, Ve, Voe, Pe, Vbe, gv, go, prm, bq[q, 0], bq[q, 1], sp, dens)
            for a in range(12):
                Re[a] += w * dens[a]
            if want_matrix and residual:
                tau, nuc, ub0, ub1 = sp[0], sp[1], sp[2], sp[3]
                for b in range(4):
                    adv = v0 * dNx[b, 0] + v1 * dNx[b, 1]
                    for i in range(2):
                        for kk in range(2):
                            d = th * rho * N[b] * gv[i, kk]
                            if i == kk:
                                d += mc * N[b] + th * rho * adv
                            else:
                                d -= th * mu * sym * _MIXED[b] * dxy
                            dR[i, 3 * b + kk] = d
                        dR[i, 3 * b + 2] = dNx[b, i]
                for a in range(4):
                    supg = tau * (ub0 * dNx[a, 0] + ub1 * dNx[a, 1])
                    for cb in range(12):
                        Ke[3 * a, cb] += w * supg * dR[0, cb]
                        Ke[3 * a + 1, cb] += w * supg * dR[1, cb]
                        Ke[3 * a + 2, cb] += w * tau / rho * (dNx[a, 0] * dR[0, cb] + dNx[a, 1] * dR[1, cb])
                    for b in range(4):
                        for i in range(2):
                            for kk in range(2):
                                Ke[3 * a + i, 3 * b + kk] += w * rho * nuc * dNx[a, i] * dNx[b, kk]
                if linear:
                    _scalings_derivative(dNx, hx, hy, nu, rho, sp, dS)
                    # ū is the mean of the four nodal velocities: d/dV[b, c] = d/dū_c / 4
                    for a in range(4):
                        for i in range(3):
                            for b in range(4):
                                for kk in range(2):
                                    Ke[3 * a + i, 3 * b + kk] += 0.25 * w * dS[a, kk, i]
            if want_matrix:
                for a in range(4):
                    ra = 3 * a
                    for b in range(4):
                        cb = 3 * b
                        adv = v0 * dNx[b, 0] + v1 * dNx[b, 1]
                        lap = dNx[a, 0] * dNx[b, 0] + dNx[a, 1] * dNx[b, 1]
                        diag = mc * N[a] * N[b] + th * (rho * adv * N[a] + mu * lap)
                        for i in range(2):
                            Ke[ra + i, cb + i] += w * diag
                            for kk in range(2):
                                Ke[ra + i, cb + kk] += w * th * (
                                    rho * N[b] * gv[i, kk] * N[a] + mu * sym * dNx[b, i] * dNx[a, kk]
                                )
                            Ke[ra + i, cb + 2] -= w * N[b] * dNx[a, i]
                            Ke[ra + 2, cb + i] += w * dNx[b, i] * N[a]
        add_local(data, rhs, row_base, row_len, start, ndof, nodes, pos[k], Ke, Re, want_matrix)


@njit(cache=True, inline="always")
def _face_map(d, rmap):
    """Positions in the six face nodes (:attr:`fsci.mesh.grid.Grid.face_nodes`) of the right/upper
    cell's four nodes."""
    if d == 0:
        rmap[0] = 1
        rmap[1] = 4
        rmap[2] = 5
        rmap[3] = 2
    else:
        rmap[0] = 3
        rmap[1] = 2
        rmap[2] = 4
        rmap[3] = 5


@njit(cache=True, inline="always")
def _normal_jump(d, gqg, hxl, hyl, hxr, hyr, rmap, N, dN, J, NL):
    """At the face's Gauss point ``gqg``: ``J`` the jump of the normal derivative of the six
    face nodes' shape functions (right/upper minus left/lower), ``NL`` the left/lower cell's
    shape functions there."""
    J[:] = 0.0
    # left/bottom parent: xi = +1 on the face (d=0) or eta = +1 (d=1)
    if d == 0:
        q1_shape(1.0, gqg, N, dN)
        for a in range(4):
            J[a] -= dN[a, 0] * 2.0 / hxl
            NL[a] = N[a]
        q1_shape(-1.0, gqg, N, dN)
        for a in range(4):
            J[rmap[a]] += dN[a, 0] * 2.0 / hxr
    else:
        q1_shape(gqg, 1.0, N, dN)
        for a in range(4):
            J[a] -= dN[a, 1] * 2.0 / hyl
            NL[a] = N[a]
        q1_shape(gqg, -1.0, N, dN)
        for a in range(4):
            J[rmap[a]] += dN[a, 1] * 2.0 / hyr


@njit(cache=True)
def assemble_fluid_faces(items, xs, ys, nx, fnodes, faces, ghost_weight, Vbar, V, P, prm, gnode, pos,
                         data, rhs, row_base, row_len, start, ndof, want_matrix):
    """Add CIP (25) and ghost-penalty (26) face terms of the faces ``f`` in ``items``, in that
    order; ``ghost_weight[f]`` scales the ghost
    penalty on face ``f`` (0: none; see :meth:`fsci.cut.state.CutState.ghost_weights`),
    ``fnodes[f]`` are the six (virtual) nodes of face ``f``'s two cells.

    The scalings of (25) are evaluated at the velocity ``Vbar``. With ``prm[S_LINEAR]`` set
    ``Vbar`` is the unknown velocity (steady flow) and the Jacobian gets the scalings'
    derivative: through ``u·n`` at the Gauss point and through ``|u|_max`` of the face's nodes,
    a maximum whose derivative is that of the component attaining it."""
    rho = prm[S_RHO]
    mu = prm[S_MU]
    nu = mu / rho
    linear = want_matrix and prm[S_LINEAR] != 0.0
    gq = np.array([-1.0 / np.sqrt(3.0), 1.0 / np.sqrt(3.0)])
    N = np.empty(4)
    dN = np.empty((4, 2))
    fn = np.empty(6, dtype=np.int64)
    rmap = np.empty(4, dtype=np.int64)
    nodes = np.empty(6, dtype=np.int64)
    J = np.empty(6)
    NL = np.empty(4)
    Ke = np.empty((18, 18))
    Re = np.empty(18)
    for f in items:
        cl = faces[f, 0]
        cr = faces[f, 1]
        d = faces[f, 2]
        _face_map(d, rmap)
        for a in range(6):
            fn[a] = fnodes[f, a]
            nodes[a] = gnode[fn[a]]
        _, _, hxl, hyl = _cell_geometry(xs, ys, nx, cl)
        _, _, hxr, hyr = _cell_geometry(xs, ys, nx, cr)
        if d == 0:
            h = max(hxl, hxr)
            flen = hyl
            nvec0 = 1.0
            nvec1 = 0.0
        else:
            h = max(hyl, hyr)
            flen = hxl
            nvec0 = 0.0
            nvec1 = 1.0
        umax = 0.0
        mcol = -1  # the unknown attaining |u|_max, and d|u|_max/d(that unknown)
        msign = 0.0
        for a in range(6):
            for c in range(2):
                if abs(Vbar[fn[a], c]) > umax:
                    umax = abs(Vbar[fn[a], c])
                    mcol = 3 * a + c
                    msign = 1.0 if Vbar[fn[a], c] > 0.0 else -1.0
        regime = nu + 10.0 * h * umax + h * h / 12.0 * prm[S_DTINV]
        tau_div = rho * prm[S_GDIV] * regime * h
        tau_p = prm[S_GP] * h ** 3 / (rho * regime)
        dregime = 10.0 * h * msign  # d regime / d(unknown mcol)
        tau_gp = ghost_weight[f] * (prm[S_GGP] * rho * nu * h + prm[S_GGPT] * rho * h ** 3 * prm[S_DTINV])
        Ke[:] = 0.0
        Re[:] = 0.0
        for g in range(2):
            _normal_jump(d, gq[g], hxl, hyl, hxr, hyr, rmap, N, dN, J, NL)
            un = 0.0
            for a in range(4):
                un += NL[a] * (Vbar[fn[a], 0] * nvec0 + Vbar[fn[a], 1] * nvec1)
            tau_u = rho * prm[S_GU] * un * un * h ** 3 / regime
            tau_v = tau_u + tau_gp
            w = 0.5 * flen
            jv0 = 0.0
            jv1 = 0.0
            jp = 0.0
            for b in range(6):
                jv0 += J[b] * V[fn[b], 0]
                jv1 += J[b] * V[fn[b], 1]
                jp += J[b] * P[fn[b]]
            jdiv = jv0 * nvec0 + jv1 * nvec1
            for a in range(6):
                Re[3 * a] += w * J[a] * (tau_v * jv0 + tau_div * jdiv * nvec0)
                Re[3 * a + 1] += w * J[a] * (tau_v * jv1 + tau_div * jdiv * nvec1)
                Re[3 * a + 2] += w * J[a] * tau_p * jp
            if want_matrix:
                for a in range(6):
                    for b in range(6):
                        jj = w * J[a] * J[b]
                        Ke[3 * a, 3 * b] += jj * (tau_v + tau_div * nvec0 * nvec0)
                        Ke[3 * a + 1, 3 * b + 1] += jj * (tau_v + tau_div * nvec1 * nvec1)
                        Ke[3 * a + 2, 3 * b + 2] += jj * tau_p
            if linear:
                # d tau_u = rho g_u h^3 (2 u_n du_n / regime - u_n^2 dregime / regime^2); u_n is
                # the normal component d of the left/lower cell's four nodes
                dun = 2.0 * rho * prm[S_GU] * un * h ** 3 / regime
                for a in range(6):
                    wj = w * J[a]
                    for b in range(4):
                        col = 3 * b + d
                        Ke[3 * a, col] += wj * jv0 * dun * NL[b]
                        Ke[3 * a + 1, col] += wj * jv1 * dun * NL[b]
                    if mcol >= 0:
                        dtv = -tau_u / regime * dregime
                        dtd = rho * prm[S_GDIV] * h * dregime
                        Ke[3 * a, mcol] += wj * (dtv * jv0 + dtd * jdiv * nvec0)
                        Ke[3 * a + 1, mcol] += wj * (dtv * jv1 + dtd * jdiv * nvec1)
                        Ke[3 * a + 2, mcol] -= wj * tau_p / regime * dregime * jp
        # n = (1, 0) or (0, 1): the n-n coupling of the divergence jump is within a component
        # (not so for the scalings' derivative)
        add_local(data, rhs, row_base, row_len, start, ndof, nodes, pos[f], Ke, Re, want_matrix, not linear)


@njit(cache=True)
def assemble_ghost_weight_motion(xs, ys, nx, fnodes, faces, face_of, dwdu, V, prm, conn, pos,
                                 data, rhs, row_base, row_len, start, ndof, want_matrix):
    """The ghost penalty's dependence on the body motion through its weight (decision 33): for
    every pair ``k`` of a face ``face_of[k]`` and an edge of a body, the derivative
    ``dwdu[k]`` (edge nodes × components) of the face's weight times the penalty's residual at
    unit weight, into the velocity rows of the face's six nodes and the edge nodes' columns.
    ``conn[k]``: the six face nodes, then the edge's two nodes (global). The residual is the
    fluid term's; only the matrix gets entries."""
    if not want_matrix:
        return
    rho = prm[S_RHO]
    nu = prm[S_MU] / rho
    gq = np.array([-1.0 / np.sqrt(3.0), 1.0 / np.sqrt(3.0)])
    N = np.empty(4)
    dN = np.empty((4, 2))
    rmap = np.empty(4, dtype=np.int64)
    J = np.empty(6)
    NL = np.empty(4)
    G = np.empty((6, 2))
    Ke = np.zeros((22, 22))
    Re = np.zeros(22)
    for k in range(len(face_of)):
        f = face_of[k]
        cl = faces[f, 0]
        cr = faces[f, 1]
        d = faces[f, 2]
        _face_map(d, rmap)
        _, _, hxl, hyl = _cell_geometry(xs, ys, nx, cl)
        _, _, hxr, hyr = _cell_geometry(xs, ys, nx, cr)
        h = max(hxl, hxr) if d == 0 else max(hyl, hyr)
        flen = hyl if d == 0 else hxl
        tau_gp = prm[S_GGP] * rho * nu * h + prm[S_GGPT] * rho * h ** 3 * prm[S_DTINV]  # at unit weight
        G[:] = 0.0
        for g in range(2):
            _normal_jump(d, gq[g], hxl, hyl, hxr, hyr, rmap, N, dN, J, NL)
            jv0 = 0.0
            jv1 = 0.0
            for b in range(6):
                jv0 += J[b] * V[fnodes[f, b], 0]
                jv1 += J[b] * V[fnodes[f, b], 1]
            for a in range(6):
                G[a, 0] += 0.5 * flen * tau_gp * J[a] * jv0
                G[a, 1] += 0.5 * flen * tau_gp * J[a] * jv1
        for a in range(6):
            for i in range(2):
                for c in range(4):
                    Ke[3 * a + i, 18 + c] = G[a, i] * dwdu[k, c]
        add_local(data, rhs, row_base, row_len, start, ndof, conn[k], pos[k], Ke, Re, want_matrix)


BLOCK = 8  # cells per side of an assembly block (from 2 on, blocks of one colour share no node)


def coloured_blocks(cell_ij: np.ndarray, block: int = BLOCK) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """An order of items (cell parts or faces) on the cells ``cell_ij`` ``(n, 2)`` (a face: its
    first cell, the left or lower one) for assembly in parallel: square blocks of ``block``
    cells, four colours in a 2×2 pattern, so that two blocks of one colour are ``block`` cells
    apart and their items (a part touches its cell, a face also the next cell) share no node.

    Returns
    -------
    order, bptr, cptr
        Items block by block (in their own order within a block), colour by colour; block
        ``b`` holds ``order[bptr[b]:bptr[b+1]]``, colour ``c`` the blocks ``cptr[c]:cptr[c+1]``.
    """
    b = np.asarray(cell_ij, dtype=np.int64).reshape(-1, 2) // block
    nbx = int(b[:, 0].max(initial=0)) + 1
    colour = (b[:, 0] % 2) + 2 * (b[:, 1] % 2)
    key = colour * (nbx * (int(b[:, 1].max(initial=0)) + 1)) + b[:, 1] * nbx + b[:, 0]
    order = np.argsort(key, kind="stable")
    keys, first = np.unique(key[order], return_index=True)
    bptr = np.append(first, len(order)).astype(np.int64)
    cptr = np.searchsorted(colour[order][first], np.arange(5)).astype(np.int64)
    return order.astype(np.int64), bptr, cptr


@njit(cache=True, parallel=True)
def assemble_cells_in_parallel(order, bptr, cptr, args):
    """:func:`assemble_fluid_cells` (arguments ``args`` after ``items``) block by block, the
    blocks of one colour in parallel (:func:`coloured_blocks`): every entry gets its terms in
    the order of ``order`` whatever the number of threads, as in one serial call on it."""
    for c in range(4):
        for b in prange(cptr[c], cptr[c + 1]):
            assemble_fluid_cells(order[bptr[b]:bptr[b + 1]], *args)


@njit(cache=True, parallel=True)
def assemble_faces_in_parallel(order, bptr, cptr, args):
    """:func:`assemble_fluid_faces` as :func:`assemble_cells_in_parallel`."""
    for c in range(4):
        for b in prange(cptr[c], cptr[c + 1]):
            assemble_fluid_faces(order[bptr[b]:bptr[b + 1]], *args)
