"""The coupling term: every body boundary coupled to what lies beyond it — fluid, another body,
or both (paper Sec. 3.2-3.4.4). Plain FSI and dry contact are its special cases.

Per geometry update (:meth:`CouplingTerm.pieces`) the body-boundary quadrature is built once
(:mod:`fsci.coupling.points`); per assembly the per-piece arrays are gathered and the traction
kernel (:mod:`fsci.coupling.traction`) adds residual and exact Jacobian.

Parameters per piece (fluid-sided, 4C's "xfluid" weighting, Remark 8):

* ``h_K`` = area / longest edge of the background cell (4C ``ele_vol_div_by_max_ele_surf``),
* ``γ^F = γ0^F (μ C_T / h_K + ρ |v|_∞ / 6 + ρ h_K / (12 θ Δt))`` (4C "full, sum"), ``|v|_∞``
  the largest velocity component of the fluid cell and the solid edge at the start of the step
  (frozen, so the Jacobian stays exact); the extension point uses its own cell's γ^F,
* ``a = h_K / (γ0^t C_T)`` for the Navier-slip coefficients (37),
* contact (Remark 7; 4C ``nitsche_weights_and_scaling``): per parent element of a contact edge
  ``φ = λ_max`` of ``∫_edge (n·σ(v)·n)² ds = λ ∫_element σ(v):ε(v) dV`` (v ⊥ rigid modes, small-
  strain tangent on the current shape, ≈ E/h), recomputed at the start of every step; harmonic
  weights ``ω_own = φ_opp/(φ_own + φ_opp)`` or ½; a rigid body has φ = ∞ and weight 0;
  ``γ^S = γ0^S (ω φ_own + (1 − ω) φ_opp)``,
* the slip length of the body: a number, ∞, an expression, or the gap law (40)
  (``slip_length = "gap_law"``, with ``κ0`` and ``h`` from ``[fluid.interface]``).

Time levels: the θ-weighted parts of the old level (see :mod:`fsci.coupling.traction`) are
evaluated at the start of a step on the converged state and its own cut, stored per node, and
added with weight 1 − θ.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from fsci.assembly import Assembly, ResidualAssembly
from fsci.coupling import traction as tk
from fsci.coupling.points import BoundaryOf, CouplingPieces, build_pieces
from fsci.cut.state import END_NODE0, END_NODE1, is_end_on_edge, is_moving_end
from fsci.cut.transfer import transfer_indices
from fsci.errors import InputError
from fsci.expressions import Expression
from fsci.fem.quadrature import gauss_line, gauss_quad
from fsci.fields import StepContext, time_weighted_vector
from fsci.physics import fluid as fk
from fsci.physics.fluid import N_CELL_PARAMETERS

GAP_LAW = "gap_law"
CASE_NAMES = ("I", "II", "III", "IV")
HOLD_AFTER_SWINGS = 2  # reversals of a dry edge's number of contact points in a step before it is held
_CORNERS = tk.CORNERS  # reference corners of the Q1 element, a constant of the kernels


def trace_constants(Xe: np.ndarray, edge: np.ndarray, E: float, nu: float) -> np.ndarray:
    """λ_max of the trace inequality of Q1 elements ``Xe (k, 4, 2)`` and one edge of each
    (local index ``edge (k,)``), plane strain, small-strain tangent (Remark 7):
    ``∫_edge (n·σ(v)·n)² ds = λ ∫_element σ(v):ε(v) dV`` for v ⊥ rigid-body modes."""
    k = len(Xe)
    if k == 0:
        return np.zeros(0)
    lam = E * nu / ((1 + nu) * (1 - 2 * nu))
    mu = E / (2 * (1 + nu))
    D = np.array([[lam + 2 * mu, lam, 0.0], [lam, lam + 2 * mu, 0.0], [0.0, 0.0, mu]])
    xi, w = gauss_quad(2)
    gx, gw = gauss_line(3)
    return _trace_constants(np.ascontiguousarray(Xe, dtype=np.float64), np.asarray(edge, dtype=np.int64), D,
                            xi, w, 0.5 * (gx + 1.0), 0.5 * gw)


@njit(cache=True, inline="always")
def _strain_matrix(X: np.ndarray, r: float, s: float, B: np.ndarray) -> float:
    """B (3, 8) of a Q1 element with corners ``X (4, 2)`` at (r, s) into ``B``; returns det J."""
    j00 = j01 = j10 = j11 = 0.0
    for a in range(4):
        dr = 0.25 * _CORNERS[a, 0] * (1.0 + _CORNERS[a, 1] * s)
        ds = 0.25 * _CORNERS[a, 1] * (1.0 + _CORNERS[a, 0] * r)
        j00 += dr * X[a, 0]
        j01 += dr * X[a, 1]
        j10 += ds * X[a, 0]
        j11 += ds * X[a, 1]
    det = j00 * j11 - j01 * j10
    B[:] = 0.0
    for a in range(4):  # dN/dx = J^-T (dN/dr, dN/ds)
        dr = 0.25 * _CORNERS[a, 0] * (1.0 + _CORNERS[a, 1] * s)
        ds = 0.25 * _CORNERS[a, 1] * (1.0 + _CORNERS[a, 0] * r)
        nx = (j11 * dr - j01 * ds) / det
        ny = (-j10 * dr + j00 * ds) / det
        B[0, 2 * a] = nx
        B[1, 2 * a + 1] = ny
        B[2, 2 * a] = ny
        B[2, 2 * a + 1] = nx
    return det


@njit(cache=True, inline="always")
def _largest_eigenvalue_3x3(M: np.ndarray) -> float:
    """Largest eigenvalue of a symmetric 3×3 matrix, closed form (the trigonometric solution of
    the characteristic cubic)."""
    p1 = M[0, 1] ** 2 + M[0, 2] ** 2 + M[1, 2] ** 2
    q = (M[0, 0] + M[1, 1] + M[2, 2]) / 3.0
    p2 = (M[0, 0] - q) ** 2 + (M[1, 1] - q) ** 2 + (M[2, 2] - q) ** 2 + 2.0 * p1
    if p2 <= 1e-30 * q * q:
        return q
    p = np.sqrt(p2 / 6.0)
    Bm = (M - q * np.eye(3)) / p
    r = 0.5 * (Bm[0, 0] * (Bm[1, 1] * Bm[2, 2] - Bm[1, 2] * Bm[2, 1])
               - Bm[0, 1] * (Bm[1, 0] * Bm[2, 2] - Bm[1, 2] * Bm[2, 0])
               + Bm[0, 2] * (Bm[1, 0] * Bm[2, 1] - Bm[1, 1] * Bm[2, 0]))
    phi = np.arccos(min(1.0, max(-1.0, r))) / 3.0
    return q + 2.0 * p * np.cos(phi)


@njit(cache=True)
def _trace_constants(Xe: np.ndarray, edge: np.ndarray, D: np.ndarray, xi: np.ndarray, w: np.ndarray,
                     s_line: np.ndarray, w_line: np.ndarray) -> np.ndarray:
    """Kernel of :func:`trace_constants`. Per element the stiffness K (2×2 Gauss) and the edge
    form A = C Cᵀ (3-point Gauss on the edge, C (8, 3)). Both vanish on the rigid-body modes
    R (8, 3), so on their complement the pencil (A, K) has the eigenvalues of (A, K + α R Rᵀ)
    for any α > 0, whose largest is that of the 3×3 matrix Cᵀ (K + α R Rᵀ)⁻¹ C."""
    k = Xe.shape[0]
    out = np.empty(k)
    B = np.empty((3, 8))
    R = np.zeros((8, 3))
    C = np.empty((8, 3))
    for e in range(k):
        X = Xe[e]
        K = np.zeros((8, 8))
        for q in range(xi.shape[0]):
            det = _strain_matrix(X, xi[q, 0], xi[q, 1], B)
            K += (w[q] * det) * (B.T @ (D @ B))
        a = edge[e]
        b = (a + 1) % 4
        tx = X[b, 0] - X[a, 0]
        ty = X[b, 1] - X[a, 1]
        L = np.sqrt(tx * tx + ty * ty)
        nx, ny = ty / L, -tx / L
        proj = np.array([nx * nx, ny * ny, 2.0 * nx * ny])
        for q in range(s_line.shape[0]):
            t = s_line[q]
            r = (1 - t) * _CORNERS[a, 0] + t * _CORNERS[b, 0]
            s = (1 - t) * _CORNERS[a, 1] + t * _CORNERS[b, 1]
            _strain_matrix(X, r, s, B)
            C[:, q] = np.sqrt(w_line[q] * L) * (proj @ (D @ B))
        cx = 0.25 * (X[0, 0] + X[1, 0] + X[2, 0] + X[3, 0])
        cy = 0.25 * (X[0, 1] + X[1, 1] + X[2, 1] + X[3, 1])
        for i in range(4):  # translations and the (infinitesimal) rotation about the centroid
            R[2 * i, 0] = 0.5
            R[2 * i + 1, 1] = 0.5
            R[2 * i, 2] = -(X[i, 1] - cy)
            R[2 * i + 1, 2] = X[i, 0] - cx
        R[:, 2] /= np.sqrt(np.sum(R[:, 2] ** 2))
        Kr = K + (np.trace(K) / 8.0) * (R @ R.T)
        out[e] = _largest_eigenvalue_3x3(C.T @ np.linalg.solve(Kr, C))
    return out


@njit(cache=True, inline="always")
def _solid_velocity_terms(nodes, Un, Vn, motion, c_new, coef, W):
    """The solid velocity terms ``W (2, 2)`` of an edge's two ``nodes`` (see :func:`_gather_own`):
    ``c_new U_n + coef V_n`` for ``motion`` 1, ``-V_n`` for 2, untouched for 0."""
    for a in range(2):
        for i in range(2):
            if motion == 1:
                W[a, i] = c_new * Un[nodes[a], i] + coef * Vn[nodes[a], i]
            elif motion == 2:
                W[a, i] = -Vn[nodes[a], i]


@njit(cache=True)
def _gather_own(m, edge, ext_edge, has_opp, has_ext, cell_of, local_of, edges_of, cells, X, gnode, Un, Vn, base,
                law, prm, motion, c_new, coef, zidx, conn, ip, fp, Xo, prmo, W, Xe, We, vmax_s):
    """The slots of the pieces ``m`` of one body that come from the body itself
    (:meth:`CouplingTerm._gather_static`): its element of each piece's coupling edge (reference
    coordinates, local unknowns; global nodes of the edge's two nodes, or of all four where the
    piece has an opposite segment, whose stress needs the whole element), the largest solid
    velocity component of the edge at the step's start, and the edge of an extension point.
    ``motion`` 1: the solid velocity terms of the new time level (``W = c_new U_n + coef V_n``),
    2: of the old level (``W = -V_n``), 0: none (a prescribed interface velocity, steady flow).
    ``cell_of``, ``local_of``, ``edges_of``: element, local edge and nodes of every coupling edge."""
    for j in range(len(m)):
        k = m[j]
        ce = edge[k]
        c = cell_of[ce]
        eo = local_of[ce]
        ip[k, tk.I_EO] = eo
        ip[k, tk.I_LAWO] = law
        prmo[k, 0] = prm[0]
        prmo[k, 1] = prm[1]
        for a in range(4):
            n = cells[c, a]
            for i in range(2):
                Xo[k, a, i] = X[n, i]
                zidx[k, 2 * a + i] = base + 2 * n + i
            conn[k, a] = gnode[n] if has_opp[k] or a == eo or a == (eo + 1) % 4 else -1
        vmax = 0.0
        for a in range(2):
            for i in range(2):
                vmax = max(vmax, abs(Vn[edges_of[ce, a], i]))
        vmax_s[k] = vmax
        _solid_velocity_terms(edges_of[ce], Un, Vn, motion, c_new, coef, W[k])
        if motion == 1:
            fp[k, tk.F_CU] = c_new
        if not has_ext[k]:
            continue
        ee = ext_edge[k]
        for a in range(2):
            n = edges_of[ee, a]
            conn[k, 16 + a] = gnode[n]
            for i in range(2):
                Xe[k, a, i] = X[n, i]
                zidx[k, tk.OFF_EDGE + 2 * a + i] = base + 2 * n + i
        _solid_velocity_terms(edges_of[ee], Un, Vn, motion, c_new, coef, We[k])
        if motion == 1:
            fp[k, tk.F_CUE] = c_new


@njit(cache=True)
def _gather_cells(sel, parts, nodes, n_cells, gnode, fbase, xs, ys, cell_ij, cell_size, slot, off, cols, Vbar,
                  vmax_s, transient, gam_prm, conn, zidx, fp, hk):
    """The fluid slots of the pieces ``sel`` in the fluid parts ``parts`` (virtual nodes
    ``nodes``; :meth:`CouplingTerm._gather_static`): global nodes from ``slot``, local unknowns
    from ``off``, and into the columns ``cols`` of ``fp`` the cell's lower-left corner, its
    sides and γ^F (module docstring; ``gam_prm``: γ0 μ C_T, γ0, μ C_T, ρ, γ0 ρ, 12 θ Δt, each
    multiplied in the formula's order). In a time step |v|_∞ is the largest of the frozen
    stabilisation velocity at the cell's nodes and ``vmax_s`` of the piece; in steady flow
    γ^F's convective part is the kernel's (at the unknowns). ``hk`` receives h_K."""
    for j in range(len(sel)):
        k = sel[j]
        c = parts[j] % n_cells
        vmax = 0.0
        for a in range(4):
            n = nodes[j, a]
            conn[k, slot + a] = gnode[n]
            for i in range(3):
                zidx[k, off + 3 * a + i] = fbase + 3 * n + i
            for i in range(2):
                vmax = max(vmax, abs(Vbar[n, i]))
        hx = cell_size[c, 0]
        hy = cell_size[c, 1]
        fp[k, cols[0]] = xs[cell_ij[c, 0]]
        fp[k, cols[1]] = ys[cell_ij[c, 1]]
        fp[k, cols[2]] = hx
        fp[k, cols[3]] = hy
        h = hx * hy / max(hx, hy)
        hk[j] = h
        if not transient:
            fp[k, cols[4]] = gam_prm[0] / h
            continue
        vmax = max(vmax, vmax_s[k])
        gam = gam_prm[1] * (gam_prm[2] / h + gam_prm[3] * vmax / 6.0)
        fp[k, cols[4]] = gam + gam_prm[4] * h / gam_prm[5]


class CouplingTerm:
    """Coupling of all body boundaries (FSI, contact, FSCI) in one residual term."""

    def __init__(self, system) -> None:
        p = system.problem
        self.names = [s.name for s in system.solids]
        self.contact = p.contact
        f = system.fluid
        self.iset = f.spec.interface if f is not None else None
        self.sadj = -1.0 if self.iset is None or self.iset.adjoint == "skew" else 1.0
        self.variant33 = self.iset is not None and self.iset.case_iii == "original"
        x, w = gauss_line(self.contact.n_gauss)
        self.gp, self.gw = 0.5 * (x + 1.0), 0.5 * w
        self._edges, self._cell, self._local, self._contact = [], [], [], []
        for i, s in enumerate(system.solids):
            if f is not None:
                edges = system.interface_edges[i]
            elif s.body.contact:
                edges = np.vstack([s.mesh.edge_sets[n] for n in s.body.contact])
            else:
                edges = np.zeros((0, 2), dtype=np.int64)
            cell, local = s.mesh.parent_of_edges(edges) if len(edges) else (np.zeros(0, np.int64),) * 2
            self._edges.append(edges)
            self._cell.append(cell)
            self._local.append(local)
            self._contact.append(self._contact_indices(i, s, edges))
        n_contact = sum(len(c) > 0 for c in self._contact)
        if n_contact == 1 and not self.contact.self_contact:
            i = next(k for k, c in enumerate(self._contact) if len(c))
            raise InputError(f"bodies[{i}].contact", system.solids[i].body.contact,
                             "contact surfaces on a second body to touch (no other body has 'contact'; "
                             "or set contact.self_contact = true)")
        lengths = [np.linalg.norm(s.X[e[c, 1]] - s.X[e[c, 0]], axis=1).max()
                   for s, e, c in zip(system.solids, self._edges, self._contact) if len(c)]
        radius = self.contact.search_radius if self.contact.search_radius > 0 else 2.0 * max(lengths, default=0.0)
        self.slip_h = 0.0
        if any(s.body.slip_length == GAP_LAW for s in system.solids):
            g = f.grid
            self.slip_h = self.iset.slip_h if self.iset.slip_h > 0 else float(g.cell_size.max())
            radius = max(radius, 1.01 * self.slip_h)  # the law (40) needs the gap up to h
        self.radius = radius
        self._key = None
        self._pieces: CouplingPieces | None = None
        self._ghost: tuple[object, tuple[np.ndarray, np.ndarray, np.ndarray] | None] = (None, None)
        self._data_key = None
        self._data: dict | None = None
        self._old: dict[str, np.ndarray] | None = None
        self.out = np.zeros((0, len(self.gp), tk.N_OUT))
        self._out_body = np.zeros(0, dtype=np.int64)
        self._out_edge = np.zeros(0, dtype=np.int64)
        self._out_dry = np.zeros(0, dtype=bool)
        self._edge_offset = np.concatenate([[0], np.cumsum([len(e) for e in self._edges])]).astype(np.int64)
        self._reset_swings()
        self.update_penalty(system)

    def _reset_swings(self) -> None:
        """Per coupling edge (all bodies, concatenated): number of contact points at the last
        iteration, direction of its last change, reversals, seen; and the held edges."""
        n = int(self._edge_offset[-1])
        self._swing = np.zeros((n, 4), dtype=np.int64)
        self._held = np.zeros(n, dtype=bool)  # replaced (not changed in place) when it changes: a cache key
        self.swung = False  # an edge reversed HOLD_AFTER_SWINGS times in this attempt

    def track_case_swings(self, hold: bool) -> None:
        """After the assembly of a Newton iterate: count, per edge, the reversals of its number of
        contact points (case II); with ``hold`` (a step repeated after an attempt in which contact
        swung, decision 38) hold in contact, for the rest of the step, the dry points (Γ^SC, with
        an opposite surface, g_n <= 0) of every edge that reversed ``HOLD_AFTER_SWINGS`` times.
        Where the fluid traction extended to the two sides of a contact zone
        differs (each body's from its own wetted end), the switch (29) can have no solution near
        the state: on the pump's inflow valve at t = 0.28668 nine points of one flap went from
        case II to IV and back in every iteration (12, 21, 12, 20, ... contact points), down to
        steps of 3e-9. A held point gets the contact traction; the next step decides afresh.
        Not in a step's first attempt (:meth:`fsci.simulation.Simulation.advance` decides when
        to repeat one with the hold): on the r = 2 pump at t = 0.0386 a hold made the step of
        4e-4 converge with a mass-balance error of 4.3e-5 of the flux, where the two halves of
        the cut step converge freely at solver level."""
        dry = self._out_dry
        if not dry.any():
            return
        key = self._edge_offset[self._out_body[dry]] + self._out_edge[dry]
        n_contact = np.sum(self.out[dry][..., tk.O_CASE] == tk.CASE_II, axis=1)
        present = np.zeros(len(self._swing), dtype=bool)
        present[key] = True
        count = np.bincount(key, weights=n_contact, minlength=len(self._swing)).astype(np.int64)
        st = self._swing
        d = np.where(present & (st[:, 3] == 1), np.sign(count - st[:, 0]), 0)
        st[:, 2] += (d != 0) & (st[:, 1] != 0) & (d != st[:, 1])
        st[:, 1] = np.where(d != 0, d, st[:, 1])
        st[present, 0] = count[present]
        st[present, 3] = 1
        held = st[:, 2] >= HOLD_AFTER_SWINGS
        self.swung = bool(held.any())
        if hold and not np.array_equal(held, self._held):
            self._held = held

    @staticmethod
    def _contact_indices(i: int, s, edges: np.ndarray) -> np.ndarray:
        """Indices into the coupling edges of the body's contact edges."""
        if not s.body.contact:
            return np.zeros(0, dtype=np.int64)
        lookup = {(int(a), int(b)): k for k, (a, b) in enumerate(edges)}
        out = []
        for name in s.body.contact:
            for a, b in s.mesh.edge_sets[name]:
                k = lookup.get((int(a), int(b)), lookup.get((int(b), int(a))))
                if k is None:
                    raise InputError(f"bodies[{i}].contact", s.body.contact,
                                     f"edge set '{name}' must be part of the body's fluid interface "
                                     "(not loaded by a Neumann condition and listed in 'interface' if given)")
                out.append(k)
        return np.unique(np.asarray(out, dtype=np.int64))

    # ----------------------------------------------------------------- geometry
    def update_penalty(self, system) -> None:
        """Take the trace-inequality estimates φ of the contact elements (:meth:`penalty_scales`)
        at the current shape. They are computed when a piece with an opposite segment first needs
        them: most steps of a body falling through fluid have none."""
        self._phi_shape = [s.X + s.U for s in system.solids]
        self._phi = None

    def penalty_scales(self, system) -> list[np.ndarray]:
        """φ of every coupling edge of each body at the shape of the last :meth:`update_penalty`
        (∞ off the contact boundary and on rigid or prescribed bodies)."""
        if self._phi is None:
            self._phi = []
            for k, (s, x) in enumerate(zip(system.solids, self._phi_shape)):
                phi = np.full(len(self._edges[k]), np.inf)
                if len(self._contact[k]) and not (s.body.rigid or s.fixed.all()):
                    m = s.body.material
                    c = self._contact[k]
                    phi[c] = trace_constants(x[s.mesh.cells[self._cell[k][c]]], self._local[k][c], m.E, m.nu)
                self._phi.append(phi)
        return self._phi

    def _geometry_key(self, system) -> tuple:
        if system.fluid is not None:
            # the cut object itself, not its id(): a freed cut's id is reused by a new one
            return ("cut", system.cut)
        return ("dry",) + tuple(s.U.tobytes() for s, c in zip(system.solids, self._contact) if len(c))

    def pieces(self, system) -> CouplingPieces:
        """The coupling pieces of the current geometry (rebuilt with the cut; for dry contact
        whenever the displacements changed)."""
        key = self._geometry_key(system)
        if key != self._key:
            bnd = [BoundaryOf(s.X + s.U, e, c, l, k)
                   for s, e, c, l, k in zip(system.solids, self._edges, self._cell, self._local, self._contact)]
            st = self.contact
            self._pieces = build_pieces(bnd, system.cut if system.fluid is not None else None, self.radius,
                                        st.self_contact, st.split, st.n_fixed,
                                        self.iset is None or self.iset.extension)
            self._key = key
        return self._pieces

    def ghost_motion(self, system) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """Where the ghost penalty's weight of a face lies inside its ramp (decision 33), it
        moves with the body boundary in the cell that sets it: pairs of such a face and a wetted
        piece in that cell, as ``(face, dwdu, conn)``: the face (index into the fluid's
        faces), the weight's derivative with respect to the piece's edge nodes ``(k, 4)``, and
        the global nodes ``(k, 8)`` (the face's six, the edge's two); None without such faces.

        With σ = 1 - |K_fluid| / |K| the cell's solid fraction, a boundary moving by δu(s)
        along its outward normal n takes ``δσ = (1/|K|) ∫ δu·n ds`` from the fluid; on a piece
        of an edge a → b with ``δu = (1 - s) δu_a + s δu_b`` that is
        ``(L/|K|) n (∫(1 - s) ds, ∫ s ds)`` over the piece's parameter range. Per geometry."""
        f = system.fluid
        if f is None or not np.any(f.ghost_slope > 0.0):
            return None
        key = self._geometry_key(system)
        if self._ghost[0] is not None and self._ghost[0] == key:
            return self._ghost[1]
        pc = self.pieces(system)
        g = f.grid
        faces = np.nonzero(f.ghost_slope > 0.0)[0]
        wet = np.nonzero(pc.fs & ~pc.mouth)[0]
        wet = wet[[system.solids[b].has_dofs for b in pc.body[wet]]] if len(wet) else wet
        cell_of_piece = pc.cell[wet] % g.n_cells
        face_of, piece = [], []
        for k in faces:
            p = wet[cell_of_piece == f.ghost_cell[k]]
            face_of.append(np.full(len(p), k))
            piece.append(p)
        face_of = np.concatenate(face_of).astype(np.int64)
        piece = np.concatenate(piece).astype(np.int64)
        out = None
        if len(piece):
            dwdu = np.empty((len(piece), 4))
            conn = np.empty((len(piece), 8), dtype=np.int64)
            conn[:, :6] = f.gnode[f.face_nodes[face_of]]
            for b, s in enumerate(system.solids):
                m = np.nonzero(pc.body[piece] == b)[0]
                if not len(m):
                    continue
                e = self._edges[b][pc.edge[piece[m]]]
                x = s.X + s.U
                t = x[e[:, 1]] - x[e[:, 0]]
                L = np.linalg.norm(t, axis=1)
                n = np.column_stack([t[:, 1], -t[:, 0]]) / L[:, None]
                s0, s1 = pc.s0[piece[m]], pc.s1[piece[m]]
                half = 0.5 * (s1 * s1 - s0 * s0)
                cell = f.ghost_cell[face_of[m]]
                scale = f.ghost_slope[face_of[m]] * L / (g.cell_size[cell, 0] * g.cell_size[cell, 1])
                dwdu[m, :2] = (scale * (s1 - s0 - half))[:, None] * n
                dwdu[m, 2:] = (scale * half)[:, None] * n
                conn[m, 6:] = s.gnode[e]
            full = np.all(conn >= 0, axis=1)  # the kernel's local matrix has every slot (faces join ACTIVE cells)
            out = (face_of[full], dwdu[full], conn[full]) if full.any() else None
        self._ghost = (key, out)
        return out

    # ----------------------------------------------------------------- per-piece data
    def _weights(self, phi_o: np.ndarray, phi_m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Harmonic (or ½) weights ω_own and penalties γ^S (a rigid side has φ = ∞ and weight 0)."""
        g0 = self.contact.gamma0
        rigid_o, rigid_m = np.isinf(phi_o), np.isinf(phi_m)
        both = ~rigid_o & ~rigid_m
        w = np.where(rigid_m, 1.0, 0.0)
        pen = g0 * np.where(rigid_m, phi_o, phi_m)
        if both.any():
            po, pm = phi_o[both], phi_m[both]
            wb = np.full(len(po), 0.5) if self.contact.weighting == "half" else pm / (po + pm)
            w[both] = wb
            pen[both] = g0 * (wb * po + (1.0 - wb) * pm)
        return w, pen

    def gather(self, system, ctx: StepContext, level: str = "new") -> dict:
        """Kernel arrays of every piece. ``level`` "old": the solid velocity is the stored one
        (evaluation of the old time level at the converged state).

        Everything but the local unknowns ``z`` (and, where expressions are evaluated at the
        current Gauss points, the prescribed interface velocity, slip length and fluid body force)
        depends only on the pieces, the step and the step's frozen data; that part is gathered
        once per (pieces, step, level) and ``z`` is one indexed read of the state per call."""
        f = system.fluid
        key = (self.pieces(system), ctx, level, self._held,
               *(s.Un for s in system.solids), *(s.Vn for s in system.solids),
               *(s.gnode for s in system.solids), *self._phi_shape,
               *((f.Vbar, f.Vn, f.gnode) if f is not None else ()))
        cache = self.__dict__.setdefault("_static_cache", {})
        hit = cache.get(level)
        if hit is None or len(hit[0]) != len(key) or any(a is not b for a, b in zip(hit[0], key)):
            hit = (key, self._gather_static(system, ctx, level))
            cache[level] = hit
        d = dict(hit[1])
        parts = [s.U.ravel() for s in system.solids]
        if f is not None:
            parts.append(np.column_stack([f.V, f.P]).ravel())
        flat = np.concatenate(parts + [np.zeros(1)])  # the last entry: 0 for absent slots
        d["z"] = flat[d.pop("zidx")]
        if d.pop("moving_data"):
            d.update(self._position_data(system, ctx, level, self.pieces(system)))
        if f is not None and ctx.static:
            sel = np.nonzero(self.pieces(system).fs)[0]
            Vo = np.zeros_like(d["Vo"])
            Vo[sel] = f.V[system.cut.part_conn(self.pieces(system).cell[sel])]
            d["Vo"] = Vo
        return d

    def _position_data(self, system, ctx: StepContext, level: str, pc: CouplingPieces) -> dict:
        """Data evaluated at the current Gauss points (expressions in x, y, t): prescribed interface
        velocity ``vq``/``vqe``, slip length ``kap``, fluid body-force density ``bq``."""
        K = len(pc)
        G = len(self.gp)
        f = system.fluid
        vq = np.zeros((K, G, 2))
        kap = np.zeros((K, G))
        vqe = np.zeros((K, 2))
        bq = np.zeros((K, G, 2))
        has_ext = pc.ext_edge >= 0
        t_lvl = ctx.t_new if level == "new" else ctx.t_old
        for b, s in enumerate(system.solids):
            m = np.nonzero(pc.body == b)[0]
            if len(m) == 0:
                continue
            body = s.body
            e = self._edges[b][pc.edge[m]]
            if body.interface_velocity is not None or isinstance(body.slip_length, Expression):
                xg = self._gauss_points((s.X + s.U)[e], pc.s0[m], pc.s1[m])
            if body.interface_velocity is not None:
                for c in range(2):
                    vq[m, :, c] = body.interface_velocity[c](xg[..., 0], xg[..., 1], t_lvl)
            if isinstance(body.slip_length, Expression):
                kv = body.slip_length(xg[..., 0], xg[..., 1], t_lvl)
                if np.any(kv < 0):
                    raise InputError(f"bodies.{body.name}.slip_length", body.slip_length.text,
                                     f"a slip length κ ≥ 0 (the expression gives {kv.min():.3g})")
                kap[m] = kv
            elif body.slip_length != GAP_LAW:
                kap[m] = float(body.slip_length)
            me = m[has_ext[m]]
            if len(me) and body.interface_velocity is not None:
                ee = self._edges[b][pc.ext_edge[me]]
                xe = (1 - pc.ext_s[me, None]) * (s.X + s.U)[ee[:, 0]] + pc.ext_s[me, None] * (s.X + s.U)[ee[:, 1]]
                for c in range(2):
                    vqe[me, c] = body.interface_velocity[c](xe[:, 0], xe[:, 1], t_lvl)
        if f is not None and f.spec.body_force is not None:
            sel = np.nonzero(pc.fs)[0]
            if len(sel):
                body = pc.body[sel]
                xg = np.zeros((len(sel), G, 2))
                for b, s in enumerate(system.solids):
                    mb = body == b
                    e = self._edges[b][pc.edge[sel[mb]]]
                    x = s.X + s.U
                    xg[mb] = self._gauss_points(x[e], pc.s0[sel[mb]], pc.s1[sel[mb]])
                    t = x[e[:, 1]] - x[e[:, 0]]
                    n = np.column_stack([t[:, 1], -t[:, 0]]) / np.linalg.norm(t, axis=1)[:, None]
                    xg[mb] += (system.cut.film_delta * pc.mouth[sel[mb]])[:, None, None] * n[:, None, :]  # on the film's line
                bq[sel] = f.rho * time_weighted_vector(f.spec.body_force, f.spec.body_force_function, ctx,
                                                       lambda: xg.reshape(-1, 2), len(sel) * G).reshape(-1, G, 2)
        return dict(vq=vq, kap=kap, vqe=vqe, bq=bq)

    def _gather_static(self, system, ctx: StepContext, level: str) -> dict:
        """Everything of :meth:`gather` that does not change within a step's Newton iterations on
        one set of pieces, plus ``zidx``: for every local unknown its index into the flat state
        ``[U of each body, (v_x, v_y, p) of each virtual fluid node, 0]`` (absent: the final 0)."""
        pc = self.pieces(system)
        K = len(pc)
        f = system.fluid
        zero = sum(2 * s.n for s in system.solids) + (3 * len(f.V) if f is not None else 0)
        zidx = np.full((K, tk.N_LOCAL), zero, dtype=np.int64)
        base = np.concatenate([[0], np.cumsum([2 * s.n for s in system.solids])]).astype(np.int64)
        fbase = int(base[-1])
        conn = np.full((K, tk.N_SLOTS), -1, dtype=np.int64)
        ip = np.zeros((K, tk.N_INT), dtype=np.int64)
        fp = np.zeros((K, tk.N_FLT))
        Xo = np.zeros((K, 4, 2))
        Xm = np.zeros((K, 4, 2))
        prmo = np.zeros((K, 2))
        prmm = np.zeros((K, 2))
        W = np.zeros((K, 2, 2))
        Xe = np.zeros((K, 8, 2))  # extension edge; the other bodies' edges crossed at the ends, the extension point
        We = np.zeros((K, 2, 2))
        Vo = np.zeros((K, 4, 2))  # previous fluid velocity at the cell nodes (bulk shape derivative)
        Vb = np.zeros((K, 4, 2))  # the stabilisation velocity there in a time step (residual-based scheme)
        vmax_s = np.zeros(K)
        fp[:, tk.F_S0] = pc.s0
        fp[:, tk.F_S1] = pc.s1
        fp[:, tk.F_C0] = pc.c0
        fp[:, tk.F_C1] = pc.c1
        ip[:, tk.I_D0] = pc.d0
        ip[:, tk.I_D1] = pc.d1
        ip[:, tk.I_DE] = pc.ext_d
        fp[:, tk.F_CE] = pc.ext_c
        if system.cut is not None:  # half-thickness of closed films (fsci.cut.state.END_FILM_OUT)
            fp[:, tk.F_FILM] = system.cut.film_delta
        has_opp = pc.opp_body >= 0
        has_ext = pc.ext_edge >= 0
        flags = np.where(has_opp, tk.HAS_OPP, 0) | np.where(pc.fs, tk.ON_FS, 0) | np.where(has_ext, tk.HAS_EXT, 0) | \
            np.where(pc.mouth, tk.MOUTH, 0)
        held = has_opp & ~pc.fs & self._held[self._edge_offset[pc.body] + pc.edge]
        flags |= np.where(held, tk.HELD, 0)
        transient = not ctx.static
        c_new = 1.0 / (ctx.theta * ctx.dt) if transient else 0.0
        moving = False  # data evaluated at the current Gauss points
        two = np.arange(2)
        for b, s in enumerate(system.solids):
            m = np.nonzero(pc.body == b)[0]
            if len(m) == 0:
                continue
            body = s.body
            moving |= body.interface_velocity is not None or isinstance(body.slip_length, Expression)
            motion = 0 if not transient or body.interface_velocity is not None else (1 if level == "new" else 2)
            _gather_own(m, pc.edge, pc.ext_edge, has_opp, has_ext, self._cell[b], self._local[b], self._edges[b],
                        s.mesh.cells, s.X, s.gnode, s.Un, s.Vn, int(base[b]), s.law, s.prm, motion, c_new,
                        (1.0 - ctx.theta) / ctx.theta, zidx, conn, ip, fp, Xo, prmo, W, Xe, We, vmax_s)
            if body.slip_length == GAP_LAW:
                flags[m] |= tk.SLIP_LAW
        # opposite bodies: the whole element of the opposite segment (its stress)
        for b, s in enumerate(system.solids):
            m = np.nonzero(has_opp & (pc.opp_body == b))[0]
            if len(m) == 0:
                continue
            cells = s.mesh.cells[self._cell[b][pc.opp_edge[m]]]
            ip[m, tk.I_EM] = self._local[b][pc.opp_edge[m]]
            ip[m, tk.I_LAWM] = s.law
            prmm[m] = s.prm
            Xm[m] = s.X[cells]
            zidx[m, tk.OFF_OPP:tk.OFF_OPP + 8] = (base[b] + 2 * cells[:, :, None] + two).reshape(len(m), 8)
            conn[m, 4:8] = s.gnode[cells]
        self._gather_end_edges(system, pc, base, zidx, conn, Xe)
        mo = np.nonzero(has_opp)[0]
        if len(mo):
            phi = self.penalty_scales(system)
            phi_o = np.array([phi[b][e] for b, e in zip(pc.body[mo], pc.edge[mo])])
            phi_m = np.array([phi[b][e] for b, e in zip(pc.opp_body[mo], pc.opp_edge[mo])])
            fp[mo, tk.F_WOWN], fp[mo, tk.F_PEN] = self._weights(phi_o, phi_m)
        ip[:, tk.I_FLAGS] = flags
        if f is not None:
            g = f.grid
            st = self.iset
            fp[:, tk.F_KAPPA0] = st.kappa0
            fp[:, tk.F_SLIPH] = self.slip_h
            # γ^F's factors, multiplied in the order of its formula (module docstring)
            gam_prm = np.array([st.gamma_n * f.mu * st.trace_constant, st.gamma_n, f.mu * st.trace_constant, f.rho,
                                st.gamma_n * f.rho, 12.0 * ctx.theta * ctx.dt if transient else 1.0])

            def cell_data(sel: np.ndarray, parts: np.ndarray, nodes: np.ndarray, slot: int, off: int,
                          cols: tuple[int, int, int, int, int]) -> np.ndarray:
                """Fluid slots, cell geometry and γ^F of the pieces ``sel`` in fluid ``parts`` (of
                virtual nodes ``nodes``); returns h_K."""
                hk = np.empty(len(sel))
                _gather_cells(sel, parts, nodes, g.n_cells, f.gnode, fbase, g.xs, g.ys, g.cell_ij, g.cell_size,
                              slot, off, np.array(cols, dtype=np.int64), f.Vbar, vmax_s, transient, gam_prm,
                              conn, zidx, fp, hk)
                return hk

            if not transient:
                fp[:, tk.F_GAMV] = st.gamma_n * f.rho / 6.0
                fp[:, tk.F_VMS] = vmax_s

            sel = np.nonzero(pc.fs)[0]
            if len(sel):
                nodes = system.cut.part_conn(pc.cell[sel])
                hk = cell_data(sel, pc.cell[sel], nodes, 8, tk.OFF_CELL,
                               (tk.F_X0C, tk.F_Y0C, tk.F_HX, tk.F_HY, tk.F_GAM))
                fp[sel, tk.F_AT] = hk / (st.gamma_t * st.trace_constant)
                if not ctx.static:
                    Vo[sel] = f.Vn[nodes]
                if transient:  # steady flow: the unknown velocity (add_bulk_shape_derivative)
                    Vb[sel] = f.Vbar[nodes]
                moving |= f.spec.body_force is not None
            sel = np.nonzero(has_ext)[0]
            if len(sel):
                cell_data(sel, pc.ext_cell[sel], system.cut.part_conn(pc.ext_cell[sel]), 12, tk.OFF_EXT,
                          (tk.F_X0E, tk.F_Y0E, tk.F_HXE, tk.F_HYE, tk.F_GAME))
                fp[sel, tk.F_SE] = pc.ext_s[sel]
        out = dict(zidx=zidx, conn=conn, ip=ip, fp=fp, Xo=Xo, prmo=prmo, Xm=Xm, prmm=prmm, W=W, Xe=Xe, We=We, Vo=Vo,
                   Vb=Vb, moving_data=moving)
        if not moving:  # evaluated once: constant slip lengths only
            out.update(self._position_data(system, ctx, level, pc))
        return out

    def _gather_end_edges(self, system, pc: CouplingPieces, base: np.ndarray, zidx: np.ndarray, conn: np.ndarray,
                          Xe: np.ndarray) -> None:
        """Slots of the edges that the pieces' ends and extension points take their position
        from: the other bodies' boundary edges they cross or whose closed film's line they meet
        (kinds ``MOVING_ENDS``, the coordinate the edge's index among all bodies' boundary edges
        in the cut's order), and the coupling edges whose node projects there (``END_NODE0/1``,
        the index among all bodies' coupling edges): reference coordinates into ``Xe[:, 2:8]``,
        local unknowns from ``OFF_END``, global nodes into slots 18-23."""
        kinds = (pc.d0, pc.d1, pc.ext_d)
        if not any(is_end_on_edge(d).any() for d in kinds):
            return
        lists = [(is_moving_end, [s.mesh.boundary.edges for s in system.solids]),
                 (lambda d: (d == END_NODE0) | (d == END_NODE1), self._edges)]
        two = np.arange(2)
        for of_kind, edges in lists:
            off = np.concatenate([[0], np.cumsum([len(e) for e in edges])]).astype(np.int64)
            for end, (d, c) in enumerate(zip(kinds, (pc.c0, pc.c1, pc.ext_c))):
                sel = np.nonzero(of_kind(d))[0]
                if not len(sel):
                    continue
                g = np.rint(c[sel]).astype(np.int64)
                body = np.searchsorted(off, g, side="right") - 1
                for b in np.unique(body):
                    s = system.solids[b]
                    m = sel[body == b]
                    nodes = edges[b][g[body == b] - off[b]]
                    Xe[m, 2 + 2 * end:4 + 2 * end] = s.X[nodes]
                    o = tk.OFF_END + 4 * end
                    zidx[m, o:o + 4] = (base[b] + 2 * nodes[:, :, None] + two).reshape(len(m), 4)
                    conn[m, 18 + 2 * end:20 + 2 * end] = s.gnode[nodes]

    def _gauss_points(self, x: np.ndarray, s0: np.ndarray, s1: np.ndarray) -> np.ndarray:
        s = s0[:, None] + (s1 - s0)[:, None] * self.gp[None, :]
        return x[:, 0, None, :] + s[..., None] * (x[:, 1, None, :] - x[:, 0, None, :])

    def _current(self, system, ctx: StepContext) -> dict:
        """Per-piece data of the current state (gathered once per state and step)."""
        key = (self._geometry_key(system), ctx.t_new, ctx.dt, ctx.theta, self._held.tobytes(),
               *(s.U.tobytes() for s in system.solids),
               *((system.fluid.V.tobytes(), system.fluid.P.tobytes()) if system.fluid is not None else ()))
        if self._data_key != key:
            self._data = self.gather(system, ctx)
            self._data_key = key
        return self._data

    # ----------------------------------------------------------------- term interface
    def blocks(self, system) -> list[np.ndarray]:
        ctx = getattr(system, "ctx", None) or StepContext(0.0, 1.0, 1.0, 1.0, True)
        ghost = self.ghost_motion(system)
        return [self._current(system, ctx)["conn"]] + ([ghost[2]] if ghost is not None else [])

    def reach(self, system) -> list[tuple[np.ndarray, np.ndarray]]:
        """Node pairs the pieces may couple once the bodies moved by up to a cell: every body
        node of a piece with the nodes of the fluid parts around the piece's cells (the kept
        sparsity pattern, :meth:`fsci.system.System.pattern`)."""
        if system.fluid is None:
            return []
        conn = self.blocks(system)[0]
        fluid = tk.SLOT_NDOF == 3
        return [(conn[:, ~fluid], system.fluid.nodes_around(conn[:, fluid]))]

    def _run(self, system, ctx: StepContext, d: dict, asm: Assembly, weights: tuple[float, float, float],
             out: np.ndarray) -> None:
        f = system.fluid
        mu, sym = (1.0, 0.0) if f is None else (f.mu, f.sym)
        fprm = np.zeros(N_CELL_PARAMETERS) if f is None else f.cell_parameters(ctx)
        shape = self._shape_derivative(system)
        tk.assemble_pieces(d["z"], d["ip"], d["fp"], d["Xo"], d["prmo"], d["Xm"], d["prmm"], d["W"], d["vq"],
                           d["kap"], d["Xe"], d["We"], d["vqe"], d["Vo"], d["Vb"], d["bq"], fprm, shape, mu, sym, self.sadj,
                           self.variant33, *weights, self.gp, self.gw, d["conn"], asm.positions(d["conn"]),
                           *asm.target(), out)

    def _shape_derivative(self, system) -> bool:
        """The shape derivative is the derivative of the re-cut residual: not while the cut is frozen."""
        return system.fluid is not None and self.iset.shape_derivative and not getattr(system, "_cut_frozen", False)

    def begin_step(self, system, ctx: StepContext) -> None:
        self.update_penalty(system)
        self._reset_swings()

    def store_old_level(self, system, ctx: StepContext) -> None:
        """θ < 1: the θ-weighted coupling terms at the converged state of ``t_old`` (this call
        comes before anything of the new step moves), per node."""
        self._old = None
        if ctx.static or ctx.theta >= 1.0:
            return
        if system.fluid is not None:
            system.update_cut()  # the cut of the converged state (also after a restart)
        d = self.gather(system, ctx, level="old")
        asm = ResidualAssembly(system.layout)
        out = np.zeros((len(d["ip"]), len(self.gp), tk.N_OUT))
        self._run(system, ctx, d, asm, (0.0, 1.0, 0.0), out)
        st = system.layout.start
        old = {f"solid{i}": asm.rhs[st[s.gnode][:, None] + np.arange(2)].copy()
               for i, s in enumerate(system.solids) if s.has_dofs}  # prescribed bodies have no rows
        if system.fluid is not None:
            f = system.fluid
            arr = np.zeros((len(f.active), 3))
            act = np.nonzero(f.active)[0]
            arr[act] = asm.rhs[st[f.gnode[act]][:, None] + np.arange(3)]
            old["fluid"] = arr
            old["fluid_nodes"] = (f.vnode_node, f.vnode_rep, f.active.copy())
        self._old = old

    def assemble(self, system, asm: Assembly, ctx: StepContext) -> None:
        d = self._current(system, ctx)
        out = np.zeros((len(d["ip"]), len(self.gp), tk.N_OUT))
        w_t = 1.0 if ctx.static else ctx.theta
        self._run(system, ctx, d, asm, (1.0, w_t, 1.0), out)
        ghost = self.ghost_motion(system) if asm.want_matrix and self._shape_derivative(system) else None
        if ghost is not None:  # the ghost penalty's weight moving with the bodies (the fluid term's residual)
            f = system.fluid
            g = f.grid
            face_of, dwdu, conn = ghost
            fk.assemble_ghost_weight_motion(g.xs, g.ys, g.nx, f.face_nodes, f.faces, face_of, dwdu, f.V,
                                            f.face_parameters(ctx), conn, asm.positions(conn), *asm.target())
        pc = self.pieces(system)
        real = ~pc.mouth  # a film's mouth has no interface points
        self.out = out[real]
        self._out_body, self._out_edge, self._out_dry = pc.body[real], pc.edge[real], (~pc.fs & (pc.opp_body >= 0))[real]
        if self._old is not None:
            st = asm.layout.start
            c = 1.0 - ctx.theta
            for i, s in enumerate(system.solids):
                if s.has_dofs:
                    asm.rhs[st[s.gnode][:, None] + np.arange(2)] += c * self._old[f"solid{i}"]
            if system.fluid is not None:
                f = system.fluid
                node, rep_pt, was_active = self._old["fluid_nodes"]
                if node is not f.vnode_node:  # another cut's virtual nodes: carry the rows over
                    src = transfer_indices(node, rep_pt, was_active, f.vnode_node, f.vnode_rep, f.grid.n_nodes)
                    self._old["fluid"] = np.where((src >= 0)[:, None], self._old["fluid"][np.maximum(src, 0)], 0.0)
                    self._old["fluid_nodes"] = (f.vnode_node, f.vnode_rep, f.active.copy())
                act = np.nonzero(f.active)[0]
                asm.rhs[st[f.gnode[act]][:, None] + np.arange(3)] += c * self._old["fluid"][act]

    # ----------------------------------------------------------------- post-processing
    def samples(self) -> tuple[np.ndarray, np.ndarray]:
        """Gauss-point data of the last assembly ``(K, G, N_OUT)`` (columns ``traction.O_*``) and
        the body of every piece."""
        return self.out, self._out_body

    def loads(self, system, about: np.ndarray | None = None) -> np.ndarray:
        """Force and moment of the interface traction on each body, ``(n_bodies, 3)``: ∫_Γ σ_Γ ds and
        ∫_Γ (x − about) × σ_Γ ds (traction form, last assembly)."""
        out, body = self.samples()
        res = np.zeros((len(system.solids), 3))
        if len(out) == 0:
            return res
        r0 = np.zeros(2) if about is None else np.asarray(about, float)
        w = out[..., tk.O_W]
        tx, ty = out[..., tk.O_TX], out[..., tk.O_TY]
        rx, ry = out[..., tk.O_X] - r0[0], out[..., tk.O_Y] - r0[1]
        per = np.column_stack([(w * tx).sum(1), (w * ty).sum(1), (w * (rx * ty - ry * tx)).sum(1)])
        np.add.at(res, body, per)
        return res

    def case_counts(self) -> dict[str, int]:
        """Number of interface Gauss points in each case I-IV (last assembly)."""
        c = self.out[..., tk.O_CASE].ravel()
        return {f"case_{n}": int(np.sum(c == k + 1)) for k, n in enumerate(CASE_NAMES)}

    def body_summary(self, system, b: int, x_range: list[float] | None = None) -> dict[str, float]:
        """Interface force on body ``b`` split into the FSI part (case I) and the contact part
        (cases II-IV), the length of its Γ^SC and of its C ≤ 0 part; with ``x_range`` = [x0, x1]
        only over the Gauss points whose current x lies in it."""
        out, body = self.samples()
        sel = out[body == b]
        if x_range is not None:
            inside = (sel[..., tk.O_X] >= x_range[0]) & (sel[..., tk.O_X] <= x_range[1])
            sel = np.where(inside[..., None], sel, 0.0)  # weight 0 and case 0 outside
        w = sel[..., tk.O_W]
        case = sel[..., tk.O_CASE]
        fsi = case == tk.CASE_I
        res = {}
        for name, mask in (("fsi", fsi), ("contact", ~fsi & (case > 0))):
            res[f"force_{name}_x"] = float(np.sum((w * sel[..., tk.O_TX])[mask]))
            res[f"force_{name}_y"] = float(np.sum((w * sel[..., tk.O_TY])[mask]))
        res["length_sc"] = float(np.sum(w[(case == tk.CASE_II) | (case == tk.CASE_IV)]))
        res["length_contact"] = float(np.sum(w[(case == tk.CASE_II) | (case == tk.CASE_III)]))
        return res

    def profile(self, body_name: str) -> np.ndarray:
        """Contact traction along a body's surface from its own pass (pieces that see an opposite
        surface): rows (x, y, pressure = −σ_nn of the contact branch, gap, active, weight, n_x,
        n_y), sorted by x."""
        if body_name not in self.names:
            return np.zeros((0, 8))
        out, body = self.samples()
        sel = out[body == self.names.index(body_name)].reshape(-1, tk.N_OUT)
        sel = sel[np.isfinite(sel[:, tk.O_GAP])]
        if len(sel) == 0:
            return np.zeros((0, 8))
        active = (sel[:, tk.O_CASE] == tk.CASE_II) | (sel[:, tk.O_CASE] == tk.CASE_III)
        a = np.column_stack([sel[:, tk.O_X], sel[:, tk.O_Y], -sel[:, tk.O_TN_CON], sel[:, tk.O_GAP],
                             active.astype(float), sel[:, tk.O_W], sel[:, tk.O_NX], sel[:, tk.O_NY]])
        return a[np.argsort(a[:, 0], kind="stable")]

    def output_meshes(self, system):
        """The interface Gauss points as a vertex cloud with body, case (1-4), gap, κ, the
        traction vector and its normal FSI and contact parts."""
        import meshio

        out, body = self.samples()
        if len(out) == 0:
            return []
        pts = out.reshape(-1, tk.N_OUT)
        bod = np.repeat(body, len(self.gp))
        P = np.column_stack([pts[:, tk.O_X], pts[:, tk.O_Y], np.zeros(len(pts))])
        gap = np.where(np.isfinite(pts[:, tk.O_GAP]), pts[:, tk.O_GAP], -1.0)
        kappa = np.where(np.isfinite(pts[:, tk.O_KAPPA]), pts[:, tk.O_KAPPA], -1.0)
        mesh = meshio.Mesh(P, [("vertex", np.arange(len(P))[:, None])],
                           point_data={"body": bod.astype(np.int32), "case": pts[:, tk.O_CASE].astype(np.int32),
                                       "gap": gap, "kappa": kappa,
                                       "traction": np.column_stack([pts[:, tk.O_TX], pts[:, tk.O_TY], np.zeros(len(P))]),
                                       "traction_n_fsi": pts[:, tk.O_TN_FSI], "traction_n_contact": pts[:, tk.O_TN_CON]})
        return [("interface", mesh)]
