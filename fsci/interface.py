"""The fluid-structure interface term: gathers, for every Γ^FS piece of the current cut, the
solid and fluid data the Nitsche kernel (:mod:`fsci.physics.fsi`) needs, and assembles it.

Per piece (fluid-sided, 4C's "xfluid" weighting, FORMULATION §4.4 / Remark 8):

* ``h_K`` = area / longest edge of the background cell (4C ``ele_vol_div_by_max_ele_surf``),
* ``γ^F = γ0^F (μ C_T / h_K + ρ |v|_∞ / 6 + ρ h_K / (12 θ Δt))`` (4C "full, sum"),
  ``|v|_∞`` the largest velocity component of the fluid cell and the solid edge at the start
  of the step (frozen, so the Jacobian stays exact),
* ``a = h_K / (γ0^t C_T)`` for the Navier-slip coefficients (37),
* the solid velocity from the one-step-θ update of the edge nodes (static problems: 0), or a
  prescribed ``interface_velocity``,
* the slip length κ of the body (number, ∞, or expression evaluated at the Gauss points).
"""

from __future__ import annotations

import math

import numpy as np

from fsci.assembly import Assembly
from fsci.errors import InputError
from fsci.expressions import Expression
from fsci.fem.quadrature import gauss_line
from fsci.fields import StepContext
from fsci.physics import fsi

N_GAUSS = 3


def gauss_unit(n: int = N_GAUSS) -> tuple[np.ndarray, np.ndarray]:
    x, w = gauss_line(n)
    return 0.5 * (x + 1.0), 0.5 * w


class NitscheInterface:
    """Coupling term on Γ^FS for all bodies."""

    def __init__(self, system) -> None:
        f = system.fluid
        self.settings = f.spec.interface
        self.sadj = -1.0 if self.settings.adjoint == "skew" else 1.0
        self.gp, self.gw = gauss_unit()
        self.traction = np.zeros((0, N_GAUSS, 2))
        self._data = None

    # ----------------------------------------------------------------- data per piece
    def pieces(self, system) -> np.ndarray:
        """Indices (into the cut's segments) of the pieces this term integrates: Γ^FS."""
        return np.nonzero(system.cut.segments.fs)[0]

    def blocks(self, system) -> list[np.ndarray]:
        return [self._conn(system, self.pieces(system))]

    def _conn(self, system, idx: np.ndarray) -> np.ndarray:
        seg = system.cut.segments
        conn = np.empty((len(idx), 6), dtype=np.int64)
        for b, s in enumerate(system.solids):
            m = seg.body[idx] == b
            e = system.interface_edges[b][seg.edge[idx[m]]]
            conn[m, 0] = s.gnode[e[:, 0]]
            conn[m, 1] = s.gnode[e[:, 1]]
        conn[:, 2:] = system.fluid.gnode[system.fluid.grid.cells[seg.cell[idx]]]
        return conn

    def begin_step(self, system, ctx: StepContext) -> None:
        pass

    def gather(self, system, ctx: StepContext, idx: np.ndarray) -> dict:
        """Per-piece arrays for the kernel."""
        seg = system.cut.segments
        f = system.fluid
        g = f.grid
        st = self.settings
        K = len(idx)
        X = np.empty((K, 2, 2))
        U = np.empty((K, 2, 2))
        W = np.zeros((K, 2, 2))
        cu = np.zeros(K)
        vq = np.zeros((K, N_GAUSS, 2))
        kap = np.zeros((K, N_GAUSS))
        vmax_s = np.zeros(K)
        for b, s in enumerate(system.solids):
            m = np.nonzero(seg.body[idx] == b)[0]
            if len(m) == 0:
                continue
            e = system.interface_edges[b][seg.edge[idx[m]]]
            X[m] = s.X[e]
            U[m] = s.U[e]
            body = s.body
            if not ctx.static and body.interface_velocity is None:
                c = 1.0 / (ctx.theta * ctx.dt)
                cu[m] = c
                W[m] = c * s.Un[e] + (1.0 - ctx.theta) / ctx.theta * s.Vn[e]
            vmax_s[m] = np.max(np.abs(s.Vn[e]), axis=(1, 2))
            xq = self._gauss_points(X[m] + U[m], seg.s0[idx[m]], seg.s1[idx[m]])
            if body.interface_velocity is not None:
                for c in range(2):
                    vq[m, :, c] = body.interface_velocity[c](xq[..., 0], xq[..., 1], ctx.t_new)
            if isinstance(body.slip_length, Expression):
                kv = body.slip_length(xq[..., 0], xq[..., 1], ctx.t_new)
                if np.any(kv < 0):
                    raise InputError(f"bodies.{body.name}.slip_length", body.slip_length.text,
                                     f"a slip length κ ≥ 0 (the expression gives {kv.min():.3g})")
                kap[m] = kv
            else:
                kap[m] = float(body.slip_length)
        cells = seg.cell[idx]
        hx = g.cell_size[cells, 0]
        hy = g.cell_size[cells, 1]
        hk = hx * hy / np.maximum(hx, hy)
        vmax_f = np.max(np.abs(f.Vbar[g.cells[cells]]), axis=(1, 2))
        vmax = np.maximum(vmax_f, vmax_s)
        gam = st.gamma_n * (f.mu * st.trace_constant / hk + f.rho * vmax / 6.0)
        if not ctx.static:
            gam += st.gamma_n * f.rho * hk / (12.0 * ctx.theta * ctx.dt)
        a_t = hk / (st.gamma_t * st.trace_constant)
        return dict(X=X, U=U, W=W, cu=cu, vq=vq, kap=kap, gam=gam, a_t=a_t, cells=cells,
                    s0=seg.s0[idx], s1=seg.s1[idx], body=seg.body[idx])

    def _gauss_points(self, x: np.ndarray, s0: np.ndarray, s1: np.ndarray) -> np.ndarray:
        s = s0[:, None] + (s1 - s0)[:, None] * self.gp[None, :]
        return x[:, 0, None, :] + s[..., None] * (x[:, 1, None, :] - x[:, 0, None, :])

    # ----------------------------------------------------------------- assembly
    def assemble(self, system, asm: Assembly, ctx: StepContext) -> None:
        idx = self.pieces(system)
        f = system.fluid
        g = f.grid
        d = self.gather(system, ctx, idx)
        conn = self._conn(system, idx)
        self.traction = np.zeros((len(idx), N_GAUSS, 2))
        fsi.assemble_interface(g.xs, g.ys, g.nx, g.cells, d["cells"], d["s0"], d["s1"], d["X"], d["U"], d["W"],
                               d["cu"], d["vq"], d["kap"], d["gam"], d["a_t"], f.V, f.P, f.mu, f.sym, self.sadj,
                               self.gp, self.gw, conn, asm.positions(conn), *asm.target(), self.traction)
        self._last = (idx, d)

    # ----------------------------------------------------------------- post-processing
    def output_meshes(self, system):
        """Interface pieces as line cells with the traction σ_Γ (mean over the piece), the
        body id and the Γ^FS flag."""
        import meshio

        seg = system.cut.segments
        pts, fs, body, trac = [], [], [], []
        last_idx, tr = (self._last[0], self.traction) if hasattr(self, "_last") else (np.zeros(0, int), None)
        mean_tr = np.zeros((len(seg), 2))
        if tr is not None and len(last_idx) == len(tr) and len(last_idx) and last_idx.max() < len(seg):
            mean_tr[last_idx] = np.einsum("g,kgc->kc", self.gw, tr)
        for b in range(len(system.solids)):
            p, _ = system.cut.interface_points(b)
            m = seg.body == b
            pts.append(p)
            fs.append(seg.fs[m])
            body.append(np.full(m.sum(), b))
            trac.append(mean_tr[m])
        P = np.vstack(pts).reshape(-1, 2) if pts else np.zeros((0, 2))
        conn = np.arange(len(P)).reshape(-1, 2)
        T = np.vstack(trac) if trac else np.zeros((0, 2))
        mesh = meshio.Mesh(np.column_stack([P, np.zeros(len(P))]), [("line", conn)],
                           cell_data={"traction": [np.column_stack([T, np.zeros(len(T))])],
                                      "fluid_wetted": [np.concatenate(fs).astype(np.int32) if fs else np.zeros(0, np.int32)],
                                      "body": [np.concatenate(body).astype(np.int32) if body else np.zeros(0, np.int32)]})
        return [("interface", mesh)]

    def traction_samples(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The interface traction σ_Γ of the last assembly at its Gauss points.

        Returns
        -------
        x : (K, G, 2) Gauss-point positions on the K wetted pieces
        w : (K, G) quadrature weights (length)
        t : (K, G, 2) traction of the fluid on the body
        body : (K,) body index of each piece
        """
        if not hasattr(self, "_last"):
            return np.zeros((0, N_GAUSS, 2)), np.zeros((0, N_GAUSS)), np.zeros((0, N_GAUSS, 2)), np.zeros(0, int)
        idx, d = self._last
        x = d["X"] + d["U"]
        w = (np.linalg.norm(x[:, 1] - x[:, 0], axis=1) * (d["s1"] - d["s0"]))[:, None] * self.gw[None, :]
        return self._gauss_points(x, d["s0"], d["s1"]), w, self.traction, d["body"]

    def loads(self, system, about: np.ndarray | None = None) -> np.ndarray:
        """Force and moment of the fluid on each body, ``(n_bodies, 3)``: ∫_Γ^FS σ_Γ ds and
        ∫_Γ^FS (x − about) × σ_Γ ds (traction form, last assembly)."""
        xq, w, t, body = self.traction_samples()
        r = xq - (np.zeros(2) if about is None else np.asarray(about, float))
        per_piece = np.column_stack([np.einsum("kg,kgc->kc", w, t),
                                     np.einsum("kg,kg->k", w, r[..., 0] * t[..., 1] - r[..., 1] * t[..., 0])])
        out = np.zeros((len(system.solids), 3))
        np.add.at(out, body, per_piece)
        return out
