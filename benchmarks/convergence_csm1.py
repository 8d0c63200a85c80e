"""Mesh convergence of Turek-Hron CSM1 (docs/validation.md): ux(A), uy(A) and their errors
against the reference values for a sequence of meshes, as a Markdown table."""

from __future__ import annotations

import argparse

from fsci.cases import get_case
from fsci.config import apply_override, problem_from_dict
from fsci.simulation import Simulation

REF = (-7.18767e-3, -66.1023e-3)
MESHES = ("80x4", "160x8", "320x16", "640x32", "1280x64")


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--meshes", nargs="+", default=list(MESHES), metavar="NXxNY",
                    help="bar meshes, cells along x 'x' across (default: %(default)s)")
    args = ap.parse_args(argv)
    print("| mesh (nx × ny) | unknowns | ux(A) [1e-3] | err | uy(A) [1e-3] | err |")
    print("|---|---|---|---|---|---|")
    for mesh in args.meshes:
        nx, ny = (int(v) for v in mesh.split("x"))
        c = get_case("turek-hron-csm1")
        apply_override(c, f"nx={nx}")
        apply_override(c, f"ny={ny}")
        sim = Simulation(problem_from_dict(c))
        r = sim.run()
        print(f"| {nx} × {ny} | {sim.system.layout.n_dofs} | {1e3 * r['ux_A']:.5f} | {abs(r['ux_A'] / REF[0] - 1):.2%} | "
              f"{1e3 * r['uy_A']:.4f} | {abs(r['uy_A'] / REF[1] - 1):.2%} |", flush=True)


if __name__ == "__main__":
    main()
