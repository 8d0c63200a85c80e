"""The monolithic discrete system: unknown layout, assembly of every term, Dirichlet rows.

Unknowns are ``[u of body 0, u of body 1, ..., (v_x, v_y, p) of every ACTIVE fluid node]``
(paper Sec. 3.1: one set of fluid dofs per background node). Dirichlet rows are replaced by identity rows, the same way for every
field. Their residual is ``x_D - x_D(prescribed)``, so the first Newton increment carries the
change of the boundary values into the interior (consistent Dirichlet predictor).
"""

from __future__ import annotations

import numpy as np
import shapely

import time
import warnings

from fsci.assembly import Assembly, ResidualAssembly
from fsci.coupling import CouplingTerm
from fsci.cut.state import CutState
from fsci.errors import GeometryError, InputError, SolverError
from fsci.fem.sparse import DofLayout, Pattern, PatternCache
from fsci.fields import FLUID_VALUES, FluidField, SolidField, StepContext
from fsci.geometry.outlines import Outline, body_polygon, check_in_box, warn_if_thin
from fsci.problem import Problem

HOLD_AFTER_FLIPS = 2  # changes of the fluid's topology within a step after which dry regions are held
HOLD_MARGIN = 0.05  # a held region is grown by this × (smallest cell side): the bodies move on
# largest mass-balance error Φ¹_err of a state converged with a held region, relative to the
# step's largest flux: fluid flows through the held region's edge, where nothing holds it back,
# and a larger error repeats the step without the hold (decision 36). About twice what the
# squeezed body's states have without any hold (1.7e-6); most of the pump's held states stay below it.
HOLD_LEAK = 3e-6
# where the repeat without the hold fails, the held state is accepted after all if its error is
# at most this (decision 51): the step is solved once more with the hold instead of being cut,
# which on the pump's shutting outflow valve refused held states of 3e-6 … 6.7e-6 step after step
HOLD_LEAK_FALLBACK = 1e-5
# times in a step a converged state is solved again without the nodes that grow-only re-cuts kept
# (decision 41); after that, such a state is accepted as it is
MAX_OWN_DROPS = 2


class System:
    """All fields of a problem and the global dof layout."""

    def __init__(self, problem: Problem) -> None:
        self.problem = problem
        self.solids = [SolidField(b, i) for i, b in enumerate(problem.bodies)]
        self.fluid = FluidField(problem.fluid) if problem.fluid is not None else None
        self.patterns = PatternCache()
        self._pattern: Pattern | None = None  # the sparsity pattern matrices are assembled in (see pattern)
        self.extra_terms: list = []  # the coupling term (FSI, contact, FSCI)
        self.interface_edges = [self._interface_edges(s) for s in self.solids]
        self._loops = [s.mesh.boundary_loops() for s in self.solids]
        self._outlines: list[Outline | None] = [None] * len(self.solids)  # the last of each body (outlines)
        self.cut: CutState | None = None
        self.layout_changes = 0
        self.hold_swings = False  # hold contact that swings in this attempt (decision 38)
        self.hold_pockets = True  # hold a pocket that opens and shuts in this attempt (decision 36)
        self._cut_frozen = False
        self._follow_until = 0  # the cut follows the iterates up to this iteration of the step
        self._own_drops = 0  # re-cuts of the step that dropped kept nodes (decision 41)
        self._drop_kept = False  # the next re-cut drops them
        self._dry_seen = shapely.Polygon()  # islands of this step's cuts
        self._islands_last: int | None = None  # number of islands of the last cut
        self._topology_flips = 0  # changes of that number within the step
        self.timings = {"cut": 0.0, "assembly": 0.0}
        self.counts = {"cut": 0, "assembly": 0, "residual_only": 0}  # residual_only: assemblies without matrix
        if self.fluid is not None:
            try:
                self.update_cut(initial=True)
            except GeometryError as exc:
                raise InputError("bodies", "initial geometry", str(exc)) from None
        if (self.fluid is not None and self.solids) or any(b.contact for b in problem.bodies):
            self.extra_terms.append(CouplingTerm(self))
        self.build_layout()

    # ----------------------------------------------------------------- geometry
    @staticmethod
    def _interface_edges(s: SolidField) -> np.ndarray:
        """Coupling-interface edges Γ of a body: its ``interface`` sets, or every boundary edge
        that carries no Neumann load (paper Sec. 2)."""
        body = s.body
        if body.interface is not None:
            return np.vstack([s.mesh.edge_sets[n] for n in body.interface])
        loaded = {(int(a), int(b)) for nm in body.neumann for a, b in s.mesh.edge_sets[nm.boundary]}
        e = s.mesh.boundary.edges
        keep = np.array([(int(a), int(b)) not in loaded for a, b in e], dtype=bool)
        return e[keep]

    def outlines(self) -> list[Outline]:
        """Current outlines of all bodies (validated). A body whose nodes have not moved since
        its last outline (a fixed slab, a body between the iterates of a frozen one) keeps it."""
        out = []
        box = self.fluid.grid.box
        tol = 1e-10 * max(1.0, max(abs(v) for v in box))
        for b, s in enumerate(self.solids):
            x = s.X + s.U
            o = self._outlines[b]
            if o is None or not np.array_equal(o.x, x):
                o = Outline(b, s.name, x, self.interface_edges[b],
                            body_polygon(x, self._loops[b], s.name, s.body.dry_cavities), s.mesh.boundary.edges)
                if not s.body.extends_outside:
                    check_in_box(o, box, tol)
                self._outlines[b] = o
            out.append(o)
        return out

    def update_cut(self, keep_nodes: np.ndarray | None = None, initial: bool = False) -> bool:
        """Recompute the cut at the current positions; returns True if the ACTIVE set changed
        (the dof layout is then rebuilt and new nodes get extended values)."""
        f = self.fluid
        t0 = time.perf_counter()
        outlines = self.outlines()
        st = f.spec.interface
        # a pocket of fluid that is an island (dry) in one iterate and open to the fluid in the
        # next, back and forth: the residual jumps with it and Newton cycles (decision 36); after
        # two such changes in a step the islands of its cuts stay dry for the rest of the step
        held = shapely.buffer(self._dry_seen, HOLD_MARGIN * self._smallest_cell_side()) \
            if self.hold_pockets and self._topology_flips >= HOLD_AFTER_FLIPS else None
        cut = CutState(f.grid, outlines, st.island_factor, keep_nodes=keep_nodes, film_closure=st.film_closure,
                       separate_parts=st.unknowns == "per_fluid_part", trapped_film=st.trapped_film,
                       held_dry=held)
        if self._islands_last is not None and len(cut.islands) != self._islands_last:
            self._topology_flips += 1
        self._islands_last = len(cut.islands)
        if cut.islands:
            self._dry_seen = shapely.union_all([self._dry_seen, *cut.islands])
        self.timings["cut"] += time.perf_counter() - t0
        self.counts["cut"] += 1
        if initial and st.unknowns == "per_node":  # thin bodies share nodes only with one set per node
            g = f.grid
            for o in outlines:
                h = float(np.max(np.hypot(*g.cell_size[g.locate(o.x)].T))) / np.sqrt(2.0)

                def cell_h(x: float, y: float) -> float:
                    return float(np.hypot(*g.cell_size[g.locate(np.array([[x, y]]))[0]])) / np.sqrt(2.0)

                warn_if_thin(o, h, g.box, cell_h)
        changed = f.set_cut(cut, extend=not initial)
        self.cut = cut
        self._u_at_cut = [s.U.copy() for s in self.solids]
        if changed and not initial:
            self.build_layout()
        return changed

    def holds_pocket(self) -> bool:
        """Whether the current cut holds a region dry (decision 36)."""
        return self.cut is not None and self.cut.held_dry is not None and not self.cut.held_dry.is_empty

    def contact_swung(self) -> bool:
        """Whether contact swung back and forth in the iterations of the last attempt (decision 38)."""
        return any(term.swung for term in self.extra_terms)

    def _smallest_cell_side(self) -> float:
        return self.fluid.grid.h_min

    def _motion_since_cut(self) -> float:
        """Largest body displacement since the last cut, in units of the smallest cell side."""
        moved = max(float(np.max(np.abs(s.U - u0), initial=0.0)) for s, u0 in zip(self.solids, self._u_at_cut))
        return moved / self._smallest_cell_side()

    def cut_is_own(self) -> bool:
        """Whether a state that Newton converged to satisfies its own cut: the cut follows the
        iterates, or on a frozen cut the bodies moved at most ``own_cut_tol`` × (smallest cell)
        since it was made; and no node is ACTIVE only because a grow-only re-cut kept it (its
        CIP / ghost-penalty faces reach into cells its cut leaves out, and the state would
        depend on the iterates that activated it: decision 41), unless such nodes were dropped
        ``MAX_OWN_DROPS`` times in the step already. The last rule is for steady flow only,
        whose solution must not depend on the load steps; in a time step the kept nodes lie
        within the step's motion and the ACTIVE set can cycle where dropping them restarts it
        (a valve shutting). Otherwise the state solves another geometry or discrete space and
        :meth:`follow_cut_again` must be called."""
        if self.fluid is None:
            return True
        if self._kept_to_drop():
            return False
        if not self._cut_frozen:
            return True
        return self._motion_since_cut() <= self.fluid.spec.interface.own_cut_tol

    def _kept_to_drop(self) -> bool:
        """Whether a converged steady-flow state holds nodes kept by grow-only re-cuts that are
        to be dropped (decision 41)."""
        return self.ctx.static and self.cut.kept_nodes > 0 and self._own_drops < MAX_OWN_DROPS

    def cut_follows(self) -> bool:
        """Whether the cut was rebuilt at the current iterate (the shape derivative is then in
        the Jacobian, but in contact only in part: decision 21)."""
        return self.fluid is not None and self.moving() and not self._cut_frozen

    def keep_following(self, it: int) -> None:
        """The cut follows the iterates at least up to iteration ``it`` (Newton converges while
        it follows: decision 35)."""
        if not self._cut_frozen:
            self._follow_until = max(self._follow_until, it)

    def follow_cut_again(self, it: int) -> None:
        """A converged state was not the state's own cut: the cut follows the iterates again
        for ``freeze_cut_after`` iterations from iteration ``it``; the next re-cut drops the
        nodes that grow-only re-cuts kept (the ACTIVE set then starts again from the cut's own)."""
        if self._kept_to_drop():
            self._own_drops += 1
            self._drop_kept = True
        self._cut_frozen = False
        self._follow_until = it + self.fluid.spec.interface.freeze_cut_after

    def moving(self) -> bool:
        """True if a body's shape or position is an unknown (its cut may change in Newton)."""
        return any(not s.fixed.all() for s in self.solids)

    def before_iteration(self, it: int) -> bool:
        """Before assembling Newton iteration ``it``: re-cut while the bodies moved more than
        eps_geom since the last cut and at most ``freeze_cut_after`` iterations into the step or
        since :meth:`follow_cut_again` was called for a frozen-cut state (paper Sec. 3.4.2; the
        shape derivative is left out of the Jacobian while the cut is frozen), and apply the
        solution-space update rule (Sec. 3.4.3). Returns True if the dof layout changed."""
        f = self.fluid
        if it > 1:
            for term in self.extra_terms:  # contact that swings (held in a repeated attempt, decision 38)
                term.track_case_swings(hold=self.hold_swings)
        if f is None or not self.solids or it == 1 or not self.moving():
            return False
        st = self.fluid.spec.interface
        if it == 2:
            self._cut_frozen = False
            self._follow_until = st.freeze_cut_after
        if it > self._follow_until:
            self._cut_frozen = True
            return False  # cut kept fixed: Newton finishes on it (its Jacobian is exact)
        if self._motion_since_cut() <= st.eps_geom and not self._drop_kept:
            return False
        grow_only = it > st.grow_only_after or self.layout_changes >= st.max_layout_changes
        # the nodes that stay ACTIVE: in a time step those of all the step's cuts; in steady flow
        # those of the last cut (a state holding kept nodes is solved again without them,
        # decision 41, and the smaller set needs fewer iterations to that)
        keep = None
        if grow_only and not self._drop_kept:
            keep = self.fluid.node_active.copy() if self.ctx.static else self._step_active
        pieces = len(self.cut.pieces)
        changed = self.update_cut(keep_nodes=keep)
        if self._drop_kept:
            self._drop_kept = False
            self._step_active = self.fluid.node_active.copy()
        if changed:
            self.layout_changes += 1
            self._step_active |= self.fluid.node_active
        if self.cut.separate_parts and len(self.cut.pieces) != pieces:
            # a gap that closes in one iterate and opens by a fraction of a cell in the next:
            # the unknowns split and merge in turn and Newton cycles; a smaller step starts
            # closer to the event
            self.piece_changes += 1
            if self.piece_changes > st.max_layout_changes:
                raise SolverError(f"the fluid split and merged again {self.piece_changes} times in this step")
        return changed

    # ----------------------------------------------------------------- layout
    def build_layout(self) -> None:
        """Number global nodes: solid nodes body by body, then ACTIVE fluid nodes."""
        ndof = []
        offset = 0
        for s in self.solids:
            if not s.has_dofs:  # fully prescribed: placed at every step start, no unknowns
                s.gnode = np.full(s.n, -1, dtype=np.int64)
                continue
            s.gnode = offset + np.arange(s.n, dtype=np.int64)
            offset += s.n
            ndof.append(np.full(s.n, 2))
        if self.fluid is not None:
            f = self.fluid
            act = np.nonzero(f.active)[0]
            f.gnode = np.full(len(f.active), -1, dtype=np.int64)
            f.gnode[act] = offset + np.arange(len(act), dtype=np.int64)
            offset += len(act)
            ndof.append(np.full(len(act), 3))
        self.layout = DofLayout(np.concatenate(ndof) if ndof else np.zeros(0, dtype=np.int64))
        st = self.layout.start
        disp = [st[s.gnode][:, None] + np.arange(2)[None, :] for s in self.solids if s.has_dofs]
        self.field_dofs: dict[str, np.ndarray] = {}
        if disp:
            self.field_dofs["displacement"] = np.concatenate([d.ravel() for d in disp])
        if self.fluid is not None:
            fdofs = st[self.fluid.gnode[self.fluid.active]]
            self.field_dofs["velocity"] = np.concatenate([fdofs, fdofs + 1])
            self.field_dofs["pressure"] = fdofs + 2

    def blocks(self) -> list[np.ndarray]:
        out = []
        for s in self.solids:
            if s.has_dofs:
                out += s.blocks()
        if self.fluid is not None:
            out += self.fluid.blocks()
        for term in self.extra_terms:
            out += term.blocks(self)
        return out

    # ----------------------------------------------------------------- state
    def gather(self) -> np.ndarray:
        x = np.zeros(self.layout.n_dofs)
        st = self.layout.start
        for s in self.solids:
            if not s.has_dofs:
                continue
            i = st[s.gnode]
            x[i] = s.U[:, 0]
            x[i + 1] = s.U[:, 1]
        if self.fluid is not None:
            f = self.fluid
            act = f.active
            i = st[f.gnode[act]]
            x[i] = f.V[act, 0]
            x[i + 1] = f.V[act, 1]
            x[i + 2] = f.P[act]
        return x

    def scatter(self, x: np.ndarray) -> None:
        st = self.layout.start
        for s in self.solids:
            if not s.has_dofs:
                continue
            i = st[s.gnode]
            s.U[:, 0] = x[i]
            s.U[:, 1] = x[i + 1]
        if self.fluid is not None:
            f = self.fluid
            act = f.active
            i = st[f.gnode[act]]
            f.V[act, 0] = x[i]
            f.V[act, 1] = x[i + 1]
            f.P[act] = x[i + 2]

    # ----------------------------------------------------------------- boundary conditions
    def dirichlet(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """Global Dirichlet dofs and their values at time ``t`` (incl. a pressure pin); cached
        per (t, dof layout): every Newton iteration of a step asks for the same values."""
        cached = getattr(self, "_dirichlet_cache", None)
        if cached is not None and cached[0] == t and cached[1] is self.layout:
            return cached[2], cached[3]
        d, v = self._dirichlet(t)
        self._dirichlet_cache = (t, self.layout, d, v)
        return d, v

    def _dirichlet(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        dofs, vals = [], []
        st = self.layout.start
        for s in self.solids:
            if not s.has_dofs:
                continue
            nodes, comps, v = s.dirichlet_values(t)
            dofs.append(st[s.gnode[nodes]] + comps)
            vals.append(v)
        if self.fluid is not None:
            f = self.fluid
            nodes, comps, v = f.dirichlet_values(t)
            dofs.append(st[f.gnode[nodes]] + comps)
            vals.append(v)
            pins = f.pressure_pin()
            dofs.append(st[f.gnode[pins]] + 2)
            vals.append(np.zeros(len(pins)))
        if not dofs:
            return np.zeros(0, dtype=np.int64), np.zeros(0)
        d = np.concatenate(dofs).astype(np.int64)
        v = np.concatenate(vals)
        # the last definition of a dof wins (later conditions override earlier ones)
        _, last = np.unique(d[::-1], return_index=True)
        keep = len(d) - 1 - last
        return d[keep], v[keep]


    # ----------------------------------------------------------------- steps
    def begin_step(self, ctx: StepContext, hold_swings: bool = False, hold_pockets: bool = True) -> None:
        """Start the step ``ctx``; with ``hold_swings`` contact that swings in its iterations is
        held (a repeated attempt, decision 38); with ``hold_pockets`` False a pocket that opens
        and shuts is not held dry (a repeat after a held state lost mass, decision 36)."""
        self.hold_swings = hold_swings
        self.hold_pockets = hold_pockets
        for term in self.extra_terms:  # the old time level, before anything of the new step moves
            term.store_old_level(self, ctx)
        for s in self.solids:
            if s.fixed.all():  # fully prescribed body: place it before cutting
                nodes, comps, vals = s.dirichlet_values(ctx.t_new)
                s.U[nodes, comps] = vals
            s.begin_step(ctx)
        if self.fluid is not None and self.solids:
            self._dry_seen, self._islands_last, self._topology_flips = shapely.Polygon(), None, 0
            self.update_cut()
            self.layout_changes = 0
            self.piece_changes = 0
            self._own_drops = 0
            self._drop_kept = False
            self._step_active = self.fluid.node_active.copy()
        if self.fluid is not None:
            self.fluid.begin_step(ctx)
        for term in self.extra_terms:
            term.begin_step(self, ctx)
        self.ctx = ctx

    def finish_step(self, ctx: StepContext) -> None:
        """After convergence: derived quantities (solid velocities); the old time level is kept
        so that quantities evaluated now see the complete residual of the step."""
        for s in self.solids:
            s.finish_step(ctx)

    def end_step(self, ctx: StepContext) -> None:
        for s in self.solids:
            s.end_step(ctx)
        if self.fluid is not None:
            self.fluid.end_step(ctx)

    # ----------------------------------------------------------------- assembly
    def pattern(self) -> Pattern:
        """The sparsity pattern to assemble the current state's matrix in.

        While the bodies move, the coupling's node pairs change with the cut from one Newton
        iteration (and step) to the next, and every new pattern costs a new symbolic analysis
        of the linear solver (FSI1 at m = 12: 0.3-0.55 s each) and ends the reuse of its
        factors. So a new pattern also holds the pairs the interface may reach by moving up
        to a cell (the coupling's ``reach``), and later matrices are assembled into it (explicit
        zeros where their terms couple nothing) as long as every pair of theirs is in it and
        the dof layout is the same (docs/architecture.md, decision 45). The pattern kept is
        that of the last matrix Newton solved with (:meth:`keep_pattern`; a matrix assembled and
        not used changes nothing), and it is part of the state (:func:`snapshot`), so a
        restarted run is bit-identical to an uninterrupted one (decision 15)."""
        blocks = self.blocks()
        p = self._pattern
        if p is not None and np.array_equal(p.layout.ndof, self.layout.ndof) and p.covers(blocks):
            return p
        reach = [r for term in self.extra_terms for r in term.reach(self)] if self.moving() else []
        return self.patterns.get(self.layout, blocks, reach)

    def keep_pattern(self, pattern: Pattern) -> None:
        """``pattern`` is that of a matrix Newton solved with: later matrices go into it while
        they fit (:meth:`pattern`)."""
        self._pattern = pattern

    def assemble(self, ctx: StepContext, want_matrix: bool = True, dirichlet: bool = True) -> Assembly:
        """Residual (and Jacobian) of all terms at the current state."""
        t0 = time.perf_counter()
        pattern = self.pattern() if want_matrix else None
        asm = Assembly(self.layout, pattern, want_matrix) if want_matrix else ResidualAssembly(self.layout)
        for s in self.solids:
            if s.has_dofs:
                s.assemble(asm, ctx)
        if self.fluid is not None:
            self.fluid.assemble(asm, ctx)
        for term in self.extra_terms:
            term.assemble(self, asm, ctx)
        if dirichlet:
            dofs, vals = self.dirichlet(ctx.t_new)
            asm.apply_dirichlet(dofs, self.gather()[dofs] - vals)
        self.timings["assembly"] += time.perf_counter() - t0
        self.counts["assembly" if want_matrix else "residual_only"] += 1
        return asm


FLUID_STATE = FLUID_VALUES + ("active", "vnode_node", "vnode_rep")
SOLID_STATE = ("U", "V", "Un", "Vn", "Vrate")


def snapshot(system: System) -> dict[str, np.ndarray]:
    """Copy of every state array of the system (for step retries and checkpoints)."""
    state: dict[str, np.ndarray] = {}
    for s in system.solids:
        for k in SOLID_STATE:
            state[f"solid{s.index}.{k}"] = getattr(s, k).copy()
    if system.fluid is not None:
        f = system.fluid
        for k in FLUID_STATE:
            state[f"fluid.{k}"] = getattr(f, k).copy()
    if system._pattern is not None:  # the matrices' sparsity pattern (never changed in place)
        state["pattern.nptr"], state["pattern.nbr"] = system._pattern.nptr, system._pattern.nbr
    return state


def restore(system: System, state: dict[str, np.ndarray]) -> None:
    """Inverse of :func:`snapshot`; rebuilds the layout if the ACTIVE set differs. The cut is
    recomputed by the next ``begin_step`` (callers that need it before call ``update_cut``)."""
    for s in system.solids:
        for k in SOLID_STATE:
            key = f"solid{s.index}.{k}"
            # checkpoints written before the constant-acceleration predictor lack the rate (only it)
            setattr(s, k, state[key].copy() if key in state or k != "Vrate" else np.zeros_like(s.U))
    if system.fluid is not None:
        f = system.fluid
        old_active = f.active.copy()
        n = f.grid.n_nodes
        for k in FLUID_STATE:
            # checkpoints written before virtual nodes or the load-step predictor lack these
            default = {"vnode_node": np.arange(n), "vnode_rep": f.grid.nodes,
                       "Vrate": np.zeros_like(f.V), "Prate": np.zeros_like(f.P)}.get(k)
            setattr(f, k, state.get(f"fluid.{k}", default).copy())
        if not np.array_equal(old_active, f.active):
            system.build_layout()
    p = system._pattern
    if "pattern.nbr" not in state or len(state["pattern.nptr"]) != system.layout.n_nodes + 1:
        system._pattern = None  # none kept, or a checkpoint written before patterns were in the state
    elif p is None or p.nbr is not state["pattern.nbr"]:
        system._pattern = Pattern.from_graph(system.layout, state["pattern.nptr"], state["pattern.nbr"])
