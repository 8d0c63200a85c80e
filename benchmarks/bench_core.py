"""Per-phase timings of the foundation: assembly, PARDISO analysis / factorisation / solve.

Fluid: one Newton system of the lid-driven cavity (steady Navier-Stokes, Q1/Q1 + CIP) at
about 10k, 40k and 120k unknowns. Solid: the Turek-Hron bar (St. Venant-Kirchhoff).

Usage:  python benchmarks/bench_core.py [--repeat 3]
Prints the median of the repeats for every phase.
"""

from __future__ import annotations

import argparse
import os
import platform
import time

import numpy as np

from fsci.cases import get_case
from fsci.config import apply_override, problem_from_dict
from fsci.fields import StepContext
from fsci.solver.linear import PardisoSolver, SuperLUSolver
from fsci.system import System


def _median(f, repeat):
    ts = []
    out = None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = f()
        ts.append(time.perf_counter() - t0)
    return float(np.median(ts)), out


def bench_system(label, case, overrides, static, repeat, superlu):
    for o in overrides:
        apply_override(case, o)
    system = System(problem_from_dict(case))
    ctx = StepContext(0.0, 1.0, 1.0, 1.0, static)
    system.begin_step(ctx)
    if system.fluid is not None:  # a non-trivial convective state
        f = system.fluid
        X = f.grid.nodes
        f.V[:, 0] = np.sin(np.pi * X[:, 0]) * np.cos(np.pi * X[:, 1])
        f.V[:, 1] = -np.cos(np.pi * X[:, 0]) * np.sin(np.pi * X[:, 1])
        f.Vbar = f.V.copy()
    t_pat, _ = _median(lambda: system.patterns.get(system.layout, system.blocks()).__class__(system.layout, system.blocks()), 1)
    t_asm, asm = _median(lambda: system.assemble(ctx, want_matrix=True), repeat)
    A = asm.matrix()
    b = -asm.rhs
    ps = PardisoSolver()
    ps.solve(A, b, asm.pattern.key)  # analysis + factorisation + solve once
    ps.timings = {k: 0.0 for k in ps.timings}
    ps.counts = {k: 0 for k in ps.counts}
    for _ in range(repeat):
        ps._key = None
        ps.solve(A, b, asm.pattern.key)
    an = ps.timings["analysis"] / repeat
    fa = ps.timings["factorization"] / repeat
    so = ps.timings["solve"] / repeat
    n = A.shape[0]
    row = f"{label:<28} {n:>8d} {A.nnz / n:6.1f} {t_pat:8.3f} {t_asm:8.3f} {an:8.3f} {fa:8.3f} {so:8.3f} {t_asm / fa:7.1%}"
    if superlu:
        sl = SuperLUSolver()
        sl.solve(A, b)
        row += f" {sl.timings['factorization']:8.3f}"
    print(row, flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--superlu", action="store_true", help="also time the SuperLU fallback")
    args = ap.parse_args()
    print(f"# machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, python {platform.python_version()}")
    print(f"{'problem':<28} {'unknowns':>8} {'nnz/row':>6} {'pattern':>8} {'assembly':>8} {'analysis':>8} "
          f"{'factor':>8} {'solve':>8} {'asm/fac':>7}" + (f" {'superlu':>8}" if args.superlu else ""))
    for n in (58, 115, 200):
        bench_system(f"cavity fluid n={n}", get_case("cavity"), [f"n={n}"], True, args.repeat, args.superlu)
    bench_system("turek-hron bar 640x32", get_case("turek-hron-csm1"), ["nx=640", "ny=32"], True, args.repeat,
                 args.superlu)


if __name__ == "__main__":
    main()
