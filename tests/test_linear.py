"""Linear solvers: factor reuse through GMRES and the inexact-Newton forcing term."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from fsci.solver.linear import PardisoSolver, available_backends
from fsci.solver.newton import forcing_term


def test_forcing_term_follows_the_newton_rate():
    assert forcing_term([], 0.9) == 0.0  # first iteration of a step: exact
    assert forcing_term([1.0], 0.9) == 0.0  # no rate known yet
    assert forcing_term([1.0, 1e-3], 0.9) == pytest.approx(0.9e-6)  # quadratic phase: nearly exact
    assert forcing_term([1.0, 0.06], 0.9) == pytest.approx(0.9 * 0.06 ** 2)  # linear rate 0.06
    assert forcing_term([1.0, 5.0], 0.9) == 0.9  # residual grew: capped
    assert forcing_term([1.0, 0.06], 0.0) == 0.0  # switched off


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
@pytest.mark.parametrize("shift, rtol, reused, krylov", [
    (0.52, 0.0, True, 7),     # close: GMRES with the old factors reaches round-off (1e-10)
    (0.52, 1e-3, True, 3),    # ... and a forcing term of 1e-3 in fewer iterations
    (0.6, 0.0, False, None),  # farther: not to 1e-10 in 8 Krylov steps, factorised anew
    (0.6, 1e-3, True, 4),     # ... but to 1e-3 with the old factors
    (40.0, 1e-3, False, None),  # far: factorised anew even for 1e-3
])
def test_reused_factors_solve_to_the_requested_residual(shift, rtol, reused, krylov):
    """A matrix near the factorised one is solved by GMRES preconditioned with the old factors,
    to the relative residual asked for (the inexact-Newton forcing term; round-off when 0);
    otherwise it is factorised and solved to round-off."""
    n = 150  # 22,500 unknowns: above PardisoSolver.SMALL, where factors are reused
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
