"""Mesh convergence of Turek-Hron FSI1 with cylinder and bar embedded (docs/validation.md).

Usage:  python benchmarks/convergence_fsi1.py [--m 4 6 8 12 16] [--ny 16] [--shift 0.37] [--moments]

``--shift s`` moves the uniform band of the background grid (and so every grid line near
cylinder and bar) by ``s·h`` in x and y: the bar's surfaces and tip then cut cells instead
of lying on grid lines, which measures the sensitivity to the cut position. ``--moments``
also prints the moment of the fluid traction on the bar about the clamp (0.25, 0.2), split
into its top, bottom and tip faces: the bending that gives uy(A).
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from fsci.cases import get_case
from fsci.config import apply_override, problem_from_dict
from fsci.simulation import Simulation


def bar_moments(sim: Simulation) -> str:
    """Moment of the traction on the bar about the clamp centre, by face (top, bottom, tip)."""
    term = next(t for t in sim.system.extra_terms if hasattr(t, "traction_samples"))
    x, w, t, body = term.traction_samples()
    bar = body == 1
    x, w, t = x[bar], w[bar], t[bar]
    m = w * ((x[..., 0] - 0.25) * t[..., 1] - (x[..., 1] - 0.2) * t[..., 0])
    d = x[:, -1] - x[:, 0]
    tip = (np.abs(d[:, 1]) > np.abs(d[:, 0])) & (x[:, 0, 0] > 0.5)  # vertical pieces at the free end
    top = ~tip & (x[..., 1].mean(axis=1) > 0.2)
    parts = {"top": m[top].sum(), "bottom": m[~tip & ~top].sum(), "tip": m[tip].sum()}
    return "moment on bar: " + ", ".join(f"{k} {v:+.6f}" for k, v in parts.items()) + f", total {m.sum():+.6f}"


REF = {"ux_A": 2.270493e-5, "uy_A": 8.208773e-4, "drag": 14.29426, "lift": 0.7637460}

ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
ap.add_argument("--m", type=int, nargs="+", default=[4, 6, 8, 12, 16])
ap.add_argument("--ny", type=int, default=16)
ap.add_argument("--shift", type=float, default=0.0, help="band shift in cells (0 = bar surfaces on grid lines)")
ap.add_argument("--moments", action="store_true", help="print the bar's bending moment by face")
args = ap.parse_args()
print("| m (cells across bar) | h | unknowns | ux(A) | err | uy(A) | err | drag | err | lift | err | Newton | time [s] |")
print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
for m in args.m:
    c = get_case("turek-hron-fsi1")
    for o in (f"m={m}", f"ny={args.ny}", f"nx={args.ny * 35 // 2}"):
        apply_override(c, o)
    d = args.shift * 0.02 / m
    c["fluid"]["grid"]["x"]["breaks"][1:3] = [0.14 + d, 0.66 + d]
    c["fluid"]["grid"]["y"]["breaks"][1:3] = [0.14 + d, 0.26 + d]
    sim = Simulation(problem_from_dict(c))
    t0 = time.perf_counter()
    r = sim.run()
    cells = " | ".join(f"{r[k]:.6g} | {r[k] / REF[k] - 1:+.2%}" for k in REF)
    print(f"| {m}{f', shift {args.shift} h' if args.shift else ''} | {0.02 / m:.5f} | {sim.system.layout.n_dofs} | {cells} | {r['run']['newton_iterations']} | "
          f"{time.perf_counter() - t0:.0f} |", flush=True)
    if args.moments:
        print(bar_moments(sim), flush=True)
