"""The contact term: unbiased two-half-pass Nitsche contact between bodies (dry; FORMULATION
§4.4 case II). Every non-rigid body with ``contact`` edge sets integrates the contact traction
on its own surface against every other body's contact surface (:mod:`fsci.physics.contact`).

Penalty and weights (Remark 7; 4C ``nitsche_weights_and_scaling``): for each parent element
of a contact edge, ``φ = λ_max`` of the generalised eigenvalue problem

    ∫_edge (n·σ(v)·n)² ds = λ ∫_element σ(v):ε(v) dV     (v ⊥ rigid-body modes)

with the small-strain tangent of the material on the current element shape (≈ E/h); it is
recomputed at the start of every step and frozen within it. Harmonic weights
``ω_own = φ_opp / (φ_own + φ_opp)``, or ω = ½; a rigid body has φ = ∞ and weight 0;
``γ^S = γ0^S (ω φ_own + (1 - ω) φ_opp)``.
"""

from __future__ import annotations

import numpy as np

from fsci.assembly import Assembly
from fsci.fem.q1 import q1_eval
from fsci.fem.quadrature import gauss_line, gauss_quad
from fsci.fields import StepContext
from fsci.geometry.search import Surface, find_pieces
from fsci.physics import contact as ck
from fsci.physics.materials import LAW_NAMES

CORNERS = ck.CORNERS


def trace_constant(Xe: np.ndarray, edge: int, E: float, nu: float) -> float:
    """λ_max of the trace inequality of one Q1 element and one of its edges (plane strain)."""
    lam = E * nu / ((1 + nu) * (1 - 2 * nu))
    mu = E / (2 * (1 + nu))
    D = np.array([[lam + 2 * mu, lam, 0.0], [lam, lam + 2 * mu, 0.0], [0.0, 0.0, mu]])

    def Bmat(xi):
        _, dN = q1_eval(xi)
        J = np.einsum("ad,qak->qdk", Xe, dN)
        inv = np.linalg.inv(J)
        dNx = np.einsum("qak,qkd->qad", dN, inv)
        B = np.zeros((len(xi), 3, 8))
        B[:, 0, 0::2] = dNx[:, :, 0]
        B[:, 1, 1::2] = dNx[:, :, 1]
        B[:, 2, 0::2] = dNx[:, :, 1]
        B[:, 2, 1::2] = dNx[:, :, 0]
        return B, np.linalg.det(J)

    xi, w = gauss_quad(2)
    B, det = Bmat(xi)
    K = np.einsum("q,qik,ij,qjl->kl", w * det, B, D, B)
    a, b = edge, (edge + 1) % 4
    gx, gw = gauss_line(3)
    s = 0.5 * (gx + 1.0)
    pts = (1 - s)[:, None] * CORNERS[a] + s[:, None] * CORNERS[b]
    Be, _ = Bmat(pts)
    t = Xe[b] - Xe[a]
    L = np.linalg.norm(t)
    n = np.array([t[1], -t[0]]) / L
    proj = np.array([n[0] ** 2, n[1] ** 2, 2 * n[0] * n[1]])
    bvec = np.einsum("i,ij,qjk->qk", proj, D, Be)
    A = np.einsum("q,qk,ql->kl", 0.5 * gw * L, bvec, bvec)
    ev, V = np.linalg.eigh(K)
    keep = ev > 1e-10 * ev.max()
    Z = V[:, keep] / np.sqrt(ev[keep])[None, :]
    return float(np.linalg.eigvalsh(Z.T @ A @ Z).max())


class NitscheContact:
    """Contact between all bodies that declare ``contact`` edge sets."""

    def __init__(self, system, settings) -> None:
        self.settings = settings
        self.gp, self.gw = (lambda x, w: (0.5 * (x + 1.0), 0.5 * w))(*gauss_line(settings.n_gauss))
        self.bodies = [s for s in system.solids if s.body.contact]
        self._edges, self._cell, self._local = [], [], []
        for s in self.bodies:
            e = np.vstack([s.mesh.edge_sets[n] for n in s.body.contact])
            cell, local = s.mesh.parent_of_edges(e)
            self._edges.append(e)
            self._cell.append(cell)
            self._local.append(local)
        lengths = [np.linalg.norm(s.X[e[:, 1]] - s.X[e[:, 0]], axis=1).max() for s, e in zip(self.bodies, self._edges)]
        self.radius = settings.search_radius if settings.search_radius > 0 else 2.0 * max(lengths, default=0.0)
        self.phi = [np.full(len(e), np.inf) for e in self._edges]
        self._key = None
        self._pieces = None
        self.result: list[dict] = []
        self.update_penalty(system)

    # ----------------------------------------------------------------- geometry
    def surfaces(self) -> list[Surface]:
        return [Surface(k, s.X + s.U, self._edges[k], self._cell[k], self._local[k]) for k, s in enumerate(self.bodies)]

    def update_penalty(self, system) -> None:
        """Trace-inequality estimates φ of every contact element at the current shape."""
        for k, s in enumerate(self.bodies):
            if s.body.rigid or s.fixed.all():
                self.phi[k] = np.full(len(self._edges[k]), np.inf)
                continue
            x = s.X + s.U
            m = s.body.material
            self.phi[k] = np.array([trace_constant(x[s.mesh.cells[c]], l, m.E, m.nu)
                                    for c, l in zip(self._cell[k], self._local[k])])

    def _state_key(self) -> tuple:
        return tuple(s.U.tobytes() for s in self.bodies)

    def pieces(self) -> list:
        """Integration pieces of every pass (recomputed when the displacements changed)."""
        key = self._state_key()
        if key != self._key:
            surf = self.surfaces()
            self._pieces = []
            for k, s in enumerate(self.bodies):
                if s.body.rigid or s.fixed.all():
                    self._pieces.append(None)  # a rigid body's own pass has no free test functions
                    continue
                self._pieces.append(find_pieces(surf, k, self.radius, self.settings.self_contact,
                                                self.settings.split, self.settings.n_fixed))
            self._key = key
        return self._pieces

    # ----------------------------------------------------------------- assembly data
    def _gather(self) -> dict | None:
        rows = []
        for k, pc in enumerate(self.pieces()):
            if pc is None or len(pc) == 0:
                continue
            rows.append((k, pc))
        if not rows:
            return None
        out = {key: [] for key in ("Xo", "eo", "lawo", "prmo", "Xm", "em", "lawm", "prmm", "w", "pen", "s0", "s1",
                                   "d0", "d1", "z", "conn", "pass")}
        for k, pc in rows:
            so = self.bodies[k]
            co = self._cell[k][pc.edge]
            Xo = so.X[so.mesh.cells[co]]
            uo = so.U[so.mesh.cells[co]]
            lawo = LAW_NAMES[so.body.material.law]
            phi_o = self.phi[k][pc.edge]
            for j in range(len(pc)):
                m = pc.opp_surface[j]
                sm = self.bodies[m]
                cm = self._cell[m][pc.opp_edge[j]]
                phi_m = self.phi[m][pc.opp_edge[j]]
                w, pen = self._weights(phi_o[j], phi_m)
                out["Xo"].append(Xo[j])
                out["eo"].append(self._local[k][pc.edge[j]])
                out["lawo"].append(lawo)
                out["prmo"].append(so.prm)
                out["Xm"].append(sm.X[sm.mesh.cells[cm]])
                out["em"].append(self._local[m][pc.opp_edge[j]])
                out["lawm"].append(LAW_NAMES[sm.body.material.law])
                out["prmm"].append(sm.prm)
                out["w"].append(w)
                out["pen"].append(pen)
                out["z"].append(np.concatenate([uo[j].ravel(), sm.U[sm.mesh.cells[cm]].ravel()]))
                out["conn"].append(np.concatenate([so.gnode[so.mesh.cells[co[j]]], sm.gnode[sm.mesh.cells[cm]]]))
                out["pass"].append(k)
            out["s0"].append(pc.s0)
            out["s1"].append(pc.s1)
            out["d0"].append(pc.d0)
            out["d1"].append(pc.d1)
        arr = {}
        for key, val in out.items():
            if key in ("s0", "s1", "d0", "d1"):
                arr[key] = np.concatenate(val)
            else:
                arr[key] = np.ascontiguousarray(np.array(val))
        arr["eo"] = arr["eo"].astype(np.int64)
        arr["em"] = arr["em"].astype(np.int64)
        arr["lawo"] = arr["lawo"].astype(np.int64)
        arr["lawm"] = arr["lawm"].astype(np.int64)
        arr["d0"] = arr["d0"].astype(np.int64)
        arr["d1"] = arr["d1"].astype(np.int64)
        arr["conn"] = arr["conn"].astype(np.int64)
        return arr

    def _weights(self, phi_o: float, phi_m: float) -> tuple[float, float]:
        g0 = self.settings.gamma0
        if np.isinf(phi_m):
            return 1.0, g0 * phi_o
        if np.isinf(phi_o):
            return 0.0, g0 * phi_m
        w = 0.5 if self.settings.weighting == "half" else phi_m / (phi_o + phi_m)
        return w, g0 * (w * phi_o + (1.0 - w) * phi_m)

    # ----------------------------------------------------------------- term interface
    def _current(self) -> dict | None:
        """Per-piece data of the current displacements (gathered once per state)."""
        key = self._state_key()
        if getattr(self, "_data_key", None) != key:
            self._data = self._gather()
            self._data_key = key
        return self._data

    def blocks(self, system) -> list[np.ndarray]:
        d = self._current()
        return [] if d is None else [d["conn"]]

    def begin_step(self, system, ctx: StepContext) -> None:
        self.update_penalty(system)

    def assemble(self, system, asm: Assembly, ctx: StepContext) -> None:
        d = self._current()
        if d is None:
            self.result = []
            return
        out = np.zeros((len(d["w"]), len(self.gp), 8))
        ck.assemble_contact(d["Xo"], d["eo"], d["lawo"], d["prmo"], d["Xm"], d["em"], d["lawm"], d["prmm"], d["w"],
                            d["pen"], d["s0"], d["s1"], d["d0"], d["d1"], d["z"], self.gp, self.gw, d["conn"],
                            asm.positions(d["conn"]), *asm.target(), out)
        self.result = [(int(p), o) for p, o in zip(d["pass"], out)]

    # ----------------------------------------------------------------- post-processing
    def profile(self, body_name: str) -> np.ndarray:
        """Contact pressure along a body's surface from the last assembly: rows
        (x, y, pressure = -σ_nn, gap, active, weight, n_x, n_y), sorted by x."""
        names = [s.name for s in self.bodies]
        if body_name not in names:
            return np.zeros((0, 8))
        k = names.index(body_name)
        rows = [o for p, o in self.result if p == k]
        if not rows:
            return np.zeros((0, 8))
        a = np.vstack(rows)
        a[:, 2] = -a[:, 2]
        return a[np.argsort(a[:, 0])]

    def output_meshes(self, system):
        import meshio

        meshes = []
        for k, s in enumerate(self.bodies):
            prof = self.profile(s.name)
            if len(prof) == 0:
                continue
            pts = np.column_stack([prof[:, :2], np.zeros(len(prof))])
            meshes.append((f"contact_{s.name}", meshio.Mesh(pts, [("vertex", np.arange(len(prof))[:, None])],
                                                           point_data={"pressure": prof[:, 2], "gap": prof[:, 3],
                                                                       "active": prof[:, 4]})))
        return meshes
