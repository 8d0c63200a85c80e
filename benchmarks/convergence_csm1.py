"""Mesh convergence of Turek-Hron CSM1 (docs/validation.md).  Usage: python benchmarks/convergence_csm1.py"""

from fsci.cases import get_case
from fsci.config import apply_override, problem_from_dict
from fsci.simulation import Simulation

REF = (-7.18767e-3, -66.1023e-3)
print("| mesh (nx × ny) | unknowns | ux(A) [1e-3] | err | uy(A) [1e-3] | err |")
print("|---|---|---|---|---|---|")
for nx, ny in ((80, 4), (160, 8), (320, 16), (640, 32), (1280, 64)):
    c = get_case("turek-hron-csm1")
    apply_override(c, f"nx={nx}")
    apply_override(c, f"ny={ny}")
    sim = Simulation(problem_from_dict(c))
    r = sim.run()
    print(f"| {nx} × {ny} | {sim.system.layout.n_dofs} | {1e3 * r['ux_A']:.5f} | {abs(r['ux_A'] / REF[0] - 1):.2%} | "
          f"{1e3 * r['uy_A']:.4f} | {abs(r['uy_A'] / REF[1] - 1):.2%} |", flush=True)
