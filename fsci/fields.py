"""Discrete fields: one :class:`SolidField` per body and the :class:`FluidField`.

A field owns its nodal state arrays (displacement/velocity of a body; velocity and pressure on
all background nodes), its boundary conditions, and the terms it contributes. The
:class:`fsci.system.System` gives every field the global node numbers of its dofs.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from fsci.assembly import Assembly
from fsci.cut.transfer import carry_values, transfer_indices
from fsci.errors import InputError
from fsci.fem.quadrature import gauss_quad
from fsci.mesh.grid import Grid
from fsci.physics import fluid as fk
from fsci.physics import solid as sk
from fsci.physics.materials import LAW_NAMES, material_parameters
from fsci.problem import Body, Fluid

# the fluid's nodal arrays, carried from one cut's virtual nodes to the next and checkpointed
FLUID_VALUES = ("V", "P", "Vn", "Pn", "Vbar", "Vrate", "Prate")
# fluid cell parts (or faces) from which their terms are assembled in parallel, block colour by
# block colour (fewer: one thread; the sums are the same either way)
PARALLEL_ITEMS = 2000


@dataclass
class StepContext:
    """Time level data for one step ``t_old -> t_new`` (``static``: no inertia, steady flow).

    ``lead``: how far Newton's start goes along the last step's rate of change. Static steps:
    the flow starts from ``x_n + lead (x_n − x_(n−1)) / Δt_n``, with ``lead = α Δt_n`` and α
    the ratio of this step's data change to the last step's
    (:func:`fsci.problem.load_step_ratio`; 0: from the last solution). Time steps: ``Δt`` with
    the constant-acceleration predictor (``solver.predictor``), else 0: the velocities, fluid
    and solid, start from ``v_n + lead (v_n − v_(n−1)) / Δt_n`` and the fluid pressure
    likewise."""

    t_old: float
    t_new: float
    dt: float
    theta: float
    static: bool
    lead: float = 0.0  # how far Newton's start goes along the last step's rate of change

    @property
    def w_new(self) -> float:
        """Weight of time-dependent data at t_new (1 for static, theta otherwise)."""
        return 1.0 if self.static else self.theta

    @property
    def w_old(self) -> float:
        return 0.0 if self.static else 1.0 - self.theta


_GAUSS2 = np.polynomial.legendre.leggauss(2)  # the fluid Neumann rule (computed once)


def time_weighted_vector(values, function, ctx: StepContext, points, n: int) -> np.ndarray:
    """Evaluate a pair of expressions ``values`` at ``points()`` for both time levels of a step,
    weighted by ``w_new``/``w_old`` and a time function; zeros if ``values`` is None."""
    out = np.zeros((n, 2))
    if values is None:
        return out
    fn = function or (lambda t: 1.0)
    pts = None
    for t, w in ((ctx.t_new, ctx.w_new), (ctx.t_old, ctx.w_old)):
        if w == 0.0:
            continue
        f = fn(t) * w
        if f == 0.0:
            continue
        if pts is None:
            pts = points()
        for c in range(2):
            out[:, c] += values[c](pts[:, 0], pts[:, 1], t) * f
    return out


class SolidField:
    """Total-Lagrangian body: state, Dirichlet/Neumann data, bulk and load terms."""

    def __init__(self, body: Body, index: int) -> None:
        self.body = body
        self.index = index
        self.name = body.name
        self.mesh = body.mesh
        self.X = body.mesh.nodes
        self.n = body.mesh.n_nodes
        self.law = LAW_NAMES[body.material.law]
        self.prm = material_parameters(self.law, body.material.E, body.material.nu)
        self.rho = body.material.rho
        self.U = np.zeros((self.n, 2))
        self.V = np.zeros((self.n, 2))
        self.Un = np.zeros((self.n, 2))
        self.Vn = np.zeros((self.n, 2))
        self.Vrate = np.zeros((self.n, 2))  # velocity change per unit time over the last time step
        self.gnode = np.full(self.n, -1, dtype=np.int64)
        self.qxi, self.qw = gauss_quad(2)
        self._r_old: np.ndarray | None = None
        self._dirichlet = []
        fixed = np.zeros((self.n, 2), dtype=bool)
        for d in body.dirichlet:
            nodes = self._node_set(d.boundary)
            for c, expr in enumerate(d.values):
                if expr is not None:
                    self._dirichlet.append((nodes, c, expr, d.function))
                    fixed[nodes, c] = True
        if body.rigid:
            missing = ~fixed
            if missing.any():
                raise InputError(f"bodies.{self.name}.rigid", True,
                                 "a rigid body needs every node prescribed (Dirichlet on boundary 'body')")
        self.fixed = fixed
        self._neumann = [(self.mesh.edge_sets[nm.boundary], nm) for nm in body.neumann]

    @property
    def has_dofs(self) -> bool:
        """False for a fully prescribed (rigid) body: it is placed at the start of every step
        and carries no unknowns, so a finely meshed rigid body costs nothing in the solve."""
        return not self.fixed.all()

    def _node_set(self, name: str) -> np.ndarray:
        if name == "body":
            return np.arange(self.n)
        if name in self.mesh.node_sets:
            return self.mesh.node_sets[name]
        return np.unique(self.mesh.edge_sets[name])

    # ----------------------------------------------------------------- layout
    def blocks(self) -> list[np.ndarray]:
        conn = [self.gnode[self.mesh.cells]]
        for edges, nm in self._neumann:
            if nm.kind == "pressure":
                conn.append(self.gnode[edges])
        return conn

    def dirichlet_values(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Local nodes, components and prescribed displacements at time ``t``."""
        nodes, comps, vals = [], [], []
        for nd, c, expr, fn in self._dirichlet:
            nodes.append(nd)
            comps.append(np.full(len(nd), c))
            vals.append(expr(self.X[nd, 0], self.X[nd, 1], t) * fn(t))
        if not nodes:
            e = np.zeros(0, dtype=np.int64)
            return e, e, np.zeros(0)
        return np.concatenate(nodes), np.concatenate(comps), np.concatenate(vals)

    # ----------------------------------------------------------------- time stepping
    def begin_step(self, ctx: StepContext) -> None:
        """Store the explicit (1 - theta) part of the internal and follower forces and start
        Newton (free dofs) from the displacement whose one-step-theta velocity is the predicted
        ``v = v_n + lead (v_n − v_(n−1)) / Δt_n``: ``d_n + Δt v_n + θ Δt lead (v_n − v_(n−1)) /
        Δt_n``. With ``lead = 0`` the constant-velocity predictor (the first residual is O(Δt)
        instead of the inertia of the whole velocity change), with ``lead = Δt`` the
        constant-acceleration one (O(Δt²) where the motion is smooth). A static step starts
        from ``d_n``: its first Newton increment, with the change of the prescribed
        displacements in the residual, is the tangent predictor (a secant one, as the fluid's,
        overshoots where contact spreads: 355 Newton iterations instead of 77 on two-blocks)."""
        self._r_old = None
        if not ctx.static:
            if ctx.theta < 1.0:
                self._r_old = self.old_force(ctx)
            free = ~self.fixed
            self.U[free] = self.Un[free] + ctx.dt * self.Vn[free]
            if ctx.lead:
                self.U[free] += ctx.theta * ctx.dt * ctx.lead * self.Vrate[free]

    def velocity_from(self, U: np.ndarray, ctx: StepContext) -> np.ndarray:
        """One-step-theta velocity ``v = (d - d_n)/(theta dt) - (1 - theta)/theta v_n``."""
        if ctx.static:
            return (U - self.Un) / ctx.dt
        return (U - self.Un) / (ctx.theta * ctx.dt) - (1.0 - ctx.theta) / ctx.theta * self.Vn

    def finish_step(self, ctx: StepContext) -> None:
        """Derived quantities of the converged step (velocity), old level untouched."""
        self.V = self.velocity_from(self.U, ctx)

    def end_step(self, ctx: StepContext) -> None:
        """Move to the next time level."""
        if not ctx.static:
            self.Vrate = (self.V - self.Vn) / ctx.dt
        self.Un = self.U.copy()
        self.Vn = self.V.copy()

    # ----------------------------------------------------------------- assembly
    def quadrature_points(self) -> np.ndarray:
        """Reference coordinates of all cell quadrature points, ``(n_cells * nq, 2)``."""
        from fsci.fem.q1 import q1_values

        N = q1_values(self.qxi)
        return np.einsum("qa,ead->eqd", N, self.X[self.mesh.cells]).reshape(-1, 2)

    def _body_force(self, ctx: StepContext) -> np.ndarray:
        """Time-weighted body force per unit mass at every quadrature point."""
        nq = self.mesh.n_cells * len(self.qw)
        return time_weighted_vector(self.body.body_force, self.body.body_force_function, ctx,
                                    self.quadrature_points, nq)

    def assemble(self, asm: Assembly, ctx: StepContext) -> None:
        tgt = asm.target()
        static = ctx.static
        mass_coef = 0.0 if static or self.rho == 0.0 else 1.0 / (ctx.theta * ctx.dt ** 2)
        upred = self.Un + ctx.dt * self.Vn
        w_int = 1.0 if static else ctx.theta
        conn = self.gnode[self.mesh.cells]
        sk.assemble_solid(self.X, self.mesh.cells, self.U, self.law, self.prm, self.rho, mass_coef, upred, w_int,
                          self._body_force(ctx), self.qxi, self.qw, self.gnode, asm.positions(conn), *tgt)
        self._assemble_neumann(asm, self.U, ((ctx.t_new, ctx.w_new), (ctx.t_old, ctx.w_old)), dead=True,
                               follower=True)
        if self._r_old is not None:
            start = asm.layout.start[self.gnode]
            for c in range(2):
                asm.rhs[start + c] += self._r_old[:, c]

    def _edge_loads(self, edges: np.ndarray, nm, levels) -> tuple[np.ndarray, np.ndarray]:
        """Per-edge dead traction ``(k, 2)`` and follower pressure ``(k,)``, time-weighted.

        Load expressions are evaluated at the edge midpoints (reference coordinates)."""
        key = (id(nm), tuple(levels))
        cache = self.__dict__.setdefault("_load_cache", {})
        if cache.get(key, (None,))[0] is nm:  # same condition and time levels: same values
            return cache[key][1], cache[key][2]
        mid = 0.5 * (self.X[edges[:, 0]] + self.X[edges[:, 1]])
        traction = np.zeros((len(edges), 2))
        pressure = np.zeros(len(edges))
        for t, w in levels:
            if w == 0.0:
                continue
            f = nm.function(t) * w
            if nm.kind == "traction":
                for c in range(2):
                    traction[:, c] += nm.values[c](mid[:, 0], mid[:, 1], t) * f
            else:
                pressure += nm.values[0](mid[:, 0], mid[:, 1], t) * f
        if len(cache) > 16:
            cache.clear()
        cache[key] = (nm, traction, pressure)
        return traction, pressure

    def _assemble_neumann(self, asm: Assembly, U: np.ndarray, levels, dead: bool, follower: bool) -> None:
        """Dead loads with both time levels; follower pressures only at t_new (old part in r_old)."""
        tgt = asm.target()
        for edges, nm in self._neumann:
            if (nm.kind == "traction" and not dead) or (nm.kind == "pressure" and not follower):
                continue
            use = levels if nm.kind == "traction" else levels[:1]
            traction, pressure = self._edge_loads(edges, nm, use)
            conn = self.gnode[edges]
            sk.assemble_edge_loads(self.X, U, edges, traction, pressure, self.gnode, asm.positions(conn), *tgt)

    def old_force(self, ctx: StepContext) -> np.ndarray:
        """(1 - theta) (F_int(d_n) - F_follower(d_n)) as a nodal array ``(n, 2)``."""
        from fsci.assembly import ResidualAssembly
        from fsci.fem.sparse import DofLayout

        asm = ResidualAssembly(DofLayout(np.full(self.n, 2)))
        tgt = asm.target()
        gid = np.arange(self.n, dtype=np.int64)
        cells = self.mesh.cells
        sk.assemble_solid(self.X, cells, self.Un, self.law, self.prm, self.rho, 0.0, self.Un, 1.0 - ctx.theta,
                          np.zeros((len(cells) * len(self.qw), 2)), self.qxi, self.qw, gid, asm.positions(cells), *tgt)
        for edges, nm in self._neumann:
            if nm.kind == "pressure":
                _, p = self._edge_loads(edges, nm, ((ctx.t_old, 1.0 - ctx.theta),))
                sk.assemble_edge_loads(self.X, self.Un, edges, np.zeros((len(edges), 2)), p, gid,
                                       asm.positions(edges), *tgt)
        return asm.rhs.reshape(-1, 2)

    def cell_stress(self) -> np.ndarray:
        out = np.empty((self.mesh.n_cells, 3))
        sk.cell_cauchy_stress(self.X, self.mesh.cells, self.U, self.law, self.prm, out)
        return out


class FluidField:
    """Velocity/pressure on the virtual nodes of the background grid (one set of unknowns per
    node, or per node and connected fluid part, :class:`fsci.cut.state.CutState`; the first ``n_nodes`` are the grid nodes); ACTIVE
    virtual nodes carry dofs."""

    def __init__(self, fluid: Fluid) -> None:
        self.spec = fluid
        self.grid: Grid = fluid.grid
        g = self.grid
        self.rho = fluid.rho
        self.mu = fluid.mu
        self.sym = 1.0 if fluid.viscous_form == "symmetric" else 0.0
        n = g.n_nodes
        self.V = np.zeros((n, 2))
        self.P = np.zeros(n)
        self.Vn = np.zeros((n, 2))
        self.Pn = np.zeros(n)
        self.Vbar = np.zeros((n, 2))  # velocity of the scalings in a time step (scaling_velocity)
        self.Vrate = np.zeros((n, 2))  # change per unit time over the last step (the predictors')
        self.Prate = np.zeros(n)
        self.active = np.ones(n, dtype=bool)
        self.gnode = np.full(n, -1, dtype=np.int64)
        self.vnode_node = np.arange(n, dtype=np.int64)  # background node of each virtual node
        self.vnode_rep = g.nodes.astype(float)  # a point of its fluid (matches unknowns across cuts)
        st = fluid.stabilization
        self.stab = (st.gamma_u, st.gamma_p, st.gamma_div, st.gamma_gp, st.gamma_gp_t)
        self._dirichlet = []
        for d in fluid.dirichlet:
            nodes = g.side_nodes(d.boundary)
            for c, expr in enumerate(d.values):
                if expr is not None:
                    self._dirichlet.append((nodes, c, expr, d.function))
        self._neumann = [(nm.boundary, g.side_normal(nm.boundary), nm) for nm in fluid.neumann]
        # sides on which the normal velocity is prescribed (no outflow, no traction condition)
        normal_comp = {"left": 0, "right": 0, "bottom": 1, "top": 1}
        self._closed_sides = {d.boundary for d in fluid.dirichlet if d.values[normal_comp[d.boundary]] is not None}
        self.cut = None
        self._blocks_of: tuple[np.ndarray, np.ndarray] | None = None  # the parts and faces of self._blocks

    # ----------------------------------------------------------------- geometry
    def set_cut(self, cut, extend: bool = True) -> bool:
        """Take integration parts, quadrature, faces and the ACTIVE virtual nodes from a
        CutState and carry the state over to its virtual nodes (a node's set of unknowns
        from the set of the previous cut at that node whose fluid lies nearest; newly ACTIVE nodes,
        if ``extend``, from their neighbours, paper Sec. 3.4.3). Returns True if the ACTIVE
        virtual nodes changed (the dof layout must then be rebuilt)."""
        self.cut = cut
        self.int_cells = cut.int_cells
        self.int_conn = cut.int_conn
        self.qptr = cut.qptr
        self.qx = cut.qx
        self.qw = cut.qw
        st = self.spec.stabilization
        # "residual": the cells carry the bulk stabilisation, the faces only the ghost penalty
        keep = np.ones(len(cut.faces), dtype=bool) if st.scheme == "cip" else cut.ghost.copy()
        if not st.ghost_penalty:
            keep &= ~cut.ghost
        self.faces = cut.faces[keep]
        self.ghost_weight = cut.ghost_weights(st.ghost_ramp)[keep]
        self.ghost_cell, self.ghost_slope = (a[keep] for a in cut.ghost_weight_slopes(st.ghost_ramp))
        self.face_nodes = cut.face_vnodes[keep]
        n = self.grid.n_nodes
        single = cut.n_vnodes == n and len(self.active) == n
        same = (cut.n_vnodes == len(self.active) and np.array_equal(cut.active, self.active)
                and np.array_equal(cut.vnode_node, self.vnode_node))
        if single and (same or not extend):
            changed = not same
            self.active = cut.active.copy()
            return changed
        src = transfer_indices(self.vnode_node, self.vnode_rep, self.active, cut.vnode_node, cut.vnode_rep, n)
        for name in FLUID_VALUES:
            setattr(self, name, carry_values(self.grid, getattr(self, name), src, cut.vnode_node, cut.active, extend))
        self.vnode_node = cut.vnode_node
        self.vnode_rep = cut.vnode_rep
        self.active = cut.active.copy()
        return not same

    @property
    def node_active(self) -> np.ndarray:
        """ACTIVE background nodes (those with at least one ACTIVE set of unknowns)."""
        return self.active[:self.grid.n_nodes]

    def vnodes_of(self, nodes: np.ndarray) -> np.ndarray:
        """The ACTIVE virtual nodes of background nodes ``nodes``."""
        nodes = np.asarray(nodes, dtype=np.int64)
        n = self.grid.n_nodes
        v = nodes[self.active[nodes]]
        if len(self.vnode_node) > n:
            v = np.concatenate([v, n + np.nonzero(np.isin(self.vnode_node[n:], nodes))[0]])
        return v

    def blocks(self) -> list[np.ndarray]:
        return [self.gnode[self.int_conn], self.gnode[self.face_nodes]]

    def nodes_around(self, nodes: np.ndarray) -> np.ndarray:
        """The global nodes of every integration part touching the global fluid nodes ``nodes``
        ``(k, m)`` (entries ``< 0`` none): ``(k, p)``, each node once per row, the rest -1. For
        the nodes of a cell: the nodes of the cell and its neighbours in its fluid region."""
        G = self.gnode[self.int_conn]
        n = int(G.max(initial=-1)) + 1
        flat = G.ravel()
        part = np.repeat(np.arange(len(G)), G.shape[1])
        ok = flat >= 0
        order = np.argsort(flat[ok], kind="stable")
        flat, part = flat[ok][order], part[ok][order]
        count = np.bincount(flat, minlength=n)
        table = np.full((n, int(count.max(initial=1))), -1, dtype=np.int64)  # the parts of a node
        table[flat, np.arange(len(flat)) - np.repeat(np.cumsum(count) - count, count)] = part
        q = np.asarray(nodes, dtype=np.int64).reshape(len(nodes), -1)
        fluid = (q >= 0) & (q < n)
        parts = np.where(fluid[..., None], table[np.where(fluid, q, 0)], -1)
        out = np.where(parts[..., None] >= 0, G[np.maximum(parts, 0)], -1).reshape(len(q), -1)
        out.sort(axis=1)
        out[:, 1:][out[:, 1:] == out[:, :-1]] = -1
        return out

    def evaluate(self, points: np.ndarray, cells: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Velocity ``(k, 2)`` and pressure at points inside given background cells."""
        from fsci.fem.q1 import q1_values

        g = self.grid
        x0 = np.column_stack([g.xs[g.cell_ij[cells, 0]], g.ys[g.cell_ij[cells, 1]]])
        N = q1_values(2.0 * (points - x0) / g.cell_size[cells] - 1.0)
        nodes = self.cut.conn_at(cells, points) if self.cut is not None else g.cells[cells]
        return np.einsum("ka,kad->kd", N, self.V[nodes]), np.einsum("ka,ka->k", N, self.P[nodes])

    def physical_polygons(self) -> tuple[list[np.ndarray], np.ndarray]:
        """PHYSICAL fluid cells as polygons (vertex arrays) with their parent cell ids."""
        import shapely

        from fsci.cut.state import FLUID

        g = self.grid
        polys, parents = [], []
        full = np.nonzero(self.cut.state == FLUID)[0]
        for c, xy in zip(full, g.nodes[g.cells[full]]):
            polys.append(xy)
            parents.append(c)
        for c, geom in sorted(self.cut.polygons.items()):
            for part in shapely.get_parts(geom):
                polys.append(np.asarray(part.exterior.coords)[:-1])
                parents.append(c)
        return polys, np.asarray(parents, dtype=np.int64)

    def output_mesh(self):
        """meshio mesh of the PHYSICAL fluid: cut cells as their polygons, cell data
        ``parent_cell``, point data velocity/pressure (evaluated in the parent cell)."""
        import meshio

        polys, parents = self.physical_polygons()
        counts = np.array([len(p) for p in polys], dtype=np.int64)
        pts = np.vstack(polys) if polys else np.zeros((0, 2))
        owner = np.repeat(parents, counts)
        v, p = self.evaluate(pts, owner) if len(pts) else (np.zeros((0, 2)), np.zeros(0))
        offs = np.concatenate([[0], np.cumsum(counts)])
        blocks, cdata = [], []
        for k in sorted(set(counts.tolist())):
            sel = np.nonzero(counts == k)[0]
            conn = offs[sel][:, None] + np.arange(k)[None, :]
            blocks.append(("quad" if k == 4 else ("triangle" if k == 3 else "polygon"), conn))
            cdata.append(parents[sel])
        return meshio.Mesh(np.column_stack([pts, np.zeros(len(pts))]), blocks,
                           point_data={"velocity": np.column_stack([v, np.zeros(len(pts))]), "pressure": p},
                           cell_data={"parent_cell": cdata})

    def speed_polygons(self) -> tuple[list[np.ndarray], np.ndarray]:
        polys, parents = self.physical_polygons()
        speed = np.linalg.norm(self.V, axis=1)
        inner = np.array([p.mean(axis=0) for p in polys]).reshape(-1, 2)
        return polys, speed[self.cut.conn_at(parents, inner)].mean(axis=1)

    # ----------------------------------------------------------------- data
    def dirichlet_values(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """ACTIVE virtual nodes, components (0, 1 velocity) and values at time ``t``."""
        nodes, comps, vals = [], [], []
        for nd, c, expr, fn in self._dirichlet:
            v = self.vnodes_of(nd)
            X = self.grid.nodes[self.vnode_node[v]]
            nodes.append(v)
            comps.append(np.full(len(v), c))
            vals.append(expr(X[:, 0], X[:, 1], t) * fn(t))
        if not nodes:
            e = np.zeros(0, dtype=np.int64)
            return e, e, np.zeros(0)
        return np.concatenate(nodes), np.concatenate(comps), np.concatenate(vals)

    def needs_pressure_pin(self) -> bool:
        """True if the normal velocity is prescribed on the whole fluid boundary: every box side
        with ACTIVE edges has a normal Dirichlet condition (embedded interfaces always prescribe
        the normal velocity), or a pressure reference point is given."""
        if self.spec.pressure_reference is not None:
            return True
        g = self.grid
        for side in ("left", "right", "bottom", "top"):
            e = g.side_edges(side)
            if side not in self._closed_sides and np.any(self.active[e[:, 0]] & self.active[e[:, 1]]):
                return False
        return True

    def pressure_pin(self) -> np.ndarray:
        """Virtual nodes whose pressure is fixed to 0 (none if the pressure is determined): the
        one nearest the reference point if given, else the first; with separate unknowns per
        fluid part one in each fluid piece (nothing else fixes a piece's pressure level)."""
        if not self.needs_pressure_pin():
            return np.zeros(0, dtype=np.int64)
        ref = self.spec.pressure_reference
        act = np.nonzero(self.active)[0]
        separate = self.cut is not None and self.cut.separate_parts
        piece = np.maximum(self.cut.vnode_piece[act], 0) if separate else np.zeros(len(act), np.int64)
        pins = []
        for k in np.unique(piece):
            mine = act[piece == k]
            if ref is None:
                pins.append(int(mine[0]))
            else:
                d = np.linalg.norm(self.grid.nodes[self.vnode_node[mine]] - ref[None, :], axis=1)
                pins.append(int(mine[np.argmin(d)]))
        return np.array(pins, dtype=np.int64)

    def body_force_density(self, ctx: StepContext) -> np.ndarray:
        """rho * b at the quadrature points, time-weighted, ``(nq, 2)``."""
        return self.rho * time_weighted_vector(self.spec.body_force, self.spec.body_force_function, ctx,
                                               lambda: self.qx, len(self.qw))

    # ----------------------------------------------------------------- time stepping
    def begin_step(self, ctx: StepContext) -> None:
        """Start the step from ``x_n + lead (x_n - x_(n-1)) / Δt_n`` (:class:`StepContext`):
        in steady flow (a static step) the secant predictor of continuation in the data, so
        that Newton begins near the flow at the next load level instead of at the last one; in
        a time step with the constant-acceleration predictor, the linear extrapolation in time
        (ACTIVE nodes only: an inactive node's rate is not updated, and its stale value would
        drift)."""
        if ctx.static:
            self.V = self.Vn + ctx.lead * self.Vrate
            self.P = self.Pn + ctx.lead * self.Prate
            return
        self.Vbar = self.Vn.copy()
        if ctx.lead:
            act = self.active
            self.V[act] = self.Vn[act] + ctx.lead * self.Vrate[act]
            self.P[act] = self.Pn[act] + ctx.lead * self.Prate[act]

    def end_step(self, ctx: StepContext) -> None:
        self.Vrate = (self.V - self.Vn) / ctx.dt
        self.Prate = (self.P - self.Pn) / ctx.dt
        self.Vn = self.V.copy()
        self.Pn = self.P.copy()

    # ----------------------------------------------------------------- assembly
    def cell_parameters(self, ctx: StepContext) -> np.ndarray:
        mass = 0.0 if ctx.static else self.rho / ctx.dt
        theta = 1.0 if ctx.static else ctx.theta
        residual = 1.0 if self.spec.stabilization.scheme == "residual" else 0.0
        return np.array([self.rho, self.mu, self.sym, mass, theta, residual, 1.0 if ctx.static else 0.0])

    def face_parameters(self, ctx: StepContext) -> np.ndarray:
        gu, gp, gdiv, ggp, ggpt = self.stab
        return np.array([self.rho, self.mu, gu, gp, gdiv, ggp, ggpt, 0.0 if ctx.static else 1.0 / ctx.dt,
                         1.0 if ctx.static else 0.0])

    def scaling_velocity(self, ctx: StepContext) -> np.ndarray:
        """The velocity the stabilisation and Nitsche scalings are evaluated at: in a time step
        the last step's, ``Vbar`` (frozen in the step, so the Jacobian needs no derivative of the
        scalings); in steady flow the unknown velocity itself, and the Jacobian includes the
        scalings' derivative (no last step to take it from; lagging it by one Newton iteration
        made Newton converge only linearly)."""
        return self.V if ctx.static else self.Vbar

    def assemble(self, asm: Assembly, ctx: StepContext) -> None:
        g = self.grid
        tgt = asm.target()
        body_force_q = self.body_force_density(ctx)
        conn = self.gnode[self.int_conn]
        Vo = self.Vn if not ctx.static else self.V
        ub = self.scaling_velocity(ctx)
        if self._blocks_of is None or not (np.array_equal(self._blocks_of[0], self.int_cells)
                                           and np.array_equal(self._blocks_of[1], self.faces)):
            # (a re-cut inside a step mostly keeps the cells and faces: then so do their blocks)
            self._blocks = (fk.coloured_blocks(g.cell_ij[self.int_cells]), fk.coloured_blocks(g.cell_ij[self.faces[:, 0]]))
            self._blocks_of = (self.int_cells, self.faces)
        cells = (g.xs, g.ys, g.nx, self.int_conn, self.int_cells, self.qptr, self.qx, self.qw, body_force_q, self.V,
                 self.P, Vo, ub, self.cell_parameters(ctx), self.gnode, asm.positions(conn), *tgt)
        faces = (g.xs, g.ys, g.nx, self.face_nodes, self.faces, self.ghost_weight, ub, self.V, self.P,
                 self.face_parameters(ctx), self.gnode, asm.positions(self.gnode[self.face_nodes]), *tgt)
        # the same sums in the same order either way (fsci.physics.fluid.coloured_blocks)
        for (order, bptr, cptr), args, serial, parallel in (
                (self._blocks[0], cells, fk.assemble_fluid_cells, fk.assemble_cells_in_parallel),
                (self._blocks[1], faces, fk.assemble_fluid_faces, fk.assemble_faces_in_parallel)):
            if len(order) >= PARALLEL_ITEMS and numba.get_num_threads() > 1:
                parallel(order, bptr, cptr, args)
            else:
                serial(order, *args)
        self._assemble_neumann(asm, ctx)

    def _assemble_neumann(self, asm: Assembly, ctx: StepContext) -> None:
        """Fluid tractions on box sides, integrated over the PHYSICAL part of each side."""
        if not self._neumann:
            return
        gx, gw = _GAUSS2
        X = self.grid.nodes
        start = asm.layout.start
        for side, normal, nm in self._neumann:
            if all(w == 0.0 or nm.function(t) * w == 0.0 for t, w in ((ctx.t_new, ctx.w_new), (ctx.t_old, ctx.w_old))):
                continue  # no load at either level (e.g. before a ramp starts): it would add zeros
            edges_all = self.grid.side_edges(side)
            k, s0, s1, vn = self.cut.boundary_pieces(side)
            if len(k) == 0:
                continue
            edges = edges_all[k]
            a, b = edges[:, 0], edges[:, 1]
            length = np.linalg.norm(X[b] - X[a], axis=1) * (s1 - s0)
            for xg, wg in zip(gx, gw):
                s = s0 + 0.5 * (xg + 1.0) * (s1 - s0)
                Na, Nb = 1.0 - s, s
                p = Na[:, None] * X[a] + Nb[:, None] * X[b]
                traction = np.zeros((len(edges), 2))
                for t, w in ((ctx.t_new, ctx.w_new), (ctx.t_old, ctx.w_old)):
                    if w == 0.0:
                        continue
                    f = nm.function(t) * w
                    if nm.kind == "traction":
                        traction[:, 0] += nm.values[0](p[:, 0], p[:, 1], t) * f
                        traction[:, 1] += nm.values[1](p[:, 0], p[:, 1], t) * f
                    else:  # pressure: h = -p n (compressive normal traction)
                        pv = nm.values[0](p[:, 0], p[:, 1], t) * f
                        traction -= pv[:, None] * normal[None, :]
                wl = 0.5 * wg * length
                for node, Nn in ((vn[:, 0], Na), (vn[:, 1], Nb)):
                    dof = start[self.gnode[node]]
                    for c in range(2):
                        np.add.at(asm.rhs, dof + c, -(wl * Nn * traction[:, c]))
