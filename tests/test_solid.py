"""Solid verification: patch test, material tangent, element Jacobian vs finite differences,
manufactured-solution convergence rates, quadratic Newton convergence."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from fsci.config import problem_from_dict
from fsci.fields import StepContext
from fsci.physics.materials import NEO_HOOKE, SVK, material_parameters, strain_energy, stress_tangent
from fsci.post.errors import solid_errors
from fsci.problem import SolverSettings
from fsci.simulation import Simulation
from fsci.solver.linear import make_linear_solver
from fsci.solver.newton import solve_nonlinear
from fsci.system import System

from helpers import check_jacobian
from mms import rates, solid_neo_hooke, x, y


def _body(law, nx=4, ny=4, **extra):
    b = {"name": "b", "material": {"law": law, "E": 10.0, "nu": 0.3, "rho": 1.0},
         "mesh": {"type": "rectangle", "x0": 0, "x1": 1, "y0": 0, "y1": 1, "nx": nx, "ny": ny}}
    b.update(extra)
    return b


def _distort(mesh, amount, seed=0):
    rng = np.random.default_rng(seed)
    inner = np.setdiff1d(np.arange(mesh.n_nodes), mesh.node_sets["all"])
    mesh.nodes[inner] += amount * rng.uniform(-1, 1, (len(inner), 2))


@pytest.mark.parametrize("law", ["neo_hooke", "svk"])
def test_patch_test_homogeneous_deformation_is_exact(law):
    """An affine displacement prescribed on the boundary is reproduced exactly inside."""
    ux, uy = "0.2*x + 0.1*y", "-0.05*x + 0.15*y"
    case = {"name": "patch", "time": {"type": "static", "t_end": 1.0, "dt": 1.0},
            "bodies": [_body(law, dirichlet=[{"boundary": "all", "value": [ux, uy]}])]}
    pr = problem_from_dict(case)
    _distort(pr.bodies[0].mesh, 0.08)
    sim = Simulation(pr)
    sim.run()
    s = sim.system.solids[0]
    X = s.X
    exact = np.column_stack([0.2 * X[:, 0] + 0.1 * X[:, 1], -0.05 * X[:, 0] + 0.15 * X[:, 1]])
    assert np.max(np.abs(s.U - exact)) < 1e-10


@pytest.mark.parametrize("law", [NEO_HOOKE, SVK])
@pytest.mark.parametrize("nu", [0.0, 0.3, 0.45])
def test_stress_and_tangent_match_strain_energy(law, nu):
    """S = 2 dpsi/dC and D = dS/dE by central differences (nu = 0 is the exact limit)."""
    prm = material_parameters(law, 5.0, nu)
    C = np.array([[1.3, 0.2], [0.2, 0.9]])
    S = np.zeros((2, 2))
    D = np.zeros((3, 3))
    stress_tangent(law, prm, C, S, D, True)
    h = 1e-6
    for (i, j) in ((0, 0), (1, 1), (0, 1)):
        dC = np.zeros((2, 2))
        dC[i, j] = dC[j, i] = h
        dpsi = (strain_energy(law, prm, C + dC) - strain_energy(law, prm, C - dC)) / (2 * h)
        factor = 1.0 if i == j else 2.0  # symmetric perturbation touches two entries
        assert abs(2 * dpsi / factor - S[i, j]) < 1e-7 * max(1.0, abs(S).max())
    for k, (i, j) in enumerate(((0, 0), (1, 1), (0, 1))):
        dE = np.zeros((2, 2))
        dE[i, j] = dE[j, i] = h
        Sp = np.zeros((2, 2))
        Sm = np.zeros((2, 2))
        stress_tangent(law, prm, C + 2 * dE, Sp, np.zeros((3, 3)), False)
        stress_tangent(law, prm, C - 2 * dE, Sm, np.zeros((3, 3)), False)
        dS = (Sp - Sm) / (2 * h)
        col = np.array([dS[0, 0], dS[1, 1], dS[0, 1]]) / (1.0 if i == j else 2.0)
        assert np.allclose(col, D[:, k], rtol=1e-6, atol=1e-7 * np.abs(D).max())


def test_neo_hooke_nu_zero_is_the_limit():
    """The beta = 0 law equals the limit nu -> 0 of (43)."""
    C = np.array([[1.4, -0.3], [-0.3, 0.8]])
    S0, S1 = np.zeros((2, 2)), np.zeros((2, 2))
    stress_tangent(NEO_HOOKE, material_parameters(NEO_HOOKE, 3.0, 0.0), C, S0, np.zeros((3, 3)), False)
    stress_tangent(NEO_HOOKE, material_parameters(NEO_HOOKE, 3.0, 1e-9), C, S1, np.zeros((3, 3)), False)
    assert np.allclose(S0, S1, atol=1e-8)
    psi0 = strain_energy(NEO_HOOKE, material_parameters(NEO_HOOKE, 3.0, 0.0), C)
    psi1 = strain_energy(NEO_HOOKE, material_parameters(NEO_HOOKE, 3.0, 1e-9), C)
    assert abs(psi0 - psi1) < 1e-7


@pytest.mark.parametrize("theta", [0.5, 0.6, 1.0])
@pytest.mark.parametrize("law", ["neo_hooke", "svk"])
def test_solid_jacobian_matches_finite_differences(law, theta):
    """Full residual (θ-weighted internal forces and follower pressure, inertia, dead load) vs
    central FD, per block (one body: the displacement block)."""
    case = {"name": "fd", "time": {"type": "transient", "theta": 0.6, "t_end": 0.1, "dt": 0.1},
            "bodies": [_body(law, nx=3, ny=2,
                             neumann=[{"boundary": "top", "type": "pressure", "value": 0.7},
                                      {"boundary": "right", "type": "traction", "value": [0.3, -0.2]}],
                             body_force=["0.1*x", "-1"])]}
    pr = problem_from_dict(case)
    _distort(pr.bodies[0].mesh, 0.05)
    system = System(pr)
    rng = np.random.default_rng(1)
    s = system.solids[0]
    s.Un = 0.05 * rng.standard_normal(s.U.shape)
    s.Vn = 0.1 * rng.standard_normal(s.U.shape)
    ctx = StepContext(0.0, 0.1, 0.1, theta, False)  # θ = 0.5 is below the case files' range but a valid step
    system.begin_step(ctx)
    x0 = 0.1 * rng.standard_normal(system.layout.n_dofs)
    check_jacobian(system, ctx, x0, label=f"{law} θ={theta}")


@pytest.mark.parametrize("law", ["neo_hooke", "svk"])
def test_manufactured_solution_rates(law):
    """Large-deformation MMS: displacement L2 rate ≈ 2, H1 rate ≈ 1."""
    u = (0.1 * sp.sin(sp.pi * x) * sp.sin(sp.pi * y) + 0.05 * x * y, 0.08 * sp.cos(sp.pi * x / 2) * sp.sin(sp.pi * y))
    ms = solid_neo_hooke(u, 10.0, 0.3, law)
    errs = []
    hs = []
    for n in (4, 8, 16, 32):
        case = {"name": "mms", "time": {"type": "static", "t_end": 1.0, "dt": 1.0},
                "solver": {"tol_residual": 1e-11, "tol_increment": 1e-11},
                "bodies": [_body(law, nx=n, ny=n, body_force=ms["b_str"],
                                 dirichlet=[{"boundary": "all", "value": ms["u_str"]}])]}
        pr = problem_from_dict(case)
        _distort(pr.bodies[0].mesh, 0.15 / n, seed=n)
        sim = Simulation(pr)
        sim.run()
        errs.append(solid_errors(sim.system.solids[0], ms["u"], ms["grad"], n=4))
        hs.append(1.0 / n)
    r_l2 = rates(hs, [e["u_l2"] for e in errs])
    r_h1 = rates(hs, [e["u_h1"] for e in errs])
    assert r_l2[-1] > 1.9 and r_l2[-2] > 1.85, r_l2
    assert r_h1[-1] > 0.95 and r_h1[-2] > 0.9, r_h1


def test_newton_converges_quadratically_on_a_nonlinear_step():
    """Pure Newton (no damping) on a large-strain step: residual-ratio order ≥ 1.8."""
    case = {"name": "newton", "time": {"type": "static", "t_end": 1.0, "dt": 1.0},
            "solver": {"damping": False, "tol_residual": 1e-13, "tol_increment": 1e-14, "max_iterations": 20},
            "bodies": [_body("neo_hooke", nx=6, ny=6,
                             dirichlet=[{"boundary": "bottom", "value": [0.0, 0.0]},
                                        {"boundary": "top", "value": ["0.3", "-0.25"]}])]}
    pr = problem_from_dict(case)
    system = System(pr)
    ctx = StepContext(0.0, 1.0, 1.0, 1.0, True)
    system.begin_step(ctx)
    rep = solve_nonlinear(system, ctx, pr.solver, make_linear_solver("auto"))
    assert rep.converged
    r = np.array(rep.residuals)
    r = r[r > 1e-11 * r[0]]  # above round-off
    assert len(r) >= 4
    order = np.log(r[2:] / r[1:-1]) / np.log(r[1:-1] / r[:-2])
    assert order[-1] >= 1.8, (r, order)
