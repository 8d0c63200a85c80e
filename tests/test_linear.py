"""Linear solvers: factor reuse through GMRES and the inexact-Newton forcing term."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from fsci.solver.linear import PardisoSolver, available_backends, right_preconditioned_gmres
from fsci.solver.newton import forcing_term


def test_forcing_term_follows_the_newton_rate():
    assert forcing_term([], 0.9) == 0.0  # first iteration of a step: exact
    assert forcing_term([1.0], 0.9) == 0.0  # no rate known yet
    assert forcing_term([1.0, 1e-3], 0.9) == pytest.approx(0.9e-6)  # quadratic phase: nearly exact
    assert forcing_term([1.0, 0.06], 0.9) == pytest.approx(0.9 * 0.06 ** 2)  # linear rate 0.06
    assert forcing_term([1.0, 5.0], 0.9) == 0.9  # residual grew: capped
    assert forcing_term([1.0, 0.06], 0.0) == 0.0  # switched off


def test_right_preconditioned_gmres_stops_on_the_true_residual():
    """The residual GMRES minimises with right preconditioning is the true one: the solve stops
    once |b − A x| ≤ tol |b| (checked here against the true residual, and against the direct
    solution), takes one step with the exact inverse as preconditioner, and gives up (None)
    when the steps allowed are too few."""
    A = _convection_diffusion(20, 0.5)
    b = np.random.default_rng(1).standard_normal(A.shape[0])
    exact = spla.spsolve(A.tocsc(), b)
    lu = spla.splu(_convection_diffusion(20, 0.45).tocsc())  # factors of a nearby matrix
    applied = []
    def precondition(r):
        applied.append(1)
        return lu.solve(r)
    for tol in (1e-3, 1e-10):
        applied.clear()
        x, steps = right_preconditioned_gmres(A, b, precondition, tol, 20)
        assert x is not None and 1 < steps < 20 and len(applied) == steps  # one application per step
        assert np.linalg.norm(A @ x - b) <= 1.01 * tol * np.linalg.norm(b)
        assert np.linalg.norm(x - exact) <= 1e3 * tol * np.linalg.norm(exact)
    x, steps = right_preconditioned_gmres(A, b, lambda r: spla.spsolve(A.tocsc(), r), 1e-12, 20)
    assert steps == 1 and np.linalg.norm(A @ x - b) <= 1e-12 * np.linalg.norm(b)
    assert right_preconditioned_gmres(A, b, precondition, 1e-10, 2) == (None, 2)


def _convection_diffusion(n: int, shift: float) -> sp.csr_matrix:
    """Upwinded convection-diffusion on an n × n grid (non-symmetric, n² unknowns)."""
    d = sp.diags([-1.0 - shift, 2.0 + shift, -1.0], [-1, 0, 1], shape=(n, n))
    eye = sp.identity(n)
    return (sp.kron(eye, d) + sp.kron(d, eye)).tocsr()


def _factorised(A: sp.csr_matrix, b: np.ndarray) -> PardisoSolver:
    solver = PardisoSolver()
    solver.solve(A, b, b"pattern")
    assert solver.counts["factorization"] == 1
    return solver


@pytest.mark.skipif("pardiso" not in available_backends(), reason="PARDISO not available")
@pytest.mark.parametrize("n", [30, 150])  # 900 unknowns (one MKL thread) and 22,500 (two)
@pytest.mark.parametrize("shift, rtol, reused, krylov", [
    (0.52, 0.0, True, 7),     # close: GMRES with the old factors reaches round-off (1e-10)
    (0.52, 1e-3, True, 3),    # ... and a forcing term of 1e-3 in fewer iterations
    (0.6, 0.0, False, None),  # farther: not to 1e-10 in 8 Krylov steps, factorised anew
    (0.6, 1e-3, True, 4),     # ... but to 1e-3 with the old factors
    (40.0, 1e-3, False, None),  # far: factorised anew even for 1e-3
])
def test_reused_factors_solve_to_the_requested_residual(n, shift, rtol, reused, krylov):
    """A matrix near the factorised one is solved by GMRES preconditioned with the old factors,
    to the relative residual asked for (the inexact-Newton forcing term; round-off when 0);
    otherwise it is factorised and solved to round-off. At every size (decision 37)."""
    b = np.random.default_rng(3).standard_normal(n * n)
    solver = _factorised(_convection_diffusion(n, 0.5), b)
    A1 = _convection_diffusion(n, shift)
    x = solver.solve(A1, b, b"pattern", rtol)
    residual = np.linalg.norm(A1 @ x - b) / np.linalg.norm(b)
    assert solver.counts["reused"] == int(reused)
    assert solver.counts["factorization"] == 1 + int(not reused)
    if reused:
        assert residual <= max(rtol, PardisoSolver.RTOL) and solver.counts["krylov"] <= krylov
    else:
        assert residual <= 1e-8


@pytest.mark.skipif("pardiso" not in available_backends(), reason="PARDISO not available")
def test_pardiso_threads_follow_mkl_num_threads(monkeypatch):
    """Large systems use every core unless ``MKL_NUM_THREADS`` (set by ``fsci sweep`` for runs
    side by side) asks for fewer."""
    import os

    solver = PardisoSolver()
    monkeypatch.delenv("MKL_NUM_THREADS", raising=False)
    assert solver.threads == (os.cpu_count() or 1)
    monkeypatch.setenv("MKL_NUM_THREADS", "1")
    assert solver.threads == 1


@pytest.mark.skipif("pardiso" not in available_backends(), reason="PARDISO not available")
def test_pardiso_orders_by_size(monkeypatch):
    """The analysis orders with minimum degree below ``LARGE`` unknowns and with METIS from
    there on; either ordering solves to round-off."""
    A = _convection_diffusion(40, 0.5)
    b = np.random.default_rng(5).standard_normal(A.shape[0])
    for large, expected in ((A.shape[0] + 1, 0), (A.shape[0], 2)):
        monkeypatch.setattr(PardisoSolver, "LARGE", large)
        solver = PardisoSolver()
        x = solver.solve(A, b, b"pattern")
        assert solver._ps.iparm[1] == expected and solver.counts["analysis"] == 1
        assert np.linalg.norm(A @ x - b) <= 1e-12 * np.linalg.norm(b)


@pytest.mark.parametrize("user", [None, "2"])
def test_numpy_blas_runs_on_one_thread_unless_the_user_says(user):
    """Importing fsci after numpy puts numpy's OpenBLAS on one thread (an idle second thread
    spins on the core PARDISO needs); an ``OPENBLAS_NUM_THREADS`` the user set stays."""
    import json
    import os
    import subprocess
    import sys

    import threadpoolctl
    env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_NUM_THREADS"}
    if user is not None:
        env["OPENBLAS_NUM_THREADS"] = user
    code = ("import json, numpy, threadpoolctl, fsci; print(json.dumps([p['num_threads'] for p in "
            "threadpoolctl.threadpool_info() if p['internal_api'] == 'openblas']))")
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True).stdout
    counts = json.loads(out)
    if not counts:
        pytest.skip(f"numpy is not linked to OpenBLAS here (threadpoolctl {threadpoolctl.__version__})")
    assert set(counts) == {1 if user is None else int(user)}
