"""The per-block Jacobian check can fail: a deliberately broken block of the assembled matrix is
reported by name, also where the former check (one error scaled by the global max |J|) passes.

The break is applied to the matrix ``System.assemble`` returns, so it does not depend on how the
coupling terms are implemented; the residual is left intact, as for a wrong linearisation.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager

import numpy as np
import pytest
import scipy.sparse as sp

from fsci.config import problem_from_dict
from fsci.fields import StepContext
from fsci.system import System

from cutcases import fluid_box, static_case
from helpers import TOL, check_jacobian, coupling_terms, dof_fields, jacobian_blocks

# Material and step sets of the elastic blob in a channel: "moderate" as in the coupling test
# of test_cutfem.py; "stiff" with Turek-Hron FSI1 data (E = 1.4e6, rho = 1000, mu = 1), where
# the solid rows exceed the pressure blocks by seven orders of magnitude.
REGIMES = {"moderate": dict(E=10.0, rho_s=1.0, rho=1.0, mu=0.3, dt=0.1),
           "stiff": dict(E=1.4e6, rho_s=1e3, rho=1e3, mu=1.0, dt=0.01)}
# The residual is quadratic in v and linear in p (stabilisation velocities frozen), so central
# differences are exact up to round-off in those columns; a large step there keeps the round-off
# of the stiff solid rows (eps |R| / h) below the small u-p block.
STEPS = {"v": 1e-3, "p": 1e-3}


def _blob(E: float, rho_s: float, rho: float, mu: float, dt: float, theta: float = 0.6) -> tuple:
    """Elastic blob cut into a 5 x 5 grid of the unit box, random state and old level, step begun."""
    body = {"name": "blob", "material": {"law": "neo_hooke", "E": E, "nu": 0.4, "rho": rho_s},
            "mesh": {"type": "rectangle", "x0": 0.33, "x1": 0.71, "y0": 0.37, "y1": 0.62, "nx": 3, "ny": 2}}
    # the cut stays frozen in these checks: the Jacobian without the cut's motion
    fluid = fluid_box(5, mu=mu, rho=rho, interface={"shape_derivative": False},
                      dirichlet=[{"boundary": "left", "value": [1.0, 0.0]}])
    case = static_case([body], fluid)
    case["time"] = {"type": "transient", "theta": theta, "t_end": dt, "dt": dt}
    system = System(problem_from_dict(case))
    ctx = StepContext(0.0, dt, dt, theta, False)
    rng = np.random.default_rng(7)
    s, f = system.solids[0], system.fluid
    s.Un = 0.01 * rng.standard_normal(s.U.shape)
    s.Vn = 0.1 * rng.standard_normal(s.U.shape)
    f.Vn = rng.standard_normal(f.V.shape)
    system.begin_step(ctx)
    x0 = 0.01 * rng.standard_normal(system.layout.n_dofs)
    x0[system.field_dofs["velocity"]] += rng.standard_normal(len(system.field_dofs["velocity"]))
    return system, ctx, x0


@contextmanager
def broken_matrix(system, change: Callable[[sp.csr_matrix], sp.csr_matrix]) -> Iterator[None]:
    """Within the block, the matrix of every ``system.assemble`` is ``change(J)``; the residual
    is untouched."""
    assemble = system.assemble

    def wrapped(*args, **kwargs):
        asm = assemble(*args, **kwargs)
        matrix = asm.matrix
        asm.matrix = lambda: change(matrix())
        return asm

    system.assemble = wrapped
    try:
        yield
    finally:
        del system.assemble


def scale_block(system, rows: str, cols: str, factor: float) -> Callable[[sp.csr_matrix], sp.csr_matrix]:
    """Matrix change: the entries of block (``rows``, ``cols``) times ``factor``."""
    fields = dof_fields(system)

    def change(J: sp.csr_matrix) -> sp.csr_matrix:
        J = J.tocsr(copy=True)
        r = np.repeat(np.arange(J.shape[0]), np.diff(J.indptr))
        J.data[np.isin(r, fields[rows]) & np.isin(J.indices, fields[cols])] *= factor
        return J

    return change


def add_block(system, rows: str, cols: str, value: float) -> Callable[[sp.csr_matrix], sp.csr_matrix]:
    """Matrix change: ``value`` added to every entry of block (``rows``, ``cols``)."""
    fields = dof_fields(system)

    def change(J: sp.csr_matrix) -> sp.csr_matrix:
        r, c = np.meshgrid(fields[rows], fields[cols], indexing="ij")
        return (J + sp.csr_matrix((np.full(r.size, value), (r.ravel(), c.ravel())), shape=J.shape)).tocsr()

    return change


@pytest.mark.parametrize("regime, rows, cols, factor", [
    ("moderate", "u:blob", "p", 1.0002),  # pressure load on the body 0.02 % off
    ("moderate", "v", "p", 1.0002),       # pressure gradient 0.02 % off
    ("moderate", "p", "v", 1.0002),       # divergence 0.02 % off
    ("stiff", "u:blob", "p", -1.0),      # pressure load on the body with the wrong sign
    ("stiff", "v", "p", -1.0),           # pressure gradient with the wrong sign
])
def test_a_broken_block_is_reported_where_global_scaling_passes(regime, rows, cols, factor):
    """The intact Jacobian passes; with one block scaled the check fails naming that block,
    while the same differences scaled by the global max |J| stay below the tolerance."""
    system, ctx, x0 = _blob(**REGIMES[regime])
    intact = jacobian_blocks(system, ctx, x0, h_field=STEPS, label=f"{regime} intact")
    print(intact.table())
    assert intact.worst()[1] < TOL, intact.table()
    with broken_matrix(system, scale_block(system, rows, cols, factor)):
        broken = jacobian_blocks(system, ctx, x0, h_field=STEPS, label=f"{regime} {rows}-{cols} x {factor}")
        print(broken.table())
        with pytest.raises(AssertionError, match=f"Jacobian block {rows}-{cols} "):
            check_jacobian(system, ctx, x0, h_field=STEPS)
    assert broken.worst()[0] == (rows, cols)
    assert broken.worst()[1] > 100 * TOL
    assert broken.global_error < TOL  # the former check would have passed


def test_a_dropped_coupling_block_fails():
    """A coupling term whose Jacobian lacks its solid-fluid block: analytic zero, FD not."""
    system, ctx, x0 = _blob(**REGIMES["moderate"])
    term = coupling_terms(system)
    with broken_matrix(system, scale_block(system, "u:blob", "v", 0.0)):
        res = jacobian_blocks(system, ctx, x0, terms=term)
    assert res.worst() == (("u:blob", "v"), 1.0)


def test_a_spurious_block_fails():
    """Entries in a block whose residual does not depend on the columns: analytic not zero,
    FD zero (the fluid term alone has no solid columns)."""
    system, ctx, x0 = _blob(**REGIMES["moderate"])
    with broken_matrix(system, add_block(system, "v", "u:blob", 1e-12)):
        res = jacobian_blocks(system, ctx, x0, terms=["fluid"])
    assert res.worst() == (("v", "u:blob"), 1.0)
    assert res.errors[("u:blob", "u:blob")] == 0.0  # both exactly zero: passes
