"""Mesh convergence of Turek-Hron FSI1 with cylinder and bar embedded (docs/validation.md).

Usage:  python benchmarks/convergence_fsi1.py [--m 6 8 12 16] [--r 1] [--ny 16] [--shift 0 0.37] [--moments]
        [--set KEY=VALUE ...]

``--r`` is the case's refinement of the rows and columns at the bar's surfaces and tip
(1: the plain uniform band). ``--shift s`` moves the band of the background grid (and so
every grid line near cylinder and bar) by ``s·h`` in x and y (the case parameter ``shift``):
the bar's surfaces and tip then cut cells instead of lying on grid lines, which measures the
sensitivity to the cut position; several shifts print their mean and spread. ``--moments``
also prints the moment of the fluid traction on the bar about the clamp (0.25, 0.2), split
into its top, bottom and tip faces: the bending that gives uy(A).
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from fsci.cases import get_case
from fsci.config import apply_override, problem_from_dict
from fsci.errors import SolverError
from fsci.simulation import Simulation


def bar_moments(sim: Simulation) -> str:
    """Moment of the traction on the bar about the clamp centre, by face (top, bottom, tip)."""
    from fsci.coupling import traction as tk

    term = next(t for t in sim.system.extra_terms if hasattr(t, "samples"))
    out, body = term.samples()
    bar = out[body == term.names.index("bar")]
    x, y, w, tx, ty = (bar[..., k] for k in (tk.O_X, tk.O_Y, tk.O_W, tk.O_TX, tk.O_TY))
    m = w * ((x - 0.25) * ty - (y - 0.2) * tx)
    d = np.column_stack([x[:, -1] - x[:, 0], y[:, -1] - y[:, 0]])
    tip = (np.abs(d[:, 1]) > np.abs(d[:, 0])) & (x[:, 0] > 0.5)  # vertical pieces at the free end
    top = ~tip & (y.mean(axis=1) > 0.2)
    parts = {"top": m[top].sum(), "bottom": m[~tip & ~top].sum(), "tip": m[tip].sum()}
    return "moment on bar: " + ", ".join(f"{k} {v:+.6f}" for k, v in parts.items()) + f", total {m.sum():+.6f}"


REF = {"ux_A": 2.270493e-5, "uy_A": 8.208773e-4, "drag": 14.29426, "lift": 0.7637460}

ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
ap.add_argument("--m", type=int, nargs="+", default=[6, 8, 12, 16])
ap.add_argument("--r", type=int, default=None,
                help="refinement at the bar's surfaces and tip (1: plain band; default: the case's)")
ap.add_argument("--ny", type=int, default=16)
ap.add_argument("--shift", type=float, nargs="+", default=[0.0],
                help="band shifts in cells (0 = bar surfaces on grid lines)")
ap.add_argument("--moments", action="store_true", help="print the bar's bending moment by face")
ap.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                help="further case overrides (repeatable), e.g. time.dt=0.25")
args = ap.parse_args()
print("| m (cells across bar), r, shift | h | unknowns | ux(A) | err | uy(A) | err | drag | err | lift | err | Newton | time [s] |")
print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
for m in args.m:
    errors = []
    for shift in args.shift:
        c = get_case("turek-hron-fsi1")
        for o in (f"m={m}", f"shift={shift}", f"ny={args.ny}", f"nx={args.ny * 35 // 2}", *args.overrides):
            apply_override(c, o)
        if args.r is not None:
            apply_override(c, f"r={args.r}")
        r = c["parameters"]["r"]
        sim = Simulation(problem_from_dict(c))
        t0 = time.perf_counter()
        try:
            res = sim.run()
        except SolverError as exc:  # one position that does not converge must not end the study
            print(f"| {m}, {r}, {shift:g} h | failed: {exc} |", flush=True)
            continue
        errors.append([res[k] / REF[k] - 1 for k in REF])
        cells = " | ".join(f"{res[k]:.6g} | {e:+.2%}" for k, e in zip(REF, errors[-1]))
        print(f"| {m}, {r}, {shift:g} h | {0.02 / m:.5f} | {sim.system.layout.n_dofs} | {cells} | "
              f"{res['run']['newton_iterations']} | {time.perf_counter() - t0:.0f} |", flush=True)
        if args.moments:
            print(bar_moments(sim), flush=True)
    if len(errors) > 1:
        e = np.array(errors)
        stats = " | ".join(f"mean {a:+.2%} | spread {b - c:.2%}" for a, b, c in zip(e.mean(0), e.max(0), e.min(0)))
        print(f"| {m}, {r}, {len(errors)} shifts | | | {stats} | | |", flush=True)
