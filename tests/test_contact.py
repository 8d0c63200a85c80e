"""Dry Nitsche contact: patch test (matching and non-matching meshes), Hertz, unbiasedness and
Newton rate on two blocks, Jacobian vs finite differences, penalty sweep."""

from __future__ import annotations

import copy

import numpy as np
import pytest

from fsci.cases import get_case
from fsci.config import apply_override, problem_from_dict
from fsci.fields import StepContext
from fsci.simulation import Simulation
from fsci.system import System

from helpers import check_jacobian

UPPER_X = {"matching": {"start": 0.0, "end": 2.0, "cells": 5},
           "non-matching": [0.0, 0.31, 0.7, 1.13, 1.52, 2.0]}  # ratio ≈ 1.3 with an offset


def patch_case(mesh="non-matching", law="neo_hooke", split=True, weighting="harmonic", E_up=1.0):
    def block(name, y0, y1, xs, ny, E, extra):
        b = {"name": name, "material": {"law": law, "E": E, "nu": 0.3},
             "mesh": {"type": "rectilinear", "x": xs, "y": {"start": y0, "end": y1, "cells": ny}}}
        b.update(extra)
        return b

    low = block("lower", 0.0, 1.0, {"start": 0.0, "end": 2.0, "cells": 5}, 3, 1.0,
                {"contact": ["top"], "dirichlet": [{"boundary": "bottom", "value": ["free", 0.0]},
                                                   {"boundary": "bottom_left", "value": [0.0, 0.0]}]})
    up = block("upper", 1.0, 2.0, UPPER_X[mesh], 3, E_up,
               {"contact": ["bottom"], "neumann": [{"boundary": "top", "type": "traction", "value": [0.0, -0.01]}],
                "dirichlet": [{"boundary": "top_left", "value": [0.0, "free"]}]})
    return {"name": "patch", "time": {"type": "static", "t_end": 1.0, "dt": 1.0}, "bodies": [low, up],
            "solver": {"tol_residual": 1e-13, "tol_increment": 1e-13},
            "contact": {"weighting": weighting, "split": split}, "output": {"every": 0, "figures": False}}


@pytest.mark.parametrize("mesh", ["matching", "non-matching"])
@pytest.mark.parametrize("law", ["neo_hooke", "svk"])
def test_contact_patch_test(mesh, law):
    """Uniform pressure transmitted exactly: on both surfaces the contact pressure equals the
    (uniform) Cauchy stress -σ_yy of the blocks (measured 7e-14, asserted 1e-11: the solver
    tolerance), the gap vanishes (measured 1e-16)."""
    sim = Simulation(problem_from_dict(patch_case(mesh, law)))
    sim.run()
    term = sim.system.extra_terms[0]
    sigma = sim.system.solids[0].cell_stress()[:, 1]
    assert np.ptp(sigma) < 1e-12
    for name in ("lower", "upper"):
        prof = term.profile(name)
        assert np.all(prof[:, 4] > 0)
        assert np.max(np.abs(prof[:, 2] + sigma.mean())) < 1e-11 * abs(sigma.mean())
        assert np.max(np.abs(prof[:, 3])) < 1e-13


def test_split_integration_balances_the_two_passes():
    """Remark 9: pieces split where the opposite element edges project integrate the jumping
    opposite stress exactly; fixed sub-intervals do not. Two blocks at maximum compression:
    the contact forces of the two passes balance to 0.5 % with splitting (measured 0.20 %),
    not without (3 sub-intervals: 5.8 %)."""
    def forces(*overrides):
        case = get_case("two-blocks")
        for o in ("time.t_end=1.0",) + overrides:
            apply_override(case, o)
        r = Simulation(problem_from_dict(case)).run()
        return abs(r["upper_contact_force_y"] + r["lower_contact_force_y"]) / r["upper_contact_force_y"]

    assert forces("contact.split=true") < 0.005
    assert forces("contact.split=false", "contact.n_fixed=3") > 0.02


@pytest.mark.parametrize("theta", [None, 0.5, 0.6])  # None: static
@pytest.mark.parametrize("weighting, law, E_up", [("harmonic", "neo_hooke", 3.0), ("half", "svk", 1.0)])
def test_contact_jacobian_matches_finite_differences(weighting, law, E_up, theta):
    """Penetrating non-matching surfaces: the projections of the opposite nodes split the
    pieces (their motion is part of the Jacobian); all 4 blocks against central differences,
    relative to their own size, for all terms and for each term (two bodies, contact) alone;
    static and θ-weighted transient steps."""
    case = patch_case("non-matching", law, True, weighting, E_up)
    for b in case["bodies"]:
        b["material"]["rho"] = 1.0  # inertia in the transient steps
    system = System(problem_from_dict(case))
    ctx = StepContext(0.0, 1.0, 1.0, 1.0, True) if theta is None else StepContext(0.0, 0.1, 0.1, theta, False)
    rng = np.random.default_rng(11)
    for s in system.solids:
        s.Un = 1e-3 * rng.standard_normal(s.U.shape)
        s.Vn = 1e-2 * rng.standard_normal(s.U.shape)
    system.begin_step(ctx)
    x0 = 2e-3 * rng.standard_normal(system.layout.n_dofs)
    up = system.solids[1]
    x0[system.layout.start[up.gnode] + 1] -= 0.01  # press the upper block 0.01 into the lower one
    x0[system.layout.start[up.gnode]] += 0.05  # and shift it sideways: projections cross element edges
    check_jacobian(system, ctx, x0, h=1e-7, label=f"{weighting} {law} θ={theta}")


def test_contact_jacobian_against_a_rigid_body():
    case = get_case("hertz")
    apply_override(case, "h=0.02")
    system = System(problem_from_dict(case))
    ctx = StepContext(0.0, 1.0, 1.0, 1.0, True)
    system.begin_step(ctx)
    rng = np.random.default_rng(2)
    x0 = 1e-4 * rng.standard_normal(system.layout.n_dofs)
    cyl = system.solids[0]
    x0[system.layout.start[cyl.gnode] + 1] -= 0.003
    dofs = system.layout.start[cyl.gnode[np.unique(cyl.mesh.edge_sets["arc"])]]
    dofs = np.concatenate([dofs, dofs + 1])[:40]
    check_jacobian(system, ctx, x0, h=1e-8, dofs=dofs, label="hertz")


def test_reaction_is_the_applied_load():
    """The ``reaction`` quantity (the body's own residual summed over its prescribed dofs, used
    as the Hertz load) on the patch test: the support under the lower block carries the
    traction 0.01 applied over the width 2 of the upper block, through the contact. (Hertz
    itself, with a/a_H, p0/p0_H and contact force = load, runs at its default in
    tests/test_cases.py.)"""
    case = patch_case()
    case["quantities"] = [{"name": "support", "type": "reaction", "body": "lower", "boundary": "bottom",
                           "component": 1},
                          {"name": "support_x", "type": "reaction", "body": "lower", "boundary": "bottom"}]
    res = Simulation(problem_from_dict(case)).run()
    assert res["support"] == pytest.approx(0.02, rel=1e-11)
    assert abs(res["support_x"]) < 1e-13


def test_penetration_falls_with_the_penalty():
    """γ0^S sweep (paper Fig. 12 trend): the penetration decreases monotonically."""
    pen = []
    for g in (0.1, 1.0, 10.0, 100.0):
        case = get_case("hertz")
        apply_override(case, f"contact.gamma0={g}")
        apply_override(case, "h=0.004")
        pen.append(Simulation(problem_from_dict(case)).run()["penetration"])
    assert all(a > 2 * b for a, b in zip(pen[:-1], pen[1:])), pen


def _two_blocks(swap: bool, monitor=None):
    case = get_case("two-blocks")
    if swap:
        case["bodies"] = case["bodies"][::-1]
    sim = Simulation(problem_from_dict(case))
    reports = []
    sim.step_hooks.append(lambda s, ctx, rep: reports.append(rep))
    return sim.run(), sim, reports


def test_two_blocks_unbiased_and_quadratic():
    """Swapping which body is listed first changes nothing (to 1e-10); Newton converges
    quadratically once the contact set is settled."""
    a, sim_a, reps = _two_blocks(False)
    b, sim_b, _ = _two_blocks(True)
    for ha, hb in zip(sim_a.history, sim_b.history):
        for k in ("uy_upper", "uy_lower", "ux_corner", "upper_contact_force_y", "lower_contact_force_y"):
            assert abs(ha[k] - hb[k]) <= 1e-12 * max(1.0, abs(ha[k])), (k, ha[k], hb[k])  # measured 3e-15
    peak = min(sim_a.history, key=lambda h: h["uy_upper"])
    assert peak["uy_upper"] < -0.15 and peak["upper_contact_force_y"] > 0.1
    # action = reaction between the two passes (measured 0.20 %)
    f_up, f_lo = peak["upper_contact_force_y"], peak["lower_contact_force_y"]
    assert abs(f_up + f_lo) < 0.006 * f_up
    # quadratic convergence at maximum compression
    r = np.array(reps[9].residuals)
    r = r[r > 1e-12]
    order = np.log(r[2:] / r[1:-1]) / np.log(r[1:-1] / r[:-2])
    assert order[-1] > 1.8, (r, order)


def _c_shape_case():
    pts = [(0, 0), (1, 0), (1, 0.4), (0.3, 0.4), (0.3, 0.6), (1, 0.6), (1, 1), (0, 1)]
    names = ["bottom", "end", "slot", "slot", "slot", "end", "top", "back"]
    loop = [{"line": [list(pts[i]), list(pts[(i + 1) % 8])], "name": names[i]} for i in range(8)]
    body = {"name": "c", "material": {"law": "neo_hooke", "E": 1.0, "nu": 0.3},
            "mesh": {"type": "outline", "loops": [loop], "h": 0.05},
            "dirichlet": [{"boundary": "bottom", "value": [0.0, 0.0]},
                          {"boundary": "top", "value": [0.0, "-0.35"], "function": {"type": "ramp", "t0": 0.0, "t1": 1.0}}],
            "contact": ["slot"]}
    return {"name": "c", "time": {"type": "static", "t_end": 1.0, "dt": 0.1}, "bodies": [body],
            "contact": {"self_contact": True}, "solver": {"tol_residual": 1e-11, "tol_increment": 1e-11},
            "quantities": [{"name": "slot", "type": "contact_profile", "body": "c", "axis": 0.3}],
            "output": {"every": 0, "figures": False}}


def test_self_contact_closes_a_slot():
    """A C-shaped body pressed from the top: the slot's faces come into contact (same body,
    two half passes on the same surface); the contact forces of the two faces balance."""
    sim = Simulation(problem_from_dict(_c_shape_case()))
    res = sim.run()
    prof = sim.system.extra_terms[0].profile("c")
    upper = prof[(prof[:, 4] > 0) & (prof[:, 7] < -0.5)]  # face of the top arm (normal pointing down)
    lower = prof[(prof[:, 4] > 0) & (prof[:, 7] > 0.5)]
    assert len(upper) and len(lower)
    f_up = -np.sum(upper[:, 2] * upper[:, 5] * upper[:, 7])
    f_lo = -np.sum(lower[:, 2] * lower[:, 5] * lower[:, 7])
    assert f_up > 0.01 and abs(f_up + f_lo) < 3.2e-4 * f_up  # measured 1.06e-4
    assert res["penetration"] < 0.05 * 0.05  # below 5 % of the element size (measured 2.0 %)


def test_self_contact_jacobian():
    """The slot of the C-shaped body closed by bending the upper arm down (the back shortens
    smoothly, no cell inverts): the slot dofs' columns against central differences."""
    case = _c_shape_case()
    system = System(problem_from_dict(case))
    ctx = StepContext(0.0, 1.0, 1.0, 1.0, True)
    system.begin_step(ctx)
    s = system.solids[0]
    x0 = np.zeros(system.layout.n_dofs)
    # u_y = -0.25 x above the slot (overlap 0.05 at the tip), ramped over the back's 0.4 < y < 0.6
    ramp = np.clip((s.X[:, 1] - 0.4) / 0.2, 0.0, 1.0)
    x0[system.layout.start[s.gnode] + 1] = -0.25 * s.X[:, 0] * ramp
    x0 += 1e-4 * np.random.default_rng(4).standard_normal(len(x0))
    slot = np.unique(s.mesh.edge_sets["slot"])
    dofs = np.concatenate([system.layout.start[s.gnode[slot]], system.layout.start[s.gnode[slot]] + 1])[::3]
    check_jacobian(system, ctx, x0, h=1e-7, dofs=dofs, label="self-contact")


def _strip_surface(body: int, y0: float, y1: float, n: int = 10):
    """Counter-clockwise outline of the strip [0, 1] × [y0, y1], edges of length 1/n along x."""
    from fsci.geometry.search import Surface

    xs = np.linspace(0.0, 1.0, n + 1)
    pts = np.array([[x, y0] for x in xs] + [[x, y1] for x in xs[::-1]])
    m = len(pts)
    edges = np.column_stack([np.arange(m), (np.arange(m) + 1) % m])
    return Surface(body, pts, edges, np.zeros(m, dtype=np.int64), np.zeros(m, dtype=np.int64))


@pytest.mark.parametrize("y_top_other", [-0.01, 0.002])
def test_search_rejects_surfaces_seen_through_a_thin_body(y_top_other):
    """A strip 0.01 thick with edges 0.1 long over a second strip, apart (top at y = -0.01) or
    penetrating it by 0.002: the second strip's far side, 0.03 behind the first strip's top face,
    is seen through the thin strip and is no contact partner; the near side is (gap +0.01, or the
    penetration -0.002). A rule on the size of g_n (e.g. half an edge) cannot tell these apart."""
    from fsci.geometry.search import find_pieces, gap_along_normal

    own = _strip_surface(0, 0.0, 0.01)
    other = _strip_surface(1, -0.02, y_top_other)
    pc = find_pieces([own, other], 0, radius=0.1)
    A, B = own.x[own.edges[pc.edge, 0]], own.x[own.edges[pc.edge, 1]]
    P, Q = other.x[other.edges[pc.opp_edge, 0]], other.x[other.edges[pc.opp_edge, 1]]
    g, _ = gap_along_normal(A, B, P, Q, 0.5 * (pc.s0 + pc.s1))
    normal_y = own.normals()[pc.edge, 1]
    assert len(pc) >= 10 and np.all(normal_y < -0.99)  # only the bottom face sees the other strip
    np.testing.assert_allclose(g, -(y_top_other - 0.0), atol=1e-12)


def test_search_rejects_a_face_seen_through_a_thin_body_that_it_slightly_penetrates():
    """A flap lying on a strip 0.01 thick with its blunt tip pressed 3e-4 into the strip's top
    face (the pump's inflow valve at t = 0.28668): the flap's short tip face lies inside the
    strip and faces the strip's bottom face, which sees it through the strip at the gap -0.0098
    with a ray that ends inside the strip; no contact partner (on the pump such a pair gave a
    contact pressure fifty times the real one). The penetration of the top face by the flap's
    lower face is (gaps -3e-4 … -1e-4)."""
    from fsci.geometry.search import Surface, find_pieces, gap_along_normal

    own = _strip_surface(0, 0.0, 0.01)
    # flap, counter-clockwise: lower face (0.45, 0.0097) -> (1, 0.0099), end, upper face to
    # (0.452, 0.00998), tip face back to (0.45, 0.0097) (outward normal about (-0.14, 0.99))
    flap = np.array([[0.45, 0.0097], [1.0, 0.0099], [1.0, 0.013], [0.452, 0.00998]])
    other = Surface(1, flap, np.array([[0, 1], [1, 2], [2, 3], [3, 0]]), np.zeros(4, dtype=np.int64),
                    np.zeros(4, dtype=np.int64))
    pc = find_pieces([own, other], 0, radius=0.1)
    A, B = own.x[own.edges[pc.edge, 0]], own.x[own.edges[pc.edge, 1]]
    P, Q = other.x[other.edges[pc.opp_edge, 0]], other.x[other.edges[pc.opp_edge, 1]]
    g, _ = gap_along_normal(A, B, P, Q, 0.5 * (pc.s0 + pc.s1))
    assert len(pc) >= 5
    assert np.all(own.normals()[pc.edge, 1] > 0.99)  # only the top face has a partner
    assert np.all(pc.opp_edge == 0) and np.all((g > -3.01e-4) & (g < -0.99e-4))


def _trace_constant_by_generalised_eigenproblem(X: np.ndarray, edge: int, E: float, nu: float,
                                                 n_volume: int = 3, n_edge: int = 5) -> float:
    """Reference for the trace constant of Remark 7, built independently of the kernel: K with
    ``n_volume``² Gauss points, the edge form with ``n_edge``, and the pencil solved by scipy on
    an explicit basis of the complement of the rigid-body modes."""
    import scipy.linalg as sla

    lam, mu = E * nu / ((1 + nu) * (1 - 2 * nu)), E / (2 * (1 + nu))
    D = np.array([[lam + 2 * mu, lam, 0.0], [lam, lam + 2 * mu, 0.0], [0.0, 0.0, mu]])
    ref = np.array([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]])

    def strain_matrix(r, s):
        dN = 0.25 * np.column_stack([ref[:, 0] * (1 + ref[:, 1] * s), ref[:, 1] * (1 + ref[:, 0] * r)])
        J = dN.T @ X
        dNx = dN @ np.linalg.inv(J).T
        B = np.zeros((3, 8))
        B[0, 0::2], B[1, 1::2], B[2, 0::2], B[2, 1::2] = dNx[:, 0], dNx[:, 1], dNx[:, 1], dNx[:, 0]
        return B, np.linalg.det(J)

    g3, w3 = np.polynomial.legendre.leggauss(n_volume)
    K = sum(wi * wj * (lambda B, d: d * B.T @ D @ B)(*strain_matrix(ri, sj))
            for ri, wi in zip(g3, w3) for sj, wj in zip(g3, w3))
    a, b = edge, (edge + 1) % 4
    t = X[b] - X[a]
    L = np.linalg.norm(t)
    n = np.array([t[1], -t[0]]) / L
    g5, w5 = np.polynomial.legendre.leggauss(n_edge)
    A = np.zeros((8, 8))
    for gi, wi in zip(g5, w5):
        s = 0.5 * (gi + 1)
        B, _ = strain_matrix(*((1 - s) * ref[a] + s * ref[b]))
        bv = np.array([n[0] ** 2, n[1] ** 2, 2 * n[0] * n[1]]) @ D @ B
        A += 0.5 * wi * L * np.outer(bv, bv)
    rigid = np.zeros((8, 3))
    rigid[0::2, 0], rigid[1::2, 1] = 1.0, 1.0
    rigid[0::2, 2], rigid[1::2, 2] = -X[:, 1], X[:, 0]
    Q = sla.null_space(rigid.T)  # (8, 5): displacements orthogonal to the rigid-body modes
    return float(sla.eigh(Q.T @ A @ Q, Q.T @ K @ Q, eigvals_only=True)[-1])


def test_trace_constants_agree_with_the_generalised_eigenproblem_and_scale_as_one_over_h():
    """The closed-form kernel of the trace inequality (Remark 7) against scipy's generalised
    eigenproblem on parallelograms (where both quadratures are exact) and distorted quads; λ
    scales as E/h and does not change under a rigid motion of the element."""
    from fsci.coupling.term import trace_constants

    rng = np.random.default_rng(7)
    square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    shapes = []
    for _ in range(6):  # parallelograms: a random affine map of the square
        shapes.append(square @ (np.eye(2) + 0.4 * rng.uniform(-1, 1, (2, 2))).T)
    for _ in range(6):  # general convex quads
        shapes.append(square + 0.15 * rng.uniform(-1, 1, (4, 2)))
    Xe = np.array(shapes)
    edge = rng.integers(0, 4, len(Xe))
    got = trace_constants(Xe, edge, 2000.0, 0.3)
    # parallelograms: the reference's higher rules are exact as the kernel's are; distorted
    # quads (rational strains): the reference with the kernel's rules, 2×2 and 3 points
    want = np.array([_trace_constant_by_generalised_eigenproblem(X, e, 2000.0, 0.3) for X, e in zip(Xe[:6], edge[:6])]
                    + [_trace_constant_by_generalised_eigenproblem(X, e, 2000.0, 0.3, 2, 3)
                       for X, e in zip(Xe[6:], edge[6:])])
    np.testing.assert_allclose(got, want, rtol=1e-10)
    # λ ∝ E / h, invariant under rotation and translation
    c, s = np.cos(0.7), np.sin(0.7)
    moved = 0.1 * Xe @ np.array([[c, -s], [s, c]]).T + np.array([3.0, -2.0])
    np.testing.assert_allclose(trace_constants(moved, edge, 500.0, 0.3), got * 10.0 / 4.0, rtol=1e-10)
    # a unit square of E = 1: φ of the order of 1/h (the 4C estimate's scale), the same for every edge
    sq = trace_constants(np.repeat(square[None], 4, axis=0), np.arange(4), 1.0, 0.3)
    np.testing.assert_allclose(sq, sq[0], rtol=1e-12)
    assert 0.5 < sq[0] < 20.0
