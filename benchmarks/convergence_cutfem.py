"""Convergence studies of the unfitted fluid (docs/validation.md): manufactured solutions on
an embedded disk and the DFG 2D-1 benchmark.

Usage:  python benchmarks/convergence_cutfem.py [--dfg 10 20 40 80] [--mms 8 16 32 64 128]
                                                [--adjoint skew|symmetric]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import sympy as sp

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from mms import rates, x, y  # noqa: E402
from test_cutfem import _disk_mms  # noqa: E402

from fsci.cases import get_case  # noqa: E402
from fsci.config import apply_override, problem_from_dict  # noqa: E402
from fsci.simulation import Simulation  # noqa: E402

REF = {"cd": 5.57953523384, "cl": 0.010618948146, "dp": 0.11752016697}


def dfg(levels):
    print("| n (cells / D) | unknowns | c_D | err | c_L | err | Δp | err |")
    print("|---|---|---|---|---|---|---|---|")
    for n in levels:
        c = get_case("dfg-2d-1")
        apply_override(c, f"n={n}")
        sim = Simulation(problem_from_dict(c))
        r = sim.run()
        cells = [f"{r[k]:.6g} | {abs(r[k] / REF[k] - 1):.3%}" for k in ("cd", "cl", "dp")]
        print(f"| {n} | {sim.system.layout.n_dofs} | " + " | ".join(cells) + " |", flush=True)


def mms(levels, adjoint):
    fields = {
        "polynomial Stokes field (μ = 1)": ((20 * x * y ** 3, 5 * x ** 4 - 5 * y ** 4), 60 * x ** 2 * y - 20 * y ** 3, 1.0),
        "Taylor-Green field (μ = 0.1)": ((-sp.cos(2 * sp.pi * x) * sp.sin(2 * sp.pi * y),
                                          sp.sin(2 * sp.pi * x) * sp.cos(2 * sp.pi * y)),
                                         -sp.Rational(1, 4) * (sp.cos(4 * sp.pi * x) + sp.cos(4 * sp.pi * y)), 0.1),
    }
    for name, (v, p, mu) in fields.items():
        errs = [_disk_mms(v, p, mu, n, adjoint) for n in levels]
        hs = [1.0 / n for n in levels]
        print(f"\n{name}, {adjoint} adjoint\n")
        print("| n | ‖v−v_h‖_L2 | rate | ‖∇(v−v_h)‖ | rate | ‖p−p_h‖_L2 | rate |")
        print("|---|---|---|---|---|---|---|")
        r = {k: np.concatenate([[np.nan], rates(hs, [e[k] for e in errs])]) for k in ("v_l2", "v_h1", "p_l2")}
        for i, n in enumerate(levels):
            print(f"| {n} | " + " | ".join(f"{errs[i][k]:.3e} | {r[k][i]:.2f}" for k in ("v_l2", "v_h1", "p_l2")) + " |",
                  flush=True)


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--dfg", type=int, nargs="*", default=[10, 20, 40, 80])
    ap.add_argument("--mms", type=int, nargs="*", default=[8, 16, 32, 64, 128])
    ap.add_argument("--adjoint", choices=("skew", "symmetric"), default="skew", help="viscous adjoint of the Nitsche terms")
    a = ap.parse_args()
    if a.mms:
        mms(a.mms, a.adjoint)
    if a.dfg:
        dfg(a.dfg)
