"""Separate fluid unknowns per connected fluid part (``fluid.interface.unknowns =
"per_fluid_part"``): a node whose cells hold fluid on both sides of a body thinner than a cell
(a thin wall, a ring) carries one set of unknowns for each side, and nothing couples them."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fsci.config import problem_from_dict
from fsci.cut.state import SOLID, CutState
from fsci.errors import FsciWarning, SolverError
from fsci.fields import StepContext
from fsci.post.quantities import flow_rate
from fsci.simulation import Simulation
from fsci.system import System

from cutcases import static_case
from helpers import check_jacobian

H = 0.125  # cell size of the grid below
X0, X1 = 0.90, 0.96  # the wall: thinner than half a cell, inside the cell column [0.875, 1]


def _wall_case(x0: float = X0, x1: float = X1, **fluid) -> dict:
    """Box [0, 2] × [0, 1], 16 × 8 cells, a fixed rigid wall x ∈ [x0, x1] through the whole
    height (it reaches outside the box, so the fluid is two pieces); pressure 1 on the left
    side, 0 on the right, no slip at the bottom and top."""
    a, b = -0.05, 1.05
    sides = {"bottom": {"line": [[x0, a], [x1, a]]}, "right": {"line": [[x1, a], [x1, b]]},
             "top": {"line": [[x0, b], [x1, b]]}, "left": {"line": [[x0, a], [x0, b]]}}
    wall = {"name": "wall", "rigid": True, "extends_outside": True, "interface": ["left", "right"],
            "material": {"law": "neo_hooke", "E": 1.0, "nu": 0.3},
            "mesh": {"type": "mapped", "nx": 2, "ny": 24, "sides": sides},
            "dirichlet": [{"boundary": "body", "value": [0.0, 0.0]}]}
    f = {"rho": 1.0, "mu": 1.0, "grid": {"x": {"start": 0.0, "end": 2.0, "cells": 16},
                                         "y": {"start": 0.0, "end": 1.0, "cells": 8}},
         "dirichlet": [{"boundary": s, "value": [0.0, 0.0]} for s in ("bottom", "top")],
         "neumann": [{"boundary": "left", "type": "pressure", "value": ["1"]}],
         "interface": {"unknowns": "per_fluid_part"}}
    f.update(fluid)
    return static_case([wall], f)


@pytest.fixture(scope="module")
def wall_run():
    sim = Simulation(problem_from_dict(_wall_case()))
    sim.run()
    return sim


def test_nodes_beside_a_thin_wall_carry_one_set_of_unknowns_per_side(wall_run):
    """The wall cuts the cells of one column into a left and a right fluid part: their nodes
    (two grid lines of 9 nodes) carry a second set, every integration part and every face
    stays within one piece, and the wall's pieces of interface see the piece on their side."""
    cut = wall_run.system.cut
    g = cut.grid
    assert len(cut.pieces) == 2
    assert cut.n_vnodes == g.n_nodes + 18
    two = np.unique(cut.vnode_node[g.n_nodes:])
    assert np.allclose(np.unique(g.nodes[two, 0]), [0.875, 1.0])
    piece_left = cut.piece_of(np.array([[0.5, 0.5]]))[0]
    pieces = cut.vnode_piece[cut.int_conn]
    assert np.all(pieces == pieces[:, :1]), "an integration part mixes pieces"
    assert np.all(cut.state[cut.int_cells] != SOLID)
    fp = cut.vnode_piece[cut.face_vnodes]
    fp = np.where(fp < 0, fp.max(axis=1, keepdims=True), fp)
    assert np.all(fp == fp[:, :1]), "a face term couples two pieces"
    seg = cut.segments
    wet = seg.fs
    side = cut.vnode_piece[cut.part_conn(seg.part[wet])]
    mid_x = np.array([cut.outlines[0].x[cut.outlines[0].edges[e]].mean(axis=0)[0] for e in seg.edge[wet]])
    expected = np.where(mid_x < 0.93, piece_left, 1 - piece_left)
    assert np.all(side == expected[:, None])


def test_a_wall_between_two_pieces_holds_the_pressure_difference(wall_run):
    """Fluid at rest with pressure 1 left of the wall and 0 right of it is the exact solution
    and lies in the discrete space only if the nodes beside the wall carry one set of unknowns
    per side (with one set, the pressure jump inside a cell drives a flow through the wall).
    Asserted to solver tolerance: |v| < 1e-10, |p - 1| and |p| < 1e-10, no flow through the
    left side (measured 0 to round-off)."""
    sim = wall_run
    f = sim.system.fluid
    cut = sim.system.cut
    act = np.nonzero(f.active)[0]
    piece = cut.vnode_piece[act]
    left = piece == cut.piece_of(np.array([[0.5, 0.5]]))[0]
    assert np.abs(f.V[act]).max() < 1e-10
    assert np.abs(f.P[act[left]] - 1.0).max() < 1e-10
    assert np.abs(f.P[act[~left & (piece >= 0)]]).max() < 1e-10
    assert abs(flow_rate(f, "left")) < 1e-10


def _ring(r_out: float = 0.3, r_in: float = 0.27, center=(0.5 + 1e-3, 0.5 + 2e-3)) -> dict:
    """An elastic ring thinner than a quarter cell inside the unit box: fluid inside and
    outside it, two pieces whose nodes near the ring carry two sets."""
    def circle(r: float, name: str) -> list[dict]:
        pts = [[center[0] + r * math.cos(a), center[1] + r * math.sin(a)] for a in (0, math.pi / 2, math.pi, 1.5 * math.pi)]
        return [{"arc": {"start": pts[k], "center": list(center), "end": pts[(k + 1) % 4]}, "name": name}
                for k in range(4)]
    return {"name": "ring", "interface": ["outer", "inner"],
            "material": {"law": "neo_hooke", "E": 10.0, "nu": 0.3, "rho": 1.0},
            "mesh": {"type": "outline", "loops": [circle(r_out, "outer"), circle(r_in, "inner")], "h": 0.04}}


def _ring_case(recut: bool) -> dict:
    """The ring in a closed unit box (8 × 8 cells), transient, separate unknowns per part."""
    fluid = {"rho": 1.0, "mu": 0.3, "grid": {"x": {"start": 0.0, "end": 1.0, "cells": 8},
                                             "y": {"start": 0.0, "end": 1.0, "cells": 8}},
             "interface": {"shape_derivative": recut, "unknowns": "per_fluid_part"}, "body_force": [0.3, "-1+x"],
             "dirichlet": [{"boundary": s, "value": [0.0, 0.0]} for s in ("left", "right", "bottom", "top")]}
    case = static_case([_ring()], fluid)
    case["time"] = {"type": "transient", "theta": 1.0, "t_end": 0.1, "dt": 0.1}
    return case


@pytest.mark.parametrize("recut", [False, True])
def test_jacobian_with_two_sets_per_node_matches_finite_differences(recut):
    """An elastic ring between an inner and an outer piece: fluid cells, faces, coupling pieces
    and the pressure pin of each piece (closed box) read the sets of their own piece; every
    block of the Jacobian against central differences, with the cut following the ring
    (``recut``, the shape derivative) or not."""
    system = System(problem_from_dict(_ring_case(recut)))
    ctx = StepContext(0.0, 0.1, 0.1, 1.0, False)
    rng = np.random.default_rng(7)
    f = system.fluid
    system.begin_step(ctx)
    assert len(system.cut.pieces) == 2 and system.cut.n_vnodes > system.cut.grid.n_nodes
    assert len(f.pressure_pin()) == 2
    f.Vn = rng.standard_normal(f.V.shape)
    x0 = 1e-3 * rng.standard_normal(system.layout.n_dofs)
    x0[system.field_dofs["velocity"]] += rng.standard_normal(len(system.field_dofs["velocity"]))
    check_jacobian(system, ctx, x0, h=1e-7 if recut else 1e-6, recut=recut, label=f"two pieces recut={recut}")


def test_with_one_set_per_node_the_thin_wall_leaks():
    """The default (the paper's one set per node): the nodes beside the wall are shared by the
    fluid on both sides, so the pressure difference drives a flow through the wall; the tests
    above would fail. Measured: 0.14 of the flow rate of the same channel without the wall
    (Poiseuille, H³Δp/(12 μ L) = 1/24); asserted > 0.05, with a warning that says so."""
    case = _wall_case()
    case["fluid"].pop("interface")
    with pytest.warns(FsciWarning, match="per_fluid_part"):
        sim = Simulation(problem_from_dict(case))
    sim.run()
    q = flow_rate(sim.system.fluid, "left")
    print(q * 24.0)
    assert -q > 0.05 / 24.0


def test_a_gap_that_closes_and_opens_in_turn_stops_the_step(monkeypatch):
    """Where a gap closes in one Newton iterate and opens again in the next, the sets of
    unknowns split and merge in turn and Newton cycles (seen on the pump's closing valve): after
    ``max_layout_changes`` such alternations the step stops with a SolverError (the time loop
    then retries with a smaller step); with one set per node it goes on."""
    case = _ring_case(recut=False)
    case["fluid"]["interface"]["freeze_cut_after"] = 20
    system = System(problem_from_dict(case))
    ctx = StepContext(0.0, 0.1, 0.1, 1.0, False)
    system.begin_step(ctx)
    split = system.cut
    merged = CutState(split.grid, split.outlines[:0], separate_parts=True)  # no body: one piece
    assert len(split.pieces) == 2 and len(merged.pieces) == 1
    turn = iter([merged, split] * 10)

    def alternate(keep_nodes=None, initial=False):
        system.cut = next(turn)
        return False

    monkeypatch.setattr(system, "update_cut", alternate)
    monkeypatch.setattr(system, "_motion_since_cut", lambda: 1.0)
    limit = system.fluid.spec.interface.max_layout_changes
    for it in range(2, 2 + limit):
        system.before_iteration(it)
    with pytest.raises(SolverError, match="split and merged again"):
        system.before_iteration(2 + limit)
    split.separate_parts = merged.separate_parts = False  # one set per node: no unknowns change
    system.piece_changes = 0
    for it in range(2, 4 + limit):
        system.before_iteration(it)


def _slot_case() -> dict:
    """Four elastic blocks touching each other in the unit box (10 × 10 cells), enclosing a
    slot x ∈ (0.5, 0.6), y ∈ (0.495, 0.505) smaller than the island threshold; moving the left
    block 0.03 to the left opens the slot's mouth to the fluid."""
    def block(name, x0, y0, x1, y1):
        sides = {"bottom": {"line": [[x0, y0], [x1, y0]]}, "right": {"line": [[x1, y0], [x1, y1]]},
                 "top": {"line": [[x0, y1], [x1, y1]]}, "left": {"line": [[x0, y0], [x0, y1]]}}
        return {"name": name, "interface": ["bottom", "right", "top", "left"],
                "material": {"law": "neo_hooke", "E": 1.0, "nu": 0.3},
                "mesh": {"type": "mapped", "nx": 2, "ny": 2, "sides": sides},
                "dirichlet": [{"boundary": "left", "value": [0.0, 0.0]}]}
    bodies = [block("left", 0.2, 0.3, 0.5, 0.7), block("lower", 0.5, 0.3, 0.6, 0.495),
              block("upper", 0.5, 0.505, 0.6, 0.7), block("right", 0.6, 0.3, 0.8, 0.7)]
    f = {"rho": 1.0, "mu": 1.0, "grid": {"x": {"start": 0.0, "end": 1.0, "cells": 10},
                                         "y": {"start": 0.0, "end": 1.0, "cells": 10}},
         "dirichlet": [{"boundary": s, "value": [0.0, 0.0]} for s in ("bottom", "top", "left", "right")]}
    return static_case(bodies, f)


def test_a_pocket_that_opens_and_shuts_in_turn_is_held_dry():
    """Where a pocket's mouth opens in one Newton iterate and shuts in the next (seen on the
    pump's closing valve: a pocket between the flaps dropped as an island, then wetted, in
    turn), the residual jumps each time and Newton cycles. After two such changes of the
    fluid's topology within a step, what was dry in any cut of the step stays dry (grown by
    ``HOLD_MARGIN`` cells) until the step ends; the next step cuts afresh."""
    import shapely

    from fsci.system import HOLD_MARGIN

    system = System(problem_from_dict(_slot_case()))
    ctx = StepContext(0.0, 1.0, 1.0, 1.0, True)
    left = system.solids[0]

    def cut_with_mouth(is_open: bool) -> CutState:
        left.U[:, 0] = -0.03 if is_open else 0.0
        system.update_cut()
        return system.cut

    system.begin_step(ctx)
    shut = system.cut
    assert len(shut.islands) == 1
    first_open = cut_with_mouth(True)  # flip 1: the pocket is fluid
    assert not first_open.islands
    assert len(cut_with_mouth(False).islands) == 1  # flip 2
    held = cut_with_mouth(True)  # open again, but held dry
    lost = shapely.intersection(first_open.fluid, shapely.buffer(shut.islands[0], HOLD_MARGIN * 0.1)).area  # cells 0.1
    assert lost > 0.9 * shut.islands[0].area and not held.islands
    assert abs(first_open.qw.sum() - held.qw.sum() - lost) < 1e-12
    system.begin_step(ctx)  # a new step: no hold
    assert abs(system.cut.qw.sum() - first_open.qw.sum()) < 1e-12


@pytest.mark.parametrize("leak, attempts", [(1e-3, [True, False]), (1e-6, [True])])
def test_a_held_state_that_loses_mass_is_solved_again_without_the_hold(monkeypatch, leak, attempts):
    """A held region's edge against open fluid carries no condition, so fluid can leave through
    it (seen on the squeezed body: Φ¹_err 1.3e-3 of the inflow). A step that converged with a
    region held dry is accepted only if its mass-balance error is at most ``HOLD_LEAK`` of the
    step's largest flux; otherwise the same step (same Δt) is solved again from its start
    without the hold, and that state is accepted as it is. The cut's hold is stood in for here:
    the converged state holds a region whenever the attempt allowed it, and loses ``leak``."""
    import fsci.simulation as simulation
    from fsci.system import HOLD_LEAK

    assert 1e-6 < HOLD_LEAK < 1e-3
    sim = Simulation(problem_from_dict(_wall_case()))
    allowed: list[bool] = []
    begin = System.begin_step

    def begin_step(self, ctx, hold_swings=False, hold_pockets=True):
        allowed.append(hold_pockets)
        begin(self, ctx, hold_swings=hold_swings, hold_pockets=hold_pockets)

    monkeypatch.setattr(System, "begin_step", begin_step)
    monkeypatch.setattr(System, "holds_pocket", lambda self: self.hold_pockets)
    monkeypatch.setattr(simulation, "relative_mass_error", lambda system: leak)
    ctx = sim.advance()
    assert allowed == attempts
    assert ctx.dt == 1.0 and sim.step == 1 and sim.t == 1.0
    assert sim.newton_total == len(attempts) * sim.history[-1]["newton_iterations"]


@pytest.mark.parametrize("leak, attempts, dt", [(5e-6, [True, False, True], 1.0),
                                                (1e-3, [True, False, True], 0.5)])
def test_a_refused_held_state_is_kept_where_the_step_fails_without_the_hold(monkeypatch, leak, attempts, dt):
    """Where the repeat without the hold fails (seen on the pump's shutting outflow valve: held
    states losing 3e-6 … 6.7e-6 of the flux refused, the repeats failing in 25 iterations, the
    step halved four times), the held state is solved again and kept if it loses at most
    ``HOLD_LEAK_FALLBACK`` (decision 51); a state that loses more is not, and the step is cut
    (its first attempt holds again). The hold, the loss and the failure without the hold are
    stood in for."""
    import fsci.simulation as simulation
    from fsci.solver.newton import NewtonReport
    from fsci.system import HOLD_LEAK, HOLD_LEAK_FALLBACK

    assert HOLD_LEAK < 5e-6 < HOLD_LEAK_FALLBACK < 1e-3
    sim = Simulation(problem_from_dict(_wall_case()))
    allowed: list[bool] = []
    begin = System.begin_step
    solve = Simulation.solve_step

    def begin_step(self, ctx, hold_swings=False, hold_pockets=True):
        allowed.append(hold_pockets)
        begin(self, ctx, hold_swings=hold_swings, hold_pockets=hold_pockets)

    def solve_step(self, ctx):
        if not self.system.hold_pockets:
            return NewtonReport(False, 25, reason="no convergence in 25 iterations")
        return solve(self, ctx)

    monkeypatch.setattr(System, "begin_step", begin_step)
    monkeypatch.setattr(System, "holds_pocket", lambda self: self.hold_pockets)
    monkeypatch.setattr(Simulation, "solve_step", solve_step)
    monkeypatch.setattr(simulation, "relative_mass_error", lambda system: leak if system.hold_pockets and
                        system.ctx.dt == 1.0 else 0.0)
    ctx = sim.advance()
    assert allowed == attempts
    assert ctx.dt == dt and sim.step == 1
