"""Per-phase timings of the CutFEM fluid on dfg-2d-1 (cylinder embedded): cut, assembly
(fluid cells + faces + Nitsche interface), PARDISO analysis / factorisation / solve.

Usage:  python benchmarks/bench_cutfem.py [--levels 20 40 80] [--repeat 3]
"""

from __future__ import annotations

import argparse
import os
import platform
import time

import numpy as np

from fsci.cases import get_case
from fsci.config import apply_override, problem_from_dict
from fsci.cut.state import CutState
from fsci.fields import StepContext
from fsci.solver.linear import PardisoSolver
from fsci.system import System


def dfg_system(n: int) -> tuple[System, StepContext]:
    """DFG 2D-1 at ``n`` cells per diameter, its first static step begun, with the inflow
    profile as velocity everywhere (a representative state for timing one Newton iteration)."""
    case = get_case("dfg-2d-1")
    apply_override(case, f"n={n}")
    system = System(problem_from_dict(case))
    ctx = StepContext(0.0, 1.0, 1.0, 1.0, True)
    system.begin_step(ctx)
    f = system.fluid
    X = f.grid.nodes
    f.V[:, 0] = 1.2 * X[:, 1] * (0.41 - X[:, 1]) / 0.41 ** 2
    f.Vbar = f.V.copy()
    return system, ctx


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--levels", type=int, nargs="+", default=[20, 40, 80])
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    print(f"# machine: {platform.machine()}, {os.cpu_count()} cores, python {platform.python_version()}")
    print(f"{'n':>4} {'cells':>8} {'unknowns':>9} {'cut cells':>9} {'cut':>7} {'assembly':>8} {'analysis':>8} "
          f"{'factor':>7} {'solve':>6} {'(cut+asm)/fac':>13}")
    for n in args.levels:
        system, ctx = dfg_system(n)
        f = system.fluid
        outl = system.outlines()
        t_cut = []
        for _ in range(args.repeat):
            t0 = time.perf_counter()
            CutState(f.grid, outl, f.spec.interface.island_factor)
            t_cut.append(time.perf_counter() - t0)
        system.assemble(ctx)  # pattern + compile
        t_asm = []
        for _ in range(args.repeat):
            t0 = time.perf_counter()
            asm = system.assemble(ctx)
            t_asm.append(time.perf_counter() - t0)
        A = asm.matrix()
        ps = PardisoSolver()
        for _ in range(args.repeat):
            ps._key = None
            ps.solve(A, -asm.rhs, asm.pattern.key)
        r = args.repeat
        an, fa, so = (ps.timings[k] / r for k in ("analysis", "factorization", "solve"))
        cut, am = float(np.median(t_cut)), float(np.median(t_asm))
        print(f"{n:>4} {f.grid.n_cells:>8} {A.shape[0]:>9} {len(system.cut.cut_cells):>9} {cut:7.3f} {am:8.3f} "
              f"{an:8.3f} {fa:7.3f} {so:6.3f} {(cut + am) / fa:13.1%}", flush=True)


if __name__ == "__main__":
    main()
