"""Fluid-structure-contact interaction: the one interface traction (27) through the FSI ->
contact transition and back. Jacobian in every case I-IV (both variants of III, extension,
slip-length law (40)), continuity of force and residual in a quasi-static sweep, lift-off at
the predicted load, contact through a closing film with mass balance, bad input."""

from __future__ import annotations

import inspect
import json
from pathlib import Path

import numpy as np
import pytest

from cutcases import fluid_box, static_case
from fsci.cases import get_case
from fsci.cli import main
from fsci.config import problem_from_dict
from fsci.coupling import traction as tk
from fsci.cut.state import END_NODE0, END_NODE1
from fsci.errors import InputError
from fsci.fields import StepContext
from fsci.simulation import Simulation
from fsci.system import System
from helpers import check_jacobian, jacobian_blocks


def two_bodies_in_fluid(variant: str, shape_derivative: bool = False, scheme: str = "cip",
                        film_closure: float = 0.0) -> tuple[System, StepContext, np.ndarray]:
    """Two elastic blocks in a fluid box: the upper one, tilted, overlaps the lower one on its
    left and opens a gap below the slip-law distance h on its right. A random state (θ = 0.6
    step, random old level) puts interface points in every case I-IV. ``shape_derivative``:
    the Jacobian includes the motion of the cut (to be checked with the cut following);
    ``scheme``: the fluid's bulk stabilisation; ``film_closure``: films thinner than this are dry."""
    lower = {"name": "lower", "material": {"law": "neo_hooke", "E": 10.0, "nu": 0.3, "rho": 1.0},
             "mesh": {"type": "rectangle", "x0": 0.1, "x1": 0.9, "y0": 0.13, "y1": 0.45, "nx": 4, "ny": 2},
             "dirichlet": [{"boundary": "bottom", "value": [0.0, 0.0]}],
             "contact": ["top"], "slip_length": "gap_law"}
    upper = {"name": "upper", "material": {"law": "neo_hooke", "E": 10.0, "nu": 0.3, "rho": 1.0},
             "mesh": {"type": "mapped", "nx": 4, "ny": 2, "sides": {
                 "bottom": {"line": [[0.23, 0.43], [0.77, 0.5]]},
                 "right": {"line": [[0.77, 0.5], [0.77, 0.81]]},
                 "top": {"line": [[0.23, 0.81], [0.77, 0.81]]},
                 "left": {"line": [[0.23, 0.43], [0.23, 0.81]]}}},
             "contact": ["bottom"], "slip_length": "gap_law"}
    # by default the cut stays frozen in the check: the Jacobian without the cut's motion (see
    # test_cutfem for the shape derivative, checked with the cut following the differences)
    fluid = fluid_box(8, mu=0.3, interface={"case_iii": variant, "film_closure": film_closure,
                                            "shape_derivative": shape_derivative},
                      stabilization={"scheme": scheme}, dirichlet=[{"boundary": "left", "value": [1.0, 0.0]}])
    case = static_case([lower, upper], fluid)
    case["time"] = {"type": "transient", "theta": 1.0, "t_end": 0.1, "dt": 0.1}
    case["contact"] = {**case.get("contact", {}), "allow_overlap": True}  # the overlap is the point of the state
    system = System(problem_from_dict(case))
    ctx, x0 = random_step_start(system, 0)
    return system, ctx, x0


def random_step_start(system: System, seed: int) -> tuple[StepContext, np.ndarray]:
    """Begin a θ = 0.6 step of ``system`` from a random old level (displacements, velocities,
    fluid velocity and pressure) and return it with a random state near it (displacements
    moved by 0.002)."""
    ctx = StepContext(0.0, 0.1, 0.1, 0.6, False)
    rng = np.random.default_rng(seed)
    for s in system.solids:
        s.Un = 0.002 * rng.standard_normal(s.U.shape)
        s.Vn = 0.1 * rng.standard_normal(s.U.shape)
        s.U = s.Un.copy()
    f = system.fluid
    f.Vn = rng.standard_normal(f.V.shape)
    f.V = f.Vn.copy()
    f.P = rng.standard_normal(f.P.shape)
    system.begin_step(ctx)
    x0 = system.gather()
    disp = system.field_dofs["displacement"]
    x0[disp] += 0.002 * rng.standard_normal(len(disp))
    return ctx, x0


@pytest.mark.parametrize("variant, scheme", [("remark6", "cip"), ("original", "cip"), ("remark6", "residual")])
def test_coupling_jacobian_in_every_case(variant, scheme):
    """Every block of the coupling term against central differences (< 1e-6 of the block's own
    size, cut frozen) in a state with points in each case I-IV, the extension active in case
    IV and the slip law (40) at 0 < g_n < h; case III as Remark 6 (35) and as (33); with the
    paper's CIP and with the residual-based bulk stabilisation."""
    system, ctx, x0 = two_bodies_in_fluid(variant, scheme=scheme)
    system.scatter(x0)
    system.assemble(ctx, want_matrix=False)
    term = system.extra_terms[0]
    out, _ = term.samples()
    case = out[..., tk.O_CASE]
    gap = out[..., tk.O_GAP]
    counts = [int(np.sum(case == c)) for c in (tk.CASE_I, tk.CASE_II, tk.CASE_III, tk.CASE_IV)]
    assert min(counts) > 0, counts
    assert np.any((case == tk.CASE_I) & (gap > 0) & (gap < term.slip_h))  # law (40) between 0 and h
    assert np.any(term.pieces(system).ext_edge >= 0)
    check_jacobian(system, ctx, x0, h=1e-7, label=f"FSCI {variant} {scheme}")


def test_gathered_piece_data_are_those_of_their_elements_and_cells():
    """The per-piece arrays of the coupling kernel, gathered by compiled loops, in the θ = 0.6
    state with points in every case I-IV: each piece's own element (reference coordinates, its
    displacements among the local unknowns, the global nodes of its coupling edge, or of the
    whole element where the piece has an opposite segment), the solid velocity terms
    ``W = U_n / (θ Δt) + (1 − θ)/θ V_n`` at the edge's nodes, the extension edge likewise, and
    the wetted piece's fluid cell: corner, sides, nodes, unknowns and γ^F of its formula
    ``γ0 (μ C_T / h_K + ρ |v|_∞ / 6 + ρ h_K / (12 θ Δt))``, with |v|_∞ the largest component of
    the stabilisation velocity at the cell's nodes and of V_n at the edge's nodes (raised here
    so that either can be the larger)."""
    system, ctx, x0 = two_bodies_in_fluid("remark6")
    system.scatter(x0)
    for s in system.solids:
        s.Vn = 30.0 * s.Vn
    term = system.extra_terms[0]
    d = term.gather(system, ctx)
    pc = term.pieces(system)
    f, g, st = system.fluid, system.fluid.grid, term.iset
    assert pc.fs.any() and (pc.opp_body >= 0).any() and (pc.ext_edge >= 0).any()
    fluid_z = np.column_stack([f.V, f.P])
    c_new, c_old = 1.0 / (ctx.theta * ctx.dt), (1.0 - ctx.theta) / ctx.theta
    solid_larger = 0
    for k in range(len(pc.body)):
        s = system.solids[pc.body[k]]
        cell = term._cell[pc.body[k]][pc.edge[k]]
        nodes, eo = s.mesh.cells[cell], term._local[pc.body[k]][pc.edge[k]]
        edge = term._edges[pc.body[k]][pc.edge[k]]
        on_edge = np.isin(np.arange(4), [eo, (eo + 1) % 4])
        assert set(edge) == set(nodes[on_edge])
        assert np.array_equal(d["Xo"][k], s.X[nodes])
        assert np.array_equal(d["z"][k, :8], s.U[nodes].ravel())
        whole = pc.opp_body[k] >= 0
        assert np.array_equal(d["conn"][k, :4], np.where(on_edge | whole, s.gnode[nodes], -1))
        np.testing.assert_allclose(d["W"][k], c_new * s.Un[edge] + c_old * s.Vn[edge], rtol=1e-14, atol=0.0)
        if pc.ext_edge[k] >= 0:
            ee = term._edges[pc.body[k]][pc.ext_edge[k]]
            assert np.array_equal(d["Xe"][k, :2], s.X[ee])
            assert np.array_equal(d["z"][k, tk.OFF_EDGE:tk.OFF_EDGE + 4], s.U[ee].ravel())
            assert np.array_equal(d["conn"][k, 16:18], s.gnode[ee])
            np.testing.assert_allclose(d["We"][k], c_new * s.Un[ee] + c_old * s.Vn[ee], rtol=1e-14, atol=0.0)
        if not pc.fs[k]:
            continue
        fn = system.cut.part_conn(pc.cell[k:k + 1])[0]
        c = pc.cell[k] % g.n_cells
        assert np.array_equal(d["conn"][k, 8:12], f.gnode[fn])
        assert np.array_equal(d["z"][k, tk.OFF_CELL:tk.OFF_CELL + 12], fluid_z[fn].ravel())
        hx, hy = g.cell_size[c]
        fp = d["fp"][k]
        assert (fp[tk.F_X0C], fp[tk.F_Y0C], fp[tk.F_HX], fp[tk.F_HY]) == (g.xs[g.cell_ij[c, 0]], g.ys[g.cell_ij[c, 1]], hx, hy)
        hk = hx * hy / max(hx, hy)
        vmax = max(np.abs(f.Vbar[fn]).max(), np.abs(s.Vn[edge]).max())
        solid_larger += np.abs(s.Vn[edge]).max() > np.abs(f.Vbar[fn]).max()
        gam = st.gamma_n * (f.mu * st.trace_constant / hk + f.rho * vmax / 6.0 + f.rho * hk / (12.0 * ctx.theta * ctx.dt))
        assert fp[tk.F_GAM] == pytest.approx(gam, rel=1e-14)
    assert 0 < solid_larger < pc.fs.sum()


def test_fluid_columns_by_differences_equal_the_complex_step(monkeypatch):
    """The coupling kernel takes the Jacobian columns of the fluid unknowns as real differences
    of step ``AFFINE_STEP`` with the case of every point fixed (the residual is affine in them),
    the others by complex step. In the state with points in every case I-IV, the extension and
    the slip law, every such column must equal the complex step's to 1e-13 of its largest
    entry (measured 2e-15; a unit step gives 1.6e-11 here, a term nonlinear in a fluid value far
    more)."""
    system, ctx, x0 = two_bodies_in_fluid("remark6")
    system.scatter(x0)
    captured = {}
    real_assemble = tk.assemble_pieces

    def capture(*args):
        captured["args"] = args
        return real_assemble(*args)

    monkeypatch.setattr(tk, "assemble_pieces", capture)
    system.assemble(ctx, want_matrix=True)
    (z_all, ip_all, fp_all, Xo_all, prmo_all, Xm_all, prmm_all, W_all, vq_all, kap_all, Xe_all, We_all, vqe_all,
     Vo_all, Vb_all, bq_all, fprm, _shape, mu, sym, sadj, variant33, w_p, w_t, w_c, gp, gw, conn, *_rest,
     out_all) = captured["args"]
    n = len(ip_all)
    R_all, used = np.zeros((n, tk.N_LOCAL)), np.zeros(n, dtype=np.bool_)
    m_all = tk._live_counts(conn)
    k_off = np.concatenate([[0], np.cumsum(m_all ** 2)])
    K_live = np.empty(k_off[-1])
    tk._piece_locals(z_all, ip_all, fp_all, Xo_all, prmo_all, Xm_all, prmm_all, W_all, vq_all, kap_all, Xe_all,
                     We_all, vqe_all, Vo_all, Vb_all, bq_all, fprm, False, mu, sym, sadj, variant33, w_p, w_t, w_c,
                     gp, gw, conn, True, out_all, R_all, K_live, k_off, used)
    worst, columns = 0.0, 0
    rc, dummy = np.empty(tk.N_LOCAL, dtype=complex), np.empty((len(gp), tk.N_OUT))
    idx = np.empty(tk.N_LOCAL, dtype=np.int64)
    for k in np.nonzero(used)[0]:
        m = tk._live_columns(conn[k], idx)
        K = K_live[k_off[k]:k_off[k + 1]].reshape(m, m)
        for jj, j in enumerate(idx[:m]):
            if not tk.OFF_CELL <= j < tk.OFF_EDGE:
                continue
            zc = z_all[k].astype(complex)
            zc[j] += 1j * tk.CS_STEP
            tk.piece_residual(zc, rc, dummy, ip_all[k], fp_all[k], Xo_all[k], prmo_all[k], Xm_all[k], prmm_all[k],
                              W_all[k], vq_all[k], kap_all[k], Xe_all[k], We_all[k], vqe_all[k], mu, sym, sadj,
                              variant33, w_p, w_t, w_c, gp, gw, np.empty(0, dtype=np.int64))
            exact = rc.imag / tk.CS_STEP
            assert not np.any(np.delete(exact, idx[:m]))  # no residual in the rows of absent slots
            exact = exact[idx[:m]]
            if np.any(exact != 0.0):
                worst = max(worst, float(np.max(np.abs(K[:, jj] - exact)) / np.max(np.abs(exact))))
                columns += 1
    assert columns > 100, columns
    assert worst < 1e-13, worst


def test_coupling_jacobian_with_the_cut_following_in_contact():
    """The state of :func:`test_coupling_jacobian_in_every_case` with the cut rebuilt for every
    difference and the shape derivative in the Jacobian, as Newton sees it while the cut
    follows the iterates: every block within 1e-6 of central differences. Before decision 39
    the errors were 0.08-0.99 in every block with a displacement column: the end of an edge's
    wetted part where it crosses the other body, the extension point there and the splits of
    wetted pieces at opposite-node projections were fixed with the cut, and so missing from
    the Jacobian (docs/architecture.md, decisions 21 and 39)."""
    system, ctx, x0 = two_bodies_in_fluid("remark6", shape_derivative=True)
    check_jacobian(system, ctx, x0, h=1e-7, recut=True, label="FSCI, cut following")


def test_coupling_jacobian_with_the_cut_following_where_a_film_closes():
    """As above with the films closed (``film_closure``; one where the upper block's bottom
    leaves the lower's top, one at its left side): the wetted part of an edge ends where the
    closed film does, on the line at the film's half-thickness from the other body's edge, and
    moves with both edges (with those ends fixed 0.99 in u:lower-u:upper, as before decision
    39); the film's mouth, the fluid boundary between those ends on the two lines, moves with
    the edges it is parallel to, and the bulk shape derivative has it (decision 43; without it
    1.1e-2 in p-u and 1e-3 in v-u). Every block < 1e-6."""
    system, ctx, x0 = two_bodies_in_fluid("remark6", shape_derivative=True, film_closure=0.02)
    system.scatter(x0)
    system.update_cut()
    m = system.cut.mouths
    assert sorted(m.body.tolist()) == [0, 0, 1, 1]  # two mouths, each on one line of either body
    check_jacobian(system, ctx, x0, h=1e-7, recut=True, label="FSCI, cut following, closed film")


def test_coupling_jacobian_where_the_opposite_surface_ends():
    """A block hovers over another with a step in its bottom: a near face over the left part,
    a far one behind an undercut over the right. The lower block's top sees the near face up
    to where the near face's last node projects, the far one beyond it, each within the slip
    law's gap h (40), so the tangential traction jumps there. The split moves with that node on
    both sides: on the far side as the projection of a node of a segment that is not the
    piece's opposite (``END_NODE0/1``). It was fixed on that side: p-u, v-u were 0.18-0.31 and
    0.05-0.24 off (on the pump, where a valve's tip hides the far flap, 0.5-13 % at the nodes of
    the edge). The end of a farther segment that projects inside a piece no longer splits it:
    that fixed split moved the Gauss rule's error on the slip law outside the Jacobian (u-u
    5e-4). Every block now within 1e-6 of central differences."""
    lower = {"name": "lower", "material": {"law": "neo_hooke", "E": 10.0, "nu": 0.3, "rho": 1.0},
             "mesh": {"type": "rectangle", "x0": 0.1, "x1": 0.9, "y0": 0.13, "y1": 0.45, "nx": 4, "ny": 2},
             "dirichlet": [{"boundary": "bottom", "value": [0.0, 0.0]}],
             "contact": ["top"], "slip_length": "gap_law"}
    corners = [[0.3, 0.49], [0.52, 0.49], [0.47, 0.56], [0.8, 0.56], [0.8, 0.8], [0.3, 0.8]]
    upper = {"name": "upper", "material": {"law": "neo_hooke", "E": 10.0, "nu": 0.3, "rho": 1.0},
             "mesh": {"type": "outline", "h": 0.06,
                      "loops": [[{"line": [a, b], "name": "wet"} for a, b in zip(corners, corners[1:] + corners[:1])]]},
             "contact": ["wet"], "slip_length": "gap_law"}
    fluid = fluid_box(8, mu=0.3, interface={"shape_derivative": True},
                      dirichlet=[{"boundary": "left", "value": [1.0, 0.0]}])
    case = static_case([lower, upper], fluid)
    case["time"] = {"type": "transient", "theta": 1.0, "t_end": 0.1, "dt": 0.1}
    system = System(problem_from_dict(case))
    ctx, x0 = random_step_start(system, 3)
    system.scatter(x0)
    system.update_cut()
    term = system.extra_terms[0]
    pc = term.pieces(system)
    node_ends = np.isin(pc.d0, [END_NODE0, END_NODE1]) | np.isin(pc.d1, [END_NODE0, END_NODE1])
    assert np.any(node_ends & (pc.opp_body >= 0))  # a far-side piece with its own opposite segment
    system.assemble(ctx, want_matrix=False)
    out, _ = term.samples()
    gap = out[..., tk.O_GAP]
    assert np.sum((gap > 0) & (gap < term.slip_h)) > 0  # the slip law acts
    # (pressure and velocity columns by larger steps: the residual is affine in p and quadratic
    # in v, and the stiff rows of the upper block, 1e8, put round-off of 1e-4 and 1e-6 into its
    # small u-p and u-v blocks at 1e-7)
    check_jacobian(system, ctx, x0, h=1e-7, h_field={"p": 1e-3, "v": 1e-5}, recut=True,
                   label="FSCI, the opposite surface ends")


def test_case_iii_variants_differ_only_in_case_iii():
    """(33) and (35) coincide except at case-III points: the residuals differ only in the fluid
    rows of cells that hold case-III points."""
    a, ctx, x0 = two_bodies_in_fluid("remark6")
    b, _, _ = two_bodies_in_fluid("original")
    a.scatter(x0)
    b.scatter(x0)
    ra = a.assemble(ctx, want_matrix=False).rhs
    rb = b.assemble(ctx, want_matrix=False).rhs
    np.testing.assert_allclose(ra[a.field_dofs["displacement"]], rb[b.field_dofs["displacement"]], rtol=0, atol=1e-12)
    assert np.abs(ra - rb).max() > 1e-6


def test_a_contact_that_swings_is_held_for_the_rest_of_the_step():
    """Dry points (Γ^SC) of an edge whose number of contact points reverses twice within a step
    repeated with ``hold_swings`` (here forced: case IV, II, IV, II in four iterates) are held in
    contact for the rest of the step (decision 38); without it the swing is only reported.
    After the fourth iterate, not before, the edge's points with g_n <= 0 are case II
    although C > 0 there, its point with g_n > 0 stays case IV, no other point
    changes, the fluid rows are unchanged (dry points load only the solid), the Jacobian of the
    held state is exact, and the next step decides afresh."""
    system, ctx, x0 = two_bodies_in_fluid("remark6", film_closure=0.02)  # a closed film: dry with g_n > 0
    system.scatter(x0)
    term = system.extra_terms[0]
    r_free = system.assemble(ctx, want_matrix=False).rhs.copy()
    free = term.out.copy()
    swing = term._out_dry & (free[:, 0, tk.O_CASE] == tk.CASE_IV)
    gap = free[..., tk.O_GAP]
    assert swing.any() and np.any(gap[swing] > 0) and np.any(gap[swing] <= 0)
    for hold in (False, True):  # counted in every attempt, held in a repeated one
        term._reset_swings()  # as at the start of an attempt
        for k, case in enumerate([tk.CASE_IV, tk.CASE_II, tk.CASE_IV, tk.CASE_II]):
            assert not term._held.any() and not system.contact_swung()
            term.out = free.copy()
            term.out[swing, :, tk.O_CASE] = case
            term._out_dry = swing | term._out_dry
            term.track_case_swings(hold)
        pc = term.pieces(system)
        edges = len(set(pc.edge[~pc.mouth][swing]))  # (the rows of term.out: the pieces that are not a film's mouth)
        assert system.contact_swung() and term._held.sum() == (edges if hold else 0)
    r_held = system.assemble(ctx, want_matrix=False).rhs
    case = term.out[..., tk.O_CASE]
    flipped = swing[:, None] & (gap <= 0)
    assert np.all(case[flipped] == tk.CASE_II) and np.all(case[~flipped] == free[..., tk.O_CASE][~flipped])
    assert np.all(term.out[..., tk.O_CC][flipped] - term.out[..., tk.O_F][flipped] > 0)  # C > 0: held, not decided
    fluid = np.concatenate([system.field_dofs["velocity"], system.field_dofs["pressure"]])
    disp = system.field_dofs["displacement"]
    np.testing.assert_array_equal(r_held[fluid], r_free[fluid])
    assert np.abs(r_held[disp] - r_free[disp]).max() > 1e-3
    check_jacobian(system, ctx, x0, h=1e-7, label="held contact")
    system.begin_step(ctx)
    assert not term._held.any() and not system.contact_swung() and not system.hold_swings


def sweep(n_steps: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The built-in ``contact-sweep`` with steps of ``1/n_steps`` of the push. Returns the load
    level, the total vertical interface force on the block and the first Newton residual of
    every step; asserts on the way that the summaries of the block's two halves (``x_range``)
    add up to the whole in every step and that both halves are in contact at some step."""
    case = get_case("contact-sweep")
    case["parameters"]["n"] = n_steps
    case["output"] = {"every": 0, "figures": False, "fields": False}
    # the block's interface summary split at its axis x = 0.5 (x_range)
    case["quantities"] += [{"name": side, "type": "interface_summary", "body": "block", "x_range": xr}
                           for side, xr in (("west", [0.0, 0.5]), ("east", [0.5, 1.0]))]
    sim = Simulation(problem_from_dict(case))
    first = []
    sim.step_hooks.append(lambda s, ctx, rep: first.append(rep.residuals[0]))
    sim.run()
    h = {k: np.array([row[k] for row in sim.history]) for k in sim.history[0]}
    for col in ("force_fsi_y", "force_contact_y", "length_contact", "length_sc"):  # the halves make the whole
        np.testing.assert_allclose(h["west_" + col] + h["east_" + col], h["block_" + col], rtol=1e-12, atol=1e-14)
    assert (h["west_length_contact"] > 0).any() and (h["east_length_contact"] > 0).any()
    return h["time"], h["block_force_fsi_y"] + h["block_force_contact_y"], np.array(first)


def test_fsi_to_contact_sweep_is_continuous():
    """Quasi-static sweep through the FSI -> contact transition and back (lift-off), steps of
    1/40 and 1/80 of the push (33 and 65 steps): the total interface force and the first Newton residual of each step
    change by amounts that shrink with the step (halving the step halves the largest jump:
    ratios ≥ 1.8, measured 1.97 and 2.00); a jump at the switch of (27) would not shrink. The
    block starts at ambient pressure (force = p × width) and contact does form."""
    res = {n: sweep(n) for n in (40, 80)}
    (t1, f1, r1), (t2, f2, r2) = res[40], res[80]
    for t, n in ((t1, 40), (t2, 80)):  # no step of the sweep itself had to be cut
        assert np.allclose(np.diff(t[t >= 0.6 - 1e-12]), 1.0 / n)
    f1, f2 = f1[t1 >= 0.6 - 1e-12], f2[t2 >= 0.6 - 1e-12]
    r1, r2 = r1[t1 >= 0.6 - 1e-12], r2[t2 >= 0.6 - 1e-12]
    j1, j2 = np.abs(np.diff(f1)).max(), np.abs(np.diff(f2)).max()
    q1, q2 = r1[1:].max(), r2[1:].max()  # the first step also brings the fluid to ambient pressure
    print(f"largest force jump {j1:.4g} / {j2:.4g}, largest first residual {q1:.4g} / {q2:.4g}")
    assert j1 / j2 >= 1.8 and q1 / q2 >= 1.8
    assert f1[0] == pytest.approx(0.4, rel=0.01) and f1.max() > 0.8
    i = np.arange(16)
    np.testing.assert_allclose(f1[i], f1[32 - i], rtol=1e-3)  # pressing and lifting pass the same states


def test_lift_off_at_the_predicted_pressure(tmp_path):
    """The block lifts off when the ambient pressure reaches the load on its dry top (the
    contact traction falls to the extended fluid traction, not to zero): within 2 % (measured
    0.6 %); Newton converges in every step; Φ¹ at solver tolerance (measured ≤ 8e-9)."""
    out = tmp_path / "lift"
    assert main(["run", "lift-off", "--out", str(out)]) == 0
    res = json.loads((out / "results.json").read_text())
    assert res["liftoff_pressure"] == pytest.approx(res["liftoff_pressure_predicted"], rel=0.02)
    assert res["mass_err1_max"] < 3e-8


def test_without_extension_the_block_does_not_lift_off(tmp_path):
    """With the fluid traction not extended into the contact zone the block's bottom sees no
    fluid, so it stays in contact however high the ambient pressure rises."""
    out = tmp_path / "noext"
    assert main(["run", "lift-off", "--set", "fluid.interface.extension=false",
                 "--set", "time.segments=[{until=1.5, dt=0.05}]", "--out", str(out)]) in (0, 1)
    res = json.loads((out / "results.json").read_text())
    assert res["liftoff_pressure"] is None
    assert res["block_length_contact"] > 0.4


def test_blocks_pressed_through_a_film(tmp_path):
    """The film closes, contact forms and spreads, the fluid splits in two; every step
    converges; the case counts go from all-I to II/III in the contact zone; Φ¹ stays at solver
    tolerance in every step, also where the fluid splits (measured ≤ 2.8e-9); each of the two
    pieces on its own balances to 2.8e-4 of the largest interface flux (asserted 1e-3; the
    pump's shut valve, whose contact zone is about one cell long, 0.34)."""
    out = tmp_path / "bf"
    assert main(["run", "blocks-film", "--out", str(out)]) == 0
    res = json.loads((out / "results.json").read_text())
    rows = np.genfromtxt(out / "history.csv", delimiter=",", names=True)
    assert 0.5 < res["first_contact_time"] < 0.9
    before = rows["time"] < res["first_contact_time"] - 1e-9
    assert np.all(rows["case_II"][before] + rows["case_III"][before] + rows["case_IV"][before] == 0)
    assert np.all(rows["pieces"][before] == 1) and rows["pieces"][-1] == 2
    assert rows["case_II"][-1] > 0
    assert rows["mass_err1"].max() < 1e-8
    split = rows["pieces"] > 1
    assert np.all(rows["mass_err1_pieces"][split] < 1e-3 * np.abs(rows["mass_phi_solid"]).max())


@pytest.mark.parametrize("change, key", [
    (lambda c: [c["bodies"][0].pop(k) for k in ("contact", "slip_length")], "bodies[1].contact"),
    (lambda c: c["fluid"].setdefault("interface", {}).update(kappa0=-0.1), "fluid.interface.kappa0"),
    (lambda c: c["fluid"].setdefault("interface", {}).update(case_iii="other"), "fluid.interface.case_iii"),
    (lambda c: c["bodies"][1].update(slip_length="gap-law"), "bodies[1].slip_length"),
])
def test_bad_fsci_input_is_one_clear_error(change, key):
    case = get_case("blocks-film")
    change(case)
    with pytest.raises(InputError) as exc:
        System(problem_from_dict(case))
    assert exc.value.field.startswith(key), str(exc.value)


def test_stamp_contacts_rests_and_lifts_off_at_the_calibrated_times(tmp_path):
    """The paper's stamp (coarse, navslip) with large time steps (0.5 / 2 / 20 instead of
    0.01 / 0.2 / 2; 292 steps): first contact and release within 2 % of the coarse paper
    times 268.2 and 2166 that the loads were calibrated to with the paper's steps (measured
    272 and 2175: one step late at most); the contact zone is closed (case II) while the
    stamp rests, with the stamp on the slab (u_y(X*) ≈ -0.5, penetration < 1e-3); mass
    balance Φ¹ at solver tolerance before contact (measured 1.6e-13); in contact the cut is
    frozen after 8 Newton iterations in some steps and Φ¹ rises to 2.6e-6 of the largest
    flux with PARDISO on 2 threads, 2.5e-5 on one (the path through frozen cuts follows the
    round-off; release then at 2165 instead of 2175; architecture decision 24), asserted
    below 5e-5."""
    out = tmp_path / "stamp"
    assert main(["run", "stamp", "--set", "time.segments=[{until=20.0, dt=0.5}, {until=300.0, dt=2.0}, "
                 "{until=2500.0, dt=20.0}]", "--set", "output.every=0", "--set", "output.figures=false",
                 "--out", str(out)]) == 0
    res = json.loads((out / "results.json").read_text())
    assert res["first_contact_time"] == pytest.approx(268.2, rel=0.02)
    assert res["release_time"] == pytest.approx(2166.0, rel=0.02)
    r = np.genfromtxt(out / "history.csv", delimiter=",", names=True)
    t, phi = r["time"], np.abs(r["mass_phi_solid"]).max()
    rest = (t > 500) & (t < 1000)
    assert np.all(r["case_II"][rest] > 0) and np.all(r["stamp_length_contact"][rest] > 0)
    assert np.all(np.abs(r["uy_X"][rest] + 0.5) < 1e-3) and r["penetration"][rest].max() < 1e-3
    assert r["mass_err1"][t < 268].max() < 1e-9 * phi
    assert r["mass_err1"].max() < 5e-5 * phi
    assert r["stamp_length_contact"][-1] == 0 and r["uy_X"][-1] > r["uy_X"][rest].max()


def run_pump(out: Path, *overrides: str) -> np.ndarray:
    """History of the built-in pump run with ``overrides`` (``--set``), without field output."""
    args = [a for o in (*overrides, "output.every=0", "output.figures=false") for a in ("--set", o)]
    assert main(["run", "pump", *args, "--out", str(out)]) == 0
    return np.genfromtxt(out / "history.csv", delimiter=",", names=True)


@pytest.fixture(scope="module")
def pump_compression(tmp_path_factory):
    """The reconstructed pump (docs/cases/pump.md; the paper's grid with the valve zones 4 times
    finer) through its first compression until the inflow valve has been shut for a while
    (t ≤ 0.016, steps of 4e-4, twice the paper's)."""
    return run_pump(tmp_path_factory.mktemp("pump"), "time.segments=[{until=0.016, dt=4e-4}]")


def test_pump_compression_shuts_the_inflow_valve_by_contact(pump_compression):
    """First compression: fluid leaves through the outflow side in the design direction (−x), the
    outflow (left) valve opens (tip faces 0.006 apart at rest), the inflow (right) valve shuts by
    contact (cases II > 0 and the fluid split in two pieces from t ≈ 0.0095; all of the upper
    body's contact lies in that valve) and carries a pressure jump (asserted > 5); the chamber
    walls approach; Newton converges in every step and the mass balance Φ¹ holds at solver
    tolerance (asserted 1e-7 of the flux)."""
    r = pump_compression
    opening = {v: 0.006 + r[f"tip_{v}_upper"] - r[f"tip_{v}_lower"] for v in ("left", "right")}
    shut = r["pieces"] > 1
    phi = np.abs(r["mass_phi_solid"]).max()
    print({v: g[-1] for v, g in opening.items()}, r["time"][np.argmax(shut)],
          r["p_right_valve_chamber"][-1] - r["p_right_valve_in"][-1], (r["mass_err1"] / phi).max(),
          r["wall_upper"][-1] - r["wall_lower"][-1], np.sum(r["flow_out"] * r["dt"]))
    assert r["time"][-1] == pytest.approx(0.016)
    assert r["flow_out"][-1] > 0.0 and np.sum(r["flow_out"] * r["dt"]) > 0.0  # outward through x = 0: −x
    assert opening["left"][-1] > 0.015
    assert shut.any() and np.all(shut[np.argmax(shut):]) and np.all(r["case_II"][shut] > 0)
    # the contact is in the inflow valve only (x_range summaries of the upper body)
    assert np.all(r["valve_right_length_contact"][shut] > 0) and np.all(r["valve_left_length_contact"] == 0)
    assert np.all(r["chamber_length_contact"] == 0)
    np.testing.assert_allclose(r["valve_right_length_contact"], r["upper_length_contact"], rtol=1e-12)
    assert r["p_right_valve_chamber"][-1] > r["p_right_valve_in"][-1] + 5.0
    assert r["wall_upper"][-1] - r["wall_lower"][-1] < -0.02  # the chamber gap 0.1 closes by more than 0.02
    assert np.all(r["mass_err1"] < 1e-7 * phi)


def test_pump_shut_valve_holds_the_mass_of_each_fluid_piece(pump_compression):
    """While the inflow valve is shut, each fluid piece on its own satisfies the mass balance
    (46): the flux through Γ^in equals the motion of the walls of the inlet piece. In the first
    steps after the flaps touch their contact zone is shorter than a cell and the cells there
    hold fluid of both sides (one set of unknowns per node, docs/cases/pump.md: up to 0.5 % of
    the largest flux); from 0.002 after the closure on, the imbalance of each piece is asserted
    below 1e-6 of the largest interface flux."""
    r = pump_compression
    shut = r["pieces"] > 1
    t_shut = r["time"][np.argmax(shut)]
    phi = np.abs(r["mass_phi_solid"]).max()
    later = shut & (r["time"] >= t_shut + 0.002)
    print((r["mass_err1_pieces"][shut] / phi).round(8))
    assert later.sum() >= 5
    assert np.all(r["mass_err1_pieces"][later] < 1e-6 * phi)


@pytest.fixture(scope="module")
def pump_cycle(tmp_path_factory):
    """The pump's first load cycle (t ≤ 0.05, A = 1, steps of 4e-4) on a coarser grid: the
    valve zones twice as fine as the paper's grid instead of 4 times (``r = 2``, 33,939
    unknowns), the default own-cut tolerance (before the pocket hold of decision 36 the
    outflow valve's closure stalled there at steps near 3e-6, and this test relaxed it to
    1e-3)."""
    return run_pump(tmp_path_factory.mktemp("pump_cycle"), "r=2", "time.segments=[{until=0.05, dt=4e-4}]")


def test_pump_cycle_shuts_each_valve_in_its_half_and_pumps_in_the_design_direction(pump_cycle):
    """One whole cycle on the coarser grid: the inflow valve shuts by contact during compression
    and the outflow valve during suction (never both at once), each carrying a pressure jump
    (asserted > 5, measured 13.6 and 13.4); fluid leaves through Γ^out in compression and enters
    through Γ^in in suction: net transport in the design direction −x (measured 0.0211 out,
    0.0083 in). Every step converges or is cut and recovered (the run reaches t = 0.05); Φ¹
    stays below 1e-5 of the largest flux (measured 5.4e-6, in a step where the pocket between
    the shutting outflow flaps is held dry, decision 36: the step was solved again without the
    hold, failed, and the held state was kept, decision 51, as it loses less than 1e-5 of that
    step's largest flux)."""
    r = pump_cycle
    t, dt = r["time"], r["dt"]
    inflow_shut = r["valve_right_length_contact"] > 0
    outflow_shut = r["valve_left_length_contact"] > 0
    compression, suction = t <= 0.025, t > 0.025  # the load h = −20 (1 − cos 40πt) peaks at 0.025
    print(t[inflow_shut][[0, -1]], t[outflow_shut][[0, -1]], np.sum(r["flow_out"] * dt), np.sum(-r["flow_in"] * dt))
    assert t[-1] == pytest.approx(0.05)
    assert inflow_shut[compression & (t >= 0.012)].all() and not inflow_shut[t >= 0.045].any()
    assert outflow_shut[t >= 0.045].all() and not outflow_shut[compression].any()
    assert not (inflow_shut & outflow_shut).any()
    assert np.all(r["case_II"][inflow_shut | outflow_shut] > 0)
    assert np.all(r["chamber_length_contact"] == 0)
    jump_in = r["p_right_valve_chamber"] - r["p_right_valve_in"]
    jump_out = r["p_left_valve_out"] - r["p_left_valve_chamber"]
    assert np.nanmax(jump_in[inflow_shut]) > 5.0 and np.nanmax(jump_out[outflow_shut]) > 5.0
    out_c = np.sum((r["flow_out"] * dt)[compression])
    in_s = np.sum((-r["flow_in"] * dt)[suction])
    assert out_c > 0.01 and in_s > 0.005
    assert np.sum(r["flow_out"] * dt) > np.sum(-r["flow_in"] * dt) > 0.0
    phi = np.abs(r["mass_phi_solid"]).max()
    assert np.all(r["mass_err1"] < 1e-5 * phi)


def test_a_division_by_zero_in_the_parallel_coupling_kernel_is_an_arithmetic_error(monkeypatch):
    """numba hands an exception of a parallel worker on as SystemError with the original as its
    context (seen: the coarse squeezed case with thick films closed stopped with it at first
    contact); the coupling term passes the ZeroDivisionError on, which Newton treats as an
    iterate that cannot be evaluated (backtracking, then a step cut), and anything else as it is."""
    def worker_failed(*args):
        try:
            raise ZeroDivisionError("division by zero")
        except ZeroDivisionError:
            raise SystemError("CPUDispatcher(<function _piece_locals>) returned a result with an exception set")

    def worker_broken(*args):
        raise SystemError("something else")

    # the mock ignores the arguments but for the piece count and want_matrix
    args = dict.fromkeys(inspect.signature(tk.assemble_pieces).parameters)
    args.update(ip_all=np.zeros((1, tk.N_INT), dtype=np.int64), want_matrix=False)
    monkeypatch.setattr(tk, "_piece_locals", worker_failed)
    with pytest.raises(ZeroDivisionError):
        tk.assemble_pieces(**args)
    monkeypatch.setattr(tk, "_piece_locals", worker_broken)
    with pytest.raises(SystemError):
        tk.assemble_pieces(**args)
