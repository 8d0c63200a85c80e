"""What the CIP face stabilisation costs in the linear solver (issue 12, item 6).

One Newton matrix of dfg-2d-1 (cylinder cut from the grid, Q1/Q1 + CIP (25) on every interior
face + ghost penalty (26) near the cylinder) is compared with the same matrix on the pattern of
a stabilisation that keeps face terms only near the interface (ghost penalty faces) — the
9-node Q1 stencil in the bulk, what any cell-based bulk stabilisation (PSPG/SUPG-like) would
give. The bulk pressure block of that matrix gets a cell-local pressure mass ``eps h² (p, q)``
(a stand-in for such a stabilisation, same pattern) so that it is non-singular. Printed per
pattern and PARDISO ordering (``iparm[1]``: 0 minimum degree, 2 METIS, 3 parallel METIS):
unknowns, nonzeros per row, nonzeros of the factors, analysis / factorisation / solve time
(median of ``--repeat``).

    python benchmarks/bench_stencil.py                 # n = 40 (94k unknowns)
    python benchmarks/bench_stencil.py --n 20 40 --orderings 2 0 3
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np
import scipy.sparse as sp  # noqa: F401

from bench_cutfem import dfg_system  # the same DFG state as the cut/assembly timing

from fsci.fields import StepContext
from fsci.solver.linear import PardisoSolver
from fsci.system import System


def _matrix(system: System, ctx: StepContext, bulk_faces: bool) -> sp.csr_matrix:
    f = system.fluid
    faces, weight, face_nodes = f.faces, f.ghost_weight, f.face_nodes
    try:
        if not bulk_faces:
            ghost = weight > 0.0
            f.faces, f.ghost_weight, f.face_nodes = faces[ghost], weight[ghost], face_nodes[ghost]
        asm = system.assemble(ctx)
    finally:
        f.faces, f.ghost_weight, f.face_nodes = faces, weight, face_nodes
    A = asm.matrix().copy()  # fsci's pattern, structural zeros included (as in a run)
    if not bulk_faces:  # pressure mass eps h^2 on the diagonal (cell-local, keeps the pattern)
        h = float(f.grid.cell_size.min())
        p = system.field_dofs["pressure"]
        A.data[asm.pattern.diagonal_positions()[p]] += 1e-2 * h * h
    return A


def _time(A: sp.csr_matrix, ordering: int, repeat: int) -> dict[str, float]:
    ps = PardisoSolver(max_krylov=0)
    orig = ps._set_mode

    def set_mode(robust: bool) -> None:  # the solver's settings with this ordering, factor size reported
        orig(robust)
        ps._ps.iparm[1] = ordering
        ps._ps.iparm[17] = -1

    ps._set_mode = set_mode
    set_mode(False)
    b = np.ones(A.shape[0])
    an, fa, so, nnz_lu = [], [], [], 0
    for _ in range(repeat):
        ps._key = None
        ps.timings = {k: 0.0 for k in ps.timings}
        ps.solve(A, b, b"pattern")
        an.append(ps.timings["analysis"])
        fa.append(ps.timings["factorization"])
        so.append(ps.timings["solve"])
        nnz_lu = int(ps._ps.iparm[17])
    return {"analysis": float(np.median(an)), "factor": float(np.median(fa)), "solve": float(np.median(so)),
            "nnz_lu": nnz_lu}


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, nargs="+", default=[40], help="dfg-2d-1 resolutions")
    ap.add_argument("--orderings", type=int, nargs="+", default=[2, 0, 3], help="PARDISO iparm[1] values")
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args(argv)
    print(f"# {os.cpu_count()} cores; PARDISO threads: {os.cpu_count()} at >= {PardisoSolver.SMALL} unknowns")
    print("| n | pattern | ordering | unknowns | nnz/row | nnz(L+U) [M] | analysis [s] | factor [s] | solve [s] |")
    print("|---|---|---|---|---|---|---|---|---|")
    for n in args.n:
        system, ctx = dfg_system(n)
        for label, bulk in (("CIP on all faces (default)", True), ("face terms near Γ only (9-node bulk)", False)):
            A = _matrix(system, ctx, bulk)
            for o in args.orderings:
                r = _time(A, o, args.repeat)
                print(f"| {n} | {label} | {o} | {A.shape[0]} | {A.nnz / A.shape[0]:.1f} | {r['nnz_lu'] / 1e6:.2f} "
                      f"| {r['analysis']:.3f} | {r['factor']:.3f} | {r['solve']:.3f} |", flush=True)


if __name__ == "__main__":
    main()
