"""Fluid forces and moments on bodies, and flow rates through interfaces (paper (44)).

* Volume (Babuška-Miller / John) form: ``F·e = -R_bulk(w_e)`` where ``R_bulk`` is the fluid
  residual (Galerkin + stabilisation, no interface terms) and ``w_e = e`` on the nodes of the
  cells that contain the body's wetted interface, 0 elsewhere (John 2004 computed the DFG values this way); the
  moment takes the rigid rotation ``w = e_z × (x − x_0)`` instead.
* Traction form: ``∫_Γ^FS σ_Γ ds`` and ``∫_Γ^FS (x − x_0) × σ_Γ ds`` with the Nitsche interface
  traction σ_Γ (27), (37) — the negative of the interface contributions to the solid residual.
"""

from __future__ import annotations

import numpy as np

from fsci.assembly import ResidualAssembly


def fluid_bulk_residual(system) -> np.ndarray:
    """Fluid residual without interface terms and Dirichlet rows, per virtual node ``(n, 3)``."""
    f = system.fluid
    asm = ResidualAssembly(system.layout)
    f.assemble(asm, system.ctx)
    out = np.zeros((len(f.active), 3))
    act = np.nonzero(f.active)[0]
    start = system.layout.start[f.gnode[act]]
    for c in range(3):
        out[act, c] = asm.rhs[start + c]
    return out


def volume_loads(system, bodies: list[int], about=None) -> np.ndarray:
    """Force and moment (about ``about``, default the origin) of the fluid on a set of bodies by
    the volume form, ``[F_x, F_y, M]``: ``-R_bulk(w)`` with ``w = e_x``, ``e_y`` and the rigid
    rotation ``e_z × (x − about)`` on the nodes of every cell containing one of their wetted
    pieces (Q1 reproduces both exactly there; no double counting where bodies meet)."""
    seg = system.cut.segments
    parts = seg.part[np.isin(seg.body, bodies) & seg.fs]
    if len(parts) == 0:
        return np.zeros(3)
    nodes = np.unique(system.cut.part_conn(parts))
    R = fluid_bulk_residual(system)[nodes, :2]
    r = system.fluid.grid.nodes[system.fluid.vnode_node[nodes]] - (np.zeros(2) if about is None else np.asarray(about, float))
    return -np.array([R[:, 0].sum(), R[:, 1].sum(), np.sum(r[:, 0] * R[:, 1] - r[:, 1] * R[:, 0])])


def traction_loads(system, bodies: list[int], about=None) -> np.ndarray:
    """``[F_x, F_y, M]`` of the fluid on a set of bodies: ∫ σ_Γ and ∫ (x − about) × σ_Γ over
    their wetted interface (last assembly)."""
    for term in system.extra_terms:
        if hasattr(term, "loads"):
            return term.loads(system, about)[bodies].sum(axis=0)
    return np.zeros(3)


def interface_flux_points(system, body: int | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Gauss points of Γ^FS (of one body or all) with their contributions to (44):
    ``(x (k, 2), n (k, 2), w v·n fluid (k,), w v·n solid (k,))``, n the solid's outward normal."""
    from fsci.fem.q1 import q1_values
    from fsci.fem.quadrature import gauss_line

    seg = system.cut.segments
    f = system.fluid
    g = f.grid
    gx, gw = gauss_line(3)
    gp, gw = 0.5 * (gx + 1.0), 0.5 * gw
    parts: list[tuple[np.ndarray, ...]] = []
    for b, s in enumerate(system.solids):
        if body is not None and b != body:
            continue
        m = (seg.body == b) & seg.fs
        if not m.any():
            continue
        e = system.interface_edges[b][seg.edge[m]]
        x = s.X[e] + s.U[e]
        vs_nodes = s.V[e]
        d = x[:, 1] - x[:, 0]
        L = np.linalg.norm(d, axis=1)
        n = np.column_stack([d[:, 1], -d[:, 0]]) / L[:, None]
        sq = seg.s0[m, None] + (seg.s1[m] - seg.s0[m])[:, None] * gp[None, :]
        xq = x[:, 0, None, :] + sq[..., None] * d[:, None, :]
        wq = (L * (seg.s1[m] - seg.s0[m]))[:, None] * gw[None, :]
        parts_q = np.repeat(seg.part[m], len(gp))
        cells = parts_q % g.n_cells
        pts = xq.reshape(-1, 2)
        x0 = np.column_stack([g.xs[g.cell_ij[cells, 0]], g.ys[g.cell_ij[cells, 1]]])
        N = q1_values(2.0 * (pts - x0) / g.cell_size[cells] - 1.0)
        v = np.einsum("ka,kad->kd", N, f.V[system.cut.part_conn(parts_q)]).reshape(xq.shape)
        vs = (1.0 - sq)[..., None] * vs_nodes[:, 0, None, :] + sq[..., None] * vs_nodes[:, 1, None, :]
        nq = np.repeat(n, len(gp), axis=0)
        parts.append((pts, nq, (wq * np.einsum("kgd,kd->kg", v, n)).ravel(), (wq * np.einsum("kgd,kd->kg", vs, n)).ravel()))
    if not parts:
        return np.zeros((0, 2)), np.zeros((0, 2)), np.zeros(0), np.zeros(0)
    return tuple(np.concatenate([p[i] for p in parts]) for i in range(4))
